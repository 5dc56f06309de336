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

TEST(AppTrackCamera, HelpAndUsage) {
    const auto r = vbme_test::run(kVbme + " track-camera --help");
    EXPECT_EQ(r.code, 0);
    for (const char* opt :
         {"--video", "--scene", "--out", "--work", "--stride", "--overlay", "--colmap", "--force"})
        EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
    EXPECT_EQ(vbme_test::run(kVbme + " track-camera --video a.mp4").code, 2);
    EXPECT_EQ(vbme_test::run(kVbme + " track-camera --video a --scene b --out c --stride 0").code,
              2);
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
