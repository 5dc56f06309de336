// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// `vbme track` as a user runs it: outputs, exit codes, messages, nothing half-written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/datasets/ball_clip.hpp>
#include <opencv2/vbme/track.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

namespace {

const std::string kVbme = VBME_EXE;

// A short lossless clip as a PNG sequence, and its true first-frame mask.
struct Clip {
    std::string frames, mask;
    SyntheticBallClip clip;
    explicit Clip(const vbme_test::ScratchDir& dir, int n = 8)
        : clip([n] {
              SyntheticBallClip::Params p;
              p.size = Size(320, 240);
              p.frames = 60;  // the motion of a 60-frame clip; only the first n are written
              return p;
          }()) {
        frames = dir / "frames";
        VideoSink sink(frames + "/f%05d.png", 25, clip.params().size);
        for (int i = 0; i < n; ++i) sink.write(clip.frame(i));
        sink.close();
        Mat m;
        diskMask(clip.params().size, clip.truth(0), m);
        mask = dir / "mask.png";
        imwrite(mask, m);
    }
};

std::string slurp(const std::string& path) {
    std::ifstream f(path);
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

}  // namespace

// --help is true and takes precedence: on a command line that works (the control below runs
// it and gets its outputs), adding --help prints the usage, exits 0 and does none of the work.
TEST(AppTrack, HelpTakesPrecedenceAndDoesNoWork) {
    vbme_test::ScratchDir dir;
    Clip c(dir, 2);
    const std::string out = dir / "out";
    const std::string cmd =
        kVbme + " track --video " + c.frames + " --mask " + c.mask + " --out " + out + " --quiet";
    const auto h = vbme_test::run(cmd + " --help");
    EXPECT_EQ(h.code, 0) << h.output;
    EXPECT_NE(h.output.find("Usage:"), std::string::npos) << h.output;
    EXPECT_FALSE(fs::exists(out)) << "--help wrote outputs";
    const auto r = vbme_test::run(cmd);  // control: the same line without --help does the work
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(fs::exists(out + "/track.csv"));
}

TEST(AppTrack, UsageErrorsExitTwo) {
    EXPECT_EQ(vbme_test::run(kVbme + " track --video x.mp4").code, 2);                  // missing options
    EXPECT_EQ(vbme_test::run(kVbme + " track --video a --mask b --out c --threshold 3").code, 2);
    EXPECT_EQ(vbme_test::run(kVbme + " track --video a --mask b --out c --bogus").code, 2);
    EXPECT_EQ(vbme_test::run(kVbme + " nosuchcommand").code, 2);
    EXPECT_EQ(vbme_test::run(kVbme).code, 2);
    EXPECT_EQ(vbme_test::run(kVbme + " --version").code, 0);
}

TEST(AppTrack, TracksAClipAndWritesMasksCsvAndOverlay) {
    vbme_test::ScratchDir dir;
    Clip c(dir);
    const std::string out = dir / "out", overlay = dir / "overlay.mp4";
    // Both option forms: --opt value and --opt=value.
    const auto r = vbme_test::run(kVbme + " track --video " + c.frames + " --mask=" + c.mask + " --out " + out +
                                  " --overlay=" + overlay + " --quiet");
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string csv = slurp(out + "/track.csv");
    EXPECT_EQ(csv.rfind("frame,cx,cy,r,confidence\n", 0), 0u);
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 9);
    for (int i = 0; i < 8; ++i) {
        Mat m = imread(out + "/" + maskFileName(i), IMREAD_UNCHANGED), truth;
        ASSERT_FALSE(m.empty()) << i;
        EXPECT_EQ(m.type(), CV_8UC1);
        diskMask(m.size(), c.clip.truth(i), truth);
        EXPECT_GT(maskIoU(m, truth), 0.9) << i;
    }
    VideoReader ov(overlay);
    Mat f;
    int n = 0;
    while (ov.read(f)) ++n;
    EXPECT_EQ(n, 8);
    EXPECT_NEAR(ov.fps(), 25, 1e-6);
    // Nothing staged is left behind.
    for (const auto& e : fs::directory_iterator(dir.path()))
        EXPECT_EQ(e.path().filename().string().find(".partial-"), std::string::npos) << e.path();
}

TEST(AppTrack, RefusesToOverwriteWithoutForce) {
    vbme_test::ScratchDir dir;
    Clip c(dir, 3);
    const std::string cmd = kVbme + " track -q --video " + c.frames + " --mask " + c.mask + " --out " + (dir / "out");
    ASSERT_EQ(vbme_test::run(cmd).code, 0);
    const auto again = vbme_test::run(cmd);
    EXPECT_EQ(again.code, 1);
    EXPECT_NE(again.output.find("--force"), std::string::npos) << again.output;
    EXPECT_EQ(vbme_test::run(cmd + " --force").code, 0);
}

// A failed run prints why, exits 1, and leaves no output folder, overlay or staging folder.
static void expectCleanFailure(const vbme_test::ScratchDir& dir, const std::string& args, const std::string& words) {
    const auto r = vbme_test::run(kVbme + " track -q " + args + " --out " + (dir / "out") + " --overlay " + (dir / "o.mp4"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find(words), std::string::npos) << "expected '" << words << "' in: " << r.output;
    EXPECT_FALSE(fs::exists(dir / "out"));
    EXPECT_FALSE(fs::exists(dir / "o.mp4"));
    for (const auto& e : fs::directory_iterator(dir.path()))
        EXPECT_EQ(e.path().filename().string().find("partial"), std::string::npos) << e.path();
}

TEST(AppTrack, BadInputFailsCleanly) {
    vbme_test::ScratchDir dir;
    Clip c(dir, 3);
    expectCleanFailure(dir, "--video " + (dir / "missing.mp4") + " --mask " + c.mask, "does not exist");
    std::ofstream(dir / "junk.mp4") << "this is not a video";
    expectCleanFailure(dir, "--video " + (dir / "junk.mp4") + " --mask " + c.mask, "junk.mp4");
    expectCleanFailure(dir, "--video " + c.frames + " --mask " + (dir / "nomask.png"), "does not exist");

    const Size size = c.clip.params().size;
    imwrite(dir / "empty.png", Mat(size, CV_8UC1, Scalar(0)));
    expectCleanFailure(dir, "--video " + c.frames + " --mask " + (dir / "empty.png"), "no object pixel");
    imwrite(dir / "full.png", Mat(size, CV_8UC1, Scalar(255)));
    expectCleanFailure(dir, "--video " + c.frames + " --mask " + (dir / "full.png"), "every pixel");
    imwrite(dir / "small.png", Mat(100, 100, CV_8UC1, Scalar(255)));
    expectCleanFailure(dir, "--video " + c.frames + " --mask " + (dir / "small.png"), "100x100");
    std::ofstream(dir / "params.yml") << "%YAML:1.0\ntracker: { threshold: 7 }\n";
    expectCleanFailure(dir, "--video " + c.frames + " --mask " + c.mask + " --params " + (dir / "params.yml"), "threshold");
}

TEST(AppTrack, CorruptFrameMidVideoLeavesNothing) {
    vbme_test::ScratchDir dir;
    Clip c(dir, 6);
    std::ofstream(c.frames + "/f00003.png", std::ios::trunc) << "truncated";
    expectCleanFailure(dir, "--video " + c.frames + " --mask " + c.mask, "f00003.png");
}
