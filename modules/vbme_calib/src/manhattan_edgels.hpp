// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Edge-pixel ("edgel") likelihood of a Manhattan frame (manhattan_edgels.cpp): scoring and
// local refinement of (focal length, rotation) with every edge pixel of the image, used by the
// GLOBAL search (manhattan.cpp) when VanishingPointCalibrator::Params::edgel_scoring is set.
#ifndef VBME_CALIB_MANHATTAN_EDGELS_HPP
#define VBME_CALIB_MANHATTAN_EDGELS_HPP

#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {
namespace detail {

/** Edge pixels of an image in normalised coordinates ((pixel − principal point) / W) with the
unit tangent of the edge (perpendicular to the smoothed gradient). */
struct Edgels {
    std::vector<Vec2d> x;   //!< positions, normalised
    std::vector<Vec2d> u;   //!< unit edge tangents
    std::vector<double> w;  //!< weights (mean 1): edge length each stands for
    double W = 1;           //!< the normalising length (pixels)
    size_t size() const { return x.size(); }
};

/** The likelihood's settings. */
struct EdgelModel {
    double sigma = 1.5 * CV_PI / 180;  //!< orientation noise of a Manhattan edgel (radians)
    double eps = 0.4;                  //!< share of edgels of no Manhattan direction
};

/** Edge pixels of an 8-bit gray image after a 3×3 median, at three scales (full, ½, ¼
resolution; half, 30 % and 20 % of @p max_edgels): Gaussian blur σ 1 px, Scharr gradient,
non-maximum suppression across the edge, magnitude above 3× the median (noise), orientation
from the structure tensor (σ 1.5 px) with coherence ≥ 0.5; a fixed pseudo-random even subset
of each scale's (deterministic), each weighted by the edge length it stands for. */
Edgels extractEdgels(const Mat& gray8, const Point2d& pp, double W, int max_edgels);

/** Mean log-likelihood ratio of the edgels under the Manhattan frame @cite Coughlan1999
@cite Denis2008 (columns of @p D the three
directions in camera coordinates, @p F the focal length in units of W) against orientations
uniform on [0, π): mean of log(ε + (1 − ε)/3 Σ_i π N(θ − θ_i(p); σ)), θ_i(p) the direction from
the edgel towards vanishing point i (at infinity: the direction itself). 0 means the frame
explains nothing; at most log(1 + (1 − ε)(π / (√(2π) σ) − 1)). @p per_dir (if given) receives
the share of the edgels' responsibility per direction. */
double edgelScore(const Edgels& e, const Matx33d& D, double F, const EdgelModel& m,
                  double per_dir[3] = nullptr);

/** Local maximisation of edgelScore over log F and a rotation of D (EM: responsibilities, then
Gauss–Newton steps on the responsibility-weighted angular residuals), @p iterations rounds,
F kept when @p fix_focal. With @p prior_logF_sigma > 0, a Gaussian prior on log F around
@p prior_logF is added, its weight relative to the mean log-likelihood being 1 / @p n_eff
(the edgels are not independent). Returns the final score. */
double refineEdgels(const Edgels& e, Matx33d& D, double& F, const EdgelModel& m, bool fix_focal,
                    int iterations, double prior_logF = 0, double prior_logF_sigma = 0,
                    double n_eff = 1);

/** Every @p n-th edgel (about @p n of them). */
Edgels subsampleEdgels(const Edgels& e, size_t n);

/** A frame scored by the edgels. */
struct EdgelFrame {
    Matx33d D;  //!< columns: the three directions in camera coordinates
    double F = 1, score = 0;
};

/** Frames sharing the direction of vanishing point @p v (homogeneous, normalised
coordinates): at each focal length of @p focals (units of W), @p n_psi rotations about that
direction over 90°; scored by edgelScore on about 300 of the edgels; best first. */
std::vector<EdgelFrame> edgelFramesAroundVP(const Edgels& e, const Vec3d& v,
                                            const std::vector<double>& focals, int n_psi,
                                            const EdgelModel& m);

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
