// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_PIPELINE_CAMERA_MATCH_HPP
#define OPENCV_VBME_PIPELINE_CAMERA_MATCH_HPP

#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"
#include "opencv2/vbme/core/camera_path.hpp"
#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/render/differential.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_pipeline
//! @{

/** @brief The footage's noise ("grain") as measureGrain() finds it: its standard deviation per
display intensity and channel, and its spatial correlation.

The noise of a pixel of channel c whose noise-free display value is v (8-bit code values) is
modelled as `sigmaAt(v)[c] · ε`, with ε white Gaussian noise of unit variance blurred by a
Gaussian of standard deviation @ref blur pixels and rescaled to unit variance (what sensor
noise looks like after demosaicking and compression). */
struct CV_EXPORTS GrainModel {
    std::vector<double> level;  //!< the intensity bins' centres (8-bit code values)
    std::vector<Vec3d> sigma;   //!< noise standard deviation per bin (code values, B, G, R)
    std::vector<int> count;     //!< flat pixels measured per bin (all frames, all channels)
    double correlation = 0;     //!< correlation of the noise of neighbouring pixels (lag 1)
    double blur = 0;            //!< Gaussian blur (px) of white noise that gives @ref correlation
    int pixels = 0;             //!< flat pixels measured in all
    bool reliable = false;      //!< enough flat pixels in enough bins for the model to be used

    /** @brief The noise standard deviation (code values, B, G, R) at display value @p v (code
    values), linear between the bins' centres, constant beyond the first and last. Zero for an
    empty model. */
    Vec3d sigmaAt(double v) const;
    /** @brief The mean of the per-bin standard deviations over channels, weighted by the bins'
    pixel counts (one figure for the report). */
    double meanSigma() const;
};

/** @brief Options of measureGrain(). */
struct CV_EXPORTS GrainParams {
    int bins = 16;               //!< intensity bins over [0, 256) code values
    int min_bin_pixels = 300;    //!< a bin with fewer flat pixels takes its neighbour's value
    int min_reliable_bins = 3;   //!< bins with enough pixels for GrainModel::reliable
    double flat_fraction = 0.5;  //!< the flattest fraction of each frame's pixels is measured
};

/** @brief Measures the noise of a video from some of its frames.

Each frame's high-pass residual r = I − G₁ * I (G₁: Gaussian of σ = 1 px) is taken on its
flattest pixels (the smallest gradient of G₁ * I, GrainParams::flat_fraction of the frame),
where r is mostly noise; per intensity bin of G₁ * I and per channel, the residual's standard
deviation is measured robustly (median absolute value / 0.6745) and so is the correlation of
neighbouring residuals. Both depend on the noise's own spatial correlation; the estimator is
run on synthetic noise of known blur to invert that dependence (a table over blurs of 0…2 px),
giving GrainModel::blur and the noise's standard deviation (not the residual's).
@param frames 8-bit (or 16-bit, scaled to code values) BGR frames of the video.
@param params options.
@return the model; GrainModel::reliable false when the frames hold too few flat pixels. */
CV_EXPORTS GrainModel measureGrain(const std::vector<Mat>& frames,
                                   const GrainParams& params = GrainParams());

/** @brief The noise of a linear image on a region, per channel, in display code values: the
robust standard deviation of the same high-pass residual as measureGrain()'s, for white noise
(a path tracer's). The region's smooth shading cancels in the residual; edges in it do not.
@param linear CV_32FC3 linear image (e.g. DifferentialImages::obj).
@param region CV_8UC1, non-zero where to measure.
@param response display encoding of the code values.
@return σ per channel (B, G, R); 0 when the region has fewer than 20 pixels. */
CV_EXPORTS Vec3d regionNoise(InputArray linear, InputArray region, Response response);

/** @brief Adds noise matching @p model to the pixels of a linear image in proportion to a
weight, so that they end as noisy as the footage: a pixel of weight w whose (1 − w) part comes
from the noisy footage and whose w part has noise @p present gets noise of variance
`(1 − (1 − w)²) · sigmaAt(v)² − w² · present²` (none where that is negative) added in display
space (v: the pixel's display value). The noise is Gaussian, blurred by GrainModel::blur, a
function of @p seed only.
@param linear CV_32FC3 linear image (modified in place).
@param weight CV_32FC1 weight in [0, 1] of @p linear's size (e.g. the objects' coverage).
@param model the footage's noise.
@param response the footage's response (display ↔ linear).
@param seed the noise's seed (e.g. a hash of a base seed and the frame index).
@param present noise the weighted pixels already have (code values, B, G, R; e.g. the render's,
regionNoise()). */
CV_EXPORTS void addGrain(InputOutputArray linear, InputArray weight, const GrainModel& model,
                         Response response, uint64 seed, const Vec3d& present = Vec3d());

/** @brief The camera at a fractional frame time @p time of a camera path: the rotation
interpolated on the shortest arc (slerp) and the camera centre linearly between the frames
floor(time) and floor(time) + 1; before the first or after the last frame, the nearest
interval's motion is extrapolated. K, image size and response are those of @p base. */
CV_EXPORTS Camera cameraAtTime(const CameraPath& path, double time, const Camera& base);

/** @brief The largest image motion (pixels) of the world points @p points between the
cameras at times @p t0 and @p t1 of @p path (points behind either camera are skipped). */
CV_EXPORTS double projectedMotion(const CameraPath& path, double t0, double t1, const Camera& base,
                                  const std::vector<Vec3d>& points);

/** @brief Renders the layers of a differential render integrated over a shutter interval:
@p subframes renders at the times t_k = @p time + shutter·((k + ½)/subframes − ½) (the
interval centred on the frame's time), each with the renderer's samples divided among them
and its own seed, then averaged so that compositeDifferential() gives the time average of the
per-time composites (with the background the footage's own blurred frame):
M̄ = mean M_k, obj = mean(M_k·obj_k)/M̄, diff = mean((1 − M_k)·diff_k)/(1 − M̄) (the plain
means where M̄ is 0 or 1), noobj and object the plain means, samples the sums.
@param params the differential renderer's options (render.spp is the frame's budget).
@param scene the render scene.
@param camera_at the camera at a fractional frame time (e.g. cameraAtTime()).
@param time the frame's time (frame index).
@param shutter the exposure as a fraction of the frame interval (0: one render at @p time).
@param subframes renders over the interval (≥ 1).
@param out receives the layers. */
CV_EXPORTS void renderOverShutter(const DifferentialRenderer::Params& params,
                                  const RenderScene& scene,
                                  const std::function<Camera(double)>& camera_at, double time,
                                  double shutter, int subframes, DifferentialImages& out);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
