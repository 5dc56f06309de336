// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The camera effects the insertion tests put on Blender clips: gains in linear light, noise of
// the asked level and correlation, nothing when off.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/datasets/camera_effects.hpp>

namespace {

using namespace cv;
using namespace cv::vbme;

Mat ramp() {
    Mat f(64, 96, CV_8UC3);
    for (int y = 0; y < f.rows; ++y)
        for (int x = 0; x < f.cols; ++x)
            f.at<Vec3b>(y, x) = Vec3b((uchar)(40 + x), (uchar)(60 + y), (uchar)(30 + x + y));
    return f;
}

TEST(DatasetsCameraEffects, GainsFollowTheDriftsInLinearLight) {
    CameraEffects fx;
    fx.exposure_amplitude = 0.17;
    fx.wb_amplitude = 0.06;
    // quarter period: exposure at its peak, white balance (a quarter turn later) at zero
    const Vec3d g12 = cameraEffectGains(fx, 12);
    EXPECT_NEAR(g12[1], 1.17, 1e-12);
    EXPECT_NEAR(g12[0], 1.17, 1e-9);
    EXPECT_NEAR(g12[2], 1.17, 1e-9);
    const Vec3d g0 = cameraEffectGains(fx, 0);  // exposure 1, white balance at its peak
    EXPECT_NEAR(g0[1], 1.0, 1e-12);
    EXPECT_NEAR(g0[2], 1.06, 1e-12);
    EXPECT_NEAR(g0[0], 0.94, 1e-12);

    // the frame's linear values scale by the gain (up to 8-bit rounding)
    const Mat f = ramp();
    const Mat out = applyLinearGains(f, g12);
    Mat lin_in, lin_out;
    linearize(f, lin_in, Response::SRGB);
    linearize(out, lin_out, Response::SRGB);
    const Scalar s_out = sum(lin_out), s_in = sum(lin_in);
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(s_out[c] / s_in[c], 1.17, 0.005) << c;
    // not a gain on the encoded values: those scale by less (the sRGB curve)
    EXPECT_LT(sum(out)[1] / sum(f)[1], 1.10);
}

TEST(DatasetsCameraEffects, NoiseHasTheAskedLevelAndCorrelation) {
    Mat flat(200, 200, CV_8UC3, Scalar(100, 120, 140));
    for (double blur : {0.0, 1.0}) {
        const Mat n = addSensorNoise(flat, 1.5, blur, 7);
        Mat d;
        n.convertTo(d, CV_32F);
        d -= Scalar(100, 120, 140);
        Scalar mean, sd;
        meanStdDev(d, mean, sd);
        for (int c = 0; c < 3; ++c) {
            // rounding to integers adds 1/12 to the variance
            EXPECT_NEAR(sd[c], std::sqrt(1.5 * 1.5 + 1.0 / 12), 0.06) << "blur " << blur;
            EXPECT_NEAR(mean[c], 0, 0.1);  // blurred: ~3000 independent values
        }
        // neighbour correlation: ~0 for white noise, high when blurred
        std::vector<Mat> ch;
        split(d, ch);
        const Mat a = ch[1](Rect(0, 0, 199, 200)), b = ch[1](Rect(1, 0, 199, 200));
        const double corr = (a.dot(b) / a.total()) / (sd[1] * sd[1]);
        if (blur == 0)
            EXPECT_LT(std::abs(corr), 0.05);
        else
            EXPECT_GT(corr, 0.5);
    }
    // deterministic in the seed
    EXPECT_EQ(norm(addSensorNoise(flat, 1.5, 0, 3), addSensorNoise(flat, 1.5, 0, 3), NORM_INF), 0);
    EXPECT_GT(norm(addSensorNoise(flat, 1.5, 0, 3), addSensorNoise(flat, 1.5, 0, 4), NORM_INF), 0);
}

TEST(DatasetsCameraEffects, DefaultIsIdentityAndFramesDiffer) {
    const Mat f = ramp();
    EXPECT_EQ(norm(applyCameraEffects(f, 5, CameraEffects()), f, NORM_INF), 0);
    CameraEffects fx;
    fx.noise_sigma = 1.5;
    fx.exposure_amplitude = 0.17;
    EXPECT_EQ(norm(applyCameraEffects(f, 5, fx), applyCameraEffects(f, 5, fx), NORM_INF), 0);
    EXPECT_GT(norm(applyCameraEffects(f, 5, fx), applyCameraEffects(f, 6, fx), NORM_INF), 0);
}

}  // namespace
