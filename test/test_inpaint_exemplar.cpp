// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Exemplar inpainting: known backgrounds (PSNR over the hole), structure continuation (the
// thesis's three disks, IoU), parameters, determinism.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/inpaint.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

/** PSNR (dB) of @p a against @p b over the non-zero pixels of @p mask (99 if equal). */
double psnrIn(const Mat& a, const Mat& b, const Mat& mask) {
    double sse = 0;
    int n = 0;
    for (int y = 0; y < a.rows; ++y)
        for (int x = 0; x < a.cols; ++x) {
            if (!mask.at<uchar>(y, x)) continue;
            const Vec3b p = a.at<Vec3b>(y, x), q = b.at<Vec3b>(y, x);
            for (int c = 0; c < 3; ++c)
                sse += double(p[c] - q[c]) * (p[c] - q[c]);
            n += 3;
        }
    const double mse = sse / std::max(1, n);
    return mse < 1e-12 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse);
}

Mat gradientImage(Size s) {
    Mat m(s, CV_8UC3);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            m.at<Vec3b>(y, x) =
                Vec3b(saturate_cast<uchar>(40 + 0.8 * x), saturate_cast<uchar>(60 + 0.9 * y),
                      saturate_cast<uchar>(120 + 0.4 * (x + y)));
    return m;
}

Mat stripesImage(Size s) {
    Mat m(s, CV_8UC3);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            m.at<Vec3b>(y, x) = ((x / 4) % 2) ? Vec3b(200, 60, 30) : Vec3b(30, 160, 220);
    return m;
}

Mat checkerImage(Size s) {
    Mat m(s, CV_8UC3);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            m.at<Vec3b>(y, x) = ((x / 8 + y / 8) % 2) ? Vec3b(230, 230, 230) : Vec3b(20, 40, 60);
    return m;
}

/** A woven-looking texture: a 23×17 tile of smoothed colour noise repeated. */
Mat textureImage(Size s) {
    RNG rng(7);
    Mat tile(17, 23, CV_32FC3);
    rng.fill(tile, RNG::UNIFORM, 0, 255);
    GaussianBlur(tile, tile, Size(0, 0), 1.2, 1.2, BORDER_REFLECT);
    normalize(tile, tile, 20, 235, NORM_MINMAX);
    Mat m(s, CV_8UC3);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const Vec3f v = tile.at<Vec3f>(y % 17, x % 23);
            m.at<Vec3b>(y, x) = Vec3b(saturate_cast<uchar>(v[0]), saturate_cast<uchar>(v[1]),
                                      saturate_cast<uchar>(v[2]));
        }
    return m;
}

Mat diskMask(Size s, double frac) {
    Mat m = Mat::zeros(s, CV_8U);
    circle(m, Point(s.width / 2, s.height / 2), cvRound(s.height * frac), Scalar(255), FILLED);
    return m;
}

Mat fill(const Mat& img, const Mat& mask, const ExemplarInpainter::Params& p) {
    Mat in = img.clone(), out;
    in.setTo(Scalar(0, 255, 0), mask);  // what was there must not matter
    ExemplarInpainter::create(p)->inpaint(in, mask, out);
    return out;
}

Mat fill(const Mat& img, const Mat& mask, int method, int patch = 9) {
    ExemplarInpainter::Params p;
    p.method = method;
    p.patch_size = patch;
    return fill(img, mask, p);
}

struct Background {
    const char* name;
    Mat (*make)(Size);
    int patch;
    bool periodic;  // the hole's content occurs exactly elsewhere in the image
};

// Oracles: a periodic background is reproduced exactly (every pixel of the hole equals the
// truth); a smooth gradient cannot be copied exactly (a patch from elsewhere carries another
// level), so there the fill must beat the best single copy of the truth from one hole
// diameter away (the nearest whole source region). The mean-of-rim fill is printed as the
// naive baseline (on a smooth gradient it is about as good as exemplar filling).
const Background kBackgrounds[] = {
    {"gradient", gradientImage, 9, false},
    {"stripes", stripesImage, 9, true},
    {"checkerboard", checkerImage, 13, true},  // patches must span more than one 8-px square
    {"texture", textureImage, 9, true},
};

/** The naive fill: every hole pixel gets the mean colour of the known pixels bordering the
hole. */
Mat meanRimFill(const Mat& img, const Mat& mask) {
    Mat grown, rim;
    dilate(mask, grown, Mat());
    rim = grown & ~mask;
    Mat out = img.clone();
    out.setTo(mean(img, rim), mask);
    return out;
}

class InpaintBackground : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(InpaintBackground, FillsKnownBackground) {
    const int method = std::get<0>(GetParam());
    const Background& bg = kBackgrounds[std::get<1>(GetParam())];
    // The vp-tree is the slowest search: it gets the smallest images.
    const Size size = method == PATCH_SEARCH_VPTREE ? Size(96, 72) : Size(128, 96);
    const Mat img = bg.make(size);
    const Mat mask = diskMask(size, 0.2);
    const Mat out = fill(img, mask, method, bg.patch);
    ASSERT_EQ(out.size(), img.size());
    ASSERT_EQ(out.type(), img.type());
    EXPECT_EQ(norm(out, img, NORM_INF, ~mask), 0) << "pixels outside the hole changed";
    const double psnr = psnrIn(out, img, mask);
    const double psnr_naive = psnrIn(meanRimFill(img, mask), img, mask);
    RecordProperty("psnr", std::to_string(psnr));
    std::printf("[ measured ] %s, %s: PSNR in the hole %.2f dB (mean-of-rim fill %.2f dB)\n",
                bg.name, toString((PatchSearchMethod)method).c_str(), psnr, psnr_naive);
    if (bg.periodic)
        EXPECT_EQ(norm(out, img, NORM_INF, mask), 0)
            << bg.name << " with " << toString((PatchSearchMethod)method);
    else {
        // the best a single copy can do: the hole filled from the truth one hole diameter
        // away (the nearest whole source patch), along the better axis
        const Rect hole = boundingRect(mask);
        double best_copy = 0;
        for (const Point2d shift : {Point2d(hole.width, 0), Point2d(-hole.width, 0),
                                    Point2d(0, hole.height), Point2d(0, -hole.height)}) {
            Mat copy;
            warpAffine(img, copy, Matx23d(1, 0, shift.x, 0, 1, shift.y), img.size(), INTER_NEAREST,
                       BORDER_REPLICATE);
            best_copy = std::max(best_copy, psnrIn(copy, img, mask));
        }
        std::printf("[ measured ] %s, %s: a copy from one hole diameter away %.2f dB\n", bg.name,
                    toString((PatchSearchMethod)method).c_str(), best_copy);
        EXPECT_GT(psnr, best_copy) << bg.name << " with " << toString((PatchSearchMethod)method);
    }
}

INSTANTIATE_TEST_SUITE_P(AllMethods, InpaintBackground,
                         ::testing::Combine(::testing::Values(PATCH_SEARCH_PATCHMATCH,
                                                              PATCH_SEARCH_VPTREE,
                                                              PATCH_SEARCH_LOCAL),
                                            ::testing::Range(0, 4)),
                         [](const auto& info) {
                             return toString((PatchSearchMethod)std::get<0>(info.param)) + "_" +
                                    kBackgrounds[std::get<1>(info.param)].name;
                         });

/** The three-disks case of the thesis (its Fig. 4.7): three dark disks on a light ground, a
triangle with its corners at the disk centres hides a 60° wedge of each. */
struct ThreeDisks {
    Mat image, truth, hole;
    explicit ThreeDisks(int S) {
        image = Mat(S, S, CV_8UC3, Scalar(200, 200, 200));
        truth = Mat::zeros(S, S, CV_8U);
        hole = Mat::zeros(S, S, CV_8U);
        const int R = cvRound(S * 0.14);
        const Point c[3] = {Point(S / 2, cvRound(S * 0.2)),
                            Point(cvRound(S * 0.2), cvRound(S * 0.75)),
                            Point(cvRound(S * 0.8), cvRound(S * 0.75))};
        for (const Point& p : c) {
            circle(image, p, R, Scalar(40, 40, 40), FILLED);
            circle(truth, p, R, Scalar(255), FILLED);
        }
        std::vector<Point> tri(c, c + 3);
        fillConvexPoly(hole, tri, Scalar(255));
    }
    double iou(const Mat& out) const {
        Mat g;
        cvtColor(out, g, COLOR_BGR2GRAY);
        const Mat dark = g < 120;
        return double(countNonZero(dark & truth)) / countNonZero(dark | truth);
    }
};

class InpaintThreeDisks : public ::testing::TestWithParam<int> {};

TEST_P(InpaintThreeDisks, GlobalSearchCompletesDisksRound) {
    const ThreeDisks scene(GetParam() == PATCH_SEARCH_VPTREE ? 112 : 128);
    const Mat out = fill(scene.image, scene.hole, GetParam());
    // Filling the wedges with background gives IoU 0.82; the local search of the original
    // paper grows droplets (measured 0.89-0.94 at 112-160 px); a global search brings the
    // disks back (0.98-0.99).
    const double iou = scene.iou(out);
    RecordProperty("iou", std::to_string(iou));
    EXPECT_GE(iou, 0.96) << toString((PatchSearchMethod)GetParam());
}

INSTANTIATE_TEST_SUITE_P(Global, InpaintThreeDisks,
                         ::testing::Values(PATCH_SEARCH_PATCHMATCH, PATCH_SEARCH_VPTREE),
                         [](const auto& info) { return toString((PatchSearchMethod)info.param); });

TEST(InpaintExemplar, GlobalSearchBeatsLocalWindowOnThreeDisks) {
    const ThreeDisks scene(128);
    ExemplarInpainter::Params p;
    p.local_radius = 15;  // the window sees only the disk being completed
    p.method = PATCH_SEARCH_LOCAL;
    const double local = scene.iou(fill(scene.image, scene.hole, p));
    const double global = scene.iou(fill(scene.image, scene.hole, PATCH_SEARCH_PATCHMATCH));
    RecordProperty("iou_local", std::to_string(local));
    RecordProperty("iou_global", std::to_string(global));
    EXPECT_GT(global, local + 0.03) << "local " << local << " global " << global;
}

TEST(InpaintExemplar, DeterministicForASeedAndSeedMatters) {
    const Mat img = textureImage(Size(96, 72));
    Mat mask = diskMask(img.size(), 0.25);
    ExemplarInpainter::Params p;
    p.pm_random_samples = 4;  // few samples, so that the seed shows
    p.pm_band_iterations = 0;
    Mat a, b, c;
    ExemplarInpainter::create(p)->inpaint(img, mask, a);
    ExemplarInpainter::create(p)->inpaint(img, mask, b);
    EXPECT_EQ(norm(a, b, NORM_INF), 0);
    p.seed = 12345;
    ExemplarInpainter::create(p)->inpaint(img, mask, c);
    EXPECT_GT(norm(a, c, NORM_L1), 0) << "another seed should draw other candidates";
}

TEST(InpaintExemplar, GrayImageAndRgbDistance) {
    Mat img = stripesImage(Size(96, 72)), gray;
    cvtColor(img, gray, COLOR_BGR2GRAY);
    const Mat mask = diskMask(gray.size(), 0.2);
    ExemplarInpainter::Params p;
    p.color_space = PATCH_COLOR_RGB;
    Mat out;
    ExemplarInpainter::create(p)->inpaint(gray, mask, out);
    ASSERT_EQ(out.type(), CV_8UC1);
    EXPECT_EQ(norm(out, gray, NORM_INF), 0);
}

TEST(InpaintExemplar, SourceMaskRestrictsWhereFromIsCopied) {
    // Left half red, right half blue; the hole is in the blue half but only the red half may
    // be copied from.
    Mat img(64, 96, CV_8UC3, Scalar(0, 0, 255));
    img.colRange(48, 96).setTo(Scalar(255, 0, 0));
    Mat mask = Mat::zeros(img.size(), CV_8U);
    circle(mask, Point(72, 32), 8, Scalar(255), FILLED);
    Mat source = Mat::zeros(img.size(), CV_8U);
    source.colRange(0, 48).setTo(255);
    Mat out;
    ExemplarInpainter::create()->inpaint(img, mask, out, source);
    EXPECT_EQ(out.at<Vec3b>(32, 72), Vec3b(0, 0, 255));
}

TEST(InpaintExemplar, ParamsRoundTripThroughFileStorage) {
    ExemplarInpainter::Params p;
    p.patch_size = 11;
    p.method = PATCH_SEARCH_VPTREE;
    p.color_space = PATCH_COLOR_RGB;
    p.vp_candidates = 50;
    p.seed = 77;
    FileStorage out(".yml", FileStorage::WRITE | FileStorage::MEMORY);
    out << "inpaint"
        << "{";
    p.write(out);
    out << "}";
    const std::string text = out.releaseAndGetString();
    EXPECT_NE(text.find("vptree"), std::string::npos);
    FileStorage in(text, FileStorage::READ | FileStorage::MEMORY);
    ExemplarInpainter::Params q;
    q.read(in["inpaint"]);
    EXPECT_EQ(q.patch_size, 11);
    EXPECT_EQ(q.method, PATCH_SEARCH_VPTREE);
    EXPECT_EQ(q.color_space, PATCH_COLOR_RGB);
    EXPECT_EQ(q.vp_candidates, 50);
    EXPECT_EQ(q.seed, 77u);
}

TEST(InpaintExemplar, ParsesMethodNames) {
    EXPECT_EQ(parsePatchSearchMethod("PatchMatch"), PATCH_SEARCH_PATCHMATCH);
    EXPECT_EQ(parsePatchSearchMethod("vptree"), PATCH_SEARCH_VPTREE);
    EXPECT_EQ(parsePatchSearchMethod("local"), PATCH_SEARCH_LOCAL);
    try {
        parsePatchSearchMethod("kdtree");
        FAIL() << "expected an exception";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("patchmatch, vptree or local"), std::string::npos) << e.err;
    }
}

}  // namespace
