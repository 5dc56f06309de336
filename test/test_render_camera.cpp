// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <cstring>

#include <opencv2/calib3d.hpp>
#include <opencv2/vbme/render/camera.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {
Camera testCamera() {
    Camera c;
    c.K = Matx33d(612.3, 0, 318.7, 0, 598.1, 241.2, 0, 0, 1);  // projectPoints has no skew
    Matx31d rvec(0.3, -0.7, 0.2);
    Matx33d R;
    Rodrigues(rvec, R);
    c.R = R;
    c.t = Vec3d(0.2, -0.4, 3.1);
    c.image_size = Size(640, 480);
    return c;
}
}  // namespace

// The ray through the pixel where cv::projectPoints puts a world point passes through it.
TEST(RenderCamera, RaysAgreeWithProjectPoints) {
    const Camera c = testCamera();
    const PinholeCamera cam(c);
    RNG rng(1);
    std::vector<Point3d> pts;
    for (int i = 0; i < 200; ++i) {
        const Vec3d Xc(rng.uniform(-2.0, 2.0), rng.uniform(-1.5, 1.5), rng.uniform(0.5, 8.0));
        pts.push_back(Point3d(c.worldFromCam(Xc)));
    }
    Matx31d rvec;
    Rodrigues(c.R, rvec);
    std::vector<Point2d> proj;
    projectPoints(pts, rvec, c.t, c.K, noArray(), proj);
    double worst_px = 0, worst_dist = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
        const Point2d p = cam.project(Vec3d(pts[i]));
        worst_px = std::max(worst_px, norm(p - proj[i]));
        Vec3f o, d;
        cam.generateRay(Point2f(proj[i]), o, d);
        EXPECT_NEAR(norm(d), 1.0, 1e-6);
        const Vec3d X(pts[i]), od(o), dd(d);
        const double t = (X - od).dot(dd);
        const Vec3d closest = od + dd * t;
        // distance off the ray, expressed in pixels at that depth
        const double depth = c.camFromWorld(X)[2];
        worst_dist = std::max(worst_dist, norm(closest - X) / depth * c.K(0, 0));
    }
    EXPECT_LT(worst_px, 1e-9);
    EXPECT_LT(worst_dist, 0.01);  // a small fraction of a pixel
}

// Pixel centres at integers: the principal point of a centred camera is ((w−1)/2, (h−1)/2),
// and its ray is the optical axis; rendering at half size scales K (Camera::scaled).
TEST(RenderCamera, PixelCentresAndScaling) {
    Camera c = Camera::fromFocal(500, Size(64, 48));
    PinholeCamera cam(c);
    Vec3f o, d;
    cam.generateRay(Point2f(31.5f, 23.5f), o, d);
    EXPECT_NEAR(d[0], 0, 1e-7);
    EXPECT_NEAR(d[1], 0, 1e-7);
    EXPECT_NEAR(d[2], 1, 1e-7);
    const Camera half = c.scaled(Size(32, 24));
    PinholeCamera cam2(half);
    // A point at the left edge of pixel 0 of the big image (x = −0.5) is at x = −0.5 in the
    // small one too; the image centre maps to the image centre.
    const Vec3d X = c.worldFromCam(Vec3d(-0.5 - 31.5, 0, 500));
    EXPECT_NEAR(cam2.project(X).x, -0.5, 1e-9);
    EXPECT_NEAR(cam2.project(c.worldFromCam(Vec3d(0, 0, 1))).x, 15.5, 1e-9);
    EXPECT_THROW(PinholeCamera{Camera()}, cv::Exception);  // no image size
}

// generateRays (four rays at a time in SSE) gives generateRay's bits for every point, over a
// whole image's pixel grid with sub-pixel offsets, any count (the remainder after the last four).
TEST(RenderCamera, GenerateRaysSameBitsAsGenerateRay) {
    Camera c = Camera::fromFocal(277.3, Size(320, 240));
    c.R = Matx33d(0.96, -0.28, 0, 0.1344, 0.4608, -0.8776, 0.2457, 0.8424, 0.48);  // ≈ rotation
    c.t = Vec3d(0.3, -1.2, 2.5);
    const PinholeCamera cam(c);
    RNG rng(3);
    std::vector<Point2f> px;
    for (int y = 0; y < 240; y += 3)
        for (int x = 0; x < 320; x += 3)
            px.push_back(Point2f(x + rng.uniform(-0.5f, 0.5f), y + rng.uniform(-0.5f, 0.5f)));
    px.push_back(Point2f(159.5f, 119.5f));
    int differ = 0, checked = 0;
    for (int n : {(int)px.size(), 1, 3, 5, 7}) {
        std::vector<Vec3f> dirs(n);
        cam.generateRays(px.data(), n, dirs.data());
        for (int i = 0; i < n; ++i) {
            Vec3f o, d;
            cam.generateRay(px[i], o, d);
            ++checked;
            if (std::memcmp(&d, &dirs[i], sizeof(Vec3f)) != 0 ||
                std::memcmp(&o, &cam.origin(), sizeof(Vec3f)) != 0)
                ++differ;
        }
    }
    EXPECT_EQ(differ, 0) << "of " << checked;
}
