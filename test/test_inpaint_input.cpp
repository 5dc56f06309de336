// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Exemplar and video inpainting on bad or degenerate input: defined results, clear errors.
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/inpaint.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

Mat noiseImage(Size s, int seed = 3) {
    Mat m(s, CV_8UC3);
    RNG rng(seed);
    rng.fill(m, RNG::UNIFORM, 0, 256);
    GaussianBlur(m, m, Size(0, 0), 1.5);
    return m;
}

/** Runs @p f and returns the cv::Exception message it throws ("" if none). */
std::string errorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const cv::Exception& e) {
        return e.err;
    }
    return "";
}

TEST(InpaintInput, EmptyMaskIsANoOp) {
    const Mat img = noiseImage(Size(64, 48));
    Mat out;
    ExemplarInpainter::create()->inpaint(img, Mat::zeros(img.size(), CV_8U), out);
    EXPECT_EQ(norm(out, img, NORM_INF), 0);
}

TEST(InpaintInput, FullMaskSaysNothingToCopyFrom) {
    const Mat img = noiseImage(Size(64, 48));
    Mat out;
    const std::string err = errorOf([&] {
        ExemplarInpainter::create()->inpaint(img, Mat(img.size(), CV_8U, Scalar(255)), out);
    });
    EXPECT_NE(err.find("no 9x9 patch"), std::string::npos) << err;
    EXPECT_NE(err.find("100.0%"), std::string::npos) << err;
    EXPECT_TRUE(out.empty()) << "nothing is written on failure";
}

TEST(InpaintInput, MaskLeavingNoWholePatchIsRejected) {
    // A known border 3 pixels wide holds no 9×9 patch.
    const Mat img = noiseImage(Size(64, 48));
    Mat mask(img.size(), CV_8U, Scalar(255));
    mask.rowRange(0, 3).setTo(0);
    Mat out;
    EXPECT_NE(errorOf([&] {
                  ExemplarInpainter::create()->inpaint(img, mask, out);
              }).find("smaller mask or patch_size"),
              std::string::npos);
    // A 3×3 patch fits: it fills.
    ExemplarInpainter::Params p;
    p.patch_size = 3;
    ExemplarInpainter::create(p)->inpaint(img, mask, out);
    EXPECT_EQ(out.size(), img.size());
}

TEST(InpaintInput, SizeMismatchNamesBothSizes) {
    const Mat img = noiseImage(Size(64, 48));
    Mat out;
    const std::string err =
        errorOf([&] { ExemplarInpainter::create()->inpaint(img, Mat::zeros(40, 30, CV_8U), out); });
    EXPECT_NE(err.find("mask is 30x40 but the image is 64x48"), std::string::npos) << err;
}

TEST(InpaintInput, WrongTypesAreRejected) {
    const Mat img = noiseImage(Size(64, 48));
    const Mat mask = Mat::zeros(img.size(), CV_8U);
    Mat out;
    EXPECT_NE(errorOf([&] {
                  ExemplarInpainter::create()->inpaint(img, Mat::zeros(img.size(), CV_32F), out);
              }).find("expected CV_8UC1"),
              std::string::npos);
    EXPECT_NE(errorOf([&] {
                  ExemplarInpainter::create()->inpaint(Mat(img.size(), CV_32FC3), mask, out);
              }).find("expected CV_8UC3 (BGR) or CV_8UC1"),
              std::string::npos);
    EXPECT_NE(errorOf([&] {
                  ExemplarInpainter::create()->inpaint(Mat(), mask, out);
              }).find("image is empty"),
              std::string::npos);
    EXPECT_NE(errorOf([&] {
                  ExemplarInpainter::create()->inpaint(img, Mat(), out);
              }).find("mask is empty"),
              std::string::npos);
}

TEST(InpaintInput, NonBinaryMaskFillsEveryNonZeroPixel) {
    // An anti-aliased mask: its soft edge (values 1..254) is filled like 255.
    const Mat img = noiseImage(Size(80, 60));
    Mat soft = Mat::zeros(img.size(), CV_8U);
    circle(soft, Point(40, 30), 10, Scalar(255), FILLED, LINE_AA);
    GaussianBlur(soft, soft, Size(5, 5), 0);
    ASSERT_GT(countNonZero((soft > 0) & (soft < 255)), 20);
    const Mat binary = (soft > 0);
    Mat a, b;
    ExemplarInpainter::create()->inpaint(img, soft, a);
    ExemplarInpainter::create()->inpaint(img, binary, b);
    EXPECT_EQ(norm(a, b, NORM_INF), 0);
    EXPECT_EQ(norm(a, img, NORM_INF, ~binary), 0) << "only the hole changes";
}

TEST(InpaintInput, InvalidParamsAreRejected) {
    ExemplarInpainter::Params p;
    p.patch_size = 8;
    EXPECT_NE(errorOf([&] { ExemplarInpainter::create(p); }).find("expected an odd number >= 3"),
              std::string::npos);
    p = ExemplarInpainter::Params();
    p.method = 7;
    EXPECT_NE(errorOf([&] { ExemplarInpainter::create(p); }).find("PatchSearchMethod"),
              std::string::npos);
    VideoInpainter::Params v;
    v.temporal_radius = -1;
    EXPECT_NE(
        errorOf([&] { VideoInpainter::create(v); }).find("temporal_radius = -1: expected >= 0"),
        std::string::npos);
}

TEST(InpaintInput, VideoRejectsFrameSizeChangeAndBadMask) {
    Ptr<VideoInpainter> vi = VideoInpainter::create();
    vi->push(noiseImage(Size(64, 48)), Mat());
    EXPECT_NE(errorOf([&] {
                  vi->push(noiseImage(Size(32, 48)), Mat());
              }).find("frame 1 is 32x48, earlier frames 64x48"),
              std::string::npos);
    EXPECT_NE(errorOf([&] {
                  vi->push(noiseImage(Size(64, 48)), Mat::zeros(10, 10, CV_8U));
              }).find("mask 1 is 10x10 but the frame is 64x48"),
              std::string::npos);
    EXPECT_NE(errorOf([&] {
                  vi->push(Mat(48, 64, CV_8UC1), Mat());
              }).find("expected a non-empty CV_8UC3"),
              std::string::npos);
}

}  // namespace
