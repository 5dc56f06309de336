// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Isotropic microfacet distributions (private to vbme_render; header-only, inline).
//
// All directions in the local frame (z = macro-surface normal). Microfacet normals m have
// m.z > 0. Distributions are normalised so that ∫ D(m) m.z dω_m = 1.
#ifndef VBME_RENDER_MICROFACET_HPP
#define VBME_RENDER_MICROFACET_HPP

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "sampling.hpp"

namespace cv {
namespace vbme {
namespace microfacet {

using sampling::kPi;

/** @brief GGX / Trowbridge–Reitz distribution (Walter et al. 2007) with Smith masking. */
struct Ggx {
    float alpha;  //!< roughness α (> 0)

    /** @brief D(m). */
    float D(const Vec3f& m) const {
        const float c = m[2];
        if (c <= 0.f) return 0.f;
        const float a2 = alpha * alpha;
        const float t = c * c * (a2 - 1.f) + 1.f;
        return a2 / (kPi * t * t);
    }
    /** @brief Smith Λ(w). */
    float lambda(const Vec3f& w) const {
        const float c2 = w[2] * w[2];
        if (c2 <= 0.f) return 1e30f;
        const float t2 = std::max(0.f, 1.f - c2) / c2;
        return 0.5f * (-1.f + std::sqrt(1.f + alpha * alpha * t2));
    }
    /** @brief Smith masking G1(w) = 1/(1 + Λ(w)). */
    float G1(const Vec3f& w) const { return 1.f / (1.f + lambda(w)); }
    /** @brief Height-correlated masking-shadowing G2 = 1/(1 + Λ(wo) + Λ(wi)) (Heitz 2014). */
    float G2(const Vec3f& wo, const Vec3f& wi) const {
        return 1.f / (1.f + lambda(wo) + lambda(wi));
    }
    /** @brief Samples a visible normal for wo (wo.z > 0) (Heitz 2018, "Sampling the GGX
    distribution of visible normals"). Its density is pdfVisible(wo, m). */
    Vec3f sampleVisible(const Vec3f& wo, const Vec2f& u) const {
        // Stretch to the hemisphere configuration.
        Vec3f vh(alpha * wo[0], alpha * wo[1], wo[2]);
        vh /= (float)cv::norm(vh);
        const float lensq = vh[0] * vh[0] + vh[1] * vh[1];
        const Vec3f t1 =
            lensq > 0.f ? Vec3f(-vh[1], vh[0], 0.f) / std::sqrt(lensq) : Vec3f(1.f, 0.f, 0.f);
        const Vec3f t2 = vh.cross(t1);
        const float r = std::sqrt(u[0]);
        const float phi = 2.f * kPi * u[1];
        const float p1 = r * std::cos(phi);
        float p2 = r * std::sin(phi);
        const float s = 0.5f * (1.f + vh[2]);
        p2 = (1.f - s) * std::sqrt(std::max(0.f, 1.f - p1 * p1)) + s * p2;
        const Vec3f nh = t1 * p1 + t2 * p2 + vh * std::sqrt(std::max(0.f, 1.f - p1 * p1 - p2 * p2));
        Vec3f m(alpha * nh[0], alpha * nh[1], std::max(1e-7f, nh[2]));
        return m / (float)cv::norm(m);
    }
    /** @brief Density of sampleVisible: G1(wo)·max(0, wo·m)·D(m)/wo.z. */
    float pdfVisible(const Vec3f& wo, const Vec3f& m) const {
        if (wo[2] <= 0.f) return 0.f;
        return G1(wo) * std::max(0.f, wo.dot(m)) * D(m) / wo[2];
    }
};

/** @brief Beckmann distribution with the Cook–Torrance V-cavity masking term. */
struct Beckmann {
    float alpha;  //!< roughness α (> 0): RMS slope

    /** @brief D(m) = exp(−tan²θ/α²)/(π α² cos⁴θ). */
    float D(const Vec3f& m) const {
        const float c = m[2];
        if (c <= 0.f) return 0.f;
        const float c2 = c * c;
        const float t2 = std::max(0.f, 1.f - c2) / c2;
        const float a2 = alpha * alpha;
        return std::exp(-t2 / a2) / (kPi * a2 * c2 * c2);
    }
    /** @brief Cook–Torrance geometric attenuation min(1, 2(n·m)(n·wo)/(wo·m),
    2(n·m)(n·wi)/(wo·m)) (Cook & Torrance 1982; m = half vector, so wo·m = wi·m). */
    static float Gct(const Vec3f& wo, const Vec3f& wi, const Vec3f& m) {
        const float om = std::abs(wo.dot(m));
        if (om <= 0.f) return 0.f;
        const float k = 2.f * std::abs(m[2]) / om;
        return std::min(1.f, std::min(k * std::abs(wo[2]), k * std::abs(wi[2])));
    }
    /** @brief Samples m with density D(m)·m.z (pdfNormal). */
    Vec3f sampleNormal(const Vec2f& u) const {
        const float t2 = -alpha * alpha * std::log(std::max(1.f - u[0], 1e-30f));
        const float c = 1.f / std::sqrt(1.f + t2);
        const float s = std::sqrt(std::max(0.f, 1.f - c * c));
        const float phi = 2.f * kPi * u[1];
        return Vec3f(s * std::cos(phi), s * std::sin(phi), c);
    }
    /** @brief Density of sampleNormal. */
    float pdfNormal(const Vec3f& m) const { return D(m) * std::max(0.f, m[2]); }
};

/** @brief Mirror reflection of @p w about @p m: 2(w·m)m − w. */
inline Vec3f reflect(const Vec3f& w, const Vec3f& m) {
    return m * (2.f * w.dot(m)) - w;
}

/** @brief Refraction of @p w (pointing away, on the side of @p m) through microfacet @p m
with relative index @p eta = η_t/η_i and |cos θt| = @p cos_t (from fresnel::dielectric). */
inline Vec3f refract(const Vec3f& w, const Vec3f& m, float eta, float cos_t) {
    const float c = w.dot(m);
    return -w / eta + m * (c / eta - cos_t);
}

}  // namespace microfacet
}  // namespace vbme
}  // namespace cv

#endif
