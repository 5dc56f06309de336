// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// regionPsnr: the PSNR of a known error pattern, restricted to a region, pooled over frames.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core/metrics.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {
double psnrOfMse(double mse) {
    return 10 * std::log10(255.0 * 255.0 / mse);
}
}  // namespace

TEST(CoreMetrics, RegionPsnrOfAKnownError) {
    // b differs from a by +6 in every channel inside a rectangle and by 2 in the blue channel
    // elsewhere: the region's MSE is 36, the whole image's is known from the pixel counts.
    RNG rng(3);
    Mat a(40, 50, CV_8UC3);
    rng.fill(a, RNG::UNIFORM, 20, 200);
    const Rect r(10, 5, 20, 15);
    Mat b = a + Scalar(2, 0, 0);
    Mat roi = b(r);
    add(a(r), Scalar::all(6), roi);
    Mat region = Mat::zeros(a.size(), CV_8U);
    region(r).setTo(255);

    double sse = 0, count = 0;
    const double in = regionPsnr(a, b, region, &sse, &count);
    EXPECT_NEAR(in, psnrOfMse(36), 1e-9);
    EXPECT_DOUBLE_EQ(count, 3.0 * r.area());
    EXPECT_DOUBLE_EQ(sse, 36.0 * 3 * r.area());

    const double n = (double)a.total();
    const double whole_mse = (36.0 * 3 * r.area() + 4.0 * (n - r.area())) / (3 * n);
    EXPECT_NEAR(regionPsnr(a, b), psnrOfMse(whole_mse), 1e-9);

    // Pooling two frames through sse / count is the PSNR of their joint MSE.
    double sse2 = 0, count2 = 0;
    regionPsnr(a, a + Scalar::all(3), region, &sse2, &count2);
    EXPECT_NEAR(psnrOfMse((sse + sse2) / (count + count2)), psnrOfMse((36.0 + 9.0) / 2), 1e-9);
}

TEST(CoreMetrics, RegionPsnrEdgeCases) {
    Mat a(8, 8, CV_8UC1, Scalar(90));
    EXPECT_EQ(regionPsnr(a, a), std::numeric_limits<double>::infinity());
    Mat empty_region = Mat::zeros(a.size(), CV_8U);
    double count = -1;
    EXPECT_EQ(regionPsnr(a, a + 10, empty_region, nullptr, &count),
              std::numeric_limits<double>::infinity());
    EXPECT_EQ(count, 0.0);
    // One grey level of error everywhere: MSE 1.
    EXPECT_NEAR(regionPsnr(a, a + 1), psnrOfMse(1), 1e-9);
    EXPECT_THROW(regionPsnr(a, Mat(9, 8, CV_8UC1, Scalar(0))), cv::Exception);
    EXPECT_THROW(regionPsnr(Mat(8, 8, CV_32F, Scalar(0)), Mat(8, 8, CV_32F, Scalar(1))),
                 cv::Exception);
}
