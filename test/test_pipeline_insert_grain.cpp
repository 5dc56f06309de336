// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion that matches the camera's grain and motion blur (issue 21), on the Blender clip
// (test/data/insertion_blender: Cycles renders with and without a sphere, motion blur on with a
// half-frame shutter, a 24° pan over frames 12–20), with sensor noise added in test code to the
// input and the truth alike (cv::vbme::addSensorNoise, independent seeds: two recordings).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core/metrics.hpp>
#include <opencv2/vbme/core/video.hpp>
#include <opencv2/vbme/datasets/camera_effects.hpp>
#include <opencv2/vbme/pipeline/insertion.hpp>

#include "insertion_blender_util.hpp"
#include "vbme_test_util.hpp"
#include "video_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

const std::string kData = vbme_test::insertionBlenderData();

// Noise level of an image on a region: the RMS over the region's pixels and the channels of
// the residual I − G(σ = 1.5 px) * I (smooth shading cancels; the same estimator on every
// image compared, so its gain cancels in the ratios).
double noiseLevel(const Mat& img, const Mat& region) {
    Mat f, s;
    img.convertTo(f, CV_32FC3);
    GaussianBlur(f, s, Size(9, 9), 1.5);
    const Mat r = f - s;
    double ss = 0;
    int n = 0;
    for (int y = 0; y < r.rows; ++y)
        for (int x = 0; x < r.cols; ++x)
            if (region.at<uchar>(y, x)) {
                const Vec3f v = r.at<Vec3f>(y, x);
                ss += v.dot(v);
                n += 3;
            }
    return n ? std::sqrt(ss / n) : 0;
}

double psnr(double sse, double count) {
    return 10 * std::log10(255.0 * 255.0 * count / sse);
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The clip with sensor noise of σ = 1.5 code values (spatially correlated, 0.7 px) on the input
// and the truth, prepared once for the tests below (grain auto, shutter auto). The render is
// less noisy than the footage on the object (adaptive sampling: 4 samples where no path meets
// the object, up to 64 where one does), so that there is grain to add.
class PipelineInsertGrain : public ::testing::Test {
protected:
    static constexpr double kSigma = 1.5, kBlur = 0.7;
    struct Shared {
        vbme_test::ScratchDir tmp;
        std::vector<Mat> plate, truth, plate_n, truth_n;
        InsertionParams ip;
        PipelineReport rep;
        PreparedInsertion prep;
        double prepare_seconds = 0;
    };
    static Shared* s_;
    static void SetUpTestSuite() {
        const auto t0 = std::chrono::steady_clock::now();
        s_ = new Shared;
        Shared& s = *s_;
        s.plate = vbme_test::readVideoFrames(kData + "/plate.mkv");
        s.truth = vbme_test::readVideoFrames(kData + "/truth.mkv");
        ASSERT_EQ(s.plate.size(), s.truth.size());
        fs::create_directories(s.tmp.path() / "plate");
        for (size_t t = 0; t < s.plate.size(); ++t) {
            s.plate_n.push_back(addSensorNoise(s.plate[t], kSigma, kBlur, 1000 + t));
            s.truth_n.push_back(addSensorNoise(s.truth[t], kSigma, kBlur, 2000 + t));
            imwrite(s.tmp / format("plate/%05d.png", (int)t), s.plate_n.back());
        }
        s.ip.video = s.tmp / "plate/%05d.png";
        s.ip.scene = kData + "/scene.yml";
        s.ip.cameras = kData + "/cameras.yml";
        s.ip.out = s.tmp / "inserted.mkv";
        s.ip.work = s.tmp / "work";
        s.ip.spp = 16;
        s.ip.adaptive_min_spp = 4;
        s.prep = prepareInsertion(s.ip, PipelineProgress(), &s.rep);
        s.prepare_seconds = secondsSince(t0);
    }
    static void TearDownTestSuite() {
        delete s_;
        s_ = nullptr;
    }
};
PipelineInsertGrain::Shared* PipelineInsertGrain::s_ = nullptr;

// The measured model finds the added noise's level (with the clean clip's own noise in
// quadrature); the object in the composite is then as noisy as the truth's object (the room's
// noise at the same pixels of the other recording), within 20 %, and clearly less noisy with
// grain off.
TEST_F(PipelineInsertGrain, ObjectAsNoisyAsTheRoom) {
    ASSERT_TRUE(s_);
    const auto t0 = std::chrono::steady_clock::now();
    PreparedInsertion prep = s_->prep;
    const GrainModel& g = prep.grain;
    ASSERT_TRUE(g.reliable);
    ASSERT_TRUE(prep.grain_on);
    std::printf(
        "grain model: mean sigma %.3f code values, blur %.2f px (neighbour correlation "
        "%.3f), %d flat pixels; per bin (level: b g r):",
        g.meanSigma(), g.blur, g.correlation, g.pixels);
    for (size_t b = 0; b < g.level.size(); ++b)
        if (g.count[b] >= 300)
            std::printf(" %.0f: %.2f %.2f %.2f;", g.level[b], g.sigma[b][0], g.sigma[b][1],
                        g.sigma[b][2]);
    std::printf("\n");
    // the clean clip's own noise (Cycles' at 64 spp and the 8-bit rounding), for reference
    const GrainModel g_clean = measureGrain({s_->plate[0], s_->plate[8], s_->plate[16]});
    const double expect = std::sqrt(kSigma * kSigma + g_clean.meanSigma() * g_clean.meanSigma());
    std::printf(
        "grain model of the clean input: mean sigma %.3f, blur %.2f px; expected with "
        "the added noise %.3f\n",
        g_clean.meanSigma(), g_clean.blur, expect);
    EXPECT_NEAR(g.meanSigma(), expect, 0.2 * expect);

    double n_on = 0, n_off = 0, n_truth = 0;
    double sse_on = 0, sse_off = 0, cnt = 0;
    const int frames[] = {0, 1};
    for (int i : frames) {
        const Mat& in = s_->plate_n[i];
        DifferentialImages layers;
        Mat out_on, out_off;
        prep.grain_on = true;
        prep.shutter = 0;  // the first frames hardly move
        renderInsertionFrame(prep, i, in, out_on, &layers);
        prep.grain_on = false;
        renderInsertionFrame(prep, i, in, out_off);
        // the object's interior (full coverage, 2 px in)
        Mat obj = layers.mask >= 1.f;
        erode(obj, obj, getStructuringElement(MORPH_ELLIPSE, Size(5, 5)));
        ASSERT_GT(countNonZero(obj), 200);
        n_on += noiseLevel(out_on, obj) / 2;
        n_off += noiseLevel(out_off, obj) / 2;
        n_truth += noiseLevel(s_->truth_n[i], obj) / 2;
        const Mat region = vbme_test::insertionInfluence(s_->plate[i], s_->truth[i]);
        double s = 0, c = 0;
        regionPsnr(out_on, s_->truth_n[i], region, &s, &c);
        sse_on += s;
        cnt += c;
        regionPsnr(out_off, s_->truth_n[i], region, &s, &c);
        sse_off += s;
        if (i == 0) {
            imwrite(s_->tmp / "grain_on.png", out_on);
            imwrite(s_->tmp / "grain_off.png", out_off);
        }
    }
    std::printf(
        "noise level (residual RMS, code values) on the object, frames 0-1: grain on "
        "%.3f, off %.3f, truth (the room's noise there) %.3f; ratio on %.3f, off %.3f\n",
        n_on, n_off, n_truth, n_on / n_truth, n_off / n_truth);
    std::printf(
        "region PSNR against the noisy truth, frames 0-1: grain on %.2f dB, off %.2f "
        "dB over %.0f values (independent noise cannot match pixel by pixel); "
        "preparation %.1f s, test %.1f s\n",
        psnr(sse_on, cnt), psnr(sse_off, cnt), cnt, s_->prepare_seconds, secondsSince(t0));
    EXPECT_NEAR(n_on / n_truth, 1.0, 0.2);
    EXPECT_LT(n_off / n_truth, 0.75);
}

// After phone-rate H.264 (400 kbit/s at 320×180, 30 fps: about a phone's bits per pixel) of the
// noisy input and truth, the measured noise is weaker and more correlated. Printed, not
// asserted: the object's noise against the compressed truth's (compression keeps more noise on
// the object's gradients than on the flat walls the model is measured on).
TEST_F(PipelineInsertGrain, GrainMatchesAfterH264) {
    ASSERT_TRUE(s_);
    const auto t0 = std::chrono::steady_clock::now();
    const int n = 8;
    const std::vector<Mat> plate_n(s_->plate_n.begin(), s_->plate_n.begin() + n);
    const std::vector<Mat> truth_n(s_->truth_n.begin(), s_->truth_n.begin() + n);
    const std::vector<Mat> plate_c = compressH264(plate_n, 30, 400000, s_->tmp / "plate.mp4");
    const std::vector<Mat> truth_c = compressH264(truth_n, 30, 400000, s_->tmp / "truth.mp4");
    ASSERT_EQ((int)plate_c.size(), n);
    ASSERT_EQ((int)truth_c.size(), n);
    PreparedInsertion prep = s_->prep;
    prep.grain = measureGrain(plate_c);
    const GrainModel& g = prep.grain;
    std::printf(
        "grain model after H.264: mean sigma %.3f code values (before %.3f), blur %.2f px "
        "(before %.2f), reliable %d\n",
        g.meanSigma(), s_->prep.grain.meanSigma(), g.blur, s_->prep.grain.blur, (int)g.reliable);
    ASSERT_TRUE(g.reliable);
    prep.grain_on = true;
    prep.shutter = 0;
    double n_on = 0, n_off = 0, n_truth = 0;
    {
        DifferentialImages layers;
        Mat out, out_off;
        renderInsertionFrame(prep, 0, plate_c[0], out, &layers);
        prep.grain_on = false;
        renderInsertionFrame(prep, 0, plate_c[0], out_off);
        Mat obj = layers.mask >= 1.f;
        erode(obj, obj, getStructuringElement(MORPH_ELLIPSE, Size(5, 5)));
        n_on = noiseLevel(out, obj);
        n_off = noiseLevel(out_off, obj);
        n_truth = noiseLevel(truth_c[0], obj);
    }
    std::printf(
        "H.264: noise level on the object, frame 0: grain on %.3f, off %.3f, the "
        "compressed truth %.3f, ratio on %.3f, off %.3f; test %.1f s\n",
        n_on, n_off, n_truth, n_on / n_truth, n_off / n_truth, secondsSince(t0));
    EXPECT_LT(g.meanSigma(), 0.6 * s_->prep.grain.meanSigma());
    EXPECT_GT(g.blur, s_->prep.grain.blur);
}

// grain and shutter go through InsertionParams' read / write and check.
TEST(PipelineInsertGrainParams, ReadWriteCheck) {
    InsertionParams p;
    p.video = "v.mp4";
    p.scene = "s.yml";
    p.out = "o.mp4";
    p.grain = InsertionParams::GRAIN_OFF;
    p.shutter = 0.375;
    FileStorage fs(".yml", FileStorage::WRITE | FileStorage::MEMORY);
    fs << "p"
       << "{";
    p.write(fs);
    fs << "}";
    const std::string text = fs.releaseAndGetString();
    FileStorage in(text, FileStorage::READ | FileStorage::MEMORY);
    InsertionParams q;
    q.read(in["p"]);
    EXPECT_EQ(q.grain, InsertionParams::GRAIN_OFF);
    EXPECT_EQ(q.shutter, 0.375);
    EXPECT_NO_THROW(q.check());
    q.shutter = 1.5;
    EXPECT_THROW(q.check(), cv::Exception);
    q.shutter = -1;  // auto
    EXPECT_NO_THROW(q.check());
    FileStorage bad("%YAML:1.0\np: { grain: maybe }\n", FileStorage::READ | FileStorage::MEMORY);
    EXPECT_THROW(q.read(bad["p"]), cv::Exception);
}

// Motion blur: the shutter estimated from the room's edges is the clip's (half a frame); on the
// pan's fastest frame the composite rendered over it is closer to Cycles' motion-blurred truth
// near the object than the sharp render is, most of all along the object's outline.
TEST_F(PipelineInsertGrain, MotionBlurMatchesThePan) {
    ASSERT_TRUE(s_);
    const auto t0 = std::chrono::steady_clock::now();
    PreparedInsertion prep = s_->prep;
    const PipelineReport& rep = s_->rep;
    const double estimated = prep.shutter;
    std::printf(
        "shutter estimated %.3f of a frame (true 0.5) on frame %.0f (motion %.1f px a "
        "frame)\n",
        estimated, rep.figure("shutter_frame"), rep.figure("shutter_motion_px"));
    EXPECT_EQ(rep.figure("shutter_estimated"), 1);
    EXPECT_NEAR(estimated, 0.5, 0.1);

    double sse_on = 0, sse_off = 0, cnt = 0, esse_on = 0, esse_off = 0, ecnt = 0;
    const int frames[] = {16};  // the fastest
    for (int i : frames) {
        const Mat region = vbme_test::insertionInfluence(s_->plate[i], s_->truth[i]);
        Mat on, off;
        DifferentialImages layers;
        prep.shutter = estimated;
        renderInsertionFrame(prep, i, s_->plate_n[i], on);
        prep.shutter = 0;
        renderInsertionFrame(prep, i, s_->plate_n[i], off, &layers);
        // the outline: 3 px either side of the sharp render's silhouette
        Mat in = layers.mask > 0.5f, outline, inner;
        dilate(in, outline, getStructuringElement(MORPH_ELLIPSE, Size(7, 7)));
        erode(in, inner, getStructuringElement(MORPH_ELLIPSE, Size(7, 7)));
        outline &= ~inner;
        double s = 0, c = 0;
        regionPsnr(on, s_->truth_n[i], region, &s, &c);
        sse_on += s;
        cnt += c;
        regionPsnr(off, s_->truth_n[i], region, &s, &c);
        sse_off += s;
        regionPsnr(on, s_->truth_n[i], outline, &s, &c);
        esse_on += s;
        ecnt += c;
        regionPsnr(off, s_->truth_n[i], outline, &s, &c);
        esse_off += s;
        if (i == frames[0]) {
            imwrite(s_->tmp / "blur_on.png", on);
            imwrite(s_->tmp / "blur_off.png", off);
            imwrite(s_->tmp / "blur_truth.png", s_->truth_n[i]);
        }
    }
    const double p_on = psnr(sse_on, cnt), p_off = psnr(sse_off, cnt);
    const double e_on = psnr(esse_on, ecnt), e_off = psnr(esse_off, ecnt);
    std::printf(
        "pan frame 16 against Cycles' blurred truth: region PSNR blur on %.2f dB, "
        "off %.2f dB over %.0f values; outline (±3 px) PSNR on %.2f dB, off %.2f dB "
        "over %.0f values; test %.1f s\n",
        p_on, p_off, cnt, e_on, e_off, ecnt, secondsSince(t0));
    EXPECT_GT(p_on, p_off + 0.1);
    EXPECT_GT(e_on, e_off + 1);
}

}  // namespace
