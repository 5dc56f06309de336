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
at most params.max_segments. If @p with_fld is given (and OpenCV's ximgproc is available), it
receives the same set made with FastLineDetector's segments added (see proposeManhattan). */
void detectSegmentsMerged(const Mat& gray, const VanishingPointCalibrator::Params& params,
                          std::vector<Vec4f>& segments, std::vector<Vec4f>* with_fld = nullptr);

/** Segments and GLOBAL search as detectManhattanProposals() does it: with
params.fld_pass, the search runs on the LSD segments and on the LSD + FastLineDetector
segments; when the two first frames agree, the LSD pass's proposals are returned; when they
disagree, the FLD pass's, every confidence halved and the LSD pass's first frame kept as the
second proposal. */
std::vector<ManhattanProposal> proposeManhattan(const Mat& gray,
                                                const VanishingPointCalibrator::Params& params,
                                                int max_proposals);

/** The GLOBAL search on given segments (pixels); proposals best first. Throws with the
reason when none is plausible. */
std::vector<ManhattanProposal> searchManhattan(const std::vector<Vec4f>& segments, Size size,
                                               const VanishingPointCalibrator::Params& params,
                                               int max_proposals);

/** The GLOBAL search's refinement (relabelling + robust joint refinement of focal length and
rotation, no distortion) started from a given frame: @p focal (px) and @p R (cam_from_world,
columns the world axes in camera coordinates), principal point as in @p params. Returns the
refined focal length; @p focal_rel_sigma (if given) its relative standard deviation and
@p score (if given) the refined frame's consensus score. White-box: lets tests start the
refinement from the true frame to tell a biased objective from a badly chosen start. */
double refineManhattanFrameFrom(const std::vector<Vec4f>& segments, Size size,
                                const VanishingPointCalibrator::Params& params, double focal,
                                const Matx33d& R, double* focal_rel_sigma = nullptr,
                                double* score = nullptr);

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
