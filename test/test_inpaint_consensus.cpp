// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Consensus video fill and shadow removal on clips rendered by Blender Cycles (not by vbme):
// a ball rolling over a striped wooden floor with a soft shadow, a clean plate rendered without
// the ball as the oracle. Compared in the same test with the per-pixel temporal median of the
// input frames and with the previous nearest-frame fill (VideoInpainter).
// The clips are made by scripts/blender/inpaint_clip.py (see test/data/README.md).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/inpaint.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

struct BlenderClip {
    std::vector<Mat> frames, clean, holes, shadow;  // shadow: the oracle's shadow region
};

/** Reads test/data/inpaint_<name>: frames, clean plate, ball coverage → holes (the ball
dilated by 4 px) and the true shadow region: outside the hole, where the frame is darker than
the clean plate by more than 4 % in luminance (the renders share their sampling, so elsewhere
the ratio is 1 but for noise). */
BlenderClip loadClip(const std::string& name) {
    const std::string dir = std::string(VBME_TEST_DATA_DIR) + "/inpaint_" + name;
    BlenderClip c;
    VideoReader rf(dir + "/frames.mkv"), rc(dir + "/clean.mkv");
    Mat f, cl;
    const Mat k = getStructuringElement(MORPH_ELLIPSE, Size(9, 9));
    while (rf.read(f)) {
        if (!rc.read(cl)) break;
        const int i = (int)c.frames.size();
        Mat ball = imread(dir + format("/ball_%05d.png", i), IMREAD_GRAYSCALE);
        if (ball.empty()) break;
        Mat hole;
        dilate(ball > 0, hole, k);
        Mat fy, cy, valid;
        cvtColor(f, fy, COLOR_BGR2GRAY);
        cvtColor(cl, cy, COLOR_BGR2GRAY);
        fy.convertTo(fy, CV_32F);
        cy.convertTo(cy, CV_32F);
        GaussianBlur(fy, fy, Size(0, 0), 1.0);
        GaussianBlur(cy, cy, Size(0, 0), 1.0);
        Mat sh = (fy < 0.96 * cy) & (cy > 8) & (hole == 0);
        morphologyEx(sh, sh, MORPH_OPEN, getStructuringElement(MORPH_ELLIPSE, Size(3, 3)));
        c.frames.push_back(f.clone());
        c.clean.push_back(cl.clone());
        c.holes.push_back(hole);
        c.shadow.push_back(sh);
    }
    return c;
}

/** PSNR over all frames' masked pixels together. */
double psnrIn(const std::vector<Mat>& a, const std::vector<Mat>& b, const std::vector<Mat>& m) {
    double se = 0;
    int64 n = 0;
    for (size_t t = 0; t < a.size(); ++t)
        for (int y = 0; y < a[t].rows; ++y)
            for (int x = 0; x < a[t].cols; ++x) {
                if (!m[t].at<uchar>(y, x)) continue;
                const Vec3b p = a[t].at<Vec3b>(y, x), q = b[t].at<Vec3b>(y, x);
                for (int c = 0; c < 3; ++c)
                    se += double(p[c] - q[c]) * (p[c] - q[c]);
                n += 3;
            }
    if (n == 0) return 0;
    return se < 1e-9 ? 99 : 10 * std::log10(255.0 * 255.0 * n / se);
}

/** The naive baseline: each pixel the median of the input frames (no alignment). */
std::vector<Mat> temporalMedian(const std::vector<Mat>& frames) {
    Mat med(frames[0].size(), CV_8UC3);
    std::vector<uchar> v(frames.size());
    for (int y = 0; y < med.rows; ++y)
        for (int x = 0; x < med.cols; ++x)
            for (int c = 0; c < 3; ++c) {
                for (size_t t = 0; t < frames.size(); ++t)
                    v[t] = frames[t].at<Vec3b>(y, x)[c];
                std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
                med.at<Vec3b>(y, x)[c] = v[v.size() / 2];
            }
    return std::vector<Mat>(frames.size(), med);
}

template <class Inp, class Stats>
std::vector<Mat> runAll(Inp& inp, const BlenderClip& c, std::vector<Stats>* stats = nullptr) {
    std::vector<Mat> out;
    Mat o;
    Stats st;
    for (size_t t = 0; t < c.frames.size(); ++t) {
        inp->push(c.frames[t], c.holes[t]);
        while (inp->pop(o, &st)) {
            out.push_back(o.clone());
            if (stats) stats->push_back(st);
        }
    }
    inp->finish();
    while (inp->pop(o, &st)) {
        out.push_back(o.clone());
        if (stats) stats->push_back(st);
    }
    return out;
}

void checkClip(const std::string& name) {
    const BlenderClip c = loadClip(name);
    ASSERT_GE(c.frames.size(), 20u) << "test data of " << name << " missing or short";
    std::vector<Mat> both(c.frames.size());
    int shadowPixels = 0;
    for (size_t t = 0; t < c.frames.size(); ++t) {
        both[t] = c.holes[t] | c.shadow[t];
        shadowPixels += countNonZero(c.shadow[t]);
    }
    ASSERT_GT(shadowPixels, 1000) << "the clip's ball casts a visible shadow";

    std::clock_t t0 = std::clock();
    const std::vector<Mat> median = temporalMedian(c.frames);
    {
        std::vector<Mat> rest;
        for (size_t t = 0; t < c.frames.size(); ++t) {
            Mat v;
            cvtColor(c.clean[t], v, COLOR_BGR2GRAY);
            Mat grown;
            dilate(both[t], grown, getStructuringElement(MORPH_ELLIPSE, Size(9, 9)));
            rest.push_back((v > 0) & (grown == 0));
        }
        const double agree = psnrIn(c.frames, c.clean, rest);
        std::printf("[ %s ] input vs clean plate away from ball and shadow: %.2f dB\n",
                    name.c_str(), agree);
        ASSERT_GE(agree, 45.0) << "the oracle (clean plate) matches the frames elsewhere";
    }
    std::clock_t t1 = std::clock();
    Ptr<VideoInpainter> prev = VideoInpainter::create();
    const std::vector<Mat> nearest =
        runAll<Ptr<VideoInpainter>, VideoInpainter::FrameStats>(prev, c);
    std::clock_t t2 = std::clock();
    ConsensusInpainter::Params dp;
    Ptr<ConsensusInpainter> ci = ConsensusInpainter::create(dp);
    std::vector<ConsensusInpainter::FrameStats> stats;
    const std::vector<Mat> ours = runAll(ci, c, &stats);
    std::clock_t t3 = std::clock();
    std::printf("[ %s ] CPU seconds: median %.2f, nearest %.2f, consensus %.2f\n", name.c_str(),
                double(t1 - t0) / CLOCKS_PER_SEC, double(t2 - t1) / CLOCKS_PER_SEC,
                double(t3 - t2) / CLOCKS_PER_SEC);
    ASSERT_EQ(ours.size(), c.frames.size());

    const double hOurs = psnrIn(ours, c.clean, c.holes), hMed = psnrIn(median, c.clean, c.holes);
    const double hPrev = psnrIn(nearest, c.clean, c.holes);
    const double sOurs = psnrIn(ours, c.clean, c.shadow), sIn = psnrIn(c.frames, c.clean, c.shadow);
    const double sMed = psnrIn(median, c.clean, c.shadow);
    int K = stats.empty() ? 0 : stats[0].radius, flow = 0, nb = 0, shadow = 0, ex = 0;
    for (const auto& s : stats) {
        flow += s.flow_aligned;
        nb += s.neighbours;
        shadow += s.shadow;
        ex += s.exemplar;
    }
    std::printf(
        "[ %s ] %zu frames, K %d, neighbours %d (%d by flow), exemplar px %d, "
        "shadow px found %d (oracle %d)\n",
        name.c_str(), c.frames.size(), K, nb, flow, ex, shadow, shadowPixels);
    std::printf(
        "[ %s ] PSNR in holes: consensus %.2f dB, temporal median %.2f dB, previous "
        "nearest-frame fill %.2f dB\n",
        name.c_str(), hOurs, hMed, hPrev);
    std::printf(
        "[ %s ] PSNR in shadow region: consensus (shadows removed) %.2f dB, input (kept) "
        "%.2f dB, temporal median %.2f dB, previous nearest-frame fill %.2f dB\n",
        name.c_str(), sOurs, sIn, sMed, psnrIn(nearest, c.clean, c.shadow));
    // Around the hole, outside the object's shadow: the zone where the shadow is sought, less
    // the hole and the oracle's shadow region grown by 7 px (more than the 5 px the removal
    // grows and feathers), less the clean plate's black unrendered area. Nothing there is the
    // object's shadow, so the fill should keep the input.
    const double reach = ConsensusInpainter::Params().shadow_reach;
    std::vector<Mat> rim(c.frames.size());
    for (size_t t = 0; t < c.frames.size(); ++t) {
        Mat inv, dist, grown, v;
        bitwise_not(c.holes[t], inv);
        distanceTransform(inv, dist, DIST_L2, 3);
        const double r = std::sqrt(countNonZero(c.holes[t]) / CV_PI);
        dilate(c.shadow[t], grown, getStructuringElement(MORPH_ELLIPSE, Size(15, 15)));
        cvtColor(c.clean[t], v, COLOR_BGR2GRAY);
        rim[t] = (dist <= reach * r + 1) & (c.holes[t] == 0) & (grown == 0) & (v > 0);
    }
    const double zOurs = psnrIn(ours, c.clean, rim), zIn = psnrIn(c.frames, c.clean, rim);
    std::printf(
        "[ %s ] PSNR in the zone outside hole and grown shadow: consensus %.2f dB, input %.2f "
        "dB\n",
        name.c_str(), zOurs, zIn);
    std::printf("[ %s ] per frame in holes (consensus/median):", name.c_str());
    for (size_t t = 0; t < ours.size(); ++t)
        std::printf(" %.1f/%.1f", psnrIn({ours[t]}, {c.clean[t]}, {c.holes[t]}),
                    psnrIn({median[t]}, {c.clean[t]}, {c.holes[t]}));
    std::printf("\n[ %s ] per frame in the zone outside hole and grown shadow (consensus/input):",
                name.c_str());
    for (size_t t = 0; t < ours.size(); ++t)
        std::printf(" %.1f/%.1f", psnrIn({ours[t]}, {c.clean[t]}, {rim[t]}),
                    psnrIn({c.frames[t]}, {c.clean[t]}, {rim[t]}));
    std::printf("\n");
    if (std::getenv("VBME_KEEP_TEST_FILES")) {  // input | vbme | clean | median | nearest
        vbme_test::ScratchDir dir;
        for (size_t t = 0; t < ours.size(); t += 4) {
            Mat row;
            hconcat(std::vector<Mat>{c.frames[t], ours[t], c.clean[t], median[t], nearest[t]}, row);
            imwrite(dir / format("%s_%02d.png", name.c_str(), (int)t), row);
        }
    }
    EXPECT_GE(hOurs, hMed + 3.0);
    EXPECT_GE(hOurs, 32.0);
    EXPECT_GT(hOurs, hPrev);
    EXPECT_GE(sOurs, 30.0);
    EXPECT_GT(sOurs, sIn + 3.0) << "the shadow is removed, not left";
    // Measured: static 52.40 / 52.40 dB; pan 50.31 / 51.53 dB (frame 18 keeps a false shadow of
    // another cause, 43.1 dB); before the chromaticity test the pan clip measured 33.96 dB.
    EXPECT_GE(zOurs, zIn - 2.0) << "nothing but the object's shadow is removed";
    // Outside the hole only the object's zone (where its shadow is sought) may change.
    for (size_t t = 0; t < ours.size(); ++t) {
        Mat inv, dist;
        bitwise_not(c.holes[t], inv);
        distanceTransform(inv, dist, DIST_L2, 3);
        const double r = std::sqrt(countNonZero(c.holes[t]) / CV_PI);
        EXPECT_EQ(norm(ours[t], c.frames[t], NORM_INF, dist > reach * r + 1), 0) << "frame " << t;
    }
}

}  // namespace

TEST(InpaintConsensus, BlenderStaticCameraBeatsTemporalMedian) {
    checkClip("static");
}

// Parallax: the camera travels sideways, floor, crate and wall move differently. The local
// homographies are refined by direct (ECC) alignment around the hole; before that, this
// clip measured 20.26 dB in the holes and 24.58 dB in the shadow region (issue 14's
// closing note), short of the aims checked here.
TEST(InpaintConsensus, BlenderPanningCameraWithParallaxBeatsTemporalMedian) {
    checkClip("pan");
}

TEST(InpaintConsensus, ParamsRoundTripAndValidation) {
    ConsensusInpainter::Params p;
    p.temporal_radius = 5;
    p.alignment = CONSENSUS_ALIGN_HOMOGRAPHY;
    p.shadows = SHADOWS_KEEP;
    p.shadow_threshold = 0.12;
    p.reuse_previous = false;
    p.exemplar.patch_size = 7;
    FileStorage fs("p.yml", FileStorage::WRITE | FileStorage::MEMORY);
    fs << "consensus"
       << "{";
    p.write(fs);
    fs << "}";
    const std::string text = fs.releaseAndGetString();
    FileStorage in(text, FileStorage::READ | FileStorage::MEMORY);
    ConsensusInpainter::Params q;
    q.read(in["consensus"]);
    EXPECT_EQ(q.temporal_radius, 5);
    EXPECT_EQ(q.alignment, CONSENSUS_ALIGN_HOMOGRAPHY);
    EXPECT_EQ(q.shadows, SHADOWS_KEEP);
    EXPECT_DOUBLE_EQ(q.shadow_threshold, 0.12);
    EXPECT_FALSE(q.reuse_previous);
    EXPECT_EQ(q.exemplar.patch_size, 7);
    ConsensusInpainter::Params bad;
    bad.shadow_threshold = 1.5;
    EXPECT_THROW(ConsensusInpainter::create(bad), cv::Exception);
    EXPECT_EQ(parseShadowMode("Remove"), SHADOWS_REMOVE);
    EXPECT_EQ(toString(SHADOWS_KEEP), "keep");
    EXPECT_THROW(parseShadowMode("erase"), cv::Exception);
}

TEST(InpaintConsensus, StreamsWithLatencyOfTheRadius) {
    const Size s(96, 48);
    RNG rng(3);
    Mat bg(s, CV_8UC3);
    rng.fill(bg, RNG::UNIFORM, 30, 220);
    GaussianBlur(bg, bg, Size(0, 0), 1.0);
    ConsensusInpainter::Params p;
    p.temporal_radius = 3;
    p.alignment = CONSENSUS_ALIGN_NONE;
    Ptr<ConsensusInpainter> ci = ConsensusInpainter::create(p);
    Mat out;
    ConsensusInpainter::FrameStats st;
    int popped = 0;
    for (int t = 0; t < 10; ++t) {
        Mat f = bg.clone(), m = Mat::zeros(s, CV_8U);
        circle(f, Point(8 + 8 * t, 24), 5, Scalar(0, 0, 255), FILLED);
        circle(m, Point(8 + 8 * t, 24), 7, Scalar(255), FILLED);
        ci->push(f, m);
        while (ci->pop(out, &st)) {
            EXPECT_EQ(st.index, popped);
            EXPECT_EQ(t, popped + 3) << "frame t comes out when frame t + K has arrived";
            // Identical background everywhere: the vote reproduces it exactly.
            EXPECT_EQ(norm(out, bg, NORM_INF), 0) << "frame " << popped;
            EXPECT_EQ(st.temporal, st.hole);
            ++popped;
        }
    }
    ci->finish();
    while (ci->pop(out, &st))
        ++popped;
    EXPECT_EQ(popped, 10);
}

// The vote runs in parallel over rows and the candidates' Lab conversion over candidates: the
// fill and the shadow found must not depend on the thread count. The material-edit removal's
// settings (no alignment, shadows removed) on the first frames of the static Blender clip.
TEST(InpaintConsensus, ShadowRemovalIsTheSameOnOneAndTwoThreads) {
    BlenderClip c = loadClip("static");
    ASSERT_GE(c.frames.size(), 8u) << "test data of static missing or short";
    ConsensusInpainter::Params p;
    p.alignment = CONSENSUS_ALIGN_NONE;
    p.temporal_radius = 3;
    p.shadows = SHADOWS_REMOVE;
    auto run = [&](int threads, std::vector<Mat>& outs, std::vector<Mat>& shadows, int& found) {
        const int before = getNumThreads();
        setNumThreads(threads);
        Ptr<ConsensusInpainter> ci = ConsensusInpainter::create(p);
        Mat o, sh;
        ConsensusInpainter::FrameStats st;
        found = 0;
        auto drain = [&] {
            while (ci->pop(o, &st, sh)) {
                outs.push_back(o.clone());
                shadows.push_back(sh.clone());
                found += st.shadow;
            }
        };
        for (size_t t = 0; t < 8; ++t) {
            ci->push(c.frames[t], c.holes[t]);
            drain();
        }
        ci->finish();
        drain();
        setNumThreads(before);
    };
    std::vector<Mat> o1, s1, o2, s2;
    int found1 = 0, found2 = 0;
    run(1, o1, s1, found1);
    run(2, o2, s2, found2);
    ASSERT_EQ(o1.size(), 8u);
    ASSERT_EQ(o2.size(), 8u);
    EXPECT_GT(found1, 1000) << "the clip's shadow is found, so the zone's vote ran";
    EXPECT_EQ(found1, found2);
    for (size_t t = 0; t < o1.size(); ++t) {
        EXPECT_EQ(norm(o1[t], o2[t], NORM_INF), 0) << "frame " << t;
        EXPECT_EQ(norm(s1[t], s2[t], NORM_INF), 0) << "frame " << t;
    }
    std::printf(
        "[ measured ] static clip, 8 frames: shadow pixels found %d (1 thread) and %d (2)\n",
        found1, found2);
}
