// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion on footage vbme did not render: a lit room filmed hand-held, rendered by Blender
// Cycles without (the input) and with a diffuse sphere (the truth), with the true cameras and
// the true frame-0 scene (test/data/insertion_blender, scripts/blender/insertion_clip.py).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core/camera_path.hpp>
#include <opencv2/vbme/core/metrics.hpp>
#include <opencv2/vbme/core/video.hpp>
#include <opencv2/vbme/pipeline/insertion.hpp>

#include "insertion_blender_util.hpp"
#include "vbme_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

Mat influence(const Mat& input, const Mat& truth) {
    return vbme_test::insertionInfluence(input, truth);
}

// With the true cameras and the true annotation, the composite near the object is closer to
// Cycles' rendering of the object in the room than the input without it is, by a margin
// measured on this clip; the composite moved by 4 px (a wrong placement) must fall below it.
TEST(PipelineInsertBlender, TrueCamerasBeatTheInputAgainstCyclesTruth) {
    const std::string data = vbme_test::insertionBlenderData();
    vbme_test::ScratchDir tmp;
    InsertionParams ip = vbme_test::insertionBlenderParams(tmp.path());
    ip.spp = 8;
    ip.end = 3;
    const PipelineReport rep = runInsertion(ip);
    ASSERT_EQ(rep.frames_processed, ip.end);

    // the sphere's own pixels (the clip's sphere: centre (0.25, 1.9, 0.2) m, radius 0.2 m,
    // scripts/blender/insertion_clip.py), projected with the true cameras, rim left out
    const CameraPath path = CameraPath::read(ip.cameras);
    auto sphereDisk = [&](int i, Size size) {
        const Camera cam = path.camera((size_t)i);
        double depth = 0;
        const Point2d c = cam.project(Vec3d(0.25, 1.9, 0.2), &depth);
        const double r = cam.K(0, 0) * 0.2 / depth;
        Mat m = Mat::zeros(size, CV_8U);
        circle(m, Point(cvRound(c.x), cvRound(c.y)), std::max(1, cvRound(r - 3)), Scalar(255),
               FILLED);
        return m;
    };
    Scalar bias_sum;  // composite − truth on the sphere, summed per channel (code values)
    double bias_n = 0;
    // the same frames composited with additive shadows (Eq. 5.2), through the stage API from
    // the same preparation: the baseline of the default ratio shadows
    PreparedInsertion additive = prepareInsertion(ip);
    ASSERT_TRUE(additive.reused);
    additive.composite.shadows = CompositeParams::SHADOWS_ADDITIVE;
    VideoReader plate(ip.video), truth(data + "/truth.mkv");
    double sse_out = 0, sse_in = 0, sse_off = 0, sse_add = 0, n = 0, n_off = 0;
    for (int i = 0; i < ip.end; ++i) {
        Mat in, tr;
        ASSERT_TRUE(plate.read(in));
        ASSERT_TRUE(truth.read(tr));
        const Mat out = imread(
            (fs::path(ip.work) / "frames" / format("frame_%05d.png", i)).string(), IMREAD_COLOR);
        ASSERT_EQ(out.size(), in.size());
        const Mat region = influence(in, tr);
        {
            Mat d;
            subtract(out, tr, d, noArray(), CV_32FC3);
            const Mat disk = sphereDisk(i, in.size());
            const double cnt = countNonZero(disk);
            bias_sum += mean(d, disk) * cnt;
            bias_n += cnt;
        }
        double s = 0, c = 0;
        regionPsnr(out, tr, region, &s, &c);
        sse_out += s;
        n += c;
        regionPsnr(in, tr, region, &s, &c);
        sse_in += s;
        Mat add;
        renderInsertionFrame(additive, i, in, add);
        regionPsnr(add, tr, region, &s, &c);
        sse_add += s;
        // negative control: the composite moved 4 px to the right inside the region (the object
        // and its shadow where they are not)
        Mat moved, off = in.clone();
        warpAffine(out, moved, Matx23d(1, 0, 4, 0, 1, 0), out.size(), INTER_NEAREST,
                   BORDER_REPLICATE);
        moved.copyTo(off, region);
        regionPsnr(off, tr, region, &s, &c);
        sse_off += s;
        n_off += c;
    }
    ASSERT_GT(n, 1000);
    auto psnr = [](double sse, double count) {
        return 10 * std::log10(255.0 * 255.0 * count / sse);
    };
    const double p_out = psnr(sse_out, n), p_in = psnr(sse_in, n);
    const double p_off = psnr(sse_off, n_off), p_add = psnr(sse_add, n);
    ASSERT_GT(bias_n, 100);
    const Scalar bias = bias_sum * (1.0 / bias_n);
    std::printf(
        "Blender truth, true cameras: region PSNR insert %.2f dB (additive shadows %.2f dB), "
        "input (no object) %.2f dB, composite moved 4 px %.2f dB, over %.0f values; white scale "
        "%.3f; sphere composite - truth (B, G, R) %.2f %.2f %.2f code values over %.0f pixels\n",
        p_out, p_add, p_in, p_off, n, rep.figure("white_scale"), bias[0], bias[1], bias[2], bias_n);
    // The object is as bright as Cycles renders it (it was 0.56x too dim, by the white point
    // scaling exact lights down; issue 21's "remaining 4 %")
    for (int c = 0; c < 3; ++c)
        EXPECT_LT(std::abs(bias[c]), 3.0) << "channel " << c;
    // measured 35.99 dB with adaptive sampling (the default since 2026-11-24: 2…32 spp, 5.3
    // samples per pixel), 32.76 dB with uniform 8 spp (the old default); additive shadows
    // 33.98 dB (31.19 dB uniform: their clamped black speckle where the sphere meets the
    // floor); 23.33 dB while the white point scaled the exact lights by 0.56
    EXPECT_GT(p_out, 34.5);
    EXPECT_GT(p_out, p_add + 0.5);
    // on clean footage the exposure gains (on by default) stay 1
    double worst_gain = 0;
    for (int i = 0; i < rep.frames_total; ++i)
        for (char c : {'b', 'g', 'r'})
            worst_gain =
                std::max(worst_gain, std::abs(rep.figure(format("gain_%d_%c", i, c), -1) - 1));
    std::printf("exposure gains on the clean clip (%d frames): worst |gain - 1| %.2f %%\n",
                rep.frames_total, 100 * worst_gain);
    EXPECT_LT(worst_gain, 0.01);
    EXPECT_GT(p_out, p_in + 3);
    EXPECT_GT(p_out, p_off + 1.5);
}

// Adaptive sampling of the differential render (issue 16), on the same footage: with a minimum
// of 2 and at most 32 samples per pixel it must beat uniform 8 spp by a clear margin at about
// its cost, and come near uniform 32 spp. (Its estimate used to weigh the later samples by the
// cap, 1 − n_min / 32, so that it rested on them alone: 35.00 dB then, 36.22 dB now.)
TEST(PipelineInsertBlender, AdaptiveSamplingBeatsUniformAtItsCost) {
    const std::string data = vbme_test::insertionBlenderData();
    vbme_test::ScratchDir tmp;
    InsertionParams ip = vbme_test::insertionBlenderParams(tmp.path());
    const PreparedInsertion prep = prepareInsertion(ip);
    const int frame = 1;
    Mat in, tr;
    {
        VideoReader plate(ip.video), truth(data + "/truth.mkv");
        for (int i = 0; i <= frame; ++i) {
            ASSERT_TRUE(plate.read(in));
            ASSERT_TRUE(truth.read(tr));
        }
    }
    const Mat region = influence(in, tr);
    struct Run {
        const char* name;
        int spp, min_spp;
        double psnr = 0, mean_spp = 0, seconds = 0;
    };
    std::vector<Run> runs = {{"uniform 8", 8, 0}, {"adaptive 2..32", 32, 2}, {"uniform 32", 32, 0}};
    for (Run& r : runs) {
        PreparedInsertion p = prep;
        p.renderer.release();
        p.render.spp = r.spp;
        p.render.adaptive_min_spp = r.min_spp;
        p.render.adaptive_error = 0.5f;
        p.render.adaptive_roulette = 0;
        DifferentialImages layers;
        Mat out;
        const int64 t0 = getTickCount();
        renderInsertionFrame(p, frame, in, out, &layers);
        r.seconds = double(getTickCount() - t0) / getTickFrequency();
        r.psnr = regionPsnr(out, tr, region);
        r.mean_spp = r.min_spp > 0 ? mean(layers.samples)[0] : r.spp;
        std::printf("%s: region PSNR %.2f dB, mean %.1f samples per pixel, %.2f s\n", r.name,
                    r.psnr, r.mean_spp, r.seconds);
    }
    // measured 32.78, 36.22 (mean 5.3 spp) and 37.05 dB; with the old weights the adaptive
    // render measured 1.9 dB below uniform 32
    EXPECT_LT(runs[1].mean_spp, 1.25 * 8);
    EXPECT_GT(runs[1].psnr, runs[0].psnr + 2.5);
    EXPECT_GT(runs[1].psnr, runs[2].psnr - 1.2);
}

}  // namespace
