// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Owen-scrambled Sobol sampler after Burley 2020, "Practical Hash-based Owen Scrambling".
#include "opencv2/vbme/render/sampler.hpp"

#include "opencv2/vbme/core/utility.hpp"
#include "sobol_impl.hpp"

namespace cv {
namespace vbme {

namespace sobol_detail {

// Generator matrix of Sobol dimension 1 applied a byte at a time through look-up tables (4 XORs
// per value instead of up to 32), and the same matrix conjugated by the bit reversal.
SobolTables::SobolTables() {
    uint32_t v[32];
    v[0] = 1u << 31;  // Pascal matrix mod 2
    for (int i = 1; i < 32; ++i)
        v[i] = v[i - 1] ^ (v[i - 1] >> 1);
    for (int b = 0; b < 4; ++b)
        for (int x = 0; x < 256; ++x) {
            uint32_t r = 0, q = 0;
            for (int bit = 0; bit < 8; ++bit)
                if (x & (1 << bit)) {
                    const int j = 8 * b + bit;
                    r ^= v[j];
                    // bit j of z is bit 31 − j of reverseBits(z)
                    q ^= reverseBits(v[31 - j]);
                }
            sobol1[b][x] = r;
            reversed[b][x] = q;
        }
}
const SobolTables g_tables;

}  // namespace sobol_detail

using namespace sobol_detail;

uint32_t SobolSampler::sobol(uint32_t index, int c) {
    CV_DbgAssert(c == 0 || c == 1);
    if (c == 0) return reverseBits(index);
    return lookup(g_tables.sobol1, index);
}

uint64 SobolSampler::pixelKey(const Point& px) const {
    const uint64 pix = (uint64(uint32_t(px.x)) << 32) | uint32_t(px.y);
    return hashCombine(seed_, pix);
}

Vec2f SobolSampler::get2D(uint64 key, uint32_t index, uint32_t dim) const {
    CV_DbgAssert((dim & 1u) == 0);
    return sobol_detail::get2D(pairSeeds(key, dim >> 1), reverseBits(index));
}

float SobolSampler::get1D(uint64 key, uint32_t index, uint32_t dim) const {
    return sobol_detail::get1D(pairSeeds(key, dim >> 1), reverseBits(index), dim & 1u);
}

}  // namespace vbme
}  // namespace cv
