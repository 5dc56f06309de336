// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <opencv2/vbme/core.hpp>

using namespace cv;
using namespace cv::vbme;

TEST(CoreResponse, SrgbKnownValues) {
    // IEC 61966-2-1: 0.5 encoded is 0.21404 linear; 0.04045 is the knee.
    EXPECT_NEAR(linearize(0.5f, Response::SRGB), 0.214041f, 1e-5);
    EXPECT_NEAR(linearize(0.04045f, Response::SRGB), 0.04045f / 12.92f, 1e-7);
    EXPECT_NEAR(linearize(1.f, Response::SRGB), 1.f, 1e-6);
    EXPECT_NEAR(linearize(0.5f, Response::GAMMA22), std::pow(0.5f, 2.2f), 1e-7);
    EXPECT_EQ(linearize(0.3f, Response::LINEAR), 0.3f);
}

TEST(CoreResponse, RoundTripEveryByte) {
    for (Response r : {Response::SRGB, Response::GAMMA22, Response::LINEAR}) {
        Mat v(1, 256, CV_8UC3);
        for (int i = 0; i < 256; ++i)
            v.at<Vec3b>(i) = Vec3b(i, 255 - i, i / 2);
        Mat lin, back;
        linearize(v, lin, r);
        ASSERT_EQ(lin.type(), CV_32FC3);
        encode(lin, back, r, CV_8U);
        EXPECT_EQ(norm(v, back, NORM_INF), 0) << toString(r);
        // Monotone.
        for (int i = 1; i < 256; ++i)
            EXPECT_GT(lin.at<Vec3f>(i)[0], lin.at<Vec3f>(i - 1)[0]);
    }
}

TEST(CoreResponse, FloatAndSixteenBitAgreeWithScalar) {
    Mat f(1, 3, CV_32F);
    f.at<float>(0) = 0.f;
    f.at<float>(1) = 0.25f;
    f.at<float>(2) = 0.9f;
    Mat lin;
    linearize(f, lin, Response::SRGB);
    for (int i = 0; i < 3; ++i)
        EXPECT_FLOAT_EQ(lin.at<float>(i), linearize(f.at<float>(i), Response::SRGB));
    Mat s(1, 1, CV_16U, Scalar(65535));
    linearize(s, lin, Response::GAMMA22);
    EXPECT_NEAR(lin.at<float>(0), 1.f, 1e-6);
}

TEST(CoreResponse, ParseNames) {
    EXPECT_EQ(parseResponse("sRGB"), Response::SRGB);
    EXPECT_EQ(parseResponse("gamma2.2"), Response::GAMMA22);
    EXPECT_EQ(parseResponse("linear"), Response::LINEAR);
    EXPECT_THROW(parseResponse("log"), cv::Exception);
    for (Response r : {Response::SRGB, Response::GAMMA22, Response::LINEAR})
        EXPECT_EQ(parseResponse(toString(r)), r);
}
