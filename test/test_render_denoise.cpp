// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// denoiseDifference: the joint bilateral filter of a differential render's difference layer.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/render/differential.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

// A 64×48 frame: a dark left half and a bright right half (the guide's edge at x = 32); a
// covered object at the centre; a true difference (a shadow) of −0.2 on the left half's lower
// part and −0.05 on the right half's, exactly 0 above y = 20; the rendered difference is the
// truth plus Gaussian noise (σ 0.05) where it is not 0.
struct Frame {
    Mat guide, truth;
    DifferentialImages layers;
    Frame() {
        const Size sz(64, 48);
        guide.create(sz, CV_8UC3);
        truth.create(sz, CV_32FC3);
        layers.mask = Mat::zeros(sz, CV_32FC1);
        RNG rng(5);
        for (int y = 0; y < sz.height; ++y)
            for (int x = 0; x < sz.width; ++x) {
                guide.at<Vec3b>(y, x) = x < 32 ? Vec3b(40, 40, 40) : Vec3b(200, 200, 200);
                const float t = y < 20 ? 0.f : x < 32 ? -0.2f : -0.05f;
                truth.at<Vec3f>(y, x) = Vec3f::all(t);
            }
        layers.mask(Rect(26, 26, 12, 10)).setTo(1.f);
        layers.diff = truth.clone();
        for (int y = 20; y < sz.height; ++y)
            for (int x = 0; x < sz.width; ++x)
                layers.diff.at<Vec3f>(y, x) += Vec3f::all(float(rng.gaussian(0.05)));
    }
    // RMS error against the truth outside the coverage
    double error(const Mat& diff) const {
        double se = 0;
        int n = 0;
        for (int y = 0; y < diff.rows; ++y)
            for (int x = 0; x < diff.cols; ++x)
                if (layers.mask.at<float>(y, x) == 0) {
                    const Vec3f d = diff.at<Vec3f>(y, x) - truth.at<Vec3f>(y, x);
                    se += d.dot(d) / 3;
                    ++n;
                }
        return std::sqrt(se / n);
    }
};

}  // namespace

TEST(RenderDenoise, LowersTheErrorKeepsZerosCoverageAndEdges) {
    const Frame f;
    DifferentialImages d = f.layers;
    d.diff = f.layers.diff.clone();
    denoiseDifference(d, f.guide, 2);
    // Baseline: a plain 5×5 box filter of the difference (no guide, no mask).
    Mat box;
    blur(f.layers.diff, box, Size(5, 5), Point(-1, -1), BORDER_REPLICATE);
    const double e_in = f.error(f.layers.diff), e_out = f.error(d.diff), e_box = f.error(box);
    std::printf("[ measured ] RMS error: noisy %.4f, denoised (r 2) %.4f, box 5x5 %.4f\n", e_in,
                e_out, e_box);
    EXPECT_LT(e_out, 0.5 * e_in);
    EXPECT_LT(e_out, e_box);  // the box blurs the step at the guide's edge and the zero border
    // Rows whose window holds no difference stay exactly 0; covered pixels are untouched.
    for (int y = 0; y < 18; ++y)
        for (int x = 0; x < 64; ++x)
            ASSERT_EQ(d.diff.at<Vec3f>(y, x), Vec3f(0, 0, 0)) << x << "," << y;
    Mat cov_in = f.layers.diff(Rect(26, 26, 12, 10)), cov_out = d.diff(Rect(26, 26, 12, 10));
    EXPECT_EQ(norm(cov_in, cov_out, NORM_INF), 0.0);
    // The step across the guide's edge survives: the columns next to it (x = 31 | 32, rows
    // 36..47); the box filter, the control, mixes the two sides there.
    auto side = [](const Mat& m, int x) { return mean(m(Rect(x, 36, 1, 12)))[0]; };
    const double left = side(d.diff, 31), right = side(d.diff, 32);
    const double box_left = side(box, 31), box_right = side(box, 32);
    std::printf("[ measured ] beside the edge: %.3f | %.3f, box %.3f | %.3f (truth -0.2 | -0.05)\n",
                left, right, box_left, box_right);
    EXPECT_LT(std::abs(left + 0.2), 0.5 * std::abs(box_left + 0.2));
    EXPECT_LT(std::abs(right + 0.05), 0.5 * std::abs(box_right + 0.05));
    // 16-bit and float guides give the same result as the 8-bit one.
    Mat g16, g32;
    f.guide.convertTo(g16, CV_16UC3, 257.0);
    f.guide.convertTo(g32, CV_32FC3, 1 / 255.0);
    for (const Mat& g : {g16, g32}) {
        DifferentialImages e = f.layers;
        e.diff = f.layers.diff.clone();
        denoiseDifference(e, g, 2);
        EXPECT_LT(norm(e.diff, d.diff, NORM_INF), 1e-5);
    }
}
