// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/vbme/core.hpp>

using namespace cv;
using namespace cv::vbme;

static Camera testCamera() {
    Camera c = Camera::fromFocal(700, Size(640, 480));
    Vec3d rvec(0.3, -0.2, 0.1);
    Mat R;
    Rodrigues(rvec, R);
    c.R = Matx33d(R);
    c.t = Vec3d(0.1, -0.4, 2.5);
    return c;
}

TEST(CoreCamera, ProjectionMatchesProjectPoints) {
    Camera c = testCamera();
    RNG rng(1);
    std::vector<Point3d> pts;
    for (int i = 0; i < 200; ++i)
        pts.emplace_back(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
    Mat rvec;
    Rodrigues(Mat(c.R), rvec);
    std::vector<Point2d> ref;
    projectPoints(pts, rvec, Mat(c.t), Mat(c.K), noArray(), ref);
    for (size_t i = 0; i < pts.size(); ++i) {
        double depth = 0;
        Point2d p = c.project(Vec3d(pts[i].x, pts[i].y, pts[i].z), &depth);
        EXPECT_GT(depth, 0);
        EXPECT_NEAR(p.x, ref[i].x, 1e-9);
        EXPECT_NEAR(p.y, ref[i].y, 1e-9);
    }
}

TEST(CoreCamera, RayDirectionInvertsProjection) {
    Camera c = testCamera();
    const Vec3d X(0.2, 0.3, -0.4);
    const Point2d px = c.project(X);
    const Vec3d d = c.rayDirection(px);
    const Vec3d toX = normalize(X - c.center());
    EXPECT_NEAR(norm(d - toX), 0, 1e-12);
}

TEST(CoreCamera, ImageCentreConvention) {
    Camera c = Camera::fromFocal(500, Size(640, 480));
    EXPECT_DOUBLE_EQ(c.K(0, 2), 319.5);
    EXPECT_DOUBLE_EQ(c.K(1, 2), 239.5);
    EXPECT_DOUBLE_EQ(c.toColmapPrincipalPoint().x, 320.0);
    c.fromColmapPrincipalPoint(Point2d(320, 240));
    EXPECT_DOUBLE_EQ(c.K(1, 2), 239.5);
}

TEST(CoreCamera, ScaledKeepsPixelCentres) {
    Camera c = testCamera();
    Camera h = c.scaled(Size(320, 240));
    EXPECT_DOUBLE_EQ(h.K(0, 0), 350);
    EXPECT_DOUBLE_EQ(h.K(0, 2), 159.5);
    // A point projecting to pixel p at full size projects to (p + 0.5) / 2 - 0.5 at half size.
    const Vec3d X(0.1, 0.2, 0.3);
    Point2d p = c.project(X), q = h.project(X);
    EXPECT_NEAR(q.x, (p.x + 0.5) / 2 - 0.5, 1e-9);
    EXPECT_NEAR(q.y, (p.y + 0.5) / 2 - 0.5, 1e-9);
}

TEST(CoreCamera, OrthonormalizeGivesRotation) {
    Matx33d R = testCamera().R;
    Matx33d noisy = R + Matx33d(1e-3, 0, 2e-3, 0, -1e-3, 0, 1e-3, 0, 0);
    Matx33d Ro = orthonormalize(noisy);
    EXPECT_NEAR(determinant(Mat(Ro)), 1.0, 1e-12);
    EXPECT_LT(norm(Mat(Ro.t() * Ro - Matx33d::eye())), 1e-12);
    EXPECT_LT(norm(Mat(Ro - R)), 5e-3);
}

// The focal length of a horizontal field of view: a point at half the angle off the axis
// projects to the outer edge of the last pixel column (x = w − ½ with centres at integers).
TEST(CoreCamera, FocalFromFovPutsTheHalfAngleAtTheImageEdge) {
    for (double fov : {30.0, 60.0, 90.0, 120.0})
        for (Size sz : {Size(640, 480), Size(321, 200)}) {
            const Camera c = Camera::fromFocal(Camera::focalFromFov(sz.width, fov), sz);
            const double h = fov * CV_PI / 360.0;
            EXPECT_NEAR(c.project(Vec3d(std::tan(h), 0, 1)).x, sz.width - 0.5, 1e-9);
            EXPECT_NEAR(c.project(Vec3d(-std::tan(h), 0, 1)).x, -0.5, 1e-9);
        }
    EXPECT_THROW(Camera::focalFromFov(0, 60), cv::Exception);
    EXPECT_THROW(Camera::focalFromFov(640, 180), cv::Exception);
    EXPECT_THROW(Camera::focalFromFov(640, 0), cv::Exception);
}
