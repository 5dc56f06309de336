// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_LIGHT_ESTIMATION_HPP
#define OPENCV_VBME_RENDER_LIGHT_ESTIMATION_HPP

#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"
#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief Options of estimateLights() (thesis §5.1.3). */
struct CV_EXPORTS LightEstimationParams {
    /** @brief Fitting method. */
    enum Method {
        HILL_CLIMB = 0,  //!< the thesis's multiplicative update, Eq. 5.1
        NNLS = 1         //!< linear least squares with non-negative powers @cite Lawson1974
    };
    Method method = NNLS;             //!< fitting method
    Size render_size = Size(80, 60);  //!< low-resolution renders
    int spp = 16;                     //!< samples per pixel of the basis renders
    int max_depth = 4;                //!< bounces of the basis renders (all of them are fitted)
    int max_iterations = 5;           //!< hill climbing (Eq. 5.1)
    double tolerance = 1e-3;          //!< hill climbing: stop when every |error| is below
    double clip_level = 0.98;     //!< encoded value (0..1) at or above which a pixel is left out
    bool per_frame_gain = false;  //!< also fit one exposure gain per frame (auto-exposure)
    uint64 seed = 0;              //!< sampler seed of the basis renders
    /** @brief Reads the fields present in @p fn. */
    void read(const FileNode& fn);
    /** @brief Writes the fields. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Result of estimateLights(). */
struct CV_EXPORTS LightEstimate {
    std::vector<Vec3d> scale;   //!< per scene light: factor on its radiance / intensity (RGB)
    std::vector<double> gains;  //!< per frame exposure gain (all 1 without per_frame_gain)
    double error_before = 0, error_after = 0;  //!< relative RMS error of the fit
    int iterations = 0;                        //!< iterations made (hill climbing, gain loop)
    int pixels_used = 0;                       //!< low-resolution pixels fitted (all frames)
    /** @brief Writes the fields. */
    void write(FileStorage& fs) const;
};

/** @brief Estimates the scene lights' powers from video frames, given the room's albedo
(thesis §5.1.3).

The frames are linearised with the scene camera's response and downsampled (INTER_AREA) to
`render_size`. A low-resolution pixel is used only if none of its source pixels is clipped
(any channel ≥ `clip_level` in the frame's encoded 0..1 scale) and neither are those of its 8
neighbours, so over-exposed lights and highlights never bias the fit (the unclipped rim of a
saturated light is a sliver of very bright emitter whose coverage frame and basis renders both
estimate noisily; it would bias the fit like noise in a regressor).

Rendered radiance is linear in each light's emission, so one **basis image** B_i per light i is
rendered per frame (vbme_render Renderer, the scene with only light i at its current value,
`spp` samples, up to `max_depth` bounces, room Lambertian with the scene's albedo textures,
without the `objects:`), and the model of frame f is g_f · Σ_i s_i ⊙ B_i,f (per colour
channel). Light beyond `max_depth` bounces is missing from the basis, so in a bright room the
powers come out high: raise `max_depth` there (figures in doc/vbme_render_room_model.md,
"Measured results").

- **NNLS** (default): per colour channel, min_s Σ (Σ_i s_i B_i − I)² subject to s ≥ 0, solved
  exactly by the Lawson–Hanson active-set method @cite Lawson1974 on the normal equations.
  With `per_frame_gain`, gains and powers are alternated (gain_f in closed form per frame, then
  NNLS), the scale being fixed by mean(gain) = 1, for at most 20 rounds.
- **HILL_CLIMB**: the thesis's update (Eq. 5.1), per light and channel,
  s ← s · 2·(1 − 1/(1 + e^(−15·err))), where err is the mean difference of display-encoded
  values (0..1, the camera response), rendered − observed, over the used pixels, each pixel
  weighted by the light's own share s_i·B_i of the render (err > 0: too bright, the power
  drops). The render R = Σ s_i B_i is the exact re-render at the new powers (same samples), at
  most `max_iterations` times, stopping when every |err| < `tolerance`; the iterate with the
  lowest relative RMS error is returned. (With a relative radiance error instead, the factor
  ≈ 1 − 7.5·err overshot ~7.5× per step and no iterate improved on the start.) Shared pixels
  couple the lights, and 5 steps do not reach the optimum: NNLS is the better method.

A light whose basis contributes nothing to the used pixels gets scale 0 from NNLS (it is not
observable); check LightEstimate::scale before applying it.

**Scale ambiguity.** Image ∝ albedo × light power: the powers are only as right as the albedo's
scale. With a known (or Retinex-normalised) albedo this problem is well-posed; an albedo k× too
bright gives powers k× too weak. A user who knows a light's radiance (e.g. from its own
unclipped pixels in a short exposure) can fix the scale.
@param scene room with albedo textures (files, as RenderScene loads them), lights with their
initial values (the scales are relative to these).
@param frames display-encoded BGR frames as in the video (8- or 16-bit, or float in 0..1).
@param cameras one camera per frame.
@param p options.
@return the scales, gains and fit errors. */
CV_EXPORTS LightEstimate estimateLights(const Scene& scene, InputArrayOfArrays frames,
                                        const std::vector<Camera>& cameras,
                                        const LightEstimationParams& p = LightEstimationParams());

/** @brief Multiplies each scene light's emission by its estimated scale: polygon, distant and
constant environment `radiance`, point `intensity` (per RGB channel); an environment image's
scalar `scale` by the mean of the three factors. */
CV_EXPORTS void applyLightEstimate(Scene& scene, const LightEstimate& e);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
