// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Bsdf::create and the non-microfacet models (Lambertian, normalised Phong).
#include "opencv2/vbme/render/bsdf.hpp"

#include <algorithm>
#include <cmath>

#include "bsdf_models.hpp"
#include "sampling.hpp"

namespace cv {
namespace vbme {

Bsdf::~Bsdf() {}

namespace bsdf_detail {
namespace {

using sampling::kInvPi;
using sampling::kPi;

inline Vec3f toF(const Vec3d& v) {
    return Vec3f((float)v[0], (float)v[1], (float)v[2]);
}
inline bool sameHemisphere(const Vec3f& a, const Vec3f& b) {
    return a[2] * b[2] > 0.f;
}

// ---------------------------------------------------------------------------------------------
class Lambertian final : public Bsdf {
public:
    explicit Lambertian(const Vec3f& albedo) : albedo_(albedo) {}
    Vec3f eval(const Vec3f& wo, const Vec3f& wi, const Vec3f& diffuse) const override {
        return lambertianEval(wo, wi, diffuse);
    }
    float pdf(const Vec3f& wo, const Vec3f& wi, const Vec3f&) const override {
        if (!sameHemisphere(wo, wi)) return 0.f;
        return std::abs(wi[2]) * kInvPi;
    }
    bool sample(const Vec3f& wo, const Vec2f& u, float, const Vec3f& diffuse,
                BsdfSample& s) const override {
        return lambertianSample(wo, u, diffuse, s);
    }
    Vec3f defaultDiffuse() const override { return albedo_; }
    bool singleLobe() const override { return true; }

private:
    Vec3f albedo_;
};

// ---------------------------------------------------------------------------------------------
// Normalised (energy-conserving) Phong, Lafortune & Willems 1994:
//   f = kd/π + ks (n+2)/(2π) cos^n α,  α = angle(wi, reflect(wo)),
// sampled by choosing the diffuse lobe with probability pd = mean(kd)/(mean(kd)+mean(ks)), the
// cosine hemisphere for it and the cos^n lobe around the mirror direction otherwise. The
// specular lobe's directional albedo is ≤ ks (part of the lobe falls below the horizon), so
// kd + ks ≤ 1 per channel keeps energy ≤ 1; larger sums are scaled down at construction.
class Phong final : public Bsdf {
public:
    Phong(const Vec3f& kd, const Vec3f& ks, float n) : kd_(kd), ks_(ks), n_(std::max(n, 0.f)) {
        for (int c = 0; c < 3; c++) {
            kd_[c] = std::max(kd_[c], 0.f);
            ks_[c] = std::max(ks_[c], 0.f);
            const float sum = kd_[c] + ks_[c];
            if (sum > 1.f) {
                // Scale both down per channel so that kd + ks = 1.
                kd_[c] /= sum;
                ks_[c] /= sum;
            }
        }
        ks_mean_ = (ks_[0] + ks_[1] + ks_[2]) / 3.f;
    }
    Vec3f eval(const Vec3f& wo, const Vec3f& wi, const Vec3f& diffuse) const override {
        if (!sameHemisphere(wo, wi)) return Vec3f(0, 0, 0);
        return clampKd(diffuse) * kInvPi + ks_ * specLobe(wo, wi);
    }
    float pdf(const Vec3f& wo, const Vec3f& wi, const Vec3f& diffuse) const override {
        if (!sameHemisphere(wo, wi)) return 0.f;
        const float pd = diffuseProb(clampKd(diffuse));
        return pd * std::abs(wi[2]) * kInvPi + (1.f - pd) * specPdf(wo, wi);
    }
    bool sample(const Vec3f& wo, const Vec2f& u, float u_lobe, const Vec3f& diffuse,
                BsdfSample& s) const override {
        if (wo[2] == 0.f) return false;
        const Vec3f kd = clampKd(diffuse);
        const float pd = diffuseProb(kd);
        Vec3f wi;
        if (u_lobe < pd) {
            wi = sampling::squareToCosineHemisphere(u);
            if (wo[2] < 0.f) wi[2] = -wi[2];
        } else {
            // cos^n lobe around the mirror direction r.
            const Vec3f r(-wo[0], -wo[1], wo[2]);
            const float cos_a = std::pow(u[0], 1.f / (n_ + 1.f));
            const float sin_a = std::sqrt(std::max(0.f, 1.f - cos_a * cos_a));
            const float phi = 2.f * kPi * u[1];
            const sampling::Frame fr(r);
            wi = fr.toWorld(Vec3f(sin_a * std::cos(phi), sin_a * std::sin(phi), cos_a));
        }
        if (!sameHemisphere(wo, wi)) return false;
        s.wi = wi;
        s.pdf = pd * std::abs(wi[2]) * kInvPi + (1.f - pd) * specPdf(wo, wi);
        if (!(s.pdf > 0.f)) return false;
        s.f = kd * kInvPi + ks_ * specLobe(wo, wi);
        s.weight = s.f * (std::abs(wi[2]) / s.pdf);
        s.delta = false;
        s.transmission = false;
        return true;
    }
    Vec3f defaultDiffuse() const override { return kd_; }

private:
    // The texture's colour replaces kd, limited to 1 − ks per channel (energy).
    Vec3f clampKd(const Vec3f& d) const { return clampDiffuse(d, ks_); }
    float diffuseProb(const Vec3f& kd) const {
        const float kdm = (kd[0] + kd[1] + kd[2]) / 3.f;
        const float t = kdm + ks_mean_;
        return t > 0.f ? kdm / t : 1.f;
    }
    float cosAlpha(const Vec3f& wo, const Vec3f& wi) const {
        // reflect(wo) about z = (-wo.x, -wo.y, wo.z)
        return std::max(0.f, -wo[0] * wi[0] - wo[1] * wi[1] + wo[2] * wi[2]);
    }
    float specLobe(const Vec3f& wo, const Vec3f& wi) const {
        return (n_ + 2.f) * (0.5f * kInvPi) * std::pow(cosAlpha(wo, wi), n_);
    }
    float specPdf(const Vec3f& wo, const Vec3f& wi) const {
        return (n_ + 1.f) * (0.5f * kInvPi) * std::pow(cosAlpha(wo, wi), n_);
    }

    Vec3f kd_, ks_;
    float n_;
    float ks_mean_;
};

}  // namespace

Ptr<Bsdf> createLambertian(const Vec3f& albedo) {
    return makePtr<Lambertian>(albedo);
}
bool isLambertian(const Bsdf& b) {
    return dynamic_cast<const Lambertian*>(&b) != nullptr;
}
Ptr<Bsdf> createPhong(const Vec3f& kd, const Vec3f& ks, float exponent) {
    return makePtr<Phong>(kd, ks, exponent);
}

}  // namespace bsdf_detail

Ptr<Bsdf> Bsdf::create(const Material& m) {
    using namespace bsdf_detail;
    const float alpha = (float)m.roughness;
    CV_Assert(alpha >= 0.f && "material roughness (microfacet alpha) must be >= 0");
    switch (m.type) {
        case Material::LAMBERTIAN:
            return createLambertian(toF(m.albedo));
        case Material::PHONG:
            CV_Assert(m.exponent >= 0 && "phong exponent must be >= 0");
            return createPhong(toF(m.kd), toF(m.ks), (float)m.exponent);
        case Material::COOK_TORRANCE:
            CV_Assert(m.ior > 0 && "cook_torrance ior must be > 0");
            return createCookTorrance(toF(m.kd), toF(m.ks), alpha, (float)m.ior);
        case Material::CONDUCTOR:
            return createConductor(toF(m.eta), toF(m.k), m.use_colour, toF(m.colour), alpha);
        case Material::DIELECTRIC:
            CV_Assert(m.ior > 0 && "dielectric ior must be > 0");
            return createDielectric((float)m.ior, alpha, toF(m.absorption));
        case Material::PLASTIC:
            CV_Assert(m.ior > 0 && "plastic ior must be > 0");
            return createPlastic(toF(m.albedo), (float)m.ior, alpha);
        case Material::EMISSIVE:
            return createBlack();
    }
    CV_Error(Error::StsBadArg, "Bsdf::create: unknown material type " +
                                   std::to_string((int)m.type) +
                                   " (expected lambertian, phong, cook_torrance, conductor, "
                                   "dielectric, plastic or emissive)");
}

}  // namespace vbme
}  // namespace cv
