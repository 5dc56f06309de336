// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The single homes of small shared tools (opencv2/vbme/core/utility.hpp), each checked
// against an independent oracle.
#include <gtest/gtest.h>

#include <signal.h>

#include <atomic>
#include <bitset>
#include <chrono>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>

#include <tbb/parallel_for.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::ScratchDir;

namespace cv {
// exported by libopencv_core but declared only in its private headers
CV_EXPORTS const char* currentParallelFramework();
}  // namespace cv

namespace {
double wallSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

// ---------------------------------------------------------------- ScopedTimer

TEST(ScopedTimer, AddsTheScopesWallTimeOnce) {
    double acc = 1.0;  // adds, does not overwrite
    const auto t0 = std::chrono::steady_clock::now();
    double inner = 0;
    {
        ScopedTimer t(acc);
        std::this_thread::sleep_for(std::chrono::milliseconds(30));
        inner = t.seconds();
    }
    const double outer = wallSince(t0);
    EXPECT_GE(acc - 1.0, 0.030);  // at least the sleep
    EXPECT_LE(acc - 1.0, outer);  // at most the clock read around it
    EXPECT_GE(acc - 1.0, inner);  // stops after the last read inside
    int calls = 0;
    double got = -1;
    {
        ScopedTimer t([&](double s) {
            ++calls;
            got = s;
        });
        const double s = t.stop();
        EXPECT_EQ(got, s);
        EXPECT_EQ(t.stop(), s);  // second stop: same figure, no second call
        EXPECT_EQ(t.seconds(), s);
    }
    EXPECT_EQ(calls, 1);  // the destructor did not report again

    // measuring only: the figure is read with stop()
    const auto t1 = std::chrono::steady_clock::now();
    ScopedTimer m;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const double ms = m.stop();
    EXPECT_GE(ms, 0.010);
    EXPECT_LE(ms, wallSince(t1));
}

// ---------------------------------------------------------------- runProcess / shellQuote

TEST(RunProcess, ArgumentsReachTheProgramVerbatim) {
    // No shell between: quotes, spaces, $, ; and * are passed as bytes.
    const std::vector<std::string> args = {"a b", "it's", "$HOME", "x;echo pwned",
                                           "*",   "",     "\"q\"", "tab\there"};
    std::vector<std::string> argv = {"printf", "<%s>\\n"};
    argv.insert(argv.end(), args.begin(), args.end());
    const ProcessResult r = runProcess(argv);
    ASSERT_TRUE(r.ok()) << r.error << r.err;
    std::string expect;
    for (const auto& a : args)
        expect += "<" + a + ">\n";
    EXPECT_EQ(r.out, expect);
    EXPECT_EQ(r.err, "");
}

TEST(RunProcess, ExitStatusStderrAndMissingProgram) {
    const ProcessResult r = runProcess({"sh", "-c", "echo out; echo err >&2; exit 7"});
    EXPECT_EQ(r.status, 7);
    EXPECT_EQ(r.signal, 0);
    EXPECT_FALSE(r.ok());
    EXPECT_EQ(r.out, "out\n");
    EXPECT_EQ(r.err, "err\n");
    EXPECT_TRUE(r.error.empty());

    const ProcessResult m = runProcess({"vbme-no-such-program-xyz", "--help"});
    EXPECT_EQ(m.status, 127);
    EXPECT_FALSE(m.error.empty());
    EXPECT_FALSE(m.ok());
    const ProcessResult p = runProcess({"/no/such/dir/prog"});
    EXPECT_EQ(p.status, 127);
    EXPECT_NE(p.error.find("No such file"), std::string::npos) << p.error;

    EXPECT_THROW(runProcess({}), cv::Exception);
}

TEST(RunProcess, EnvironmentInputWorkingDirAndLog) {
    ScratchDir dir;
    ProcessOptions o;
    o.env = {"VBME_UTIL_TEST=a b;c", "HOME=/elsewhere"};
    o.working_dir = dir.path().string();
    const ProcessResult r =
        runProcess({"sh", "-c", "printf '%s|%s|%s' \"$VBME_UTIL_TEST\" \"$HOME\" \"$PWD\""}, o);
    ASSERT_TRUE(r.ok()) << r.err;
    EXPECT_EQ(r.out, "a b;c|/elsewhere|" + std::filesystem::canonical(dir.path()).string());

    // 1 MiB through cat: stdin and stdout are served together (no pipe deadlock).
    ProcessOptions in;
    in.input.resize(1 << 20);
    for (size_t i = 0; i < in.input.size(); ++i)
        in.input[i] = char('a' + (i * 7919) % 26);
    const ProcessResult c = runProcess({"cat"}, in);
    ASSERT_TRUE(c.ok());
    EXPECT_TRUE(c.out == in.input);

    ProcessOptions lo;
    lo.log_file = dir / "run.log";
    ASSERT_TRUE(runProcess({"sh", "-c", "echo one; echo two >&2"}, lo).ok());
    const ProcessResult second = runProcess({"sh", "-c", "echo three"}, lo);
    EXPECT_TRUE(second.ok());
    EXPECT_EQ(second.out, "");
    std::ifstream f(lo.log_file);
    const std::string log((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_EQ(log, "one\ntwo\nthree\n");  // appended, stdout and stderr together
}

TEST(RunProcess, TimeoutStopsTheProgram) {
    ProcessOptions o;
    o.timeout = 0.3;
    const auto t0 = std::chrono::steady_clock::now();
    const ProcessResult r = runProcess({"sleep", "20"}, o);
    const double wall = wallSince(t0);
    EXPECT_TRUE(r.timed_out);
    EXPECT_EQ(r.signal, SIGTERM);
    EXPECT_EQ(r.status, 128 + SIGTERM);
    EXPECT_GE(r.seconds, 0.3);
    EXPECT_LT(wall, 5.0);

    // A program that ignores SIGTERM gets SIGKILL kill_after seconds later; its child keeps
    // the output pipe open and is not waited for. Same with output to a log file.
    for (bool to_log : {false, true}) {
        ScratchDir dir;
        ProcessOptions k;
        k.timeout = 0.2;
        k.kill_after = 0.2;
        if (to_log) k.log_file = dir / "k.log";
        const auto t1 = std::chrono::steady_clock::now();
        const ProcessResult s =
            runProcess({"sh", "-c", "trap '' TERM; echo started; sleep 3; sleep 3"}, k);
        const double w = wallSince(t1);
        EXPECT_TRUE(s.timed_out);
        EXPECT_EQ(s.signal, SIGKILL);
        EXPECT_GE(w, 0.4);
        EXPECT_LT(w, 2.9) << "waited for the program's child";
        if (!to_log) {
            EXPECT_EQ(s.out, "started\n");
        }
    }
}

TEST(ShellQuote, ShellGivesBackTheString) {
    const std::vector<std::string> nasty = {
        "plain", "a b", "it's", "''", "$(touch x)`id`", "back\\slash", "new\nline", "*?[a]", ""};
    for (const std::string& s : nasty) {
        const ProcessResult r = runProcess({"sh", "-c", "printf %s " + shellQuote(s)});
        ASSERT_TRUE(r.ok()) << s;
        EXPECT_EQ(r.out, s);
    }
}

// ---------------------------------------------------------------- mix64 / hashCombine

TEST(Mix64, SplitMix64ReferenceAndAvalanche) {
    // splitmix64 (Steele, Lea, Flood 2014): state += golden gamma, output mix64(state).
    // Its first outputs from seed 0 in the reference implementation (Vigna's splitmix64.c).
    uint64 state = 0;
    state += 0x9e3779b97f4a7c15ULL;
    EXPECT_EQ(mix64(state), 0xe220a8397b1dcdafULL);
    state += 0x9e3779b97f4a7c15ULL;
    EXPECT_EQ(mix64(state), 0x6e789e6aa1b965f4ULL);
    state += 0x9e3779b97f4a7c15ULL;
    EXPECT_EQ(mix64(state), 0x06c45d188009454fULL);

    // Avalanche: flipping one input bit flips each output bit with probability ~1/2.
    RNG rng(5);
    double flipped = 0;
    int n = 0, worst_bit_count_min = 1 << 30, worst_bit_count_max = 0;
    std::vector<int> per_out(64, 0);
    const int trials = 200;
    for (int t = 0; t < trials; ++t) {
        const uint64 x = (uint64(rng.next()) << 32) | rng.next();
        for (int b = 0; b < 64; ++b) {
            const uint64 d = mix64(x) ^ mix64(x ^ (1ULL << b));
            flipped += (double)std::bitset<64>(d).count();
            for (int o = 0; o < 64; ++o)
                per_out[o] += int((d >> o) & 1);
            ++n;
        }
    }
    for (int c : per_out) {
        worst_bit_count_min = std::min(worst_bit_count_min, c);
        worst_bit_count_max = std::max(worst_bit_count_max, c);
    }
    const double mean = flipped / n / 64;
    std::printf("[ MEASURED ] mix64 avalanche: mean flip rate %.4f, per output bit %.4f..%.4f\n",
                mean, (double)worst_bit_count_min / n, (double)worst_bit_count_max / n);
    EXPECT_NEAR(mean, 0.5, 0.01);
    // each output bit: binomial(12800, 1/2) has sd 0.0044; 0.03 is ~7 sd
    EXPECT_NEAR((double)worst_bit_count_min / n, 0.5, 0.03);
    EXPECT_NEAR((double)worst_bit_count_max / n, 0.5, 0.03);

    // hashCombine: the definition, and order matters.
    EXPECT_EQ(hashCombine(3, 4), mix64(3 ^ (mix64(4) + 0x9e3779b97f4a7c15ULL)));
    EXPECT_NE(hashCombine(3, 4), hashCombine(4, 3));
}

// ---------------------------------------------------------------- bilinear

TEST(Bilinear, ExactOnPlanesClampedAtEdgesAndMatchesRemap) {
    // Oracle 1: bilinear interpolation reproduces an affine function exactly (up to float
    // rounding) inside the image; outside, the value at the clamped position.
    const Size sz(13, 7);
    Mat plane(sz, CV_32FC3), gray(sz, CV_32F);
    auto f = [](double x, double y) { return Vec3d(0.5 + 0.25 * x - 0.5 * y, 2 - 0.125 * x, y); };
    for (int y = 0; y < sz.height; ++y)
        for (int x = 0; x < sz.width; ++x) {
            const Vec3d v = f(x, y);
            plane.at<Vec3f>(y, x) = Vec3f(v);
            gray.at<float>(y, x) = float(v[0]);
        }
    RNG rng(11);
    double worst = 0;
    for (int i = 0; i < 2000; ++i) {
        const float x = rng.uniform(-3.f, sz.width + 2.f), y = rng.uniform(-3.f, sz.height + 2.f);
        const Vec3d want = f(std::min(std::max(x, 0.f), sz.width - 1.f),
                             std::min(std::max(y, 0.f), sz.height - 1.f));
        const Vec3f got = bilinear<Vec3f>(plane, x, y);
        const Vec3f got_d = bilinear<Vec3f>(plane, (double)x, (double)y);
        for (int c = 0; c < 3; ++c) {
            worst = std::max(worst, std::abs(got[c] - want[c]));
            worst = std::max(worst, std::abs(got_d[c] - want[c]));
        }
        EXPECT_NEAR(bilinear<float>(gray, x, y), want[0], 1e-5);
    }
    EXPECT_LT(worst, 1e-5);
    // pixel centres at integers: exact samples
    EXPECT_EQ(bilinear<Vec3f>(plane, 4.f, 3.f), plane.at<Vec3f>(3, 4));
    EXPECT_EQ(bilinear<Vec3f>(plane, 12.f, 6.f), plane.at<Vec3f>(6, 12));  // last pixel

    // Oracle 2: cv::remap (INTER_LINEAR, BORDER_REPLICATE) on noise, within its 1/32-pixel
    // weight quantisation.
    Mat noise(sz, CV_32FC3);
    rng.fill(noise, RNG::UNIFORM, 0, 1);
    Mat mx(1, 500, CV_32F), my(1, 500, CV_32F), ref;
    rng.fill(mx, RNG::UNIFORM, -2, sz.width + 1);
    rng.fill(my, RNG::UNIFORM, -2, sz.height + 1);
    remap(noise, ref, mx, my, INTER_LINEAR, BORDER_REPLICATE);
    double worst_remap = 0;
    for (int i = 0; i < 500; ++i) {
        const Vec3f a = bilinear<Vec3f>(noise, mx.at<float>(i), my.at<float>(i));
        const Vec3f b = ref.at<Vec3f>(i);
        for (int c = 0; c < 3; ++c)
            worst_remap = std::max(worst_remap, (double)std::abs(a[c] - b[c]));
    }
    std::printf("[ MEASURED ] bilinear vs cv::remap: max |diff| %.5f (remap weights are 1/32)\n",
                worst_remap);
    EXPECT_LT(worst_remap, 2.0 / 32);

    // One row, one column, one pixel.
    Mat row = (Mat_<float>(1, 3) << 1, 2, 4);
    EXPECT_FLOAT_EQ(bilinear<float>(row, 1.5f, 0.7f), 3.f);
    EXPECT_FLOAT_EQ(bilinear<float>(row, 9.f, -4.f), 4.f);
    Mat col = (Mat_<float>(3, 1) << 1, 2, 4);
    EXPECT_FLOAT_EQ(bilinear<float>(col, 0.3f, 0.25f), 1.25f);
    Mat one = (Mat_<float>(1, 1) << 5);
    EXPECT_FLOAT_EQ(bilinear<float>(one, 0.4f, -0.4f), 5.f);
}

// ---------------------------------------------------------------- runLimited

namespace {
// Distinct threads that ran `chunks` small blocking work items of a loop.
template <typename Loop>
size_t threadsUsed(Loop loop) {
    std::mutex m;
    std::set<std::thread::id> ids;
    loop([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        std::lock_guard<std::mutex> l(m);
        ids.insert(std::this_thread::get_id());
    });
    return ids.size();
}
}  // namespace

TEST(RunLimited, LimitsTbbLoopsNotTheGlobalThreadCount) {
    const int cv_threads = getNumThreads();
    const int hw = currentConcurrency();
    auto tbbLoop = [](const std::function<void()>& work) {
        tbb::parallel_for(0, 64, [&](int) { work(); });
    };
    const size_t free_threads = threadsUsed(tbbLoop);
    size_t limited = 0;
    int inside = 0, cv_inside = 0;
    runLimited(1, [&] {
        inside = currentConcurrency();
        cv_inside = getNumThreads();
        limited = threadsUsed(tbbLoop);
    });
    std::printf("[ MEASURED ] TBB loop: %zu threads free (concurrency %d), %zu in runLimited(1)\n",
                free_threads, hw, limited);
    EXPECT_EQ(inside, 1);
    EXPECT_EQ(limited, 1u);
    EXPECT_EQ(cv_inside, cv_threads);  // the process-wide setting is untouched …
    EXPECT_EQ(getNumThreads(), cv_threads);
    EXPECT_EQ(currentConcurrency(), hw);  // … and so is the caller's arena afterwards
    if (hw >= 2) {
        EXPECT_GE(free_threads, 2u);  // the loop does use more threads when free
    }

    // Nested limits: the inner one applies inside, the outer one after it.
    runLimited(2, [&] {
        EXPECT_EQ(currentConcurrency(), 2);
        runLimited(1, [&] { EXPECT_EQ(currentConcurrency(), 1); });
        EXPECT_EQ(currentConcurrency(), 2);
    });
    // 0 = no limit; exceptions pass through
    runLimited(0, [&] { EXPECT_EQ(currentConcurrency(), hw); });
    EXPECT_THROW(runLimited(1, [] { CV_Error(Error::StsError, "inside"); }), cv::Exception);
}

TEST(RunLimited, OpenCvLoops) {
    // Documents what runLimited() does not limit: cv::parallel_for_ runs in OpenCV's own
    // arena (Debian's OpenCV is built with TBB), sized by cv::setNumThreads() only.
    auto cvLoop = [](const std::function<void()>& work) {
        parallel_for_(Range(0, 64), [&](const Range& r) {
            for (int i = r.start; i < r.end; ++i)
                work();
        });
    };
    const int cv_threads = getNumThreads();
    const size_t free_threads = threadsUsed(cvLoop);
    size_t limited = 0;
    runLimited(1, [&] { limited = threadsUsed(cvLoop); });
    std::printf(
        "[ MEASURED ] cv::parallel_for_ (%s backend): %zu threads free, %zu in "
        "runLimited(1)\n",
        cv::currentParallelFramework(), free_threads, limited);
    // What is asserted: the loop still runs every item, and getNumThreads() is unchanged.
    EXPECT_GE(limited, 1u);
    EXPECT_EQ(getNumThreads(), cv_threads);
}

// ---------------------------------------------------------------- ParamsReader

namespace {
FileStorage parse(const std::string& yaml) {
    return FileStorage(yaml, FileStorage::READ | FileStorage::MEMORY | FileStorage::FORMAT_YAML);
}
}  // namespace

TEST(ParamsReader, ReadsKnownKeysAndRefusesUnknownOnes) {
    FileStorage fs = parse(
        "%YAML:1.0\n---\n"
        "p:\n  radius: 3\n  scale: 0.25\n  name: disk\n  on: 1\n  seed: 1099511627776.\n"
        "  inner: { a: 2 }\n");
    int radius = 0, missing = 42, a = 0;
    double scale = 0;
    std::string name;
    bool on = false;
    uint64 seed = 0;
    ParamsReader r(fs["p"], "p");
    EXPECT_TRUE(r("radius", radius));
    EXPECT_TRUE(r("scale", scale));
    EXPECT_TRUE(r("name", name));
    EXPECT_TRUE(r("on", on));
    EXPECT_TRUE(r("seed", seed));
    EXPECT_FALSE(r("missing", missing));
    ParamsReader inner(r.node("inner"), "p.inner");
    inner("a", a);
    EXPECT_NO_THROW(inner.finish());
    EXPECT_NO_THROW(r.finish());
    EXPECT_EQ(radius, 3);
    EXPECT_EQ(scale, 0.25);
    EXPECT_EQ(name, "disk");
    EXPECT_TRUE(on);
    EXPECT_EQ(seed, 1ULL << 40);  // exact beyond 32 bits
    EXPECT_EQ(missing, 42);       // absent: unchanged
    EXPECT_EQ(a, 2);

    // A typo is an error naming it and the valid keys.
    FileStorage typo = parse("%YAML:1.0\n---\np:\n  radus: 3\n  scale: 0.5\n  zzz: 1\n");
    ParamsReader t(typo["p"], "tracker");
    radius = 7;
    t("radius", radius);
    t("scale", scale);
    EXPECT_EQ(t.unknownKeys(), (std::vector<std::string>{"radus", "zzz"}));
    try {
        t.finish();
        FAIL() << "an unknown key was accepted";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("tracker"), std::string::npos) << e.err;
        EXPECT_NE(e.err.find("radus, zzz"), std::string::npos) << e.err;
        EXPECT_NE(e.err.find("valid: radius, scale"), std::string::npos) << e.err;
    }
    EXPECT_EQ(radius, 7);
    // accept(): read elsewhere, so valid
    ParamsReader t2(typo["p"], "p");
    t2.accept("radus");
    t2.accept("zzz");
    t2("scale", scale);
    EXPECT_NO_THROW(t2.finish());

    // An absent map reads nothing and has no unknown keys; a scalar is refused.
    ParamsReader none(typo["nothing"], "none");
    EXPECT_FALSE(none("radius", radius));
    EXPECT_NO_THROW(none.finish());
    EXPECT_THROW(ParamsReader(typo["p"]["scale"], "scale"), cv::Exception);
}
