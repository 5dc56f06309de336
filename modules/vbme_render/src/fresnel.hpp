// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fresnel equations (private to vbme_render; header-only, inline).
#ifndef VBME_RENDER_FRESNEL_HPP
#define VBME_RENDER_FRESNEL_HPP

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {
namespace fresnel {

/** @brief Unpolarised Fresnel reflectance of a dielectric interface.
@param cos_i cosine between the incident direction and the normal; positive when the light
arrives from the side the normal points to (the "outside", index 1), negative from inside.
@param eta relative index inside/outside (e.g. 1.5 for glass in air).
@param cos_t receives |cos θt| of the refracted direction (0 under total internal reflection).
@param eta_ti receives the ratio η_t/η_i for the actual direction of travel.
@return reflectance in [0,1] (1 under total internal reflection). */
inline float dielectric(float cos_i, float eta, float& cos_t, float& eta_ti) {
    eta_ti = cos_i >= 0.f ? eta : 1.f / eta;
    const float ci = std::min(std::abs(cos_i), 1.f);
    const float sin2_t = (1.f - ci * ci) / (eta_ti * eta_ti);
    if (sin2_t >= 1.f) {
        cos_t = 0.f;
        return 1.f;
    }
    const float ct = std::sqrt(std::max(0.f, 1.f - sin2_t));
    cos_t = ct;
    const float rs = (ci - eta_ti * ct) / (ci + eta_ti * ct);
    const float rp = (eta_ti * ci - ct) / (eta_ti * ci + ct);
    return 0.5f * (rs * rs + rp * rp);
}
/** @brief dielectric() without the by-products. */
inline float dielectric(float cos_i, float eta) {
    float ct, e;
    return dielectric(cos_i, eta, ct, e);
}

/** @brief Unpolarised Fresnel reflectance of a conductor of complex index η + iκ (relative to
the outside medium), for |cos θi| = @p cos_i (exact formula, e.g. PBRT 3rd ed. §8.2.1). */
inline float conductor(float cos_i, float eta, float k) {
    const float c = std::min(std::abs(cos_i), 1.f);
    const float c2 = c * c, s2 = 1.f - c2;
    const float e2 = eta * eta, k2 = k * k;
    const float t0 = e2 - k2 - s2;
    const float a2b2 = std::sqrt(std::max(0.f, t0 * t0 + 4.f * e2 * k2));
    const float t1 = a2b2 + c2;
    const float a = std::sqrt(std::max(0.f, 0.5f * (a2b2 + t0)));
    const float t2 = 2.f * c * a;
    const float rs = (t1 - t2) / std::max(t1 + t2, 1e-12f);
    const float t3 = c2 * a2b2 + s2 * s2;
    const float t4 = t2 * s2;
    const float rp = rs * (t3 - t4) / std::max(t3 + t4, 1e-12f);
    return std::min(std::max(0.5f * (rp + rs), 0.f), 1.f);
}
/** @brief conductor() per RGB channel. */
inline Vec3f conductor(float cos_i, const Vec3f& eta, const Vec3f& k) {
    return Vec3f(conductor(cos_i, eta[0], k[0]), conductor(cos_i, eta[1], k[1]),
                 conductor(cos_i, eta[2], k[2]));
}

/** @brief Schlick's approximation F0 + (1 − F0)(1 − cos)^5 per channel. */
inline Vec3f schlick(float cos_i, const Vec3f& f0) {
    const float m = std::min(std::max(1.f - std::abs(cos_i), 0.f), 1.f);
    const float m5 = (m * m) * (m * m) * m;
    return f0 + (Vec3f(1, 1, 1) - f0) * m5;
}
/** @brief Schlick's approximation, scalar. */
inline float schlick(float cos_i, float f0) {
    const float m = std::min(std::max(1.f - std::abs(cos_i), 0.f), 1.f);
    const float m5 = (m * m) * (m * m) * m;
    return f0 + (1.f - f0) * m5;
}
/** @brief Reflectance at normal incidence of a dielectric of relative index @p eta. */
inline float f0FromIor(float eta) {
    const float r = (eta - 1.f) / (eta + 1.f);
    return r * r;
}

/** @brief Hemispherical average 2∫₀¹ F(μ) μ dμ of the dielectric Fresnel reflectance for
light arriving from the outside of an interface of relative index @p eta (numerical, 1024-point
midpoint rule: call it once, at construction). With 1/eta it gives the internal reflectance
seen from inside. */
inline float diffuseReflectance(float eta) {
    const int n = 1024;
    double s = 0;
    for (int i = 0; i < n; i++) {
        const float mu = (i + 0.5f) / n;
        s += (double)dielectric(mu, eta) * mu;
    }
    return (float)(2.0 * s / n);
}

}  // namespace fresnel
}  // namespace vbme
}  // namespace cv

#endif
