// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The GLOBAL Manhattan-frame search of VanishingPointCalibrator (manhattan.cpp).
#ifndef VBME_CALIB_MANHATTAN_HPP
#define VBME_CALIB_MANHATTAN_HPP

#include <array>
#include <map>
#include <string>
#include <vector>

#include "opencv2/vbme/calib/frame_calibration.hpp"

namespace cv {
namespace vbme {
namespace detail {

struct Edgels;  // manhattan_edgels.hpp

/** 8-bit gray copy (or view) of an 8/16-bit gray/BGR/BGRA image; throws when empty. */
Mat toGray8(InputArray image);

/** The GLOBAL search's segments of one image: the LSD passes and the gradients are computed
once; lsd() merges and refits the LSD pieces, withFld() the same with FastLineDetector's
pieces added (empty without OpenCV's ximgproc). Both: at least the minimum length, longest
first, at most params.max_segments. @p passes (if given) receives, for each returned segment,
the number of the three LSD passes (full, half, quarter resolution) whose pieces were merged
into it: 1–3, or 0 for a segment of FastLineDetector pieces alone (an FLD piece merged into
LSD pieces adds nothing). Params::pass_weight weights the refinement by it. */
class MergedSegments {
public:
    MergedSegments(const Mat& gray, const VanishingPointCalibrator::Params& params);
    std::vector<Vec4f> lsd(std::vector<int>* passes = nullptr) const;
    std::vector<Vec4f> withFld(std::vector<int>* passes = nullptr) const;

private:
    std::vector<Vec4f> finish(const std::vector<Vec4f>& raw, const std::vector<int>& raw_mask,
                              bool merge_again, std::vector<int>* passes) const;
    std::vector<Vec4f> raw_;
    std::vector<int> raw_mask_;  // per raw_ piece: bit k for LSD pass k
    Mat blurred2_, gx_, gy_;
    /** Refitted pieces by their endpoints before the refit (the refit depends on nothing
    else): a merged piece both sets have is refitted once. */
    mutable std::map<std::array<double, 4>, std::array<double, 4>> refitted_;
    double minlen_ = 0;
    int max_segments_ = 0;
};

/** LSD segments with collinear pieces merged (MergedSegments::lsd()). */
void detectSegmentsMerged(const Mat& gray, const VanishingPointCalibrator::Params& params,
                          std::vector<Vec4f>& segments);

/** Segments and GLOBAL search as detectManhattanProposals() does it: the search runs on the
LSD segments; with params.fld_pass, when its first proposal's confidence is below
params.fld_pass_below_confidence (or it found none), again on the LSD + FastLineDetector
segments. When the two first frames agree, the LSD pass's proposals are returned; when they
disagree, the FLD pass's (unless only the LSD frame reaches params.min_confidence), every
confidence halved and the other pass's first frame kept as the second proposal. */
std::vector<ManhattanProposal> proposeManhattan(const Mat& gray,
                                                const VanishingPointCalibrator::Params& params,
                                                int max_proposals);

/** The GLOBAL search on given segments (pixels); proposals best first. Throws with the
reason when none is plausible. @p gray (8-bit, the image the segments come from) is used when
params.edgel_scoring is set (manhattan_edgels.hpp); empty: segments only. @p shared_edgels
(if given) are @p gray's edge pixels, extracted once by the caller (extractEdgels with at most
3000, principal point as in @p params) for several searches on one image. @p passes (if
given, one per segment; MergedSegments) weights each segment's residual in the refinement
(Params::pass_weight); without it every segment counts as found by one pass. */
std::vector<ManhattanProposal> searchManhattan(const std::vector<Vec4f>& segments, Size size,
                                               const VanishingPointCalibrator::Params& params,
                                               int max_proposals, const Mat& gray = Mat(),
                                               const Edgels* shared_edgels = nullptr,
                                               const std::vector<int>* passes = nullptr);

/** How far a frame's support is the room's rather than one object's or one edge's, in [0, 1]: a
factor of the confidence (proposeManhattan). The search's own confidence counts the second
direction's segments (4 or more: full) and its length share; here (1) the second direction's
support is counted in distinct lines instead of pieces (an edge found in three pieces is one
line: min(1, lines / 4) replaces min(1, segments / 4)), and (2) a frame whose second and third
directions rest mostly on one ninth of the image (a box turned about the vertical, a few tile
joints, the pieces of one corner) is one object's frame, not the room's: the factor falls
linearly from 1 to 0 as the largest share of their length inside one window of a third of the
width and height goes from half to all of it. Directions ranked by segment count as in the
search. @p why (if given) says which applied. */
double supportSpread(const FrameCalibration& c, std::string* why = nullptr);

/** Params::upright_prior's factor for a frame of rotation @p R (cam_from_world, the world
vertical its third column): 1 within |roll| ≤ 15° and |pitch| ≤ 45°, beyond that
exp(−½ (excess / σ)²) per angle, σ = @p sigma_deg; 1 when @p sigma_deg is 0 (off). Pitch is
the viewing direction's elevation (positive up), roll the image's turn about it. */
double uprightPrior(const Matx33d& R, double sigma_deg);

/** The GLOBAL search's refinement (relabelling + robust joint refinement of focal length and
rotation, no distortion) started from a given frame: @p focal (px) and @p R (cam_from_world,
columns the world axes in camera coordinates), principal point as in @p params. Returns the
refined focal length; @p focal_rel_sigma (if given) its relative standard deviation and
@p score (if given) the refined frame's consensus score and @p R_out (if given) the refined
rotation (cam_from_world; its columns may be permuted or negated as @p R's). White-box: lets tests
start the refinement from the true frame to tell a biased objective from a badly chosen start.
@p passes as for searchManhattan. */
double refineManhattanFrameFrom(const std::vector<Vec4f>& segments, Size size,
                                const VanishingPointCalibrator::Params& params, double focal,
                                const Matx33d& R, double* focal_rel_sigma = nullptr,
                                double* score = nullptr, Matx33d* R_out = nullptr,
                                const std::vector<int>* passes = nullptr);

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
