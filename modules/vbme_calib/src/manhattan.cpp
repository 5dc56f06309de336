// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// GLOBAL Manhattan-frame search: merged LSD segments with an angular uncertainty each;
// vanishing-point candidates from all pairs of the longest segments, scored by a robust
// consensus; every pair of candidates a frame (focal from orthogonality); distinct frames
// refined with Ceres (Cauchy loss) over focal, rotation and optionally one radial coefficient.
#include "manhattan.hpp"

#include "manhattan_edgels.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#ifdef VBME_HAVE_XIMGPROC
#include <opencv2/ximgproc/fast_line_detector.hpp>
#endif

namespace cv {
namespace vbme {
namespace detail {

Mat toGray8(InputArray image) {
    Mat img = image.getMat();
    if (img.empty()) CV_Error(Error::StsBadArg, "detect: the image is empty");
    Mat gray;
    if (img.channels() == 3)
        cvtColor(img, gray, COLOR_BGR2GRAY);
    else if (img.channels() == 4)
        cvtColor(img, gray, COLOR_BGRA2GRAY);
    else
        gray = img;
    if (gray.depth() != CV_8U) {
        Mat g8;
        gray.convertTo(g8, CV_8U, gray.depth() == CV_16U ? 1.0 / 257 : 255.0);
        gray = g8;
    }
    return gray;
}

namespace {

struct Piece {
    Vec2d p, q;
    int mask = 0;  // the passes merged into it: bit k for LSD pass k, bit 3 for FLD
    double len() const { return norm(q - p); }
};

/** Merges collinear, nearly touching pieces (longest first); returns the merged set. */
std::vector<Piece> mergeCollinear(std::vector<Piece> s) {
    const double sin_tol = std::sin(2.0 * CV_PI / 180), dist_tol = 1.5;
    std::sort(s.begin(), s.end(), [](const Piece& a, const Piece& b) { return a.len() > b.len(); });
    std::vector<char> alive(s.size(), 1);
    for (size_t i = 0; i < s.size(); ++i) {
        if (!alive[i]) continue;
        bool merged = true;
        while (merged) {
            merged = false;
            const double li = s[i].len();
            if (li < 1e-9) break;
            const Vec2d u = (s[i].q - s[i].p) / li, nrm(-u[1], u[0]);
            for (size_t j = i + 1; j < s.size(); ++j) {
                if (!alive[j]) continue;
                const double lj = s[j].len();
                if (lj < 1e-9) continue;
                const Vec2d uj = (s[j].q - s[j].p) / lj;
                if (std::abs(u[0] * uj[1] - u[1] * uj[0]) > sin_tol) continue;
                const double dp = (s[j].p - s[i].p).dot(nrm), dq = (s[j].q - s[i].p).dot(nrm);
                if (std::abs(dp) > dist_tol || std::abs(dq) > dist_tol) continue;
                const double tp = (s[j].p - s[i].p).dot(u), tq = (s[j].q - s[i].p).dot(u);
                const double tmin = std::min(tp, tq), tmax = std::max(tp, tq);
                const double gap = std::max({0.0, tmin - li, -tmax});
                if (gap > std::min(20.0, 3.0 + 0.25 * std::min(li, lj))) continue;
                // Length-weighted line through the pieces, spanning both.
                const Vec2d uj_al = uj.dot(u) >= 0 ? uj : -uj;
                const Vec2d d = normalize(li * u + lj * uj_al);
                const Vec2d c =
                    (li * (s[i].p + s[i].q) * 0.5 + lj * (s[j].p + s[j].q) * 0.5) / (li + lj);
                double a = 1e300, b = -1e300;
                for (const Vec2d& e : {s[i].p, s[i].q, s[j].p, s[j].q}) {
                    const double t = (e - c).dot(d);
                    a = std::min(a, t);
                    b = std::max(b, t);
                }
                s[i].p = c + a * d;
                s[i].q = c + b * d;
                s[i].mask |= s[j].mask;
                alive[j] = 0;
                merged = true;
                break;
            }
        }
    }
    std::vector<Piece> out;
    for (size_t i = 0; i < s.size(); ++i)
        if (alive[i]) out.push_back(s[i]);
    return out;
}

/** Sub-pixel refit of a segment's line on the full-resolution image: along the segment, the
peak of the gradient across it (within ±@p reach px, parabolic interpolation) is found at
every pixel step; a weighted line fit through the peaks (two rounds, the second without
peaks more than 1 px off) replaces the segment's line, keeping its extent. Segments from the
coarse LSD passes are found where the fine pass misses soft edges, but their position is
only as good as the coarse pixel; this recovers full-resolution precision. */
bool refitPiece(const Mat& gx, const Mat& gy, Piece& pc, double reach) {
    const double L = pc.len();
    if (L < 8) return false;
    const Vec2d u = (pc.q - pc.p) / L, nrm(-u[1], u[0]);
    auto bil = [](const Mat& m, double x, double y) {
        const int x0 = (int)std::floor(x), y0 = (int)std::floor(y);
        if (x0 < 0 || y0 < 0 || x0 + 1 >= m.cols || y0 + 1 >= m.rows) return 0.0f;
        const float fx = (float)(x - x0), fy = (float)(y - y0);
        const float* r0 = m.ptr<float>(y0);
        const float* r1 = m.ptr<float>(y0 + 1);
        return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
               fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
    };
    const int ns = (int)std::ceil(reach);
    std::vector<double> ts, ss, ws;
    std::vector<double> g(2 * ns + 1);
    for (double t = 0.05 * L; t <= 0.95 * L; t += 1.0) {
        const Vec2d c = pc.p + t * u;
        double best = 0;
        int bk = -1;
        for (int k = -ns; k <= ns; ++k) {
            const Vec2d x = c + k * nrm;
            g[k + ns] = bil(gx, x[0], x[1]) * nrm[0] + bil(gy, x[0], x[1]) * nrm[1];
            if (std::abs(g[k + ns]) > best) {
                best = std::abs(g[k + ns]);
                bk = k + ns;
            }
        }
        if (bk <= 0 || bk >= 2 * ns) continue;  // peak at the window's edge: not this edge
        const double a = std::abs(g[bk - 1]), b = std::abs(g[bk]), cc = std::abs(g[bk + 1]);
        const double den = a - 2 * b + cc;
        const double off = den < 0 ? 0.5 * (a - cc) / den : 0;
        ts.push_back(t);
        ss.push_back(bk - ns + std::max(-0.5, std::min(0.5, off)));
        ws.push_back(b);
    }
    if (ts.size() < 6) return false;
    double a0 = 0, a1 = 0;
    std::vector<char> use(ts.size(), 1);
    for (int round = 0; round < 2; ++round) {
        double S = 0, St = 0, Ss = 0, Stt = 0, Sts = 0;
        for (size_t i = 0; i < ts.size(); ++i) {
            if (!use[i]) continue;
            const double w = ws[i];
            S += w;
            St += w * ts[i];
            Ss += w * ss[i];
            Stt += w * ts[i] * ts[i];
            Sts += w * ts[i] * ss[i];
        }
        const double det = S * Stt - St * St;
        if (S <= 0 || std::abs(det) < 1e-12) return false;
        a1 = (S * Sts - St * Ss) / det;
        a0 = (Ss - a1 * St) / S;
        int kept = 0;
        for (size_t i = 0; i < ts.size(); ++i) {
            use[i] = std::abs(ss[i] - a0 - a1 * ts[i]) <= 1.0;
            kept += use[i];
        }
        if (kept < 6) return false;
    }
    if (std::abs(a0) > reach || std::abs(a0 + a1 * L) > reach) return false;
    pc.p = pc.p + a0 * nrm;
    pc.q = pc.q + (a0 + a1 * L) * nrm;
    return true;
}

}  // namespace

MergedSegments::MergedSegments(const Mat& gray, const VanishingPointCalibrator::Params& p)
    : max_segments_(p.max_segments) {
    // Three LSD passes after a 3×3 median (which removes the isolated bright and dark pixels
    // of render and sensor noise): on the image; on a smoothed copy at half resolution; on a
    // more smoothed copy at quarter resolution, where the soft shading edges of room corners,
    // invisible to the gradient test at full resolution in a noisy image, become lines. The
    // union is merged below (a line found by several passes becomes one segment) and every
    // segment's line refitted at full resolution (refitPiece).
    Mat g0;
    medianBlur(gray, g0, 3);
    const double scales[3] = {0.8, 0.5, 0.25}, blurs[3] = {0, 1.0, 2.0};
    for (int k = 0; k < 3; ++k) {
        Mat src;
        if (blurs[k] > 0)
            GaussianBlur(g0, src, Size(), blurs[k]);
        else
            src = g0;
        if (blurs[k] == 2.0) blurred2_ = src;
        std::vector<Vec4f> r;
        createLineSegmentDetector(LSD_REFINE_STD, scales[k])->detect(src, r);
        raw_.insert(raw_.end(), r.begin(), r.end());
        raw_mask_.insert(raw_mask_.end(), r.size(), 1 << k);
    }
    const double diag = std::hypot(gray.cols, gray.rows);
    minlen_ = p.min_segment_length > 0 ? p.min_segment_length : 0.03 * diag;
    Mat gf;
    GaussianBlur(g0, gf, Size(), 1.0);
    gf.convertTo(gf, CV_32F);
    Sobel(gf, gx_, CV_32F, 1, 0, 3);
    Sobel(gf, gy_, CV_32F, 0, 1, 3);
}

std::vector<Vec4f> MergedSegments::finish(const std::vector<Vec4f>& raw,
                                          const std::vector<int>& raw_mask, bool merge_again,
                                          std::vector<int>* passes) const {
    // Pieces shorter than a third of the threshold are texture; longer ones may join up.
    std::vector<Piece> pieces;
    for (size_t i = 0; i < raw.size(); ++i) {
        const Vec4f& s = raw[i];
        Piece pc{Vec2d(s[0], s[1]), Vec2d(s[2], s[3]), raw_mask[i]};
        if (pc.len() >= std::max(6.0, minlen_ / 3)) pieces.push_back(pc);
    }
    pieces = mergeCollinear(pieces);
    // The refit depends on the piece alone: a piece the LSD set also had is refitted once.
    for (auto& pc : pieces) {
        const std::array<double, 4> key = {pc.p[0], pc.p[1], pc.q[0], pc.q[1]};
        const auto it = refitted_.find(key);
        if (it != refitted_.end()) {
            pc.p = Vec2d(it->second[0], it->second[1]);
            pc.q = Vec2d(it->second[2], it->second[3]);
            continue;
        }
        refitPiece(gx_, gy_, pc, 3.0);
        refitted_.emplace(key, std::array<double, 4>{pc.p[0], pc.p[1], pc.q[0], pc.q[1]});
    }
    if (merge_again) pieces = mergeCollinear(pieces);
    std::vector<std::pair<Vec4f, int>> out;
    for (const auto& pc : pieces)
        if (pc.len() >= minlen_) {
            // LSD passes only (bits 0–2). FLD runs on the quarter pass's σ = 2 copy, so it is not
            // an independent sighting; counting it as a fourth pass was measured worse (AA@3/5/10
            // 82.6 / 86.8 / 90.2 at a = 1, doc/vbme_calib.md).
            const int m = ((pc.mask >> 0) & 1) + ((pc.mask >> 1) & 1) + ((pc.mask >> 2) & 1);
            out.emplace_back(Vec4f((float)pc.p[0], (float)pc.p[1], (float)pc.q[0], (float)pc.q[1]),
                             m);
        }
    std::stable_sort(
        out.begin(), out.end(), [](const std::pair<Vec4f, int>& x, const std::pair<Vec4f, int>& y) {
            const Vec4f &a = x.first, &b = y.first;
            return std::hypot(a[2] - a[0], a[3] - a[1]) > std::hypot(b[2] - b[0], b[3] - b[1]);
        });
    if ((int)out.size() > max_segments_) out.resize(max_segments_);
    std::vector<Vec4f> segs(out.size());
    if (passes) passes->resize(out.size());
    for (size_t i = 0; i < out.size(); ++i) {
        segs[i] = out[i].first;
        if (passes) (*passes)[i] = out[i].second;
    }
    return segs;
}

std::vector<Vec4f> MergedSegments::lsd(std::vector<int>* passes) const {
    return finish(raw_, raw_mask_, false, passes);
}

std::vector<Vec4f> MergedSegments::withFld(std::vector<int>* passes) const {
#ifdef VBME_HAVE_XIMGPROC
    // FastLineDetector (Canny edges, then straight runs of edge pixels) on the σ = 2 copy of
    // LSD's third pass, at full resolution: it follows long faint edges LSD's gradient test
    // breaks up in noisy images. Its pieces join the LSD pieces in the same merge and refit; a
    // second merge after the refit joins duplicates the refit brought onto one edge. (Canny
    // 20/40; session 9 measured 10/20 … 30/60 and σ 1.5 … 2.5 as well: doc/vbme_calib.md.)
    std::vector<Vec4f> r;
    ximgproc::createFastLineDetector(10, 1.414213562f, 20, 40, 3, false)->detect(blurred2_, r);
    std::vector<Vec4f> rw = raw_;
    rw.insert(rw.end(), r.begin(), r.end());
    std::vector<int> mask = raw_mask_;
    mask.insert(mask.end(), r.size(), 1 << 3);
    return finish(rw, mask, true, passes);
#else
    if (passes) passes->clear();
    return {};
#endif
}

void detectSegmentsMerged(const Mat& gray, const VanishingPointCalibrator::Params& p,
                          std::vector<Vec4f>& segments) {
    segments = MergedSegments(gray, p).lsd();
}

namespace {

/** A segment in normalised coordinates ((pixel − principal point) / W). */
struct Seg {
    Vec2d a, b;      // endpoints as detected (distorted)
    Vec2d ua, ub;    // endpoints undistorted with the current κ
    Vec2d m, u;      // undistorted midpoint and unit direction
    Vec3d l;         // undistorted line, unit normal
    double len = 0;  // length in pixels
    double thr = 0;  // sine of the inlier angle
    double w = 0;    // weight (length share)
    double q = 1;    // factor on its residual in the refinement (Params::pass_weight)
};

/** Undistorts a normalised point: x_d = x_u (1 + κ |x_u|²) solved for x_u. */
template <class T>
void undistortKappa(const T& xd, const T& yd, const T& kappa, T& xu, T& yu) {
    xu = xd;
    yu = yd;
    for (int it = 0; it < 8; ++it) {
        T s = T(1) + kappa * (xu * xu + yu * yu);
        if (s < T(0.2)) s = T(0.2);
        xu = xd / s;
        yu = yd / s;
    }
}

void setKappa(std::vector<Seg>& segs, double kappa) {
    for (auto& s : segs) {
        undistortKappa(s.a[0], s.a[1], kappa, s.ua[0], s.ua[1]);
        undistortKappa(s.b[0], s.b[1], kappa, s.ub[0], s.ub[1]);
        s.m = (s.ua + s.ub) * 0.5;
        const Vec2d d = s.ub - s.ua;
        const double n = norm(d);
        s.u = n > 0 ? d / n : Vec2d(1, 0);
        Vec3d l = Vec3d(s.ua[0], s.ua[1], 1).cross(Vec3d(s.ub[0], s.ub[1], 1));
        const double ln = std::hypot(l[0], l[1]);
        s.l = ln > 0 ? l / ln : l;
    }
}

inline double angleSin(const Seg& s, const Vec3d& v) {
    const double tx = v[0] - s.m[0] * v[2], ty = v[1] - s.m[1] * v[2];
    const double tn = std::hypot(tx, ty);
    if (tn < 1e-12) return 1.0;
    return std::abs(s.u[0] * ty - s.u[1] * tx) / tn;
}

inline double vote(const Seg& s, const Vec3d& v) {
    const double sa = angleSin(s, v);
    if (sa >= s.thr) return 0;
    const double r = sa / s.thr;
    return s.w * (1 - r * r);
}

/** A Manhattan frame: D's columns are the three directions in camera coordinates, F the
focal length in units of W. */
struct Frame {
    Matx33d D;
    double F = 1, kappa = 0, score = 0;
    /** Standard deviation of log F from the refinement (0 when not refined or F is fixed). */
    double sigma_logF = 0;
    Vec3d vp(int a) const { return Vec3d(F * D(0, a), F * D(1, a), D(2, a)); }
};

double scoreFrame(const std::vector<Seg>& segs, const Frame& fr, std::vector<int>* labels,
                  double thr_scale = 1.0, bool exclusive = false) {
    const Vec3d V[3] = {fr.vp(0), fr.vp(1), fr.vp(2)};
    double sc = 0;
    if (labels) labels->assign(segs.size(), -1);
    for (size_t i = 0; i < segs.size(); ++i) {
        const Seg& s = segs[i];
        double best = s.thr * thr_scale;
        int ba = -1;
        for (int a = 0; a < 3; ++a) {
            const double sa = angleSin(s, V[a]);
            if (sa < best) {
                best = sa;
                ba = a;
            }
        }
        if (ba >= 0) {
            const double r = best / (s.thr * thr_scale);
            sc += s.w * (1 - r * r);
        }
        if (labels) (*labels)[i] = ba;
        if (labels && exclusive && ba >= 0) {
            // A segment that also points at another vanishing point (it lies on the line
            // joining the two) tells them apart from nothing: left out.
            for (int a = 0; a < 3; ++a)
                if (a != ba && angleSin(s, V[a]) < s.thr * thr_scale) (*labels)[i] = -1;
        }
    }
    return sc;
}

Vec3d unitPositive(Vec3d v) {
    const double n = norm(v);
    if (n > 0) v /= n;
    if (v[2] < 0 || (v[2] == 0 && (v[0] < 0 || (v[0] == 0 && v[1] < 0)))) v = -v;
    return v;
}

/** Least-squares vanishing point of the segments voting for @p v (weighted lines' normal
space), or @p v when fewer than two vote. */
Vec3d refineCandidate(const std::vector<Seg>& segs, const Vec3d& v) {
    Matx33d M = Matx33d::zeros();
    int k = 0;
    for (const auto& s : segs) {
        const double sa = angleSin(s, v);
        if (sa >= s.thr) continue;
        const double r = sa / s.thr;
        M += (s.w * (1 - r * r)) * (s.l * s.l.t());
        ++k;
    }
    if (k < 2) return v;
    Matx31d ev;
    Matx33d evec;
    eigen(M, ev, evec);
    return unitPositive(Vec3d(evec(2, 0), evec(2, 1), evec(2, 2)));
}

/** All pairs of the longest segments' lines → candidates, NMS, refined. */
std::vector<std::pair<double, Vec3d>> vpCandidates(const std::vector<Seg>& segs, int n_long,
                                                   int keep) {
    const int N = std::min<int>((int)segs.size(), n_long);
    std::vector<std::pair<double, Vec3d>> cand;
    cand.reserve(N * (N - 1) / 2);
    for (int i = 0; i < N; ++i)
        for (int j = i + 1; j < N; ++j) {
            Vec3d v = segs[i].l.cross(segs[j].l);
            const double nv = norm(v);
            if (nv < 1e-12) continue;
            v /= nv;
            if (std::abs(v[2]) > 1e-9) {  // a finite VP must not lie inside either segment
                const Vec2d p(v[0] / v[2], v[1] / v[2]);
                if ((p - segs[i].ua).dot(p - segs[i].ub) < 0 ||
                    (p - segs[j].ua).dot(p - segs[j].ub) < 0)
                    continue;
            }
            double sc = 0;
            for (const auto& s : segs)
                sc += vote(s, v);
            cand.emplace_back(sc, unitPositive(v));
        }
    std::sort(cand.begin(), cand.end(),
              [](const std::pair<double, Vec3d>& a, const std::pair<double, Vec3d>& b) {
                  return a.first > b.first;
              });
    // Non-maximum suppression by votes: a candidate is kept when most of its votes come from
    // segments no kept candidate explains yet (a strong vanishing point has many near
    // duplicates, which would otherwise crowd out the weaker directions).
    const double cos_sep = std::cos(1.0 * CV_PI / 180);
    std::vector<char> claimed(segs.size(), 0);
    std::vector<std::pair<double, Vec3d>> kept;
    for (const auto& c : cand) {
        if (c.first <= 0) break;
        bool dup = false;
        for (const auto& k : kept)
            if (std::abs(c.second.dot(k.second)) > cos_sep) {
                dup = true;
                break;
            }
        if (dup) continue;
        double novel = 0;
        for (size_t i = 0; i < segs.size(); ++i)
            if (!claimed[i]) novel += vote(segs[i], c.second);
        if (novel < 0.5 * c.first) continue;
        kept.push_back(c);
        for (size_t i = 0; i < segs.size(); ++i)
            if (vote(segs[i], c.second) > 0) claimed[i] = 1;
        if ((int)kept.size() >= keep) break;
    }
    for (auto& k : kept) {
        k.second = refineCandidate(segs, k.second);
        double sc = 0;
        for (const auto& s : segs)
            sc += vote(s, k.second);
        k.first = sc;
    }
    return kept;
}

Frame frameFrom(const Vec3d& a, const Vec3d& b, double F, bool orthogonalise) {
    Vec3d d1 = normalize(Vec3d(a[0] / F, a[1] / F, a[2]));
    Vec3d d2 = normalize(Vec3d(b[0] / F, b[1] / F, b[2]));
    if (orthogonalise) d2 = normalize(d2 - d1 * d1.dot(d2));
    const Vec3d d3 = d1.cross(d2);
    Frame fr;
    fr.F = F;
    for (int r = 0; r < 3; ++r) {
        fr.D(r, 0) = d1[r];
        fr.D(r, 1) = d2[r];
        fr.D(r, 2) = d3[r];
    }
    return fr;
}

/** Every pair of candidates → frame(s), scored; best first. */
std::vector<Frame> pairHypotheses(const std::vector<Seg>& segs,
                                  const std::vector<std::pair<double, Vec3d>>& cand,
                                  const VanishingPointCalibrator::Params& p, double W) {
    std::vector<Frame> hyp;
    const double minF = p.min_focal, maxF = p.max_focal;
    std::vector<double> fixedF;
    if (p.focal > 0)
        fixedF.push_back(p.focal / W);
    else if (p.focal_prior > 0)
        fixedF.push_back(p.focal_prior / W);
    const double max_cos = std::sin(12.0 * CV_PI / 180);
    for (size_t i = 0; i < cand.size(); ++i)
        for (size_t j = i + 1; j < cand.size(); ++j) {
            const Vec3d &a = cand[i].second, &b = cand[j].second;
            if (p.focal <= 0 && std::abs(a[2]) > 1e-6 && std::abs(b[2]) > 1e-6) {
                const double F2 = -(a[0] * b[0] + a[1] * b[1]) / (a[2] * b[2]);
                if (F2 > minF * minF && F2 < maxF * maxF) {
                    Frame fr = frameFrom(a, b, std::sqrt(F2), true);
                    fr.score = scoreFrame(segs, fr, nullptr);
                    hyp.push_back(fr);
                }
            }
            for (double F : fixedF) {
                Frame fr = frameFrom(a, b, F, false);
                const Vec3d d1(fr.D(0, 0), fr.D(1, 0), fr.D(2, 0)),
                    d2(fr.D(0, 1), fr.D(1, 1), fr.D(2, 1));
                if (std::abs(d1.dot(d2)) > max_cos) continue;
                fr = frameFrom(a, b, F, true);
                fr.score = scoreFrame(segs, fr, nullptr);
                hyp.push_back(fr);
            }
        }
    std::sort(hyp.begin(), hyp.end(),
              [](const Frame& x, const Frame& y) { return x.score > y.score; });
    return hyp;
}

bool sameFrame(const Frame& x, const Frame& y) {
    if (std::abs(std::log(x.F / y.F)) > 0.05) return false;
    const double c = std::cos(3.0 * CV_PI / 180);
    for (int a = 0; a < 3; ++a) {
        bool found = false;
        for (int b = 0; b < 3 && !found; ++b) {
            double d = 0;
            for (int r = 0; r < 3; ++r)
                d += x.D(r, a) * y.D(r, b);
            found = std::abs(d) > c;
        }
        if (!found) return false;
    }
    return true;
}

/** Endpoint distance to the line joining the midpoint and the VP of the segment's axis, in
pixels, with the endpoints undistorted by κ. */
struct SegmentCost {
    double ax, ay, bx, by, sw;
    Vec3d d0;  // the axis direction before the rotation update
    template <class T>
    bool operator()(const T* rot, const T* logF, const T* kappa, T* r) const {
        T xa, ya, xb, yb;
        undistortKappa(T(ax), T(ay), kappa[0], xa, ya);
        undistortKappa(T(bx), T(by), kappa[0], xb, yb);
        const T p[3] = {T(d0[0]), T(d0[1]), T(d0[2])};
        T d[3];
        ceres::AngleAxisRotatePoint(rot, p, d);
        const T F = exp(logF[0]);
        const T v0 = F * d[0], v1 = F * d[1], v2 = d[2];
        const T m0 = (xa + xb) * 0.5, m1 = (ya + yb) * 0.5;
        const T L0 = m1 * v2 - v1, L1 = v0 - m0 * v2, L2 = m0 * v1 - m1 * v0;
        const T n = sqrt(L0 * L0 + L1 * L1 + T(1e-30));
        r[0] = T(sw) * (L0 * xa + L1 * ya + L2) / n;
        return true;
    }
};

struct FocalPriorCost {
    double logF0, inv_sigma;
    template <class T>
    bool operator()(const T* logF, T* r) const {
        r[0] = (logF[0] - T(logF0)) * T(inv_sigma);
        return true;
    }
};

/** Bounds of the refinement's log(f / W). */
const double kLogFMin = std::log(0.05), kLogFMax = std::log(50.0);

/** Relabel + robust joint refinement, a few rounds. */
void refineFrame(std::vector<Seg>& segs, Frame& fr, const VanishingPointCalibrator::Params& p,
                 double W, bool est_kappa) {
    double mean_len = 0;
    for (const auto& s : segs)
        mean_len += s.len;
    mean_len /= std::max<size_t>(1, segs.size());
    bool weighted = false;  // Params::pass_weight (makeSegs)
    for (const auto& s : segs)
        weighted = weighted || s.q != 1;
    const int rounds = 3;
    for (int round = 0; round < rounds; ++round) {
        setKappa(segs, fr.kappa);
        std::vector<int> labels;
        scoreFrame(segs, fr, &labels, 1.5, true);
        double rot[3] = {0, 0, 0}, logF = std::clamp(std::log(fr.F), kLogFMin, kLogFMax),
               kappa = fr.kappa;
        // The residual blocks; with_q: each segment's times its pass factor s.q.
        auto build = [&](ceres::Problem& problem, bool with_q) {
            int nres = 0;
            for (size_t i = 0; i < segs.size(); ++i) {
                if (labels[i] < 0) continue;
                const Seg& s = segs[i];
                auto* c = new SegmentCost{
                    s.a[0],
                    s.a[1],
                    s.b[0],
                    s.b[1],
                    W * std::sqrt(s.len / mean_len) * (with_q ? s.q : 1.0),
                    Vec3d(fr.D(0, labels[i]), fr.D(1, labels[i]), fr.D(2, labels[i]))};
                problem.AddResidualBlock(
                    new ceres::AutoDiffCostFunction<SegmentCost, 1, 3, 1, 1>(c),
                    new ceres::CauchyLoss(1.0), rot, &logF, &kappa);
                ++nres;
            }
            if (p.focal > 0)
                problem.SetParameterBlockConstant(&logF);
            else if (nres > 0) {
                // f within 0.05-50x the image width: far outside any frame the search keeps
                // (0.3-6x), but a step can no longer run log f away to hundreds (seed 29's
                // room_023 with the FLD pass: a NaN Jacobian and an error printed by Ceres).
                problem.SetParameterLowerBound(&logF, 0, kLogFMin);
                problem.SetParameterUpperBound(&logF, 0, kLogFMax);
            }
            if (!est_kappa) problem.SetParameterBlockConstant(&kappa);
            if (p.focal <= 0 && p.focal_prior > 0)
                problem.AddResidualBlock(
                    new ceres::AutoDiffCostFunction<FocalPriorCost, 1, 1>(new FocalPriorCost{
                        std::log(p.focal_prior / W), 1.0 / std::max(1e-3, p.focal_prior_sigma)}),
                    nullptr, &logF);
            return nres;
        };
        ceres::Problem problem;
        const int nres = build(problem, true);
        if (nres < 5) return;
        ceres::Solver::Options opt;
        opt.linear_solver_type = ceres::DENSE_QR;
        opt.max_num_iterations = 30;
        opt.num_threads = 1;
        opt.logging_type = ceres::SILENT;
        ceres::Solver::Summary sum;
        ceres::Solve(opt, &problem, &sum);
        if (round == rounds - 1 && p.focal <= 0) {
            // Uncertainty of log F: (JᵀJ)⁻¹ of the robustified problem at the optimum, scaled
            // by its residual variance (a Gauss–Newton covariance; κ left free when estimated).
            ceres::Problem::EvaluateOptions eo;
            eo.parameter_blocks = {rot, &logF};
            if (est_kappa) eo.parameter_blocks.push_back(&kappa);
            double cost = 0;
            std::vector<double> res;
            ceres::CRSMatrix J;
            // With pass weights, from the unweighted residuals at the weighted optimum: the
            // weights say which segments are less biased, not that the data are more precise
            // (a weighted covariance shrank σ by up to 1.4× where the drift did not fall).
            if (weighted) {
                ceres::Problem plain;
                build(plain, false);
                plain.Evaluate(eo, &cost, &res, nullptr, &J);
            } else
                problem.Evaluate(eo, &cost, &res, nullptr, &J);
            const int np = J.num_cols;
            Mat JtJ = Mat::zeros(np, np, CV_64F);
            for (int r = 0; r < J.num_rows; ++r)
                for (int a = J.rows[r]; a < J.rows[r + 1]; ++a)
                    for (int b = J.rows[r]; b < J.rows[r + 1]; ++b)
                        JtJ.at<double>(J.cols[a], J.cols[b]) += J.values[a] * J.values[b];
            const int dof = std::max(1, (int)res.size() - np);
            const double s2 = 2 * cost / dof;
            Mat cov;
            if (invert(JtJ, cov, DECOMP_SVD) > 0)
                fr.sigma_logF = std::sqrt(std::max(0.0, s2 * cov.at<double>(3, 3)));
        }
        Matx33d dR;
        Rodrigues(Vec3d(rot[0], rot[1], rot[2]), dR);
        fr.D = dR * fr.D;
        fr.F = std::exp(logF);
        fr.kappa = kappa;
    }
    setKappa(segs, fr.kappa);
    fr.score = scoreFrame(segs, fr, nullptr);
}

/** Segments (pixels) in normalised coordinates around @p pp, with their inlier angles and
length weights. */
std::vector<Seg> makeSegs(const std::vector<Vec4f>& px, const Point2d& pp, double W,
                          const VanishingPointCalibrator::Params& p,
                          const std::vector<int>* passes = nullptr) {
    std::vector<Seg> segs(px.size());
    double total = 0;
    const double thr_max = std::sin(2.0 * p.inlier_angle_deg * CV_PI / 180),
                 thr_min = std::sin(0.3 * p.inlier_angle_deg * CV_PI / 180);
    for (size_t i = 0; i < px.size(); ++i) {
        Seg& s = segs[i];
        s.a = Vec2d((px[i][0] - pp.x) / W, (px[i][1] - pp.y) / W);
        s.b = Vec2d((px[i][2] - pp.x) / W, (px[i][3] - pp.y) / W);
        s.len = std::hypot(px[i][2] - px[i][0], px[i][3] - px[i][1]);
        // Angular uncertainty of a segment of length L with endpoint noise σ: √2 σ / L
        // (σ = 0.5 px), plus 0.1° of model error; the inlier threshold is 3 of those.
        const double sig = std::sqrt(2.0) * 0.5 / std::max(1.0, s.len) + 0.1 * CV_PI / 180;
        s.thr = std::min(thr_max, std::max(thr_min, std::sin(3 * sig)));
        s.w = s.len;
        total += s.len;
    }
    for (auto& s : segs)
        s.w /= total;
    // Params::pass_weight: the refinement's weight 1 + a (m − 1) of a segment m LSD passes
    // found (an FLD-only segment counts as one), divided by its mean over the segments so
    // that the weights are relative: the Cauchy loss's scale and a focal prior's pull
    // against the segments stay as without them. s.q multiplies the residual (√ of the weight).
    const double a = p.pass_weight;
    if (a > 0 && passes && passes->size() == segs.size()) {
        double mean_f = 0;
        for (size_t i = 0; i < segs.size(); ++i)
            mean_f += 1 + a * (std::max(1, (*passes)[i]) - 1);
        mean_f /= std::max<size_t>(1, segs.size());
        // (every m = 1: mean 1, every q exactly 1, as without weights)
        for (size_t i = 0; i < segs.size(); ++i)
            segs[i].q = std::sqrt((1 + a * (std::max(1, (*passes)[i]) - 1)) / mean_f);
    }
    return segs;
}

/** Distinct image lines among the segments @p idx of @p px: pieces of one edge (both endpoints
within @p tol pixels of a longer piece's line) count once. The pieces of one edge are not
independent evidence of its vanishing point: their residuals share the edge's own error. */
int distinctLines(const std::vector<Vec4f>& px, const std::vector<int>& idx, double tol) {
    std::vector<int> ord = idx;
    auto len = [&](int i) {
        return std::hypot((double)px[i][2] - px[i][0], (double)px[i][3] - px[i][1]);
    };
    std::stable_sort(ord.begin(), ord.end(), [&](int a, int b) { return len(a) > len(b); });
    std::vector<Vec3d> lines;  // unit normal, offset
    for (int i : ord) {
        const Vec4d q = px[i];
        bool same = false;
        for (const Vec3d& l : lines)
            if (std::max(std::abs(l[0] * q[0] + l[1] * q[1] + l[2]),
                         std::abs(l[0] * q[2] + l[1] * q[3] + l[2])) < tol) {
                same = true;
                break;
            }
        if (same) continue;
        const double L = std::max(1e-9, len(i)), nx = -(q[3] - q[1]) / L, ny = (q[2] - q[0]) / L;
        lines.emplace_back(nx, ny, -(nx * q[0] + ny * q[1]));
    }
    return (int)lines.size();
}

/** The largest share of the length of the segments @p idx of @p px inside one window of a third
of the image's width and height (windows stepped by a tenth of the free range). 1 when all of
it lies in one ninth of the image, e.g. on one small box. */
double lengthConcentration(const std::vector<Vec4f>& px, const std::vector<int>& idx, Size size) {
    struct Pt {
        double x, y, w;
    };
    std::vector<Pt> pts;
    double total = 0;
    for (int i : idx) {
        const Vec4d q = px[i];
        const double L = std::hypot(q[2] - q[0], q[3] - q[1]);
        const int m = std::max(2, (int)(L / 5));
        for (int j = 0; j < m; ++j) {
            const double t = (j + 0.5) / m;
            pts.push_back({q[0] + t * (q[2] - q[0]), q[1] + t * (q[3] - q[1]), L / m});
        }
        total += L;
    }
    if (total <= 0) return 1;
    const double ww = size.width / 3.0, wh = size.height / 3.0;
    double best = 0;
    for (int ix = 0; ix <= 10; ++ix)
        for (int iy = 0; iy <= 10; ++iy) {
            const double x0 = ix / 10.0 * (size.width - ww), y0 = iy / 10.0 * (size.height - wh);
            double in = 0;
            for (const Pt& p : pts)
                if (p.x >= x0 && p.x < x0 + ww && p.y >= y0 && p.y < y0 + wh) in += p.w;
            best = std::max(best, in);
        }
    return best / total;
}

}  // namespace

double uprightPrior(const Matx33d& R, double sigma_deg) {
    if (!(sigma_deg > 0)) return 1;
    // World up in camera coordinates (camera y down, z forward): R's third column.
    const double ux = R(0, 2), uy = R(1, 2), uz = R(2, 2);
    const double deg = 180 / CV_PI;
    const double pitch = std::asin(std::max(-1.0, std::min(1.0, uz))) * deg;
    const double roll = std::atan2(ux, -uy) * deg;
    const double er = std::max(0.0, std::abs(roll) - 15) / sigma_deg,
                 ep = std::max(0.0, std::abs(pitch) - 45) / sigma_deg;
    return std::exp(-0.5 * (er * er + ep * ep));
}

double supportSpread(const FrameCalibration& c, std::string* why) {
    const std::vector<Vec4f>& px = c.segments;
    if (c.labels.size() != px.size()) return 1;
    int support[3] = {0, 0, 0};
    for (int l : c.labels)
        if (l >= 0 && l < 3) ++support[l];
    int order[3] = {0, 1, 2};
    std::stable_sort(order, order + 3, [&](int a, int b) { return support[a] > support[b]; });
    if (support[order[1]] < 1) return 1;
    std::vector<int> idx2, idx23;
    for (int i = 0; i < (int)px.size(); ++i)
        if (c.labels[i] == order[1] || c.labels[i] == order[2]) {
            idx23.push_back(i);
            if (c.labels[i] == order[1]) idx2.push_back(i);
        }
    const double W = std::max(c.image_size.width, c.image_size.height);
    const int lines = distinctLines(px, idx2, 4.0 * W / 640);
    const double f_lines = std::min(1.0, lines / 4.0) / std::min(1.0, support[order[1]] / 4.0);
    const double conc = lengthConcentration(px, idx23, c.image_size);
    const double f_conc = std::max(0.0, std::min(1.0, (1 - conc) / 0.5));
    if (why) {
        why->clear();
        if (f_lines < 1)
            *why = format("the second direction's %d segments lie on %d distinct lines",
                          support[order[1]], lines);
        if (f_conc < 1)
            *why += (why->empty() ? "" : "; ") +
                    format(
                        "%.0f %% of the second and third directions' length lies in one "
                        "ninth of the image (one object's frame?)",
                        100 * conc);
    }
    return f_lines * f_conc;
}

std::vector<ManhattanProposal> searchManhattan(const std::vector<Vec4f>& px, Size size,
                                               const VanishingPointCalibrator::Params& p,
                                               int max_proposals, const Mat& gray,
                                               const Edgels* shared_edgels,
                                               const std::vector<int>* passes) {
    const int n = (int)px.size();
    if (n < 6)
        CV_Error(Error::StsError,
                 format("automatic detection found only %d line segments; expected at least "
                        "6 (annotate the lines by hand)",
                        n));
    if (max_proposals < 1) max_proposals = 1;
    const double W = std::max(size.width, size.height);
    const Point2d pp = p.principal_point.x >= 0 && p.principal_point.y >= 0
                           ? p.principal_point
                           : Point2d((size.width - 1) * 0.5, (size.height - 1) * 0.5);
    std::vector<Seg> segs = makeSegs(px, pp, W, p, passes);
    // Edge pixels (Params::edgel_scoring; manhattan_edgels.hpp): at most 3000, σ 1.5°, ε 0.4.
    // Not with distortion estimation (the edgels are not undistorted).
    const bool use_edgels = p.edgel_scoring && !gray.empty() && !p.estimate_distortion;
    Edgels own_edgels;
    const EdgelModel em;
    if (use_edgels && !shared_edgels) own_edgels = extractEdgels(gray, pp, W, 3000);
    const Edgels& edgels = shared_edgels ? *shared_edgels : own_edgels;
    // Search (at each κ of a grid when distortion is estimated; κ in units of W).
    std::vector<double> kappas = {0.0};
    if (p.estimate_distortion) kappas = {0.0, -0.05, -0.1, -0.2, -0.3, -0.45, -0.6, 0.05, 0.1};
    std::vector<Frame> hyp;
    double best_sc = -1, best_kappa = 0;
    std::vector<std::pair<double, Vec3d>> best_cand;
    for (double kappa : kappas) {
        setKappa(segs, kappa);
        const auto cand = vpCandidates(segs, 80, 30);
        std::vector<Frame> h = pairHypotheses(segs, cand, p, W);
        if (!h.empty() && h[0].score > best_sc) {
            best_sc = h[0].score;
            best_kappa = kappa;
            hyp.swap(h);
            best_cand = cand;
            for (auto& f : hyp)
                f.kappa = kappa;
        }
    }
    (void)best_kappa;
    if (hyp.empty())
        CV_Error(Error::StsError,
                 "automatic detection found no pair of orthogonal vanishing points with a "
                 "plausible focal length; annotate the lines by hand or give the focal length");
    // Distinct frames, refined, re-ranked. A refined frame is refused below when its second
    // direction has fewer than 3 segments or its focal length is implausible; when every frame
    // of a batch is refused, the next distinct hypotheses are refined too (at most 4 batches),
    // so that refused frames scoring best do not hide a valid one further down.
    auto plausible = [&](const Frame& fr) {
        setKappa(segs, fr.kappa);
        std::vector<int> labels;
        scoreFrame(segs, fr, &labels);
        int support[3] = {0, 0, 0};
        for (int l : labels)
            if (l >= 0) support[l]++;
        std::sort(support, support + 3);
        return support[1] >= 3 && fr.F >= p.min_focal && fr.F <= p.max_focal;
    };
    std::vector<Frame> frames, picked;
    const int batch = max_proposals + 2, max_batches = 4;
    size_t next = 0;
    for (int b = 0; b < max_batches && next < hyp.size(); ++b) {
        const size_t first = frames.size();
        for (; next < hyp.size() && (int)(frames.size() - first) < batch; ++next) {
            bool dup = false;
            for (const auto& f : picked)
                if (sameFrame(hyp[next], f)) {
                    dup = true;
                    break;
                }
            if (dup) continue;
            picked.push_back(hyp[next]);
            frames.push_back(hyp[next]);
        }
        bool any = false;
        for (size_t k = first; k < frames.size(); ++k) {
            refineFrame(segs, frames[k], p, W, p.estimate_distortion);
            any = any || plausible(frames[k]);
        }
        if (any) break;
    }
    if (use_edgels) {
        // Frames the edge pixels favour join the refined ones: the first 400 hypotheses (by
        // segment consensus) scored on 600 of the edgels, the 6 best distinct ones not refined
        // yet are refined too (by the segments, as the others).
        const Edgels sub = subsampleEdgels(edgels, 600);
        std::vector<std::pair<double, size_t>> es;
        for (size_t k = 0; k < std::min<size_t>(hyp.size(), 400); ++k)
            es.emplace_back(edgelScore(sub, hyp[k].D, hyp[k].F, em), k);
        std::stable_sort(es.begin(), es.end(),
                         [](const std::pair<double, size_t>& a,
                            const std::pair<double, size_t>& b) { return a.first > b.first; });
        int added = 0;
        for (const auto& e : es) {
            if (added >= 6) break;
            bool dup = false;
            for (const auto& f : picked)
                dup = dup || sameFrame(hyp[e.second], f);
            if (dup) continue;
            picked.push_back(hyp[e.second]);
            Frame fr = hyp[e.second];
            refineFrame(segs, fr, p, W, false);
            frames.push_back(fr);
            ++added;
        }
    }
    if (use_edgels && p.focal <= 0 && p.focal_prior <= 0) {
        // Frames from the strongest vanishing-point candidate alone (manhattan_edgels.hpp):
        // the other two directions are found by the edge pixels, which see the soft shading
        // edges no segment pass finds. The two best distinct ones are refined by the segments
        // like the others, with the edgels' focal length as a prior (σ 15 % and 25 %, the better
        // kept) since where the segments determine it weakly they drag it off.
        std::vector<double> Fs;
        for (int k = 0; k < 12; ++k)
            Fs.push_back(
                std::max(p.min_focal, 0.35) *
                std::pow(std::min(p.max_focal, 3.0) / std::max(p.min_focal, 0.35), (k + 0.5) / 12));
        // Not with a known or prior focal length: there it made two images worse and fixed none.
        const std::vector<EdgelFrame> grid =
            best_cand.empty() ? std::vector<EdgelFrame>()
                              : edgelFramesAroundVP(edgels, best_cand[0].second, Fs, 36, em);
        const Edgels sub = subsampleEdgels(edgels, 600);
        int added = 0;
        for (EdgelFrame g : grid) {
            if (added >= 2) break;
            refineEdgels(sub, g.D, g.F, em, false, 5);  // off the grid's steps
            Frame fr;
            fr.D = g.D;
            fr.F = g.F;
            bool dup = false;
            for (const auto& f : picked)
                dup = dup || sameFrame(fr, f);
            if (dup) continue;
            picked.push_back(fr);
            // Both refined, the one of higher segment consensus kept (keeping both split the
            // confidence of right answers between near-duplicates).
            Frame best;
            best.score = -1;
            for (double sigma : {0.15, 0.25}) {
                VanishingPointCalibrator::Params pe = p;
                pe.focal_prior = fr.F * W;
                pe.focal_prior_sigma = sigma;
                Frame f2 = fr;
                refineFrame(segs, f2, pe, W, false);
                if (f2.score > best.score) best = f2;
            }
            frames.push_back(best);
            ++added;
        }
    }
    std::sort(frames.begin(), frames.end(),
              [](const Frame& x, const Frame& y) { return x.score > y.score; });
    // Refinement can bring two hypotheses onto one frame.
    std::vector<Frame> uniq;
    for (const auto& f : frames) {
        bool dup = false;
        for (const auto& u : uniq)
            if (sameFrame(f, u)) dup = true;
        if (!dup) uniq.push_back(f);
    }
    std::vector<ManhattanProposal> out;
    std::vector<double> out_edgel;  // each proposal's edgel score (use_edgels)
    std::vector<Matx33d> out_D;     // each proposal's directions (columns, camera coordinates)
    std::vector<std::vector<int>> out_labels;  // and its segments' labels (columns of out_D)
    std::string first_reason;
    for (size_t k = 0; k < uniq.size(); ++k) {
        const Frame& fr = uniq[k];
        setKappa(segs, fr.kappa);
        std::vector<int> labels;
        scoreFrame(segs, fr, &labels);
        int support[3] = {0, 0, 0};
        double support_len[3] = {0, 0, 0}, inlier_len = 0;
        for (int i = 0; i < n; ++i)
            if (labels[i] >= 0) {
                support[labels[i]]++;
                support_len[labels[i]] += segs[i].w;
                inlier_len += segs[i].w;
            }
        int order[3] = {0, 1, 2};
        std::sort(order, order + 3, [&](int a, int b) { return support[a] > support[b]; });
        std::string reason;
        const double fpx = fr.F * W;
        if (support[order[1]] < 3)
            reason = format(
                "only one line direction (%d segments; the next has %d); expected at "
                "least two orthogonal directions",
                support[order[0]], support[order[1]]);
        else if (fr.F < p.min_focal || fr.F > p.max_focal)
            reason = format("implausible focal length %.1f px (expected %.0f–%.0f)", fpx,
                            p.min_focal * W, p.max_focal * W);
        if (!reason.empty()) {
            if (first_reason.empty()) first_reason = reason;
            continue;
        }
        std::vector<Vec3d> dirs(3);
        for (int a = 0; a < 3; ++a)
            dirs[a] = Vec3d(fr.D(0, a), fr.D(1, a), fr.D(2, a));
        std::vector<int> axis_of;
        const Matx33d R = rotationFromDirections(dirs, {}, &axis_of);
        ManhattanProposal mp;
        FrameCalibration& c = mp.calibration;
        c.image_size = size;
        c.K = Matx33d(fpx, 0, pp.x, 0, fpx, pp.y, 0, 0, 1);
        c.R = R;
        c.k1 = fr.kappa * fr.F * fr.F;  // κ (units of W) → k1 (units of f)
        c.segments = px;
        c.labels.resize(n);
        double s2 = 0;
        int ninl = 0;
        for (int i = 0; i < n; ++i) {
            c.labels[i] = labels[i] < 0 ? -1 : axis_of[labels[i]];
            if (labels[i] >= 0) {
                const Seg& s = segs[i];
                const Vec3d v = fr.vp(labels[i]);
                const double a0 = s.m[1] * v[2] - v[1], a1 = v[0] - s.m[0] * v[2],
                             a2 = s.m[0] * v[1] - s.m[1] * v[0];
                const double d =
                    W * (a0 * s.ua[0] + a1 * s.ua[1] + a2) / std::max(1e-300, std::hypot(a0, a1));
                s2 += d * d;
                ++ninl;
            }
        }
        for (int a = 0; a < 3; ++a)
            c.support[axis_of[a]] = support[a];
        for (int a = 0; a < 3; ++a) {
            Vec3d v = c.K * Vec3d(R(0, a), R(1, a), R(2, a));
            v = v / norm(v);
            if (v[2] < 0) v = -v;
            c.vanishing_points[a] = v;
        }
        c.rms_px = ninl ? std::sqrt(s2 / ninl) : 0;
        c.focal_rel_sigma = fr.sigma_logF;
        const double second = support_len[order[1]];
        // A frame whose vanishing points pin the focal length down weakly (relative σ of
        // several per cent) is often wrong, whatever its consensus: confidence falls with σ.
        const double sig_ref = 0.04;
        c.confidence = std::min(1.0, inlier_len) * std::min(1.0, second / 0.1) *
                       std::min(1.0, support[order[1]] / 4.0) /
                       (1 + std::pow(fr.sigma_logF / sig_ref, 2));
        mp.score = fr.score;
        if (c.confidence < p.min_confidence)
            mp.note = format(
                "weak: %.0f %% of the segments' length explained, %d/%d/%d segments "
                "per direction, focal length ±%.0f %%",
                100 * inlier_len, support[0], support[1], support[2], 100 * fr.sigma_logF);
        out.push_back(mp);
        out_edgel.push_back(use_edgels ? edgelScore(edgels, fr.D, fr.F, em) : 0.0);
        out_D.push_back(fr.D);
        out_labels.push_back(labels);
    }
    if (out.empty())
        CV_Error(Error::StsError,
                 "automatic detection gave " + first_reason + "; annotate the lines by hand");
    // Quality of each frame: its own confidence times its (sharpened) consensus relative to
    // the best. Proposals are ranked by it; a proposal's confidence is its own confidence times
    // its share of the qualities. The best and any other proposal of at least half its quality
    // are flagged ambiguous: both are plausible and the user should choose. Two conditions
    // more: the two frames must group the segments differently (more than 10 % of the length
    // the two frames explain together labelled differently: frames that group them alike
    // differ in the focal length within what those vanishing points determine, which the
    // first's focal_rel_sigma and confidence already say, and choosing between them would not
    // change the annotator's groups), and the edge pixels (when used) must not clearly reject
    // the other: two independent evidences must both find the frames close. "Clearly" is an
    // edgel score (mean log-likelihood ratio per edgel, every edge pixel's evidence, not only
    // the segments') lower than the first's by more than 0.05: about 1.5 % of the edge pixels
    // going from well explained (log ratio ≈ +2.3) to unexplained (≈ −0.9).
    const double gamma = 8, ambiguous_ratio = 0.5, edgel_reject = 0.05, regroup_share = 0.1;
    // Length share of the segments that either frame explains and the two label differently
    // (the other frame's directions matched to the nearest of the first's).
    auto regrouped = [&](size_t a, size_t b) {
        int map[3];
        for (int j = 0; j < 3; ++j) {
            double best = -1;
            map[j] = -1;
            for (int i = 0; i < 3; ++i) {
                double d = 0;
                for (int r = 0; r < 3; ++r)
                    d += out_D[b](r, j) * out_D[a](r, i);
                if (std::abs(d) > best) {
                    best = std::abs(d);
                    map[j] = i;
                }
            }
        }
        double both = 0, diff = 0;
        for (int i = 0; i < n; ++i) {
            const int la = out_labels[a][i], lb = out_labels[b][i];
            if (la < 0 && lb < 0) continue;
            both += segs[i].w;
            if (lb < 0 || la != map[lb]) diff += segs[i].w;
        }
        return both > 0 ? diff / both : 0.0;
    };
    double best_score = 0;
    for (const auto& m : out)
        best_score = std::max(best_score, m.score);
    std::vector<double> q(out.size());
    for (size_t k = 0; k < out.size(); ++k)
        q[k] = out[k].calibration.confidence * std::pow(out[k].score / best_score, gamma) *
               uprightPrior(out[k].calibration.R, p.upright_prior);
    std::vector<size_t> order(out.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return q[a] > q[b]; });
    const double qsum = std::accumulate(q.begin(), q.end(), 0.0);
    const double q0 = q[order[0]];
    const double e0 = out_edgel[order[0]];
    auto isRival = [&](size_t k) {
        if (!(q0 > 0 && q[k] >= ambiguous_ratio * q0)) return false;
        if (use_edgels && out_edgel[k] < e0 - edgel_reject) return false;
        return regrouped(order[0], k) > regroup_share;
    };
    bool rival = false;
    for (size_t r = 1; r < order.size(); ++r)
        rival = rival || isRival(order[r]);
    std::vector<ManhattanProposal> ranked;
    for (size_t r = 0; r < order.size() && (int)r < max_proposals; ++r) {
        ManhattanProposal mp = out[order[r]];
        const double qk = q[order[r]];
        mp.confidence = qsum > 0 ? mp.calibration.confidence * qk / qsum : 0;
        // Ranked by q (measured: ranking by the confidence itself gave AA@3/5/10 81.5 / 87.3
        // / 91.7 against 82.4 / 87.9 / 92.0 on the Blender rooms); proposeManhattan keeps the
        // confidences non-increasing along the list.
        mp.ambiguous = rival && (r == 0 || isRival(order[r]));
        if (mp.ambiguous)
            mp.note = r == 0 ? "another Manhattan frame is nearly as good; check both"
                             : "nearly as good as the first proposal; check both";
        ranked.push_back(mp);
    }
    return ranked;
}

namespace {

/** Two proposals' frames are the same: focal lengths within 5 % and every direction of one
within 3° of a direction of the other. */
bool sameCalibration(const FrameCalibration& x, const FrameCalibration& y) {
    if (std::abs(std::log(x.focal() / y.focal())) > 0.05) return false;
    const Matx33d Kx = x.K.inv(), Ky = y.K.inv();
    const double c = std::cos(3.0 * CV_PI / 180);
    for (int k = 0; k < 3; ++k) {
        const Vec3d dx = normalize(Kx * x.vanishing_points[k]);
        double best = 0;
        for (int l = 0; l < 3; ++l)
            best = std::max(best, std::abs(dx.dot(normalize(Ky * y.vanishing_points[l]))));
        if (best < c) return false;
    }
    return true;
}

/** Labels @p px (pixel segments) by the frame of @p c and makes them its segments, so that
proposals found on different segment sets (the LSD and LSD + FLD passes) label one set. */
void labelOnSegments(FrameCalibration& c, const std::vector<Vec4f>& px,
                     const VanishingPointCalibrator::Params& p) {
    const double W = std::max(c.image_size.width, c.image_size.height);
    std::vector<Seg> segs = makeSegs(px, Point2d(c.K(0, 2), c.K(1, 2)), W, p);
    Frame fr;
    fr.D = c.R;  // columns: the world axes in the camera, so labels are world axes
    fr.F = c.K(0, 0) / W;
    fr.kappa = c.k1 / (fr.F * fr.F);
    setKappa(segs, fr.kappa);
    std::vector<int> labels;
    scoreFrame(segs, fr, &labels);
    c.segments = px;
    c.labels = labels;
    for (int a = 0; a < 3; ++a)
        c.support[a] = 0;
    for (int l : labels)
        if (l >= 0) ++c.support[l];
}

/** The proposals in rank order, their confidences as each search gave them (see
proposeManhattan). */
std::vector<ManhattanProposal> proposeInRankOrder(const Mat& gray,
                                                  const VanishingPointCalibrator::Params& p,
                                                  int max_proposals) {
    const MergedSegments ms(gray, p);
    std::vector<int> passes, passes_fld;
    const std::vector<Vec4f> segs = ms.lsd(&passes);
    // The search is chaotic in its segments: a few segments of the weakest direction decide
    // which frame wins, so two slightly different segment sets can give different frames.
    // The FLD pass is a second opinion, asked for when the LSD pass's first proposal is not
    // confident: agreement keeps the LSD pass's answer (and its confidence); disagreement
    // means at least one of the two is wrong, so the FLD pass's frame (it sees the long faint
    // edges LSD misses) is returned with half the confidence and the LSD pass's frame as the
    // next proposal.
    std::vector<ManhattanProposal> a, b;
    std::string err;
    // The edge pixels depend on the image alone: extracted once for both passes.
    Edgels edgels;
    const bool use_edgels = p.edgel_scoring && !gray.empty() && !p.estimate_distortion;
    if (use_edgels) {
        const double W = std::max(gray.cols, gray.rows);
        const Point2d pp = p.principal_point.x >= 0 && p.principal_point.y >= 0
                               ? p.principal_point
                               : Point2d((gray.cols - 1) * 0.5, (gray.rows - 1) * 0.5);
        edgels = extractEdgels(gray, pp, W, 3000);
    }
    const Edgels* shared = use_edgels ? &edgels : nullptr;
    try {
        a = searchManhattan(segs, gray.size(), p, max_proposals, gray, shared, &passes);
    } catch (const cv::Exception& e) {
        err = e.err;
    }
    if (!p.fld_pass || (!a.empty() && a[0].confidence >= p.fld_pass_below_confidence)) {
        if (a.empty()) CV_Error(Error::StsError, err);
        return a;
    }
    const std::vector<Vec4f> segs_fld = ms.withFld(&passes_fld);
    if (!segs_fld.empty()) {
        try {
            b = searchManhattan(segs_fld, gray.size(), p, max_proposals, gray, shared, &passes_fld);
        } catch (const cv::Exception& e) {
            if (err.empty()) err = e.err;
        }
    }
    if (a.empty() && b.empty()) CV_Error(Error::StsError, err);
    if (b.empty()) return a;
    if (a.empty()) return b;
    if (sameCalibration(a[0].calibration, b[0].calibration)) return a;
    // ... unless only the LSD frame would pass detect()'s confidence test.
    if (b[0].calibration.confidence < p.min_confidence &&
        a[0].calibration.confidence >= p.min_confidence)
        std::swap(a, b);
    std::vector<ManhattanProposal> out = b;
    for (auto& m : out) {
        m.confidence *= 0.5;
        m.note = (m.note.empty() ? "" : m.note + "; ") +
                 "the LSD and LSD + FastLineDetector segments give different frames";
    }
    bool listed = false;
    for (const auto& m : out)
        listed = listed || sameCalibration(m.calibration, a[0].calibration);
    if (!listed) {
        ManhattanProposal alt = a[0];
        alt.confidence *= 0.5;
        alt.ambiguous = false;
        alt.note = "first frame of the other segment pass (LSD alone or with FastLineDetector)";
        out.insert(out.begin() + 1, alt);
        if ((int)out.size() > max_proposals) out.resize(std::max(1, max_proposals));
    }
    // One segment set for all proposals (the annotator regroups the first's segments by the
    // one the user chooses): the other pass's frame labels the first proposal's segments.
    for (size_t k = 1; k < out.size(); ++k)
        if (out[k].calibration.segments.size() != out[0].calibration.segments.size() ||
            !std::equal(out[k].calibration.segments.begin(), out[k].calibration.segments.end(),
                        out[0].calibration.segments.begin()))
            labelOnSegments(out[k].calibration, out[0].calibration.segments, p);
    return out;
}

}  // namespace

std::vector<ManhattanProposal> proposeManhattan(const Mat& gray,
                                                const VanishingPointCalibrator::Params& p,
                                                int max_proposals) {
    std::vector<ManhattanProposal> out = proposeInRankOrder(gray, p, max_proposals);
    // The support's spread (supportSpread) lowers each proposal's confidence after the ranking
    // and the choice between the segment passes, which it leaves alone: measured, letting it
    // rank the frames too cost AA@3/5/10 82.4 / 87.9 / 92.0 -> 78.5 / 84.0 / 88.3 on the
    // Blender rooms (two low-confidence right answers lost their rank).
    for (auto& m : out) {
        std::string why;
        const double s = supportSpread(m.calibration, &why);
        m.calibration.confidence *= s;
        m.confidence *= s;
        if (!why.empty()) m.note = (m.note.empty() ? "" : m.note + "; ") + why;
    }
    // The list is shown in rank order with its confidences (the annotator): a proposal never
    // shows more than one ranked above it. Within one search the rank is q, not the reported
    // confidence (searchManhattan); when the two segment passes disagree, the LSD pass's
    // first frame, listed second, has its own pass's scale of confidence.
    for (size_t k = 1; k < out.size(); ++k)
        out[k].confidence = std::min(out[k].confidence, out[k - 1].confidence);
    return out;
}

double refineManhattanFrameFrom(const std::vector<Vec4f>& px, Size size,
                                const VanishingPointCalibrator::Params& p, double focal,
                                const Matx33d& R, double* focal_rel_sigma, double* score,
                                Matx33d* R_out, const std::vector<int>* passes) {
    const double W = std::max(size.width, size.height);
    const Point2d pp = p.principal_point.x >= 0 && p.principal_point.y >= 0
                           ? p.principal_point
                           : Point2d((size.width - 1) * 0.5, (size.height - 1) * 0.5);
    std::vector<Seg> segs = makeSegs(px, pp, W, p, passes);
    Frame fr;
    fr.F = focal / W;
    fr.D = R;
    setKappa(segs, 0);
    refineFrame(segs, fr, p, W, false);
    if (focal_rel_sigma) *focal_rel_sigma = fr.sigma_logF;
    if (score) *score = fr.score;
    if (R_out) *R_out = fr.D;
    return fr.F * W;
}

}  // namespace detail
}  // namespace vbme
}  // namespace cv
