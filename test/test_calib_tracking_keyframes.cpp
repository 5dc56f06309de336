// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Camera tracking by keyframes + PnP: the keyframe choice on a rendered room with a fast pan, and
// the whole method on a Blender Cycles clip (motion blur, fast pan) with its true cameras,
// against interpolation between the same keyframes.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib/camera_tracking.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

namespace {

double rotationErrorDeg(const Matx33d& a, const Matx33d& b) {
    const Matx33d d = a * b.t();
    const double c = std::max(-1.0, std::min(1.0, (d(0, 0) + d(1, 1) + d(2, 2) - 1) / 2));
    return std::acos(c) * 180 / CV_PI;
}

// A camera at @p centre turned @p yaw (radians, to the left) from looking along +y, pitched down.
Camera lookingAt(const Camera& first, const Vec3d& centre, double yaw) {
    Camera c = first;
    const double pitch = 0.25;
    const Vec3d z(-std::sin(yaw) * std::cos(pitch), std::cos(yaw) * std::cos(pitch),
                  -std::sin(pitch));
    const Vec3d x = normalize(z.cross(Vec3d(0, 0, 1))), y = z.cross(x);
    c.R = Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
    c.t = -(c.R * centre);
    return c;
}

}  // namespace

TEST(CalibKeyframes, DenserWhereTheCameraPansFast) {
    // 20 frames of a slow walk (5 mm per frame), a 60-degree pan over 10 frames, 20 slow frames.
    const Scene s0 = syntheticRoomScene(Size(320, 180), 250);
    const auto textures = makeRoomTextures(3, 512);
    std::vector<Mat> gray;
    const int slow = 20, pan = 10, n = 2 * slow + pan;
    for (int i = 0; i < n; ++i) {
        const double yaw = CV_PI / 3 * std::min(1.0, std::max(0.0, double(i - slow) / pan));
        const Camera c = lookingAt(s0.camera, Vec3d(0.005 * i, 0.004 * i, 1.5), yaw);
        Mat g;
        cvtColor(renderTexturedRoom(c, s0.room, textures, 1), g, COLOR_BGR2GRAY);
        gray.push_back(g);
    }
    const std::vector<int> keys = selectKeyframes(gray);
    ASSERT_GE(keys.size(), 3u);
    EXPECT_EQ(keys.front(), 0);
    EXPECT_EQ(keys.back(), n - 1);
    EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));
    int in_pan = 0, in_slow = 0;
    for (int k : keys)
        (k > slow && k <= slow + pan ? in_pan : in_slow) += 1;
    std::string list;
    for (int k : keys)
        list += " " + std::to_string(k);
    std::printf("keyframes:%s (%d in the %d pan frames, %d in the %d slow ones)\n", list.c_str(),
                in_pan, pan, in_slow, 2 * slow);
    // A fixed stride with as many keyframes would put about one in four of them in the pan.
    EXPECT_GE(in_pan, 3);
    EXPECT_GT(double(in_pan) / pan, 3.0 * in_slow / (2 * slow)) << list;
    EXPECT_LE(keys.size(), (size_t)n / 2);
    // A fixed stride, when asked for.
    KeyframeOptions fixed;
    fixed.stride = 7;
    EXPECT_EQ(selectKeyframes(gray, fixed), (std::vector<int>{0, 7, 14, 21, 28, 35, 42, 49}));
}

TEST(CalibTracking, KeyframesAndPnPOnBlenderClip) {
    if (vbme_test::run("colmap help").code != 0)
        GTEST_SKIP() << "the colmap program is not installed";
    const fs::path data = fs::path(VBME_TEST_DATA_DIR) / "camtrack_blender";
    const Scene scene = Scene::read((data / "scene.yml").string());
    const CameraPath truth = CameraPath::read((data / "truth.yml").string());
    const int n = (int)truth.frames.size();
    vbme_test::ScratchDir tmp;
    CameraTrackingOptions opt;
    CameraTrackingReport rep;
    const auto t0 = std::chrono::steady_clock::now();
    const CameraPath path =
        trackCameraVideo((data / "clip.mkv").string(), scene, tmp / "work", opt, &rep);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ((int)path.frames.size(), n);
    // The same keyframes, the other frames interpolated (COLMAP's run reused): the baseline.
    opt.pnp = false;
    CameraTrackingReport rep_interp;
    const CameraPath interp =
        trackCameraVideo((data / "clip.mkv").string(), scene, tmp / "work", opt, &rep_interp);
    ASSERT_EQ((int)interp.frames.size(), n);

    double se[3] = {0, 0, 0}, worst[3] = {0, 0, 0}, worst_rot[3] = {0, 0, 0};
    int count[3] = {0, 0, 0};
    double se_base = 0, worst_base = 0, worst_rot_base = 0;  // interpolation on the PnP frames
    for (int i = 0; i < n; ++i) {
        const int src = path.frames[i].source;
        const double e = norm(path.camera(i).center() - truth.camera(i).center());
        const double r = rotationErrorDeg(path.frames[i].R, truth.frames[i].R);
        se[src] += e * e, ++count[src];
        worst[src] = std::max(worst[src], e);
        worst_rot[src] = std::max(worst_rot[src], r);
        if (src == CameraPath::PNP) {
            const double eb = norm(interp.camera(i).center() - truth.camera(i).center());
            se_base += eb * eb;
            worst_base = std::max(worst_base, eb);
            worst_rot_base =
                std::max(worst_rot_base, rotationErrorDeg(interp.frames[i].R, truth.frames[i].R));
        }
    }
    std::string stages;
    for (const auto& st : rep.stage_seconds)
        stages += format(" %s %.1f s", st.first.c_str(), st.second);
    std::printf(
        "%d frames, %d keyframes: %d SfM, %d PnP (inlier RMS %.3f px, %.0f inliers), %d "
        "interpolated; %.1f s = %.2f s/frame (stages:%s)\n",
        n, rep.keyframes, rep.registered, rep.pnp, rep.pnp_rms, rep.pnp_inliers, rep.interpolated,
        seconds, seconds / n, stages.c_str());
    for (int src = 0; src < 3; ++src)
        if (count[src])
            std::printf("  %-12s %2d frames: ATE %.3f cm, worst %.3f cm, worst rotation %.3f deg\n",
                        CameraPath::sourceName((CameraPath::Source)src).c_str(), count[src],
                        100 * std::sqrt(se[src] / count[src]), 100 * worst[src], worst_rot[src]);
    if (count[CameraPath::PNP])
        std::printf(
            "  the PnP frames interpolated between the same keyframes instead: ATE %.3f "
            "cm, worst %.3f cm, worst rotation %.3f deg\n",
            100 * std::sqrt(se_base / count[CameraPath::PNP]), 100 * worst_base, worst_rot_base);

    // COLMAP saw only the keyframes, far fewer than the frames; every frame is registered.
    EXPECT_EQ(rep.registered + rep.pnp + rep.interpolated, n);
    EXPECT_EQ(count[CameraPath::SFM], rep.registered);
    EXPECT_EQ(count[CameraPath::PNP], rep.pnp);
    EXPECT_LE(rep.keyframes, n / 2);
    EXPECT_GE(rep.registered, rep.keyframes - 2);
    EXPECT_GE(rep.pnp, n - rep.keyframes - 3);
    EXPECT_LE(rep.interpolated, 3);
    // The aims (every frame within 0.5 cm RMS, none worse than 1 cm or 0.2 degrees) are
    // NOT reached on this clip: COLMAP's 10-keyframe model itself is 1-5 cm off, differently in
    // every run (see doc/vbme_calib_tracking.md). Asserted here, what holds across runs: a track
    // in the room (10 cm, 2 degrees), PnP frames as good as the keyframes they hang on, and PnP
    // following the hand's rotation where interpolation between the same keyframes cannot.
    for (int src : {CameraPath::SFM, CameraPath::PNP}) {
        ASSERT_GT(count[src], 0) << src;
        EXPECT_LE(std::sqrt(se[src] / count[src]), 0.10) << src;
        EXPECT_LE(worst_rot[src], 2.0) << src;
    }
    EXPECT_LE(rep.pnp_rms, 1.0);
    EXPECT_LE(std::sqrt(se[CameraPath::PNP] / count[CameraPath::PNP]),
              1.2 * std::sqrt(se[CameraPath::SFM] / count[CameraPath::SFM]) + 0.002);
    EXPECT_LE(worst_rot[CameraPath::PNP], 1.2 * worst_rot[CameraPath::SFM] + 0.05);
    EXPECT_LT(worst_rot[CameraPath::PNP], 0.5 * worst_rot_base);
    EXPECT_EQ(rep_interp.pnp, 0);
}
