// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// fillUnseenTexels: unseen texels of a room texture filled from the seen ones.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/render/room_texture.hpp>

namespace {

using namespace cv;
using namespace cv::vbme;

// A periodic linear texture (tiles of one repeated pattern: what exemplar filling can recover)
// scaled to radiance @p scale.
Mat tiledTexture(Size size, int period, float scale) {
    Mat t(size, CV_32FC3);
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            const int u = x % period, v = y % period;
            const bool dark = (u < period / 2) != (v < period / 2);
            const float g = dark ? 0.2f : 0.8f;
            t.at<Vec3f>(y, x) = Vec3f(scale * g * 0.6f, scale * g * 0.8f, scale * g);
        }
    return t;
}

double meanAbsInside(const Mat& a, const Mat& b, const Mat& mask) {
    Mat d;
    absdiff(a, b, d);
    const Scalar m = mean(d, mask);
    return (m[0] + m[1] + m[2]) / 3;
}

// Fills @p truth with the texels where @p seen is 0 zeroed (as the accumulator leaves them);
// checks that the seen texels stay bit for bit and returns the mean error of the fill inside the
// hole, and in @p naive_error that of the naive fill (the seen texels' mean).
double fillError(const Mat& truth, const Mat& seen, double& naive_error, Mat* filled = nullptr) {
    const Mat hole = seen == 0;
    Mat tex = truth.clone();
    tex.setTo(Scalar::all(0), hole);
    fillUnseenTexels(tex, seen);
    Mat diff;
    absdiff(tex, truth, diff);
    EXPECT_EQ(norm(diff, NORM_INF, seen), 0.0);
    Mat naive = truth.clone();
    naive.setTo(mean(truth, seen), hole);
    naive_error = meanAbsInside(naive, truth, hole);
    if (filled) *filled = tex;
    return meanAbsInside(tex, truth, hole);
}

}  // namespace

// A hole in a periodic texture comes back close to the truth (much closer than the mean of the
// seen texels, the naive fill); the seen texels are left bit for bit; scale does not matter.
TEST(RenderRoomTextureFill, RecoversAPeriodicTextureAndKeepsSeenTexels) {
    for (const float scale : {1.0f, 7.5f}) {
        const Mat truth = tiledTexture(Size(96, 80), 16, scale);
        Mat seen(truth.size(), CV_8U, Scalar(255));
        seen(Rect(40, 30, 14, 12)).setTo(0);
        double err_naive = 0;
        const double err = fillError(truth, seen, err_naive);
        std::printf("scale %.1f: mean |fill - truth| %.4f, naive (mean of seen) %.4f\n", scale, err,
                    err_naive);
        EXPECT_LT(err, 0.5 * err_naive);
    }
}

// Large textures are filled at a reduced size: the hole is filled (no zero texel left), the seen
// texels stay; a texture nothing saw becomes mid-grey.
TEST(RenderRoomTextureFill, LargeTexturesAndNothingSeen) {
    const Mat truth = tiledTexture(Size(600, 300), 40, 1.0f);
    Mat seen(truth.size(), CV_8U, Scalar(255));
    seen(Rect(300, 100, 50, 40)).setTo(0);
    double err_naive = 0;
    Mat tex;
    const double err = fillError(truth, seen, err_naive, &tex);
    Mat grey;
    cvtColor(tex, grey, COLOR_BGR2GRAY);
    EXPECT_EQ(countNonZero(grey(Rect(300, 100, 50, 40)) <= 0), 0);
    std::printf("600x300: mean |fill - truth| %.4f, naive %.4f\n", err, err_naive);
    EXPECT_LT(err, err_naive);

    Mat none(Size(8, 8), CV_32FC3, Scalar::all(0));
    fillUnseenTexels(none, Mat(none.size(), CV_8U, Scalar(0)));
    EXPECT_EQ(norm(none - Scalar::all(0.18), NORM_INF), 0.0);
}
