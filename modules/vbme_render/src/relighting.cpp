// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Image-space re-rendering of a recovered object (material editing): the shaders of Khan et
// al. 2006 over the vbme_render BSDFs, and lighting fitted to the original object's shading.
#include "opencv2/vbme/render/relighting.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/core/utility.hpp>

#include "opencv2/vbme/core/utility.hpp"

#include "opencv2/vbme/render/camera.hpp"
#include "opencv2/vbme/render/sampler.hpp"
#include "sampling.hpp"

namespace cv {
namespace vbme {

namespace {

constexpr float kPi = 3.14159265358979f;
// Ramamoorthi & Hanrahan 2001: convolution of the clamped cosine with Y_lm, per band.
constexpr float kAhat[3] = {3.14159265f, 2.09439510f, 0.78539816f};
constexpr int kBand[9] = {0, 1, 1, 1, 2, 2, 2, 2, 2};

inline Vec3f bgr2rgb(const Vec3f& v) {
    return Vec3f(v[2], v[1], v[0]);
}
inline Vec3f mul(const Vec3f& a, const Vec3f& b) {
    return Vec3f(a[0] * b[0], a[1] * b[1], a[2] * b[2]);
}
inline Vec3f normalized(const Vec3f& v) {
    const float l = std::sqrt(v.dot(v));
    return l > 0 ? v / l : v;
}

// Fresnel reflectance of a smooth dielectric interface; cos_i > 0 on the side of index eta_i.
float fresnelDielectric(float cos_i, float eta_i, float eta_t) {
    cos_i = std::min(1.f, std::max(0.f, cos_i));
    const float sin_t = eta_i / eta_t * std::sqrt(std::max(0.f, 1.f - cos_i * cos_i));
    if (sin_t >= 1.f) return 1.f;
    const float cos_t = std::sqrt(std::max(0.f, 1.f - sin_t * sin_t));
    const float rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    const float rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    return 0.5f * (rs * rs + rp * rp);
}

// Refracts the unit direction v (travelling) at a surface of unit normal n facing against v
// (v·n < 0), eta = eta_from / eta_to. False on total internal reflection.
bool refractDir(const Vec3f& v, const Vec3f& n, float eta, Vec3f& t) {
    const float c = -v.dot(n);
    const float k = 1.f - eta * eta * (1.f - c * c);
    if (k < 0.f) return false;
    t = normalized(v * eta + n * (eta * c - std::sqrt(k)));
    return true;
}

inline Vec3f reflectDir(const Vec3f& wo, const Vec3f& n) {
    return n * (2.f * n.dot(wo)) - wo;
}

Vec3f rgbOf(const Vec3d& v) {
    return Vec3f((float)v[0], (float)v[1], (float)v[2]);
}

// Solves the symmetric system A x = b (n ≤ 9) by Cholesky through cv::solve.
void solveNormal(const Matx<double, 9, 9>& A, const Matx<double, 9, 1>& b, int n, double* x) {
    Mat a(n, n, CV_64F), bb(n, 1, CV_64F), xx;
    for (int i = 0; i < n; i++) {
        bb.at<double>(i) = b(i);
        for (int j = 0; j < n; j++)
            a.at<double>(i, j) = A(i, j);
    }
    if (!cv::solve(a, bb, xx, DECOMP_CHOLESKY)) cv::solve(a, bb, xx, DECOMP_SVD);
    for (int i = 0; i < n; i++)
        x[i] = xx.at<double>(i);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Spherical harmonics

void SHLighting::basis(const Vec3f& d, float y[9]) {
    const float x = d[0], yy = d[1], z = d[2];
    y[0] = 0.282095f;
    y[1] = 0.488603f * yy;
    y[2] = 0.488603f * z;
    y[3] = 0.488603f * x;
    y[4] = 1.092548f * x * yy;
    y[5] = 1.092548f * yy * z;
    y[6] = 0.315392f * (3.f * z * z - 1.f);
    y[7] = 1.092548f * x * z;
    y[8] = 0.546274f * (x * x - yy * yy);
}

Vec3f SHLighting::radiance(const Vec3f& d) const {
    float y[9];
    basis(d, y);
    Vec3f s(0, 0, 0);
    for (int i = 0; i < 9; i++)
        s += coeffs[i] * y[i];
    return Vec3f(std::max(s[0], 0.f), std::max(s[1], 0.f), std::max(s[2], 0.f));
}

Vec3f SHLighting::irradiance(const Vec3f& n) const {
    float y[9];
    basis(n, y);
    Vec3f s(0, 0, 0);
    for (int i = 0; i < 9; i++)
        s += coeffs[i] * (kAhat[kBand[i]] * y[i]);
    return Vec3f(std::max(s[0], 0.f), std::max(s[1], 0.f), std::max(s[2], 0.f));
}

// ---------------------------------------------------------------------------------------------
// Lighting fit

namespace {

struct FitSample {
    Vec3f n;
    Vec3f rgb;
    float lum;
};

// Residual of lum ≈ a + b·max(0, n·d) with (a, b) solved in closed form (b ≥ 0).
double directionalResidual(const std::vector<FitSample>& s, const Vec3f& d, double* a_out,
                           double* b_out) {
    double sx = 0, sxx = 0, sy = 0, sxy = 0, syy = 0;
    const double N = (double)s.size();
    for (const FitSample& q : s) {
        const double x = std::max(0.f, q.n.dot(d));
        sx += x;
        sxx += x * x;
        sy += q.lum;
        sxy += x * q.lum;
        syy += (double)q.lum * q.lum;
    }
    const double det = N * sxx - sx * sx;
    double a, b;
    if (det <= 1e-9 * N * N) {
        b = 0;
        a = sy / N;
    } else {
        b = (N * sxy - sx * sy) / det;
        a = (sy - b * sx) / N;
        if (b < 0) {
            b = 0;
            a = sy / N;
        }
    }
    if (a_out) *a_out = a;
    if (b_out) *b_out = b;
    // Σ (y − a − b x)²
    return syy + a * a * N + b * b * sxx - 2 * a * sy - 2 * b * sxy + 2 * a * b * sx;
}

Vec3f fromAngles(double theta, double phi) {
    return Vec3f((float)(std::sin(theta) * std::cos(phi)), (float)(std::sin(theta) * std::sin(phi)),
                 (float)std::cos(theta));
}

// Coarse-to-fine search of the direction minimising the directional residual.
Vec3f searchDirection(const std::vector<FitSample>& s, const Vec3f& start) {
    std::vector<Vec3f> starts = {start};
    // A few more starts against local minima (the residual is flat where n·d ≤ 0 everywhere).
    for (int i = 0; i < 14; i++) {
        const double z = 1.0 - (i + 0.5) * 2.0 / 14.0, r = std::sqrt(std::max(0.0, 1 - z * z));
        const double ph = i * 2.399963;
        starts.push_back(Vec3f((float)(r * std::cos(ph)), (float)(r * std::sin(ph)), (float)z));
    }
    Vec3f best = start;
    double best_e = std::numeric_limits<double>::max();
    for (const Vec3f& s0 : starts) {
        const double e = directionalResidual(s, normalized(s0), nullptr, nullptr);
        if (e < best_e) {
            best_e = e;
            best = normalized(s0);
        }
    }
    double theta = std::acos(std::min(1.f, std::max(-1.f, best[2])));
    double phi = std::atan2(best[1], best[0]);
    for (double step = 0.3; step > 5e-4;) {
        bool moved = false;
        for (int k = 0; k < 8; k++) {
            const double a = k * kPi / 4;
            const double t = theta + step * std::cos(a);
            const double st = std::max(0.05, std::sin(theta));
            const double p = phi + step * std::sin(a) / st;
            const double e = directionalResidual(s, fromAngles(t, p), nullptr, nullptr);
            if (e < best_e) {
                best_e = e;
                theta = t;
                phi = p;
                moved = true;
            }
        }
        if (!moved) step *= 0.5;
    }
    return fromAngles(theta, phi);
}

}  // namespace

LightingFit fitLighting(InputArray linear_, InputArray normals_, InputArray mask_,
                        const LightFitParams& p) {
    const Mat img = linear_.getMat(), nrm = normals_.getMat(), mask = mask_.getMat();
    CV_Assert(img.type() == CV_32FC3 &&
              "fitLighting: expected a linear CV_32FC3 image (linearise the frame first)");
    CV_Assert(nrm.type() == CV_32FC3 && nrm.size() == img.size() &&
              "fitLighting: expected CV_32FC3 normals of the image's size");
    CV_Assert((mask.empty() || (mask.type() == CV_8U && mask.size() == img.size())) &&
              "fitLighting: the mask must be empty or CV_8U of the image's size");
    CV_Assert(p.albedo_max > 0 && p.max_pixels > 0 && "fitLighting: invalid parameters");

    auto usable = [&](int y, int x) {
        if (!mask.empty() && !mask.at<uchar>(y, x)) return false;
        const Vec3f n = nrm.at<Vec3f>(y, x);
        if (n.dot(n) < 0.25f || std::abs(n[2]) < p.min_facing) return false;
        const Vec3f c = img.at<Vec3f>(y, x);
        return c[0] <= p.max_value && c[1] <= p.max_value && c[2] <= p.max_value;
    };
    int count = 0;
    for (int y = 0; y < img.rows; y++)
        for (int x = 0; x < img.cols; x++)
            count += usable(y, x);
    if (count < 20)
        CV_Error(Error::StsBadArg,
                 format("fitLighting: only %d usable object pixels (expected at least 20 "
                        "unclipped pixels with normals facing the camera)",
                        count));
    const double stride = std::max(1.0, (double)count / p.max_pixels);
    std::vector<FitSample> s;
    s.reserve(std::min(count, p.max_pixels) + 1);
    double next = 0;
    int k = 0;
    for (int y = 0; y < img.rows; y++)
        for (int x = 0; x < img.cols; x++) {
            if (!usable(y, x)) continue;
            if (k++ + 1e-9 < next) continue;
            next += stride;
            const Vec3f rgb = bgr2rgb(img.at<Vec3f>(y, x));
            s.push_back({normalized(nrm.at<Vec3f>(y, x)), rgb,
                         0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2]});
        }

    LightingFit fit;
    fit.pixels = (int)s.size();
    const int N = (int)s.size();
    std::vector<float> Y((size_t)N * 9);
    for (int i = 0; i < N; i++)
        SHLighting::basis(s[i].n, &Y[(size_t)i * 9]);

    // Plain SH fit of the observed radiance per channel (small ridge on orders ≥ 1).
    auto shFit = [&](auto value, Vec3f out[9]) {
        Matx<double, 9, 9> A = Matx<double, 9, 9>::zeros();
        Matx<double, 9, 3> B = Matx<double, 9, 3>::zeros();
        for (int i = 0; i < N; i++) {
            const float* y = &Y[(size_t)i * 9];
            const Vec3f v = value(i);
            for (int a = 0; a < 9; a++) {
                for (int b = 0; b < 9; b++)
                    A(a, b) += (double)y[a] * y[b];
                for (int c = 0; c < 3; c++)
                    B(a, c) += (double)y[a] * v[c];
            }
        }
        for (int a = 1; a < 9; a++)
            A(a, a) += p.ridge * N;
        for (int c = 0; c < 3; c++) {
            Matx<double, 9, 1> b;
            for (int a = 0; a < 9; a++)
                b(a) = B(a, c);
            double x[9];
            solveNormal(A, b, 9, x);
            for (int a = 0; a < 9; a++)
                out[a][c] = (float)x[a];
        }
    };
    shFit([&](int i) { return s[i].rgb; }, fit.shading.coeffs);

    // Dominant direction: the first-order moment of the fitted lighting, refined.
    Vec3f d;
    if (p.fixed_direction) {
        d = normalized(p.fixed_to_light);
        CV_Assert(d.dot(d) > 0.5f && "fitLighting: the fixed light direction must be non-zero");
    } else {
        auto lum = [](const Vec3f& c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; };
        Vec3f d0(lum(fit.shading.coeffs[3]), lum(fit.shading.coeffs[1]),
                 lum(fit.shading.coeffs[2]));
        if (d0.dot(d0) < 1e-12f) d0 = Vec3f(0, 0, -1);
        d = searchDirection(s, normalized(d0));
    }
    fit.to_light = d;

    // Per channel: constant ambient + directional strength, then SH of the residual.
    Vec3f a0, b0;
    for (int c = 0; c < 3; c++) {
        double sx = 0, sxx = 0, sy = 0, sxy = 0;
        for (const FitSample& q : s) {
            const double x = std::max(0.f, q.n.dot(d));
            sx += x;
            sxx += x * x;
            sy += q.rgb[c];
            sxy += x * q.rgb[c];
        }
        const double det = N * sxx - sx * sx;
        double b = det > 1e-9 * N * N ? (N * sxy - sx * sy) / det : 0;
        if (b < 0) b = 0;
        a0[c] = (float)((sy - b * sx) / N);
        b0[c] = (float)b;
    }
    Vec3f res_sh[9];
    shFit(
        [&](int i) {
            const float x = std::max(0.f, s[i].n.dot(d));
            return s[i].rgb - a0 - b0 * x;
        },
        res_sh);
    res_sh[0] += a0 * (1.f / 0.282095f);

    // Albedo and light (scale ambiguity resolved by albedo_max; white key light).
    const float bmax = std::max(b0[0], std::max(b0[1], b0[2]));
    Vec3f chroma = bmax > 1e-6f ? b0 / bmax : Vec3f(0, 0, 0);
    if (bmax <= 1e-6f) {
        const Vec3f amb = res_sh[0];
        const float m = std::max(amb[0], std::max(amb[1], amb[2]));
        chroma = m > 1e-9f ? amb / m : Vec3f(1, 1, 1);
    }
    for (int c = 0; c < 3; c++)
        fit.albedo[c] = std::max(1e-3f, p.albedo_max * chroma[c]);
    const float e = bmax > 1e-6f ? kPi * bmax / p.albedo_max : 0.f;
    fit.irradiance = Vec3f(e, e, e);
    for (int i = 0; i < 9; i++)
        for (int c = 0; c < 3; c++)
            fit.ambient.coeffs[i][c] = kPi * res_sh[i][c] / (fit.albedo[c] * kAhat[kBand[i]]);

    double err = 0;
    for (int i = 0; i < N; i++) {
        const float* y = &Y[(size_t)i * 9];
        const float x = std::max(0.f, s[i].n.dot(d));
        for (int c = 0; c < 3; c++) {
            double m = b0[c] * x;
            for (int a = 0; a < 9; a++)
                m += res_sh[a][c] * y[a];
            err += (m - s[i].rgb[c]) * (m - s[i].rgb[c]);
        }
    }
    fit.rms = std::sqrt(err / (3.0 * N));
    return fit;
}

// ---------------------------------------------------------------------------------------------
// Shaders

Shader::~Shader() {}

// The shaders' state lives here, out of the public header: each public shader holds a
// Ptr<Impl> and forwards to it.

class LightShader::Impl {
public:
    Impl(const Material& m, const Vec3f& to_light, const Vec3f& irradiance);
    Vec3f shade(const ShadingPoint& p) const;

private:
    Ptr<Bsdf> bsdf_;
    Vec3f diffuse_, dir_, E_;
};

class AreaLightShader::Impl {
public:
    Impl(const Material& m, const Vec3f& to_light, const Vec3f& irradiance, float half_angle,
         int samples);
    Vec3f shade(const ShadingPoint& p) const;

private:
    Ptr<Bsdf> bsdf_;
    Vec3f diffuse_, dir_, L_;
    float cos_max_, solid_angle_;
    int samples_;
    float ior_;
    bool spec_only_ = false;
    float cos_lobe_ = -1.f;
    float cos_mis_ = -2.f;
};

class ImageShader::Impl {
public:
    Impl(const Material& m, const EnvironmentMap* env, const SHLighting* sh,
         const SphereRefraction* refraction, const Params& params);
    Vec3f shade(const ShadingPoint& p) const;
    Vec3f environment(const Vec3f& d) const;

private:
    Vec3f refracted(const ShadingPoint& p, const Vec3f& wi_in) const;
    Material m_;
    Ptr<Bsdf> bsdf_;
    Vec3f diffuse_;
    const EnvironmentMap* env_;
    const SHLighting* sh_;
    const SphereRefraction* refr_;
    Params p_;
    int nsamples_ = 1;
};

LightShader::LightShader(const Material& m, const Vec3f& to_light, const Vec3f& irradiance)
    : impl_(makePtr<Impl>(m, to_light, irradiance)) {}

Vec3f LightShader::shade(const ShadingPoint& p) const {
    return impl_->shade(p);
}

AreaLightShader::AreaLightShader(const Material& m, const Vec3f& to_light, const Vec3f& irradiance,
                                 float half_angle, int samples)
    : impl_(makePtr<Impl>(m, to_light, irradiance, half_angle, samples)) {}

Vec3f AreaLightShader::shade(const ShadingPoint& p) const {
    return impl_->shade(p);
}

ImageShader::ImageShader(const Material& m, const EnvironmentMap* env, const SHLighting* sh,
                         const SphereRefraction* refraction, const Params& params)
    : impl_(makePtr<Impl>(m, env, sh, refraction, params)) {}

Vec3f ImageShader::shade(const ShadingPoint& p) const {
    return impl_->shade(p);
}

Vec3f ImageShader::environment(const Vec3f& d) const {
    return impl_->environment(d);
}

LightShader::Impl::Impl(const Material& m, const Vec3f& to_light, const Vec3f& irradiance)
    : bsdf_(Bsdf::create(m)), dir_(normalized(to_light)), E_(irradiance) {
    diffuse_ = bsdf_->defaultDiffuse();
}

Vec3f LightShader::Impl::shade(const ShadingPoint& p) const {
    const sampling::Frame F(p.n);
    const Vec3f wo = F.toLocal(p.wo), wi = F.toLocal(dir_);
    if (wi[2] * wo[2] <= 0.f) return Vec3f(0, 0, 0);
    return mul(bsdf_->eval(wo, wi, diffuse_), E_) * std::abs(wi[2]);
}

AreaLightShader::Impl::Impl(const Material& m, const Vec3f& to_light, const Vec3f& irradiance,
                            float half_angle, int samples)
    : bsdf_(Bsdf::create(m)),
      dir_(normalized(to_light)),
      samples_(std::max(1, samples)),
      ior_((float)m.ior) {
    CV_Assert(half_angle > 0 && half_angle < 1.5f &&
              "AreaLightShader: the half-angle must be in (0, 1.5) radians");
    diffuse_ = bsdf_->defaultDiffuse();
    cos_max_ = std::cos(half_angle);
    solid_angle_ = 2.f * kPi * (1.f - cos_max_);
    // A small disk of radiance L and solid angle Ω gives irradiance ≈ L·Ω at normal incidence.
    L_ = irradiance / solid_angle_;
    // GGX conductors: the reflected lobe is about 2α wide; beyond 10 widths its value is
    // negligible (< 1e-4 of the peak), so those pixels skip the light entirely.
    spec_only_ = m.type == Material::CONDUCTOR && m.roughness < 0.1;
    cos_lobe_ = std::cos(std::min(3.1f, half_angle + 20.f * (float)m.roughness + 0.01f));
    // Beyond ~10α (in the reflected direction) a GGX/Beckmann/Phong-like lobe's pdf is far
    // below 1 sr⁻¹ (α = 0.05 at 0.55 rad: ≈ 0.05); rough lobes (α ≥ 0.3) never skip.
    const bool glossy = m.type == Material::PHONG ? m.exponent >= 20 : m.roughness < 0.3;
    cos_mis_ = glossy ? std::cos(std::min(3.1f, half_angle + 10.f * (float)m.roughness +
                                                    (m.type == Material::PHONG ? 0.6f : 0.05f)))
                      : -2.f;
}

namespace {
// MIS weight of the light-sampling strategy: the balance heuristic, cut off to 1 (0) where
// one pdf exceeds the other 50-fold — so that a broad lobe's rare BSDF samples that land in a
// small light do not make fireflies (the weights of both strategies still sum to 1).
inline float lightWeight(float pdf_l, float pdf_b) {
    if (pdf_l >= 50.f * pdf_b) return 1.f;
    if (pdf_b >= 50.f * pdf_l) return 0.f;
    return pdf_l / (pdf_l + pdf_b);
}
}  // namespace

Vec3f AreaLightShader::Impl::shade(const ShadingPoint& p) const {
    static const SobolSampler sampler(0x5eed);
    const uint64 key = sampler.pixelKey(Point(cvRound(p.pixel.x * 4), cvRound(p.pixel.y * 4)));
    const sampling::Frame F(p.n), L(dir_);
    const Vec3f wo = F.toLocal(p.wo);
    if (bsdf_->isDelta() || bsdf_->hasTransmission()) {
        // Smooth mirror or glass: the light's reflection, deterministically (a sampled lobe
        // choice would leave isolated dots).
        const Vec3f r = reflectDir(p.wo, p.n);
        if (r.dot(dir_) < cos_max_ || p.n.dot(p.wo) <= 0.f) return Vec3f(0, 0, 0);
        if (bsdf_->hasTransmission()) {
            const float F = fresnelDielectric(p.n.dot(p.wo), 1.f, ior_);
            return L_ * F;
        }
        BsdfSample bs;
        if (!bsdf_->sample(wo, Vec2f(0.5f, 0.5f), 0.f, diffuse_, bs)) return Vec3f(0, 0, 0);
        return mul(bs.weight, L_);
    }
    if (spec_only_) {
        // A narrow single-lobe conductor reflects the light only near the mirror direction.
        if (reflectDir(p.wo, p.n).dot(dir_) < cos_lobe_) return Vec3f(0, 0, 0);
    }
    const float pdf_l = 1.f / solid_angle_;
    // Far from the glossy lobe every direction of the light has a BSDF pdf below pdf_l/50
    // (the diffuse pdf is at most 1/π): the light strategy's weight is then 1 and the BSDF
    // samples' 0, so both the pdf evaluations and the BSDF samples can be skipped.
    const bool light_only = pdf_l >= 50.f / kPi && reflectDir(p.wo, p.n).dot(dir_) < cos_mis_;
    Vec3f acc(0, 0, 0);
    for (int i = 0; i < samples_; i++) {
        // Light sample.
        const Vec3f wl =
            L.toWorld(sampling::squareToUniformCone(sampler.get2D(key, i, 0), cos_max_));
        const Vec3f wi = F.toLocal(wl);
        if (wi[2] * wo[2] > 0.f) {
            const Vec3f f = bsdf_->eval(wo, wi, diffuse_);
            const float w = light_only ? 1.f : lightWeight(pdf_l, bsdf_->pdf(wo, wi, diffuse_));
            acc += mul(f, L_) * (std::abs(wi[2]) * w / pdf_l);
        }
        if (light_only) continue;
        // BSDF sample.
        BsdfSample bs;
        if (bsdf_->sample(wo, sampler.get2D(key, i, 2), sampler.get1D(key, i, 4), diffuse_, bs) &&
            !bs.transmission) {
            const Vec3f w = F.toWorld(bs.wi);
            if (w.dot(dir_) >= cos_max_) {
                if (bs.delta)
                    acc += mul(bs.weight, L_);
                else
                    acc += mul(bs.weight, L_) * (1.f - lightWeight(pdf_l, bs.pdf));
            }
        }
    }
    return acc / (float)samples_;
}

ImageShader::Impl::Impl(const Material& m, const EnvironmentMap* env, const SHLighting* sh,
                        const SphereRefraction* refraction, const Params& params)
    : m_(m), bsdf_(Bsdf::create(m)), env_(env), sh_(sh), refr_(refraction), p_(params) {
    CV_Assert((env || sh) && "ImageShader: needs an environment map or SH lighting");
    CV_Assert(p_.samples > 0 && "ImageShader: samples must be > 0");
    diffuse_ = bsdf_->defaultDiffuse();
    // A conductor lobe narrower than the environment's detail (α < mirror_roughness) is
    // taken as a mirror: one exact look-up instead of noisy samples of the lobe's long tail.
    nsamples_ = p_.samples;
    if (m.type == Material::CONDUCTOR && m.roughness < p_.mirror_roughness) {
        Material mirror = m;
        mirror.roughness = 0;
        bsdf_ = Bsdf::create(mirror);
        nsamples_ = 1;
    }
}

Vec3f ImageShader::Impl::environment(const Vec3f& d) const {
    if (env_) return env_->eval(normalized(p_.world_from_camera * d));
    return sh_->radiance(d);
}

Vec3f ImageShader::Impl::refracted(const ShadingPoint& p, const Vec3f& wi_in) const {
    // wi_in: the refracted direction inside the object at the entry point.
    if (!refr_ || refr_->background.empty() || refr_->radius <= 0 || refr_->focal <= 0)
        return environment(wi_in);
    const SphereRefraction& r = *refr_;
    const Mat& bg = r.background;
    const float f = (float)r.focal, ppx = 0.5f * (bg.cols - 1), ppy = 0.5f * (bg.rows - 1);
    // A unit sphere at the depth where it projects with the disk's radius.
    const float zc = f / r.radius;
    const Vec3f C(zc * (r.center.x - ppx) / f, zc * (r.center.y - ppy) / f, zc);
    const float ior = (float)m_.ior;
    const Vec3f P = C + p.n;
    const float s = -2.f * p.n.dot(wi_in);
    if (s <= 0.f) return environment(wi_in);
    const Vec3f P2 = P + wi_in * s;
    const Vec3f n2 = normalized(P2 - C);
    Vec3f e;
    float weight;
    if (refractDir(wi_in, -n2, ior, e)) {
        weight = 1.f - fresnelDielectric(wi_in.dot(n2), ior, 1.f);
    } else {
        return Vec3f(0, 0, 0);  // total internal reflection: not followed further
    }
    const float zp = zc + r.background_depth;
    if (e[2] > 1e-4f) {
        const Vec3f X = P2 + e * ((zp - P2[2]) / e[2]);
        const float x = ppx + f * X[0] / X[2], y = ppy + f * X[1] / X[2];
        if (x >= 0 && y >= 0 && x <= bg.cols - 1 && y <= bg.rows - 1)
            return bgr2rgb(bilinear<Vec3f>(bg, x, y)) * weight;
    }
    return environment(e) * weight;
}

Vec3f ImageShader::Impl::shade(const ShadingPoint& p) const {
    if (m_.type == Material::LAMBERTIAN && sh_)
        return mul(rgbOf(m_.albedo), sh_->irradiance(p.n)) * (1.f / kPi);
    if (m_.type == Material::DIELECTRIC) {
        // Smooth glass: Fresnel split into the reflection and the twice-refracted ray.
        const float c = p.n.dot(p.wo);
        if (c <= 0.f) return environment(reflectDir(p.wo, p.n));
        const float F = fresnelDielectric(c, 1.f, (float)m_.ior);
        const Vec3f refl = environment(reflectDir(p.wo, p.n));
        Vec3f t;
        Vec3f trans(0, 0, 0);
        if (refractDir(-p.wo, p.n, 1.f / (float)m_.ior, t)) trans = refracted(p, t);
        return refl * F + trans * (1.f - F);
    }
    const sampling::Frame F(p.n);
    const Vec3f wo = F.toLocal(p.wo);
    BsdfSample bs;
    if (bsdf_->isDelta()) {
        if (!bsdf_->sample(wo, Vec2f(0.5f, 0.5f), 0.5f, diffuse_, bs)) return Vec3f(0, 0, 0);
        return mul(bs.weight, environment(F.toWorld(bs.wi)));
    }
    static const SobolSampler sampler(0x1a6e);
    const uint64 key = sampler.pixelKey(Point(cvRound(p.pixel.x * 4), cvRound(p.pixel.y * 4)));
    Vec3f acc(0, 0, 0);
    const int n = nsamples_;
    for (int i = 0; i < n; i++) {
        if (!bsdf_->sample(wo, sampler.get2D(key, i, 0), sampler.get1D(key, i, 2), diffuse_, bs))
            continue;
        if (bs.transmission) continue;
        const Vec3f d = F.toWorld(bs.wi);
        const bool sharp = bs.delta || bs.pdf >= p_.sharp_pdf;
        const Vec3f L = (sh_ && (!sharp || !env_)) ? sh_->radiance(d) : environment(d);
        acc += mul(bs.weight, L);
    }
    return acc / (float)n;
}

void CombinationShader::add(const Ptr<Shader>& s, float w) {
    CV_Assert(s && "CombinationShader::add: null shader");
    parts_.emplace_back(s, w);
}

Vec3f CombinationShader::shade(const ShadingPoint& p) const {
    Vec3f acc(0, 0, 0);
    for (const auto& part : parts_)
        acc += part.first->shade(p) * part.second;
    return acc;
}

// ---------------------------------------------------------------------------------------------
// Geometry helpers and the sphere renderer

Vec3f sphereNormalAt(float x, float y, Point2f center, float radius) {
    float dx = (x - center.x) / radius, dy = (y - center.y) / radius;
    const float rho2 = dx * dx + dy * dy, lim = 0.999f;
    if (rho2 > lim * lim) {
        const float k = lim / std::sqrt(rho2);
        dx *= k;
        dy *= k;
    }
    return Vec3f(dx, dy, -std::sqrt(std::max(0.f, 1.f - dx * dx - dy * dy)));
}

float diskCoverage(float x, float y, Point2f center, float radius) {
    const float dx = x - center.x, dy = y - center.y;
    return std::min(1.f, std::max(0.f, radius - std::sqrt(dx * dx + dy * dy) + 0.5f));
}

void renderSphere(InputArray background_, Point2f center, float radius, double focal,
                  const Shader& shader, OutputArray out_, OutputArray shaded_) {
    const Mat background = background_.getMat();
    CV_Assert(background.type() == CV_32FC3 &&
              "renderSphere: expected a linear CV_32FC3 background");
    CV_Assert(radius > 0 && focal > 0 && "renderSphere: radius and focal must be > 0");
    out_.create(background.size(), CV_32FC3);  // keeps the data when out is background itself
    Mat out = out_.getMat();
    if (out.data != background.data) background.copyTo(out);
    Mat shaded_mat, *shaded = nullptr;
    if (shaded_.needed()) {
        shaded_.create(background.size(), CV_32FC3);
        shaded_mat = shaded_.getMat();
        shaded_mat.setTo(Scalar::all(0));
        shaded = &shaded_mat;
    }
    const Rect box = Rect(Point(cvFloor(center.x - radius - 1), cvFloor(center.y - radius - 1)),
                          Point(cvCeil(center.x + radius + 2), cvCeil(center.y + radius + 2))) &
                     Rect(Point(0, 0), background.size());
    if (box.empty()) return;
    const PinholeCamera camera(Camera::fromFocal(focal, background.size()));
    parallel_for_(Range(box.y, box.y + box.height), [&](const Range& rows) {
        for (int y = rows.start; y < rows.end; y++) {
            Vec3f* o = out.ptr<Vec3f>(y);
            Vec3f* sh = shaded ? shaded->ptr<Vec3f>(y) : nullptr;
            for (int x = box.x; x < box.x + box.width; x++) {
                const float c = diskCoverage((float)x, (float)y, center, radius);
                if (c <= 0.f) continue;
                ShadingPoint sp;
                sp.n = sphereNormalAt((float)x, (float)y, center, radius);
                Vec3f origin, ray;
                camera.generateRay(Point2f((float)x, (float)y), origin, ray);
                sp.wo = -ray;
                // Orthographic normals seen through a perspective camera: near the rim of an
                // off-centre disk the normal can face away from the view ray. Tilt the view
                // direction to graze the surface instead of leaving the pixel unlit.
                const float cw = sp.n.dot(sp.wo);
                if (cw < 0.05f) sp.wo = normalized(sp.wo + sp.n * (0.05f - cw));
                sp.pixel = Point2f((float)x, (float)y);
                const Vec3f v = bgr2rgb(shader.shade(sp));
                o[x] = v * c + o[x] * (1.f - c);
                if (sh) sh[x] = v;
            }
        }
    });
}

}  // namespace vbme
}  // namespace cv
