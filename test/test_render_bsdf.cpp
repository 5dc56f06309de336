// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// BSDF models: energy conservation (white furnace), reciprocity, chi-square fit of sample()
// against pdf(), consistency of sample() with eval()/pdf(), Fresnel against known values.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/vbme/render/bsdf.hpp>

#include "../modules/vbme_render/src/fresnel.hpp"
#include "../modules/vbme_render/src/microfacet.hpp"
#include "test_render_bsdf_chi2.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

const float kPi = 3.14159265358979323846f;

struct Case {
    std::string name;
    Material m;
};

Material lambertian(Vec3d albedo) {
    Material m;
    m.type = Material::LAMBERTIAN;
    m.albedo = albedo;
    return m;
}
Material phong(Vec3d kd, Vec3d ks, double n) {
    Material m;
    m.type = Material::PHONG;
    m.kd = kd;
    m.ks = ks;
    m.exponent = n;
    return m;
}
Material cookTorrance(Vec3d kd, Vec3d ks, double alpha, double ior) {
    Material m;
    m.type = Material::COOK_TORRANCE;
    m.kd = kd;
    m.ks = ks;
    m.roughness = alpha;
    m.ior = ior;
    return m;
}
Material conductorColour(Vec3d colour, double alpha) {
    Material m;
    m.type = Material::CONDUCTOR;
    m.use_colour = true;
    m.colour = colour;
    m.roughness = alpha;
    return m;
}
Material gold(double alpha) {
    Material m = Material::preset("gold");
    m.roughness = alpha;
    return m;
}
Material dielectric(double ior, double alpha) {
    Material m;
    m.type = Material::DIELECTRIC;
    m.ior = ior;
    m.roughness = alpha;
    return m;
}
Material plastic(Vec3d albedo, double ior, double alpha) {
    Material m;
    m.type = Material::PLASTIC;
    m.albedo = albedo;
    m.ior = ior;
    m.roughness = alpha;
    return m;
}

// Non-delta models (every sampled direction is described by pdf(), except the smooth
// plastic's coat, which is a delta lobe next to a diffuse one).
std::vector<Case> nonDeltaCases() {
    return {
        {"lambertian", lambertian(Vec3d(0.8, 0.5, 0.2))},
        {"phong_n20", phong(Vec3d(0.3, 0.3, 0.3), Vec3d(0.6, 0.5, 0.4), 20)},
        {"phong_n3", phong(Vec3d(0.1, 0.2, 0.3), Vec3d(0.8, 0.7, 0.6), 3)},
        {"cook_torrance_a025", cookTorrance(Vec3d(0.2, 0.2, 0.2), Vec3d(0.7, 0.7, 0.7), 0.25, 1.5)},
        {"cook_torrance_a06", cookTorrance(Vec3d(0.4, 0.3, 0.2), Vec3d(0.5, 0.5, 0.5), 0.6, 2.0)},
        {"gold_a02", gold(0.2)},
        {"conductor_colour_a05", conductorColour(Vec3d(0.9, 0.6, 0.3), 0.5)},
        {"dielectric_a03", dielectric(1.5, 0.3)},
        {"dielectric_a015_ice", dielectric(1.31, 0.15)},
        {"plastic_a02", plastic(Vec3d(0.1, 0.3, 0.7), 1.5, 0.2)},
        {"plastic_smooth", plastic(Vec3d(0.6, 0.3, 0.1), 1.5, 0.0)},
        {"cook_torrance_smooth", cookTorrance(Vec3d(0.5, 0.4, 0.3), Vec3d(0.5, 0.5, 0.5), 0, 1.5)},
    };
}

Vec3f dirFromAngles(float theta, float phi) {
    return Vec3f(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
}
Vec3f randomDir(RNG& rng) {
    const float z = rng.uniform(-1.f, 1.f), phi = rng.uniform(0.f, 2 * kPi);
    const float r = std::sqrt(std::max(0.f, 1 - z * z));
    return Vec3f(r * std::cos(phi), r * std::sin(phi), z);
}

// Directional albedo ∫ f|cos| dωi for wo, estimated from sample() weights. Transmitted
// weights are multiplied by (η_wi/η_wo)² (the radiance scaling undone) so that a lossless
// interface gives exactly 1 from both sides.
Vec3f albedo(const Bsdf& b, const Vec3f& wo, int n, uint64 seed, float ior = 1.f) {
    RNG rng(seed);
    Vec3d sum(0, 0, 0);
    const Vec3f diffuse = b.defaultDiffuse();
    for (int i = 0; i < n; i++) {
        BsdfSample s;
        const Vec2f u(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f));
        if (!b.sample(wo, u, rng.uniform(0.f, 1.f), diffuse, s)) continue;
        Vec3f w = s.weight;
        if (s.transmission) {
            const float eta_ti = wo[2] > 0 ? ior : 1.f / ior;
            w *= eta_ti * eta_ti;
        }
        sum += Vec3d(w[0], w[1], w[2]);
    }
    return Vec3f((float)(sum[0] / n), (float)(sum[1] / n), (float)(sum[2] / n));
}

}  // namespace

// ------------------------------------------------------------------------------------------
// Energy

TEST(RenderBsdf, LambertianAlbedoIsExactByEvalQuadrature) {
    const Vec3f a(0.8f, 0.5f, 0.2f);
    Ptr<Bsdf> b = Bsdf::create(lambertian(Vec3d(a[0], a[1], a[2])));
    for (float th : {0.f, 0.7f, 1.5f}) {
        const Vec3f wo = dirFromAngles(th, 0.4f);
        // ∫ f cos dω by the midpoint rule in (θ, φ): independent of sample().
        const int nt = 200, np = 64;
        Vec3d s(0, 0, 0);
        for (int i = 0; i < nt; i++)
            for (int j = 0; j < np; j++) {
                const float t = (i + 0.5f) * (kPi / 2) / nt, p = (j + 0.5f) * 2 * kPi / np;
                const Vec3f wi = dirFromAngles(t, p);
                const Vec3f f = b->eval(wo, wi, a);
                const double w = std::cos(t) * std::sin(t) * (kPi / 2 / nt) * (2 * kPi / np);
                s += Vec3d(f[0], f[1], f[2]) * w;
            }
        for (int c = 0; c < 3; c++)
            EXPECT_NEAR(s[c], a[c], 2e-3 * a[c]) << "theta " << th;
        // From sampling: every weight equals the albedo.
        const Vec3f e = albedo(*b, wo, 1000, 1);
        for (int c = 0; c < 3; c++)
            EXPECT_NEAR(e[c], a[c], 1e-5);
    }
}

TEST(RenderBsdf, EnergyConservedByEveryModel) {
    std::vector<Case> cases = nonDeltaCases();
    cases.push_back({"mirror", Material::preset("mirror")});
    cases.push_back({"glass_smooth", dielectric(1.5, 0)});
    cases.push_back({"gold_a0", gold(0)});
    cases.push_back({"phong_sum_gt1", phong(Vec3d(0.8, 0.8, 0.8), Vec3d(0.8, 0.8, 0.8), 10)});
    cases.push_back({"phong_n1_white", phong(Vec3d(0, 0, 0), Vec3d(1, 1, 1), 1)});
    for (const Case& c : cases) {
        Ptr<Bsdf> b = Bsdf::create(c.m);
        const float ior = (float)c.m.ior;
        for (int i = 0; i < 9; i++) {
            const float th = (i + 0.5f) / 9 * (kPi / 2);
            for (float side : {1.f, -1.f}) {
                Vec3f wo = dirFromAngles(th, 1.1f);
                wo[2] *= side;
                const Vec3f e = albedo(*b, wo, 20000, 7 + i, ior);
                for (int k = 0; k < 3; k++)
                    EXPECT_LE(e[k], 1.f + 0.01f)
                        << c.name << " theta " << th << " side " << side << " channel " << k;
            }
        }
    }
}

TEST(RenderBsdf, WhiteFurnaceOfLosslessModelsIsOne) {
    // Plastic with a white base loses nothing (the base is coupled to the coat's albedo);
    // a smooth white mirror neither.
    const std::vector<Case> cases = {{"plastic_white_smooth", plastic(Vec3d(1, 1, 1), 1.5, 0)},
                                     {"plastic_white_rough", plastic(Vec3d(1, 1, 1), 1.5, 0.3)},
                                     {"mirror_white", conductorColour(Vec3d(1, 1, 1), 0)},
                                     {"lambert_white", lambertian(Vec3d(1, 1, 1))}};
    for (const Case& c : cases) {
        Ptr<Bsdf> b = Bsdf::create(c.m);
        for (float th : {0.1f, 0.6f, 1.0f, 1.3f, 1.5f}) {
            const Vec3f e = albedo(*b, dirFromAngles(th, 0.2f), 40000, 3);
            for (int k = 0; k < 3; k++)
                EXPECT_NEAR(e[k], 1.f, 0.015f) << c.name << " " << th;
        }
    }
    // A rough white conductor loses the single-scattering deficit. At normal incidence it is
    // known in closed form: the visible normals are D(m)cos θm, wi = 2(m·z)m − z leaves the
    // hemisphere when θm > 45°, and the weight is G2/G1 = 1/(1 + Λ(wi)) with θi = 2θm:
    //   E = ∫₀^{π/4} D(θm) cos θm sin θm 2π / (1 + Λ(2θm)) dθm.
    for (double a : {0.2, 0.5, 0.8}) {
        Ptr<Bsdf> b = Bsdf::create(conductorColour(Vec3d(1, 1, 1), a));
        double expect = 0;
        const int n = 20000;
        for (int i = 0; i < n; i++) {
            const double tm = (i + 0.5) * (CV_PI / 4) / n;
            const double c2 = std::cos(tm) * std::cos(tm);
            const double D = a * a / (CV_PI * std::pow(c2 * (a * a - 1) + 1, 2));
            const double ti = 2 * tm;
            const double lambda = 0.5 * (-1 + std::sqrt(1 + a * a * std::pow(std::tan(ti), 2)));
            expect += D * std::cos(tm) * std::sin(tm) * 2 * CV_PI / (1 + lambda) * (CV_PI / 4) / n;
        }
        const Vec3f e = albedo(*b, Vec3f(0, 0, 1), 100000, 3);
        EXPECT_NEAR(e[0], expect, 0.005) << "alpha " << a;
        // And it is less than 1 at every angle.
        for (float th : {0.6f, 1.0f, 1.4f})
            EXPECT_LE(albedo(*b, dirFromAngles(th, 0.2f), 20000, 3)[0], 1.f);
    }
}

TEST(RenderBsdf, SmoothDielectricReflectionPlusTransmissionIsOne) {
    for (float ior : {1.5f, 1.31f, 2.4f}) {
        Ptr<Bsdf> b = Bsdf::create(dielectric(ior, 0));
        ASSERT_TRUE(b->isDelta());
        ASSERT_TRUE(b->hasTransmission());
        for (int i = 0; i < 40; i++) {
            const float th = (i + 0.5f) / 40 * (kPi / 2);
            for (float side : {1.f, -1.f}) {
                Vec3f wo = dirFromAngles(th, 0.7f);
                wo[2] *= side;
                const float F = fresnel::dielectric(wo[2], ior);
                // Reflection lobe (u_lobe < F) and transmission lobe.
                BsdfSample r, t;
                ASSERT_TRUE(b->sample(wo, Vec2f(0.5f, 0.5f), 0.f, Vec3f(), r));
                EXPECT_TRUE(r.delta);
                EXPECT_FALSE(r.transmission);
                EXPECT_NEAR(r.pdf, F, 1e-6);
                EXPECT_NEAR(r.wi[0], -wo[0], 1e-6);
                EXPECT_NEAR(r.wi[2], wo[2], 1e-6);
                double total = r.pdf * r.weight[0];
                if (F < 1.f) {
                    ASSERT_TRUE(b->sample(wo, Vec2f(0.5f, 0.5f), 0.9999f, Vec3f(), t));
                    EXPECT_TRUE(t.transmission);
                    EXPECT_LT(t.wi[2] * wo[2], 0.f);
                    // Snell: η_o sin θo = η_i sin θi, and the refracted ray is in the plane.
                    const float eta_o = wo[2] > 0 ? 1.f : ior, eta_i = wo[2] > 0 ? ior : 1.f;
                    const float so = std::sqrt(1 - wo[2] * wo[2]);
                    const float si = std::sqrt(1 - t.wi[2] * t.wi[2]);
                    EXPECT_NEAR(eta_o * so, eta_i * si, 1e-4);
                    EXPECT_NEAR(t.wi[0] * wo[1] - t.wi[1] * wo[0], 0.f, 1e-5);
                    EXPECT_LT(t.wi[0] * wo[0], 1e-6f);  // goes through to the other side
                    // Radiance scaling: (η_o/η_i)².
                    EXPECT_NEAR(t.weight[0], (eta_o / eta_i) * (eta_o / eta_i), 1e-5);
                    total += t.pdf * t.weight[0] * (eta_i / eta_o) * (eta_i / eta_o);
                }
                EXPECT_NEAR(total, 1.0, 1e-5) << "ior " << ior << " theta " << th;
                // Delta lobes: eval and pdf are zero.
                EXPECT_EQ(b->eval(wo, r.wi, Vec3f())[0], 0.f);
                EXPECT_EQ(b->pdf(wo, r.wi, Vec3f()), 0.f);
            }
        }
    }
}

TEST(RenderBsdf, SmoothConductorIsAMirrorWithExactFresnel) {
    Ptr<Bsdf> b = Bsdf::create(gold(0));
    ASSERT_TRUE(b->isDelta());
    const Material g = Material::preset("gold");
    for (float th : {0.f, 0.5f, 1.2f, 1.55f}) {
        const Vec3f wo = dirFromAngles(th, 2.f);
        BsdfSample s;
        ASSERT_TRUE(b->sample(wo, Vec2f(0.3f, 0.8f), 0.5f, Vec3f(), s));
        EXPECT_TRUE(s.delta);
        EXPECT_NEAR(norm(s.wi - Vec3f(-wo[0], -wo[1], wo[2])), 0, 1e-6);
        for (int c = 0; c < 3; c++)
            EXPECT_NEAR(s.weight[c], fresnel::conductor(wo[2], (float)g.eta[c], (float)g.k[c]),
                        1e-6);
        EXPECT_EQ(b->pdf(wo, s.wi, Vec3f()), 0.f);
    }
}

// ------------------------------------------------------------------------------------------
// Reciprocity

TEST(RenderBsdf, ReflectionIsReciprocal) {
    RNG rng(11);
    for (const Case& c : nonDeltaCases()) {
        Ptr<Bsdf> b = Bsdf::create(c.m);
        const Vec3f d = b->defaultDiffuse();
        int nonzero = 0;
        for (int i = 0; i < 2000; i++) {
            Vec3f wo = randomDir(rng), wi = randomDir(rng);
            wo[2] = std::abs(wo[2]);
            wi[2] = std::abs(wi[2]);
            if (i % 2) {  // also from below (two-sided opaque models, inside of dielectrics)
                wo[2] = -wo[2];
                wi[2] = -wi[2];
            }
            const Vec3f a = b->eval(wo, wi, d), r = b->eval(wi, wo, d);
            for (int k = 0; k < 3; k++)
                ASSERT_NEAR(a[k], r[k], 1e-5 + 1e-3 * std::max(a[k], r[k]))
                    << c.name << " wo " << wo << " wi " << wi;
            nonzero += a[0] > 0;
        }
        EXPECT_GT(nonzero, 500) << c.name;
    }
}

TEST(RenderBsdf, RoughRefractionObeysGeneralisedReciprocity) {
    // f(wo, wi)/η_wo² = f(wi, wo)/η_wi² (radiance BTDF, Veach 1997 §5.2).
    RNG rng(12);
    for (float ior : {1.5f, 1.31f}) {
        Ptr<Bsdf> b = Bsdf::create(dielectric(ior, 0.3));
        int nonzero = 0;
        for (int i = 0; i < 4000; i++) {
            Vec3f wo = randomDir(rng), wi = randomDir(rng);
            if (wo[2] * wi[2] > 0) wi[2] = -wi[2];
            const float eo = wo[2] > 0 ? 1.f : ior, ei = wi[2] > 0 ? 1.f : ior;
            const float a = b->eval(wo, wi, Vec3f())[0] / (eo * eo);
            const float r = b->eval(wi, wo, Vec3f())[0] / (ei * ei);
            ASSERT_NEAR(a, r, 1e-5 + 2e-3 * std::max(a, r)) << "wo " << wo << " wi " << wi;
            nonzero += a > 0;
        }
        EXPECT_GT(nonzero, 400);
    }
}

// ------------------------------------------------------------------------------------------
// Sampling

TEST(RenderBsdf, SampleAgreesWithEvalAndPdf) {
    for (const Case& c : nonDeltaCases()) {
        Ptr<Bsdf> b = Bsdf::create(c.m);
        const Vec3f d = b->defaultDiffuse();
        RNG rng(5);
        int checked = 0;
        for (float th : {0.05f, 0.6f, 1.2f, 1.52f}) {
            for (float side : {1.f, -1.f}) {
                Vec3f wo = dirFromAngles(th, 0.9f);
                wo[2] *= side;
                for (int i = 0; i < 500; i++) {
                    BsdfSample s;
                    const Vec2f u(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f));
                    if (!b->sample(wo, u, rng.uniform(0.f, 1.f), d, s)) continue;
                    ASSERT_NEAR(norm(s.wi), 1.0, 1e-4) << c.name;
                    EXPECT_EQ(s.transmission, s.wi[2] * wo[2] < 0) << c.name;
                    if (s.delta) continue;
                    const float p = b->pdf(wo, s.wi, d);
                    const Vec3f f = b->eval(wo, s.wi, d);
                    ASSERT_NEAR(s.pdf, p, 1e-3 * p + 1e-6) << c.name << " wo " << wo;
                    for (int k = 0; k < 3; k++) {
                        ASSERT_NEAR(s.f[k], f[k], 1e-3 * f[k] + 1e-6) << c.name;
                        const float w = f[k] * std::abs(s.wi[2]) / p;
                        ASSERT_NEAR(s.weight[k], w, 2e-3 * w + 1e-6) << c.name;
                    }
                    checked++;
                }
            }
        }
        EXPECT_GT(checked, 1500) << c.name;
    }
}

TEST(RenderBsdf, SampleMatchesPdfChiSquare) {
    for (const Case& c : nonDeltaCases()) {
        Ptr<Bsdf> b = Bsdf::create(c.m);
        const Vec3f d = b->defaultDiffuse();
        for (float th : {0.15f, 0.9f, 1.4f}) {
            for (float side : {1.f, -1.f}) {
                // One look from below is enough, except inside dielectrics (refraction and TIR).
                if (side < 0 && th != 0.9f && c.m.type != Material::DIELECTRIC) continue;
                Vec3f wo = dirFromAngles(th, 0.3f);
                wo[2] *= side;
                RNG rng(1234);
                auto sample = [&](Vec3f& w) {
                    BsdfSample s;
                    const Vec2f u(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f));
                    if (!b->sample(wo, u, rng.uniform(0.f, 1.f), d, s) || s.delta) return false;
                    w = s.wi;
                    return true;
                };
                auto pdf = [&](const Vec3f& w) { return (double)b->pdf(wo, w, d); };
                const vbme_test::Chi2Result r = vbme_test::chiSquareDirections(sample, pdf, 100000);
                EXPECT_GT(r.p, 0.01)
                    << c.name << " theta " << th << " side " << side << ": " << r.detail;
            }
        }
    }
}

TEST(RenderBsdf, ChiSquareRejectsAWrongPdf) {
    // The test above must be able to fail: cosine-weighted samples against a uniform pdf.
    Ptr<Bsdf> b = Bsdf::create(lambertian(Vec3d(1, 1, 1)));
    RNG rng(3);
    const Vec3f wo(0, 0, 1);
    auto sample = [&](Vec3f& w) {
        BsdfSample s;
        if (!b->sample(wo, Vec2f(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f)), 0.f, Vec3f(1, 1, 1),
                       s))
            return false;
        w = s.wi;
        return true;
    };
    auto wrong = [&](const Vec3f& w) { return w[2] > 0 ? 1.0 / (2 * CV_PI) : 0.0; };
    EXPECT_LT(vbme_test::chiSquareDirections(sample, wrong, 100000).p, 1e-6);
    // A slightly wrong exponent of a Phong lobe is caught too.
    Ptr<Bsdf> p20 = Bsdf::create(phong(Vec3d(0, 0, 0), Vec3d(1, 1, 1), 20));
    Ptr<Bsdf> p24 = Bsdf::create(phong(Vec3d(0, 0, 0), Vec3d(1, 1, 1), 24));
    const Vec3f wo2 = dirFromAngles(0.5f, 0.f);
    auto sample2 = [&](Vec3f& w) {
        BsdfSample s;
        if (!p20->sample(wo2, Vec2f(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f)), 0.5f,
                         Vec3f(0, 0, 0), s))
            return false;
        w = s.wi;
        return true;
    };
    auto pdf24 = [&](const Vec3f& w) { return (double)p24->pdf(wo2, w, Vec3f(0, 0, 0)); };
    EXPECT_LT(vbme_test::chiSquareDirections(sample2, pdf24, 100000).p, 1e-3);
}

// ------------------------------------------------------------------------------------------
// Model details

TEST(RenderBsdf, TextureColourReplacesTheDiffuseConstant) {
    const Vec3f wo = dirFromAngles(0.3f, 0), wi = dirFromAngles(0.5f, 2.f);
    Ptr<Bsdf> l = Bsdf::create(lambertian(Vec3d(0.8, 0.8, 0.8)));
    EXPECT_NEAR(l->eval(wo, wi, Vec3f(0.1f, 0.2f, 0.3f))[2], 0.3f / kPi, 1e-6);
    EXPECT_NEAR(l->defaultDiffuse()[0], 0.8f, 1e-6);
    Ptr<Bsdf> p = Bsdf::create(plastic(Vec3d(0.5, 0.5, 0.5), 1.5, 0.2));
    EXPECT_LT(p->eval(wo, wi, Vec3f(0, 0, 0))[0], p->eval(wo, wi, Vec3f(1, 1, 1))[0]);
    // Conductors and dielectrics ignore it.
    Ptr<Bsdf> g = Bsdf::create(gold(0.3));
    EXPECT_EQ(g->eval(wo, wi, Vec3f(0, 0, 0)), g->eval(wo, wi, Vec3f(1, 1, 1)));
}

TEST(RenderBsdf, OpaqueModelsDoNotTransmitAndEmissiveIsBlack) {
    const Vec3f wo = dirFromAngles(0.3f, 0), below = dirFromAngles(2.5f, 1.f);
    for (const Case& c : nonDeltaCases()) {
        if (c.m.type == Material::DIELECTRIC) continue;
        Ptr<Bsdf> b = Bsdf::create(c.m);
        EXPECT_FALSE(b->hasTransmission()) << c.name;
        EXPECT_EQ(b->eval(wo, below, Vec3f(1, 1, 1)), Vec3f(0, 0, 0)) << c.name;
        EXPECT_EQ(b->pdf(wo, below, Vec3f(1, 1, 1)), 0.f) << c.name;
    }
    Material e;
    e.type = Material::EMISSIVE;
    e.radiance = Vec3d(5, 5, 5);
    Ptr<Bsdf> b = Bsdf::create(e);
    EXPECT_EQ(b->eval(wo, dirFromAngles(0.4f, 1.f), Vec3f(1, 1, 1)), Vec3f(0, 0, 0));
    BsdfSample s;
    EXPECT_FALSE(b->sample(wo, Vec2f(0.5f, 0.5f), 0.5f, Vec3f(1, 1, 1), s));
}

TEST(RenderBsdf, DielectricReportsAbsorptionAndIceIsRough) {
    Ptr<Bsdf> ice = Bsdf::create(Material::preset("ice"));
    EXPECT_TRUE(ice->hasTransmission());
    EXPECT_FALSE(ice->isDelta());
    EXPECT_NEAR(ice->absorption()[0], 0.8f, 1e-6);
    EXPECT_NEAR(ice->absorption()[2], 0.1f, 1e-6);
    Ptr<Bsdf> glass = Bsdf::create(Material::preset("glass"));
    EXPECT_TRUE(glass->isDelta());
    EXPECT_EQ(glass->absorption(), Vec3f(0, 0, 0));
}

TEST(RenderBsdf, PhongPeakFollowsItsNormalisation) {
    // f at the mirror direction = ks (n+2)/(2π) (+ kd/π).
    Ptr<Bsdf> b = Bsdf::create(phong(Vec3d(0.2, 0.2, 0.2), Vec3d(0.5, 0.5, 0.5), 40));
    const Vec3f wo = dirFromAngles(0.4f, 0.1f), wr(-wo[0], -wo[1], wo[2]);
    EXPECT_NEAR(b->eval(wo, wr, b->defaultDiffuse())[0], 0.5f * 42 / (2 * kPi) + 0.2f / kPi, 1e-4);
}

TEST(RenderBsdf, CookTorranceHighlightMatchesClosedForm) {
    // At normal incidence and reflection the half vector is the normal: D = 1/(πα²), G = 1,
    // F = F0, so f = kd/π + ks F0/(4 π α²).
    const double a = 0.3;
    Ptr<Bsdf> b = Bsdf::create(cookTorrance(Vec3d(0.2, 0.2, 0.2), Vec3d(0.7, 0.7, 0.7), a, 1.5));
    const Vec3f z(0, 0, 1);
    const double expect = 0.2 / CV_PI + 0.7 * 0.04 / (4 * CV_PI * a * a);
    EXPECT_NEAR(b->eval(z, z, b->defaultDiffuse())[1], expect, 1e-5);
}

TEST(RenderBsdf, GgxConductorHighlightMatchesClosedForm) {
    // Normal incidence and reflection: D = 1/(πα²), G2 = 1, so f = F0/(4πα²).
    const double a = 0.2;
    Ptr<Bsdf> b = Bsdf::create(conductorColour(Vec3d(0.9, 0.5, 0.2), a));
    const Vec3f z(0, 0, 1);
    EXPECT_NEAR(b->eval(z, z, Vec3f())[0], 0.9 / (4 * CV_PI * a * a), 1e-4);
    EXPECT_NEAR(b->eval(z, z, Vec3f())[2], 0.2 / (4 * CV_PI * a * a), 1e-4);
}

// ------------------------------------------------------------------------------------------
// Fresnel

TEST(RenderBsdfFresnel, DielectricKnownValues) {
    EXPECT_NEAR(fresnel::dielectric(1.f, 1.5f), 0.04f, 1e-6);
    EXPECT_NEAR(fresnel::dielectric(1.f, 1.33f), std::pow(0.33 / 2.33, 2), 1e-6);
    EXPECT_NEAR(fresnel::dielectric(0.3f, 1.f), 0.f, 1e-7);
    EXPECT_NEAR(fresnel::dielectric(1e-6f, 1.5f), 1.f, 1e-4);
    // Against the angle form: Rs = sin²(θi−θt)/sin²(θi+θt), Rp = tan²(θi−θt)/tan²(θi+θt).
    for (double ti = 0.05; ti < 1.55; ti += 0.1) {
        const double tt = std::asin(std::sin(ti) / 1.5);
        const double rs = std::pow(std::sin(ti - tt) / std::sin(ti + tt), 2);
        const double rp = std::pow(std::tan(ti - tt) / std::tan(ti + tt), 2);
        EXPECT_NEAR(fresnel::dielectric((float)std::cos(ti), 1.5f), 0.5 * (rs + rp), 1e-5);
        // Same pair seen from inside (Stokes): equal reflectance.
        EXPECT_NEAR(fresnel::dielectric(-(float)std::cos(tt), 1.5f), 0.5 * (rs + rp), 1e-5);
    }
    // Brewster angle: p-polarised reflectance vanishes, F = Rs/2.
    const double tb = std::atan(1.5), tt = std::asin(std::sin(tb) / 1.5);
    EXPECT_NEAR(fresnel::dielectric((float)std::cos(tb), 1.5f),
                0.5 * std::pow(std::sin(tb - tt) / std::sin(tb + tt), 2), 1e-6);
    // Total internal reflection beyond the critical angle asin(1/1.5) ≈ 41.8° from inside.
    EXPECT_EQ(fresnel::dielectric(-(float)std::cos(0.75), 1.5f), 1.f);
    EXPECT_LT(fresnel::dielectric(-(float)std::cos(0.70), 1.5f), 1.f);
}

TEST(RenderBsdfFresnel, ConductorKnownValues) {
    // Normal incidence: ((n−1)² + k²)/((n+1)² + k²).
    const Material g = Material::preset("gold");
    Vec3f f0;
    for (int c = 0; c < 3; c++) {
        const double n = g.eta[c], k = g.k[c];
        const double expect = ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
        f0[c] = fresnel::conductor(1.f, (float)n, (float)k);
        EXPECT_NEAR(f0[c], expect, 1e-5);
    }
    // Gold is yellow: F0 ≈ (0.97, 0.80, 0.32), red > green > blue.
    EXPECT_NEAR(f0[0], 0.967f, 0.005f);
    EXPECT_NEAR(f0[1], 0.803f, 0.005f);
    EXPECT_NEAR(f0[2], 0.322f, 0.005f);
    // k = 0 reduces to the dielectric formula; grazing incidence reflects everything.
    for (float c = 0.05f; c <= 1.f; c += 0.05f)
        EXPECT_NEAR(fresnel::conductor(c, 1.5f, 0.f), fresnel::dielectric(c, 1.5f), 1e-5);
    EXPECT_NEAR(fresnel::conductor(1e-5f, 0.2f, 3.9f), 1.f, 1e-3);
    // Schlick: F0 at normal incidence, 1 at grazing.
    EXPECT_NEAR(fresnel::schlick(1.f, 0.04f), 0.04f, 1e-7);
    EXPECT_NEAR(fresnel::schlick(0.f, 0.04f), 1.f, 1e-7);
    EXPECT_NEAR(fresnel::f0FromIor(1.5f), 0.04f, 1e-7);
}

TEST(RenderBsdfFresnel, DiffuseReflectanceMatchesKnownFits) {
    // Hemispherical average of F for η = 1.5 from outside is ≈ 0.092 (e.g. d'Eon & Irving 2011,
    // 2·FresnelMoment1); from inside it is 1 − (1 − 0.092)/η² ≈ 0.596 (reciprocity).
    const float ext = fresnel::diffuseReflectance(1.5f);
    const float in = fresnel::diffuseReflectance(1.f / 1.5f);
    EXPECT_NEAR(ext, 0.0918f, 0.002f);
    EXPECT_NEAR(in, 1.f - (1.f - ext) / 2.25f, 0.002f);
}

// ------------------------------------------------------------------------------------------
// Microfacet distributions

TEST(RenderBsdfMicrofacet, NormalisationAndMaskingIdentity) {
    // ∫ D(m) cos θm dωm = 1 (projected area), and Smith's G1 satisfies the "weak white furnace"
    // ∫ G1(wo) max(0, wo·m) D(m) dωm = cos θo (Heitz 2014, Eq. 2 and 18).
    const int nt = 1500, np = 256;
    for (float a : {0.05f, 0.2f, 0.5f, 1.f}) {
        const microfacet::Ggx g{a};
        const microfacet::Beckmann b{a};
        double ng = 0, nb = 0;
        for (int i = 0; i < nt; i++) {
            const double t = (i + 0.5) * (CV_PI / 2) / nt;
            const Vec3f m((float)std::sin(t), 0.f, (float)std::cos(t));
            const double w = std::cos(t) * std::sin(t) * (CV_PI / 2 / nt) * 2 * CV_PI;
            ng += g.D(m) * w;
            nb += b.D(m) * w;
        }
        EXPECT_NEAR(ng, 1.0, 2e-3) << "GGX alpha " << a;
        EXPECT_NEAR(nb, 1.0, 2e-3) << "Beckmann alpha " << a;
        if (a < 0.1f) continue;  // the azimuthal grid below is too coarse for a sharp lobe
        for (float to : {0.f, 0.7f, 1.3f}) {
            const Vec3f wo = dirFromAngles(to, 0.f);
            double s = 0;
            for (int i = 0; i < nt; i++) {
                const double t = (i + 0.5) * (CV_PI / 2) / nt;
                for (int j = 0; j < np; j++) {
                    const double p = (j + 0.5) * 2 * CV_PI / np;
                    const Vec3f m = dirFromAngles((float)t, (float)p);
                    s += g.G1(wo) * std::max(0.f, wo.dot(m)) * g.D(m) * std::sin(t) *
                         (CV_PI / 2 / nt) * (2 * CV_PI / np);
                }
            }
            EXPECT_NEAR(s, std::cos(to), 3e-3) << "alpha " << a << " theta " << to;
        }
    }
    // Height-correlated G2 = 1/(1 + Λo + Λi) lies between the separable product G1·G1 (which
    // ignores the correlation) and min(G1(wo), G1(wi)), and equals G1 when one direction is the
    // normal.
    const microfacet::Ggx g{0.4f};
    const Vec3f wo = dirFromAngles(1.f, 0.f), wi = dirFromAngles(0.6f, 2.f);
    EXPECT_GT(g.G2(wo, wi), g.G1(wo) * g.G1(wi));
    EXPECT_LT(g.G2(wo, wi), std::min(g.G1(wo), g.G1(wi)));
    EXPECT_NEAR(g.G2(wo, Vec3f(0, 0, 1)), g.G1(wo), 1e-6);
}
