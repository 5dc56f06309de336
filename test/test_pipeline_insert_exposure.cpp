// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Exposure and white balance per frame (issue 21) on footage vbme did not render: the Blender
// clip of test/data/insertion_blender (input without the object, Cycles truth with it, true
// cameras and frame-0 scene) with a phone's auto-exposure and white-balance drift applied in
// linear light to the input and the truth alike (cv::vbme::CameraEffects).
#include <gtest/gtest.h>

#include <cstdlib>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core/camera_path.hpp>
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

struct Insertion {
    PreparedInsertion prep;
    PipelineReport report;
    std::vector<Mat> composites;  // of the frames asked
};

// Prepares the insertion of the clip's object into @p plate (written as PNGs) and renders
// @p frames with the library calls (the frames need not be contiguous).
Insertion insert(const std::vector<Mat>& plate, const CameraPath& path,
                 const std::vector<int>& frames, InsertionParams::ExposureMode mode,
                 const std::string& dir) {
    fs::create_directories(dir + "/plate");
    for (size_t i = 0; i < plate.size(); ++i)
        imwrite(dir + format("/plate/frame_%05d.png", (int)i), plate[i]);
    path.write(dir + "/cameras.yml");
    InsertionParams ip;
    ip.video = dir + "/plate/frame_%05d.png";
    ip.scene = kData + "/scene.yml";
    ip.cameras = dir + "/cameras.yml";
    ip.out = dir + "/inserted.mkv";
    ip.work = dir + "/work";
    ip.spp = 8;
    ip.exposure = mode;
    Insertion r;
    r.prep = prepareInsertion(ip, PipelineProgress(), &r.report);
    const int64 t0 = getTickCount();
    for (int i : frames) {
        Mat c;
        renderInsertionFrame(r.prep, i, plate[i], c);
        r.composites.push_back(c);
    }
    std::string st;
    for (const auto& kv : r.report.seconds)
        st += format(" %s %.2f", kv.first.c_str(), kv.second);
    std::printf("%s: stages (s)%s, render %.2f\n", dir.c_str(), st.c_str(),
                (getTickCount() - t0) / getTickFrequency());
    return r;
}

// Region PSNR over @p frames of composites against truths (regions from input vs truth).
double regionPsnrOver(const std::vector<Mat>& comp, const std::vector<Mat>& input,
                      const std::vector<Mat>& truth, const std::vector<int>& frames) {
    double sse = 0, n = 0;
    for (size_t k = 0; k < frames.size(); ++k) {
        const int i = frames[k];
        double s = 0, c = 0;
        regionPsnr(comp[k], truth[i], vbme_test::insertionInfluence(input[i], truth[i]), &s, &c);
        sse += s;
        n += c;
    }
    EXPECT_GT(n, 1000);
    return 10 * std::log10(255.0 * 255.0 * n / sse);
}

// With auto-exposure hunting ±17 % and the white balance drifting ±6 % (red and blue in
// opposite directions) over the clip, the recovered per-frame gains match the applied ones
// within 1 %, and the composite near the object follows the camera: with the compensation it
// is within 1 dB of the clean footage's result and clearly better than without it.
TEST(PipelineInsertExposure, GainsFollowTheCameraAndTheObjectWithThem) {
    // every other frame of the clip (a 12-frame clip that pans 24° on its frames 6-10), so
    // that the test's three preparations stay short
    std::vector<Mat> plate, truth;
    CameraPath path = CameraPath::read(kData + "/cameras.yml");
    {
        const std::vector<Mat> p = vbme_test::readVideoFrames(kData + "/plate.mkv"),
                               t = vbme_test::readVideoFrames(kData + "/truth.mkv");
        ASSERT_EQ(p.size(), t.size());
        ASSERT_EQ(p.size(), path.frames.size());
        std::vector<CameraPath::Frame> kept;
        for (size_t i = 0; i < p.size(); i += 2) {
            plate.push_back(p[i]);
            truth.push_back(t[i]);
            kept.push_back(path.frames[i]);
            kept.back().index = (int)i / 2;
        }
        path.frames = kept;
    }
    const int n = (int)plate.size();
    ASSERT_GE(n, 10);
    CameraEffects fx;
    fx.exposure_amplitude = 0.17;  // one cycle over the clip: 1.17 at frame 3, 0.83 at 9
    fx.period = 12;
    fx.wb_amplitude = 0.06;  // red +6 %, blue −6 % at frame 0, the opposite at 6
    std::vector<Mat> plate_fx(n), truth_fx(n);
    // relative to frame 0's, so that frame 0 (the annotated frame, the room model's exposure)
    // is Blender's and the scene's (true) light powers stay true
    const Vec3d a0 = cameraEffectGains(fx, 0);
    auto applied = [&](int i) {
        const Vec3d a = cameraEffectGains(fx, i);
        return Vec3d(a[0] / a0[0], a[1] / a0[1], a[2] / a0[2]);
    };
    for (int i = 0; i < n; ++i) {
        plate_fx[i] = applyLinearGains(plate[i], applied(i));
        truth_fx[i] = applyLinearGains(truth[i], applied(i));
    }
    vbme_test::ScratchDir tmp;
    // VBME_TEST_ALL_EFFECTS=1: also sensor noise (σ 1.5 code values, 0.7 px correlation,
    // independent seeds for input and truth) and H.264 at 400 kbit/s on both, i.e. every camera
    // effect of issue 21 at once with every compensation on (the defaults). Off in CI for time.
    // Measured 2026-11-24: gains within 0.70 %, region PSNR auto 35.28 dB, off 32.38 dB, clean
    // footage 32.45 dB (the truth's H.264 removes Cycles' own noise, so the figure can pass the
    // clean one).
    const char* all = std::getenv("VBME_TEST_ALL_EFFECTS");
    if (all && std::string(all) == "1") {
        for (int i = 0; i < n; ++i) {
            plate_fx[i] = addSensorNoise(plate_fx[i], 1.5, 0.7, 100 + i);
            truth_fx[i] = addSensorNoise(truth_fx[i], 1.5, 0.7, 500 + i);
        }
        plate_fx = compressH264(plate_fx, 12, 400000, tmp / "plate.mp4");
        truth_fx = compressH264(truth_fx, 12, 400000, tmp / "truth.mp4");
        std::printf("all camera effects: + noise 1.5 (0.7 px), H.264 400 kbit/s\n");
    }
    const std::vector<int> frames = {3, 9};  // the drift's extremes
    const Insertion on = insert(plate_fx, path, frames, InsertionParams::EXPOSURE_AUTO, tmp / "on");
    const Insertion off =
        insert(plate_fx, path, frames, InsertionParams::EXPOSURE_OFF, tmp / "off");
    const Insertion clean =
        insert(plate, path, frames, InsertionParams::EXPOSURE_AUTO, tmp / "clean");

    // the gains, relative to frame 0's, against the applied ones
    ASSERT_EQ((int)on.prep.gains.size(), n);
    const Vec3d g0 = on.prep.gains[0];
    double worst = 0, worst_off = 0, worst_clean = 0;
    std::printf("frame  applied B/G/R (rel. frame 0)   recovered B/G/R        clean footage\n");
    for (int i = 0; i < n; ++i) {
        const Vec3d a = applied(i), g = on.prep.gains[i];
        const Vec3d gc = clean.prep.gains[i];
        for (int c = 0; c < 3; ++c) {
            const double recovered = g[c] / g0[c];
            worst = std::max(worst, std::abs(recovered / a[c] - 1));
            worst_off = std::max(worst_off, std::abs(1 / a[c] - 1));
            worst_clean = std::max(worst_clean, std::abs(gc[c] / clean.prep.gains[0][c] - 1));
        }
        std::printf("%5d  %.4f %.4f %.4f          %.4f %.4f %.4f   %.4f %.4f %.4f\n", i, a[0], a[1],
                    a[2], g[0] / g0[0], g[1] / g0[1], g[2] / g0[2], gc[0], gc[1], gc[2]);
    }
    std::printf(
        "gains vs applied (relative to frame 0): worst error %.2f %% (gains 1, i.e. no "
        "estimate: %.2f %%); clean footage: worst |gain - 1| %.2f %%; fewest texels %g\n",
        100 * worst, 100 * worst_off, 100 * worst_clean, on.report.figure("exposure_texels_min"));
    EXPECT_LT(worst, 0.01);
    EXPECT_LT(worst_clean, 0.01);
    EXPECT_GT(worst_off, 0.15);  // the oracle can fail: no estimate is far off

    // to look at (kept with VBME_KEEP_TEST_FILES=1): truth | auto | off, per frame
    for (size_t k = 0; k < frames.size(); ++k) {
        Mat row;
        hconcat(std::vector<Mat>{truth_fx[frames[k]], on.composites[k], off.composites[k]}, row);
        imwrite(tmp / format("truth_auto_off_%02d.png", frames[k]), row);
    }
    const double p_on = regionPsnrOver(on.composites, plate_fx, truth_fx, frames);
    const double p_off = regionPsnrOver(off.composites, plate_fx, truth_fx, frames);
    const double p_clean = regionPsnrOver(clean.composites, plate, truth, frames);
    std::printf(
        "region PSNR on frames 3, 9 against the truth with the same effects: exposure auto "
        "%.2f dB, off %.2f dB; clean footage %.2f dB\n",
        p_on, p_off, p_clean);
    EXPECT_GT(p_on, p_clean - 1);
    EXPECT_GT(p_on, p_off + 0.5);
}

}  // namespace
