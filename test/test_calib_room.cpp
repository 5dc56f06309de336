// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Room box placement, light polygons, annotation files and the single-frame driver against
// known geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/calib/projection.hpp>
#include <opencv2/vbme/datasets/room.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

const Size kSize(640, 480);

Matx33d rotAxis(const Vec3d& axis, double deg) {
    Matx33d R;
    Rodrigues(axis * (deg * CV_PI / 180), R);
    return R;
}

/** pitch < 0 looks down. */
Camera roomCamera(double f, double yaw, double pitch, double roll, double height) {
    Camera c = Camera::fromFocal(f, kSize);
    const Matx33d R0(1, 0, 0, 0, 0, -1, 0, 1, 0);
    c.R = rotAxis(Vec3d(0, 0, 1), roll) * rotAxis(Vec3d(1, 0, 0), -pitch) * R0 *
          rotAxis(Vec3d(0, 0, 1), -yaw);
    placeCamera(c, height);
    return c;
}

Room trueRoom() {
    Room r;
    r.min = Vec3d(-2.2, -1.4, 0);
    r.max = Vec3d(2.6, 3.0, 2.7);
    return r;
}

std::vector<Point2d> project(const Camera& c, const std::vector<Vec3d>& X, double noise = 0,
                             RNG* rng = nullptr) {
    std::vector<Point2d> p;
    for (const auto& x : X) {
        Point2d q = c.project(x);
        if (rng) q += Point2d(rng->gaussian(noise), rng->gaussian(noise));
        p.push_back(q);
    }
    return p;
}

/** Clicks on the back and left floor edges, the back–right corner and the back ceiling edge;
the front wall (behind the camera) as a number. */
RoomAnnotation clicks(const Camera& c, double noise = 0, RNG* rng = nullptr) {
    const Room r = trueRoom();
    RoomAnnotation a;
    a.floor_edges["back"] =
        project(c, {{-1.0, r.max[1], 0}, {0.4, r.max[1], 0}, {1.6, r.max[1], 0}}, noise, rng);
    a.floor_edges["left"] = project(c, {{r.min[0], 1.5, 0}, {r.min[0], 2.6, 0}}, noise, rng);
    a.wall_corners.push_back(
        {"back", "right",
         project(c, {{r.max[0], r.max[1], 0.6}, {r.max[0], r.max[1], 2.1}}, noise, rng)});
    a.ceiling_edges["back"] =
        project(c, {{-0.5, r.max[1], r.max[2]}, {1.0, r.max[1], r.max[2]}}, noise, rng);
    a.faces["front"] = r.min[1];
    return a;
}

double maxCornerError(const Room& a, const Room& b) {
    return std::max(norm(a.min - b.min, NORM_INF), norm(a.max - b.max, NORM_INF));
}

/** Image segments of world direction @p axis: edges of the true room's pattern. */
LineGroup groupFor(const Camera& c, int axis, const std::string& name) {
    LineGroup g;
    g.name = name;
    const Room r = trueRoom();
    // Lines of that direction on the floor / back wall, at a few offsets.
    std::vector<std::pair<Vec3d, Vec3d>> lines;
    if (axis == 0)
        for (double y : {1.0, 2.0, 3.0})
            lines.push_back({{-1.5, y, 0}, {1.5, y, 0}});
    if (axis == 1)
        for (double x : {-1.5, -0.5, 1.0})
            lines.push_back({{x, 1.0, 0}, {x, r.max[1], 0}});
    if (axis == 2)
        for (double x : {-1.0, 0.0, 1.5})
            lines.push_back({{x, r.max[1], 0.3}, {x, r.max[1], 2.4}});
    for (const auto& l : lines) {
        Point2d a, b;
        if (projectSegment(c, l.first, l.second, a, b)) g.segments.emplace_back(a.x, a.y, b.x, b.y);
    }
    return g;
}

}  // namespace

TEST(CalibRoom, ExactClicksGiveTheBox) {
    const Camera c = roomCamera(700, 25, -15, 2, 1.5);
    const Room r = fitRoom(c, clicks(c));
    EXPECT_LT(maxCornerError(r, trueRoom()), 1e-6);
}

TEST(CalibRoom, CalibratedCameraAndNoisyClicksWithin1cm) {
    const Camera truth = roomCamera(700, 25, -15, 2, 1.5);
    const FrameCalibration fc = VanishingPointCalibrator::create()->calibrate(
        {groupFor(truth, 0, "x"), groupFor(truth, 1, "y"), groupFor(truth, 2, "z")}, kSize);
    Camera c = fc.camera();
    placeCamera(c, 1.5);
    EXPECT_LT(maxCornerError(fitRoom(c, clicks(truth)), trueRoom()), 0.01);
    RNG rng(4);
    double worst = 0;
    for (int trial = 0; trial < 20; ++trial)
        worst = std::max(worst, maxCornerError(fitRoom(c, clicks(truth, 0.3, &rng)), trueRoom()));
    std::printf("room corners with 0.3 px click noise: worst error %.2f mm\n", worst * 1000);
    EXPECT_LT(worst, 0.01);
}

TEST(CalibRoom, UnknownCameraHeightFromRoomHeightOrAKnownWall) {
    const Camera truth = roomCamera(650, -20, -10, 0, 1.37);
    FrameAnnotation ann;
    ann.lines = {groupFor(truth, 0, "x"), groupFor(truth, 1, "y")};
    ann.room = clicks(truth);
    ann.room.faces.clear();
    ann.room.faces["front"] = -1.4;
    ann.room_height = 2.7;
    Mat img(kSize, CV_8UC3, Scalar::all(100));
    FrameCalibrationOptions opt;
    Scene s = calibrateFrame(img, ann, opt);
    EXPECT_NEAR(s.camera.center()[2], 1.37, 1e-6);
    EXPECT_LT(maxCornerError(s.room, trueRoom()), 1e-6);
    // The back wall's distance instead of the room height.
    ann.room_height = 0;
    ann.room.faces["back"] = 3.0;
    s = calibrateFrame(img, ann, opt);
    EXPECT_NEAR(s.camera.center()[2], 1.37, 1e-6);
    EXPECT_LT(maxCornerError(s.room, trueRoom()), 1e-6);
    // Nothing metric: a clear error.
    ann.room.faces.erase("back");
    ann.room.faces.erase("front");
    try {
        calibrateFrame(img, ann, opt);
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("camera height is unknown"), std::string::npos) << e.err;
    }
}

TEST(CalibRoom, UndeterminedFacesAndMisnamedWallsAreReported) {
    const Camera c = roomCamera(700, 25, -15, 2, 1.5);
    RoomAnnotation a = clicks(c);
    a.faces.clear();
    try {
        fitRoom(c, a);
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("front"), std::string::npos) << e.err;
        EXPECT_NE(e.err.find("undetermined"), std::string::npos) << e.err;
    }
    RoomAnnotation b = clicks(c);
    b.floor_edges["right"] = b.floor_edges["back"];  // points of the back edge, called right
    b.floor_edges.erase("back");
    try {
        fitRoom(c, b);
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("floor_edges.right"), std::string::npos) << e.err;
    }
    RoomAnnotation d;
    d.floor_edges["back"] = {Point2d(320, 5)};  // above the horizon of a camera looking down 15°
    d.faces = {{"left", -1}, {"right", 1}, {"front", -1}, {"ceiling", 2.5}};
    EXPECT_THROW(fitRoom(c, d), cv::Exception);
}

TEST(CalibRoom, LightPolygonsLandOnTheirFaceWoundIntoTheRoom) {
    const Camera c = roomCamera(450, 25, 5, 2, 1.5);  // looking slightly up
    const Room room = trueRoom();
    // A ceiling panel and a window on the back wall, drawn with clockwise image order.
    const std::vector<Vec3d> panel = {
        {0, 2.1, 2.7}, {0.8, 2.1, 2.7}, {0.8, 2.8, 2.7}, {0, 2.8, 2.7}};
    const std::vector<Vec3d> window = {
        {-1.0, 3.0, 1.0}, {0.2, 3.0, 1.0}, {0.2, 3.0, 2.0}, {-1.0, 3.0, 2.0}};
    Mat img(kSize, CV_8UC3, Scalar(20, 20, 20));
    for (int k = 0; k < 2; ++k) {
        const auto& W = k == 0 ? panel : window;
        LightAnnotation la;
        la.polygon = project(c, W);
        std::vector<Point> ip;
        for (const auto& p : la.polygon)
            ip.emplace_back(cvRound(p.x), cvRound(p.y));
        fillPoly(img, std::vector<std::vector<Point>>{ip}, Scalar(50, 128, 200));  // BGR
        EXPECT_EQ(faceSeenAt(c, room, la.polygon[0] * 0.5 + la.polygon[2] * 0.5),
                  k == 0 ? "ceiling" : "back");
        const Light L = projectLight(c, room, la, img, Response::SRGB);
        ASSERT_EQ(L.corners.size(), 4u);
        // Same corners (as a set), within 1e-6 m.
        for (const auto& X : W) {
            double best = 1e9;
            for (const auto& Y : L.corners)
                best = std::min(best, norm(X - Y));
            EXPECT_LT(best, 1e-6);
        }
        const Vec3d n = L.polygonNormal();
        EXPECT_NEAR(norm(n - (k == 0 ? Vec3d(0, 0, -1) : Vec3d(0, -1, 0))), 0, 1e-9);
        // Radiance: linearised sRGB of (R, G, B) = (200, 128, 50).
        EXPECT_NEAR(L.radiance[0], linearize(200 / 255.f, Response::SRGB), 0.01);
        EXPECT_NEAR(L.radiance[1], linearize(128 / 255.f, Response::SRGB), 0.01);
        EXPECT_NEAR(L.radiance[2], linearize(50 / 255.f, Response::SRGB), 0.01);
        // Reversed image winding gives the same, counter-clockwise, light.
        LightAnnotation rev = la;
        std::reverse(rev.polygon.begin(), rev.polygon.end());
        rev.has_radiance = true;
        rev.radiance = Vec3d(5, 4, 3);
        const Light L2 = projectLight(c, room, rev, img);
        EXPECT_NEAR(norm(L2.polygonNormal() - n), 0, 1e-9);
        EXPECT_EQ(L2.radiance, Vec3d(5, 4, 3));
    }
}

TEST(CalibRoom, AnnotationFileRoundTrip) {
    vbme_test::ScratchDir dir;
    const Camera c = roomCamera(700, 25, -15, 2, 1.5);
    FrameAnnotation a;
    a.image_size = kSize;
    a.camera_height = 1.5;
    a.principal_point = Point2d(321.5, 238);
    a.has_response = true;
    a.response = Response::GAMMA22;
    a.lines = {groupFor(c, 0, "x"), groupFor(c, 2, "z")};
    a.lines[1].axis = AxisHint::VERTICAL;
    a.room = clicks(c);
    LightAnnotation la;
    la.polygon = {Point2d(1, 2), Point2d(30, 2), Point2d(30, 40)};
    la.face = "ceiling";
    la.has_radiance = true;
    la.radiance = Vec3d(3, 2, 1);
    a.lights = {la};
    a.write(dir / "ann.yml");
    const FrameAnnotation b = FrameAnnotation::read(dir / "ann.yml");
    EXPECT_EQ(b.image_size, kSize);
    EXPECT_EQ(b.camera_height, 1.5);
    EXPECT_EQ(b.principal_point, Point2d(321.5, 238));
    EXPECT_FALSE(b.principal_point_from_orthocenter);
    EXPECT_EQ(b.response, Response::GAMMA22);
    ASSERT_EQ(b.lines.size(), 2u);
    EXPECT_EQ(b.lines[1].axis, AxisHint::VERTICAL);
    EXPECT_EQ(b.lines[0].name, "x");
    ASSERT_EQ(b.lines[0].segments.size(), a.lines[0].segments.size());
    EXPECT_LT(norm(b.lines[0].segments[1] - a.lines[0].segments[1]), 1e-9);
    EXPECT_EQ(b.room.floor_edges.at("back").size(), 3u);
    EXPECT_EQ(b.room.wall_corners.at(0).wall_b, "right");
    EXPECT_EQ(b.room.faces.at("front"), -1.4);
    ASSERT_EQ(b.lights.size(), 1u);
    EXPECT_EQ(b.lights[0].face, "ceiling");
    EXPECT_EQ(b.lights[0].radiance, Vec3d(3, 2, 1));
    // A misspelt face is reported with its place in the file.
    {
        FileStorage fs(dir / "bad.yml", FileStorage::WRITE);
        fs << "room"
           << "{"
           << "faces"
           << "{"
           << "bak" << 3.0 << "}"
           << "}";
    }
    try {
        FrameAnnotation::read(dir / "bad.yml");
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("room.faces.bak"), std::string::npos) << e.err;
    }
}

TEST(CalibRoom, FrameToSceneFileMatchesTheKnownCamera) {
    vbme_test::ScratchDir dir;
    const Camera truth = roomCamera(600, -28, -12, 1.5, 1.55);
    const Room room = trueRoom();
    const Mat img = drawSyntheticRoom(truth, room, 0.5, 0, 0);
    FrameAnnotation ann;
    ann.camera_height = 1.55;
    ann.room = clicks(truth);
    LightAnnotation la;
    la.polygon =
        project(truth, {{-1.0, 3.0, 1.0}, {0.2, 3.0, 1.0}, {0.2, 3.0, 2.0}, {-1.0, 3.0, 2.0}});
    ann.lights = {la};
    FrameCalibrationOptions opt;
    opt.auto_detect = true;  // no lines in the annotation: detected
    FrameCalibration fc;
    const Scene s = calibrateFrame(img, ann, opt, &fc);
    s.write(dir / "scene.yml");
    const Scene r = Scene::read(dir / "scene.yml");
    EXPECT_EQ(r.image_size, kSize);
    EXPECT_LT(std::abs(r.camera.K(0, 0) / 600 - 1), 0.01);
    const Matx33d D = r.camera.R.t() * truth.R;
    EXPECT_LT(std::acos(std::min(1.0, (trace(D) - 1) / 2)) * 180 / CV_PI, 0.3);
    EXPECT_LT(norm(r.camera.center() - truth.center()), 1e-6);
    ASSERT_TRUE(r.has_room);
    EXPECT_LT(maxCornerError(r.room, room), 0.03);
    ASSERT_EQ(r.lights.size(), 1u);
    EXPECT_LT(r.lights[0].polygonNormal()[1], -0.999);  // a window on the back wall, facing in
    for (const auto& X : r.lights[0].corners)
        EXPECT_NEAR(X[1], r.room.max[1], 1e-9);
}

TEST(CalibRoom, GivenPrincipalPointIsUsed) {
    Camera truth = roomCamera(650, -20, -10, 0, 1.4);
    truth.K(0, 2) = 331;
    truth.K(1, 2) = 227;
    FrameAnnotation ann;
    ann.lines = {groupFor(truth, 0, "x"), groupFor(truth, 1, "y")};
    ann.camera_height = 1.4;
    const Mat img(kSize, CV_8UC3, Scalar::all(100));
    // At the image centre, the focal length comes out wrong; with the true point, exact.
    const Scene centred = calibrateFrame(img, ann, FrameCalibrationOptions());
    EXPECT_NEAR(centred.camera.K(0, 2), 319.5, 1e-12);
    EXPECT_GT(std::abs(centred.camera.K(0, 0) - 650), 1.0);
    ann.principal_point = Point2d(331, 227);
    const Scene s = calibrateFrame(img, ann, FrameCalibrationOptions());
    EXPECT_NEAR(s.camera.K(0, 2), 331, 1e-12);
    EXPECT_NEAR(s.camera.K(1, 2), 227, 1e-12);
    EXPECT_NEAR(s.camera.K(0, 0), 650, 1e-6);
}

// With an estimated k1 the overlay draws the box as the lens bends it: each box edge's
// midpoint, distorted by k1, is on a white line of the k1 overlay and not of the pinhole one
// (and the undistorted midpoint the other way round). Oracle: distortPointK1, the inverse of
// undistortPointK1 (checked to round-trip here).
TEST(CalibRoom, OverlayBendsTheBoxWithTheEstimatedK1) {
    const Camera cam = roomCamera(500, -28, -12, 1.5, 1.55);
    Scene scene;
    scene.camera = cam;
    scene.image_size = kSize;
    scene.has_room = true;
    scene.room = trueRoom();
    FrameCalibration fc;
    fc.image_size = kSize;
    fc.K = cam.K;
    fc.R = cam.R;
    const Mat black(kSize, CV_8UC3, Scalar::all(0));
    Mat pinhole, bent;
    drawCalibrationOverlay(black, pinhole, scene, fc);
    fc.k1 = -0.15;  // barrel, as in the distorted calib_rooms renders
    drawCalibrationOverlay(black, bent, scene, fc);
    const double f = cam.K(0, 0);
    const Point2d c(cam.K(0, 2), cam.K(1, 2));
    auto white = [](const Mat& m, const Point2d& p) {
        int best = 0;
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const Vec3b v = m.at<Vec3b>(cvRound(p.y) + dy, cvRound(p.x) + dx);
                best = std::max(best, (int)std::min({v[0], v[1], v[2]}));
            }
        return best > 150;
    };
    const Rect inner(5, 40, kSize.width - 10, kSize.height - 45);  // clear of the caption
    int checked = 0;
    const Vec3d a = scene.room.min, b = scene.room.max;
    for (int e = 0; e < 12; ++e) {
        const int axis = e / 4, k = e % 4, u = (axis + 1) % 3, v = (axis + 2) % 3;
        Vec3d p, q;
        p[u] = q[u] = (k & 1) ? b[u] : a[u];
        p[v] = q[v] = (k & 2) ? b[v] : a[v];
        p[axis] = a[axis];
        q[axis] = b[axis];
        Point2d pa, pb;
        if (!projectSegment(cam, p, q, pa, pb, 0.02)) continue;
        for (double t = 0; t <= 1; t += 1.0 / 4000) {
            const Point2d m = pa + (pb - pa) * t, md = distortPointK1(m, f, c, fc.k1);
            // How far the lens moves the point off the straight edge.
            const Point2d d = pb - pa, w = md - pa;
            const double off = std::abs(d.x * w.y - d.y * w.x) / norm(d);
            if (!inner.contains(Point(cvRound(m.x), cvRound(m.y))) ||
                !inner.contains(Point(cvRound(md.x), cvRound(md.y))) || off < 6)
                continue;
            EXPECT_LT(norm(undistortPointK1(md, f, c, fc.k1) - m), 1e-3);
            ++checked;
            EXPECT_TRUE(white(bent, md)) << "edge " << e << " at " << md;
            EXPECT_FALSE(white(pinhole, md)) << "edge " << e << " at " << md;
            EXPECT_TRUE(white(pinhole, m)) << "edge " << e << " at " << m;
            EXPECT_FALSE(white(bent, m)) << "edge " << e << " at " << m;
        }
    }
    if (const char* dump = std::getenv("VBME_TEST_DUMP")) {
        Mat both;
        hconcat(pinhole, bent, both);
        imwrite(std::string(dump) + "/overlay_k1.png", both);
    }
    std::printf("box edge points checked: %d\n", checked);
    EXPECT_GE(checked, 50);
}
