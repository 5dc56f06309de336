// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// ParamsIn (unknown keys refused, types checked) and the read/write/check of the core option
// structs.
#include <gtest/gtest.h>

#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/core/video.hpp"
#include "params_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using namespace vbme_test;

namespace {

FileStorage yaml(const std::string& text) {
    return FileStorage("%YAML:1.0\n---\n" + text, FileStorage::READ | FileStorage::MEMORY);
}

}  // namespace

TEST(CoreParams, ReaderTakesKnownKeysAndRefusesOthers) {
    FileStorage fs = yaml("p: { a: 3, b: 2.5, c: text, d: [4, 5], e: true }\n");
    ParamsIn in(fs["p"], "demo");
    int a = 0;
    double b = 0;
    std::string c;
    Size d;
    bool e = false, f = true;
    EXPECT_TRUE(in("a", a));
    EXPECT_TRUE(in("b", b));
    EXPECT_TRUE(in("c", c));
    EXPECT_TRUE(in("d", d));
    EXPECT_TRUE(in("e", e));
    EXPECT_FALSE(in("f", f));  // absent: unchanged
    EXPECT_EQ(a, 3);
    EXPECT_EQ(b, 2.5);
    EXPECT_EQ(c, "text");
    EXPECT_EQ(d, Size(4, 5));
    EXPECT_TRUE(e);
    EXPECT_TRUE(f);
    EXPECT_NO_THROW(in.finish());

    FileStorage fs2 = yaml("p: { a: 3, spelled_wrong: 1, also_wrong: 2 }\n");
    ParamsIn in2(fs2["p"], "demo");
    in2("a", a);
    const std::string err = thrownBy([&] { in2.finish(); });
    EXPECT_NE(err.find("demo"), std::string::npos) << err;
    EXPECT_NE(err.find("spelled_wrong"), std::string::npos) << err;
    EXPECT_NE(err.find("also_wrong"), std::string::npos) << err;
    EXPECT_NE(err.find("(valid: a)"), std::string::npos) << err;
}

TEST(CoreParams, ReaderChoosesNamedValues) {
    enum Mode { A = 0, B = 1 };
    FileStorage fs = yaml("p: { m: Beta, n: gamma, o: 3 }\n");
    ParamsIn in(fs["p"], "demo");
    Mode m = A, n = A, o = A;
    EXPECT_TRUE(in.choice("m", m, {{"alpha", A}, {"beta", B}}));  // case does not matter
    EXPECT_EQ(m, B);
    const std::string err = thrownBy([&] { in.choice("n", n, {{"alpha", A}, {"beta", B}}); });
    EXPECT_NE(err.find("demo.n: unknown 'gamma' (expected alpha or beta)"), std::string::npos)
        << err;
    EXPECT_NE(thrownBy([&] {
                  in.choice("o", o, {{"alpha", A}, {"beta", B}});
              }).find("demo.o"),
              std::string::npos);
    EXPECT_FALSE(in.choice("absent", m, {{"alpha", A}}));
    EXPECT_EQ(m, B);
}

TEST(CoreParams, ReaderRefusesWrongTypes) {
    FileStorage fs = yaml("p: { i: 2.5, big: 3.0e9, s: 4, n: abc, b: 2, v: [1, 2] }\n");
    ParamsIn in(fs["p"], "demo");
    int i = 0, big = 0;
    std::string s;
    double n = 0;
    bool b = false;
    Vec3f v;
    EXPECT_NE(thrownBy([&] { in("i", i); }).find("demo.i"), std::string::npos);
    EXPECT_NE(thrownBy([&] { in("big", big); }).find("demo.big"), std::string::npos);
    EXPECT_NE(thrownBy([&] { in("s", s); }).find("demo.s: expected a string"), std::string::npos);
    EXPECT_NE(thrownBy([&] { in("n", n); }).find("demo.n: expected a number"), std::string::npos);
    EXPECT_NE(thrownBy([&] { in("b", b); }).find("demo.b: expected a boolean"), std::string::npos);
    EXPECT_NE(thrownBy([&] { in("v", v); }).find("demo.v: expected a list of 3"),
              std::string::npos);
    // not a map at all
    FileStorage fs3 = yaml("p: [1, 2]\n");
    EXPECT_NE(thrownBy([&] { ParamsIn(fs3["p"], "demo"); }).find("expected a map"),
              std::string::npos);
    // an absent node reads nothing and accepts finish()
    ParamsIn none(fs3["absent"], "demo");
    EXPECT_FALSE(none("i", i));
    EXPECT_NO_THROW(none.finish());
}

TEST(CoreParams, VideoColorInfoRoundTripAndChecks) {
    VideoColorInfo c;
    c.primaries = 9;
    c.transfer = 18;
    c.matrix = 9;
    c.range = 2;
    expectRoundTrip(c);
    expectUnknownKeyRefused<VideoColorInfo>("transfer");
    VideoColorInfo bad;
    bad.range = 3;
    expectRejected(bad, "range");
}

TEST(CoreParams, VideoReadOptionsRoundTripAndChecks) {
    VideoReadOptions o;
    o.depth = CV_16U;
    o.hdr = HdrPolicy::Refuse;
    o.purpose = "calibrate";
    o.log = false;
    o.strict = true;
    expectRoundTrip(o);
    expectUnknownKeyRefused<VideoReadOptions>("strict");
    VideoReadOptions bad;
    bad.depth = CV_32F;
    expectRejected(bad, "depth");
}

TEST(CoreParams, VideoSinkOptionsRoundTripAndChecks) {
    const VideoSinkOptions o = changedVideoSinkOptions();
    expectRoundTrip(o);
    expectUnknownKeyRefused<VideoSinkOptions>("crf");
    VideoSinkOptions bad;
    bad.crf = 60;
    expectRejected(bad, "crf");
    bad = VideoSinkOptions();
    bad.codec = "mpeg2";
    expectRejected(bad, "codec");
    bad = VideoSinkOptions();
    bad.time_base = Vec2i(1, 0);
    expectRejected(bad, "time_base");
    bad = VideoSinkOptions();
    bad.min_bitrate = -1;
    expectRejected(bad, "min_bitrate");
    bad = VideoSinkOptions();
    bad.color.range = -1;  // nested struct: named by its own field
    expectRejected(bad, "range");
}

TEST(CoreParams, ProcessOptionsRoundTripAndChecks) {
    ProcessOptions o;
    o.env = {"LC_ALL=C", "OMP_NUM_THREADS=1"};
    o.working_dir = "/tmp/work";
    o.timeout = 60;
    o.kill_after = 2;
    o.log_file = "run.log";
    o.input = "yes";
    expectRoundTrip(o);
    expectUnknownKeyRefused<ProcessOptions>("timeout");
    ProcessOptions bad;
    bad.timeout = -1;
    expectRejected(bad, "timeout");
    bad = ProcessOptions();
    bad.env = {"NOEQUALS"};
    expectRejected(bad, "env");
}
