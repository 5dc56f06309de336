// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The "Manhattan World" edge-pixel likelihood of a camera frame (Coughlan & Yuille 1999;
// Denis, Elder & Estrada 2008): every edge pixel's orientation is explained by one of the three
// vanishing points (Gaussian angular noise) or by none (uniform). Used to score and refine the
// frames of the GLOBAL search with all edge pixels instead of the detected segments only.
#include "manhattan_edgels.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace cv {
namespace vbme {
namespace detail {

namespace {

/** Edgels of one scale: @p img (float) at @p scale of the full-resolution image. Orientation
from the structure tensor (gradient products averaged over σ 1.5 px), which is much steadier
than a single pixel's gradient in a noisy image; pixels whose neighbourhood is not one
oriented edge (coherence below 0.5) are dropped, as are pixels that are not the maximum of the
gradient magnitude across the edge or below a noise-relative threshold. */
void edgelsAtScale(const Mat& img, double scale, const Point2d& pp, double W, int max_edgels,
                   double weight, Edgels& e) {
    Mat gx, gy, mag, jxx, jxy, jyy;
    // Scharr's kernel, not Sobel's: Sobel's gradient direction is off by up to ~1° depending
    // on the orientation, which biased the frame by 0.5–1° on synthetic rooms (the test
    // CalibEdgels.TrueFrameScoresBestAndRefinementReturnsToIt).
    Scharr(img, gx, CV_32F, 1, 0, 3.0 / 16);
    Scharr(img, gy, CV_32F, 0, 1, 3.0 / 16);
    magnitude(gx, gy, mag);
    multiply(gx, gx, jxx);
    multiply(gx, gy, jxy);
    multiply(gy, gy, jyy);
    GaussianBlur(jxx, jxx, Size(), 1.5);
    GaussianBlur(jxy, jxy, Size(), 1.5);
    GaussianBlur(jyy, jyy, Size(), 1.5);
    // Noise-relative threshold: most pixels are flat, so the median magnitude is about the
    // noise's; an edge is several times that.
    std::vector<float> sample;
    sample.reserve((size_t)mag.total() / 7 + 1);
    for (size_t i = 0; i < mag.total(); i += 7)
        sample.push_back(mag.ptr<float>()[i]);
    std::nth_element(sample.begin(), sample.begin() + sample.size() / 2, sample.end());
    const float thr = std::max(4.0f, 3.0f * sample[sample.size() / 2]);
    const int border = 3;
    struct C {
        Point p;
        float ux, uy;
    };
    std::vector<C> cand;
    for (int y = border; y < mag.rows - border; ++y) {
        const float* m = mag.ptr<float>(y);
        const float* mu = mag.ptr<float>(y - 1);
        const float* md = mag.ptr<float>(y + 1);
        const float* ax = gx.ptr<float>(y);
        const float* ay = gy.ptr<float>(y);
        for (int x = border; x < mag.cols - border; ++x) {
            const float v = m[x];
            if (v < thr) continue;
            // Non-maximum suppression across the edge (gradient direction in 4 sectors).
            const float dx = std::abs(ax[x]), dy = std::abs(ay[x]);
            float a, b;
            if (dy < 0.4142f * dx) {
                a = m[x - 1];
                b = m[x + 1];
            } else if (dx < 0.4142f * dy) {
                a = mu[x];
                b = md[x];
            } else if ((ax[x] > 0) == (ay[x] > 0)) {
                a = mu[x - 1];
                b = md[x + 1];
            } else {
                a = mu[x + 1];
                b = md[x - 1];
            }
            if (v < a || v <= b) continue;
            const float A = jxx.at<float>(y, x), B = jxy.at<float>(y, x), Cc = jyy.at<float>(y, x);
            const float tr = A + Cc, dif = std::sqrt((A - Cc) * (A - Cc) + 4 * B * B);
            if (tr <= 0 || dif / tr < 0.5f) continue;
            const float phi = 0.5f * std::atan2(2 * B, A - Cc);  // gradient direction
            cand.push_back({Point(x, y), -std::sin(phi), std::cos(phi)});
        }
    }
    const size_t n = cand.size();
    const size_t want = std::min(n, (size_t)std::max(1, max_edgels));
    // An even pseudo-random subset (fixed seed): one candidate from each slot of n / want.
    RNG rng(0x5eed);
    for (size_t k = 0; k < want; ++k) {
        const size_t lo = k * n / want, hi = (k + 1) * n / want;
        const size_t i = lo + (hi > lo + 1 ? (size_t)rng.uniform(0, (int)(hi - lo)) : 0);
        const C& c = cand[i];
        const double X = (c.p.x + 0.5) / scale - 0.5, Y = (c.p.y + 0.5) / scale - 0.5;
        e.x.emplace_back((X - pp.x) / W, (Y - pp.y) / W);
        e.u.emplace_back(c.ux, c.uy);
        // Each kept edgel stands for n / want found ones, each for 1 / scale pixels of edge.
        e.w.push_back(weight * double(n) / want / scale);
    }
}

}  // namespace

Edgels extractEdgels(const Mat& gray8, const Point2d& pp, double W, int max_edgels) {
    CV_Assert(gray8.type() == CV_8UC1 && !gray8.empty());
    Edgels e;
    e.W = W;
    Mat g0, gf;
    medianBlur(gray8, g0, 3);
    g0.convertTo(gf, CV_32F);
    const double scales[3] = {1.0, 0.5, 0.25};
    const double share[3] = {0.5, 0.3, 0.2};
    for (int k = 0; k < 3; ++k) {
        Mat src;
        if (scales[k] < 1) {
            Mat b;
            GaussianBlur(gf, b, Size(), 0.5 / scales[k]);
            resize(b, src, Size(), scales[k], scales[k], INTER_AREA);
        } else {
            src = gf;
        }
        GaussianBlur(src, src, Size(), 1.0);
        edgelsAtScale(src, scales[k], pp, W, (int)(share[k] * max_edgels), 1.0, e);
    }
    double tw = 0;
    for (double w : e.w)
        tw += w;
    for (double& w : e.w)
        w *= e.size() / std::max(1e-300, tw);  // mean weight 1
    return e;
}

namespace {

/** Signed angle (radians, in [−π/2, π/2]) between the edgel's tangent and the line from it to
the vanishing point v (homogeneous, normalised coordinates); false when the edgel is at v. */
inline bool edgelAngle(const Vec2d& x, const Vec2d& u, const Vec3d& v, double& r) {
    const double tx = v[0] - x[0] * v[2], ty = v[1] - x[1] * v[2];
    const double tn = std::hypot(tx, ty);
    if (tn < 1e-12) return false;
    double s = (u[0] * ty - u[1] * tx) / tn;
    const double c = (u[0] * tx + u[1] * ty) / tn;
    // The line's angle: fold the direction so that cos ≥ 0.
    r = std::atan2(c >= 0 ? s : -s, std::abs(c));
    return true;
}

/** k·exp(h·sin²α), α the angle between the edgel's tangent and the line to v: the Gaussian
term of the likelihood with sin α for α (equal within 0.1 % inside 3σ), 0 beyond 45° or where
it underflows; no square root or trigonometry (this is the inner loop of every score). */
inline double edgelTerm(const Vec2d& x, const Vec2d& u, const Vec3d& v, double k, double h) {
    const double tx = v[0] - x[0] * v[2], ty = v[1] - x[1] * v[2];
    const double cr = u[0] * ty - u[1] * tx, dt = u[0] * tx + u[1] * ty;
    const double cr2 = cr * cr, t2 = cr2 + dt * dt;  // |t|² (u is a unit vector)
    if (!(t2 > 1e-24) || cr2 > dt * dt) return 0;
    const double z = h * cr2 / t2;
    return z < -30 ? 0 : k * std::exp(z);
}

inline void vps(const Matx33d& D, double F, Vec3d V[3]) {
    for (int a = 0; a < 3; ++a)
        V[a] = Vec3d(F * D(0, a), F * D(1, a), D(2, a));
}

}  // namespace

double edgelScore(const Edgels& e, const Matx33d& D, double F, const EdgelModel& m,
                  double per_dir[3]) {
    if (e.size() == 0) return 0;
    Vec3d V[3];
    vps(D, F, V);
    const double k = (1 - m.eps) / 3 * CV_PI / (std::sqrt(2 * CV_PI) * m.sigma);
    const double h = -0.5 / (m.sigma * m.sigma);
    double sum = 0, dir[3] = {0, 0, 0};
    for (size_t i = 0; i < e.size(); ++i) {
        double l[3];
        double p = m.eps;
        for (int a = 0; a < 3; ++a) {
            l[a] = edgelTerm(e.x[i], e.u[i], V[a], k, h);
            p += l[a];
        }
        const double w = e.w[i];
        sum += w * std::log(p);
        if (per_dir)
            for (int a = 0; a < 3; ++a)
                dir[a] += w * l[a] / p;
    }
    if (per_dir)
        for (int a = 0; a < 3; ++a)
            per_dir[a] = dir[a] / e.size();
    return sum / e.size();
}

double refineEdgels(const Edgels& e, Matx33d& D, double& F, const EdgelModel& m, bool fix_focal,
                    int iterations, double prior_logF, double prior_logF_sigma, double n_eff) {
    const bool prior = prior_logF_sigma > 0 && !fix_focal;
    auto objective = [&](const Matx33d& Dx, double Fx) {
        double s = edgelScore(e, Dx, Fx, m);
        if (prior) {
            const double z = (std::log(Fx) - prior_logF) / prior_logF_sigma;
            s -= 0.5 * z * z / std::max(1.0, n_eff);
        }
        return s;
    };
    double best = objective(D, F);
    if (e.size() < 10) return edgelScore(e, D, F, m);
    const int np = fix_focal ? 3 : 4;
    const double k = (1 - m.eps) / 3 * CV_PI / (std::sqrt(2 * CV_PI) * m.sigma);
    const double h = -0.5 / (m.sigma * m.sigma);
    const double N = (double)e.size();
    for (int it = 0; it < iterations; ++it) {
        // E-step: responsibilities of each direction for each edgel at the current frame.
        Vec3d V[3];
        vps(D, F, V);
        std::vector<double> gam(3 * e.size(), 0.0);
        for (size_t i = 0; i < e.size(); ++i) {
            double l[3], p = m.eps;
            for (int a = 0; a < 3; ++a) {
                l[a] = edgelTerm(e.x[i], e.u[i], V[a], k, h);
                p += l[a];
            }
            for (int a = 0; a < 3; ++a)
                gam[3 * i + a] = e.w[i] * l[a] / p;
        }
        // M-step: one Gauss–Newton step on Σ γ r² / (2σ² N) (+ prior), numeric Jacobian.
        auto residuals = [&](const double* d, std::vector<double>& res) {
            Matx33d dR;
            Rodrigues(Vec3d(d[0], d[1], d[2]), dR);
            const Matx33d Dx = dR * D;
            const double Fx = F * std::exp(d[3]);
            Vec3d Vx[3];
            vps(Dx, Fx, Vx);
            res.assign(3 * e.size(), 0.0);
            for (size_t i = 0; i < e.size(); ++i)
                for (int a = 0; a < 3; ++a) {
                    if (gam[3 * i + a] < 1e-3) continue;
                    double r = 0;
                    if (edgelAngle(e.x[i], e.u[i], Vx[a], r)) res[3 * i + a] = r;
                }
        };
        const double d0[4] = {0, 0, 0, 0};
        std::vector<double> r0;
        residuals(d0, r0);
        std::vector<std::vector<double>> Jc(np);
        const double step = 1e-6;
        for (int j = 0; j < np; ++j) {
            double d[4] = {0, 0, 0, 0};
            d[j] = step;
            residuals(d, Jc[j]);
            for (size_t q = 0; q < r0.size(); ++q)
                Jc[j][q] = (Jc[j][q] - r0[q]) / step;
        }
        Matx44d H = Matx44d::zeros();
        Vec4d g(0, 0, 0, 0);
        const double wsc = 1.0 / (m.sigma * m.sigma * N);
        for (size_t q = 0; q < r0.size(); ++q) {
            const double w = gam[q] * wsc;
            if (w <= 0) continue;
            for (int a = 0; a < np; ++a) {
                g[a] += w * Jc[a][q] * r0[q];
                for (int b = 0; b < np; ++b)
                    H(a, b) += w * Jc[a][q] * Jc[b][q];
            }
        }
        if (prior) {
            const double ip = 1.0 / (prior_logF_sigma * prior_logF_sigma * std::max(1.0, n_eff));
            H(3, 3) += ip;
            g[3] += ip * (std::log(F) - prior_logF);
        }
        if (np == 3) H(3, 3) = 1;
        for (int a = 0; a < np; ++a)
            H(a, a) *= 1 + 1e-6;
        Vec4d delta;
        if (!solve(H, -g, delta, DECOMP_CHOLESKY)) break;
        if (np == 3) delta[3] = 0;
        bool improved = false;
        for (double t = 1; t > 0.1 && !improved; t *= 0.5) {
            Matx33d dR;
            Rodrigues(Vec3d(t * delta[0], t * delta[1], t * delta[2]), dR);
            const Matx33d Dn = dR * D;
            const double Fn = F * std::exp(t * delta[3]);
            const double sc = objective(Dn, Fn);
            if (sc > best) {
                best = sc;
                D = Dn;
                F = Fn;
                improved = true;
            }
        }
        if (!improved || norm(delta) < 1e-7) break;
    }
    return edgelScore(e, D, F, m);
}

Edgels subsampleEdgels(const Edgels& e, size_t n) {
    Edgels s;
    s.W = e.W;
    const size_t stride = std::max<size_t>(1, e.size() / std::max<size_t>(1, n));
    for (size_t i = 0; i < e.size(); i += stride) {
        s.x.push_back(e.x[i]);
        s.u.push_back(e.u[i]);
        s.w.push_back(e.w[i]);
    }
    return s;
}

std::vector<EdgelFrame> edgelFramesAroundVP(const Edgels& e, const Vec3d& v,
                                            const std::vector<double>& focals, int n_psi,
                                            const EdgelModel& m) {
    const Edgels sub = subsampleEdgels(e, 300);
    std::vector<EdgelFrame> out;
    for (double F : focals) {
        const Vec3d d1 = normalize(Vec3d(v[0] / F, v[1] / F, v[2]));
        Vec3d a = d1.cross(Vec3d(0, 0, 1));
        if (norm(a) < 1e-6) a = d1.cross(Vec3d(1, 0, 0));
        a = normalize(a);
        const Vec3d b = d1.cross(a);
        for (int k = 0; k < n_psi; ++k) {
            const double psi = 0.5 * CV_PI * k / n_psi;
            const Vec3d d2 = std::cos(psi) * a + std::sin(psi) * b, d3 = d1.cross(d2);
            EdgelFrame fr;
            fr.F = F;
            for (int r = 0; r < 3; ++r) {
                fr.D(r, 0) = d1[r];
                fr.D(r, 1) = d2[r];
                fr.D(r, 2) = d3[r];
            }
            fr.score = edgelScore(sub, fr.D, fr.F, m);
            out.push_back(fr);
        }
    }
    std::stable_sort(out.begin(), out.end(),
                     [](const EdgelFrame& x, const EdgelFrame& y) { return x.score > y.score; });
    return out;
}

}  // namespace detail
}  // namespace vbme
}  // namespace cv
