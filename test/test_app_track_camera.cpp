// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// `vbme track-camera` errors: plain messages, exit codes, nothing half-written.
#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/vbme/core.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

namespace {

const std::string kVbme = VBME_EXE;

// A 4-frame 64x48 clip and a matching frame-0 scene with a room.
void makeInputs(const vbme_test::ScratchDir& dir, Size scene_size) {
    VideoSink sink(dir / "clip/%05d.png", 10, Size(64, 48));
    for (int i = 0; i < 4; ++i)
        sink.write(Mat(48, 64, CV_8UC3, Scalar(10 * i, 50, 90)));
    sink.close();
    Scene s;
    s.image_size = scene_size;
    s.camera = Camera::fromFocal(60, scene_size);
    s.camera.R = Matx33d(1, 0, 0, 0, 0, -1, 0, 1, 0);
    s.camera.t = -(s.camera.R * Vec3d(0, 0, 1.5));
    s.has_room = true;
    s.room.min = Vec3d(-2, -1, 0);
    s.room.max = Vec3d(2, 4, 2.6);
    s.write(dir / "scene.yml");
}

}  // namespace

// --help is true and does no work: on a complete command line that, run, tries COLMAP (the
// control: here a missing program, exit 1), adding --help prints the usage and exits 0
// without running anything. Usage errors exit 2.
TEST(AppTrackCamera, HelpAndUsage) {
    vbme_test::ScratchDir dir;
    makeInputs(dir, Size(64, 48));
    const std::string cmd = kVbme + " track-camera --video " + (dir / "clip") + " --scene " +
                            (dir / "scene.yml") + " --out " + (dir / "cams.yml") +
                            " --colmap /nonexistent/colmap";
    const auto r = vbme_test::run(cmd);  // control: the command runs and fails on COLMAP
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("error:"), std::string::npos) << r.output;
    const auto h = vbme_test::run(cmd + " --help");
    EXPECT_EQ(h.code, 0) << h.output;
    EXPECT_NE(h.output.find("Usage:"), std::string::npos) << h.output;
    EXPECT_EQ(h.output.find("error:"), std::string::npos) << "--help ran the command";
    EXPECT_FALSE(fs::exists(dir / "cams.yml"));
    EXPECT_EQ(vbme_test::run(kVbme + " track-camera --video a.mp4").code, 2);  // missing options
    EXPECT_EQ(vbme_test::run(cmd + " --stride 0").code, 2);                    // out of range
}

TEST(AppTrackCamera, MissingColmapIsAPlainErrorAndWritesNoTrack) {
    vbme_test::ScratchDir dir;
    makeInputs(dir, Size(64, 48));
    const auto r = vbme_test::run(kVbme + " track-camera -q --video " + (dir / "clip") +
                                  " --scene " + (dir / "scene.yml") + " --out " +
                                  (dir / "cams.yml") + " --colmap /nonexistent/colmap");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.output.find("colmap program"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "cams.yml"));
    EXPECT_FALSE(fs::exists(dir / "cams_colmap"));
}

TEST(AppTrackCamera, AnnotationOfAnotherSizeIsRejected) {
    vbme_test::ScratchDir dir;
    makeInputs(dir, Size(640, 480));
    const auto r =
        vbme_test::run(kVbme + " track-camera -q --video " + (dir / "clip") + " --scene " +
                       (dir / "scene.yml") + " --out " + (dir / "cams.yml"));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.output.find("640x480"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "cams.yml"));
}

TEST(AppTrackCamera, MissingSceneIsBadInput) {
    vbme_test::ScratchDir dir;
    makeInputs(dir, Size(64, 48));
    const auto r =
        vbme_test::run(kVbme + " track-camera -q --video " + (dir / "clip") + " --scene " +
                       (dir / "none.yml") + " --out " + (dir / "cams.yml"));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.output.find("none.yml"), std::string::npos) << r.output;
}

#if __has_include(<opencv2/vbme/calib.hpp>)
#include <chrono>
#include <fstream>

#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

TEST(AppTrackCamera, TracksAVideoWithStrideAndResumes) {
    if (vbme_test::run("colmap help").code != 0)
        GTEST_SKIP() << "the colmap program is not installed";
    vbme_test::ScratchDir dir;
    // A 24-frame hand-held walk in a textured room, as a lossless video, and its true frame-0
    // scene.
    const Scene s0 = syntheticRoomScene();
    const Camera first = s0.camera;
    s0.write(dir / "frame0.yml");
    const int n = 24;
    const std::vector<Camera> truth = handheldCameraPath(first, n, 1.0, 0.01, 0.4, 9);
    const auto textures = makeRoomTextures(4, 512);
    {
        VideoSink sink(dir / "walk.mkv", 24, s0.image_size);
        for (int i = 0; i < n; ++i)
            sink.write(renderTexturedRoom(truth[i], s0.room, textures, 2));
        sink.close();
    }
    const std::string cmd = kVbme + " track-camera -q --video " + (dir / "walk.mkv") + " --scene " +
                            (dir / "frame0.yml") + " --out " + (dir / "cams.yml") +
                            " --stride 2 --overlay " + (dir / "overlay.mp4") + " --blender " +
                            (dir / "track.py");
    auto t0 = std::chrono::steady_clock::now();
    const auto r1 = vbme_test::run(cmd);
    const double first_run =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ(r1.code, 0) << r1.output;
    const CameraPath path = CameraPath::read(dir / "cams.yml");
    ASSERT_EQ(path.frames.size(), (size_t)n);
    // --stride 2: keyframes are the even frames; the odd ones are registered by PnP.
    double ate2[2] = {0, 0};
    for (int i = 0; i < n; ++i) {
        EXPECT_EQ(path.frames[i].source, i % 2 ? CameraPath::PNP : CameraPath::SFM) << i;
        ate2[i % 2] += std::pow(norm(path.camera(i).center() - truth[i].center()), 2);
    }
    const double ate_sfm = std::sqrt(ate2[0] / (n / 2)), ate_pnp = std::sqrt(ate2[1] / (n / 2));
    std::printf("stride 2: ATE %.2f cm on reconstructed frames, %.2f cm on PnP ones\n",
                ate_sfm * 100, ate_pnp * 100);
    EXPECT_LT(ate_sfm, 0.02) << r1.output;
    EXPECT_LT(ate_pnp, 0.02) << r1.output;
    for (const char* f : {"cams_report.yml", "cams_colmap/images.txt", "overlay.mp4", "track.py"})
        EXPECT_TRUE(fs::exists(dir / f)) << f;
    // The report counts what the track says and times the stages.
    {
        FileStorage rf(dir / "cams_report.yml", FileStorage::READ);
        EXPECT_EQ((int)rf["keyframes"], n / 2);
        EXPECT_EQ((int)rf["registered"], n / 2);
        EXPECT_EQ((int)rf["pnp"], n / 2);
        EXPECT_EQ((int)rf["interpolated"], 0);
        EXPECT_GT((double)rf["pnp_rms_px"], 0.0);
        EXPECT_FALSE(rf["stage_seconds"]["mapper"].empty());
        EXPECT_FALSE(rf["stage_seconds"]["pnp"].empty());
        EXPECT_GT((double)rf["stage_cpu_seconds"]["feature_extractor"], 0.0);
        EXPECT_FALSE(rf["stage_cpu_seconds"]["joint_adjustment"].empty());
        // every frame adjusted jointly, consistently with the room
        EXPECT_EQ((int)rf["joint_adjustment_applied"], 1);
        EXPECT_GT((double)rf["joint_rms_px"], 0.0);
        EXPECT_LT((double)rf["joint_rms_px"], 0.5);
        EXPECT_GT((double)rf["joint_points_on_box_faces"], 0.75);  // measured 0.86
    }
    EXPECT_NE(r1.output.find("by PnP"), std::string::npos) << r1.output;

    // Again, forced: the work folder's frames and COLMAP run are reused, the result is the same.
    std::ifstream a(dir / "cams.yml");
    const std::string before((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
    t0 = std::chrono::steady_clock::now();
    const auto r2 = vbme_test::run(cmd + " --force");
    const double second_run =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ(r2.code, 0) << r2.output;
    std::ifstream b(dir / "cams.yml");
    const std::string after((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
    EXPECT_EQ(before, after);
    std::printf("first run %.1f s, resumed run %.1f s\n", first_run, second_run);
    // the COLMAP run was reused, not redone (a time bound said so before the joint adjustment,
    // which is not cached, made the resumed run's time depend on the machine's load)
    FileStorage rf(dir / "cams_report.yml", FileStorage::READ);
    ASSERT_TRUE(rf.isOpened());
    EXPECT_FALSE(rf["stage_seconds"]["colmap__reused_"].empty());
    EXPECT_TRUE(rf["stage_seconds"]["feature_extractor"].empty());
    EXPECT_TRUE(rf["stage_seconds"]["mapper"].empty());
}
#endif
