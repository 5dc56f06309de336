// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Video inpainting: a moving occluder over a textured background (static and panning camera),
// temporal stability of fills nobody sees, streaming latency.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/inpaint.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

/** A non-periodic "natural" texture: colour noise summed over three scales. */
Mat naturalTexture(Size s, int seed = 11) {
    RNG rng(seed);
    Mat acc = Mat::zeros(s, CV_32FC3);
    for (double sigma : {1.0, 3.0, 8.0}) {
        Mat n(s, CV_32FC3);
        rng.fill(n, RNG::UNIFORM, 0, 1);
        GaussianBlur(n, n, Size(0, 0), sigma);
        normalize(n, n, 0, 1, NORM_MINMAX);
        acc += n;
    }
    normalize(acc, acc, 15, 240, NORM_MINMAX);
    Mat out;
    acc.convertTo(out, CV_8UC3);
    return out;
}

double psnrIn(const Mat& a, const Mat& b, const Mat& mask) {
    Mat d;
    absdiff(a, b, d);
    d.convertTo(d, CV_32F);
    d = d.mul(d);
    const int n = countNonZero(mask);
    if (n == 0) return 99;
    const Scalar s = sum(d.setTo(0, mask == 0));
    const double mse = (s[0] + s[1] + s[2]) / (3.0 * n);
    return mse < 1e-12 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse);
}

struct Clip {
    std::vector<Mat> frames, masks, backgrounds;
};

/** A red ball of radius 12 crossing the frame; the camera pans by (pan.x, pan.y) pixels per
frame over a larger texture. The mask covers the ball with a 2-pixel margin. */
Clip movingBall(int n, Size size, Point pan, int seed = 11) {
    Clip c;
    const Size big(size.width + std::abs(pan.x) * n + 1, size.height + std::abs(pan.y) * n + 1);
    const Mat world = naturalTexture(big, seed);
    for (int t = 0; t < n; ++t) {
        const int ox = pan.x >= 0 ? pan.x * t : big.width - size.width + pan.x * t - 1;
        const int oy = pan.y >= 0 ? pan.y * t : big.height - size.height + pan.y * t - 1;
        Mat bg = world(Rect(ox, oy, size.width, size.height)).clone();
        const Point centre(16 + t * (size.width - 32) / std::max(1, n - 1),
                           size.height / 2 + cvRound(8 * std::sin(t * 0.7)));
        Mat f = bg.clone(), m = Mat::zeros(size, CV_8U);
        circle(f, centre, 12, Scalar(30, 30, 220), FILLED, LINE_AA);
        circle(m, centre, 14, Scalar(255), FILLED);
        c.frames.push_back(f);
        c.masks.push_back(m);
        c.backgrounds.push_back(bg);
    }
    return c;
}

std::vector<Mat> runAll(const Clip& c, const VideoInpainter::Params& p,
                        std::vector<VideoInpainter::FrameStats>* stats = nullptr) {
    Ptr<VideoInpainter> vi = VideoInpainter::create(p);
    std::vector<Mat> out;
    Mat f;
    VideoInpainter::FrameStats st;
    for (size_t t = 0; t < c.frames.size(); ++t) {
        vi->push(c.frames[t], c.masks[t]);
        while (vi->pop(f, &st)) {
            out.push_back(f.clone());
            if (stats) stats->push_back(st);
        }
    }
    vi->finish();
    while (vi->pop(f, &st)) {
        out.push_back(f.clone());
        if (stats) stats->push_back(st);
    }
    return out;
}

/** Hole pixels of frame t that some frame within @p radius shows (in frame t's coordinates,
the camera moving by @p pan per frame). */
Mat seenElsewhere(const Clip& c, int t, int radius, Point pan) {
    Mat seen = Mat::zeros(c.masks[t].size(), CV_8U);
    for (int s = std::max(0, t - radius); s <= std::min((int)c.frames.size() - 1, t + radius);
         ++s) {
        if (s == t) continue;
        // A pixel x of frame t is pixel x − pan·(s − t) of frame s.
        Mat visible = c.masks[s] == 0, shifted = Mat::zeros(visible.size(), CV_8U);
        const Mat M = (Mat_<double>(2, 3) << 1, 0, pan.x * (s - t), 0, 1, pan.y * (s - t));
        warpAffine(visible, shifted, M, visible.size(), INTER_NEAREST, BORDER_CONSTANT, Scalar(0));
        Mat eroded;
        erode(shifted, eroded, Mat(), Point(-1, -1), 2);  // away from the other hole's edge
        seen |= eroded;
    }
    return seen & c.masks[t];
}

TEST(InpaintVideo, StaticCameraFillsSeenBackgroundExactly) {
    const Clip clip = movingBall(12, Size(128, 96), Point(0, 0));
    VideoInpainter::Params p;
    p.temporal_radius = 4;
    std::vector<VideoInpainter::FrameStats> stats;
    const std::vector<Mat> out = runAll(clip, p, &stats);
    ASSERT_EQ(out.size(), clip.frames.size());
    int checked = 0;
    for (size_t t = 0; t < out.size(); ++t) {
        const Mat seen = seenElsewhere(clip, (int)t, p.temporal_radius, Point(0, 0));
        EXPECT_EQ(norm(out[t], clip.frames[t], NORM_INF, clip.masks[t] == 0), 0) << "frame " << t;
        if (countNonZero(seen) < 50) continue;
        ++checked;
        // exactly the background wherever another frame within the radius saw it
        EXPECT_EQ(norm(out[t], clip.backgrounds[t], NORM_INF, seen), 0) << "frame " << t;
        EXPECT_GT(stats[t].temporal, 0) << "frame " << t;
        EXPECT_EQ(stats[t].index, (int)t);
    }
    EXPECT_GE(checked, 10);
}

TEST(InpaintVideo, PanningCameraIsAlignedByHomography) {
    const Point pan(3, 1);
    const Clip clip = movingBall(10, Size(160, 120), pan, 5);
    VideoInpainter::Params p;
    p.temporal_radius = 3;
    const std::vector<Mat> out = runAll(clip, p);
    ASSERT_EQ(out.size(), clip.frames.size());
    double worst = 99;
    for (size_t t = 0; t < out.size(); ++t) {
        const Mat seen = seenElsewhere(clip, (int)t, p.temporal_radius, pan);
        // Keep away from the frame border, which the shifted neighbours do not cover.
        Mat inner = Mat::zeros(seen.size(), CV_8U);
        inner(Rect(12, 8, seen.cols - 24, seen.rows - 16)).setTo(255);
        const Mat check = seen & inner;
        if (countNonZero(check) < 50) continue;
        worst = std::min(worst, psnrIn(out[t], clip.backgrounds[t], check));
    }
    // Resampling through an estimated homography costs a little; an unaligned copy of this
    // texture gives ~15 dB.
    RecordProperty("worst_psnr", std::to_string(worst));
    EXPECT_GE(worst, 40.0);
}

TEST(InpaintVideo, FillOfNeverSeenBackgroundIsStable) {
    // A ball that does not move hides the same background in every frame; the frames carry a
    // little sensor noise. Without reuse each frame's exemplar fill differs.
    Clip clip;
    const Mat bg = naturalTexture(Size(96, 72), 4);
    Mat mask = Mat::zeros(bg.size(), CV_8U);
    circle(mask, Point(48, 36), 10, Scalar(255), FILLED);
    RNG rng(9);
    for (int t = 0; t < 6; ++t) {
        Mat noise(bg.size(), CV_16SC3), f;
        rng.fill(noise, RNG::UNIFORM, -2, 3);
        bg.convertTo(f, CV_16SC3);
        f += noise;
        f.convertTo(f, CV_8UC3);
        f.setTo(Scalar(30, 30, 220), mask);
        clip.frames.push_back(f);
        clip.masks.push_back(mask);
    }
    auto flicker = [&](const std::vector<Mat>& out) {
        double worst = 0;
        for (size_t t = 1; t < out.size(); ++t)
            worst = std::max(worst, norm(out[t], out[t - 1], NORM_L1, mask) / countNonZero(mask));
        return worst;
    };
    VideoInpainter::Params p;
    p.temporal_radius = 2;
    std::vector<VideoInpainter::FrameStats> stats;
    const double stable = flicker(runAll(clip, p, &stats));
    EXPECT_EQ(stable, 0) << "the previous fill is carried over exactly";
    EXPECT_EQ(stats[0].exemplar, countNonZero(mask));
    EXPECT_EQ(stats[3].previous, countNonZero(mask));
    p.reuse_previous = false;
    EXPECT_GT(flicker(runAll(clip, p)), 5.0)
        << "fresh exemplar fills should differ (the test's premise)";
}

TEST(InpaintVideo, RadiusZeroUsesOnlyExemplarsAndThePreviousFill) {
    const Clip clip = movingBall(5, Size(64, 48), Point(0, 0));
    VideoInpainter::Params p;
    p.temporal_radius = 0;
    std::vector<VideoInpainter::FrameStats> stats;
    const std::vector<Mat> out = runAll(clip, p, &stats);
    ASSERT_EQ(out.size(), 5u);
    for (const auto& st : stats) {
        EXPECT_EQ(st.temporal, 0);
        EXPECT_EQ(st.previous + st.exemplar, st.hole);
        if (st.index > 0) {
            EXPECT_GT(st.previous, 0) << "frame " << st.index;
        }
    }
}

TEST(InpaintVideo, StreamsWithBoundedLatency) {
    const Clip clip = movingBall(8, Size(64, 48), Point(0, 0));
    VideoInpainter::Params p;
    p.temporal_radius = 3;
    Ptr<VideoInpainter> vi = VideoInpainter::create(p);
    Mat f;
    for (int t = 0; t < 8; ++t) {
        vi->push(clip.frames[t], clip.masks[t]);
        // Frame k is ready once frame k + radius has arrived.
        const bool ready = vi->pop(f);
        EXPECT_EQ(ready, t >= p.temporal_radius) << "after frame " << t;
    }
    int rest = 0;
    EXPECT_FALSE(vi->pop(f));
    vi->finish();
    while (vi->pop(f))
        ++rest;
    EXPECT_EQ(rest, p.temporal_radius);
}

TEST(InpaintVideo, ParamsRoundTripThroughFileStorage) {
    VideoInpainter::Params p;
    p.temporal_radius = 9;
    p.reuse_previous = false;
    p.exemplar.patch_size = 7;
    FileStorage out(".yml", FileStorage::WRITE | FileStorage::MEMORY);
    out << "video"
        << "{";
    p.write(out);
    out << "}";
    FileStorage in(out.releaseAndGetString(), FileStorage::READ | FileStorage::MEMORY);
    VideoInpainter::Params q;
    q.read(in["video"]);
    EXPECT_EQ(q.temporal_radius, 9);
    EXPECT_FALSE(q.reuse_previous);
    EXPECT_EQ(q.exemplar.patch_size, 7);
}

}  // namespace
