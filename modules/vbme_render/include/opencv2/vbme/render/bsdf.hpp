// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_BSDF_HPP
#define OPENCV_VBME_RENDER_BSDF_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief Result of Bsdf::sample().

All directions are in the local shading frame: z is the shading normal on the side the
surface's geometric normal points to (outside of a closed mesh), x and y are tangents, and
directions point away from the surface (wo towards the viewer, wi towards the light).
*/
struct BsdfSample {
    Vec3f wi;                   //!< sampled incident direction (unit, local frame)
    Vec3f f;                    //!< BSDF value f(wo, wi) (for a delta lobe: weight·pdf/|cos|)
    Vec3f weight;               //!< f·|cos θi| / pdf: the throughput multiplier of the sample
    float pdf = 0;              //!< solid-angle pdf (for a delta lobe: probability of the lobe)
    bool delta = false;         //!< sampled from a specular (Dirac) lobe: no MIS with lights
    bool transmission = false;  //!< wi is on the other side of the surface from wo
};

/** @brief A bidirectional scattering distribution function in its local shading frame.

Created once per material at scene load (never per hit). Spatially varying inputs (a texture's
diffuse colour) arrive through @p diffuse: the models that have a diffuse colour (lambertian
albedo, phong/cook_torrance kd, plastic albedo) use it instead of their constant, the others
ignore it. Values are linear RGB. eval() and pdf() return 0 for delta lobes; sample() may
pick one. Methods are const and thread-safe; they allocate nothing.

Opaque models (all but dielectrics) are two-sided: a wo below the surface (z < 0) reflects like
its mirror image above; wi on the other side from wo gives 0. Dielectrics are in radiance form:
a refracted sample's throughput carries (η_wo/η_wi)², so f(wo, wi)/η_wo² = f(wi, wo)/η_wi².
The models and their formulas are in doc/vbme_render_materials.md.
*/
class CV_EXPORTS Bsdf {
public:
    virtual ~Bsdf();
    /** @brief f(wo, wi) (no cosine factor). */
    virtual Vec3f eval(const Vec3f& wo, const Vec3f& wi, const Vec3f& diffuse) const = 0;
    /** @brief Solid-angle pdf with which sample() returns @p wi given @p wo. */
    virtual float pdf(const Vec3f& wo, const Vec3f& wi, const Vec3f& diffuse) const = 0;
    /** @brief Samples wi given wo.
    @param wo outgoing direction (local frame, unit).
    @param u two uniform numbers in [0,1) for the direction.
    @param u_lobe one uniform number in [0,1) to choose between lobes (reflection/refraction…).
    @param diffuse the diffuse colour at the hit.
    @param s receives the sample.
    @return false if no direction was produced (the path ends). */
    virtual bool sample(const Vec3f& wo, const Vec2f& u, float u_lobe, const Vec3f& diffuse,
                        BsdfSample& s) const = 0;
    /** @brief True when sample() ignores its `u_lobe` (a single lobe): the path tracer then
    does not draw it. */
    virtual bool singleLobe() const { return false; }
    /** @brief True when every lobe is a Dirac delta (next-event estimation is useless). */
    virtual bool isDelta() const { return false; }
    /** @brief True when light can pass through (dielectrics). */
    virtual bool hasTransmission() const { return false; }
    /** @brief Beer–Lambert absorption coefficient per metre inside the object (dielectrics). */
    virtual Vec3f absorption() const { return Vec3f(0, 0, 0); }
    /** @brief The constant diffuse colour of the material (used where no texture applies). */
    virtual Vec3f defaultDiffuse() const { return Vec3f(0, 0, 0); }

    /** @brief The BSDF of a scene-file material. EMISSIVE gives a black BSDF (the
    emission is the light's business). */
    static Ptr<Bsdf> create(const Material& m);
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
