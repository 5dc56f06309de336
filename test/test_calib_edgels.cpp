// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The edge-pixel ("Manhattan World") likelihood of a camera frame (manhattan_edgels.hpp) on
// synthetic room pictures with known cameras: the true frame scores above wrong ones, and the
// local refinement started off the truth comes back to it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room.hpp>

#include "manhattan_edgels.hpp"  // white-box

using namespace cv;
using namespace cv::vbme;

namespace {

Matx33d rotAxis(const Vec3d& axis, double deg) {
    Matx33d R;
    Rodrigues(axis * (deg * CV_PI / 180), R);
    return R;
}

Camera roomCamera(double f, double yaw, double pitch, double roll, Size size) {
    Camera c = Camera::fromFocal(f, size);
    const Matx33d R0(1, 0, 0, 0, 0, -1, 0, 1, 0);
    c.R = rotAxis(Vec3d(0, 0, 1), roll) * rotAxis(Vec3d(1, 0, 0), -pitch) * R0 *
          rotAxis(Vec3d(0, 0, 1), -yaw);
    placeCamera(c, 1.5);
    return c;
}

double rotationErrorDeg(const Matx33d& A, const Matx33d& B) {
    const Matx33d D = A.t() * B;
    return std::acos(std::max(-1.0, std::min(1.0, (trace(D) - 1) / 2))) * 180 / CV_PI;
}

}  // namespace

TEST(CalibEdgels, TrueFrameScoresBestAndRefinementReturnsToIt) {
    const Size size(640, 480);
    const double W = 640;
    Room room;
    room.min = Vec3d(-2.2, -1.4, 0);
    room.max = Vec3d(2.6, 4.1, 2.7);
    RNG rng(7);
    double worst_f = 0, worst_r = 0;
    for (int trial = 0; trial < 4; ++trial) {
        const double f = rng.uniform(400.0, 900.0);
        const Camera c = roomCamera(f, rng.uniform(15.0, 35.0) * (trial % 2 ? 1 : -1),
                                    -rng.uniform(5.0, 20.0), rng.uniform(-4.0, 4.0), size);
        Mat img = drawSyntheticRoom(c, room, 0.5, 2.0, trial), gray;
        cvtColor(img, gray, COLOR_BGR2GRAY);
        const Point2d pp(c.K(0, 2), c.K(1, 2));
        const vbme::detail::Edgels e = vbme::detail::extractEdgels(gray, pp, W, 3000);
        ASSERT_GT(e.size(), 500u);
        const vbme::detail::EdgelModel m;
        const double s_true = vbme::detail::edgelScore(e, c.R, f / W, m);
        // Wrong frames: focal ±20 %, rotation 2° about each axis.
        for (double df : {0.8, 1.25})
            EXPECT_GT(s_true, vbme::detail::edgelScore(e, c.R, f * df / W, m)) << "trial " << trial;
        for (int a = 0; a < 3; ++a) {
            Vec3d ax(0, 0, 0);
            ax[a] = 1;
            EXPECT_GT(s_true, vbme::detail::edgelScore(e, rotAxis(ax, 2) * c.R, f / W, m))
                << "trial " << trial << " axis " << a;
        }
        // Refinement from focal +10 % and 1.5° off.
        Matx33d D = rotAxis(normalize(Vec3d(1, 2, 3)), 1.5) * c.R;
        double F = 1.1 * f / W;
        const double s_ref = vbme::detail::refineEdgels(e, D, F, m, false, 20);
        const double fe = std::abs(F * W / f - 1), re = rotationErrorDeg(D, c.R);
        std::printf(
            "trial %d: f %.0f px, %d edgels, score true %.4f refined %.4f; focal error "
            "%.2f %%, rotation error %.3f deg\n",
            trial, f, (int)e.size(), s_true, s_ref, 100 * fe, re);
        worst_f = std::max(worst_f, fe);
        worst_r = std::max(worst_r, re);
    }
    std::printf(
        "edgel refinement from +10 %% / 1.5 deg: worst focal error %.2f %%, rotation "
        "%.3f deg\n",
        100 * worst_f, worst_r);
    EXPECT_LT(worst_f, 0.02);
    EXPECT_LT(worst_r, 0.3);
}
