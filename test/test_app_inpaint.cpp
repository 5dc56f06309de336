// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The `vbme inpaint` command: outputs, exit codes (2 usage, 1 bad input), nothing written on
// failure, --force.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
namespace fs = std::filesystem;

namespace {

const std::string kExe = VBME_EXE;

Mat stripes(Size s) {
    Mat m(s, CV_8UC3);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            m.at<Vec3b>(y, x) = ((x / 4) % 2) ? Vec3b(200, 60, 30) : Vec3b(30, 160, 220);
    return m;
}

Mat texture(Size s) {
    Mat m(s, CV_8UC3);
    RNG rng(5);
    rng.fill(m, RNG::UNIFORM, 0, 256);
    GaussianBlur(m, m, Size(0, 0), 2.0);
    normalize(m, m, 0, 255, NORM_MINMAX);
    return m;
}

Mat disk(Size s, Point c, int r) {
    Mat m = Mat::zeros(s, CV_8U);
    circle(m, c, r, Scalar(255), FILLED);
    return m;
}

struct ImageCase {
    vbme_test::ScratchDir dir;
    std::string in, mask, out;
    Mat img;
    ImageCase() {
        img = stripes(Size(96, 64));
        in = dir / "in.png";
        mask = dir / "hole.png";
        out = dir / "out.png";
        Mat shown = img.clone();
        const Mat hole = disk(img.size(), Point(48, 32), 12);
        shown.setTo(Scalar(0, 0, 255), hole);
        imwrite(in, shown);
        imwrite(mask, hole);
    }
    vbme_test::RunResult run(const std::string& args) const {
        return vbme_test::run(kExe + " inpaint " + args);
    }
};

TEST(AppInpaint, ImageIsFilled) {
    ImageCase c;
    for (const std::string m : {"patchmatch", "vptree", "local"}) {
        const auto r = c.run("--image " + c.in + " --mask " + c.mask + " --out " + c.out +
                             " --force --method " + m);
        ASSERT_EQ(r.code, 0) << r.output;
        const Mat out = imread(c.out);
        ASSERT_EQ(out.size(), c.img.size());
        EXPECT_EQ(norm(out, c.img, NORM_INF), 0) << m << ": stripes are refilled exactly";
    }
}

TEST(AppInpaint, UsageErrorsExitTwoAndWriteNothing) {
    ImageCase c;
    const std::string io = "--image " + c.in + " --mask " + c.mask + " --out " + c.out;
    for (const std::string& args :
         {std::string(""), "--image " + c.in + " --out " + c.out,  // no mask
          io + " --video " + c.in + " --masks " + c.dir.path().string(), io + " --method kdtree",
          io + " --patch 8", io + " --patch 1", "--mask " + c.mask + " --out " + c.out,
          io + " --bogus"}) {
        const auto r = c.run(args);
        EXPECT_EQ(r.code, 2) << args << "\n" << r.output;
        EXPECT_FALSE(fs::exists(c.out)) << args;
    }
}

TEST(AppInpaint, BadInputExitsOneWithAMessageAndWritesNothing) {
    ImageCase c;
    // A missing input is bad input (exit 1), as for every command.
    {
        const auto m =
            c.run("--image " + c.dir / "missing.png" + " --mask " + c.mask + " --out " + c.out);
        EXPECT_EQ(m.code, 1) << m.output;
        EXPECT_NE(m.output.find("does not exist"), std::string::npos) << m.output;
        EXPECT_FALSE(fs::exists(c.out));
    }
    // Mask of another size.
    imwrite(c.dir / "small.png", Mat::zeros(10, 10, CV_8U));
    auto r = c.run("--image " + c.in + " --mask " + c.dir / "small.png" + " --out " + c.out);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("is 10x10 but image"), std::string::npos) << r.output;
    // A file that is not an image.
    std::ofstream(c.dir / "junk.png") << "not a png";
    r = c.run("--image " + c.dir / "junk.png" + " --mask " + c.mask + " --out " + c.out);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("not a readable image"), std::string::npos) << r.output;
    // A mask covering everything: nothing to copy from.
    imwrite(c.dir / "full.png", Mat(c.img.size(), CV_8U, Scalar(255)));
    r = c.run("--image " + c.in + " --mask " + c.dir / "full.png" + " --out " + c.out);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("vbme: error:"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(c.out));
    for (const auto& e : fs::directory_iterator(c.dir.path()))
        EXPECT_EQ(e.path().filename().string().find("out"), std::string::npos)
            << "left behind: " << e.path();
}

TEST(AppInpaint, RefusesExistingOutputWithoutForce) {
    ImageCase c;
    imwrite(c.out, Mat::zeros(4, 4, CV_8UC3));
    const std::string args = "--image " + c.in + " --mask " + c.mask + " --out " + c.out;
    auto r = c.run(args);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
    EXPECT_EQ(imread(c.out).size(), Size(4, 4)) << "the existing file is untouched";
    r = c.run(args + " --force");
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(imread(c.out).size(), c.img.size());
}

TEST(AppInpaint, NonBinaryMaskIsFilledAndNoted) {
    ImageCase c;
    Mat soft = disk(c.img.size(), Point(48, 32), 12);
    GaussianBlur(soft, soft, Size(5, 5), 0);
    imwrite(c.mask, soft);
    const auto r = c.run("--image " + c.in + " --mask " + c.mask + " --out " + c.out);
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("neither 0 nor 255"), std::string::npos) << r.output;
    EXPECT_EQ(norm(imread(c.out), c.img, NORM_INF), 0);
}

TEST(AppInpaint, VideoWithMaskFolder) {
    vbme_test::ScratchDir dir;
    const Size size(96, 64);
    const Mat bg = texture(size);
    fs::create_directories(dir / "masks");
    const int n = 8;
    std::vector<Mat> holes;
    {
        cv::vbme::VideoSink sink(dir / "in/%05d.png", 15, size);
        for (int t = 0; t < n; ++t) {
            const Point c(14 + t * 9, 32);
            Mat f = bg.clone();
            circle(f, c, 9, Scalar(20, 20, 230), FILLED);
            holes.push_back(disk(size, c, 11));
            sink.write(f);
            imwrite(dir / ("masks/" + cv::vbme::maskFileName(t)), holes.back());
        }
        sink.close();
    }
    const std::string out = dir / "out.mkv";  // FFV1: lossless, so the fill can be checked
    const auto r = vbme_test::run(kExe + " inpaint --quiet --video " + dir / "in" + " --masks " +
                                  dir / "masks" + " --out " + out + " --radius 3");
    ASSERT_EQ(r.code, 0) << r.output;
    cv::vbme::VideoReader reader(out);
    EXPECT_NEAR(reader.fps(), 15, 1e-6);
    Mat f;
    int t = 0;
    while (reader.read(f)) {
        ASSERT_LT(t, n);
        // The ball moves 9 px per frame and is 22 px wide: its middle frames see all of
        // their hole in neighbours, which are copied exactly.
        if (t >= 2 && t <= n - 3) {
            EXPECT_EQ(norm(f, bg, NORM_INF), 0) << "frame " << t;
        }
        ++t;
    }
    EXPECT_EQ(t, n);

    // A missing mask: exit 1, message, no output.
    fs::remove(dir / ("masks/" + cv::vbme::maskFileName(5)));
    const std::string out2 = dir / "out2.mkv";
    const auto r2 = vbme_test::run(kExe + " inpaint --quiet --video " + dir / "in" + " --masks " +
                                   dir / "masks" + " --out " + out2);
    EXPECT_EQ(r2.code, 1) << r2.output;
    EXPECT_NE(r2.output.find("mask of frame 5 is missing"), std::string::npos) << r2.output;
    EXPECT_FALSE(fs::exists(out2));
    // A mask folder that does not exist.
    const auto r3 = vbme_test::run(kExe + " inpaint --quiet --video " + dir / "in" + " --masks " +
                                   dir / "nope" + " --out " + out2);
    EXPECT_EQ(r3.code, 1) << r3.output;
    EXPECT_FALSE(fs::exists(out2));
}

// The Blender clip of test_inpaint_consensus.cpp (static camera) through the command line:
// the default consensus fill with shadow removal against --fill nearest (the earlier method),
// measured against the clean plate inside the holes.
TEST(AppInpaint, BlenderClipConsensusAndShadows) {
    vbme_test::ScratchDir dir;
    const std::string data = std::string(VBME_TEST_DATA_DIR) + "/inpaint_static";
    fs::create_directories(dir / "masks");
    std::vector<Mat> holes, clean;
    {
        cv::vbme::VideoReader rc(data + "/clean.mkv");
        Mat c;
        for (int i = 0; rc.read(c); ++i) {
            const Mat ball = imread(data + format("/ball_%05d.png", i), IMREAD_GRAYSCALE);
            ASSERT_FALSE(ball.empty());
            Mat hole;
            dilate(ball > 0, hole, getStructuringElement(MORPH_ELLIPSE, Size(9, 9)));
            imwrite(dir / ("masks/" + cv::vbme::maskFileName(i)), hole);
            holes.push_back(hole);
            clean.push_back(c.clone());
        }
    }
    ASSERT_GE(holes.size(), 20u);
    auto psnr = [&](const std::string& video, const std::vector<Mat>& masks) {
        cv::vbme::VideoReader r(video);
        Mat f;
        double se = 0, n = 0;
        for (size_t t = 0; r.read(f) && t < masks.size(); ++t) {
            Mat d;
            absdiff(f, clean[t], d);
            d.convertTo(d, CV_64F);
            d = d.mul(d);
            const Scalar s = sum(d.setTo(0, masks[t] == 0));
            se += s[0] + s[1] + s[2];
            n += 3.0 * countNonZero(masks[t]);
        }
        return 10 * std::log10(255.0 * 255.0 * n / std::max(se, 1e-9));
    };
    const std::string base =
        kExe + " inpaint --quiet --video " + data + "/frames.mkv --masks " + dir / "masks";
    auto r = vbme_test::run(base + " --out " + dir / "consensus.mkv");
    ASSERT_EQ(r.code, 0) << r.output;
    r = vbme_test::run(base + " --fill nearest --out " + dir / "nearest.mkv");
    ASSERT_EQ(r.code, 0) << r.output;
    const double ours = psnr(dir / "consensus.mkv", holes);
    const double nearest = psnr(dir / "nearest.mkv", holes);
    std::printf("[ app ] PSNR in holes: consensus %.2f dB, --fill nearest %.2f dB\n", ours,
                nearest);
    EXPECT_GE(ours, 32.0);
    EXPECT_GE(ours, nearest + 3.0);
    // Outside the holes, the default --shadows remove changes the shadow's pixels.
    cv::vbme::VideoReader in(data + "/frames.mkv"), removed(dir / "consensus.mkv");
    Mat a, c;
    int changed = 0;
    for (size_t t = 0; in.read(a) && removed.read(c) && t < holes.size(); ++t) {
        Mat d;
        absdiff(a, c, d);
        d.setTo(0, holes[t]);
        changed += countNonZero(d.reshape(1));
    }
    EXPECT_GT(changed, 0) << "--shadows remove changes the shadow outside the holes";
    // Usage: an unknown shadow mode is a usage error.
    r = vbme_test::run(base + " --shadows erase --out " + dir / "x.mkv");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_FALSE(fs::exists(dir / "x.mkv"));
}

}  // namespace
