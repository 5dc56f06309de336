// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Object placement (placeOnFloor, objectWorldBounds).
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/vbme/datasets/room_sequence.hpp>
#include <opencv2/vbme/render/placement.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;

// --place: the placed object's bottom centre projects back onto the pixel (< 0.5 px) and
// sits on the floor; a pixel looking at the ceiling and one that would push the object
// through a wall are refused.
TEST(RenderPlacement, PlaceOnFloorHitsThePixel) {
    vbme_test::ScratchDir dir;
    Scene s = syntheticRoomScene(Size(160, 120), 130, 0.35, 1.5);
    const std::string mesh = dir / "cube.obj";
    vbme_test::writeCubeObj(mesh, "", "", 0.3, true);
    SceneObject o;
    o.mesh = mesh;
    // a turned object, offset: placement keeps the turn and replaces the offset
    const double a = 0.4;
    o.world_from_object = Matx44d(std::cos(a), -std::sin(a), 0, 5, std::sin(a), std::cos(a), 0, 5,
                                  0, 0, 1, 5, 0, 0, 0, 1);
    for (const Point2d px : {Point2d(80, 100), Point2d(30.25, 90.5), Point2d(120, 75)}) {
        SceneObject placed = o;
        placed.world_from_object = placeOnFloor(s, o, px);
        Vec3d lo, hi;
        objectWorldBounds(placed, lo, hi);
        EXPECT_NEAR(lo[2], s.room.min[2], 1e-5);
        const Vec3d bottom((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]);
        double depth = 0;
        const Point2d back = s.camera.project(bottom, &depth);
        EXPECT_GT(depth, 0);
        EXPECT_LT(norm(back - px), 0.5) << px << " -> " << back;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                EXPECT_DOUBLE_EQ(placed.world_from_object(r, c), o.world_from_object(r, c));
    }
    EXPECT_THROW(placeOnFloor(s, o, Point2d(80, 2)), cv::Exception);    // the ceiling
    EXPECT_THROW(placeOnFloor(s, o, Point2d(80, 500)), cv::Exception);  // outside the frame
    // a big object at the floor's far corner would poke through the walls
    SceneObject big = o;
    big.world_from_object = Matx44d(10, 0, 0, 0, 0, 10, 0, 0, 0, 0, 10, 0, 0, 0, 0, 1);
    EXPECT_THROW(placeOnFloor(s, big, Point2d(80, 100)), cv::Exception);
}

}  // namespace

namespace {

// The ray–floor intersection against plane geometry: a camera at height h looking down at
// angle a sees the floor at distance h / tan(a) through the image centre, and the point
// projects back onto the pixel; a pixel above the horizon, or a camera below the floor plane,
// has no floor point.
TEST(RenderPlacement, FloorPointUnderPixelMatchesGeometry) {
    const double h = 1.5, a = 0.5;
    const Size size(161, 121);
    Camera cam = Camera::fromFocal(140, size);
    // world z up; the camera looks along +y, tilted down by a (OpenCV axes: y down, z forward)
    const Matx33d R(1, 0, 0, 0, -std::sin(a), -std::cos(a), 0, std::cos(a), -std::sin(a));
    cam.R = R;
    cam.t = -(R * Vec3d(0, 0, h));
    Vec3d p;
    ASSERT_TRUE(floorPointUnderPixel(cam, 0.0, Point2d(80, 60), p));
    EXPECT_NEAR(p[0], 0, 1e-9);
    EXPECT_NEAR(p[1], h / std::tan(a), 1e-9);
    EXPECT_NEAR(p[2], 0, 1e-12);
    for (const Point2d px : {Point2d(3, 118), Point2d(150.5, 70.25)}) {
        ASSERT_TRUE(floorPointUnderPixel(cam, 0.2, px, p));
        EXPECT_NEAR(p[2], 0.2, 1e-12);
        const Point2d back = cam.project(p);
        EXPECT_NEAR(back.x, px.x, 1e-6);
        EXPECT_NEAR(back.y, px.y, 1e-6);
    }
    // 100 px above the centre the ray rises: atan(100 / 140) = 0.62 rad > a
    const Vec3d untouched(7, 7, 7);
    p = untouched;
    EXPECT_FALSE(floorPointUnderPixel(cam, 0.0, Point2d(80, 60 - 100), p));
    EXPECT_EQ(p, untouched);
    EXPECT_FALSE(floorPointUnderPixel(cam, h + 0.1, Point2d(80, 60), p));  // camera below it
}

}  // namespace
