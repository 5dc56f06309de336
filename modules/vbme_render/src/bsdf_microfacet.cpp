// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Microfacet and layered models: Cook–Torrance (Beckmann), GGX conductor, smooth/rough
// dielectric, plastic. See doc/vbme_render_materials.md for the formulas.
#include <algorithm>
#include <cmath>
#include <vector>

#include "bsdf_models.hpp"
#include "fresnel.hpp"
#include "microfacet.hpp"
#include "sampling.hpp"

namespace cv {
namespace vbme {
namespace bsdf_detail {
namespace {

using sampling::kInvPi;
using sampling::kPi;

inline float mean3(const Vec3f& v) {
    return (v[0] + v[1] + v[2]) / 3.f;
}
inline Vec3f clamp01(const Vec3f& v) {
    return Vec3f(std::min(std::max(v[0], 0.f), 1.f), std::min(std::max(v[1], 0.f), 1.f),
                 std::min(std::max(v[2], 0.f), 1.f));
}
// Opaque models are two-sided: mirror a configuration seen from below to z > 0.
// Returns false when wo and wi are not on the same side (no reflection possible).
inline bool toUpper(Vec3f& wo, Vec3f& wi) {
    if (wo[2] * wi[2] <= 0.f) return false;
    if (wo[2] < 0.f) {
        wo[2] = -wo[2];
        wi[2] = -wi[2];
    }
    return true;
}
// Fills s from f and pdf (non-delta lobes).
inline bool finish(BsdfSample& s, const Vec3f& wi, const Vec3f& f, float pdf, bool transmission) {
    if (!(pdf > 0.f) || !std::isfinite(pdf)) return false;
    s.wi = wi;
    s.f = f;
    s.pdf = pdf;
    s.weight = f * (std::abs(wi[2]) / pdf);
    s.delta = false;
    s.transmission = transmission;
    return true;
}
// Fills s for a delta lobe chosen with probability @p prob and throughput @p weight.
inline bool finishDelta(BsdfSample& s, const Vec3f& wi, const Vec3f& weight, float prob,
                        bool transmission) {
    const float c = std::abs(wi[2]);
    if (!(prob > 0.f) || c <= 0.f) return false;
    s.wi = wi;
    s.weight = weight;
    s.pdf = prob;
    s.f = weight * (prob / c);
    s.delta = true;
    s.transmission = transmission;
    return true;
}

// ---------------------------------------------------------------------------------------------
// Cook–Torrance (1982) with Walter's normalisation:
//   f = kd/π + ks·F_Schlick(wo·h; F0(ior))·D_Beckmann(h)·G_CT/(4 cos θo cos θi).
// kd + ks ≤ 1 per channel (scaled down at construction; a texture's kd is clamped to 1 − ks).
// At α < kSpecularAlpha the specular lobe becomes a delta mirror of weight ks·F(cos θo).
class CookTorrance final : public Bsdf {
public:
    CookTorrance(const Vec3f& kd, const Vec3f& ks, float alpha, float ior)
        : kd_(clamp01(kd)),
          ks_(clamp01(ks)),
          dist_{std::max(alpha, kSpecularAlpha)},
          f0_(fresnel::f0FromIor(ior)),
          specular_(alpha < kSpecularAlpha) {
        for (int c = 0; c < 3; c++) {
            const float sum = kd_[c] + ks_[c];
            if (sum > 1.f) {
                kd_[c] /= sum;
                ks_[c] /= sum;
            }
        }
        ks_mean_ = mean3(ks_);
    }
    Vec3f eval(const Vec3f& wo_, const Vec3f& wi_, const Vec3f& diffuse) const override {
        Vec3f wo = wo_, wi = wi_;
        if (!toUpper(wo, wi)) return Vec3f(0, 0, 0);
        return clampKd(diffuse) * kInvPi + ks_ * spec(wo, wi);
    }
    float pdf(const Vec3f& wo_, const Vec3f& wi_, const Vec3f& diffuse) const override {
        Vec3f wo = wo_, wi = wi_;
        if (!toUpper(wo, wi)) return 0.f;
        const float ps = specProb(wo, clampKd(diffuse));
        return (1.f - ps) * wi[2] * kInvPi + ps * specPdf(wo, wi);
    }
    bool sample(const Vec3f& wo_, const Vec2f& u, float u_lobe, const Vec3f& diffuse,
                BsdfSample& s) const override {
        if (wo_[2] == 0.f) return false;
        const bool flip = wo_[2] < 0.f;
        const Vec3f wo(wo_[0], wo_[1], std::abs(wo_[2]));
        const Vec3f kd = clampKd(diffuse);
        const float ps = specProb(wo, kd);
        Vec3f wi;
        if (u_lobe < ps && specular_) {
            const Vec3f w = ks_ * (fresnel::schlick(wo[2], f0_) / ps);
            return finishDelta(s, Vec3f(-wo_[0], -wo_[1], wo_[2]), w, ps, false);
        }
        if (u_lobe < ps) {
            const Vec3f m = dist_.sampleNormal(u);
            if (wo.dot(m) <= 0.f) return false;  // back-facing microfacet: pdf() has no mass there
            wi = microfacet::reflect(wo, m);
        } else {
            wi = sampling::squareToCosineHemisphere(u);
        }
        if (wi[2] <= 0.f) return false;
        const float pdf = (1.f - ps) * wi[2] * kInvPi + ps * specPdf(wo, wi);
        const Vec3f f = kd * kInvPi + ks_ * spec(wo, wi);
        if (flip) wi[2] = -wi[2];
        return finish(s, wi, f, pdf, false);
    }
    Vec3f defaultDiffuse() const override { return kd_; }

private:
    Vec3f clampKd(const Vec3f& d) const { return clampDiffuse(d, ks_); }
    // Probability of sampling the specular lobe: its weight ks·F(cos θo) against mean(kd),
    // kept within [0.1, 0.9] when both lobes exist.
    float specProb(const Vec3f& wo, const Vec3f& kd) const {
        const float ws = ks_mean_ * fresnel::schlick(wo[2], f0_);
        const float wd = mean3(kd);
        if (ws <= 0.f) return 0.f;
        if (wd <= 0.f) return 1.f;
        return std::min(std::max(ws / (ws + wd), 0.1f), 0.9f);
    }
    float spec(const Vec3f& wo, const Vec3f& wi) const {
        if (specular_) return 0.f;
        Vec3f h = wo + wi;
        const float l = (float)cv::norm(h);
        if (l <= 0.f) return 0.f;
        h /= l;
        const float F = fresnel::schlick(wo.dot(h), f0_);
        return F * dist_.D(h) * microfacet::Beckmann::Gct(wo, wi, h) / (4.f * wo[2] * wi[2]);
    }
    float specPdf(const Vec3f& wo, const Vec3f& wi) const {
        if (specular_) return 0.f;
        Vec3f h = wo + wi;
        const float l = (float)cv::norm(h);
        if (l <= 0.f) return 0.f;
        h /= l;
        const float oh = wo.dot(h);
        if (oh <= 0.f) return 0.f;
        return dist_.pdfNormal(h) / (4.f * oh);
    }

    Vec3f kd_, ks_;
    microfacet::Beckmann dist_;
    float f0_;
    bool specular_;
    float ks_mean_;
};

// ---------------------------------------------------------------------------------------------
// Conductor: GGX with height-correlated Smith masking, visible-normal sampling; exact
// conductor Fresnel from (eta, k), or Schlick from a colour. Mirror (delta) at α = 0.
class Conductor final : public Bsdf {
public:
    Conductor(const Vec3f& eta, const Vec3f& k, bool use_colour, const Vec3f& colour, float alpha)
        : eta_(eta), k_(k), colour_(clamp01(colour)), dist_{alpha} {
        // Without a complex index (eta = k = 0) the colour is the only description available.
        use_colour_ = use_colour || (eta == Vec3f(0, 0, 0) && k == Vec3f(0, 0, 0));
        specular_ = alpha < kSpecularAlpha;
    }
    Vec3f eval(const Vec3f& wo_, const Vec3f& wi_, const Vec3f&) const override {
        if (specular_) return Vec3f(0, 0, 0);
        Vec3f wo = wo_, wi = wi_;
        if (!toUpper(wo, wi)) return Vec3f(0, 0, 0);
        Vec3f h = wo + wi;
        h /= (float)cv::norm(h);
        return fresnelAt(wo.dot(h)) * (dist_.D(h) * dist_.G2(wo, wi) / (4.f * wo[2] * wi[2]));
    }
    float pdf(const Vec3f& wo_, const Vec3f& wi_, const Vec3f&) const override {
        if (specular_) return 0.f;
        Vec3f wo = wo_, wi = wi_;
        if (!toUpper(wo, wi)) return 0.f;
        Vec3f h = wo + wi;
        h /= (float)cv::norm(h);
        const float oh = wo.dot(h);
        if (oh <= 0.f) return 0.f;
        return dist_.pdfVisible(wo, h) / (4.f * oh);
    }
    bool sample(const Vec3f& wo_, const Vec2f& u, float, const Vec3f&,
                BsdfSample& s) const override {
        if (wo_[2] == 0.f) return false;
        const bool flip = wo_[2] < 0.f;
        const Vec3f wo(wo_[0], wo_[1], std::abs(wo_[2]));
        if (specular_) {
            const Vec3f wi(-wo_[0], -wo_[1], wo_[2]);
            return finishDelta(s, wi, fresnelAt(wo[2]), 1.f, false);
        }
        const Vec3f m = dist_.sampleVisible(wo, u);
        const float om = wo.dot(m);
        Vec3f wi = microfacet::reflect(wo, m);
        if (wi[2] <= 0.f || om <= 0.f) return false;
        const Vec3f F = fresnelAt(om);
        const float pdf = dist_.pdfVisible(wo, m) / (4.f * om);
        const Vec3f f = F * (dist_.D(m) * dist_.G2(wo, wi) / (4.f * wo[2] * wi[2]));
        if (flip) wi[2] = -wi[2];
        if (!finish(s, wi, f, pdf, false)) return false;
        s.weight = F * (dist_.G2(wo, wi) / dist_.G1(wo));  // exact form of f·cos/pdf
        return true;
    }
    bool isDelta() const override { return specular_; }
    Vec3f defaultDiffuse() const override { return Vec3f(0, 0, 0); }

private:
    Vec3f fresnelAt(float c) const {
        return use_colour_ ? fresnel::schlick(c, colour_) : fresnel::conductor(c, eta_, k_);
    }
    Vec3f eta_, k_, colour_;
    bool use_colour_ = false;
    bool specular_ = false;
    microfacet::Ggx dist_;
};

// ---------------------------------------------------------------------------------------------
// Dielectric interface of relative index eta = η_inside/η_outside. Radiance transport: the
// refracted throughput carries (η_wo/η_wi)² (radiance is compressed entering a denser medium).
class Dielectric final : public Bsdf {
public:
    Dielectric(float ior, float alpha, const Vec3f& absorption)
        : eta_(ior), dist_{alpha}, absorption_(absorption) {
        specular_ = alpha < kSpecularAlpha || std::abs(ior - 1.f) < 1e-6f;
    }
    Vec3f eval(const Vec3f& wo, const Vec3f& wi, const Vec3f&) const override {
        if (specular_) return Vec3f(0, 0, 0);
        float f, pdf;
        evalPdf(wo, wi, f, pdf);
        return Vec3f(f, f, f);
    }
    float pdf(const Vec3f& wo, const Vec3f& wi, const Vec3f&) const override {
        if (specular_) return 0.f;
        float f, pdf;
        evalPdf(wo, wi, f, pdf);
        return pdf;
    }
    bool sample(const Vec3f& wo, const Vec2f& u, float u_lobe, const Vec3f&,
                BsdfSample& s) const override {
        if (wo[2] == 0.f) return false;
        if (specular_) {
            float cos_t, eta_ti;
            const float F = fresnel::dielectric(wo[2], eta_, cos_t, eta_ti);
            if (u_lobe < F) {
                return finishDelta(s, Vec3f(-wo[0], -wo[1], wo[2]), Vec3f(1, 1, 1), F, false);
            }
            const Vec3f n(0, 0, wo[2] > 0.f ? 1.f : -1.f);
            const Vec3f wi = microfacet::refract(wo, n, eta_ti, cos_t);
            const float w = 1.f / (eta_ti * eta_ti);
            return finishDelta(s, wi, Vec3f(w, w, w), 1.f - F, true);
        }
        // Rough: work in the frame where wo is above (the distribution is symmetric).
        const float sign = wo[2] > 0.f ? 1.f : -1.f;
        const Vec3f wol(wo[0], wo[1], wo[2] * sign);
        const float eta_ti = wo[2] > 0.f ? eta_ : 1.f / eta_;
        const Vec3f m = dist_.sampleVisible(wol, u);
        const float om = wol.dot(m);
        if (om <= 0.f) return false;
        float cos_t, dummy;
        const float F = fresnel::dielectric(om, eta_ti, cos_t, dummy);
        Vec3f wil;
        bool transmission;
        if (u_lobe < F) {
            wil = microfacet::reflect(wol, m);
            if (wil[2] <= 0.f) return false;
            transmission = false;
        } else {
            wil = microfacet::refract(wol, m, eta_ti, cos_t);
            if (wil[2] >= 0.f) return false;
            transmission = true;
        }
        const Vec3f wi(wil[0], wil[1], wil[2] * sign);
        float f, pdf;
        evalPdf(wo, wi, f, pdf);
        return finish(s, wi, Vec3f(f, f, f), pdf, transmission);
    }
    bool isDelta() const override { return specular_; }
    bool hasTransmission() const override { return true; }
    Vec3f absorption() const override { return absorption_; }

private:
    // Walter et al. 2007 (GGX, height-correlated G2), with visible-normal sampling pdfs.
    void evalPdf(const Vec3f& wo, const Vec3f& wi, float& f, float& pdf) const {
        f = 0.f;
        pdf = 0.f;
        if (wo[2] == 0.f || wi[2] == 0.f) return;
        const float sign = wo[2] > 0.f ? 1.f : -1.f;
        const Vec3f wol(wo[0], wo[1], wo[2] * sign), wil(wi[0], wi[1], wi[2] * sign);
        const float eta_ti = wo[2] > 0.f ? eta_ : 1.f / eta_;
        const bool reflect = wil[2] > 0.f;
        Vec3f m = reflect ? wol + wil : wol + wil * eta_ti;
        const float l = (float)cv::norm(m);
        if (l <= 0.f) return;
        m /= l;
        if (m[2] < 0.f) m = -m;
        const float om = wol.dot(m), im = wil.dot(m);
        // Each direction must lie on the side of the microfacet its hemisphere implies.
        if (om <= 0.f) return;
        if (reflect ? im <= 0.f : im >= 0.f) return;
        float cos_t, dummy;
        const float F = fresnel::dielectric(om, eta_ti, cos_t, dummy);
        const float D = dist_.D(m), G = dist_.G2(wol, wil);
        const float pm = dist_.pdfVisible(wol, m);
        if (reflect) {
            f = F * D * G / (4.f * wol[2] * wil[2]);
            pdf = F * pm / (4.f * om);
        } else {
            const float denom = om + eta_ti * im;
            const float d2 = denom * denom;
            if (d2 <= 0.f) return;
            f = (1.f - F) * D * G * std::abs(im) * om / (std::abs(wil[2]) * wol[2] * d2);
            pdf = (1.f - F) * pm * eta_ti * eta_ti * std::abs(im) / d2;
        }
    }

    float eta_;
    microfacet::Ggx dist_;
    Vec3f absorption_;
    bool specular_ = false;
};

// ---------------------------------------------------------------------------------------------
// Plastic: a Lambertian base of albedo ρ under a dielectric coat (smooth or GGX-rough).
//   f = f_coat + (1 − E(μo))(1 − E(μi))/(π(1 − E_avg)) · ρ_eff,
//   ρ_eff = ρ(1 − F_int)/(1 − ρ F_int),
// with E(μ) the directional albedo of the coat's reflection (F(μ) when smooth, a table
// integrated once when rough), E_avg = 2∫E(μ)μ dμ, and F_int the smooth interface's
// hemispherical reflectance seen from inside (the base's light bounces under the coat). The
// directional albedo is E(μo) + (1 − E(μo))ρ_eff ≤ 1, with equality for ρ = 1.
class Plastic final : public Bsdf {
public:
    Plastic(const Vec3f& albedo, float ior, float alpha)
        : albedo_(clamp01(albedo)), eta_(ior), dist_{alpha} {
        specular_ = alpha < kSpecularAlpha;
        f_int_ = fresnel::diffuseReflectance(1.f / eta_);
        if (!specular_) buildTable();
        // E_avg = 2∫ E(μ) μ dμ of the interpolated function (midpoint rule).
        const int n = 1024;
        double s = 0;
        for (int i = 0; i < n; i++) {
            const float mu = (i + 0.5f) / n;
            s += (double)coatAlbedo(mu) * mu;
        }
        e_avg_ = (float)(2.0 * s / n);
    }
    Vec3f eval(const Vec3f& wo_, const Vec3f& wi_, const Vec3f& diffuse) const override {
        Vec3f wo = wo_, wi = wi_;
        if (!toUpper(wo, wi)) return Vec3f(0, 0, 0);
        return diffusePart(wo, wi, effectiveAlbedo(diffuse)) + Vec3f::all(coat(wo, wi));
    }
    float pdf(const Vec3f& wo_, const Vec3f& wi_, const Vec3f& diffuse) const override {
        Vec3f wo = wo_, wi = wi_;
        if (!toUpper(wo, wi)) return 0.f;
        const float ps = coatProb(wo, effectiveAlbedo(diffuse));
        return (1.f - ps) * wi[2] * kInvPi + (specular_ ? 0.f : ps * coatPdf(wo, wi));
    }
    bool sample(const Vec3f& wo_, const Vec2f& u, float u_lobe, const Vec3f& diffuse,
                BsdfSample& s) const override {
        if (wo_[2] == 0.f) return false;
        const bool flip = wo_[2] < 0.f;
        const Vec3f wo(wo_[0], wo_[1], std::abs(wo_[2]));
        const Vec3f rho = effectiveAlbedo(diffuse);
        const float ps = coatProb(wo, rho);
        Vec3f wi;
        if (u_lobe < ps) {
            if (specular_) {
                const float F = fresnel::dielectric(wo[2], eta_);
                return finishDelta(s, Vec3f(-wo_[0], -wo_[1], wo_[2]), Vec3f::all(F / ps), ps,
                                   false);
            }
            const Vec3f m = dist_.sampleVisible(wo, u);
            if (wo.dot(m) <= 0.f) return false;
            wi = microfacet::reflect(wo, m);
        } else {
            wi = sampling::squareToCosineHemisphere(u);
        }
        if (wi[2] <= 0.f) return false;
        const float pdf = (1.f - ps) * wi[2] * kInvPi + (specular_ ? 0.f : ps * coatPdf(wo, wi));
        const Vec3f f = diffusePart(wo, wi, rho) + Vec3f::all(coat(wo, wi));
        if (flip) wi[2] = -wi[2];
        return finish(s, wi, f, pdf, false);
    }
    Vec3f defaultDiffuse() const override { return albedo_; }

private:
    Vec3f effectiveAlbedo(const Vec3f& d) const {
        const Vec3f r = clamp01(d);
        Vec3f e;
        for (int c = 0; c < 3; c++)
            e[c] = r[c] * (1.f - f_int_) / (1.f - r[c] * f_int_);
        return e;
    }
    // Directional albedo of the coat's reflection for cos θ = mu.
    float coatAlbedo(float mu) const {
        if (specular_) return fresnel::dielectric(mu, eta_);
        const float x = std::min(std::max(mu, 0.f), 1.f) * (kTable - 1);
        const int i = std::min((int)x, kTable - 2);
        const float t = x - i;
        return table_[i] * (1.f - t) + table_[i + 1] * t;
    }
    Vec3f diffusePart(const Vec3f& wo, const Vec3f& wi, const Vec3f& rho) const {
        const float k = (1.f - coatAlbedo(wo[2])) * (1.f - coatAlbedo(wi[2])) /
                        (kPi * std::max(1.f - e_avg_, 1e-6f));
        return rho * k;
    }
    float coat(const Vec3f& wo, const Vec3f& wi) const {
        if (specular_) return 0.f;
        Vec3f h = wo + wi;
        h /= (float)cv::norm(h);
        const float F = fresnel::dielectric(wo.dot(h), eta_);
        return F * dist_.D(h) * dist_.G2(wo, wi) / (4.f * wo[2] * wi[2]);
    }
    float coatPdf(const Vec3f& wo, const Vec3f& wi) const {
        Vec3f h = wo + wi;
        h /= (float)cv::norm(h);
        const float oh = wo.dot(h);
        if (oh <= 0.f) return 0.f;
        return dist_.pdfVisible(wo, h) / (4.f * oh);
    }
    // Coat sampled in proportion to its albedo against the base's, within [0.1, 0.9].
    float coatProb(const Vec3f& wo, const Vec3f& rho) const {
        const float e = coatAlbedo(wo[2]);
        const float d = (1.f - e) * mean3(rho);
        if (d <= 0.f) return 1.f;
        return std::min(std::max(e / (e + d), 0.1f), 0.9f);
    }
    // E(μ) at kTable equally spaced μ ∈ [0,1], by stratified visible-normal sampling:
    // E(μ) = E_m[F(wo·m)·G2/G1].
    void buildTable() {
        const int n = 32;  // n×n strata
        for (int i = 0; i < kTable; i++) {
            const float mu = std::max((float)i / (kTable - 1), 1e-3f);
            const Vec3f wo(std::sqrt(std::max(0.f, 1.f - mu * mu)), 0.f, mu);
            double s = 0;
            for (int a = 0; a < n; a++)
                for (int b = 0; b < n; b++) {
                    const Vec2f u((a + 0.5f) / n, (b + 0.5f) / n);
                    const Vec3f m = dist_.sampleVisible(wo, u);
                    const Vec3f wi = microfacet::reflect(wo, m);
                    if (wi[2] <= 0.f) continue;
                    s += fresnel::dielectric(wo.dot(m), eta_) * dist_.G2(wo, wi) / dist_.G1(wo);
                }
            table_[i] = (float)(s / (n * n));
        }
    }

    static constexpr int kTable = 32;
    Vec3f albedo_;
    float eta_;
    microfacet::Ggx dist_;
    bool specular_ = false;
    float f_int_ = 0.f, e_avg_ = 0.f;
    float table_[kTable] = {};
};

// Emissive surfaces: black whatever the texture says.
class Black final : public Bsdf {
public:
    Vec3f eval(const Vec3f&, const Vec3f&, const Vec3f&) const override { return Vec3f(0, 0, 0); }
    float pdf(const Vec3f&, const Vec3f&, const Vec3f&) const override { return 0.f; }
    bool sample(const Vec3f&, const Vec2f&, float, const Vec3f&, BsdfSample&) const override {
        return false;
    }
};

}  // namespace

Ptr<Bsdf> createCookTorrance(const Vec3f& kd, const Vec3f& ks, float alpha, float ior) {
    return makePtr<CookTorrance>(kd, ks, alpha, ior);
}
Ptr<Bsdf> createConductor(const Vec3f& eta, const Vec3f& k, bool use_colour, const Vec3f& colour,
                          float alpha) {
    return makePtr<Conductor>(eta, k, use_colour, colour, alpha);
}
Ptr<Bsdf> createDielectric(float ior, float alpha, const Vec3f& absorption) {
    return makePtr<Dielectric>(ior, alpha, absorption);
}
Ptr<Bsdf> createPlastic(const Vec3f& albedo, float ior, float alpha) {
    return makePtr<Plastic>(albedo, ior, alpha);
}
Ptr<Bsdf> createBlack() {
    return makePtr<Black>();
}

}  // namespace bsdf_detail
}  // namespace vbme
}  // namespace cv
