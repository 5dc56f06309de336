// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_METRICS_HPP
#define OPENCV_VBME_CORE_METRICS_HPP

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief PSNR (dB, peak 255) of two 8-bit images over the pixels where @p region is non-zero
(all pixels when empty); +inf when they are equal there (or the region is empty).

The mean squared error is taken over every channel of every region pixel. The sum of squared
errors and the count of values it was taken over are returned through @p sse and @p count, so
that a clip's PSNR can be pooled over frames: `10 log10(255² · Σcount / Σsse)`.
@param a first image, 8-bit, any number of channels.
@param b second image, same size and type as @p a.
@param region CV_8UC1 mask of the same size, or empty for the whole image.
@param sse if not null, receives the sum of squared errors over the region.
@param count if not null, receives the number of values (region pixels × channels). */
CV_EXPORTS double regionPsnr(InputArray a, InputArray b, InputArray region = noArray(),
                             double* sse = nullptr, double* count = nullptr);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
