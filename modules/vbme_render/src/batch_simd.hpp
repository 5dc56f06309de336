// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Vector code for a path batch (RendererImpl::traceBatch, private to vbme_render): the lanes'
// Sobol draws (film, BSDF direction) and cosine-hemisphere samples eight at a time with AVX2,
// chosen at run time.
#ifndef VBME_RENDER_BATCH_SIMD_HPP
#define VBME_RENDER_BATCH_SIMD_HPP

#include <cstdint>

#include "sobol_impl.hpp"

namespace cv {
namespace vbme {
namespace batch_simd {

/** Lanes are processed in groups of this many: the arrays given to the functions below hold
n rounded up to a multiple of it (the extra entries are computed and ignored). */
constexpr int kWidth = 8;

/** Whether this processor runs the vector code (AVX2; asked once). Without it the functions
below must not be called: the path batch keeps its scalar code. */
bool available();

/** The pair of dimensions whose seeds are @p s, for the lanes' bit-reversed sample indices
rindex[0 … n): ux[k], uy[k] are bitwise sobol_detail::get2D(s, rindex[k]). */
void draw2D(const sobol_detail::PairSeeds& s, const uint32_t* rindex, int n, float* ux, float* uy);

/** sampling::squareToCosineHemisphere of (ux[k], uy[k]) into (x[k], y[k], z[k]), bitwise (the
same operations in the same order, no contraction into fused multiply-adds). */
void cosineHemisphere(const float* ux, const float* uy, int n, float* x, float* y, float* z);

}  // namespace batch_simd
}  // namespace vbme
}  // namespace cv

#endif
