// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion into footage filmed through a lens with radial distortion (Camera::k1): the
// synthetic insertion sequence rendered wider than the frame, then distorted with a known k1 by
// the test's own map (OpenCV's undistortPoints, not vbme's), input and truth alike. The
// insertion with k1 in the scene (room model from undistorted frames, layers distorted back
// before compositing) is compared with the same insertion ignoring k1, against that truth; and
// the COLMAP camera track of such footage with k1 in the scene against the track ignoring it.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/insertion_sequence.hpp>
#include <opencv2/vbme/pipeline/insertion.hpp>

#include "vbme_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

// remap() maps of a lens with radial coefficient k1 and intrinsics K (a frame of size `size`)
// reading from a pinhole image whose pixel (0, 0) is the frame's pixel -offset: for every
// distorted pixel its undistorted point by OpenCV's iterative undistortPoints, checked by
// distorting it again (projectPoints); pixels without one map outside.
void lensMaps(const Matx33d& K, double k1, Size size, Point2d offset, Mat& mx, Mat& my) {
    std::vector<Point2d> pd;
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x)
            pd.emplace_back(x, y);
    const std::vector<double> dist = {k1, 0, 0, 0};
    std::vector<Point2d> pu;
    undistortPoints(pd, pu, Mat(K), dist, noArray(), Mat(K),
                    TermCriteria(TermCriteria::COUNT + TermCriteria::EPS, 100, 1e-12));
    std::vector<Point3d> X;
    const Matx33d Ki = K.inv();
    for (const Point2d& p : pu) {
        const Vec3d x = Ki * Vec3d(p.x, p.y, 1);
        X.emplace_back(x[0], x[1], 1);
    }
    std::vector<Point2d> back;
    projectPoints(X, Vec3d(0, 0, 0), Vec3d(0, 0, 0), Mat(K), dist, back);
    mx.create(size, CV_32F);
    my.create(size, CV_32F);
    for (size_t i = 0; i < pd.size(); ++i) {
        const bool ok = norm(back[i] - pd[i]) < 1e-6;
        mx.at<float>((int)pd[i].y, (int)pd[i].x) = ok ? (float)(pu[i].x + offset.x) : -1e6f;
        my.at<float>((int)pd[i].y, (int)pd[i].x) = ok ? (float)(pu[i].y + offset.y) : -1e6f;
    }
}

// The synthetic insertion sequence (one frame) seen through a lens with k1 = −0.2 as a 160×120
// frame (focal 134.4 px): rendered at 224×168 with the same focal, so the barrel lens's wider view
// has content to its corners, and distorted by lensMaps, input, truth and region alike; the
// object stands under the frame's pinhole pixel `place`. insert() runs vbme insert on it with
// the true camera path.
struct DistortedInsertion {
    const Size big{224, 168}, size{160, 120};
    const Point2d offset{(224 - 160) / 2.0, (168 - 120) / 2.0};
    const double k1 = -0.2;  // the frame's corners (r = 0.74) before the fold (r = 0.86)
    vbme_test::ScratchDir tmp;
    SyntheticInsertionSequence::Params p;
    std::unique_ptr<SyntheticInsertionSequence> seq;
    Mat input, truth, region;
    std::string pin_scene, k1_scene;

    explicit DistortedInsertion(Point2d place) {
        p.size = big;
        p.frames = 1;
        p.spp = 4;
        p.max_depth = 3;
        p.texture_size = 128;
        p.travel = 0.05;
        p.object_width = 0.6;
        p.place = place + offset;
        seq.reset(new SyntheticInsertionSequence(tmp / "seq", p));
        Scene scene = seq->trueScene();
        scene.image_size = size;
        scene.camera.image_size = size;
        scene.camera.K(0, 2) -= offset.x;
        scene.camera.K(1, 2) -= offset.y;
        Mat mx, my, in, tr, reg;
        lensMaps(scene.camera.K, k1, size, offset, mx, my);
        fs::create_directories(tmp / "video");
        seq->renderFrame(0, in, tr, reg);
        remap(in, input, mx, my, INTER_LINEAR, BORDER_CONSTANT);
        imwrite(tmp / "video/00000.png", input);
        remap(tr, truth, mx, my, INTER_LINEAR, BORDER_CONSTANT);
        remap(reg, region, mx, my, INTER_NEAREST, BORDER_CONSTANT);
        CameraPath path = seq->truePath();
        path.K = scene.camera.K;
        path.image_size = size;
        path.write(tmp / "cameras.yml");
        // the scene files next to the sequence's (their texture paths are relative to it)
        pin_scene = (fs::path(seq->dir()) / "scene_pinhole.yml").string();
        k1_scene = (fs::path(seq->dir()) / "scene_k1.yml").string();
        scene.write(pin_scene);
        scene.camera.k1 = k1;
        scene.write(k1_scene);
    }

    Mat insert(const std::string& scene_file, const std::string& name) {
        InsertionParams ip;
        ip.video = tmp / "video";
        ip.scene = scene_file;
        ip.cameras = tmp / "cameras.yml";
        ip.out = tmp / (name + ".mkv");
        ip.work = tmp / name;
        ip.grain = InsertionParams::GRAIN_OFF;  // the truth holds the input's own noise
        const PipelineReport r = runInsertion(ip);
        EXPECT_EQ(r.frames_processed, 1);
        return imread((fs::path(ip.work) / "frames" / "frame_00000.png").string());
    }

    // Where the composite differs from the input by more than 40 grey levels (the object).
    Mat objectPixels(const Mat& composite) const {
        Mat d, g;
        absdiff(composite, input, d);
        cvtColor(d, g, COLOR_BGR2GRAY);
        return g > 40;
    }
    static Point2d centroid(const Mat& mask) {
        const Moments m = moments(mask, true);
        return m.m00 > 0 ? Point2d(m.m10 / m.m00, m.m01 / m.m00) : Point2d(-1e3, -1e3);
    }
    void keep(const std::vector<Mat>& composites, const std::string& name) const {
        if (!std::getenv("VBME_KEEP_TEST_FILES")) return;
        std::vector<Mat> row = {input};
        row.insert(row.end(), composites.begin(), composites.end());
        row.push_back(truth);
        Mat out;
        hconcat(row, out);
        imwrite(tmp / name, out);
    }
};

// The object under the frame's pixel (0.88 w, 0.82 h): r² = 0.29, where k1 moves points by ~4 px.
TEST(PipelineInsertDistortion, K1InSceneBeatsIgnoringIt) {
    DistortedInsertion d(Point2d(0.88 * 160, 0.82 * 120));
    const Mat with_k1 = d.insert(d.k1_scene, "k1"), without = d.insert(d.pin_scene, "pin");
    // region PSNR; also the object's position: the centroid of where the composite differs from
    // the input, against the truth's
    double sse_k1 = 0, sse_pin = 0, sse_in = 0, count = 0;
    regionPsnr(with_k1, d.truth, d.region, &sse_k1, &count);
    regionPsnr(without, d.truth, d.region, &sse_pin, nullptr);
    regionPsnr(d.input, d.truth, d.region, &sse_in, nullptr);
    const Point2d ct = d.centroid(d.objectPixels(d.truth));
    const double shift_k1 = norm(d.centroid(d.objectPixels(with_k1)) - ct);
    const double shift_pin = norm(d.centroid(d.objectPixels(without)) - ct);
    d.keep({with_k1, without}, "compare_00000.png");
    ASSERT_GT(count, 0);
    auto psnr = [&](double sse) { return 10 * std::log10(255.0 * 255.0 * count / sse); };
    std::printf(
        "k1 %.2f: region PSNR with k1 %.2f dB, k1 ignored %.2f dB, input (no object) %.2f dB "
        "over %.0f values; object centroid off the truth's by %.2f px with k1, %.2f px "
        "ignoring it\n",
        d.k1, psnr(sse_k1), psnr(sse_pin), psnr(sse_in), count, shift_k1, shift_pin);
    // Measured: with k1 25.81 dB, k1 ignored 17.83 dB, input 17.10 dB; centroid 0.27 px off
    // with k1, 4.85 px ignoring it (the lens moves points by ~4 px there). Before the render
    // was enlarged (lensCoverCamera): 25.43 dB, 0.49 px with k1.
    EXPECT_GT(psnr(sse_k1), psnr(sse_pin) + 3.0);
    EXPECT_GT(psnr(sse_k1), psnr(sse_in) + 4.0);
    EXPECT_LT(shift_k1, 1.5);
    EXPECT_GT(shift_pin, 2.5);
    EXPECT_GT(shift_pin, 3.0 * shift_k1);
}

// The object under the pinhole pixel (w + 2, 113), beyond the pinhole frame's right edge: the
// barrel lens shows it inside the frame, in the band a render of the frame's own pinhole camera
// does not hold. The insertion (rendered over lensCoverCamera) against the distorted truth: the
// object's area and centroid in the frame.
TEST(PipelineInsertDistortion, ObjectAtTheFrameEdgeIsNotCutOff) {
    DistortedInsertion d(Point2d(160 + 2, 113));
    const Mat with_k1 = d.insert(d.k1_scene, "k1");
    d.keep({with_k1}, "edge_00000.png");
    const Mat obj_truth = d.objectPixels(d.truth), obj = d.objectPixels(with_k1);
    const double area_truth = countNonZero(obj_truth), area = countNonZero(obj);
    // the part in the band a frame-size pinhole render leaves out (its undistorted point beyond
    // the pinhole frame's last column)
    Camera cam = Scene::read(d.k1_scene).camera;
    Mat band = Mat::zeros(d.size, CV_8U);
    for (int y = 0; y < band.rows; ++y)
        for (int x = 0; x < band.cols; ++x)
            band.at<uchar>(y, x) = cam.undistortPixel(Point2d(x, y)).x > d.size.width - 1 ? 255 : 0;
    const double band_truth = countNonZero(obj_truth & band), band_k1 = countNonZero(obj & band);
    double sse = 0, count = 0, sse_in = 0;
    regionPsnr(with_k1, d.truth, d.region, &sse, &count);
    regionPsnr(d.input, d.truth, d.region, &sse_in, nullptr);
    ASSERT_GT(count, 0);
    auto psnr = [&](double s) { return 10 * std::log10(255.0 * 255.0 * count / s); };
    const double shift = norm(d.centroid(obj) - d.centroid(obj_truth));
    std::printf(
        "object at the frame edge (k1 %.2f): %.0f object pixels (truth %.0f), %.0f of them in "
        "the band beyond the pinhole frame (truth %.0f); centroid %.2f px off the truth's; region "
        "PSNR %.2f dB (input %.2f dB)\n",
        d.k1, area, area_truth, band_k1, band_truth, shift, psnr(sse), psnr(sse_in));
    // Measured: 163 object pixels (truth 192; the rest are pixels inside the object where the
    // 4-spp renders differ by the threshold), 93 in the band (truth 112), centroid 0.31 px off,
    // 26.57 dB (input 16.50 dB). Rendered over the frame's own pinhole camera (before
    // lensCoverCamera): 78 pixels, 11 in the band, centroid 3.77 px off, 18.96 dB.
    ASSERT_GT(band_truth, 20);  // the setting: the truth has the object in the band
    EXPECT_GT(band_k1, 0.7 * band_truth);
    EXPECT_NEAR(area, area_truth, 0.25 * area_truth);
    EXPECT_LT(shift, 1.0);
}

double rotationErrorDeg(const Matx33d& a, const Matx33d& b) {
    const Matx33d d = a * b.t();
    const double c = std::max(-1.0, std::min(1.0, (d(0, 0) + d(1, 1) + d(2, 2) - 1) / 2));
    return std::acos(c) * 180 / CV_PI;
}

// trackCameraVideo (keyframes, COLMAP, PnP) on 8 distorted frames (k1 = −0.2, 240×180, the
// sequence rendered at 336×252 so the lens has content to its corners), given frame 0's true
// pinhole camera and room, with k1 in the scene (frames undistorted before COLMAP and PnP) and
// without it. Measured: the trajectory against the true cameras and the rms distance between
// where the track and the truth put floor points in the distorted frames.
TEST(PipelineInsertDistortion, CameraTrackWithK1BeatsIgnoringIt) {
    if (vbme_test::run("colmap help").code != 0)
        GTEST_SKIP() << "the colmap program is not installed";
    Progress::setEnabled(false);
    vbme_test::ScratchDir tmp;
    const Size size(240, 180), big(336, 252);
    const Point2d offset((big.width - size.width) / 2.0, (big.height - size.height) / 2.0);
    const double k1 = -0.2;
    SyntheticInsertionSequence::Params p;
    p.size = big;
    p.frames = 8;
    p.spp = 4;
    p.max_depth = 3;
    p.texture_size = 256;
    const SyntheticInsertionSequence seq(tmp / "seq", p);
    Scene scene = seq.trueScene();
    scene.objects.clear();  // the footage is the room alone
    scene.image_size = size;
    scene.camera.image_size = size;
    scene.camera.K(0, 2) -= offset.x;
    scene.camera.K(1, 2) -= offset.y;
    Mat mx, my;
    lensMaps(scene.camera.K, k1, size, offset, mx, my);
    fs::create_directories(tmp / "video");
    for (int i = 0; i < p.frames; ++i) {
        Mat in, tr, reg, d;
        seq.renderFrame(i, in, tr, reg);
        remap(in, d, mx, my, INTER_LINEAR, BORDER_CONSTANT);
        imwrite(tmp / format("video/%05d.png", i), d);
    }
    struct Result {
        double ate = 0, worst_rot = 0, floor_rms = 0;
        int registered = 0;
    };
    auto track = [&](double scene_k1) {
        Scene s = scene;
        s.camera.k1 = scene_k1;
        CameraTrackingReport rep;
        const CameraPath path = trackCameraVideo(
            tmp / "video", s, tmp / format("track_%g", scene_k1), CameraTrackingOptions(), &rep);
        EXPECT_EQ(path.k1, scene_k1);
        Result r;
        r.registered = rep.registered + rep.pnp;
        double ate2 = 0, floor2 = 0;
        int n_floor = 0;
        for (int i = 0; i < p.frames; ++i) {
            Camera truth = seq.cameras()[i];
            truth.K = scene.camera.K;
            truth.k1 = k1;
            truth.image_size = size;
            const Camera est = path.camera(i);
            ate2 += std::pow(norm(est.center() - truth.center()), 2);
            r.worst_rot = std::max(r.worst_rot, rotationErrorDeg(est.R, truth.R));
            for (double x = -1.5; x <= 1.5; x += 0.25)
                for (double y = 0.5; y <= 4; y += 0.25) {
                    double z = 0;
                    const Point2d a = truth.projectDistorted(Vec3d(x, y, 0), &z);
                    if (z < 0.3 || a.x < 0 || a.y < 0 || a.x > size.width - 1 ||
                        a.y > size.height - 1 || !std::isfinite(truth.undistortPixel(a).x))
                        continue;
                    floor2 += std::pow(norm(est.projectDistorted(Vec3d(x, y, 0)) - a), 2);
                    ++n_floor;
                }
        }
        r.ate = std::sqrt(ate2 / p.frames);
        r.floor_rms = n_floor ? std::sqrt(floor2 / n_floor) : 1e9;
        return r;
    };
    const Result with_k1 = track(k1), without = track(0);
    Progress::setEnabled(true);
    std::printf(
        "camera track of distorted footage (k1 %.2f, %d frames): with k1 in the scene ATE %.1f "
        "mm, worst rotation %.3f deg, floor points %.2f px rms, %d registered; ignoring it ATE "
        "%.1f mm, worst rotation %.3f deg, floor points %.2f px rms, %d registered\n",
        k1, p.frames, 1000 * with_k1.ate, with_k1.worst_rot, with_k1.floor_rms, with_k1.registered,
        1000 * without.ate, without.worst_rot, without.floor_rms, without.registered);
    // Measured: with k1 17.1 mm, 0.404 deg, 3.29 px; ignoring it 624.4 mm, 14.586 deg,
    // 160.79 px (8 of 8 registered both times).
    EXPECT_LT(with_k1.floor_rms, 6.0);
    EXPECT_LT(with_k1.ate, 0.04);
    EXPECT_GT(without.floor_rms, 4 * with_k1.floor_rms);
    EXPECT_GT(without.ate, 4 * with_k1.ate);
}

}  // namespace
