// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Vector code for a path batch: see batch_simd.hpp. Only the functions marked
// VBME_AVX2 are compiled for AVX2 (function attributes, not -mavx2 on the whole file, so that
// no inline function of a header is emitted here with AVX2 instructions and picked by the
// linker for callers on processors without them). No FMA is enabled: every product is rounded
// before its sum, as in the scalar code.
#include "batch_simd.hpp"

#include "sampling.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define VBME_BATCH_SIMD 1
#define VBME_AVX2 __attribute__((target("avx2")))
#endif

namespace cv {
namespace vbme {
namespace batch_simd {

#if VBME_BATCH_SIMD

bool available() {
    static const bool avx2 = __builtin_cpu_supports("avx2");
    return avx2;
}

namespace {

VBME_AVX2 inline __m256i mul(__m256i a, uint32_t c) {
    return _mm256_mullo_epi32(a, _mm256_set1_epi32((int)c));
}

// sobol_detail::laineKarras, lane by lane.
VBME_AVX2 inline __m256i laineKarras(__m256i x, uint32_t seed) {
    x = _mm256_xor_si256(x, mul(x, 0x3d20adeau));
    x = _mm256_add_epi32(x, _mm256_set1_epi32((int)seed));
    x = mul(x, (seed >> 16) | 1u);
    x = _mm256_xor_si256(x, mul(x, 0x05526c56u));
    x = _mm256_xor_si256(x, mul(x, 0x53a22864u));
    return x;
}

// sobol_detail::reverseBits, lane by lane: the bits of each byte through two nibble tables,
// then the bytes of each lane swapped.
VBME_AVX2 inline __m256i reverseBits(__m256i x) {
    const __m256i rev_nibble = _mm256_setr_epi8(
        0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd, 0x3, 0xb, 0x7, 0xf, 0x0, 0x8,
        0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd, 0x3, 0xb, 0x7, 0xf);
    const __m256i low = _mm256_set1_epi8(0x0f);
    const __m256i lo = _mm256_shuffle_epi8(rev_nibble, _mm256_and_si256(x, low));
    const __m256i hi =
        _mm256_shuffle_epi8(rev_nibble, _mm256_and_si256(_mm256_srli_epi16(x, 4), low));
    const __m256i bytes = _mm256_or_si256(_mm256_slli_epi16(lo, 4), hi);  // each byte reversed
    const __m256i swap = _mm256_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12, 3,
                                          2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12);
    return _mm256_shuffle_epi8(bytes, swap);
}

// sobol_detail::lookup(g_tables.reversed, z): four gathers from the byte tables.
VBME_AVX2 inline __m256i lookupReversed(__m256i z) {
    const int* t = reinterpret_cast<const int*>(&sobol_detail::g_tables.reversed[0][0]);
    const __m256i byte = _mm256_set1_epi32(0xff);
    __m256i r = _mm256_i32gather_epi32(t, _mm256_and_si256(z, byte), 4);
    r = _mm256_xor_si256(
        r, _mm256_i32gather_epi32(t + 256, _mm256_and_si256(_mm256_srli_epi32(z, 8), byte), 4));
    r = _mm256_xor_si256(
        r, _mm256_i32gather_epi32(t + 512, _mm256_and_si256(_mm256_srli_epi32(z, 16), byte), 4));
    r = _mm256_xor_si256(r, _mm256_i32gather_epi32(t + 768, _mm256_srli_epi32(z, 24), 4));
    return r;
}

// sobol_detail::toUnit: the top 24 bits as an integer (exact in a float), times 2⁻²⁴ (exact).
VBME_AVX2 inline __m256 toUnit(__m256i x) {
    return _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(x, 8)), _mm256_set1_ps(0x1p-24f));
}

VBME_AVX2 void draw2DAvx2(const sobol_detail::PairSeeds& s, const uint32_t* rindex, int n,
                          float* ux, float* uy) {
    for (int k = 0; k < n; k += kWidth) {
        const __m256i ri = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rindex + k));
        const __m256i z = laineKarras(ri, s.shuffle);
        const __m256i ax = laineKarras(reverseBits(z), s.x);
        const __m256i ay = laineKarras(lookupReversed(z), s.y);
        _mm256_storeu_ps(ux + k, toUnit(reverseBits(ax)));
        _mm256_storeu_ps(uy + k, toUnit(reverseBits(ay)));
    }
}

VBME_AVX2 inline __m256 pick(__m256 m, __m256 a, __m256 b) {  // m ? a : b
    return _mm256_blendv_ps(b, a, m);
}

// sampling::squareToCosineHemisphere (detail::concentricDisk, sinCosQuarter), lane by lane.
VBME_AVX2 void cosineHemisphereAvx2(const float* ux, const float* uy, int n, float* x, float* y,
                                    float* z) {
    const __m256 one = _mm256_set1_ps(1.f), two = _mm256_set1_ps(2.f), zero = _mm256_setzero_ps();
    const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    for (int k = 0; k < n; k += kWidth) {
        const __m256 ox = _mm256_sub_ps(_mm256_mul_ps(two, _mm256_loadu_ps(ux + k)), one);
        const __m256 oy = _mm256_sub_ps(_mm256_mul_ps(two, _mm256_loadu_ps(uy + k)), one);
        const __m256 at_centre =
            _mm256_and_ps(_mm256_cmp_ps(ox, zero, _CMP_EQ_OQ), _mm256_cmp_ps(oy, zero, _CMP_EQ_OQ));
        const __m256 m =
            _mm256_cmp_ps(_mm256_and_ps(ox, abs_mask), _mm256_and_ps(oy, abs_mask), _CMP_GT_OQ);
        __m256 r = pick(m, ox, oy);
        __m256 radius = _mm256_and_ps(r, abs_mask);
        const __m256 phi =
            _mm256_mul_ps(_mm256_set1_ps(sampling::kPi / 4.f), _mm256_div_ps(pick(m, oy, ox), r));
        // sinCosQuarter(phi)
        const __m256 zz = _mm256_mul_ps(phi, phi);
        const __m256 ps = _mm256_add_ps(
            _mm256_set1_ps(-1.6666654611e-1f),
            _mm256_mul_ps(zz, _mm256_add_ps(_mm256_set1_ps(8.3321608736e-3f),
                                            _mm256_mul_ps(zz, _mm256_set1_ps(-1.9515295891e-4f)))));
        const __m256 sn = _mm256_add_ps(phi, _mm256_mul_ps(_mm256_mul_ps(phi, zz), ps));
        const __m256 pc = _mm256_add_ps(
            _mm256_set1_ps(-0.5f),
            _mm256_mul_ps(
                zz, _mm256_add_ps(
                        _mm256_set1_ps(4.166664568298827e-2f),
                        _mm256_mul_ps(
                            zz, _mm256_add_ps(
                                    _mm256_set1_ps(-1.388731625493765e-3f),
                                    _mm256_mul_ps(zz, _mm256_set1_ps(2.443315711809948e-5f)))))));
        const __m256 cs = _mm256_add_ps(one, _mm256_mul_ps(zz, pc));
        // the centre of the square: the disk's centre, radius 0
        r = _mm256_andnot_ps(at_centre, r);
        radius = _mm256_andnot_ps(at_centre, radius);
        const __m256 dx = _mm256_andnot_ps(at_centre, _mm256_mul_ps(r, pick(m, cs, sn)));
        const __m256 dy = _mm256_andnot_ps(at_centre, _mm256_mul_ps(r, pick(m, sn, cs)));
        const __m256 dz =
            _mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(one, _mm256_mul_ps(radius, radius)), zero));
        _mm256_storeu_ps(x + k, dx);
        _mm256_storeu_ps(y + k, dy);
        _mm256_storeu_ps(z + k, dz);
    }
}

}  // namespace

void draw2D(const sobol_detail::PairSeeds& s, const uint32_t* rindex, int n, float* ux, float* uy) {
    draw2DAvx2(s, rindex, n, ux, uy);
}
void cosineHemisphere(const float* ux, const float* uy, int n, float* x, float* y, float* z) {
    cosineHemisphereAvx2(ux, uy, n, x, y, z);
}

#else  // no vector code on this target: the path batch stays scalar

bool available() {
    return false;
}
void draw2D(const sobol_detail::PairSeeds&, const uint32_t*, int, float*, float*) {}
void cosineHemisphere(const float*, const float*, int, float*, float*, float*) {}

#endif

}  // namespace batch_simd
}  // namespace vbme
}  // namespace cv
