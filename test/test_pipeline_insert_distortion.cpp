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

TEST(PipelineInsertDistortion, K1InSceneBeatsIgnoringIt) {
    vbme_test::ScratchDir tmp;
    // the frame: 160×120 with focal 134.4 px; the sequence is rendered at 224×168 with the
    // same focal (0.6 × 224), so the barrel lens's wider view has content to its corners
    const Size big(224, 168), size(160, 120);
    const Point2d offset((big.width - size.width) / 2.0, (big.height - size.height) / 2.0);
    const double k1 = -0.2;  // the frame's corners (r = 0.74) before the fold (r = 0.86)
    SyntheticInsertionSequence::Params p;
    p.size = big;
    p.frames = 1;
    p.spp = 4;
    p.max_depth = 3;
    p.texture_size = 128;
    p.travel = 0.05;
    p.object_width = 0.6;
    // under the frame's pixel (0.88 w, 0.82 h): r² = 0.29, where k1 moves points by ~4 px
    p.place = Point2d(0.88 * size.width + offset.x, 0.82 * size.height + offset.y);
    const SyntheticInsertionSequence seq(tmp / "seq", p);

    Scene scene = seq.trueScene();
    scene.image_size = size;
    scene.camera.image_size = size;
    scene.camera.K(0, 2) -= offset.x;
    scene.camera.K(1, 2) -= offset.y;
    Mat mx, my;
    lensMaps(scene.camera.K, k1, size, offset, mx, my);

    // the distorted input (PNG folder), truth and region of each frame
    fs::create_directories(tmp / "video");
    std::vector<Mat> truth, region;
    for (int i = 0; i < p.frames; ++i) {
        Mat in, tr, reg, d;
        seq.renderFrame(i, in, tr, reg);
        remap(in, d, mx, my, INTER_LINEAR, BORDER_CONSTANT);
        imwrite(tmp / format("video/%05d.png", i), d);
        remap(tr, d, mx, my, INTER_LINEAR, BORDER_CONSTANT);
        truth.push_back(d);
        remap(reg, d, mx, my, INTER_NEAREST, BORDER_CONSTANT);
        region.push_back(d);
    }
    CameraPath path = seq.truePath();
    path.K = scene.camera.K;
    path.image_size = size;
    path.write(tmp / "cameras.yml");
    // the scene files next to the sequence's (their texture paths are relative to it)
    const std::string pin_scene = (fs::path(seq.dir()) / "scene_pinhole.yml").string();
    const std::string k1_scene = (fs::path(seq.dir()) / "scene_k1.yml").string();
    scene.write(pin_scene);
    scene.camera.k1 = k1;
    scene.write(k1_scene);

    auto insert = [&](const std::string& scene_file, const std::string& name) {
        InsertionParams ip;
        ip.video = tmp / "video";
        ip.scene = scene_file;
        ip.cameras = tmp / "cameras.yml";
        ip.out = tmp / (name + ".mkv");
        ip.work = tmp / name;
        ip.grain = InsertionParams::GRAIN_OFF;  // the truth holds the input's own noise
        const PipelineReport r = runInsertion(ip);
        EXPECT_EQ(r.frames_processed, p.frames);
        std::vector<Mat> out;
        for (int i = 0; i < p.frames; ++i)
            out.push_back(
                imread((fs::path(ip.work) / "frames" / format("frame_%05d.png", i)).string()));
        return out;
    };
    const std::vector<Mat> with_k1 = insert(k1_scene, "k1"), without = insert(pin_scene, "pin");

    // region PSNR over the frames; also the object's position: the centroid of where the
    // composite differs from the input, against the truth's
    double sse_k1 = 0, sse_pin = 0, sse_in = 0, count = 0, shift_k1 = 0, shift_pin = 0;
    auto centroid = [](const Mat& a, const Mat& b) {
        Mat d, g;
        absdiff(a, b, d);
        cvtColor(d, g, COLOR_BGR2GRAY);
        const Moments m = moments(g > 40, true);
        return m.m00 > 0 ? Point2d(m.m10 / m.m00, m.m01 / m.m00) : Point2d(-1e3, -1e3);
    };
    for (int i = 0; i < p.frames; ++i) {
        const Mat input = imread(tmp / format("video/%05d.png", i));
        double s, c;
        regionPsnr(with_k1[i], truth[i], region[i], &s, &c);
        sse_k1 += s;
        count += c;
        regionPsnr(without[i], truth[i], region[i], &s, &c);
        sse_pin += s;
        regionPsnr(input, truth[i], region[i], &s, &c);
        sse_in += s;
        const Point2d ct = centroid(truth[i], input);
        shift_k1 += norm(centroid(with_k1[i], input) - ct) / p.frames;
        shift_pin += norm(centroid(without[i], input) - ct) / p.frames;
        if (std::getenv("VBME_KEEP_TEST_FILES")) {
            Mat row;
            hconcat(std::vector<Mat>{input, with_k1[i], without[i], truth[i]}, row);
            imwrite(tmp / format("compare_%05d.png", i), row);
        }
    }
    ASSERT_GT(count, 0);
    auto psnr = [&](double sse) { return 10 * std::log10(255.0 * 255.0 * count / sse); };
    std::printf(
        "k1 %.2f: region PSNR with k1 %.2f dB, k1 ignored %.2f dB, input (no object) %.2f dB "
        "over %.0f values; object centroid off the truth's by %.2f px with k1, %.2f px "
        "ignoring it\n",
        k1, psnr(sse_k1), psnr(sse_pin), psnr(sse_in), count, shift_k1, shift_pin);
    // Measured: with k1 25.37 dB, k1 ignored 17.74 dB, input 17.10 dB; centroid 0.41 px off
    // with k1, 4.91 px ignoring it (the lens moves points by ~4 px there). (With two frames:
    // 24.70 / 17.75 / 17.05 dB, 0.56 / 4.96 px.)
    EXPECT_GT(psnr(sse_k1), psnr(sse_pin) + 3.0);
    EXPECT_GT(psnr(sse_k1), psnr(sse_in) + 4.0);
    EXPECT_LT(shift_k1, 1.5);
    EXPECT_GT(shift_pin, 2.5);
    EXPECT_GT(shift_pin, 3.0 * shift_k1);
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
