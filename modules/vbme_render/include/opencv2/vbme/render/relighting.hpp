// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_RELIGHTING_HPP
#define OPENCV_VBME_RENDER_RELIGHTING_HPP

#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/render/bsdf.hpp"
#include "opencv2/vbme/render/environment.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @name Image-space re-rendering of a recovered object (material editing, thesis chapter 4)

The object of a video frame is re-rendered pixel by pixel from its normal map (camera
coordinates, OpenCV axes: x right, y down, z forward; visible normals have n_z < 0) and the
viewing direction of each pixel, with the shaders of @cite Khan2006 over vbme_render's BSDFs:
a light at infinity (LightShader), a light with an angular spread (AreaLightShader), the
image-based environment with refraction through the recovered shape into the background
(ImageShader), and weighted sums of them (CombinationShader). The original object serves as a
light probe: fitLighting() fits order-2 spherical harmonics @cite Ramamoorthi2001 plus a
dominant directional light and an albedo to its observed linear shading. See
doc/vbme_pipeline_material_edit.md.
@{ */

/** @brief Order-2 real spherical harmonics of radiance, RGB, directions in camera coordinates.

`L(ω) = Σ_lm L_lm Y_lm(ω)` with the basis of @cite Ramamoorthi2001 (index order
Y00, Y1−1, Y10, Y11, Y2−2, Y2−1, Y20, Y21, Y22; Y1−1 ∝ y, Y10 ∝ z, Y11 ∝ x). Colours are
linear RGB, like Bsdf and EnvironmentMap values (images stay BGR).
*/
struct CV_EXPORTS SHLighting {
    Vec3f coeffs[9];  //!< L_lm per channel (R, G, B)
    /** @brief The 9 basis functions at unit direction @p d. */
    static void basis(const Vec3f& d, float y[9]);
    /** @brief Radiance arriving from direction @p d, clamped at 0. */
    Vec3f radiance(const Vec3f& d) const;
    /** @brief Irradiance on a surface of normal @p n: `E(n) = Σ Â_l L_lm Y_lm(n)` with
    Â_0 = π, Â_1 = 2π/3, Â_2 = π/4 (@cite Ramamoorthi2001, Eq. 8), clamped at 0. */
    Vec3f irradiance(const Vec3f& n) const;
};

/** @brief Lighting fitted to the observed shading of a (roughly) Lambertian object. */
struct CV_EXPORTS LightingFit {
    Vec3f to_light = Vec3f(0, 0, -1);   //!< dominant light direction (unit, camera coordinates)
    Vec3f irradiance = Vec3f(0, 0, 0);  //!< its irradiance at normal incidence (RGB)
    SHLighting ambient;                 //!< the rest of the lighting (radiance SH, RGB)
    Vec3f albedo = Vec3f(0.5f, 0.5f, 0.5f);  //!< estimated albedo (RGB)
    /** @brief The fitted observed shading `ρ/π·E(n)` as 9 SH coefficients of outgoing
    radiance (what a Lambertian sphere shows: `B(n) = Σ B_lm Y_lm(n)`). */
    SHLighting shading;
    double rms = 0;  //!< RMS residual of the directional + ambient model (linear units)
    int pixels = 0;  //!< pixels used
};

/** @brief Settings of fitLighting(). */
struct CV_EXPORTS LightFitParams {
    /** The albedo's largest channel: the fit only knows albedo × light, so the scale is
    assumed (0.8 leaves room for white objects; colour ratios come from the data). */
    float albedo_max = 0.8f;
    /** Pixels whose normal faces the camera less than this (|n_z|) are not used (the rim is
    blurred and mixes with the background). */
    float min_facing = 0.15f;
    /** Pixels with a channel above this (linear) are clipped or specular: not used. */
    float max_value = 0.97f;
    /** At most this many pixels are used (an even subsample). */
    int max_pixels = 4000;
    /** Ridge weight on the order-2 coefficients of the ambient fit (keeps the unseen
    back hemisphere tame). */
    float ridge = 1e-3f;
    /** If true, only the strength of the dominant light is fitted, along @p fixed_to_light. */
    bool fixed_direction = false;
    Vec3f fixed_to_light = Vec3f(0, 0, -1);  //!< the fixed direction (camera coordinates)

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Fits the lighting of a Lambertian object from its observed linear radiance.

Model: `I(n) = a(n) + b·max(0, n·d)`, where d is a dominant light direction and a(n) a smooth
ambient term (order-2 SH). d starts from the order-1 coefficients of a plain order-2 SH fit
of I (the direction of the first-order moment of the lighting) and is refined by a
coarse-to-fine search over the sphere minimising the residual of the luminance model
`a + b·max(0, n·d)`; then per channel b and the ambient SH are solved by least squares. The
albedo is `albedo_max·b/max(b)` (white key light assumed); the light's irradiance is `π·b/ρ`
and the ambient radiance SH `π·a_lm/(ρ·Â_l)`, so re-rendering the Lambertian object with
its own albedo under the fitted light gives back the fitted image.
@param linear CV_32FC3 linear BGR image.
@param normals CV_32FC3 camera-space unit normals (zero where no surface).
@param mask CV_8U, non-zero = object pixels to use (empty: where normals are non-zero).
@param params settings. Throws cv::Exception if fewer than 20 usable pixels remain. */
CV_EXPORTS LightingFit fitLighting(InputArray linear, InputArray normals, InputArray mask,
                                   const LightFitParams& params = LightFitParams());

/** @brief One pixel to shade: everything in camera coordinates. */
struct CV_EXPORTS ShadingPoint {
    Vec3f n;        //!< unit surface normal (towards the viewer side)
    Vec3f wo;       //!< unit direction from the surface towards the camera
    Point2f pixel;  //!< image position (for refraction look-ups and sample decorrelation)
};

/** @brief Outgoing radiance of a material at a pixel. Thread-safe, allocation-free shade(). */
class CV_EXPORTS Shader {
public:
    virtual ~Shader();
    /** @brief Linear radiance (RGB) leaving the surface towards the camera. */
    virtual Vec3f shade(const ShadingPoint& p) const = 0;
};

/** @brief A light at infinity: `L = f(wo, wi)·|n·wi|·E` with wi the light direction and E its
irradiance at normal incidence. Dirac BSDF lobes (smooth mirrors, glass) give nothing: use
AreaLightShader for their highlight. */
class CV_EXPORTS LightShader : public Shader {
public:
    /** @param m material. @param to_light unit direction towards the light (camera coords).
    @param irradiance E (RGB). */
    LightShader(const Material& m, const Vec3f& to_light, const Vec3f& irradiance);
    Vec3f shade(const ShadingPoint& p) const CV_OVERRIDE;

private:
    class Impl;
    Ptr<Impl> impl_;
};

/** @brief A distant light with an angular spread (a disk of half-angle @p half_angle around
@p to_light, constant radiance `E/Ω`): light sampling and BSDF sampling combined by the
balance heuristic @cite Veach1995 (cut off to one strategy where its pdf is 50 times the
other's, which keeps broad lobes free of fireflies), so near-mirror lobes show a clean
highlight; smooth mirrors and glass reflect it deterministically. */
class CV_EXPORTS AreaLightShader : public Shader {
public:
    /** @param m material. @param to_light unit centre direction (camera coords).
    @param irradiance irradiance at normal incidence (RGB). @param half_angle radians (> 0).
    @param samples light and BSDF samples per pixel each. */
    AreaLightShader(const Material& m, const Vec3f& to_light, const Vec3f& irradiance,
                    float half_angle, int samples = 16);
    Vec3f shade(const ShadingPoint& p) const CV_OVERRIDE;

private:
    class Impl;
    Ptr<Impl> impl_;
};

/** @brief Geometry for refraction through a recovered sphere (ImageShader). */
struct CV_EXPORTS SphereRefraction {
    Mat background;    //!< CV_32FC3 linear background seen behind the object (inpainted)
    Point2f center;    //!< the sphere's image disk centre (pixels)
    float radius = 0;  //!< its radius (pixels)
    double focal = 0;  //!< focal length (pixels); principal point at the image centre
    /** Distance of the background plane behind the sphere's centre, in sphere radii. */
    float background_depth = 5.f;
};

/** @brief The image-based environment @cite Khan2006: reflected (and, for dielectrics,
refracted) directions look up an EnvironmentMap (world z up, rotated by world_from_camera).

Smooth (Dirac) lobes are followed exactly: a mirror reflects the environment, glass splits by
the Fresnel factor into a reflection and a ray refracted twice through the sphere of
SphereRefraction, projected into the background image (or the environment when it leaves the
image). Rough lobes are sampled with the BSDF (deterministic stratified samples, rotated per
pixel). With an SH lighting given, broad sampled lobes (pdf below `sharp_pdf`) see the SH
radiance instead of the image (the image keeps the sharp reflections, the fit the
low-frequency light); a Lambertian material then uses the exact SH irradiance. Dielectrics
are treated as smooth (their roughness is ignored), without absorption or internal
reflections.
*/
class CV_EXPORTS ImageShader : public Shader {
public:
    /** @brief Settings. */
    struct CV_EXPORTS Params {
        int samples = 16;  //!< BSDF samples per pixel for rough lobes
        /** Conductors rougher than this are sampled; smoother ones reflect the environment
        as a mirror (one look-up): their lobe is narrower than the map's detail, and samples
        of the lobe's long tail only add noise. Their highlight comes from AreaLightShader. */
        float mirror_roughness = 0.1f;
        float sharp_pdf = 8.f;  //!< samples with a pdf above this (1/sr) read the image
        Matx33f world_from_camera = Matx33f::eye();  //!< rotation camera → environment world

        /** @brief Reads the fields present in the map @p fn (others keep their value); an
        unknown key or a value check() refuses is an error. */
        void read(const FileNode& fn);
        /** @brief Writes every field as `name: value` into the open map of @p fs. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range. */
        void check() const;
    };
    /** @param m material. @param env environment (may be null when @p sh is given; must
    outlive the shader). @param sh low-frequency lighting or null. @param refraction sphere
    and background for dielectrics, or null (refracted rays then read the environment).
    @param params settings. */
    ImageShader(const Material& m, const EnvironmentMap* env, const SHLighting* sh,
                const SphereRefraction* refraction, const Params& params);
    Vec3f shade(const ShadingPoint& p) const CV_OVERRIDE;
    /** @brief Radiance arriving along camera-space direction @p d from the environment (or
    the SH lighting when there is no environment). */
    Vec3f environment(const Vec3f& d) const;

private:
    class Impl;
    Ptr<Impl> impl_;
};

/** @brief A weighted sum of shaders. */
class CV_EXPORTS CombinationShader : public Shader {
public:
    /** @brief Adds @p s with weight @p w. */
    void add(const Ptr<Shader>& s, float w = 1.f);
    Vec3f shade(const ShadingPoint& p) const CV_OVERRIDE;

private:
    std::vector<std::pair<Ptr<Shader>, float>> parts_;
};

/** @brief Orthographic sphere normals of the disk (@p center, @p radius) at pixel (x, y) (thesis
§4.2):
`((x − cx)/r, (y − cy)/r, −sqrt(1 − ρ²))`, with the point pulled inside to ρ ≤ 0.999 for
pixels on or beyond the rim (so anti-aliased edge pixels get the rim's normal). */
CV_EXPORTS Vec3f sphereNormalAt(float x, float y, Point2f center, float radius);

/** @brief Focal length (pixels) of a horizontal field of view @p hfov_deg.
@deprecated Use cv::vbme::Camera::focalFromFov(), the one camera model; this alias goes in the
next release. */
[[deprecated("use cv::vbme::Camera::focalFromFov")]] inline double focalFromFov(int width,
                                                                                double hfov_deg) {
    return Camera::focalFromFov(width, hfov_deg);
}

/** @brief Fraction of pixel (x, y) covered by the disk, from the exact signed distance of
its centre to the edge: `clamp(r − dist + 0.5, 0, 1)`. */
CV_EXPORTS float diskCoverage(float x, float y, Point2f center, float radius);

/** @brief Re-renders a sphere seen as a disk (@p center, @p radius) and composites it.

Every pixel with coverage > 0 is shaded with sphereNormalAt() and the view ray of the camera
Camera::fromFocal(focal, background size) (PinholeCamera::generateRay(); the view
direction tilted to graze the surface where the orthographic normal faces away from the
perspective ray, near the rim of an off-centre disk) and blended
`c·shaded + (1 − c)·background` in linear space (c from diskCoverage()). Runs in parallel over
rows of the disk's bounding box; the result is deterministic.
@param background CV_32FC3 linear image the object is composited over (inpainted frame).
@param center disk centre (pixels). @param radius disk radius (pixels).
@param focal focal length (pixels). @param shader the material and light.
@param out receives the composite (CV_32FC3); may be @p background itself unless the
shader reads @p background (SphereRefraction), which would then see pixels already written.
@param shaded optional: the unblended object radiance (CV_32FC3, zero outside). */
CV_EXPORTS void renderSphere(InputArray background, Point2f center, float radius, double focal,
                             const Shader& shader, OutputArray out, OutputArray shaded = noArray());

/** @} */
//! @}

}  // namespace vbme
}  // namespace cv

#endif
