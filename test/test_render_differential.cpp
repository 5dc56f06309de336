// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Differential rendering: one pass vs two passes, exact zeros, the shadow, the coverage mask,
// the compositor and the EXR layers.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <set>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::ScratchDir;

namespace {

/** A box [lo, hi] as world_from_object of the unit cube [−½, ½]³. */
Matx44d boxPlacement(const Vec3d& lo, const Vec3d& hi) {
    const Vec3d c = 0.5 * (lo + hi), s = hi - lo;
    return Matx44d(s[0], 0, 0, c[0], 0, s[1], 0, c[1], 0, 0, s[2], c[2], 0, 0, 0, 1);
}

SceneObject box(const std::string& mesh, const Vec3d& lo, const Vec3d& hi, const Vec3d& albedo) {
    SceneObject o;
    o.mesh = mesh;
    o.world_from_object = boxPlacement(lo, hi);
    o.has_material = true;
    o.material = vbme_test::lambertian(albedo);
    return o;
}

Light polygonLight(double x0, double x1, double y0, double y1, double z, double L) {
    Light l;
    l.type = Light::POLYGON;
    // counter-clockwise seen from below (the lit side)
    l.corners = {Vec3d(x0, y1, z), Vec3d(x1, y1, z), Vec3d(x1, y0, z), Vec3d(x0, y0, z)};
    l.radiance = Vec3d(L, L, L);
    return l;
}

/** Room 4×4×3 m with a ceiling light and a dark cube on the floor. */
Scene cubeOnFloor(const std::string& cube_obj, Size size) {
    Scene s;
    s.image_size = size;
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    s.lights = {polygonLight(1.0, 1.6, -0.3, 0.3, 3, 20)};
    s.objects = {
        box(cube_obj, Vec3d(-0.3, -0.3, 0), Vec3d(0.3, 0.3, 1.0), Vec3d(0.05, 0.05, 0.05))};
    s.camera = vbme_test::lookAt(Vec3d(0, -3.0, 2.8) * 0.6, Vec3d(0, 0, 0), size.width * 0.7, size);
    return s;
}

double maxAbs(const Mat& m) {
    double mn, mx;
    minMaxLoc(m.reshape(1), &mn, &mx);
    return std::max(-mn, mx);
}

}  // namespace

// One pass and two passes at equal seeds give the same images; the difference is exactly zero
// wherever no path met the object.
TEST(RenderDifferential, OnePassMatchesTwoPass) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    const Scene s = cubeOnFloor(dir / "cube.obj", Size(32, 24));
    Ptr<RenderScene> rs = RenderScene::create(s);
    DifferentialRenderer::Params p;
    p.render.spp = 4;
    p.render.max_depth = 3;
    p.render.seed = 7;
    DifferentialImages one, two;
    DifferentialRenderer::create(p)->render(*rs, s.camera, one);
    p.method = DifferentialRenderer::TWO_PASS;
    DifferentialRenderer::create(p)->render(*rs, s.camera, two);
    EXPECT_EQ(maxAbs(one.obj - two.obj), 0.0);
    const double scale = maxAbs(two.noobj);
    ASSERT_GT(scale, 0.0);
    EXPECT_LE(maxAbs(one.noobj - two.noobj), 1e-5 * scale);
    EXPECT_LE(maxAbs(one.diff - two.diff), 1e-5 * scale);
    // Exact zeros where no path interacted; some paths did interact.
    int untouched = 0, differing = 0;
    for (int y = 0; y < one.obj.rows; ++y)
        for (int x = 0; x < one.obj.cols; ++x) {
            if (one.object.at<float>(y, x) == 0.f) {
                ++untouched;
                EXPECT_EQ(one.diff.at<Vec3f>(y, x), Vec3f(0, 0, 0)) << x << "," << y;
            }
            if (one.diff.at<Vec3f>(y, x) != Vec3f(0, 0, 0)) ++differing;
        }
    EXPECT_GT(untouched, 0);
    EXPECT_GT(differing, 20);
    // The same renders with unrelated samples differ far more.
    p.independent = true;
    DifferentialImages ind;
    DifferentialRenderer::create(p)->render(*rs, s.camera, ind);
    EXPECT_EQ(maxAbs(ind.obj - one.obj), 0.0);
    EXPECT_GT(countNonZero(ind.diff.reshape(1)), 3 * countNonZero(one.diff.reshape(1)) / 2);
}

// A room divided by an opaque wall (a proxy): from the side without the object, the difference
// is exactly zero everywhere; on the object's side its shadow makes it non-zero.
TEST(RenderDifferential, ZeroBehindOpaqueWallNonZeroInShadow) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    Scene s;
    s.image_size = Size(32, 32);
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    s.lights = {polygonLight(-1.3, -0.7, -0.3, 0.3, 3, 10),
                polygonLight(1.4, 1.8, -0.3, 0.3, 3, 10)};
    s.proxies = {
        box(dir / "cube.obj", Vec3d(-0.05, -2, 0), Vec3d(0.05, 2, 3), Vec3d(0.5, 0.5, 0.5))};
    s.objects = {
        box(dir / "cube.obj", Vec3d(0.8, -0.2, 0), Vec3d(1.2, 0.2, 1.2), Vec3d(0.3, 0.3, 0.3))};
    Ptr<RenderScene> rs = RenderScene::create(s);
    DifferentialRenderer::Params p;
    p.render.spp = 4;
    p.render.max_depth = 4;
    for (int method : {DifferentialRenderer::ONE_PASS, DifferentialRenderer::TWO_PASS}) {
        p.method = method;
        // Looking down at the floor of the side without the object.
        const Camera west =
            vbme_test::lookAt(Vec3d(-1, -1.5, 2.5), Vec3d(-1, 0, 0), 20, s.image_size);
        DifferentialImages a;
        DifferentialRenderer::create(p)->render(*rs, west, a);
        EXPECT_GT(mean(a.noobj)[0], 0.0);
        EXPECT_EQ(countNonZero(a.diff.reshape(1)), 0) << "method " << method;
        EXPECT_EQ(countNonZero(a.mask), 0);
        // The object's side, seeing the object and its shadow.
        const Camera east =
            vbme_test::lookAt(Vec3d(1, -1.5, 2.5), Vec3d(0.9, 0, 0), 30, s.image_size);
        DifferentialImages b;
        DifferentialRenderer::create(p)->render(*rs, east, b);
        // The floor just beyond the cube (seen from the camera) lies in its shadow.
        const Point2d q = east.project(Vec3d(0.5, 0.0, 0.0));
        const Point pq(cvRound(q.x), cvRound(q.y));
        ASSERT_TRUE(Rect(0, 0, 32, 32).contains(pq));
        EXPECT_EQ(b.mask.at<float>(pq), 0.f);
        EXPECT_LT(b.diff.at<Vec3f>(pq)[1], -0.05f * b.noobj.at<Vec3f>(pq)[1]);
    }
    // With independent samples the side without the object is noisy too.
    p.independent = true;
    DifferentialImages c;
    DifferentialRenderer::create(p)->render(
        *rs, vbme_test::lookAt(Vec3d(-1, -1.5, 2.5), Vec3d(-1, 0, 0), 20, s.image_size), c);
    EXPECT_GT(countNonZero(c.diff.reshape(1)), 100);
}

namespace {

/** Fraction of an n×n grid of points on the light that the box [lo, hi] hides from floor point P.
 */
double occludedFraction(const Vec3d& P, const Light& l, const Vec3d& lo, const Vec3d& hi, int n) {
    int hidden = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double u = (i + 0.5) / n, v = (j + 0.5) / n;
            const Vec3d Q = l.corners[0] + (l.corners[1] - l.corners[0]) * u +
                            (l.corners[3] - l.corners[0]) * v;
            const Vec3d d = Q - P;
            double t0 = 1e-6, t1 = 1.0;  // slab test along the segment
            bool hit = true;
            for (int k = 0; k < 3 && hit; ++k) {
                if (std::abs(d[k]) < 1e-12) {
                    hit = P[k] > lo[k] && P[k] < hi[k];
                    continue;
                }
                double a = (lo[k] - P[k]) / d[k], b = (hi[k] - P[k]) / d[k];
                if (a > b) std::swap(a, b);
                t0 = std::max(t0, a);
                t1 = std::min(t1, b);
                hit = t0 < t1;
            }
            hidden += hit;
        }
    return double(hidden) / (n * n);
}

}  // namespace

// A dark cube on a bright floor under one area light: the floor darkens in the predicted
// shadow region (segments from the floor point to the light that the cube blocks) and nowhere
// far from it.
TEST(RenderDifferential, ShadowWherePredicted) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    const Size size(48, 36);
    Scene s = cubeOnFloor(dir / "cube.obj", size);
    RenderScene::Params rsp;
    rsp.room_albedo = Vec3f(0.5f, 0.5f, 0.5f);
    Ptr<RenderScene> rs = RenderScene::create(s, rsp);
    DifferentialRenderer::Params p;
    p.render.spp = 8;
    p.render.max_depth = 2;
    DifferentialImages im;
    DifferentialRenderer::create(p)->render(*rs, s.camera, im);
    // Predicted occlusion at each pixel's floor point (pixel centre ray meets z = 0).
    const Vec3d lo(-0.3, -0.3, 0), hi(0.3, 0.3, 1.0);
    Mat occ(size, CV_32F, Scalar(-1));  // −1: not floor
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            const Vec3d c = s.camera.center(), d = s.camera.rayDirection(Point2d(x, y));
            if (d[2] >= 0) continue;
            const Vec3d P = c + d * (-c[2] / d[2]);
            if (std::abs(P[0]) > 1.9 || std::abs(P[1]) > 1.9) continue;
            if (P[0] > lo[0] && P[0] < hi[0] && P[1] > lo[1] && P[1] < hi[1]) continue;
            occ.at<float>(y, x) = (float)occludedFraction(P, s.lights[0], lo, hi, 8);
        }
    // "Near the shadow": within 2 pixels of a pixel with predicted occlusion, or of the object.
    Mat near = (occ > 0) | (im.mask > 0);
    dilate(near, near, Mat(), Point(-1, -1), 2);
    double dark_obj = 0, dark_noobj = 0, far_diff = 0, far_noobj = 0;
    int n_umbra = 0, n_far = 0;
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            const float o = occ.at<float>(y, x);
            if (o < 0 || im.mask.at<float>(y, x) > 0) continue;
            if (o == 1.f) {
                dark_obj += im.obj.at<Vec3f>(y, x)[1];
                dark_noobj += im.noobj.at<Vec3f>(y, x)[1];
                ++n_umbra;
            } else if (!near.at<uchar>(y, x)) {
                far_diff += std::abs(im.diff.at<Vec3f>(y, x)[1]);
                far_noobj += im.noobj.at<Vec3f>(y, x)[1];
                ++n_far;
            }
        }
    ASSERT_GT(n_umbra, 10);
    ASSERT_GT(n_far, 200);
    EXPECT_LT(dark_obj, 0.5 * dark_noobj) << "the umbra darkens";
    EXPECT_LT(far_diff, 0.01 * far_noobj) << "far from the shadow the floor does not change";
}

// With no object in the scene, the composite is the input frame bit for bit (any α, response).
TEST(RenderDifferential, NoObjectCompositeEqualsInput) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    Scene s = cubeOnFloor(dir / "cube.obj", Size(20, 16));
    s.objects.clear();
    Ptr<RenderScene> rs = RenderScene::create(s);
    DifferentialRenderer::Params p;
    p.render.spp = 2;
    p.render.max_depth = 2;
    DifferentialImages im;
    DifferentialRenderer::create(p)->render(*rs, s.camera, im);
    EXPECT_EQ(countNonZero(im.diff.reshape(1)), 0);
    EXPECT_EQ(countNonZero(im.mask), 0);
    Mat frame(s.image_size, CV_8UC3);
    randu(frame, 0, 256);
    for (Response r : {Response::SRGB, Response::GAMMA22})
        for (float alpha : {1.f, 2.5f}) {
            CompositeParams cp;
            cp.alpha = alpha;
            cp.response = r;
            Mat lin, enc;
            compositeDifferential(frame, im.obj, im.diff, im.mask, lin, cp);
            encodeComposite(lin, enc, r);
            EXPECT_EQ(norm(enc, frame, NORM_INF), 0.0);
        }
    // 16-bit footage gives 16-bit output, equal to the input within one code value.
    Mat frame16(s.image_size, CV_16UC3), lin16, enc16;
    randu(frame16, 0, 65536);
    compositeDifferential(frame16, im.obj, im.diff, im.mask, lin16);
    encodeComposite(lin16, enc16, Response::SRGB, CV_16U);
    ASSERT_EQ(enc16.type(), CV_16UC3);
    EXPECT_LE(norm(enc16, frame16, NORM_INF), 1.0);
}

// Eq. 5.2 against a per-pixel evaluation, including the clamp at zero.
TEST(RenderDifferential, CompositeFormulaAndClamp) {
    RNG rng(3);
    const Size sz(7, 5);
    Mat frame(sz, CV_8UC3), obj(sz, CV_32FC3), diff(sz, CV_32FC3), M(sz, CV_32FC1);
    rng.fill(frame, RNG::UNIFORM, 0, 256);
    rng.fill(obj, RNG::UNIFORM, 0, 2);
    rng.fill(diff, RNG::UNIFORM, -1, 0.5);
    rng.fill(M, RNG::UNIFORM, 0, 1);
    M.at<float>(0, 0) = 0;
    M.at<float>(0, 1) = 1;
    CompositeParams cp;
    cp.alpha = 0.7f;
    Mat lin;
    compositeDifferential(frame, obj, diff, M, lin, cp);
    int clamped = 0;
    for (int y = 0; y < sz.height; ++y)
        for (int x = 0; x < sz.width; ++x)
            for (int c = 0; c < 3; ++c) {
                const double I = linearize(frame.at<Vec3b>(y, x)[c] / 255.f, Response::SRGB);
                double back = I + 0.7 * diff.at<Vec3f>(y, x)[c];
                if (back < 0) ++clamped, back = 0;
                const double m = M.at<float>(y, x);
                const double want = m * obj.at<Vec3f>(y, x)[c] + (1 - m) * back;
                EXPECT_NEAR(lin.at<Vec3f>(y, x)[c], want, 1e-5 * (1 + want));
                EXPECT_GE(lin.at<Vec3f>(y, x)[c], 0.f);
            }
    EXPECT_GT(clamped, 0);
    EXPECT_THROW(compositeDifferential(frame(Rect(0, 0, 6, 5)), obj, diff, M, lin, cp),
                 cv::Exception);
    // ratio shadows need the noobj layer: refused by the overload without it
    cp.shadows = CompositeParams::SHADOWS_RATIO;
    EXPECT_THROW(compositeDifferential(frame, obj, diff, M, lin, cp), cv::Exception);
}

// Ratio shadows: where the difference is negative the footage keeps the fraction of light the
// render keeps (I · (1 + α·diff/noobj)); elsewhere, and wherever the render's radiance equals
// the footage's, the result is the additive one. A model brighter than the footage makes the
// additive shadow black (clamped); the ratio shadow keeps the footage's texture and never goes
// below zero.
TEST(RenderDifferential, RatioShadowsFormula) {
    RNG rng(5);
    const Size sz(9, 6);
    Mat frame(sz, CV_8UC3);
    rng.fill(frame, RNG::UNIFORM, 1, 256);
    Mat I;
    linearize(frame, I, Response::SRGB);
    DifferentialImages L;
    L.noobj.create(sz, CV_32FC3);
    L.obj.create(sz, CV_32FC3);
    rng.fill(L.noobj, RNG::UNIFORM, 0, 1.5);
    L.noobj.at<Vec3f>(0, 2) = Vec3f(0, 0, 0);  // no light in the model: a full loss
    rng.fill(L.obj, RNG::UNIFORM, 0, 1.5);
    L.diff = L.obj - L.noobj;
    L.mask.create(sz, CV_32FC1);
    rng.fill(L.mask, RNG::UNIFORM, 0, 1);
    L.mask.row(0).setTo(0);
    CompositeParams cp;
    cp.alpha = 0.8f;
    cp.shadows = CompositeParams::SHADOWS_RATIO;
    Mat lin, add;
    compositeDifferential(frame, L, lin, cp);
    int shadowed = 0, black_additive = 0;
    for (int y = 0; y < sz.height; ++y)
        for (int x = 0; x < sz.width; ++x)
            for (int c = 0; c < 3; ++c) {
                const double i = I.at<Vec3f>(y, x)[c], d = L.diff.at<Vec3f>(y, x)[c];
                const double n = L.noobj.at<Vec3f>(y, x)[c];
                double back;
                if (d < 0) {
                    ++shadowed;
                    back = i * std::max(0.0, 1 + 0.8 * std::max(-1.0, n > 0 ? d / n : -1.0));
                    if (i + 0.8 * d <= 0) ++black_additive;
                } else {
                    back = i + 0.8 * d;
                }
                const double m = L.mask.at<float>(y, x);
                const double want = m * L.obj.at<Vec3f>(y, x)[c] + (1 - m) * back;
                EXPECT_NEAR(lin.at<Vec3f>(y, x)[c], want, 1e-5 * (1 + want));
                EXPECT_GE(lin.at<Vec3f>(y, x)[c], 0.f);
            }
    EXPECT_GT(shadowed, 20);
    EXPECT_GT(black_additive, 0);  // the case ratio shadows are for occurs in this data
    // where the model's radiance is the footage's, ratio and additive agree
    DifferentialImages same = L;
    I.copyTo(same.noobj);
    same.diff = same.obj - same.noobj;
    Mat r1, a1;
    compositeDifferential(frame, same, r1, cp);
    cp.shadows = CompositeParams::SHADOWS_ADDITIVE;
    compositeDifferential(frame, same, a1, cp);
    EXPECT_LT(norm(r1, a1, NORM_INF), 1e-5);
    // the additive overload and the layers overload agree for additive shadows
    compositeDifferential(frame, L, lin, cp);
    compositeDifferential(frame, L.obj, L.diff, L.mask, add, cp);
    EXPECT_EQ(norm(lin, add, NORM_INF), 0.0);
}

// The 8×8 projected coverage of one triangle integrates to its analytic image area; pixels well
// inside are 1, well outside 0; the primary-ray mask agrees on average.
TEST(RenderDifferential, ProjectedCoverageOfTriangle) {
    ScratchDir dir;
    {
        std::ofstream f(dir / "tri.obj");
        f << "v 0 0 0\nv 1 0 0\nv 0.3 0 0.8\nf 1 2 3\n";
    }
    Scene s;
    s.image_size = Size(64, 48);
    s.lights = {};
    Light env;
    env.type = Light::ENVIRONMENT;
    env.radiance = Vec3d(1, 1, 1);
    s.lights = {env};
    SceneObject o;
    o.mesh = dir / "tri.obj";
    o.world_from_object = vbme_test::placement(1, Vec3d(-0.45, 0, 0.1));
    o.has_material = true;
    o.material = vbme_test::lambertian(Vec3d(0.5, 0.5, 0.5));
    s.objects = {o};
    s.camera = vbme_test::lookAt(Vec3d(0.2, -2.0, 1.0), Vec3d(0, 0, 0.45), 70, s.image_size);
    Ptr<RenderScene> rs = RenderScene::create(s);
    Mat cov;
    projectObjectCoverage(*rs, s.camera, cov, 8);
    const Point2d a = s.camera.project(Vec3d(-0.45, 0, 0.1)),
                  b = s.camera.project(Vec3d(0.55, 0, 0.1)),
                  c = s.camera.project(Vec3d(-0.15, 0, 0.9));
    const double area = 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    ASSERT_GT(area, 300.0);
    EXPECT_NEAR(sum(cov)[0], area, 0.005 * area);
    // Fully inside / outside pixels (distance to the edges > 1 px).
    std::vector<Point2f> tri = {Point2f(a), Point2f(b), Point2f(c)};
    for (int y = 0; y < cov.rows; ++y)
        for (int x = 0; x < cov.cols; ++x) {
            const double dist = pointPolygonTest(tri, Point2f((float)x, (float)y), true);
            if (dist > 1.0) {
                EXPECT_EQ(cov.at<float>(y, x), 1.f) << x << "," << y;
            } else if (dist < -1.0) {
                EXPECT_EQ(cov.at<float>(y, x), 0.f) << x << "," << y;
            }
        }
    // The renderer's own primary rays.
    DifferentialRenderer::Params p;
    p.render.spp = 16;
    p.render.max_depth = 1;
    p.coverage = COVERAGE_PRIMARY_RAYS;
    DifferentialImages im;
    DifferentialRenderer::create(p)->render(*rs, s.camera, im);
    EXPECT_NEAR(sum(im.mask)[0], area, 0.02 * area);
    EXPECT_THROW(projectObjectCoverage(*rs, s.camera, cov, 9), cv::Exception);
}

// The multi-layer EXR keeps every layer; a file without them is refused naming the channels.
TEST(RenderDifferential, ExrLayersRoundTrip) {
    ScratchDir dir;
    RNG rng(1);
    const Size sz(5, 4);
    DifferentialImages im;
    im.obj.create(sz, CV_32FC3);
    im.noobj.create(sz, CV_32FC3);
    im.mask.create(sz, CV_32FC1);
    rng.fill(im.obj, RNG::UNIFORM, 0, 3);
    rng.fill(im.noobj, RNG::UNIFORM, 0, 3);
    rng.fill(im.mask, RNG::UNIFORM, 0, 1);
    im.diff = im.obj - im.noobj;
    Mat comp(sz, CV_32FC3);
    rng.fill(comp, RNG::UNIFORM, 0, 1);
    writeDifferentialExr(dir / "d.exr", im, comp, {{"vbme.seed", "4"}});
    Mat comp2;
    std::map<std::string, std::string> attr;
    const DifferentialImages r = readDifferentialExr(dir / "d.exr", comp2, &attr);
    EXPECT_EQ(norm(r.obj, im.obj, NORM_INF), 0.0);
    EXPECT_EQ(norm(r.noobj, im.noobj, NORM_INF), 0.0);
    EXPECT_EQ(norm(r.diff, im.diff, NORM_INF), 0.0);
    EXPECT_EQ(norm(r.mask, im.mask, NORM_INF), 0.0);
    EXPECT_EQ(norm(comp2, comp, NORM_INF), 0.0);
    EXPECT_EQ(attr["vbme.seed"], "4");
    const auto ch = readExrChannels(dir / "d.exr");
    for (const char* n : {"R", "G", "B", "obj.R", "obj.G", "obj.B", "noobj.R", "noobj.G", "noobj.B",
                          "diff.R", "diff.G", "diff.B", "mask"})
        EXPECT_EQ(ch.count(n), 1u) << n;
    writeExrChannels(dir / "plain.exr", {{"R", im.mask}, {"G", im.mask}, {"B", im.mask}});
    try {
        readDifferentialExr(dir / "plain.exr");
        ADD_FAILURE() << "no exception";
    } catch (const cv::Exception& e) {
        EXPECT_NE(std::string(e.what()).find("obj.R"), std::string::npos) << e.what();
    }
}

// Seeds across frames: fixed keeps the seed; per-frame gives each frame its own, reproducibly.
TEST(RenderDifferential, FrameSeeds) {
    EXPECT_EQ(frameSeed(7, 0, SEEDS_FIXED), 7u);
    EXPECT_EQ(frameSeed(7, 12, SEEDS_FIXED), 7u);
    std::set<uint64> seen;
    for (int f = 0; f < 100; ++f) {
        const uint64 s = frameSeed(7, f, SEEDS_PER_FRAME);
        EXPECT_EQ(s, frameSeed(7, f, SEEDS_PER_FRAME));
        EXPECT_NE(s, frameSeed(8, f, SEEDS_PER_FRAME));
        seen.insert(s);
    }
    EXPECT_EQ(seen.size(), 100u);
    EXPECT_EQ(parseFrameSeeding("per-frame"), SEEDS_PER_FRAME);
    EXPECT_THROW(parseFrameSeeding("random"), cv::Exception);
    EXPECT_THROW(frameSeed(7, -1, SEEDS_PER_FRAME), cv::Exception);
}

// Params survive a FileStorage round trip; bad values are refused.
TEST(RenderDifferential, ParamsReadWrite) {
    DifferentialRenderer::Params p;
    p.render.spp = 12;
    p.render.seed = 9;
    p.render.light_selection = Renderer::LIGHTS_POWER;
    p.method = DifferentialRenderer::TWO_PASS;
    p.independent = true;
    p.coverage = COVERAGE_PRIMARY_RAYS;
    p.coverage_supersampling = 4;
    p.coverage_occlusion = false;
    FileStorage fs("p.yml", FileStorage::WRITE | FileStorage::MEMORY);
    fs << "p"
       << "{";
    p.write(fs);
    fs << "}";
    const std::string text = fs.releaseAndGetString();
    FileStorage in(text, FileStorage::READ | FileStorage::MEMORY);
    DifferentialRenderer::Params q;
    q.read(in["p"]);
    EXPECT_EQ(q.render.spp, 12);
    EXPECT_EQ(q.render.seed, 9u);
    EXPECT_EQ(q.render.light_selection, Renderer::LIGHTS_POWER);
    EXPECT_EQ(q.method, DifferentialRenderer::TWO_PASS);
    EXPECT_TRUE(q.independent);
    EXPECT_EQ(q.coverage, COVERAGE_PRIMARY_RAYS);
    EXPECT_EQ(q.coverage_supersampling, 4);
    EXPECT_FALSE(q.coverage_occlusion);
    p.coverage_supersampling = 0;
    EXPECT_THROW(DifferentialRenderer::create(p), cv::Exception);
    CompositeParams c;
    c.alpha = 0.25f;
    c.response = Response::GAMMA22;
    FileStorage fc("c.yml", FileStorage::WRITE | FileStorage::MEMORY);
    fc << "c"
       << "{";
    c.write(fc);
    fc << "}";
    FileStorage ic(fc.releaseAndGetString(), FileStorage::READ | FileStorage::MEMORY);
    CompositeParams d;
    d.read(ic["c"]);
    EXPECT_EQ(d.alpha, 0.25f);
    EXPECT_EQ(d.response, Response::GAMMA22);
    EXPECT_EQ(d.shadows, CompositeParams::SHADOWS_ADDITIVE);
    c.shadows = CompositeParams::SHADOWS_RATIO;
    FileStorage fr("c.yml", FileStorage::WRITE | FileStorage::MEMORY);
    fr << "c"
       << "{";
    c.write(fr);
    fr << "}";
    FileStorage ir(fr.releaseAndGetString(), FileStorage::READ | FileStorage::MEMORY);
    d.read(ir["c"]);
    EXPECT_EQ(d.shadows, CompositeParams::SHADOWS_RATIO);
    FileStorage bad("%YAML:1.0\nc: { shadows: multiply }\n",
                    FileStorage::READ | FileStorage::MEMORY);
    EXPECT_THROW(d.read(bad["c"]), cv::Exception);
}

// The one-pass differential render is bitwise identical for any thread count.
TEST(RenderDifferential, DeterministicAcrossThreadCounts) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    const Scene s = cubeOnFloor(dir / "cube.obj", Size(40, 20));
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 2;
    p.max_depth = 4;
    p.tile_size = 8;
    RenderImages w1, n1, w3, n3;
    p.threads = 1;
    Renderer::create(p)->renderDifferential(*rs, s.camera, w1, n1);
    p.threads = 3;
    Renderer::create(p)->renderDifferential(*rs, s.camera, w3, n3);
    EXPECT_EQ(norm(w1.color, w3.color, NORM_INF), 0.0);
    EXPECT_EQ(norm(n1.color, n3.color, NORM_INF), 0.0);
    EXPECT_EQ(norm(w1.object, w3.object, NORM_INF), 0.0);
    EXPECT_GT(norm(w1.color, n1.color, NORM_INF), 0.0);
}

// Camera rays traced in packets of 8 (rtcIntersect8) ahead of their paths give the same bits as
// one rtcIntersect1 each: with and without the objects, in Embree's robust mode and without,
// with a last packet of 5 (13 spp), under the adaptive sampler's two phases too.
TEST(RenderDifferential, CameraPacketsChangeNoBit) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    const Scene s = cubeOnFloor(dir / "cube.obj", Size(24, 16));
    for (const bool robust : {true, false}) {
        RenderScene::Params sp;
        sp.robust = robust;
        Ptr<RenderScene> rs = RenderScene::create(s, sp);
        for (const int min_spp : {0, 4}) {
            Renderer::Params p;
            p.spp = 13;
            p.max_depth = 3;
            p.threads = 2;
            p.adaptive_min_spp = min_spp;
            RenderImages w[2], n[2];
            for (int packets = 0; packets < 2; ++packets) {
                p.camera_packets = packets == 1;
                Renderer::create(p)->renderDifferential(*rs, s.camera, w[packets], n[packets]);
            }
            EXPECT_EQ(norm(w[0].color, w[1].color, NORM_INF), 0.0) << robust << min_spp;
            EXPECT_EQ(norm(n[0].color, n[1].color, NORM_INF), 0.0) << robust << min_spp;
            EXPECT_EQ(norm(w[0].object, w[1].object, NORM_INF), 0.0) << robust << min_spp;
            EXPECT_GT(norm(w[1].color, n[1].color, NORM_INF), 0.0);  // the object is seen
        }
    }
}
