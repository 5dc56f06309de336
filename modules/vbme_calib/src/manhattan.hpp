// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The GLOBAL Manhattan-frame search of VanishingPointCalibrator (manhattan.cpp).
#ifndef VBME_CALIB_MANHATTAN_HPP
#define VBME_CALIB_MANHATTAN_HPP

#include <vector>

#include "opencv2/vbme/calib/frame_calibration.hpp"

namespace cv {
namespace vbme {
namespace detail {

/** 8-bit gray copy (or view) of an 8/16-bit gray/BGR/BGRA image; throws when empty. */
Mat toGray8(InputArray image);

/** LSD segments with collinear pieces merged, at least the minimum length, longest first,
at most params.max_segments. */
void detectSegmentsMerged(const Mat& gray, const VanishingPointCalibrator::Params& params,
                          std::vector<Vec4f>& segments);

/** The GLOBAL search on given segments (pixels); proposals best first. Throws with the
reason when none is plausible. */
std::vector<ManhattanProposal> searchManhattan(const std::vector<Vec4f>& segments, Size size,
                                               const VanishingPointCalibrator::Params& params,
                                               int max_proposals);

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
