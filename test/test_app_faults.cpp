// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fault injection through the vbme program (doc/reliability.md): kill -9 at random moments
// and rerun (outputs identical to an uninterrupted run, never a partial file under an output
// name), two processes on one work folder, a file-size limit (disk full) while writing EXRs
// and the video, COLMAP crashing or hanging. Tiny inputs: every run takes about a second.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/room.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

#include "app_insert_inputs.hpp"
#include "vbme_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;
using namespace vbme_test;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Starts `sh -c "exec CMD"` in its own process group (so kill -9 reaches its children too).
pid_t spawn(const std::string& cmd, const std::string& output = "/dev/null") {
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::setpgid(0, 0);
        const std::string line = "exec " + cmd + " >'" + output + "' 2>&1";
        ::execl("/bin/sh", "sh", "-c", line.c_str(), (char*)nullptr);
        ::_exit(127);
    }
    return pid;
}

int waitExit(pid_t pid) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

// Kills the process group of @p pid with SIGKILL after @p seconds (or reaps it if it ended).
// Returns true when it was still running.
bool killAfter(pid_t pid, double seconds) {
    const auto until = Clock::now() + std::chrono::duration<double>(seconds);
    int status = 0;
    while (Clock::now() < until) {
        if (::waitpid(pid, &status, WNOHANG) == pid) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ::kill(-pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    return true;
}

// Every file under an output name in @p frames_dir (frame_%05d.png) is complete: it decodes to
// the reference frame of the same name.
void expectFramesComplete(const std::string& frames_dir, const std::string& ref_dir,
                          const std::string& what) {
    if (!fs::exists(frames_dir)) return;
    for (const auto& e : fs::directory_iterator(frames_dir)) {
        const std::string name = e.path().filename().string();
        if (name.rfind("frame_", 0) != 0 || e.path().extension() != ".png" ||
            name.find(".partial") != std::string::npos)
            continue;
        const Mat got = imread(e.path().string(), IMREAD_UNCHANGED);
        const Mat want = imread(ref_dir + "/" + name, IMREAD_UNCHANGED);
        EXPECT_TRUE(!got.empty() && sameImage(got, want)) << what << ": " << name;
    }
}

TEST(AppFaults, InsertKilledAtRandomMomentsResumesToIdenticalOutput) {
    vbme_test::ScratchDir dir;
    const FaultInputs in = makeFaultInputs(dir, Size(48, 36), 4);
    // the uninterrupted run, and how long it takes
    const std::string ref_out = dir / "ref.mkv", ref_work = dir / "ref_work";
    vbme_test::RunResult r;
    const double t_ref = secondsOf([&] { r = vbme_test::run(insertCmd(in, ref_out, ref_work)); });
    ASSERT_EQ(r.code, 0) << r.output;
    const std::vector<Mat> ref_video = videoFrames(ref_out);
    ASSERT_EQ(ref_video.size(), 4u);
    std::printf("uninterrupted vbme insert: %.2f s\n", t_ref);
    int killed = 0;
    for (int seed : {1, 2, 3, 4}) {
        const std::string out = dir / format("out%d.mkv", seed),
                          work = dir / format("work%d", seed);
        std::mt19937 rng(seed);
        // one or two kills at random moments, then a run to the end
        const int kills = 1 + seed % 2;
        for (int k = 0; k < kills; ++k) {
            const double at = std::uniform_real_distribution<double>(0.02, 0.98)(rng) * t_ref;
            const bool was_running = killAfter(spawn(insertCmd(in, out, work)), at);
            killed += was_running;
            std::printf("seed %d: kill -9 at %.3f s (%s)\n", seed, at,
                        was_running ? "killed" : "had finished");
            // nothing under an output name is partial
            expectFramesComplete(work + "/frames", ref_work + "/frames",
                                 format("seed %d after the kill", seed));
            if (fs::exists(out)) {
                const std::vector<Mat> v = videoFrames(out);
                ASSERT_EQ(v.size(), ref_video.size()) << "a partial video under " << out;
            }
        }
        // the rerun (unless the kill came after the video was renamed into place: then the
        // run was complete and a rerun would rightly refuse to overwrite it)
        if (!fs::exists(out)) {
            r = vbme_test::run(insertCmd(in, out, work));
            ASSERT_EQ(r.code, 0) << r.output;
        }
        const std::vector<Mat> v = videoFrames(out);
        ASSERT_EQ(v.size(), ref_video.size());
        for (size_t i = 0; i < v.size(); ++i)
            EXPECT_TRUE(sameImage(v[i], ref_video[i])) << "seed " << seed << " frame " << i;
        expectFramesComplete(work + "/frames", ref_work + "/frames", "after the rerun");
    }
    EXPECT_GE(killed, 2) << "the kills came too late to interrupt anything";
}

TEST(AppFaults, MaterialEditKilledLeavesNoPartialOutputAndRerunIsIdentical) {
    vbme_test::ScratchDir dir;
    // a ball moving over a gradient, and its first-frame mask
    fs::create_directories(dir / "clip");
    for (int i = 0; i < 4; ++i) {
        Mat img(Size(64, 48), CV_8UC3);
        for (int y = 0; y < img.rows; y++)
            for (int x = 0; x < img.cols; x++)
                img.at<Vec3b>(y, x) = Vec3b(90 + x, 100 + y, 95 + ((x / 8 + y / 8) % 2) * 20);
        circle(img, Point(18 + 4 * i, 24), 8, Scalar(20, 110, 240), FILLED);
        imwrite(dir / format("clip/%05d.png", i), img);
    }
    Mat mask = Mat::zeros(Size(64, 48), CV_8U);
    circle(mask, Point(18, 24), 8, Scalar(255), FILLED);
    imwrite(dir / "first.png", mask);
    auto cmd = [&](const std::string& out) {
        return std::string(VBME_EXE) + " material-edit --quiet --threads 1 --video " +
               (dir / "clip") + " --mask " + (dir / "first.png") + " --material chrome --out " +
               out;
    };
    vbme_test::RunResult r;
    const std::string ref = dir / "ref.mkv";
    const double t_ref = secondsOf([&] { r = vbme_test::run(cmd(ref)); });
    ASSERT_EQ(r.code, 0) << r.output;
    const std::vector<Mat> ref_video = videoFrames(ref);
    ASSERT_EQ(ref_video.size(), 4u);
    int killed = 0;
    for (int seed : {1, 2, 3}) {
        const std::string out = dir / format("out%d.mkv", seed);
        std::mt19937 rng(seed);
        const double at = std::uniform_real_distribution<double>(0.02, 0.98)(rng) * t_ref;
        const bool was_running = killAfter(spawn(cmd(out)), at);
        killed += was_running;
        // nothing under the output name is partial: a kill that lands after the rename (the
        // process still tearing down, slow under sanitizers) leaves the complete video
        if (fs::exists(out)) {
            const std::vector<Mat> v = videoFrames(out);
            ASSERT_EQ(v.size(), ref_video.size()) << "a partial video under " << out;
            for (size_t i = 0; i < v.size(); ++i)
                EXPECT_TRUE(sameImage(v[i], ref_video[i]))
                    << "seed " << seed << " frame " << i << " of the video left by the kill";
            fs::remove(out);
        }
        r = vbme_test::run(cmd(out));
        ASSERT_EQ(r.code, 0) << r.output;
        const std::vector<Mat> v = videoFrames(out);
        ASSERT_EQ(v.size(), ref_video.size());
        for (size_t i = 0; i < v.size(); ++i)
            EXPECT_TRUE(sameImage(v[i], ref_video[i])) << "seed " << seed << " frame " << i;
    }
    EXPECT_GE(killed, 2);
}

TEST(AppFaults, TwoProcessesOnOneWorkFolderRenderEachFrameOnce) {
    vbme_test::ScratchDir dir;
    const FaultInputs in = makeFaultInputs(dir, Size(48, 36), 6);
    auto r = vbme_test::run(insertCmd(in, dir / "ref.mkv", dir / "ref_work"));
    ASSERT_EQ(r.code, 0) << r.output;
    // the same command twice at once (by mistake), then two halves with overlapping ranges
    for (const auto& ranges : std::vector<std::pair<std::string, std::string>>{
             {"", ""}, {"--frames 0:4", "--frames 2:6"}}) {
        const std::string tag = ranges.first.empty() ? "same" : "split";
        const std::string out = dir / (tag + ".mkv"), work = dir / (tag + "_work");
        const pid_t pa = spawn(insertCmd(in, out, work, ranges.first), dir / "a.txt");
        const pid_t pb = spawn(insertCmd(in, out, work, ranges.second), dir / "b.txt");
        EXPECT_EQ(waitExit(pa), 0) << tag;
        EXPECT_EQ(waitExit(pb), 0) << tag;
        // each frame rendered by exactly one of them
        int rendered = 0;
        for (const char* f : {"a.txt", "b.txt"}) {
            std::ifstream t(dir / f);
            const std::string s((std::istreambuf_iterator<char>(t)),
                                std::istreambuf_iterator<char>());
            int n_total = 0, n_rendered = 0;
            const size_t pos = s.find("frames ");
            ASSERT_NE(pos, std::string::npos) << s;
            int a0, b0;
            ASSERT_EQ(std::sscanf(s.c_str() + pos, "frames %d:%d of %d: %d rendered", &a0, &b0,
                                  &n_total, &n_rendered),
                      4)
                << s;
            rendered += n_rendered;
        }
        EXPECT_EQ(rendered, 6) << tag;
        expectFramesComplete(work + "/frames", dir / "ref_work/frames", tag);
        const std::vector<Mat> v = videoFrames(out), want = videoFrames(dir / "ref.mkv");
        ASSERT_EQ(v.size(), want.size()) << tag;
        for (size_t i = 0; i < v.size(); ++i)
            EXPECT_TRUE(sameImage(v[i], want[i])) << tag << " frame " << i;
    }
}

// RLIMIT_FSIZE stands for a full disk: writes beyond the limit fail with EFBIG (SIGXFSZ is
// ignored, as a shell's trap '' XFSZ passes on through exec). bash counts -f in KiB.
std::string limited(const std::string& cmd, int kbytes) {
    return "bash -c \"trap '' XFSZ; ulimit -f " + std::to_string(kbytes) + "; exec " + cmd + "\"";
}

TEST(AppFaults, DiskFullWhileWritingIsAClearErrorAndTheWorkFolderResumes) {
    vbme_test::ScratchDir dir;
    const FaultInputs in = makeFaultInputs(dir, Size(48, 36), 3);
    auto r = vbme_test::run(insertCmd(in, dir / "ref.mkv", dir / "ref_work"));
    ASSERT_EQ(r.code, 0) << r.output;
    const std::vector<Mat> want = videoFrames(dir / "ref.mkv");
    // limits between the sizes of the files: a frame PNG fits in `fits`, not in `tight`; the
    // per-frame EXRs (~20 float channels) and the video (all frames) do not fit in `fits`
    uintmax_t png_min = UINTMAX_MAX, png_max = 0;
    for (int i = 0; i < 3; ++i) {
        const uintmax_t s = fs::file_size(dir / format("ref_work/frames/frame_%05d.png", i));
        png_min = std::min(png_min, s);
        png_max = std::max(png_max, s);
    }
    const int fits = (int)(png_max / 1024) + 1, tight = (int)(png_min / 1024);
    const uintmax_t video_size = fs::file_size(dir / "ref.mkv");
    std::printf("frame PNGs %ju..%ju bytes, video %ju bytes: limits %d KiB and %d KiB\n", png_min,
                png_max, video_size, fits, tight);
    ASSERT_GE(tight, 1) << "frames too small to test a full disk while writing them";
    ASSERT_GT(video_size, (uintmax_t)fits * 1024) << "the video would fit";
    // (a) the per-frame EXRs (--keep-exr) do not fit, the PNG frames do
    {
        const std::string out = dir / "exr.mkv", work = dir / "exr_work";
        r = vbme_test::run(insertCmd(in, out, work, "--prepare-only"));
        ASSERT_EQ(r.code, 0) << r.output;
        r = vbme_test::run(limited(insertCmd(in, out, work, "--keep-exr"), fits));
        EXPECT_EQ(r.code, 1) << r.output;
        EXPECT_NE(r.output.find(".exr"), std::string::npos) << r.output;
        std::printf("EXR on a full disk: %s", r.output.c_str());
        EXPECT_FALSE(fs::exists(out));
        EXPECT_FALSE(fs::exists(work + "/exr/frame_00000.exr"));  // no partial EXR
        r = vbme_test::run(insertCmd(in, out, work, "--keep-exr"));
        ASSERT_EQ(r.code, 0) << r.output;
        const std::vector<Mat> v = videoFrames(out);
        ASSERT_EQ(v.size(), want.size());
        for (size_t i = 0; i < v.size(); ++i)
            EXPECT_TRUE(sameImage(v[i], want[i])) << "frame " << i;
    }
    // (b) the frame PNGs do not fit: the first fails, none is left half written
    {
        const std::string out = dir / "png.mkv", work = dir / "png_work";
        r = vbme_test::run(insertCmd(in, out, work, "--prepare-only"));
        ASSERT_EQ(r.code, 0) << r.output;
        r = vbme_test::run(limited(insertCmd(in, out, work), tight));
        EXPECT_EQ(r.code, 1) << r.output;
        EXPECT_NE(r.output.find("frame_00000.png"), std::string::npos) << r.output;
        std::printf("frame PNG on a full disk: %s", r.output.c_str());
        EXPECT_FALSE(fs::exists(work + "/frames/frame_00000.png"));
        r = vbme_test::run(insertCmd(in, out, work));
        ASSERT_EQ(r.code, 0) << r.output;
        expectFramesComplete(work + "/frames", dir / "ref_work/frames", "after a full disk");
        const std::vector<Mat> v = videoFrames(out);
        ASSERT_EQ(v.size(), want.size());
        for (size_t i = 0; i < v.size(); ++i)
            EXPECT_TRUE(sameImage(v[i], want[i])) << "frame " << i;
    }
    // (c) the frames fit, the video does not: frames 0-1 first, then frame 2 and the video
    {
        const std::string out = dir / "video.mkv", work = dir / "video_work";
        r = vbme_test::run(insertCmd(in, out, work, "--frames 0:2"));
        ASSERT_EQ(r.code, 0) << r.output;
        r = vbme_test::run(limited(insertCmd(in, out, work, "--frames 2:3"), fits));
        EXPECT_EQ(r.code, 1) << r.output;
        std::printf("video on a full disk: %s", r.output.c_str());
        EXPECT_FALSE(fs::exists(out)) << "a partial video under the output name";
        expectFramesComplete(work + "/frames", dir / "ref_work/frames", "full disk");
        r = vbme_test::run(insertCmd(in, out, work));
        ASSERT_EQ(r.code, 0) << r.output;
        EXPECT_NE(r.output.find("0 rendered, 3 already done"), std::string::npos) << r.output;
        const std::vector<Mat> v = videoFrames(out);
        ASSERT_EQ(v.size(), want.size());
        for (size_t i = 0; i < v.size(); ++i)
            EXPECT_TRUE(sameImage(v[i], want[i])) << "frame " << i;
    }
}

TEST(AppFaults, ColmapCrashingOrHangingNamesTheStageAndTheLog) {
    vbme_test::ScratchDir dir;
    const FaultInputs in = makeFaultInputs(dir, Size(48, 36), 3);
    struct Case {
        const char* name;
        const char* script;
        const char* expect;
    };
    for (const Case& c : {Case{"crash", "kill -SEGV $$", "failed (exit code 139)"},
                          Case{"hang", "exec sleep 120", "did not finish within 2 s"}}) {
        const std::string fake = dir / (std::string("colmap_") + c.name);
        {
            std::ofstream f(fake);
            f << "#!/bin/sh\necho fake colmap $1\n" << c.script << "\n";
        }
        fs::permissions(fake, fs::perms::owner_all);
        const std::string out = dir / (std::string(c.name) + "_cams.yml");
        vbme_test::RunResult r;
        const double t = secondsOf([&] {
            r = vbme_test::run(std::string(VBME_EXE) + " track-camera -q --video " + in.video +
                               " --scene " + in.scene + " --out " + out + " --colmap " + fake +
                               " --colmap-timeout 2");
        });
        EXPECT_EQ(r.code, 1) << r.output;
        EXPECT_NE(r.output.find(c.expect), std::string::npos) << r.output;
        EXPECT_NE(r.output.find("feature_extractor"), std::string::npos) << r.output;
        const size_t at = r.output.find("its output is in ");
        ASSERT_NE(at, std::string::npos) << r.output;
        std::string log = r.output.substr(at + 17);
        log = log.substr(0, log.find_first_of("\n"));
        std::ifstream lf(log);
        const std::string text((std::istreambuf_iterator<char>(lf)),
                               std::istreambuf_iterator<char>());
        EXPECT_NE(text.find("fake colmap feature_extractor"), std::string::npos) << log;
        EXPECT_FALSE(fs::exists(out));
        EXPECT_LT(t, 30.0) << c.name;
        std::printf("%s: %.1f s: %s", c.name, t, r.output.c_str());
    }
}

}  // namespace
