// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_ALBEDO_HPP
#define OPENCV_VBME_RENDER_ALBEDO_HPP

#include <map>
#include <string>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief Options of retinexAlbedo().

**Scale.** Retinex recovers reflectance only up to one factor per connected image. Land's
convention is used: the albedo is scaled so that its `white_percentile` percentile of luminance
(mean of B, G, R) over the seen texels equals `white` (the brightest surfaces are taken to be
near-white paint). With `white` ≤ 0 the shading is instead normalised to mean 1 over the seen
texels, so the albedo keeps the texture's units (radiance). Each call normalises its own
texture: faces of one room are normalised independently.
*/
struct CV_EXPORTS RetinexParams {
    double threshold = 0.05;         //!< log-luminance gradients smaller than this are shading
    int max_side = 256;              //!< the Poisson solve runs at most at this size (longer side)
    double chroma_threshold = 0.02;  //!< chromaticity gradients (L2 of Δ(c/ΣC)) above this are
                                     //!< reflectance even when the luminance gradient is small
    double white = 0.9;              //!< albedo at the white percentile (≤ 0: see above)
    double white_percentile = 99.0;  //!< percentile of the seen texels' luminance set to `white`
    /** @brief Reads the fields present in @p fn. */
    void read(const FileNode& fn);
    /** @brief Writes the fields. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Albedo of a face texture by colour Retinex @cite Land1971 @cite Horn1974, as used by
Karsch et al. @cite Karsch2011 (thesis §5.1.2), in the colour form of Grosse et al.
@cite Grosse2009 (a gradient is reflectance if luminance or chromaticity changes sharply).

Shading is assumed grey, smooth and slowly varying; reflectance changes are sharp or change
the colour. The texture (downsampled with INTER_AREA so that its longer side is at most
`max_side`, sides even) is split into log-luminance ℓ = log((B+G+R)/3) and chromaticity
c = (B,G,R)/(B+G+R). A forward-difference gradient of ℓ is kept as reflectance if
|∇ℓ| > `threshold` or |∇c| > `chroma_threshold`, otherwise set to zero (shading). The kept
field g is reintegrated by solving the Poisson equation ∇²r = div g with Neumann boundaries,
exactly, by the DCT (the 5-point Laplacian is diagonal in the DCT-II basis). The log-shading
s = ℓ − r is exponentiated, upsampled bilinearly to the texture's size, and
albedo = texture / shading (all three channels), then scaled (RetinexParams).

Texels that are 0 in all channels are taken as unseen: their gradients are not used, and they
receive the mean albedo of the seen texels.
@param texture_linear CV_32FC3 linear BGR texture (e.g. RoomTextureAccumulator output).
@param albedo receives CV_32FC3, clamped to [0, 1].
@param p options. */
CV_EXPORTS void retinexAlbedo(InputArray texture_linear, OutputArray albedo,
                              const RetinexParams& p = RetinexParams());

/** @brief Options of irradianceAlbedo(). */
struct CV_EXPORTS IrradianceAlbedoParams {
    int grid = 48;       //!< irradiance samples per face side (grid × grid per face)
    int spp = 64;        //!< samples per grid point, per light and for the indirect gather
    int iterations = 3;  //!< irradiance passes (≥ 1); see irradianceAlbedo()
    uint64 seed = 0;     //!< seed of the deterministic sampler
    /** @brief Reads the fields present in @p fn. */
    void read(const FileNode& fn);
    /** @brief Writes the fields. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Albedo of the room's faces from their observed radiance and the irradiance the
scene's lights and the room itself cast on them: ρ = π·L / E, clamped to [0, 1] (thesis §5.1.2;
a Lambertian room).

E is computed at grid × grid points per face (cell centres) and upsampled bilinearly:
- **direct**: for each scene light, `spp` samples of Emitter::sample() with a shadow ray through
  the room box and the proxies (RenderScene::occluded() without the `objects:`, which are not
  in the real room): E_d = Σ L·cos θ / pdf / spp;
- **indirect**: `spp` cosine-distributed rays from the point (RenderScene::intersect() without
  the objects); a ray hitting a room face at (u, v) picks up that face's OBSERVED radiance
  (bilinear lookup in @p radiance), so E_i = π · mean(L). Rays hitting a light are left to the
  direct term; rays hitting a proxy pick up the mean observed room radiance (their radiance is
  not observed).

Where no frame saw the hit texel (L unknown) the radiance is estimated: in pass 1 as the mean
observed radiance of that face (of all faces if the face was never seen); in each later pass as
ρ̄_face · E(u, v) / π, with E from the previous pass and ρ̄_face the mean albedo of the face's
seen texels from the previous pass. The ray hits are traced once and re-used by every pass.

Texels that were not seen get ρ̄_face (or the room mean).

**Scale.** Image ∝ albedo × light power: with the lights at their true powers the albedo is
absolute; if the lights' powers are only known up to a factor k, the albedo is off by 1/k.
Fix it either from the lights (e.g. a light's own unclipped pixels give its radiance; see
estimateLights() for the converse problem), or by a normalisation such as retinexAlbedo()'s.
@param scene room (with or without textures; they are not used), proxies and lights at their
current powers. Its `objects:` are ignored.
@param radiance per face name: the observed linear CV_32FC3 radiance texture (BGR); texels 0
in all channels count as unseen. Faces missing from the map are unseen.
@param albedo receives per face of @p radiance a CV_32FC3 albedo of the same size.
@param p options. */
CV_EXPORTS void irradianceAlbedo(const Scene& scene, const std::map<std::string, Mat>& radiance,
                                 std::map<std::string, Mat>& albedo,
                                 const IrradianceAlbedoParams& p = IrradianceAlbedoParams());

/** @brief irradianceAlbedo() with explicit seen masks (CV_8U, non-zero where observed, the
radiance map's size; e.g. RoomTextureAccumulator::textures()), for radiance that may be 0
where seen. @p irradiance, if not null, receives per face the final irradiance E (CV_32FC3 BGR,
the texture's size). */
CV_EXPORTS void irradianceAlbedo(const Scene& scene, const std::map<std::string, Mat>& radiance,
                                 const std::map<std::string, Mat>& seen,
                                 std::map<std::string, Mat>& albedo,
                                 const IrradianceAlbedoParams& p,
                                 std::map<std::string, Mat>* irradiance = nullptr);

/** @brief irradianceAlbedo() with the lights' common scale fixed by the room's white point.

Image = albedo × light power leaves a common factor open, and the lights' annotated radiance,
taken from clipped LDR pixels, is only a lower bound. This scales all lights of @p scene up by
one factor k ≥ 1 until the room's whitest surfaces, the 99th percentile over seen, unclipped
texels (largest channel below 0.95) of the raw largest-channel ratio π·L/E, have albedo
@p white. Lights are never scaled down: when the whitest surfaces already have an albedo of at
most @p white with the scene's powers, those powers are kept (k = 1). A room of grey walls has
no surface as white as @p white, and scaling its (exact) lights down to make one so darkened
inserted objects by the same factor (measured: 0.56 on a Blender room whose brightest walls
have albedo ≈ 0.7; 0.63 on the synthetic insertion room).
E is nearly proportional to the lights' power (the indirect part, gathered from the observed
radiance, is not), so a fixed-point iteration converges in a few steps: up to
@p max_iterations irradianceAlbedo() passes, stopping when a step changes k by less than 1 %.
@param scene room, proxies and lights; its lights' radiance / intensity are multiplied by the
returned factor (applyLightEstimate()).
@param radiance observed linear radiance per face (RoomTextureAccumulator::textures()).
@param seen seen masks per face (same sizes as @p radiance).
@param albedo receives the albedo of the last pass (with the scaled lights).
@param white target albedo of the whitest surfaces, in (0, 1]; 0 or less: no scaling (one
irradianceAlbedo() pass).
@param p options of irradianceAlbedo().
@param max_iterations irradianceAlbedo() passes at most (≥ 1).
@return the factor applied to the lights, ≥ 1 (1 when none). */
CV_EXPORTS double irradianceAlbedoWhitePoint(Scene& scene,
                                             const std::map<std::string, Mat>& radiance,
                                             const std::map<std::string, Mat>& seen,
                                             std::map<std::string, Mat>& albedo, double white,
                                             const IrradianceAlbedoParams& p =
                                                 IrradianceAlbedoParams(),
                                             int max_iterations = 6);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
