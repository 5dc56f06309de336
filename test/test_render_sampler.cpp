// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include <opencv2/vbme/render/sampler.hpp>

#include "../modules/vbme_render/src/sobol_impl.hpp"

using namespace cv;
using namespace cv::vbme;

// Every elementary interval of area 1/256 of [0,1)² holds exactly one of 256 points:
// the Owen-scrambled Sobol pair is a (0,8,2)-net for every pixel, pair and seed.
TEST(RenderSampler, PairsAreZeroMTwoNets) {
    for (uint64 seed : {0ull, 7ull}) {
        const SobolSampler s(seed);
        for (Point px : {Point(0, 0), Point(13, 7)}) {
            for (uint32_t dim : {0u, 2u, 10u, 42u}) {
                std::vector<Vec2f> pts;
                for (uint32_t i = 0; i < 256; ++i)
                    pts.push_back(s.get2D(px, i, dim));
                for (int a = 0; a <= 8; ++a) {
                    const int nx = 1 << a, ny = 1 << (8 - a);
                    std::vector<int> count(256, 0);
                    for (const auto& p : pts) {
                        ASSERT_GE(p[0], 0.f);
                        ASSERT_LT(p[0], 1.f);
                        ASSERT_GE(p[1], 0.f);
                        ASSERT_LT(p[1], 1.f);
                        ++count[int(p[0] * nx) * ny + int(p[1] * ny)];
                    }
                    for (int c : count)
                        ASSERT_EQ(c, 1) << "interval " << nx << "x" << ny << " dim " << dim;
                }
            }
        }
    }
}

TEST(RenderSampler, PureFunctionAndOneDMatchesTwoD) {
    const SobolSampler a(3), b(3);
    for (uint32_t i = 0; i < 64; ++i)
        for (uint32_t d = 0; d < 20; d += 2) {
            const Vec2f p = a.get2D(Point(5, 9), i, d);
            EXPECT_EQ(p, b.get2D(Point(5, 9), i, d));
            EXPECT_EQ(p[0], a.get1D(Point(5, 9), i, d));
            EXPECT_EQ(p[1], a.get1D(Point(5, 9), i, d + 1));
        }
}

// Different pixels, pairs and seeds get decorrelated sequences: no two coincide and the
// correlation between them is small.
TEST(RenderSampler, Decorrelation) {
    const int n = 1024;
    auto seq = [&](uint64 seed, Point px, uint32_t dim) {
        std::vector<float> v;
        const SobolSampler s(seed);
        for (int i = 0; i < n; ++i)
            v.push_back(s.get1D(px, i, dim));
        return v;
    };
    auto corr = [&](const std::vector<float>& x, const std::vector<float>& y) {
        double mx = 0, my = 0, sxy = 0, sxx = 0, syy = 0;
        for (int i = 0; i < n; ++i)
            mx += x[i] / n, my += y[i] / n;
        for (int i = 0; i < n; ++i) {
            sxy += (x[i] - mx) * (y[i] - my);
            sxx += (x[i] - mx) * (x[i] - mx);
            syy += (y[i] - my) * (y[i] - my);
        }
        return sxy / std::sqrt(sxx * syy);
    };
    const auto base = seq(0, Point(0, 0), 2);
    const std::vector<std::vector<float>> others = {seq(1, Point(0, 0), 2), seq(0, Point(1, 0), 2),
                                                    seq(0, Point(0, 1), 2), seq(0, Point(0, 0), 4),
                                                    seq(0, Point(0, 0), 3)};
    for (const auto& o : others) {
        EXPECT_NE(o, base);
        EXPECT_LT(std::abs(corr(base, o)), 0.1);
    }
    double mean = 0;
    for (float v : base)
        mean += v / n;
    EXPECT_NEAR(mean, 0.5, 1e-3);  // stratified: much closer than Monte Carlo's ~0.009
}

// Quasi-Monte Carlo convergence: a smooth 2-D integral at 256 samples is far more accurate
// than independent random sampling would be (σ/√n ≈ 0.014 for this integrand).
TEST(RenderSampler, IntegratesSmoothFunctionsAccurately) {
    const SobolSampler s(11);
    double worst = 0;
    for (int p = 0; p < 16; ++p) {
        double sum = 0;
        for (uint32_t i = 0; i < 256; ++i) {
            const Vec2f u = s.get2D(Point(p, 3), i, 6);
            sum += std::sin(CV_PI * u[0]) * u[1] * u[1];
        }
        const double exact = (2.0 / CV_PI) / 3.0;
        worst = std::max(worst, std::abs(sum / 256 - exact));
    }
    EXPECT_LT(worst, 2e-3);
}

TEST(RenderSampler, PathDimensionsAreFixedByVertex) {
    EXPECT_EQ(PathDims::dim(0, PathDims::kBsdfDir), 2u);
    EXPECT_EQ(PathDims::dim(3, PathDims::kLightPos), 2u + 3 * PathDims::kPerVertex + 2);
    // 2-D slots start on even dimensions (they are stratified pairs).
    for (int d = 0; d < 8; ++d) {
        EXPECT_EQ(PathDims::dim(d, PathDims::kBsdfDir) % 2, 0u);
        EXPECT_EQ(PathDims::dim(d, PathDims::kLightPos) % 2, 0u);
    }
}

// The path tracer's per-pixel sampler (seeds hashed once per pixel, folded reversals) gives
// the numbers of the definition: index shuffled by a nested uniform scramble, then x =
// scramble(sobol0(i)), y = scramble(sobol1(i)), written out here from the primitives.
TEST(RenderSampler, PixelSamplerMatchesTheDefinition) {
    using namespace cv::vbme::sobol_detail;
    auto unit = [](uint32_t v) { return float(v >> 8) * 0x1p-24f; };
    int checked = 0;
    for (uint64 seed : {0ull, 99ull}) {
        const SobolSampler s(seed);
        for (Point px : {Point(0, 0), Point(5, 3), Point(639, 479)}) {
            const uint64 key = s.pixelKey(px);
            PixelSampler ps(key);
            for (uint32_t index : {0u, 1u, 2u, 7u, 31u, 1000u, 123456u}) {
                ps.setIndex(index);
                // beyond PixelSampler::kPairs too (the uncached path)
                for (uint32_t dim = 0; dim < 2 * PixelSampler::kPairs + 6; dim += 2) {
                    const PairSeeds q = pairSeeds(key, dim >> 1);
                    const uint32_t i = nestedUniformScramble(index, q.shuffle);
                    const Vec2f want(unit(nestedUniformScramble(SobolSampler::sobol(i, 0), q.x)),
                                     unit(nestedUniformScramble(SobolSampler::sobol(i, 1), q.y)));
                    ASSERT_EQ(ps.get2D(dim), want) << dim;
                    ASSERT_EQ(s.get2D(px, index, dim), want) << dim;
                    ASSERT_EQ(ps.get1D(dim), want[0]);
                    ASSERT_EQ(ps.get1D(dim + 1), want[1]);
                    ++checked;
                }
            }
        }
    }
    EXPECT_GT(checked, 2000);
}
