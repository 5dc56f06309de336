// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The path batch's vector code (batch_simd, AVX2 chosen at run time): the same bits as the
// scalar sampler and cosine-hemisphere map it stands for.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>

#include "../modules/vbme_render/src/batch_simd.hpp"
#include "../modules/vbme_render/src/sampling.hpp"
#include "../modules/vbme_render/src/sobol_impl.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

bool sameBits(float a, float b) {
    return std::memcmp(&a, &b, sizeof(float)) == 0;
}

}  // namespace

// Sobol draws of 8-lane groups (n = 61, padded to 64) for many pixel keys, dimension pairs and
// sample indices against sobol_detail::get2D, lane by lane, bit for bit.
TEST(RenderBatchSimd, DrawsSameBitsAsScalar) {
    if (!batch_simd::available()) GTEST_SKIP() << "no AVX2 on this processor: scalar code only";
    RNG rng(7);
    const int n = 61, n_pad = 64;
    std::vector<uint32_t> rindex(n_pad);
    std::vector<float> ux(n_pad), uy(n_pad);
    int compared = 0, differing = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const uint64 key = (uint64(rng.next()) << 32) | rng.next();
        const uint32_t pair = trial % 40;
        const sobol_detail::PairSeeds s = sobol_detail::pairSeeds(key, pair);
        for (int k = 0; k < n_pad; ++k)  // consecutive samples, then arbitrary ones
            rindex[k] =
                sobol_detail::reverseBits(trial < 100 ? uint32_t(trial * n + k) : rng.next());
        batch_simd::draw2D(s, rindex.data(), n_pad, ux.data(), uy.data());
        for (int k = 0; k < n; ++k) {
            const Vec2f e = sobol_detail::get2D(s, rindex[k]);
            differing += !sameBits(ux[k], e[0]) + !sameBits(uy[k], e[1]);
            compared += 2;
        }
    }
    EXPECT_EQ(compared, 200 * 61 * 2);
    EXPECT_EQ(differing, 0);
}

// The cosine-weighted hemisphere of 8-lane groups against sampling::squareToCosineHemisphere,
// bit for bit: random points, the square's centre (the disk's centre: 0/0 in the wedge's
// quotient), its diagonals (the wedge's tie), its edges and corners, numbers next to 0 and 1.
TEST(RenderBatchSimd, CosineHemisphereSameBitsAsScalar) {
    if (!batch_simd::available()) GTEST_SKIP() << "no AVX2 on this processor: scalar code only";
    std::vector<float> ux, uy;
    const float special[] = {0.f,   0.5f,  1.f - 0x1p-24f,  0x1p-24f,
                             0.25f, 0.75f, 0.5f - 0x1p-24f, 0.5f + 0x1p-24f,
                             0.1f,  0.9f};
    for (float a : special)
        for (float b : special) {
            ux.push_back(a);
            uy.push_back(b);
        }
    RNG rng(11);
    while (ux.size() < 20000) {  // the scalar sampler's numbers: multiples of 2^-24
        ux.push_back(float(rng.next() >> 8) * 0x1p-24f);
        uy.push_back(float(rng.next() >> 8) * 0x1p-24f);
    }
    const int n = (int)ux.size();
    const int n_pad = (n + batch_simd::kWidth - 1) / batch_simd::kWidth * batch_simd::kWidth;
    ux.resize(n_pad, 0.5f);
    uy.resize(n_pad, 0.5f);
    std::vector<float> x(n_pad), y(n_pad), z(n_pad);
    batch_simd::cosineHemisphere(ux.data(), uy.data(), n_pad, x.data(), y.data(), z.data());
    int differing = 0, centre = 0;
    for (int k = 0; k < n; ++k) {
        const Vec3f e = sampling::squareToCosineHemisphere(Vec2f(ux[k], uy[k]));
        differing += !sameBits(x[k], e[0]) + !sameBits(y[k], e[1]) + !sameBits(z[k], e[2]);
        centre += ux[k] == 0.5f && uy[k] == 0.5f;
    }
    EXPECT_GE(centre, 1);
    EXPECT_EQ(differing, 0);
}
