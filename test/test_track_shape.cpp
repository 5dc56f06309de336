// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Shape recovery: the sphere's height map and its normals against the analytic sphere.
#include <gtest/gtest.h>

#include <opencv2/vbme/track.hpp>

using namespace cv;
using namespace cv::vbme;

TEST(TrackShape, HeightMapIsTheSphere) {
    const Disk d(Point2f(50.5f, 40.f), 30.f);
    Mat h;
    sphereHeightMap(Size(100, 80), d, h);
    ASSERT_EQ(h.type(), CV_32F);
    EXPECT_NEAR(h.at<float>(40, 50), std::sqrt(900.f - 0.25f), 1e-4);
    EXPECT_NEAR(h.at<float>(40, 70), std::sqrt(900.f - 19.5f * 19.5f), 1e-4);
    EXPECT_EQ(h.at<float>(5, 5), 0.f);
}

// Largest angle (degrees) between recovered and analytic normals over pixels within
// rim_fraction·r of the centre.
static double maxAngleError(int method, float rim_fraction, const Disk& d, Size size) {
    Mat h, mask, n, ref;
    sphereHeightMap(size, d, h);
    diskMask(size, d, mask);
    heightToNormals(h, mask, n, method);
    sphereNormals(size, d, ref);
    double worst = 0;
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            if (norm(Point2f((float)x, (float)y) - d.center) > rim_fraction * d.radius) continue;
            const Vec3f a = n.at<Vec3f>(y, x), b = ref.at<Vec3f>(y, x);
            EXPECT_LT(a[2], 0.f);  // visible normals face the camera
            EXPECT_NEAR(norm(a), 1.0, 1e-5);
            worst = std::max(worst, std::acos(std::min(1.0, (double)a.dot(b))) * 180 / CV_PI);
        }
    return worst;
}

TEST(TrackShape, CentralDifferenceNormalsWithinTwoDegrees) {
    const Disk d(Point2f(64.3f, 60.7f), 45.f);
    const double err = maxAngleError(NORMALS_CENTRAL, 0.9f, d, Size(130, 120));
    EXPECT_LT(err, 2.0);
}

TEST(TrackShape, ForwardDifferenceNormalsWithinTwoDegreesAwayFromRim) {
    // The thesis's forward differences are biased by half a pixel: fine in the interior.
    const Disk d(Point2f(64.3f, 60.7f), 45.f);
    EXPECT_LT(maxAngleError(NORMALS_FORWARD, 0.8f, d, Size(130, 120)), 2.0);
    EXPECT_GT(maxAngleError(NORMALS_FORWARD, 0.8f, d, Size(130, 120)),
              maxAngleError(NORMALS_CENTRAL, 0.8f, d, Size(130, 120)));
}

TEST(TrackShape, NormalMapPictureEncodesDirections) {
    const Disk d(Point2f(20, 20), 15);
    Mat n, img;
    sphereNormals(Size(41, 41), d, n);
    normalMapImage(n, img);
    const Vec3b centre = img.at<Vec3b>(20, 20), right = img.at<Vec3b>(20, 34),
                top = img.at<Vec3b>(6, 20);
    EXPECT_EQ(centre[0], 255);  // facing the viewer: blue
    EXPECT_GT(right[2], 200);   // pointing right: red
    EXPECT_GT(top[1], 200);     // pointing up: green
    EXPECT_EQ(img.at<Vec3b>(0, 0), Vec3b(0, 0, 0));
}
