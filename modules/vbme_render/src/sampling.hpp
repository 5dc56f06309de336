// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Sampling warps and piecewise-constant distributions of the vbme_render path tracer.
//
// Header-only and private to the module (tests include it by relative path). Every warp maps
// uniform numbers in [0,1) to a direction or point and has a matching pdf; nothing allocates
// except Distribution1D/2D construction (done once, at scene load).
#ifndef VBME_RENDER_SAMPLING_HPP
#define VBME_RENDER_SAMPLING_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {
namespace sampling {

constexpr float kPi = 3.14159265358979323846f;      //!< π
constexpr float kInvPi = 0.31830988618379067154f;   //!< 1/π
constexpr float kInv2Pi = 0.15915494309189533577f;  //!< 1/(2π)
constexpr float kInv4Pi = 0.07957747154594766788f;  //!< 1/(4π)
/** @brief The largest float below 1: uniform numbers are clamped to it. */
constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

/** @brief Orthonormal frame (t, b, n) around a unit normal n (Duff et al. 2017, "Building an
orthonormal basis, revisited"). Branch-free apart from the sign, continuous everywhere except
across the n.z = 0 plane's sign flip; t × b = n. */
struct Frame {
    Vec3f t;  //!< first tangent
    Vec3f b;  //!< second tangent
    Vec3f n;  //!< the normal (z of the local frame)

    Frame() : t(1, 0, 0), b(0, 1, 0), n(0, 0, 1) {}
    /** @brief Builds the frame of unit normal @p nn. */
    explicit Frame(const Vec3f& nn) : n(nn) {
        const float sign = std::copysign(1.f, nn[2]);
        const float a = -1.f / (sign + nn[2]);
        const float bb = nn[0] * nn[1] * a;
        t = Vec3f(1.f + sign * nn[0] * nn[0] * a, sign * bb, -sign * nn[0]);
        b = Vec3f(bb, sign + nn[1] * nn[1] * a, -nn[1]);
    }
    /** @brief Builds a frame from a normal and a tangent hint (Gram–Schmidt; falls back to
    Duff's frame if the hint is parallel to the normal). */
    Frame(const Vec3f& nn, const Vec3f& tangent_hint) : Frame(nn) {
        Vec3f tt = tangent_hint - nn * nn.dot(tangent_hint);
        const float l = (float)cv::norm(tt);
        if (l > 1e-6f) {
            t = tt / l;
            b = n.cross(t);
        }
    }
    /** @brief World → local. */
    Vec3f toLocal(const Vec3f& v) const { return Vec3f(v.dot(t), v.dot(b), v.dot(n)); }
    /** @brief Local → world. */
    Vec3f toWorld(const Vec3f& v) const { return t * v[0] + b * v[1] + n * v[2]; }
};

/** @brief sin φ and cos φ for |φ| ≤ π/4 (and a little beyond), within 2·10⁻⁷: short polynomials
(the minimax coefficients of the Cephes library's sinf/cosf on that interval), inline, no
range reduction and the same bits on every machine (unlike libm's ifunc-selected sincosf). */
inline void sinCosQuarter(float x, float& s, float& c) {
    const float z = x * x;
    s = x + x * z * (-1.6666654611e-1f + z * (8.3321608736e-3f + z * -1.9515295891e-4f));
    c = 1.f + z * (-0.5f + z * (4.166664568298827e-2f +
                                z * (-1.388731625493765e-3f + z * 2.443315711809948e-5f)));
}

namespace detail {
/** @brief squareToConcentricDisk, also giving the point's radius @p radius (|r| below, exactly:
the radius of the concentric map is a coordinate of the square, no square root needed).
Portable scalar form: the reference the SSE form below must equal bit for bit. */
inline Vec2f concentricDiskScalar(const Vec2f& u, float& radius) {
    const float ox = 2.f * u[0] - 1.f, oy = 2.f * u[1] - 1.f;
    if (ox == 0.f && oy == 0.f) {
        radius = 0.f;
        return Vec2f(0, 0);
    }
    // Wedge |ox| > |oy|: r = ox, θ = φ = (π/4)(oy/ox); otherwise r = oy, θ = π/2 − φ with
    // φ = (π/4)(ox/oy), i.e. (cos θ, sin θ) = (sin φ, cos φ). The wedge is a coin flip per
    // sample: chosen by bit masks, not a branch that mispredicts half the time; |φ| ≤ π/4
    // needs no range reduction.
    const uint32_t m = std::abs(ox) > std::abs(oy) ? 0xffffffffu : 0u;
    auto pick = [m](float a, float b) {  // m ? a : b
        uint32_t ia, ib;
        std::memcpy(&ia, &a, 4);
        std::memcpy(&ib, &b, 4);
        const uint32_t r = (ia & m) | (ib & ~m);
        float f;
        std::memcpy(&f, &r, 4);
        return f;
    };
    const float r = pick(ox, oy);
    radius = std::abs(r);
    float sn, cs;
    sinCosQuarter((kPi / 4.f) * (pick(oy, ox) / r), sn, cs);
    return Vec2f(r * pick(cs, sn), r * pick(sn, cs));
}

#if defined(__SSE2__)
/** @brief concentricDiskScalar with both coordinates in one SSE register from the load to the
result: the same IEEE operations in the same order on each value (the same bits), without the
round trips through integer registers that scalar selects cost (each `_mm_set_ss` of a float
went out to a general register and back), with both wedges' quotients oy/ox and ox/oy in one
division that starts before the wedge is known, and sin φ and cos φ evaluated side by side.
Returns (x, y, ·, ·) and the radius in lane 0 of @p radius. */
inline __m128 concentricDiskPacked(const Vec2f& u, __m128& radius) {
    const __m128 uv = _mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(u.val));
    // 2u − 1 as u + u − 1: u + u is exactly 2u (GCC emits the same addition for 2.f * u).
    const __m128 o = _mm_sub_ps(_mm_add_ps(uv, uv), _mm_set1_ps(1.f));  // (ox, oy, −1, −1)
    if ((_mm_movemask_ps(_mm_cmpeq_ps(o, _mm_setzero_ps())) & 3) == 3) {
        radius = _mm_setzero_ps();
        return _mm_setzero_ps();
    }
    const __m128 o_sw = _mm_shuffle_ps(o, o, _MM_SHUFFLE(3, 2, 0, 1));  // (oy, ox)
    // Both candidates of the wedge's quotient at once (one of them may divide by zero; it is
    // then not chosen).
    const __m128 q = _mm_div_ps(o_sw, o);  // (oy/ox, ox/oy)
    const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
    const __m128 a = _mm_and_ps(o, abs_mask);                           // (|ox|, |oy|)
    const __m128 a_sw = _mm_shuffle_ps(a, a, _MM_SHUFFLE(3, 2, 0, 1));  // (|oy|, |ox|)
    const __m128 gt = _mm_cmpgt_ps(a, a_sw);                            // lane 0: |ox| > |oy|
    const __m128 m = _mm_shuffle_ps(gt, gt, 0);                         // that mask in every lane
    auto select = [&m](__m128 x, __m128 y) {                            // m ? x : y
        return _mm_or_ps(_mm_and_ps(m, x), _mm_andnot_ps(m, y));
    };
    const __m128 rn = select(o, o_sw);  // lane 0: r = m ? ox : oy
    radius = _mm_and_ps(rn, abs_mask);
    const __m128 qs =
        select(q, _mm_shuffle_ps(q, q, _MM_SHUFFLE(3, 2, 0, 1)));  // m ? oy/ox : ox/oy
    const __m128 x = _mm_mul_ss(_mm_set_ss(kPi / 4.f), qs);        // φ in lane 0
    const __m128 z = _mm_mul_ss(x, x);
    const __m128 zz = _mm_shuffle_ps(z, z, 0);
    // sinCosQuarter's two Horner schemes side by side, lane 0 cos φ, lane 1 sin φ:
    //   c = 1 + z·(−0.5 + z·(c2 + z·(c3 + z·c4)))
    //   s = x + (x·z)·(s1 + z·(s2 + z·s3)), where lane 1 starts one step late with z·0 + s3
    //   (exactly s3, z ≥ 0) so both lanes take the same steps.
    __m128 t = _mm_mul_ps(zz, _mm_setr_ps(2.443315711809948e-5f, 0.f, 0.f, 0.f));
    t = _mm_add_ps(_mm_setr_ps(-1.388731625493765e-3f, -1.9515295891e-4f, 0.f, 0.f), t);
    t = _mm_mul_ps(zz, t);
    t = _mm_add_ps(_mm_setr_ps(4.166664568298827e-2f, 8.3321608736e-3f, 0.f, 0.f), t);
    t = _mm_mul_ps(zz, t);
    t = _mm_add_ps(_mm_setr_ps(-0.5f, -1.6666654611e-1f, 0.f, 0.f), t);
    const __m128 xx = _mm_shuffle_ps(x, x, 0);
    const __m128 xz = _mm_mul_ss(xx, z);                               // lane 0 x·z (lane 1 x)
    const __m128 mz = _mm_unpacklo_ps(zz, _mm_shuffle_ps(xz, xz, 0));  // (z, x·z, z, x·z)
    t = _mm_mul_ps(mz, t);
    const __m128 cs = _mm_add_ps(_mm_unpacklo_ps(_mm_set1_ps(1.f), xx), t);  // (cos φ, sin φ)
    const __m128 cs_sw = _mm_shuffle_ps(cs, cs, _MM_SHUFFLE(3, 2, 0, 1));    // (sin φ, cos φ)
    const __m128 rr = _mm_shuffle_ps(rn, rn, 0);
    return _mm_mul_ps(rr, select(cs, cs_sw));  // r·(m ? (c, s) : (s, c))
}
/** @brief concentricDiskPacked as a point and a radius. */
inline Vec2f concentricDiskSse(const Vec2f& u, float& radius) {
    __m128 rad;
    const __m128 p = concentricDiskPacked(u, rad);
    radius = _mm_cvtss_f32(rad);
    Vec2f out;
    _mm_storel_pi(reinterpret_cast<__m64*>(out.val), p);
    return out;
}
#endif

/** @brief squareToConcentricDisk with the point's radius (the SSE form where there is SSE2). */
inline Vec2f concentricDisk(const Vec2f& u, float& radius) {
#if defined(__SSE2__)
    return concentricDiskSse(u, radius);
#else
    return concentricDiskScalar(u, radius);
#endif
}
}  // namespace detail

/** @brief Concentric map of the unit square onto the unit disk (Shirley & Chiu 1997). */
inline Vec2f squareToConcentricDisk(const Vec2f& u) {
    float radius;
    return detail::concentricDisk(u, radius);
}
/** @brief Density of squareToConcentricDisk per unit area (1/π inside the disk). */
inline float squareToConcentricDiskPdf(const Vec2f& p) {
    return p[0] * p[0] + p[1] * p[1] <= 1.f ? kInvPi : 0.f;
}

/** @brief Cosine-weighted hemisphere around +z (Malley's method). */
inline Vec3f squareToCosineHemisphere(const Vec2f& u) {
    // z = √(1 − r²) from the disk's radius, not from the point: the square root no longer waits
    // for the division and polynomials that place the point on its circle.
#if defined(__SSE2__)
    __m128 r;
    const __m128 d = detail::concentricDiskPacked(u, r);
    // max(0, v) as std::max(0.f, v) = (0 < v ? v : 0): _mm_max_ss(v, 0) = (v > 0 ? v : 0)
    const __m128 z =
        _mm_sqrt_ss(_mm_max_ss(_mm_sub_ss(_mm_set_ss(1.f), _mm_mul_ss(r, r)), _mm_setzero_ps()));
    return Vec3f(_mm_cvtss_f32(d), _mm_cvtss_f32(_mm_shuffle_ps(d, d, _MM_SHUFFLE(1, 1, 1, 1))),
                 _mm_cvtss_f32(z));
#else
    float r;
    const Vec2f d = detail::concentricDisk(u, r);
    const float z = std::sqrt(std::max(0.f, 1.f - r * r));
    return Vec3f(d[0], d[1], z);
#endif
}
/** @brief Solid-angle pdf of squareToCosineHemisphere: cos θ / π (0 below the horizon). */
inline float squareToCosineHemispherePdf(const Vec3f& w) {
    return w[2] > 0.f ? w[2] * kInvPi : 0.f;
}

/** @brief Uniform direction on the unit sphere. */
inline Vec3f squareToUniformSphere(const Vec2f& u) {
    const float z = 1.f - 2.f * u[0];
    const float r = std::sqrt(std::max(0.f, 1.f - z * z));
    const float phi = 2.f * kPi * u[1];
    return Vec3f(r * std::cos(phi), r * std::sin(phi), z);
}
/** @brief Solid-angle pdf of squareToUniformSphere: 1/(4π). */
inline float squareToUniformSpherePdf() {
    return kInv4Pi;
}

/** @brief Uniform direction on the hemisphere around +z. */
inline Vec3f squareToUniformHemisphere(const Vec2f& u) {
    const float z = u[0];
    const float r = std::sqrt(std::max(0.f, 1.f - z * z));
    const float phi = 2.f * kPi * u[1];
    return Vec3f(r * std::cos(phi), r * std::sin(phi), z);
}
/** @brief Solid-angle pdf of squareToUniformHemisphere: 1/(2π) above the horizon. */
inline float squareToUniformHemispherePdf(const Vec3f& w) {
    return w[2] >= 0.f ? kInv2Pi : 0.f;
}

/** @brief Uniform direction inside the cone around +z with cos(half-angle) = @p cos_max. */
inline Vec3f squareToUniformCone(const Vec2f& u, float cos_max) {
    const float z = 1.f - u[0] * (1.f - cos_max);
    const float r = std::sqrt(std::max(0.f, 1.f - z * z));
    const float phi = 2.f * kPi * u[1];
    return Vec3f(r * std::cos(phi), r * std::sin(phi), z);
}
/** @brief Solid-angle pdf of squareToUniformCone: 1/(2π(1 − cos_max)) inside the cone. A
degenerate cone (cos_max = 1) has a Dirac pdf: the function then returns 0 (treat it as a
delta direction). */
inline float squareToUniformConePdf(const Vec3f& w, float cos_max) {
    if (cos_max >= 1.f) return 0.f;
    return w[2] >= cos_max ? 1.f / (2.f * kPi * (1.f - cos_max)) : 0.f;
}

/** @brief Uniform point on a triangle, as barycentrics (b1, b2) of vertices 1 and 2 (vertex 0
gets 1 − b1 − b2). Square-root parametrisation; the pdf is 1/area. */
inline Vec2f squareToUniformTriangle(const Vec2f& u) {
    const float s = std::sqrt(u[0]);
    return Vec2f(1.f - s, u[1] * s);
}

/** @brief Veach's power heuristic (β = 2) for nf samples of pdf fpdf vs ng of gpdf. */
inline float powerHeuristic(int nf, float fpdf, int ng, float gpdf) {
    const float f = nf * fpdf, g = ng * gpdf;
    if (std::isinf(f * f)) return 1.f;
    const float d = f * f + g * g;
    return d > 0.f ? (f * f) / d : 0.f;
}

/** @brief Piecewise-constant 1-D distribution on [0,1) with n cells (built once).

Values must be finite and ≥ 0; if all are zero the distribution is uniform. Only the CDF is
stored (float, n + 1 entries): the probability of a cell is the difference of two CDF entries,
so pdf() is exactly the density with which the float search samples. */
class Distribution1D {
public:
    Distribution1D() = default;
    /** @brief Builds from @p n non-negative values. */
    Distribution1D(const float* f, int n) { build(f, n); }
    /** @brief Builds from a vector. */
    explicit Distribution1D(const std::vector<float>& f) { build(f.data(), (int)f.size()); }

    /** @brief (Re)builds from @p n ≥ 1 non-negative values. */
    void build(const float* f, int n) {
        CV_Assert(n >= 1 && "Distribution1D needs at least one cell");
        std::vector<double> c(n + 1, 0.);
        for (int i = 0; i < n; i++) {
            CV_Assert(f[i] >= 0.f && std::isfinite(f[i]) &&
                      "Distribution1D values must be finite and non-negative");
            c[i + 1] = c[i] + (double)f[i];
        }
        integral_ = (float)(c[n] / n);
        cdf_.resize(n + 1);
        for (int i = 0; i <= n; i++)
            cdf_[i] = c[n] > 0. ? (float)(c[i] / c[n]) : (float)i / n;
        cdf_[0] = 0.f;
        cdf_[n] = 1.f;
    }

    /** @brief Number of cells. */
    int size() const { return (int)cdf_.size() - 1; }
    /** @brief ∫ f over [0,1) (the mean of the values). */
    float integral() const { return integral_; }

    /** @brief Samples a continuous position x ∈ [0,1). @p pdf receives its density (per unit
    length of [0,1)), @p cell the cell index. */
    float sampleContinuous(float u, float& pdf, int& cell) const {
        cell = findCell(u);
        const float c0 = cdf_[cell], c1 = cdf_[cell + 1];
        float du = c1 > c0 ? (u - c0) / (c1 - c0) : 0.f;
        du = std::min(std::max(du, 0.f), kOneMinusEpsilon);
        pdf = (c1 - c0) * size();
        return std::min((cell + du) / size(), kOneMinusEpsilon);
    }
    /** @brief Samples a cell index; @p pmf receives its probability. */
    int sampleDiscrete(float u, float& pmf) const {
        const int cell = findCell(u);
        pmf = pdfCell(cell);
        return cell;
    }
    /** @brief Like sampleDiscrete, and @p u_remapped gets u rescaled to [0,1) inside the cell
    (reusable as a fresh uniform number). */
    int sampleDiscrete(float u, float& pmf, float& u_remapped) const {
        const int cell = findCell(u);
        const float c0 = cdf_[cell], c1 = cdf_[cell + 1];
        pmf = c1 - c0;
        u_remapped =
            c1 > c0 ? std::min(std::max((u - c0) / (c1 - c0), 0.f), kOneMinusEpsilon) : 0.f;
        return cell;
    }
    /** @brief Probability of cell i (discrete pmf). */
    float pdfCell(int i) const { return cdf_[i + 1] - cdf_[i]; }
    /** @brief Density (per unit length of [0,1)) at x ∈ [0,1). */
    float pdfContinuous(float x) const {
        const int n = size();
        const int i = std::min(std::max((int)(x * n), 0), n - 1);
        return pdfCell(i) * n;
    }

private:
    // The cell i with cdf[i] <= u < cdf[i+1] (never a zero-probability cell).
    int findCell(float u) const {
        const int n = size();
        const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
        int i = (int)(it - cdf_.begin()) - 1;
        i = std::min(std::max(i, 0), n - 1);
        // u beyond the last positive step (u rounds to 1): step back to a cell with mass.
        while (i > 0 && cdf_[i + 1] <= cdf_[i])
            i--;
        return i;
    }

    std::vector<float> cdf_;
    float integral_ = 0.f;
};

/** @brief Piecewise-constant 2-D distribution on [0,1)² from a rows×cols grid of
non-negative values (row = v, column = u): a marginal distribution over rows and a conditional
distribution over the columns of each row. */
class Distribution2D {
public:
    Distribution2D() = default;
    /** @brief Builds from a CV_32FC1 matrix of non-negative values. */
    explicit Distribution2D(const Mat& f) { build(f); }
    /** @brief (Re)builds from a CV_32FC1 matrix. */
    void build(const Mat& f) {
        CV_Assert(f.type() == CV_32FC1 && !f.empty() &&
                  "Distribution2D expects a non-empty CV_32FC1 matrix");
        rows_ = f.rows;
        cols_ = f.cols;
        conditional_.resize(rows_);
        std::vector<float> marg(rows_);
        for (int r = 0; r < rows_; r++) {
            conditional_[r].build(f.ptr<float>(r), cols_);
            marg[r] = conditional_[r].integral();
        }
        marginal_.build(marg.data(), rows_);
    }
    /** @brief Number of rows / columns. */
    int rows() const { return rows_; }
    int cols() const { return cols_; }  //!< Number of columns.
    /** @brief ∫∫ f over [0,1)². */
    float integral() const { return marginal_.integral(); }

    /** @brief Samples a point (x = column coordinate, y = row coordinate) in [0,1)²; @p pdf
    gets its density per unit area of [0,1)². */
    Vec2f sampleContinuous(const Vec2f& u, float& pdf) const {
        float pr, pc;
        int r, c;
        const float y = marginal_.sampleContinuous(u[1], pr, r);
        const float x = conditional_[r].sampleContinuous(u[0], pc, c);
        pdf = pr * pc;
        return Vec2f(x, y);
    }
    /** @brief Density per unit area at (x, y) ∈ [0,1)². */
    float pdf(const Vec2f& p) const {
        const int r = std::min(std::max((int)(p[1] * rows_), 0), rows_ - 1);
        const int c = std::min(std::max((int)(p[0] * cols_), 0), cols_ - 1);
        return marginal_.pdfCell(r) * rows_ * conditional_[r].pdfCell(c) * cols_;
    }

private:
    int rows_ = 0, cols_ = 0;
    std::vector<Distribution1D> conditional_;
    Distribution1D marginal_;
};

}  // namespace sampling
}  // namespace vbme
}  // namespace cv

#endif
