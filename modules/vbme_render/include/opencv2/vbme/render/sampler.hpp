// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_SAMPLER_HPP
#define OPENCV_VBME_RENDER_SAMPLER_HPP

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief Deterministic low-discrepancy sampler: Owen-scrambled Sobol points
@cite Sobol1967 @cite Owen1995, scrambled by hashing @cite Burley2020.

Every number is a pure function of (pixel, sample index, dimension, seed): nothing is stored
between calls, so any thread may draw any sample and a render is bitwise identical for any
thread count. Dimensions come in pairs (2k, 2k+1): each pair is the first two Sobol
dimensions with the sample index shuffled by a nested uniform scramble and each coordinate
Owen-scrambled, the scramble seeds hashed from (seed, pixel, pair). Within a pair the points of
one pixel form a (0,m,2)-net for power-of-two sample counts; different pairs and different
pixels are decorrelated.

The path tracer assigns dimensions by path vertex in a fixed pattern (see PathDims), never by
a running counter, so two renders that differ only in scene content draw the same numbers for
the same (pixel, sample, dimension) — what differential rendering needs.
*/
class CV_EXPORTS SobolSampler {
public:
    /** @brief A sampler with the given seed. */
    explicit SobolSampler(uint64 seed = 0) : seed_(seed) {}
    /** @brief The seed. */
    uint64 seed() const { return seed_; }
    /** @brief One number in [0,1) for dimension @p dim of sample @p index of pixel @p px. */
    float get1D(const Point& px, uint32_t index, uint32_t dim) const {
        return get1D(pixelKey(px), index, dim);
    }
    /** @brief Two numbers in [0,1) for dimensions (@p dim, @p dim + 1); @p dim must be even
    (the pair is stratified jointly). */
    Vec2f get2D(const Point& px, uint32_t index, uint32_t dim) const {
        return get2D(pixelKey(px), index, dim);
    }
    /** @brief The hash of (seed, pixel) that the overloads below take, so that a pixel's many
    draws hash the pixel once. */
    uint64 pixelKey(const Point& px) const;
    /** @brief get1D() for a precomputed pixelKey(). */
    float get1D(uint64 pixel_key, uint32_t index, uint32_t dim) const;
    /** @brief get2D() for a precomputed pixelKey(). */
    Vec2f get2D(uint64 pixel_key, uint32_t index, uint32_t dim) const;

    /** @brief The unscrambled Sobol value of dimension @p c (0 or 1) for @p index. */
    static uint32_t sobol(uint32_t index, int c);

private:
    uint64 seed_;
};

/** @brief The fixed assignment of sampler dimensions to the uses of a path.

Dimensions 0–1 place the sample in the pixel (film filter). Path vertex @p depth (0 = the
first surface hit by the camera ray) uses dimensions `2 + depth·kPerVertex + slot`. */
struct PathDims {
    static constexpr uint32_t kFilm = 0;         //!< 2-D: position in the pixel
    static constexpr uint32_t kFirstVertex = 2;  //!< first dimension of vertex 0
    static constexpr uint32_t kPerVertex = 8;    //!< dimensions per vertex
    static constexpr uint32_t kBsdfDir = 0;      //!< 2-D: BSDF direction
    static constexpr uint32_t kLightPos = 2;     //!< 2-D: point / direction on the light
    static constexpr uint32_t kLightSelect = 4;  //!< 1-D: which light
    static constexpr uint32_t kBsdfLobe = 5;     //!< 1-D: which BSDF lobe
    static constexpr uint32_t kRoulette = 6;     //!< 1-D: Russian roulette
    /** @brief The dimension of @p slot at vertex @p depth. */
    static constexpr uint32_t dim(int depth, uint32_t slot) {
        return kFirstVertex + uint32_t(depth) * kPerVertex + slot;
    }
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
