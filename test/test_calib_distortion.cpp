// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The scene that calibrateFrame() makes of a frame filmed through a lens with radial
// distortion: with estimate_distortion it carries k1 (Camera::k1), and the frame's pixels are
// where that camera puts them. Measured on the Blender renders with known barrel distortion of
// test/data/calib_rooms (scripts/blender/calib_rooms.py), against the same calibration with the
// distortion ignored.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/insertion_sequence.hpp>

#include "vbme_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;

struct DistortedRender {
    std::string path;
    Camera cam;  // true K, k1 and rotation (cam_from_world of Blender's world)
};

// The distorted renders of a set of test/data (truth.csv as scripts/blender/calib_rooms.py
// writes it).
std::vector<DistortedRender> distortedRenders(const std::string& set = "calib_rooms") {
    const std::string dir = std::string(VBME_TEST_DATA_DIR) + "/" + set + "/";
    std::ifstream in(dir + "truth.csv");
    std::vector<DistortedRender> out;
    std::string line;
    std::getline(in, line);  // name,kind,width,height,f_px,cx,cy,k1,f35,r00..r22
    while (std::getline(in, line)) {
        const std::vector<std::string> t = vbme_test::csvFields(line);
        if (t.size() != 18 || std::stod(t[7]) == 0) continue;
        DistortedRender r;
        r.path = dir + t[0];
        const double f = std::stod(t[4]);
        r.cam.K = Matx33d(f, 0, std::stod(t[5]), 0, f, std::stod(t[6]), 0, 0, 1);
        r.cam.k1 = std::stod(t[7]);
        r.cam.image_size = Size(std::stoi(t[2]), std::stoi(t[3]));
        for (int k = 0; k < 9; ++k)
            r.cam.R(k / 3, k % 3) = std::stod(t[9 + k]);
        out.push_back(r);
    }
    return out;
}

// The estimated camera's rotation error against the truth: the calibrated world's axes are the
// room's, named by the DESIGN conventions, so the truth's are matched to them by the signed
// axis permutation (a rotation) that brings them closest.
Matx33d rotationError(const Matx33d& R_est, const Matx33d& R_true) {
    Matx33d best_d = Matx33d::eye();
    double best = 1e9;
    const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (const auto& pm : perm)
        for (int s = 0; s < 8; ++s) {
            Matx33d P = Matx33d::zeros();
            for (int i = 0; i < 3; ++i)
                P(pm[i], i) = (s >> i & 1) ? -1 : 1;
            if (determinant(P) < 0) continue;
            const double e = norm(R_est * P - R_true);
            if (e < best) best = e, best_d = R_est * P * R_true.t();
        }
    return best_d;
}

// Pixel error, over a 16 px grid of the frame, of the estimated camera: where it puts the
// point at infinity that the true lens shows at each grid pixel (true ray, estimated rotation
// error, estimated K and k1). Median over the grid.
double gridReprojectionPx(const Camera& est, const Camera& truth) {
    const Matx33d dR = rotationError(est.R, truth.R);
    std::vector<double> err;
    for (int y = 8; y < truth.image_size.height; y += 16)
        for (int x = 8; x < truth.image_size.width; x += 16) {
            const Point2d pu = truth.undistortPixel(Point2d(x, y));
            if (!std::isfinite(pu.x)) continue;
            const Vec3d ray = dR * (truth.K.inv() * Vec3d(pu.x, pu.y, 1));
            if (ray[2] <= 0) continue;
            const Vec3d q = est.K * ray;
            err.push_back(
                norm(est.distortPixel(Point2d(q[0] / q[2], q[1] / q[2])) - Point2d(x, y)));
        }
    if (err.empty()) return 1e9;
    std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
    return err[err.size() / 2];
}

TEST(CalibDistortion, SceneWithK1ReprojectsTheDistortedFrame) {
    const std::vector<DistortedRender> renders = distortedRenders();
    ASSERT_GE(renders.size(), 4u);
    std::vector<double> with_k1, without;
    std::string per_image;
    for (const DistortedRender& r : renders) {
        const Mat img = imread(r.path, IMREAD_COLOR);
        ASSERT_FALSE(img.empty()) << r.path;
        FrameCalibrationOptions opt;
        opt.auto_detect = true;
        opt.camera_height = 1.5;
        double e_k1 = 1e9, e_pin = 1e9;
        try {
            opt.vp.estimate_distortion = true;
            FrameCalibration fc;
            const Scene s = calibrateFrame(img, FrameAnnotation(), opt, &fc);
            EXPECT_EQ(s.camera.k1, fc.k1);  // the scene carries the estimate
            e_k1 = gridReprojectionPx(s.camera, r.cam);
        } catch (const cv::Exception&) {  // refused: counts as failed
        }
        try {
            opt.vp.estimate_distortion = false;
            const Scene s = calibrateFrame(img, FrameAnnotation(), opt);
            EXPECT_EQ(s.camera.k1, 0);
            e_pin = gridReprojectionPx(s.camera, r.cam);
        } catch (const cv::Exception&) {
        }
        with_k1.push_back(e_k1);
        without.push_back(e_pin);
        auto px = [](double e) { return e >= 1e9 ? std::string("refused") : format("%.2f", e); };
        per_image += " " + px(e_k1) + "/" + px(e_pin);
    }
    auto median = [](std::vector<double> v) {
        std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
        return v[v.size() / 2];
    };
    int better = 0;
    for (size_t i = 0; i < with_k1.size(); ++i)
        better += with_k1[i] < without[i];
    std::printf(
        "distorted renders (%d): median grid reprojection error %.2f px with k1 in the scene, "
        "%.2f px ignoring it; with k1 better on %d; per image (with/without):%s\n",
        (int)renders.size(), median(with_k1), median(without), better, per_image.c_str());
    // Measured: median 7.77 px with k1, 22.52 px ignoring it; better on 4 of 6 (one image is
    // refused by both; one whose Manhattan frame is wrong either way is 19.9 vs 17.8 px).
    EXPECT_LT(median(with_k1), 0.5 * median(without));
    EXPECT_GE(2 * better, (int)with_k1.size());
}

// The COLMAP model of a track with k1 describes the video's distorted frames: SIMPLE_RADIAL
// (f, cx, cy, k) whose projection, written here after COLMAP's SimpleRadialCameraModel
// (u = X/Z, v = Y/Z; u += u k (u² + v²), the same for v; x = f u + cx), lands where vbme's
// Camera::projectDistorted() does, after COLMAP's +0.5 pixel-centre shift.
TEST(CalibDistortion, ColmapModelOfAK1TrackIsSimpleRadial) {
    CameraPath path;
    path.K = Matx33d(300, 0, 159.5, 0, 300, 119.5, 0, 0, 1);
    path.k1 = -0.17;
    path.image_size = Size(320, 240);
    path.frames.resize(1);
    path.frames[0].R = Matx33d(0.8, 0, -0.6, 0, 1, 0, 0.6, 0, 0.8);
    path.frames[0].t = Vec3d(0.1, -0.3, 0.5);
    const ColmapModel m = toColmapModel(path);
    const ColmapCamera& c = m.cameras.at(1);
    ASSERT_EQ(c.model, "SIMPLE_RADIAL");
    ASSERT_EQ(c.params.size(), 4u);
    EXPECT_EQ(c.params[3], path.k1);
    const Camera cam = path.camera(0);
    double worst = 0;
    for (double x = -1; x <= 1; x += 0.25)
        for (double y = -0.8; y <= 0.8; y += 0.2) {
            const Vec3d Xw(x, y, 3.0);
            const Vec3d Xc = cam.camFromWorld(Xw);
            double u = Xc[0] / Xc[2], v = Xc[1] / Xc[2];
            const double radial = c.params[3] * (u * u + v * v);
            u += u * radial;
            v += v * radial;
            const Point2d colmap(c.params[0] * u + c.params[1], c.params[0] * v + c.params[2]);
            worst = std::max(worst, norm(colmap - Point2d(0.5, 0.5) - cam.projectDistorted(Xw)));
        }
    EXPECT_LT(worst, 1e-9);
    path.K(1, 1) = 310;  // fx ≠ fy: OPENCV with k1 and zeros
    const ColmapModel mo = toColmapModel(path);
    const ColmapCamera& o = mo.cameras.at(1);
    EXPECT_EQ(o.model, "OPENCV");
    ASSERT_EQ(o.params.size(), 8u);
    EXPECT_EQ(o.params[4], path.k1);
    path.k1 = 0;  // no distortion: PINHOLE as before
    EXPECT_EQ(toColmapModel(path).cameras.at(1).model, "PINHOLE");
}

}  // namespace

// The annotation file carries a known k1 (e.g. from an earlier --distortion k1): the clicked lines
// and room points of a frame filmed through the lens (the synthetic sequence's exact annotation,
// every point moved where a k1 = −0.2 lens shows it) calibrate to the pinhole camera and room
// when the annotation says k1, against the same clicks with k1 left out. Files without k1 read 0
// and an annotation without one is written as before.
TEST(CalibDistortion, AnnotationWithK1CalibratesTheDistortedClicks) {
    vbme_test::ScratchDir tmp;
    SyntheticInsertionSequence::Params p;
    p.size = Size(320, 240);
    p.frames = 1;
    p.texture_size = 16;
    p.click_noise_px = 0;
    const SyntheticInsertionSequence seq(tmp / "seq", p);
    Camera lens = seq.trueScene().camera;
    lens.k1 = -0.2;
    FrameAnnotation ann = seq.annotation();
    auto bend = [&](Point2d& q) { q = lens.distortPixel(q); };
    for (LineGroup& g : ann.lines)
        for (Vec4d& s : g.segments) {
            Point2d a(s[0], s[1]), b(s[2], s[3]);
            bend(a);
            bend(b);
            s = Vec4d(a.x, a.y, b.x, b.y);
        }
    for (auto& kv : ann.room.floor_edges)
        for (Point2d& q : kv.second)
            bend(q);
    for (auto& kv : ann.room.ceiling_edges)
        for (Point2d& q : kv.second)
            bend(q);
    for (auto& c : ann.room.wall_corners)
        for (Point2d& q : c.points)
            bend(q);
    for (auto& l : ann.lights)
        for (Point2d& q : l.polygon)
            bend(q);
    // the file: k1 written and read back; without it, as before
    ann.k1 = lens.k1;
    ann.write(tmp / "k1.yml");
    EXPECT_EQ(FrameAnnotation::read(tmp / "k1.yml").k1, lens.k1);
    seq.annotation().write(tmp / "plain.yml");
    std::ifstream plain_in(tmp / "plain.yml"), orig_in(seq.annotationPath());
    const std::string plain((std::istreambuf_iterator<char>(plain_in)), {});
    const std::string orig((std::istreambuf_iterator<char>(orig_in)), {});
    EXPECT_EQ(plain.find("k1"), std::string::npos);
    EXPECT_EQ(plain, orig);
    EXPECT_EQ(FrameAnnotation::read(seq.annotationPath()).k1, 0.0);

    const Mat grey(p.size, CV_8UC3, Scalar::all(128));
    const Scene truth = seq.trueScene();
    auto errors = [&](const FrameAnnotation& a, double* room_err) {
        const Scene s = calibrateFrame(grey, a, FrameCalibrationOptions());
        *room_err = std::max(norm(s.room.min - truth.room.min, NORM_INF),
                             norm(s.room.max - truth.room.max, NORM_INF));
        EXPECT_EQ(s.camera.k1, a.k1);
        return std::abs(s.camera.K(0, 0) / truth.camera.K(0, 0) - 1);
    };
    double room_k1 = 0, room_ignored = 0;
    const double f_k1 = errors(FrameAnnotation::read(tmp / "k1.yml"), &room_k1);
    FrameAnnotation ignored = ann;
    ignored.k1 = 0;
    const double f_ignored = errors(ignored, &room_ignored);
    std::printf(
        "annotation clicked through a k1 %.2f lens: focal error %.3f %% with the "
        "annotation's k1, %.3f %% ignoring it; worst room face off by %.1f mm, %.1f mm\n",
        lens.k1, 100 * f_k1, 100 * f_ignored, 1000 * room_k1, 1000 * room_ignored);
    EXPECT_LT(f_k1, 0.002);
    EXPECT_LT(room_k1, 0.01);
    EXPECT_GT(f_ignored, 5 * f_k1);
    EXPECT_GT(room_ignored, 5 * room_k1);
}

// Blender's own lens: three of the distorted rooms rendered again with the distortion made by
// Blender's compositor (Movie Distortion, POLYNOMIAL k1, test/data/calib_rooms_lens, made by
// `calib_rooms.py --count 15 --lens compositor --distorted_only 1`) instead of the script's
// resampling (the same scenes, cameras and k1 in test/data/calib_rooms). The plumb-line k1
// estimate of each against the truth (the aim: within 10 %).
TEST(CalibDistortion, BlenderLensK1WithinTenPercent) {
    const std::vector<DistortedRender> lens = distortedRenders("calib_rooms_lens");
    const std::vector<DistortedRender> resampled = distortedRenders();
    ASSERT_EQ(lens.size(), 3u);
    auto k1Error = [](const DistortedRender& r) {
        const Mat img = imread(r.path, IMREAD_COLOR);
        EXPECT_FALSE(img.empty()) << r.path;
        FrameCalibrationOptions opt;
        opt.auto_detect = true;
        opt.camera_height = 1.5;
        opt.vp.estimate_distortion = true;
        try {
            FrameCalibration fc;
            calibrateFrame(img, FrameAnnotation(), opt, &fc);
            return std::abs(fc.k1 / r.cam.k1 - 1);
        } catch (const cv::Exception&) {  // refused: counts as failed
            return 1e9;
        }
    };
    std::vector<double> errs;
    std::string per_image;
    for (const DistortedRender& r : lens) {
        const std::string name = r.path.substr(r.path.rfind('/') + 1);
        double e_resampled = -1;
        for (const DistortedRender& q : resampled)
            if (q.path.substr(q.path.rfind('/') + 1) == name) e_resampled = k1Error(q);
        errs.push_back(k1Error(r));
        per_image += format(" %s k1 %.3f: %.1f %% (resampled %.1f %%);", name.c_str(), r.cam.k1,
                            100 * errs.back(), 100 * e_resampled);
    }
    std::sort(errs.begin(), errs.end());
    std::printf("Blender-lens renders, k1 relative error:%s median %.1f %%\n", per_image.c_str(),
                100 * errs[1]);
    EXPECT_LT(errs[1], 0.10);
}
