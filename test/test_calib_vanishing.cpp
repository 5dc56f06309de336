// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Vanishing points, focal length and rotation from synthetic line groups with known K, R.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/vbme/calib.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

const Size kSize(640, 480);
double kMinLen = 150, kMaxLen = 350;

/** Rotation angle (degrees) between two rotations. */
double rotationErrorDeg(const Matx33d& A, const Matx33d& B) {
    const Matx33d D = A.t() * B;
    const double c = std::max(-1.0, std::min(1.0, (trace(D) - 1) / 2));
    return std::acos(c) * 180 / CV_PI;
}

Matx33d rotAxis(const Vec3d& axis, double deg) {
    Matx33d R;
    Rodrigues(axis * (deg * CV_PI / 180), R);
    return R;
}

/** A camera following the DESIGN axes: looking along +y turned by @p yaw about z, pitched by
@p pitch (negative: looking down), rolled by @p roll; focal @p f. */
Camera makeCamera(double f, double yaw, double pitch, double roll, Size size = kSize) {
    Camera c = Camera::fromFocal(f, size);
    const Matx33d R0(1, 0, 0, 0, 0, -1, 0, 1, 0);  // looking along +y, z up
    // world_from_cam: yaw about world z, then pitch about the camera's x, roll about its z.
    const Matx33d R = rotAxis(Vec3d(0, 0, 1), roll) * rotAxis(Vec3d(1, 0, 0), -pitch) * R0 *
                      rotAxis(Vec3d(0, 0, 1), -yaw);
    c.R = R;
    placeCamera(c, 1.5);
    return c;
}

/** A random camera whose three vanishing points are all usable. */
Camera randomCamera(RNG& rng, Size size = kSize) {
    const double f = rng.uniform(400.0, 1500.0);
    const double yaw = rng.uniform(15.0, 38.0) * (rng.uniform(0, 2) ? 1 : -1);
    const double pitch = -rng.uniform(8.0, 35.0);
    const double roll = rng.uniform(-10.0, 10.0);
    return makeCamera(f, yaw, pitch, roll, size);
}

/** Segments of world direction @p axis: random midpoints in the image, pointing at the VP. */
std::vector<Vec4d> makeSegments(const Camera& c, int axis, int n, double noise, RNG& rng) {
    const Vec3d v = c.K * Vec3d(c.R(0, axis), c.R(1, axis), c.R(2, axis));
    std::vector<Vec4d> segs;
    while ((int)segs.size() < n) {
        const Vec2d m(rng.uniform(40.0, c.image_size.width - 40.0),
                      rng.uniform(40.0, c.image_size.height - 40.0));
        Vec2d dir(v[0] - m[0] * v[2], v[1] - m[1] * v[2]);
        if (norm(dir) < 1e-12) continue;
        dir = normalize(dir);
        bool close = false;  // keep the group's lines apart (collinear ones carry no information)
        for (const auto& o : segs) {
            const Vec3d l = Vec3d(o[0], o[1], 1).cross(Vec3d(o[2], o[3], 1));
            close |= std::abs(l.dot(Vec3d(m[0], m[1], 1))) / std::hypot(l[0], l[1]) < 20;
        }
        if (close) continue;
        const double len = rng.uniform(kMinLen, kMaxLen);
        Vec4d s(m[0] - dir[0] * len / 2, m[1] - dir[1] * len / 2, m[0] + dir[0] * len / 2,
                m[1] + dir[1] * len / 2);
        for (int k = 0; k < 4 && noise > 0; ++k)
            s[k] += rng.gaussian(noise);
        segs.push_back(s);
    }
    return segs;
}

std::vector<LineGroup> makeGroups(const Camera& c, const std::vector<int>& axes, int n,
                                  double noise, RNG& rng) {
    std::vector<LineGroup> g;
    for (int a : axes) {
        LineGroup lg;
        lg.name = std::string("axis") + char('x' + a);
        lg.segments = makeSegments(c, a, n, noise, rng);
        g.push_back(lg);
    }
    return g;
}

}  // namespace

TEST(CalibVanishing, TwoSegmentsGiveTheirIntersection) {
    // Lines y = x and y = −x + 10 meet at (5, 5).
    const std::vector<Vec4d> s = {Vec4d(0, 0, 1, 1), Vec4d(0, 10, 1, 9)};
    const Vec3d v = estimateVanishingPoint(s);
    EXPECT_NEAR(v[0] / v[2], 5, 1e-9);
    EXPECT_NEAR(v[1] / v[2], 5, 1e-9);
}

TEST(CalibVanishing, LeastSquaresPointOfManySegments) {
    RNG rng(3);
    const Point2d vp(1234.5, -321.25);
    std::vector<Vec4d> segs;
    for (int i = 0; i < 8; ++i) {
        const Point2d m(rng.uniform(0.0, 640.0), rng.uniform(0.0, 480.0));
        const Point2d d = (vp - m) * (1.0 / norm(vp - m));
        segs.emplace_back(m.x - 50 * d.x, m.y - 50 * d.y, m.x + 50 * d.x, m.y + 50 * d.y);
    }
    const Vec3d v = estimateVanishingPoint(segs);
    EXPECT_NEAR(v[0] / v[2], vp.x, 1e-6);
    EXPECT_NEAR(v[1] / v[2], vp.y, 1e-6);
}

TEST(CalibVanishing, ParallelImageLinesGiveAPointAtInfinity) {
    const std::vector<Vec4d> s = {Vec4d(0, 0, 100, 50), Vec4d(0, 40, 100, 90),
                                  Vec4d(10, 200, 210, 300)};
    const Vec3d v = estimateVanishingPoint(s);
    EXPECT_NEAR(v[2], 0, 1e-9);
    EXPECT_NEAR(std::abs(v[1] / v[0]), 0.5, 1e-9);
}

TEST(CalibVanishing, DegenerateGroupsAreRejectedWithAMessage) {
    try {
        estimateVanishingPoint({Vec4d(0, 0, 10, 10)}, "walls");
        FAIL() << "one segment accepted";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("'walls' has 1 segment"), std::string::npos) << e.err;
    }
    try {
        estimateVanishingPoint({Vec4d(0, 0, 10, 10), Vec4d(20, 20, 50, 50)}, "floor");
        FAIL() << "collinear segments accepted";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("one image line"), std::string::npos) << e.err;
    }
    EXPECT_THROW(estimateVanishingPoint({Vec4d(3, 3, 3, 3), Vec4d(0, 0, 1, 2)}), cv::Exception);
}

TEST(CalibVanishing, FocalFromTwoOrthogonalPoints) {
    const Camera c = makeCamera(900, 30, -15, 4);
    const Vec3d vx = c.K * Vec3d(c.R(0, 0), c.R(1, 0), c.R(2, 0));
    const Vec3d vy = c.K * Vec3d(c.R(0, 1), c.R(1, 1), c.R(2, 1));
    EXPECT_NEAR(focalFromVanishingPoints(vx, vy, imageCenter(kSize)), 900, 1e-6);
    // Both on the same side of the principal point: no real focal length.
    EXPECT_THROW(
        focalFromVanishingPoints(Vec3d(1000, 240, 1), Vec3d(900, 240, 1), imageCenter(kSize)),
        cv::Exception);
    EXPECT_THROW(focalFromVanishingPoints(Vec3d(1, 0, 0), vy, imageCenter(kSize)), cv::Exception);
}

TEST(CalibVanishing, OrthocentreOfThreeVanishingPointsIsThePrincipalPoint) {
    Camera c = makeCamera(700, 25, -30, 5);
    c.K(0, 2) = 300;
    c.K(1, 2) = 250;
    Point2d v[3];
    for (int a = 0; a < 3; ++a) {
        const Vec3d p = c.K * Vec3d(c.R(0, a), c.R(1, a), c.R(2, a));
        v[a] = Point2d(p[0] / p[2], p[1] / p[2]);
    }
    const Point2d h = orthocenter(v[0], v[1], v[2]);
    EXPECT_NEAR(h.x, 300, 1e-6);
    EXPECT_NEAR(h.y, 250, 1e-6);
}

TEST(CalibVanishing, ExactLinesRecoverFocalAndRotation) {
    RNG rng(11);
    auto cal = VanishingPointCalibrator::create();
    for (int trial = 0; trial < 40; ++trial) {
        const Camera c = randomCamera(rng);
        const bool three = trial % 2 == 1;
        const auto groups =
            makeGroups(c, three ? std::vector<int>{1, 2, 0} : std::vector<int>{0, 1},
                       trial % 3 == 0 ? 2 : 4, 0.0, rng);
        const FrameCalibration fc = cal->calibrate(groups, kSize);
        EXPECT_LT(std::abs(fc.focal() / c.K(0, 0) - 1), 0.005) << "trial " << trial;
        EXPECT_LT(rotationErrorDeg(fc.R, c.R), 0.2) << "trial " << trial;
        EXPECT_LT(fc.rms_px, 1e-6);
    }
}

TEST(CalibVanishing, NoisyLinesKeepFocalWithinThreePercent) {
    // 1 px Gaussian noise on every endpoint coordinate, 5 segments of 150–450 px per direction
    // in 1280×720 frames (hand-held video), focal 400–1500 px.
    const Size size(1280, 720);
    kMaxLen = 450;
    RNG rng(12);
    auto cal = VanishingPointCalibrator::create();
    std::vector<double> ferr2, ferr3, rerr2, rerr3, ferr_o, pp_o;
    VanishingPointCalibrator::Params po;
    po.principal_point_from_orthocenter = true;
    auto ortho = VanishingPointCalibrator::create(po);
    for (int trial = 0; trial < 80; ++trial) {
        const Camera c = randomCamera(rng, size);
        const bool three = trial % 2 == 1;
        const auto groups =
            makeGroups(c, three ? std::vector<int>{0, 1, 2} : std::vector<int>{0, 1}, 5, 1.0, rng);
        const FrameCalibration fc = cal->calibrate(groups, size);
        (three ? ferr3 : ferr2).push_back(std::abs(fc.focal() / c.K(0, 0) - 1));
        (three ? rerr3 : rerr2).push_back(rotationErrorDeg(fc.R, c.R));
        if (three) {  // the same lines with the principal point as the orthocentre
            const FrameCalibration fo = ortho->calibrate(groups, size);
            ferr_o.push_back(std::abs(fo.focal() / c.K(0, 0) - 1));
            pp_o.push_back(norm(Point2d(fo.K(0, 2), fo.K(1, 2)) - imageCenter(size)));
        }
    }
    kMaxLen = 350;
    auto pct = [](std::vector<double> v, double q) {
        std::sort(v.begin(), v.end());
        return v[std::min(v.size() - 1, size_t(q * v.size()))];
    };
    std::printf(
        "2 groups: focal error median %.2f %%, p90 %.2f %%, max %.2f %%; rotation median "
        "%.3f deg, max %.3f deg\n",
        100 * pct(ferr2, 0.5), 100 * pct(ferr2, 0.9), 100 * pct(ferr2, 1), pct(rerr2, 0.5),
        pct(rerr2, 1));
    std::printf(
        "3 groups: focal error median %.2f %%, p90 %.2f %%, max %.2f %%; rotation median "
        "%.3f deg, max %.3f deg\n",
        100 * pct(ferr3, 0.5), 100 * pct(ferr3, 0.9), 100 * pct(ferr3, 1), pct(rerr3, 0.5),
        pct(rerr3, 1));
    std::printf(
        "3 groups, principal point as orthocentre: focal error median %.2f %%, max "
        "%.2f %%; principal point error median %.1f px, max %.1f px\n",
        100 * pct(ferr_o, 0.5), 100 * pct(ferr_o, 1), pct(pp_o, 0.5), pct(pp_o, 1));
    EXPECT_LT(pct(pp_o, 0.5), 25);
    // Three directions: every trial within 3 %. Two directions are exactly determined (no
    // redundancy), so single badly conditioned views (a far vanishing point) exceed it: the
    // typical (median) view must be within 3 %.
    EXPECT_LT(pct(ferr3, 1.0), 0.03);
    EXPECT_LT(pct(rerr3, 1.0), 1.0);
    EXPECT_LT(pct(ferr2, 0.5), 0.03);
    EXPECT_LT(pct(rerr2, 0.5), 0.5);
}

TEST(CalibVanishing, ConventionsZUpYForwardRightHanded) {
    // A camera looking along +y, 20° to the right, pitched down: +y must be the wall axis it
    // faces, z up, and the camera above the floor at the origin.
    const Camera c = makeCamera(800, -20, -20, 0);
    RNG rng(5);
    // Give the groups in a scrambled order, without hints.
    const auto groups = makeGroups(c, {2, 0, 1}, 4, 0.0, rng);
    const FrameCalibration fc = VanishingPointCalibrator::create()->calibrate(groups, kSize);
    EXPECT_LT(rotationErrorDeg(fc.R, c.R), 1e-6);
    EXPECT_NEAR(determinant(fc.R), 1.0, 1e-9);
    Camera e = fc.camera();
    placeCamera(e, 1.5);
    const Vec3d C = e.center();
    EXPECT_NEAR(C[0], 0, 1e-9);
    EXPECT_NEAR(C[1], 0, 1e-9);
    EXPECT_NEAR(C[2], 1.5, 1e-9);
    // World z projects upwards in the image; the viewing direction has positive y.
    const Vec3d view = e.R.t() * Vec3d(0, 0, 1);
    EXPECT_GT(view[1], std::abs(view[0]));
    const Point2d a = e.project(Vec3d(0, 3, 1)), b = e.project(Vec3d(0, 3, 2));
    EXPECT_LT(b.y, a.y);
    // +x is to the right in the image.
    EXPECT_GT(e.project(Vec3d(1, 3, 1)).x, a.x);
    // Labels: group order z, x, y.
    EXPECT_EQ(fc.labels.front(), 2);
    EXPECT_EQ(fc.labels.back(), 1);
}

TEST(CalibVanishing, HintsDecideTheVerticalForAStronglyPitchedCamera) {
    // Looking down 60°: the horizontal y direction is closer to the image's y axis than the
    // vertical, so the vertical must come from the hint.
    const Camera c = makeCamera(700, 25, -60, 0);
    RNG rng(8);
    auto groups = makeGroups(c, {1, 2}, 4, 0.0, rng);
    groups[1].axis = AxisHint::VERTICAL;
    const FrameCalibration fc = VanishingPointCalibrator::create()->calibrate(groups, kSize);
    EXPECT_LT(rotationErrorDeg(fc.R, c.R), 1e-6);
}

TEST(CalibVanishing, DegenerateCalibrationInput) {
    RNG rng(9);
    auto cal = VanishingPointCalibrator::create();
    const Camera c = makeCamera(800, 30, -20, 0);
    // One direction only.
    try {
        cal->calibrate(makeGroups(c, {0}, 4, 0, rng), kSize);
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("at least two"), std::string::npos) << e.err;
    }
    // A level camera facing a wall: x lines and z lines parallel in the image.
    const Camera level = makeCamera(800, 0, 0, 0);
    try {
        cal->calibrate(makeGroups(level, {0, 2}, 4, 0, rng), kSize);
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("at infinity"), std::string::npos) << e.err;
    }
    // ... which is fine once the focal length is known.
    VanishingPointCalibrator::Params p;
    p.focal = 800;
    const FrameCalibration fc =
        VanishingPointCalibrator::create(p)->calibrate(makeGroups(level, {0, 2}, 4, 0, rng), kSize);
    EXPECT_LT(rotationErrorDeg(fc.R, level.R), 1e-6);
}

TEST(CalibVanishing, OrthocentreModeFindsAnOffCentrePrincipalPoint) {
    Camera c = makeCamera(750, 28, -25, 3);
    c.K(0, 2) = 335;
    c.K(1, 2) = 228;
    RNG rng(10);
    VanishingPointCalibrator::Params p;
    p.principal_point_from_orthocenter = true;
    const FrameCalibration fc =
        VanishingPointCalibrator::create(p)->calibrate(makeGroups(c, {0, 1, 2}, 4, 0, rng), kSize);
    EXPECT_NEAR(fc.K(0, 2), 335, 1e-3);
    EXPECT_NEAR(fc.K(1, 2), 228, 1e-3);
    EXPECT_NEAR(fc.focal(), 750, 1e-3);
}

TEST(CalibVanishing, ParamsRoundTrip) {
    VanishingPointCalibrator::Params p;
    p.focal = 812.5;
    p.principal_point = Point2d(300, 200);
    p.ransac_iterations = 77;
    p.principal_point_from_orthocenter = true;
    FileStorage fs(".yml", FileStorage::WRITE | FileStorage::MEMORY);
    fs << "params"
       << "{";
    p.write(fs);
    fs << "}";
    const std::string s = fs.releaseAndGetString();
    FileStorage in(s, FileStorage::READ | FileStorage::MEMORY);
    VanishingPointCalibrator::Params q;
    q.read(in["params"]);
    EXPECT_EQ(q.focal, 812.5);
    EXPECT_EQ(q.principal_point, Point2d(300, 200));
    EXPECT_EQ(q.ransac_iterations, 77);
    EXPECT_TRUE(q.principal_point_from_orthocenter);
}
