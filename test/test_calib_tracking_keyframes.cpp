// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Camera tracking by keyframes + PnP: the keyframe choice on a rendered room with a fast pan, and
// the whole method on a Blender Cycles clip (motion blur, fast pan) with its true cameras,
// against interpolation between the same keyframes.
#include <gtest/gtest.h>

#include <algorithm>
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

namespace {

// Accuracy of a track against the truth, per frame source (SFM, PNP, INTERPOLATED) and over all
// frames (index 3).
struct TrackErrors {
    double ate[4] = {0, 0, 0, 0}, worst[4] = {0, 0, 0, 0}, worst_rot[4] = {0, 0, 0, 0};
    int count[4] = {0, 0, 0, 0};
};

TrackErrors trackErrors(const CameraPath& path, const CameraPath& truth,
                        const std::vector<int>& only = {}) {
    TrackErrors t;
    double se[4] = {0, 0, 0, 0};
    for (int i = 0; i < (int)truth.frames.size(); ++i) {
        if (!only.empty() && std::find(only.begin(), only.end(), i) == only.end()) continue;
        const double e = norm(path.camera(i).center() - truth.camera(i).center());
        const double r = rotationErrorDeg(path.frames[i].R, truth.frames[i].R);
        for (int c : {(int)path.frames[i].source, 3}) {
            se[c] += e * e, ++t.count[c];
            t.worst[c] = std::max(t.worst[c], e);
            t.worst_rot[c] = std::max(t.worst_rot[c], r);
        }
    }
    for (int c = 0; c < 4; ++c)
        t.ate[c] = t.count[c] ? std::sqrt(se[c] / t.count[c]) : 0;
    return t;
}

void printErrors(const char* label, const TrackErrors& t) {
    std::printf("%s\n", label);
    for (int c = 0; c < 4; ++c)
        if (t.count[c])
            std::printf("  %-12s %2d frames: ATE %.3f cm, worst %.3f cm, worst rotation %.3f deg\n",
                        c == 3 ? "all" : CameraPath::sourceName((CameraPath::Source)c).c_str(),
                        t.count[c], 100 * t.ate[c], 100 * t.worst[c], t.worst_rot[c]);
}

}  // namespace

TEST(CalibTracking, KeyframesAndPnPOnBlenderClip) {
    if (vbme_test::run("colmap help").code != 0)
        GTEST_SKIP() << "the colmap program is not installed";
    const fs::path data = fs::path(VBME_TEST_DATA_DIR) / "camtrack_blender";
    const Scene scene = Scene::read((data / "scene.yml").string());
    const CameraPath truth = CameraPath::read((data / "truth.yml").string());
    const std::string clip = (data / "clip.mkv").string();
    const int n = (int)truth.frames.size();
    vbme_test::ScratchDir tmp;
    CameraTrackingOptions opt;
    // COLMAP's feature matching is not repeatable from run to run and about 1 run in 5 gave a
    // distorted keyframe model (doc/vbme_calib_tracking.md). The keyframes' features and matches
    // of such a run (a sweep's run 44: confident, yet ATE 0.61 cm, worst 1.00 cm, 0.186 degrees
    // before the joint adjustment was repeated) are replayed: COLMAP's mapper is repeatable for a
    // database and seed, so this test sees that poor case every time (descriptors and raw
    // matches dropped from the file: the mapper reads neither).
    opt.colmap.database = (data / "poor_keyframe_matches.db").string();
    CameraTrackingReport rep;
    const auto t0 = std::chrono::steady_clock::now();
    const CameraPath path = trackCameraVideo(clip, scene, tmp / "work", opt, &rep);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ((int)path.frames.size(), n);
    // The same COLMAP model (reused) with one pass of the joint adjustment (as before the fix),
    // without the joint adjustment (PnP alone), and with the other frames interpolated instead
    // (the naive baseline).
    opt.joint_passes = 1;
    CameraTrackingReport rep_one;
    const CameraPath one_pass = trackCameraVideo(clip, scene, tmp / "work", opt, &rep_one);
    ASSERT_EQ((int)one_pass.frames.size(), n);
    opt.global_refine = false;
    CameraTrackingReport rep_pnp;
    const CameraPath pnp_only = trackCameraVideo(clip, scene, tmp / "work", opt, &rep_pnp);
    opt.pnp = false;
    CameraTrackingReport rep_interp;
    const CameraPath interp = trackCameraVideo(clip, scene, tmp / "work", opt, &rep_interp);
    ASSERT_EQ((int)pnp_only.frames.size(), n);
    ASSERT_EQ((int)interp.frames.size(), n);

    std::string stages;
    for (const auto& st : rep.stage_seconds)
        stages += format(" %s %.1f s", st.first.c_str(), st.second);
    std::printf(
        "%d frames, %d keyframes: %d SfM, %d PnP (inlier RMS %.3f px, %.0f inliers), %d "
        "interpolated; %.1f s = %.2f s/frame (stages:%s)\n"
        "joint adjustment%s: %d points, %d observations, RMS %.3f px, worst frame %.3f px, "
        "%.3f of the points on the box's faces (median distance %.2f mm); passes moved a frame "
        "by at most (mm):%s\n"
        "confidence: scale spread %.4f (mapper runs:%s), %s\n",
        n, rep.keyframes, rep.registered, rep.pnp, rep.pnp_rms, rep.pnp_inliers, rep.interpolated,
        seconds, seconds / n, stages.c_str(), rep.ba_applied ? "" : " (NOT applied)", rep.ba_points,
        rep.ba_observations, rep.ba_rms, rep.ba_worst_frame_rms, rep.ba_on_face,
        1000 * rep.ba_face_distance,
        [&] {
            std::string t;
            for (double v : rep.ba_pass_moves)
                t += format(" %.1f", 1000 * v);
            return t;
        }()
            .c_str(),
        rep.scale.spread,
        [&] {
            std::string t;
            for (double v : rep.mapper_scale_spreads)
                t += format(" %.4f", v);
            return t;
        }()
            .c_str(),
        rep.confident ? "confident" : ("NOT confident: " + rep.doubt).c_str());
    const TrackErrors e = trackErrors(path, truth), e_pnp = trackErrors(pnp_only, truth),
                      e_one = trackErrors(one_pass, truth);
    std::vector<int> pnp_frames;
    for (int i = 0; i < n; ++i)
        if (path.frames[i].source == CameraPath::PNP) pnp_frames.push_back(i);
    const TrackErrors e_interp = trackErrors(interp, truth, pnp_frames);
    printErrors("keyframes + PnP + joint adjustment:", e);
    printErrors("the same, one pass of the joint adjustment:", e_one);
    printErrors("keyframes + PnP alone (the same COLMAP run):", e_pnp);
    printErrors("the PnP frames interpolated between the same keyframes instead:", e_interp);

    // COLMAP saw only the keyframes, far fewer than the frames; every frame is registered.
    EXPECT_EQ(rep.registered + rep.pnp + rep.interpolated, n);
    EXPECT_EQ(e.count[CameraPath::SFM], rep.registered);
    EXPECT_EQ(e.count[CameraPath::PNP], rep.pnp);
    EXPECT_LE(rep.keyframes, n / 2);
    EXPECT_GE(rep.registered, rep.keyframes - 2);
    EXPECT_GE(rep.pnp, n - rep.keyframes - 3);
    EXPECT_LE(rep.interpolated, 3);
    EXPECT_LE(rep.pnp_rms, 1.0);
    EXPECT_EQ(rep_interp.pnp, 0);
    // The joint adjustment ran and was used, on points spread over the clip.
    EXPECT_TRUE(rep.ba_applied);
    EXPECT_GE(rep.ba_points, 500);
    EXPECT_LE(rep.ba_rms, 0.6);
    EXPECT_GE(rep.ba_on_face, 0.74);         // measured 0.783-0.793 in seven runs
    EXPECT_LE(rep.ba_face_distance, 0.001);  // measured 0.43-0.47 mm
    // The replayed matches give the distorted model (scale spread 0.0217 at seeds 0 and 1,
    // against 0.016-0.0175 for good models): the case under test. Mapping again kept a better one.
    ASSERT_FALSE(rep.mapper_scale_spreads.empty());
    EXPECT_GT(rep.mapper_scale_spreads.front(), opt.max_scale_spread);
    EXPECT_LE(rep.scale.spread, rep.mapper_scale_spreads.front());
    // Accuracy over every frame: the aims (ATE 0.5 cm, no frame worse than 1 cm or 0.2
    // degrees). Measured 0.30 cm, worst 0.82 cm, 0.131 degrees in 3 passes; one pass 0.61 cm,
    // worst 1.00 cm, 0.186 degrees.
    EXPECT_LE(e.ate[3], 0.005);
    EXPECT_LE(e.worst[3], 0.010);
    EXPECT_LE(e.worst_rot[3], 0.2);
    EXPECT_GE(rep.ba_pass_moves.size(), 2u);
    EXPECT_LT(e.ate[3], e_one.ate[3] - 0.002);
    // No worse than PnP alone on the same model (which follows COLMAP's keyframe model), and far
    // better in rotation than interpolation.
    EXPECT_LE(e.ate[3], e_pnp.ate[3] + 0.001);
    EXPECT_LE(e.worst_rot[3], e_pnp.worst_rot[3] + 0.02);
    EXPECT_LT(e.worst_rot[CameraPath::PNP], 0.2 * e_interp.worst_rot[3]);
}

TEST(CalibTracking, KeyframeTrackConfidenceFallsWithAWrongFocalLength) {
    // The annotation's focal length 5 % too long: COLMAP and the adjustment still converge, but
    // the track is centimetres off and its points no longer sit on the room's faces.
    if (vbme_test::run("colmap help").code != 0)
        GTEST_SKIP() << "the colmap program is not installed";
    const fs::path data = fs::path(VBME_TEST_DATA_DIR) / "camtrack_blender";
    Scene scene = Scene::read((data / "scene.yml").string());
    const CameraPath truth = CameraPath::read((data / "truth.yml").string());
    scene.camera.K(0, 0) *= 1.05;
    scene.camera.K(1, 1) *= 1.05;
    vbme_test::ScratchDir tmp;
    CameraTrackingReport rep;
    CameraTrackingOptions opt;
    opt.mapper_retries = 0;  // the model is not at fault here: no time spent mapping again
    const CameraPath path =
        trackCameraVideo((data / "clip.mkv").string(), scene, tmp / "work", opt, &rep);
    const TrackErrors e = trackErrors(path, truth);
    printErrors("focal length 5 % too long:", e);
    std::printf(
        "joint adjustment RMS %.3f px, worst frame %.3f px, %.3f of the points on the "
        "box's faces (median distance %.2f mm); scale spread %.4f; %s\n",
        rep.ba_rms, rep.ba_worst_frame_rms, rep.ba_on_face, 1000 * rep.ba_face_distance,
        rep.scale.spread, rep.confident ? "confident" : ("NOT confident: " + rep.doubt).c_str());
    // measured: ATE 5.0-6.5 cm; the points' median distance to the room's faces 2.72-4.22 mm
    // (0.43-0.44 mm with the true focal length, asserted <= 1 mm in
    // KeyframesAndPnPOnBlenderClip); their
    // share on the faces 0.64-0.71 (0.78-0.79), too close to assert
    EXPECT_GT(e.ate[3], 0.03);                // the track is wrong...
    EXPECT_GT(rep.ba_face_distance, 0.0015);  // ...and says so
    EXPECT_FALSE(rep.confident);
    EXPECT_NE(rep.doubt.find("room's faces"), std::string::npos) << rep.doubt;
}
