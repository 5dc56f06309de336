// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/vbme/render/lights.hpp>
#include <opencv2/vbme/render/sampler.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

// Irradiance at x (normal n) from a uniformly emitting polygon of radiance 1, by Lambert's
// contour formula: E = ½ Σ Θ_i (n · Γ_i) (the form factor times π).
double polygonIrradiance(const std::vector<Vec3d>& poly, const Vec3d& x, const Vec3d& n) {
    double e = 0;
    for (size_t i = 0; i < poly.size(); ++i) {
        const Vec3d a = normalize(poly[i] - x), b = normalize(poly[(i + 1) % poly.size()] - x);
        const double theta = std::acos(std::min(1.0, std::max(-1.0, a.dot(b))));
        e += theta * n.dot(normalize(a.cross(b)));
    }
    return 0.5 * std::abs(e);
}

// Monte Carlo irradiance with the light's own sampling: mean of L·cos/pdf.
Vec3d estimateIrradiance(const Emitter& e, const Vec3f& x, const Vec3f& n, int count = 4096) {
    const SobolSampler s(5);
    Vec3d sum(0, 0, 0);
    for (int i = 0; i < count; ++i) {
        EmitterSample es;
        if (!e.sample(x, s.get2D(Point(0, 0), i, 0), es)) continue;
        const float c = n.dot(es.wi);
        if (c <= 0) continue;
        sum += Vec3d(es.L) * double(c / es.pdf);
    }
    return sum / count;
}

}  // namespace

TEST(RenderLights, PolygonIrradianceMatchesFormFactor) {
    Light l;
    l.type = Light::POLYGON;
    // unit square at z = 1, wound counter-clockwise seen from below (lit side down)
    l.corners = {Vec3d(-0.5, 0.5, 1), Vec3d(0.5, 0.5, 1), Vec3d(0.5, -0.5, 1),
                 Vec3d(-0.5, -0.5, 1)};
    ASSERT_NEAR(l.polygonNormal()[2], -1.0, 1e-12);
    l.radiance = Vec3d(2, 3, 4);
    Ptr<Emitter> e = Emitter::create(l);
    struct Case {
        Vec3d x, n;
    };
    const Case cases[] = {{Vec3d(0, 0, 0), Vec3d(0, 0, 1)},
                          {Vec3d(0.7, -0.3, 0.2), Vec3d(0, 0, 1)},
                          {Vec3d(0.2, 0.1, 0.5), normalize(Vec3d(0.3, -0.2, 1))},
                          {Vec3d(-1.0, 0.4, 0.0), normalize(Vec3d(0.6, 0.0, 0.8))}};
    for (const auto& c : cases) {
        const double ref = polygonIrradiance(l.corners, c.x, c.n);
        const Vec3d est = estimateIrradiance(*e, Vec3f(c.x), Vec3f(c.n));
        for (int k = 0; k < 3; ++k)
            EXPECT_NEAR(est[k], ref * l.radiance[k], 5e-3 * ref * l.radiance[k]);
    }
    // Behind the light: nothing arrives.
    EmitterSample es;
    EXPECT_FALSE(e->sample(Vec3f(0, 0, 2), Vec2f(0.3f, 0.6f), es));
}

TEST(RenderLights, PolygonPdfHitMatchesSample) {
    Light l;
    l.type = Light::POLYGON;
    l.corners = {Vec3d(0, 0, 2), Vec3d(0, 1, 2), Vec3d(1, 1.5, 2),
                 Vec3d(1.5, 0.2, 2)};  // wound so the normal points down
    ASSERT_LT(l.polygonNormal()[2], 0);
    Ptr<Emitter> e = Emitter::create(l);
    const Vec3f p(0.3f, 0.2f, 0.f);
    const SobolSampler s(1);
    for (int i = 0; i < 32; ++i) {
        EmitterSample es;
        ASSERT_TRUE(e->sample(p, s.get2D(Point(1, 1), i, 0), es));
        EXPECT_NEAR(e->pdfHit(p, es.wi, es.dist), es.pdf, 1e-4 * es.pdf);
        EXPECT_EQ(e->radianceHit(es.wi), Vec3f(l.radiance));
        EXPECT_EQ(e->radianceHit(-es.wi), Vec3f(0, 0, 0));  // one-sided
    }
}

TEST(RenderLights, PointAndDistant) {
    Light pl;
    pl.type = Light::POINT;
    pl.position = Vec3d(0, 0, 2);
    pl.intensity = Vec3d(8, 8, 8);
    const Vec3d Ep = estimateIrradiance(*Emitter::create(pl), Vec3f(0, 0, 0), Vec3f(0, 0, 1), 16);
    EXPECT_NEAR(Ep[0], 8.0 / 4.0, 1e-5);  // I cos θ / d²

    Light dl;
    dl.type = Light::DISTANT;
    dl.to_light = normalize(Vec3d(0.2, 0.1, 1));
    dl.radiance = Vec3d(100, 100, 100);
    dl.half_angle_deg = 5;
    Ptr<Emitter> d = Emitter::create(dl);
    EXPECT_FALSE(d->isDelta());
    EXPECT_TRUE(d->isInfinite());
    const Vec3f n(dl.to_light);
    const double s = std::sin(5 * CV_PI / 180);
    const Vec3d Ed = estimateIrradiance(*d, Vec3f(0, 0, 0), n);
    EXPECT_NEAR(Ed[0], 100 * CV_PI * s * s, 1e-3 * 100 * CV_PI * s * s);  // L π sin²θmax
    EXPECT_GT(d->pdfEscaped(n), 0.f);
    EXPECT_EQ(d->radianceEscaped(Vec3f(0, 0, -1)), Vec3f(0, 0, 0));

    dl.half_angle_deg = 0;
    Ptr<Emitter> d0 = Emitter::create(dl);
    EXPECT_TRUE(d0->isDelta());
    EXPECT_NEAR(estimateIrradiance(*d0, Vec3f(0, 0, 0), n, 4)[0], 100.0, 1e-3);
}

TEST(RenderLights, ConstantEnvironmentIrradiance) {
    Light l;
    l.type = Light::ENVIRONMENT;
    l.radiance = Vec3d(0.5, 1.0, 2.0);
    Ptr<Emitter> e = Emitter::create(l);
    const Vec3d E =
        estimateIrradiance(*e, Vec3f(0, 0, 0), normalize(Vec3f(0.3f, 0.4f, 0.5f)), 8192);
    for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(E[k], CV_PI * l.radiance[k], 0.01 * CV_PI * l.radiance[k]);
}
