// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Sampling warps and piecewise-constant distributions (modules/vbme_render/src/sampling.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "../modules/vbme_render/src/sampling.hpp"
#include "test_render_bsdf_chi2.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

Vec2f rand2(RNG& rng) {
    return Vec2f(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f));
}

}  // namespace

TEST(RenderSampling, FrameIsOrthonormalAndRightHanded) {
    RNG rng(1);
    std::vector<Vec3f> normals = {Vec3f(0, 0, 1), Vec3f(0, 0, -1), Vec3f(1, 0, 0), Vec3f(0, -1, 0),
                                  Vec3f(0, 0, -0.99999994f)};
    for (int i = 0; i < 1000; i++)
        normals.push_back(sampling::squareToUniformSphere(rand2(rng)));
    for (Vec3f n : normals) {
        n /= (float)norm(n);
        const sampling::Frame f(n);
        EXPECT_NEAR(norm(f.t), 1, 1e-5);
        EXPECT_NEAR(norm(f.b), 1, 1e-5);
        EXPECT_NEAR(f.t.dot(f.b), 0, 1e-5);
        EXPECT_NEAR(f.t.dot(n), 0, 1e-5);
        EXPECT_NEAR(norm(f.t.cross(f.b) - n), 0, 1e-5) << n;
        const Vec3f v(0.3f, -0.5f, 0.7f);
        EXPECT_NEAR(norm(f.toLocal(f.toWorld(v)) - v), 0, 1e-5);
        EXPECT_NEAR(norm(f.toWorld(Vec3f(0, 0, 1)) - n), 0, 1e-6);
    }
    // With a tangent hint the first tangent follows it.
    const sampling::Frame h(Vec3f(0, 0, 1), Vec3f(1, 1, 0.5f));
    EXPECT_NEAR(norm(h.t - Vec3f(1, 1, 0) / std::sqrt(2.f)), 0, 1e-6);
}

TEST(RenderSampling, DirectionWarpsMatchTheirPdfs) {
    struct W {
        const char* name;
        std::function<Vec3f(const Vec2f&)> warp;
        std::function<double(const Vec3f&)> pdf;
    };
    const float cos_max = (float)std::cos(CV_PI / 8 - 1e-4);  // just inside a bin edge
    const std::vector<W> warps = {
        {"cosine", sampling::squareToCosineHemisphere,
         [](const Vec3f& w) { return (double)sampling::squareToCosineHemispherePdf(w); }},
        {"sphere", sampling::squareToUniformSphere,
         [](const Vec3f&) { return (double)sampling::squareToUniformSpherePdf(); }},
        {"hemisphere", sampling::squareToUniformHemisphere,
         [](const Vec3f& w) { return (double)sampling::squareToUniformHemispherePdf(w); }},
        {"cone", [&](const Vec2f& u) { return sampling::squareToUniformCone(u, cos_max); },
         [&](const Vec3f& w) { return (double)sampling::squareToUniformConePdf(w, cos_max); }},
    };
    for (const W& w : warps) {
        RNG rng(42);
        auto sample = [&](Vec3f& d) {
            d = w.warp(rand2(rng));
            EXPECT_NEAR(norm(d), 1, 1e-5) << w.name;
            return true;
        };
        // Finer θ bins for the narrow cone.
        const int tb = std::string(w.name) == "cone" ? 40 : 10;
        const vbme_test::Chi2Result r = vbme_test::chiSquareDirections(sample, w.pdf, 100000, tb);
        EXPECT_GT(r.p, 0.01) << w.name << ": " << r.detail;
    }
    // Cone support and degenerate cone.
    RNG rng(2);
    for (int i = 0; i < 1000; i++)
        EXPECT_GE(sampling::squareToUniformCone(rand2(rng), cos_max)[2], cos_max - 1e-6f);
    EXPECT_EQ(sampling::squareToUniformCone(Vec2f(0.3f, 0.7f), 1.f), Vec3f(0, 0, 1));
    EXPECT_EQ(sampling::squareToUniformConePdf(Vec3f(0, 0, 1), 1.f), 0.f);
    // Cosine-weighted: E[cos θ] = 2/3.
    double s = 0;
    for (int i = 0; i < 100000; i++)
        s += sampling::squareToCosineHemisphere(rand2(rng))[2];
    EXPECT_NEAR(s / 100000, 2.0 / 3.0, 3e-3);
}

TEST(RenderSampling, DiskAndTriangleAreUniform) {
    RNG rng(3);
    int inner = 0, quadrant = 0;
    const int n = 100000;
    Vec2d bary(0, 0);
    for (int i = 0; i < n; i++) {
        const Vec2f p = sampling::squareToConcentricDisk(rand2(rng));
        const float r2 = p[0] * p[0] + p[1] * p[1];
        ASSERT_LE(r2, 1.f + 1e-5f);
        inner += r2 < 0.25f;
        quadrant += p[0] > 0 && p[1] > 0;
        const Vec2f b = sampling::squareToUniformTriangle(rand2(rng));
        ASSERT_GE(b[0], 0.f);
        ASSERT_GE(b[1], 0.f);
        ASSERT_LE(b[0] + b[1], 1.f + 1e-6f);
        bary += Vec2d(b[0], b[1]);
    }
    // Area fractions: a disk of radius 1/2 holds 1/4, a quadrant 1/4 (σ ≈ 0.0014).
    EXPECT_NEAR(inner / (double)n, 0.25, 0.006);
    EXPECT_NEAR(quadrant / (double)n, 0.25, 0.006);
    // Uniform on a triangle: mean barycentrics 1/3 each (σ ≈ 0.0007).
    EXPECT_NEAR(bary[0] / n, 1.0 / 3, 0.003);
    EXPECT_NEAR(bary[1] / n, 1.0 / 3, 0.003);
    // The triangle's sub-triangle near vertex 0 (b1 + b2 < 1/2) holds 1/4 of the area.
    int corner = 0;
    for (int i = 0; i < n; i++) {
        const Vec2f b = sampling::squareToUniformTriangle(rand2(rng));
        corner += b[0] + b[1] < 0.5f;
    }
    EXPECT_NEAR(corner / (double)n, 0.25, 0.006);
    EXPECT_NEAR(sampling::squareToConcentricDiskPdf(Vec2f(0.1f, 0.2f)), 1 / CV_PI, 1e-6);
}

// The concentric map evaluates sin/cos by sinCosQuarter's polynomials: against the map
// written with double-precision std::cos/std::sin (Shirley & Chiu), over a grid that covers
// both wedges and the diagonals where they meet.
TEST(RenderSampling, ConcentricDiskMatchesTheTrigonometricMap) {
    double worst_trig = 0, worst_map = 0;
    for (int i = -2000; i <= 2000; ++i) {
        const float x = float(i) / 2000.f * (sampling::kPi / 4.f);
        float s, c;
        sampling::sinCosQuarter(x, s, c);
        worst_trig = std::max(worst_trig, std::abs(s - std::sin(double(x))));
        worst_trig = std::max(worst_trig, std::abs(c - std::cos(double(x))));
    }
    EXPECT_LT(worst_trig, 3e-7);
    const int n = 256;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const Vec2f u(float(i) / n, float(j) / n);
            const Vec2f p = sampling::squareToConcentricDisk(u);
            const double ox = 2.0 * u[0] - 1.0, oy = 2.0 * u[1] - 1.0;
            double r = 0, th = 0;
            if (ox != 0 || oy != 0) {
                if (std::abs(ox) > std::abs(oy)) {
                    r = ox;
                    th = CV_PI / 4 * (oy / ox);
                } else {
                    r = oy;
                    th = CV_PI / 2 - CV_PI / 4 * (ox / oy);
                }
            }
            worst_map = std::max(worst_map, std::abs(p[0] - r * std::cos(th)));
            worst_map = std::max(worst_map, std::abs(p[1] - r * std::sin(th)));
            ASSERT_LE(p[0] * p[0] + p[1] * p[1], 1.f + 1e-6f);
        }
    EXPECT_LT(worst_map, 1e-6);
    std::printf(
        "sinCosQuarter: %.2g from sin/cos; concentric map: %.2g from the trigonometric one\n",
        worst_trig, worst_map);
}

// The cosine hemisphere's z comes from the disk's radius (√(1 − r²), r = max(|2u − 1|)), not from
// the disk point (√(1 − x² − y²), which the sin/cos polynomials' 2·10⁻⁷ put slightly off the
// circle): against the exact map in double precision on a grid of the square, no worse than the
// point's z, and of unit length within float rounding.
TEST(RenderSampling, CosineHemisphereZFromTheRadius) {
    double worst_z = 0, worst_point_z = 0, worst_len = 0;
    const int n = 256;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const Vec2f u(float(i) / n, float(j) / n);
            const Vec3f w = sampling::squareToCosineHemisphere(u);
            const Vec2f p = sampling::squareToConcentricDisk(u);
            ASSERT_EQ(w[0], p[0]);
            ASSERT_EQ(w[1], p[1]);
            const double r = std::max(std::abs(2.0 * u[0] - 1.0), std::abs(2.0 * u[1] - 1.0));
            const double z = std::sqrt(1.0 - r * r);
            const float point_z = std::sqrt(std::max(0.f, 1.f - p[0] * p[0] - p[1] * p[1]));
            worst_z = std::max(worst_z, std::abs(w[2] - z));
            worst_point_z = std::max(worst_point_z, std::abs(point_z - z));
            const double r2 = double(p[0]) * p[0] + double(p[1]) * p[1];
            worst_len = std::max(worst_len, std::abs(std::sqrt(r2 + double(w[2]) * w[2]) - 1.0));
        }
    EXPECT_LT(worst_len, 1e-6);
    EXPECT_LE(worst_z, worst_point_z);
    EXPECT_LT(worst_z, 1e-6);  // the grid's r are dyadic: r² has no rounding error
    std::printf(
        "cosine hemisphere: z %.2g from the exact map (%.2g from the disk point), |w| − 1 "
        "at most %.2g\n",
        worst_z, worst_point_z, worst_len);
}

// The SSE form of the concentric map (and of the cosine hemisphere built on it) must give the
// scalar form's bits: the path tracer's images depend on them (RenderPathBatch's bitwise
// oracles compare renders, this compares the map itself, including the wedges' borders
// |ox| = |oy|, the axes where one quotient divides by zero, and the centre).
TEST(RenderSampling, ConcentricDiskSseSameBitsAsScalar) {
#if defined(__SSE2__)
    auto same = [](float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; };
    int checked = 0, differ = 0;
    auto check = [&](const Vec2f& u) {
        float r_ref, r_sse;
        const Vec2f ref = sampling::detail::concentricDiskScalar(u, r_ref);
        const Vec2f sse = sampling::detail::concentricDiskSse(u, r_sse);
        const Vec3f w = sampling::squareToCosineHemisphere(u);
        const float z_ref = std::sqrt(std::max(0.f, 1.f - r_ref * r_ref));
        ++checked;
        if (!same(ref[0], sse[0]) || !same(ref[1], sse[1]) || !same(r_ref, r_sse) ||
            !same(w[0], ref[0]) || !same(w[1], ref[1]) || !same(w[2], z_ref))
            ++differ;
    };
    const int n = 512;  // a dyadic grid: borders, axes and the centre exactly
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i)
            check(Vec2f(std::min(float(i) / n, sampling::kOneMinusEpsilon),
                        std::min(float(j) / n, sampling::kOneMinusEpsilon)));
    RNG rng(7);
    for (int k = 0; k < 200000; ++k) {  // the sampler's 24-bit numbers
        const uint32_t a = rng.next(), b = rng.next();
        check(Vec2f(float(a >> 8) * 0x1p-24f, float(b >> 8) * 0x1p-24f));
    }
    EXPECT_EQ(differ, 0) << "of " << checked;
#else
    GTEST_SKIP() << "no SSE2: the scalar form is the only one";
#endif
}

TEST(RenderSampling, PowerHeuristic) {
    EXPECT_NEAR(sampling::powerHeuristic(1, 1.f, 1, 1.f), 0.5f, 1e-7);
    EXPECT_NEAR(sampling::powerHeuristic(1, 3.f, 1, 1.f), 0.9f, 1e-6);
    EXPECT_NEAR(sampling::powerHeuristic(1, 2.f, 1, 5.f) + sampling::powerHeuristic(1, 5.f, 1, 2.f),
                1.f, 1e-6);
    EXPECT_EQ(sampling::powerHeuristic(1, 0.f, 1, 0.f), 0.f);
    EXPECT_EQ(sampling::powerHeuristic(1, 1e30f, 1, 1.f), 1.f);
}

TEST(RenderSampling, Distribution1DSamplesItsValues) {
    const std::vector<float> f = {1, 0, 3, 0.5f, 0, 2, 4, 0.25f};
    const sampling::Distribution1D d(f);
    double sum = 0;
    for (float v : f)
        sum += v;
    EXPECT_NEAR(d.integral(), sum / f.size(), 1e-6);
    std::vector<int> counts(f.size(), 0);
    RNG rng(4);
    const int n = 200000;
    for (int i = 0; i < n; i++) {
        float pmf, ur;
        const int c = d.sampleDiscrete(rng.uniform(0.f, 1.f), pmf, ur);
        ASSERT_GT(f[c], 0.f) << "sampled a zero cell";
        ASSERT_NEAR(pmf, f[c] / sum, 1e-6);
        ASSERT_GE(ur, 0.f);
        ASSERT_LT(ur, 1.f);
        counts[c]++;
        float pdf;
        int cell;
        const float x = d.sampleContinuous(rng.uniform(0.f, 1.f), pdf, cell);
        ASSERT_GE(x, 0.f);
        ASSERT_LT(x, 1.f);
        ASSERT_EQ(cell, std::min((int)(x * f.size()), (int)f.size() - 1));
        ASSERT_NEAR(pdf, d.pdfContinuous(x), 1e-5);
        ASSERT_NEAR(pdf, f[cell] / d.integral(), 1e-4);
    }
    double chi2 = 0;
    int dof = -1;
    for (size_t i = 0; i < f.size(); i++) {
        if (f[i] == 0) {
            EXPECT_EQ(counts[i], 0);
            continue;
        }
        const double e = n * f[i] / sum;
        chi2 += (counts[i] - e) * (counts[i] - e) / e;
        dof++;
    }
    EXPECT_GT(vbme_test::chi2PValue(chi2, dof), 0.01) << chi2;
    // Extremes of u.
    float pmf;
    EXPECT_EQ(d.sampleDiscrete(0.f, pmf), 0);
    EXPECT_EQ(d.sampleDiscrete(sampling::kOneMinusEpsilon, pmf), 7);
    // All zero: uniform.
    const sampling::Distribution1D z(std::vector<float>(4, 0.f));
    EXPECT_NEAR(z.pdfCell(2), 0.25f, 1e-7);
    EXPECT_EQ(z.sampleDiscrete(0.6f, pmf), 2);
    EXPECT_THROW(sampling::Distribution1D(std::vector<float>{1.f, -1.f}), cv::Exception);
}

TEST(RenderSampling, Distribution2DPdfIntegratesToOneAndMatchesSamples) {
    Mat f(6, 10, CV_32FC1);
    RNG rng(5);
    rng.fill(f, RNG::UNIFORM, 0, 1);
    f.row(2).setTo(0);  // an empty row
    f.at<float>(4, 7) = 20;
    const sampling::Distribution2D d(f);
    EXPECT_NEAR(d.integral(), mean(f)[0], 1e-5);
    // ∫ pdf over [0,1)² = 1.
    double s = 0;
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 10; x++)
            s += d.pdf(Vec2f((x + 0.5f) / 10, (y + 0.5f) / 6)) / 60.0;
    EXPECT_NEAR(s, 1.0, 1e-5);
    Mat counts = Mat::zeros(6, 10, CV_64F);
    const int n = 200000;
    for (int i = 0; i < n; i++) {
        float pdf;
        const Vec2f p = d.sampleContinuous(rand2(rng), pdf);
        ASSERT_NEAR(pdf, d.pdf(p), 1e-3 * pdf);
        ASSERT_NEAR(pdf, f.at<float>((int)(p[1] * 6), (int)(p[0] * 10)) / d.integral(), 1e-3 * pdf);
        counts.at<double>((int)(p[1] * 6), (int)(p[0] * 10)) += 1;
    }
    EXPECT_EQ(sum(counts.row(2))[0], 0.0);
    double chi2 = 0;
    int dof = -1;
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 10; x++) {
            const double e = n * f.at<float>(y, x) / sum(f)[0];
            if (e <= 0) continue;
            chi2 += std::pow(counts.at<double>(y, x) - e, 2) / e;
            dof++;
        }
    EXPECT_GT(vbme_test::chi2PValue(chi2, dof), 0.01) << chi2;
}
