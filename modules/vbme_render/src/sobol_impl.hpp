// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Inline core of SobolSampler (private to vbme_render), and PixelSampler: the same numbers
// with one pixel's scramble seeds hashed once instead of on every draw.
#ifndef VBME_RENDER_SOBOL_IMPL_HPP
#define VBME_RENDER_SOBOL_IMPL_HPP

#include <cstdint>

#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/render/sampler.hpp"

namespace cv {
namespace vbme {
namespace sobol_detail {

inline uint32_t reverseBits(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    return __builtin_bswap32(x);  // the byte reversal in one instruction (GCC, Clang)
}
/** Both halves of @p x bit-reversed in one pass: the result's high half is reverseBits of the
low half of @p x and its low half reverseBits of the high half. */
inline uint64_t reverseBits64(uint64_t x) {
    x = ((x >> 1) & 0x5555555555555555ull) | ((x & 0x5555555555555555ull) << 1);
    x = ((x >> 2) & 0x3333333333333333ull) | ((x & 0x3333333333333333ull) << 2);
    x = ((x >> 4) & 0x0f0f0f0f0f0f0f0full) | ((x & 0x0f0f0f0f0f0f0f0full) << 4);
    return __builtin_bswap64(x);
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

/** Byte tables of Sobol dimension 1 (the Pascal matrix): `sobol1` maps index i to its value;
`reversed` maps z to reverseBits(sobol1(reverseBits(z))) (the matrix conjugated by the bit
reversal, a linear map too). */
struct SobolTables {
    uint32_t sobol1[4][256];
    uint32_t reversed[4][256];
    SobolTables();
};
extern const SobolTables g_tables;

inline uint32_t lookup(const uint32_t (&t)[4][256], uint32_t x) {
    return t[0][x & 0xffu] ^ t[1][(x >> 8) & 0xffu] ^ t[2][(x >> 16) & 0xffu] ^ t[3][x >> 24];
}

inline float toUnit(uint32_t x) {
    return float(x >> 8) * 0x1p-24f;
}

/** Scramble seeds of one dimension pair: the index shuffle and the two coordinates. */
struct PairSeeds {
    uint32_t shuffle, x, y;
};
inline PairSeeds pairSeeds(uint64 key, uint32_t pair) {
    const uint64 h = mix64(key ^ (uint64(pair + 1) * 0x9e3779b97f4a7c15ULL));
    const uint64 g = mix64(h);
    return {uint32_t(h), uint32_t(h >> 32), uint32_t(g)};
}

/** Both coordinates of a pair for the bit-reversed sample index @p rindex. With
z = laineKarras(rindex, shuffle) the shuffled index is i = reverseBits(z), so
x = reverseBits(laineKarras(i, sx)) and y = nestedUniformScramble(sobol1(i), sy)
= reverseBits(laineKarras(reversed(z), sy)); the two final reversals are done at once. */
inline void pairBits(const PairSeeds& s, uint32_t rindex, uint32_t& x, uint32_t& y) {
    const uint32_t z = laineKarras(rindex, s.shuffle);
    const uint32_t ax = laineKarras(reverseBits(z), s.x);
    const uint32_t ay = laineKarras(lookup(g_tables.reversed, z), s.y);
    const uint64_t r = reverseBits64((uint64_t(ay) << 32) | ax);
    x = uint32_t(r >> 32);
    y = uint32_t(r);
}
inline Vec2f get2D(const PairSeeds& s, uint32_t rindex) {
    uint32_t x, y;
    pairBits(s, rindex, x, y);
    return Vec2f(toUnit(x), toUnit(y));
}
inline float get1D(const PairSeeds& s, uint32_t rindex, bool second) {
    const uint32_t z = laineKarras(rindex, s.shuffle);
    return second ? toUnit(reverseBits(laineKarras(lookup(g_tables.reversed, z), s.y)))
                  : toUnit(reverseBits(laineKarras(reverseBits(z), s.x)));
}

}  // namespace sobol_detail

/** The numbers SobolSampler gives one pixel (same values, bit for bit), with the scramble
seeds of the first kPairs dimension pairs hashed on first use and kept, and the sample index
reversed once per sample. One per pixel and thread; not thread-safe. */
class PixelSampler {
public:
    static constexpr uint32_t kPairs = 48;
    explicit PixelSampler(uint64 pixel_key) : key_(pixel_key) {}
    uint64 key() const { return key_; }
    /** Selects sample @p index for the draws that follow. */
    void setIndex(uint32_t index) {
        index_ = index;
        rindex_ = sobol_detail::reverseBits(index);
    }
    uint32_t index() const { return index_; }
    Vec2f get2D(uint32_t dim) { return sobol_detail::get2D(seeds(dim >> 1), rindex_); }
    float get1D(uint32_t dim) { return sobol_detail::get1D(seeds(dim >> 1), rindex_, dim & 1u); }
    /** The bit-reversed sample index the draws below take (setIndex keeps it for the others). */
    static uint32_t reversedIndex(uint32_t index) { return sobol_detail::reverseBits(index); }
    /** Draws of the sample whose bit-reversed index is @p rindex (reversedIndex()), whatever
    sample setIndex selected: several samples of the pixel at once (path batches). */
    Vec2f get2D(uint32_t dim, uint32_t rindex) {
        return sobol_detail::get2D(seeds(dim >> 1), rindex);
    }
    /** @overload */
    float get1D(uint32_t dim, uint32_t rindex) {
        return sobol_detail::get1D(seeds(dim >> 1), rindex, dim & 1u);
    }

private:
    const sobol_detail::PairSeeds& seeds(uint32_t pair) {
        if (pair >= kPairs) {
            spill_ = sobol_detail::pairSeeds(key_, pair);
            return spill_;
        }
        const uint64_t bit = uint64_t(1) << pair;
        if (!(have_ & bit)) {
            cache_[pair] = sobol_detail::pairSeeds(key_, pair);
            have_ |= bit;
        }
        return cache_[pair];
    }
    uint64 key_;
    uint32_t index_ = 0, rindex_ = 0;
    uint64_t have_ = 0;
    sobol_detail::PairSeeds spill_;
    sobol_detail::PairSeeds cache_[kPairs];
};

}  // namespace vbme
}  // namespace cv

#endif
