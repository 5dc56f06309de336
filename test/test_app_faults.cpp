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
#include <map>
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
#include "video_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;
using namespace vbme_test;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The smallest textured-room walk that COLMAP tracks here (measured: see
// doc/reliability.md): kTrackClipFrames frames of kTrackClipWidth x kTrackClipHeight, a
// keyframe every kTrackClipStride-th frame.
constexpr int kTrackClipWidth = 160, kTrackClipHeight = 120, kTrackClipFrames = 12,
              kTrackClipStride = 2;

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
    const std::vector<Mat> ref_video = vbme_test::readVideoFrames(ref_out);
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
                const std::vector<Mat> v = vbme_test::readVideoFrames(out);
                ASSERT_EQ(v.size(), ref_video.size()) << "a partial video under " << out;
            }
        }
        // the rerun (unless the kill came after the video was renamed into place: then the
        // run was complete and a rerun would rightly refuse to overwrite it)
        if (!fs::exists(out)) {
            r = vbme_test::run(insertCmd(in, out, work));
            ASSERT_EQ(r.code, 0) << r.output;
        }
        const std::vector<Mat> v = vbme_test::readVideoFrames(out);
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
    const std::vector<Mat> ref_video = vbme_test::readVideoFrames(ref);
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
            const std::vector<Mat> v = vbme_test::readVideoFrames(out);
            ASSERT_EQ(v.size(), ref_video.size()) << "a partial video under " << out;
            for (size_t i = 0; i < v.size(); ++i)
                EXPECT_TRUE(sameImage(v[i], ref_video[i]))
                    << "seed " << seed << " frame " << i << " of the video left by the kill";
            fs::remove(out);
        }
        r = vbme_test::run(cmd(out));
        ASSERT_EQ(r.code, 0) << r.output;
        const std::vector<Mat> v = vbme_test::readVideoFrames(out);
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
        const std::vector<Mat> v = vbme_test::readVideoFrames(out),
                               want = vbme_test::readVideoFrames(dir / "ref.mkv");
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
    const std::vector<Mat> want = vbme_test::readVideoFrames(dir / "ref.mkv");
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
        const std::vector<Mat> v = vbme_test::readVideoFrames(out);
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
        const std::vector<Mat> v = vbme_test::readVideoFrames(out);
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
        const std::vector<Mat> v = vbme_test::readVideoFrames(out);
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

// kill -9 of `vbme track-camera` (COLMAP on a small textured-room walk), at a random moment
// (seeds 1 and 2) and just after COLMAP's run was recorded as finished (seed 3, so that the
// resume of a finished stage is tried too). COLMAP does not repeat itself from run to run even
// with one thread and a fixed seed: here the uninterrupted run and a rerun that redoes COLMAP
// differed by micrometres, and on the CI machine two runs' camera centres differed by 1.3 cm
// (both within the accuracy bound below). So the oracle is: nothing under an output name is
// partial (the track, when present, reads back whole, and so does its report); the rerun
// finishes; a COLMAP run that had finished before the kill is reused, not redone (the rerun
// says "colmap (reused)" and the model's files keep their contents and times), and what is
// made from it is exactly what a further run on the same work directory makes (camera centres
// within 1 um); and every run's track is as accurate as the uninterrupted run must be (camera
// centres within 2 cm RMS of the truth, as in AppTrackCamera.TracksAVideoWithStrideAndResumes).
TEST(AppFaults, TrackCameraKilledAtRandomMomentsResumes) {
    if (vbme_test::run("colmap help").code != 0)
        GTEST_SKIP() << "the colmap program is not installed";
    vbme_test::ScratchDir dir;
    const Size size(kTrackClipWidth, kTrackClipHeight);
    const Scene s0 = syntheticRoomScene(size, 0.8 * size.width);
    s0.write(dir / "frame0.yml");
    const int n = kTrackClipFrames;
    const std::vector<Camera> truth = handheldCameraPath(s0.camera, n, 1.0, 0.01, 0.4, 9);
    const auto textures = makeRoomTextures(4, 256);
    {
        VideoSink sink(dir / "walk.mkv", 24, size);
        for (int i = 0; i < n; ++i)
            sink.write(renderTexturedRoom(truth[i], s0.room, textures, 2));
        sink.close();
    }
    auto cmd = [&](const std::string& tag) {
        return std::string(VBME_EXE) + " track-camera --video " + (dir / "walk.mkv") + " --scene " +
               (dir / "frame0.yml") + " --out " + (dir / (tag + ".yml")) + " --work " +
               (dir / (tag + "_work")) + " --threads 1 --seed 1 --stride " +
               std::to_string(kTrackClipStride);
    };
    // the COLMAP model's files with their contents and modification times
    auto modelFiles = [](const std::string& work) {
        std::map<std::string, std::pair<std::string, fs::file_time_type>> files;
        std::error_code ec;
        for (const auto& e : fs::recursive_directory_iterator(work + "/sparse_txt", ec)) {
            if (!e.is_regular_file()) continue;
            std::ifstream f(e.path());
            files[e.path().string()] = {
                std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>()),
                e.last_write_time()};
        }
        return files;
    };
    // the uninterrupted run
    vbme_test::RunResult r;
    const double t_ref = secondsOf([&] { r = vbme_test::run(cmd("ref")); });
    ASSERT_EQ(r.code, 0) << r.output;
    const CameraPath ref = CameraPath::read(dir / "ref.yml");
    ASSERT_EQ(ref.frames.size(), (size_t)n);
    // it tracks: the camera centres within 2 cm of the truth, as in the tracking test
    auto ateOf = [&](const CameraPath& p) {
        double ate2 = 0;
        for (int i = 0; i < n; ++i)
            ate2 += std::pow(norm(p.camera(i).center() - truth[i].center()), 2);
        return std::sqrt(ate2 / n);
    };
    const double ate = ateOf(ref);
    EXPECT_LT(ate, 0.02) << r.output;
    std::printf("uninterrupted vbme track-camera: %.2f s, ATE %.2f cm\n", t_ref, ate * 100);
    int killed = 0, reused = 0;
    double worst = 0, worst_ate = 0;
    for (int seed : {1, 2, 3}) {
        const std::string tag = format("run%d", seed), out = dir / (tag + ".yml"),
                          work = dir / (tag + "_work"), report = dir / (tag + "_report.yml"),
                          marker = work + "/colmap_complete.txt";
        std::mt19937 rng(seed);
        const pid_t pid = spawn(cmd(tag));
        double at = 0;
        bool was_running;
        if (seed < 3) {
            at = std::uniform_real_distribution<double>(0.05, 0.8)(rng) * t_ref;
            was_running = killAfter(pid, at);
        } else {  // 0-100 ms after COLMAP's run is recorded as finished
            const auto t0 = Clock::now();
            int status = 0;
            bool ended = false;
            while (!fs::exists(marker) && Clock::now() - t0 < std::chrono::seconds(120))
                if ((ended = ::waitpid(pid, &status, WNOHANG) == pid))
                    break;
                else
                    std::this_thread::sleep_for(std::chrono::milliseconds(2));
            at = std::chrono::duration<double>(Clock::now() - t0).count() +
                 std::uniform_real_distribution<double>(0.0, 0.1)(rng);
            was_running =
                !ended &&
                killAfter(pid, at - std::chrono::duration<double>(Clock::now() - t0).count());
        }
        killed += was_running;
        const bool colmap_done = fs::exists(marker);
        std::printf("seed %d: kill -9 at %.2f s (%s; COLMAP %s)\n", seed, at,
                    was_running ? "killed" : "had finished",
                    colmap_done ? "had finished" : "had not finished");
        // nothing under an output name is partial
        if (fs::exists(out)) {
            EXPECT_EQ(CameraPath::read(out).frames.size(), (size_t)n) << out;
            EXPECT_TRUE(fs::exists(report)) << "the track was written before its report";
        }
        if (fs::exists(report)) {
            FileStorage rf(report, FileStorage::READ);
            EXPECT_EQ((int)rf["frames"], n) << "a partial report under " << report;
        }
        // the rerun finishes (unless the kill came after the track was written: then the run
        // had finished and a rerun would rightly refuse to overwrite it)
        if (!fs::exists(out)) {
            const auto model_before = modelFiles(work);
            r = vbme_test::run(cmd(tag));
            ASSERT_EQ(r.code, 0) << "seed " << seed << ": " << r.output;
            const bool said_reused = r.output.find("colmap (reused)") != std::string::npos;
            EXPECT_EQ(said_reused, colmap_done) << "seed " << seed << ": " << r.output;
            if (colmap_done) {
                EXPECT_FALSE(model_before.empty());
                EXPECT_TRUE(modelFiles(work) == model_before)
                    << "seed " << seed << ": the finished COLMAP run was redone";
            }
            reused += said_reused;
        }
        const CameraPath got = CameraPath::read(out);
        ASSERT_EQ(got.frames.size(), (size_t)n) << "seed " << seed;
        const double got_ate = ateOf(got);
        EXPECT_LT(got_ate, 0.02) << "seed " << seed;
        worst_ate = std::max(worst_ate, got_ate);
        for (int i = 0; i < n; ++i)
            worst = std::max(worst, norm(got.camera(i).center() - ref.camera(i).center()));
        EXPECT_FALSE(fs::exists(work + "/outputs_pending.txt")) << "seed " << seed;
        if (colmap_done) {
            // what the resumed run made from the finished COLMAP run is what any run on it makes
            const std::string again = dir / (tag + "_again.yml");
            r = vbme_test::run(std::string(VBME_EXE) + " track-camera --video " +
                               (dir / "walk.mkv") + " --scene " + (dir / "frame0.yml") + " --out " +
                               again + " --work " + work + " --threads 1 --seed 1 --stride " +
                               std::to_string(kTrackClipStride));
            ASSERT_EQ(r.code, 0) << "seed " << seed << ": " << r.output;
            EXPECT_NE(r.output.find("colmap (reused)"), std::string::npos) << r.output;
            const CameraPath same = CameraPath::read(again);
            ASSERT_EQ(same.frames.size(), (size_t)n);
            for (int i = 0; i < n; ++i)
                EXPECT_LT(norm(same.camera(i).center() - got.camera(i).center()), 1e-6)
                    << "seed " << seed << " frame " << i;
        }
    }
    std::printf(
        "%d of 3 runs killed, %d reruns reused a finished COLMAP run; camera centres within "
        "%.1f um of the uninterrupted run's; worst ATE %.2f cm\n",
        killed, reused, worst * 1e6, worst_ate * 100);
    EXPECT_GE(killed, 2) << "the kills came too late to interrupt anything";
    EXPECT_GE(reused, 1) << "no kill came after COLMAP's run: its reuse was not tried";
}

}  // namespace
