// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Video and image-sequence IO: lossless round trips, frame rate, rotation, atomic outputs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

static Mat makeFrame(int i, Size size) {
    Mat f(size, CV_8UC3);
    RNG rng(i + 1);
    rng.fill(f, RNG::UNIFORM, 0, 256);
    putText(f, std::to_string(i), Point(5, size.height - 5), FONT_HERSHEY_SIMPLEX, 1,
            Scalar(255, 255, 255), 2);
    return f;
}

TEST(CoreVideo, LosslessFfv1RoundTripKeepsFramesAndRate) {
    vbme_test::ScratchDir tmp;
    const Size size(96, 64);
    const std::string path = tmp / "clip.mkv";
    {
        VideoSink sink(path, 24, size);
        for (int i = 0; i < 10; ++i)
            sink.write(makeFrame(i, size));
        EXPECT_FALSE(std::filesystem::exists(path));  // not there until complete
        sink.close();
    }
    ASSERT_TRUE(std::filesystem::exists(path));
    VideoReader in(path);
    EXPECT_NEAR(in.fps(), 24, 1e-6);
    EXPECT_EQ(in.frameSize(), size);
    Mat f;
    int n = 0;
    while (in.read(f)) {
        ASSERT_LT(n, 10);
        EXPECT_EQ(norm(f, makeFrame(n, size), NORM_INF), 0) << "frame " << n;
        ++n;
    }
    EXPECT_EQ(n, 10);
}

TEST(CoreVideo, ImageSequenceRoundTrip) {
    vbme_test::ScratchDir tmp;
    const Size size(40, 30);
    {
        VideoSink sink(tmp / "seq/%05d.png", 12.5, size);
        for (int i = 0; i < 4; ++i)
            sink.write(makeFrame(i, size));
        sink.close();
    }
    VideoReader folder(tmp / "seq");
    EXPECT_TRUE(folder.isImageSequence());
    EXPECT_EQ(folder.frameCount(), 4);
    EXPECT_NEAR(folder.fps(), 12.5, 1e-9);
    VideoReader pattern(tmp / "seq/%05d.png");
    Mat a, b;
    int n = 0;
    while (folder.read(a)) {
        ASSERT_TRUE(pattern.read(b));
        EXPECT_EQ(norm(a, makeFrame(n, size), NORM_INF), 0);
        EXPECT_EQ(norm(a, b, NORM_INF), 0);
        ++n;
    }
    EXPECT_EQ(n, 4);
    EXPECT_FALSE(pattern.read(b));
}

TEST(CoreVideo, SequenceOrderIsNumericNotLexical) {
    vbme_test::ScratchDir tmp;
    std::filesystem::create_directories(tmp / "s");
    for (int i : {1, 2, 10})
        imwrite(tmp / ("s/f" + std::to_string(i) + ".png"), Mat(8, 8, CV_8UC3, Scalar(i, i, i)));
    VideoReader r(tmp / "s");
    Mat f;
    std::vector<int> seen;
    while (r.read(f))
        seen.push_back(f.at<Vec3b>(0, 0)[0]);
    EXPECT_EQ(seen, (std::vector<int>{1, 2, 10}));
}

TEST(CoreVideo, RotationMetadataIsHonoured) {
    // A 64x32 clip whose display matrix says "rotate by 90 degrees" must come out 32x64 and
    // look the way ffmpeg itself (which rotates like a player) decodes it.
    if (vbme_test::run("ffmpeg -version").code != 0) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir tmp;
    const Size size(64, 32);
    Mat frame(size, CV_8UC3, Scalar(0, 0, 0));
    rectangle(frame, Rect(0, 0, 16, 32), Scalar(255, 255, 255), FILLED);  // white left band
    rectangle(frame, Rect(48, 0, 16, 8), Scalar(0, 0, 255), FILLED);      // red top-right mark
    {
        VideoSink sink(tmp / "plain.mkv", 10, size);
        for (int i = 0; i < 3; ++i)
            sink.write(frame);
        sink.close();
    }
    // Encode losslessly, then tag the stream (stream copy keeps the tag as a display matrix).
    auto r = vbme_test::run("ffmpeg -v error -y -i " + (tmp / "plain.mkv") +
                            " -c:v libx264 -qp 0 " + (tmp / "plain.mp4"));
    ASSERT_EQ(r.code, 0) << r.output;
    r = vbme_test::run("ffmpeg -v error -y -i " + (tmp / "plain.mp4") +
                       " -c copy -metadata:s:v:0 rotate=90 " + (tmp / "rot.mp4"));
    ASSERT_EQ(r.code, 0) << r.output;
    r = vbme_test::run("ffmpeg -v error -y -i " + (tmp / "rot.mp4") + " -frames:v 1 " +
                       (tmp / "ref.png"));
    ASSERT_EQ(r.code, 0) << r.output;
    Mat ref = imread(tmp / "ref.png");
    ASSERT_EQ(ref.size(), Size(32, 64)) << "ffmpeg did not rotate: test premise broken";
    VideoReader in(tmp / "rot.mp4");
    EXPECT_EQ(in.frameSize(), Size(32, 64));
    Mat f;
    ASSERT_TRUE(in.read(f));
    ASSERT_EQ(f.size(), Size(32, 64));
    Mat diff;
    absdiff(f, ref, diff);
    EXPECT_LT(mean(diff)[0] + mean(diff)[1] + mean(diff)[2], 6.0);
    ASSERT_TRUE(in.read(f));
    EXPECT_EQ(f.size(), Size(32, 64));
}

TEST(CoreVideo, ClearErrors) {
    vbme_test::ScratchDir tmp;
    try {
        VideoReader r(tmp / "none.mp4");
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("does not exist"), std::string::npos);
    }
    std::ofstream(tmp / "junk.mp4") << "garbage bytes, not a video";
    EXPECT_THROW(VideoReader r(tmp / "junk.mp4"), cv::Exception);
    std::filesystem::create_directories(tmp / "empty");
    try {
        VideoReader r(tmp / "empty");
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("holds no images"), std::string::npos);
    }
    EXPECT_THROW(VideoSink s(tmp / "out.xyz", 30, Size(8, 8)), cv::Exception);
}

TEST(CoreVideo, AbandonedSinkLeavesNoFile) {
    vbme_test::ScratchDir tmp;
    {
        VideoSink sink(tmp / "partial.mkv", 30, Size(32, 32));
        sink.write(Mat(32, 32, CV_8UC3, Scalar(1, 2, 3)));
    }
    EXPECT_TRUE(std::filesystem::is_empty(tmp.path()));
}

TEST(CoreVideo, Mp4OutputIsReadable) {
    vbme_test::ScratchDir tmp;
    const Size size(64, 48);
    {
        VideoSink sink(tmp / "o.mp4", 25, size);
        for (int i = 0; i < 5; ++i)
            sink.write(Mat(size, CV_8UC3, Scalar(40 * i, 100, 200)));
        sink.close();
    }
    VideoReader in(tmp / "o.mp4");
    EXPECT_NEAR(in.fps(), 25, 1e-6);
    Mat f;
    int n = 0;
    while (in.read(f)) {
        EXPECT_LT(norm(mean(f) - Scalar(40 * n, 100, 200)), 6.0);  // lossy, but close
        ++n;
    }
    EXPECT_EQ(n, 5);
}

TEST(CoreProgress, CountsAndIsThreadSafe) {
    Progress::setEnabled(false);
    Progress p("work", 1000);
    parallel_for_(Range(0, 1000), [&](const Range& r) {
        for (int i = r.start; i < r.end; ++i)
            p.tick();
    });
    EXPECT_EQ(p.done(), 1000);
    Progress::setEnabled(true);
}
