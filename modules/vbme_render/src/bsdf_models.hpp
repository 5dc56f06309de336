// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Factories of the BSDF models behind Bsdf::create (private to vbme_render).
//
// Conventions shared by every model (see doc/vbme_render_materials.md):
// - local shading frame, z = shading normal (outside), wo/wi point away from the surface;
// - opaque models are two-sided: a wo below the surface (z < 0) is handled by mirroring both
//   directions to z > 0, so open meshes and back faces reflect like front faces; wi on the
//   other side of the surface from wo gives f = 0;
// - eval()/pdf() return 0 for delta lobes; sample() returns weight = f·|cos θi|/pdf.
#ifndef VBME_RENDER_BSDF_MODELS_HPP
#define VBME_RENDER_BSDF_MODELS_HPP

#include <algorithm>

#include "opencv2/vbme/render/bsdf.hpp"
#include "sampling.hpp"

namespace cv {
namespace vbme {
namespace bsdf_detail {

/** @brief A texture's diffuse colour limited to [0, 1 − ks] per channel, so that a diffuse plus
specular model does not reflect more than it receives (Phong, Cook-Torrance). */
inline Vec3f clampDiffuse(const Vec3f& d, const Vec3f& ks) {
    return Vec3f(std::min(std::max(d[0], 0.f), 1.f - ks[0]),
                 std::min(std::max(d[1], 0.f), 1.f - ks[1]),
                 std::min(std::max(d[2], 0.f), 1.f - ks[2]));
}

/** @brief Lambertian: f = albedo/π. */
Ptr<Bsdf> createLambertian(const Vec3f& albedo);

/** @brief The Lambertian model's sample() (which calls it), inline: a renderer that knows the
material is Lambertian (isLambertian()) calls it without the virtual call, so that the compiler
keeps the sample in registers and schedules its chain with the caller's. */
inline bool lambertianSample(const Vec3f& wo, const Vec2f& u, const Vec3f& diffuse, BsdfSample& s);
/** @brief The rest of lambertianSample() once its cosine-hemisphere direction @p wi
(sampling::squareToCosineHemisphere of the sample's numbers) is drawn: the path batch's vector
stage draws it for several lanes at once. */
inline bool lambertianFromDirection(const Vec3f& wo, Vec3f wi, const Vec3f& diffuse,
                                    BsdfSample& s) {
    if (wo[2] == 0.f || wi[2] <= 0.f) return false;
    if (wo[2] < 0.f) wi[2] = -wi[2];
    s.wi = wi;
    s.pdf = std::abs(wi[2]) * sampling::kInvPi;
    s.f = diffuse * sampling::kInvPi;
    s.weight = diffuse;
    s.delta = false;
    s.transmission = false;
    return true;
}
inline bool lambertianSample(const Vec3f& wo, const Vec2f& u, const Vec3f& diffuse, BsdfSample& s) {
    if (wo[2] == 0.f) return false;
    return lambertianFromDirection(wo, sampling::squareToCosineHemisphere(u), diffuse, s);
}
/** @brief The Lambertian model's eval() (which calls it), inline. */
inline Vec3f lambertianEval(const Vec3f& wo, const Vec3f& wi, const Vec3f& diffuse) {
    if (!(wo[2] * wi[2] > 0.f)) return Vec3f(0, 0, 0);
    return diffuse * sampling::kInvPi;
}
/** @brief True when @p b was made by createLambertian (its sample() and eval() are
lambertianSample() and lambertianEval()). */
bool isLambertian(const Bsdf& b);
/** @brief Normalised Phong: f = kd/π + ks·(n+2)/(2π)·max(0, cos α)^n, α between wi and the
mirror direction of wo. kd + ks is scaled down per channel to ≤ 1. */
Ptr<Bsdf> createPhong(const Vec3f& kd, const Vec3f& ks, float exponent);
/** @brief Cook–Torrance: kd/π + ks·D_Beckmann·G_CT·F_Schlick/(4 cos θo cos θi). */
Ptr<Bsdf> createCookTorrance(const Vec3f& kd, const Vec3f& ks, float alpha, float ior);
/** @brief GGX conductor; exact Fresnel from (eta, k) or Schlick from @p colour when
@p use_colour; a perfect mirror at alpha = 0. */
Ptr<Bsdf> createConductor(const Vec3f& eta, const Vec3f& k, bool use_colour, const Vec3f& colour,
                          float alpha);
/** @brief Smooth (alpha = 0) or rough (GGX, Walter et al. 2007) dielectric. */
Ptr<Bsdf> createDielectric(float ior, float alpha, const Vec3f& absorption);
/** @brief Diffuse base under a smooth or rough dielectric coat. */
Ptr<Bsdf> createPlastic(const Vec3f& albedo, float ior, float alpha);

/** @brief Black surface (emissive materials): f = 0 whatever the texture; sample() fails. */
Ptr<Bsdf> createBlack();

/** @brief Roughness below which a microfacet model is treated as a perfect specular one. */
constexpr float kSpecularAlpha = 1e-3f;

}  // namespace bsdf_detail
}  // namespace vbme
}  // namespace cv

#endif
