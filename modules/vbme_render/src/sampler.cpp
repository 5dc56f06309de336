// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Owen-scrambled Sobol sampler after Burley 2020, "Practical Hash-based Owen Scrambling".
#include "opencv2/vbme/render/sampler.hpp"

#include "opencv2/vbme/core/utility.hpp"

namespace cv {
namespace vbme {

namespace {

inline uint32_t reverseBits(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    return __builtin_bswap32(x);  // the byte reversal in one instruction (GCC, Clang)
}

// Laine–Karras style hash permutation, improved constants (Burley 2020 / Vegdahl): acts on
// bit-reversed values, so each output bit depends only on the bits below it = Owen scrambling.
inline uint32_t laineKarras(uint32_t x, uint32_t seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}
inline uint32_t nestedUniformScramble(uint32_t x, uint32_t seed) {
    return reverseBits(laineKarras(reverseBits(x), seed));
}

// Generator matrices of the first two Sobol dimensions, applied a byte at a time through
// look-up tables (4 XORs per value instead of up to 32).
struct SobolMatrices {
    uint32_t v[2][32];
    uint32_t table[2][4][256];
    SobolMatrices() {
        for (int i = 0; i < 32; ++i)
            v[0][i] = 1u << (31 - i);  // van der Corput
        v[1][0] = 1u << 31;            // Pascal matrix mod 2
        for (int i = 1; i < 32; ++i)
            v[1][i] = v[1][i - 1] ^ (v[1][i - 1] >> 1);
        for (int c = 0; c < 2; ++c)
            for (int b = 0; b < 4; ++b)
                for (int x = 0; x < 256; ++x) {
                    uint32_t r = 0;
                    for (int bit = 0; bit < 8; ++bit)
                        if (x & (1 << bit)) r ^= v[c][8 * b + bit];
                    table[c][b][x] = r;
                }
    }
};
const SobolMatrices g_matrices;
inline const SobolMatrices& matrices() {
    return g_matrices;
}

inline float toUnit(uint32_t x) {
    return float(x >> 8) * 0x1p-24f;
}

}  // namespace

uint32_t SobolSampler::sobol(uint32_t index, int c) {
    CV_DbgAssert(c == 0 || c == 1);
    if (c == 0) return reverseBits(index);
    const auto& t = matrices().table[1];
    return t[0][index & 0xffu] ^ t[1][(index >> 8) & 0xffu] ^ t[2][(index >> 16) & 0xffu] ^
           t[3][index >> 24];
}

uint64 SobolSampler::pixelKey(const Point& px) const {
    const uint64 pix = (uint64(uint32_t(px.x)) << 32) | uint32_t(px.y);
    return hashCombine(seed_, pix);
}

namespace {
// Scramble seeds of one dimension pair: the index shuffle and the two coordinates.
struct PairSeeds {
    uint32_t shuffle, x, y;
};
inline PairSeeds pairSeeds(uint64 key, uint32_t pair) {
    const uint64 h = mix64(key ^ (uint64(pair + 1) * 0x9e3779b97f4a7c15ULL));
    const uint64 g = mix64(h);
    return {uint32_t(h), uint32_t(h >> 32), uint32_t(g)};
}
}  // namespace

Vec2f SobolSampler::get2D(uint64 key, uint32_t index, uint32_t dim) const {
    CV_DbgAssert((dim & 1u) == 0);
    const PairSeeds s = pairSeeds(key, dim >> 1);
    const uint32_t i = nestedUniformScramble(index, s.shuffle);
    // sobol(i, 0) = reverseBits(i), so its nested scramble is reverseBits(laineKarras(i)).
    return Vec2f(toUnit(reverseBits(laineKarras(i, s.x))),
                 toUnit(nestedUniformScramble(sobol(i, 1), s.y)));
}

float SobolSampler::get1D(uint64 key, uint32_t index, uint32_t dim) const {
    const PairSeeds s = pairSeeds(key, dim >> 1);
    const uint32_t i = nestedUniformScramble(index, s.shuffle);
    return (dim & 1u) ? toUnit(nestedUniformScramble(sobol(i, 1), s.y))
                      : toUnit(reverseBits(laineKarras(i, s.x)));
}

}  // namespace vbme
}  // namespace cv
