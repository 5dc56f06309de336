// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Room albedo: colour Retinex and irradiance-based albedo (thesis §5.1.2).
#include "opencv2/vbme/render/albedo.hpp"
#include "opencv2/vbme/core/params.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/render/sampler.hpp"
#include "opencv2/vbme/render/scene.hpp"
#include "room_faces.hpp"

namespace cv {
namespace vbme {

using render_detail::lookupUV;

void RetinexParams::read(const FileNode& fn) {
    ParamsIn in(fn, "retinex parameters");
    in("threshold", threshold);
    in("max_side", max_side);
    in("chroma_threshold", chroma_threshold);
    in("white", white);
    in("white_percentile", white_percentile);
    in.finish();
    check();
}

void RetinexParams::check() const {
    const char* w = "retinex parameters";
    checkParam(threshold >= 0, w, "threshold", threshold, ">= 0");
    checkParam(max_side >= 2, w, "max_side", max_side, ">= 2 pixels");
    checkParam(std::isfinite(chroma_threshold), w, "chroma_threshold", chroma_threshold,
               "a finite number");
    checkParam(std::isfinite(white), w, "white", white,
               "a finite number (<= 0: see RetinexParams)");
    checkParam(white_percentile > 0 && white_percentile <= 100, w, "white_percentile",
               white_percentile, "(0, 100]");
}

void RetinexParams::write(FileStorage& fs) const {
    fs << "threshold" << threshold << "max_side" << max_side << "chroma_threshold"
       << chroma_threshold << "white" << white << "white_percentile" << white_percentile;
}

void IrradianceAlbedoParams::read(const FileNode& fn) {
    ParamsIn in(fn, "irradiance albedo parameters");
    in("grid", grid);
    in("spp", spp);
    in("iterations", iterations);
    in("seed", seed);
    in.finish();
    check();
}

void IrradianceAlbedoParams::check() const {
    const char* w = "irradiance albedo parameters";
    checkParam(grid >= 1, w, "grid", grid, ">= 1");
    checkParam(spp >= 1, w, "spp", spp, ">= 1");
    checkParam(iterations >= 1, w, "iterations", iterations, ">= 1");
}

void IrradianceAlbedoParams::write(FileStorage& fs) const {
    fs << "grid" << grid << "spp" << spp << "iterations" << iterations << "seed" << (double)seed;
}

namespace {

inline float lum(const Vec3f& c) {
    return (c[0] + c[1] + c[2]) * (1.f / 3.f);
}

/** Mean of @p img over @p mask (non-zero), or @p fallback if the mask is empty. */
Vec3f maskedMean(const Mat& img, const Mat& mask, const Vec3f& fallback) {
    if (countNonZero(mask) == 0) return fallback;
    const Scalar m = mean(img, mask);
    return Vec3f((float)m[0], (float)m[1], (float)m[2]);
}

/** Solves ∇²u = f (5-point Laplacian, Neumann boundaries) by the DCT; even sizes. */
Mat poissonDct(const Mat& f64) {
    Mat F;
    dct(f64, F);
    const int H = F.rows, W = F.cols;
    for (int y = 0; y < H; ++y) {
        double* row = F.ptr<double>(y);
        const double cy = 2 * std::cos(CV_PI * y / H);
        for (int x = 0; x < W; ++x) {
            const double lam = 2 * std::cos(CV_PI * x / W) + cy - 4;
            row[x] = (x == 0 && y == 0) ? 0 : row[x] / lam;
        }
    }
    Mat u;
    idct(F, u);
    return u;
}

}  // namespace

void retinexAlbedo(InputArray texture_linear, OutputArray albedo_out, const RetinexParams& p) {
    Mat tex = texture_linear.getMat();
    if (tex.empty() || tex.type() != CV_32FC3)
        CV_Error(Error::StsBadArg, "retinexAlbedo: the texture must be a non-empty CV_32FC3 image");
    CV_Assert(p.max_side >= 4 && p.threshold >= 0);
    Mat seen = Mat::zeros(tex.size(), CV_8U);
    for (int y = 0; y < tex.rows; ++y)
        for (int x = 0; x < tex.cols; ++x) {
            const Vec3f c = tex.at<Vec3f>(y, x);
            seen.at<uchar>(y, x) = (c[0] > 0 || c[1] > 0 || c[2] > 0) ? 255 : 0;
        }
    // Low-resolution working copy (even sides for the DCT).
    const double s = std::min(1.0, double(p.max_side) / std::max(tex.cols, tex.rows));
    int W = std::max(2, (int)std::lround(tex.cols * s)),
        H = std::max(2, (int)std::lround(tex.rows * s));
    W -= W & 1;
    H -= H & 1;
    Mat small, seen_f, seen_small;
    resize(tex, small, Size(W, H), 0, 0, INTER_AREA);
    seen.convertTo(seen_f, CV_32F, 1.0 / 255);
    resize(seen_f, seen_small, Size(W, H), 0, 0, INTER_AREA);
    Mat ell(H, W, CV_64F), chroma(H, W, CV_32FC3);
    Mat ok(H, W, CV_8U);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const Vec3f c = small.at<Vec3f>(y, x);
            const float sum = c[0] + c[1] + c[2];
            const bool v = seen_small.at<float>(y, x) > 0.999f && sum > 0;
            ok.at<uchar>(y, x) = v ? 255 : 0;
            ell.at<double>(y, x) = v ? std::log(std::max(sum / 3.0, 1e-12)) : 0;
            chroma.at<Vec3f>(y, x) = v ? c * (1.f / sum) : Vec3f(0, 0, 0);
        }
    // Kept (reflectance) gradients and their divergence.
    Mat gx = Mat::zeros(H, W, CV_64F), gy = Mat::zeros(H, W, CV_64F);
    auto keep = [&](int y0, int x0, int y1, int x1) -> double {
        if (!ok.at<uchar>(y0, x0) || !ok.at<uchar>(y1, x1)) return 0;
        const double g = ell.at<double>(y1, x1) - ell.at<double>(y0, x0);
        const double dc = norm(chroma.at<Vec3f>(y1, x1) - chroma.at<Vec3f>(y0, x0));
        return (std::abs(g) > p.threshold || dc > p.chroma_threshold) ? g : 0;
    };
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            if (x + 1 < W) gx.at<double>(y, x) = keep(y, x, y, x + 1);
            if (y + 1 < H) gy.at<double>(y, x) = keep(y, x, y + 1, x);
        }
    Mat div(H, W, CV_64F);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            div.at<double>(y, x) = gx.at<double>(y, x) - (x > 0 ? gx.at<double>(y, x - 1) : 0) +
                                   gy.at<double>(y, x) - (y > 0 ? gy.at<double>(y - 1, x) : 0);
    const Mat r = poissonDct(div);
    // Log shading where seen; unseen filled with the median of the seen shading.
    Mat shade(H, W, CV_32F);
    std::vector<float> vals;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            if (ok.at<uchar>(y, x)) {
                const float sv = float(ell.at<double>(y, x) - r.at<double>(y, x));
                shade.at<float>(y, x) = sv;
                vals.push_back(sv);
            }
    float fill = 0;
    if (!vals.empty()) {
        std::nth_element(vals.begin(), vals.begin() + vals.size() / 2, vals.end());
        fill = vals[vals.size() / 2];
    }
    // Spread the seen shading into unseen low-res pixels (normalised convolution), else fill.
    {
        Mat okf, num, den;
        ok.convertTo(okf, CV_32F, 1.0 / 255);
        Mat sh0 = shade.clone();
        sh0.setTo(0, ok == 0);
        GaussianBlur(sh0, num, Size(0, 0), 2.0);
        GaussianBlur(okf, den, Size(0, 0), 2.0);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x)
                if (!ok.at<uchar>(y, x))
                    shade.at<float>(y, x) = den.at<float>(y, x) > 1e-3f
                                                ? num.at<float>(y, x) / den.at<float>(y, x)
                                                : fill;
    }
    Mat S;
    exp(shade - fill, S);  // relative shading, median 1
    Mat S_full;
    resize(S, S_full, tex.size(), 0, 0, INTER_LINEAR);
    albedo_out.create(tex.size(), CV_32FC3);
    Mat A = albedo_out.getMat();
    std::vector<float> lums;
    lums.reserve((size_t)countNonZero(seen));
    double shade_sum = 0;
    int n_seen = 0;
    for (int y = 0; y < tex.rows; ++y)
        for (int x = 0; x < tex.cols; ++x) {
            const float sv = std::max(S_full.at<float>(y, x), 1e-6f);
            const Vec3f a = tex.at<Vec3f>(y, x) * (1.f / sv);
            A.at<Vec3f>(y, x) = a;
            if (seen.at<uchar>(y, x)) {
                lums.push_back(lum(a));
                shade_sum += sv;
                ++n_seen;
            }
        }
    double scale = 1;
    if (!lums.empty()) {
        if (p.white > 0) {
            const size_t k = std::min(lums.size() - 1,
                                      (size_t)std::floor(p.white_percentile / 100.0 * lums.size()));
            std::nth_element(lums.begin(), lums.begin() + k, lums.end());
            scale = lums[k] > 0 ? p.white / lums[k] : 1;
        } else {
            scale = shade_sum / n_seen;  // shading normalised to mean 1
        }
    }
    A *= scale;
    const Vec3f fill_a = maskedMean(A, seen, Vec3f(0.5f, 0.5f, 0.5f));
    A.setTo(Scalar(fill_a[0], fill_a[1], fill_a[2]), seen == 0);
    min(A, 1.0, A);
    max(A, 0.0, A);
}

void irradianceAlbedo(const Scene& scene, const std::map<std::string, Mat>& radiance,
                      std::map<std::string, Mat>& albedo, const IrradianceAlbedoParams& p) {
    std::map<std::string, Mat> seen;
    for (const auto& kv : radiance) {
        const Mat& L = kv.second;
        if (L.type() != CV_32FC3)
            CV_Error(Error::StsBadArg,
                     "irradianceAlbedo: radiance." + kv.first + " must be CV_32FC3");
        Mat m = Mat::zeros(L.size(), CV_8U);
        for (int y = 0; y < L.rows; ++y)
            for (int x = 0; x < L.cols; ++x) {
                const Vec3f c = L.at<Vec3f>(y, x);
                m.at<uchar>(y, x) = (c[0] != 0 || c[1] != 0 || c[2] != 0) ? 255 : 0;
            }
        seen[kv.first] = m;
    }
    irradianceAlbedo(scene, radiance, seen, albedo, p, nullptr);
}

namespace {

struct GatherHit {
    int8_t face;  // 0..5 room face, −1 proxy, −2 nothing usable
    float u, v;
};

}  // namespace

void irradianceAlbedo(const Scene& scene_in, const std::map<std::string, Mat>& radiance,
                      const std::map<std::string, Mat>& seen_in, std::map<std::string, Mat>& albedo,
                      const IrradianceAlbedoParams& p, std::map<std::string, Mat>* irradiance) {
    if (!scene_in.has_room) CV_Error(Error::StsBadArg, "irradianceAlbedo: the scene has no room");
    if (p.grid < 2 || p.spp < 1 || p.iterations < 1)
        CV_Error(Error::StsBadArg, "irradianceAlbedo: grid must be ≥ 2, spp and iterations ≥ 1");
    const std::vector<std::string>& names = Room::faceNames();
    // Observed radiance and seen masks per face index.
    Mat L[6], seen[6];
    for (int f = 0; f < 6; ++f) {
        auto it = radiance.find(names[f]);
        if (it == radiance.end()) continue;
        if (it->second.type() != CV_32FC3 || it->second.empty())
            CV_Error(Error::StsBadArg,
                     "irradianceAlbedo: radiance." + names[f] + " must be CV_32FC3");
        L[f] = it->second;
        auto sit = seen_in.find(names[f]);
        if (sit == seen_in.end() || sit->second.size() != L[f].size() ||
            sit->second.type() != CV_8U)
            CV_Error(Error::StsBadArg, "irradianceAlbedo: seen." + names[f] +
                                           " must be CV_8U of the radiance's size");
        seen[f] = sit->second;
    }
    // Render geometry: room + proxies + lights (room textures and objects are not needed).
    Scene sc = scene_in;
    sc.room.textures.clear();
    sc.objects.clear();
    Ptr<RenderScene> rs = RenderScene::create(sc);
    const std::vector<Ptr<Emitter>>& lights = rs->emitters();
    const int G = p.grid, N = p.spp;
    const int npts = 6 * G * G;
    const SobolSampler sampler(p.seed);

    // Pass 0: direct irradiance and the gather hits (traced once).
    std::vector<Vec3f> direct(npts);
    std::vector<GatherHit> hits((size_t)npts * N);
    parallel_for_(Range(0, 6 * G), [&](const Range& rr) {
        for (int row = rr.start; row < rr.end; ++row) {
            const int f = row / G, gi = row % G;
            const RoomFace F = sc.room.face(f);
            const Vec3f n(F.n);
            // tangent frame
            const Vec3f t1 = normalize(Vec3f(F.right)), t2 = n.cross(t1);
            for (int gj = 0; gj < G; ++gj) {
                const int id = row * G + gj;
                const double u = (gj + 0.5) / G, v = 1.0 - (gi + 0.5) / G;
                const Vec3f P(F.bl + F.right * u + F.up * v);
                const float m = std::max(std::abs(P[0]), std::max(std::abs(P[1]), std::abs(P[2])));
                const float eps = 1e-4f * std::max(m, 1.f);
                const Vec3f o = P + n * eps;
                const uint64 key = sampler.pixelKey(Point(id, 0));
                Vec3f E(0, 0, 0);
                for (size_t li = 0; li < lights.size(); ++li) {
                    const Emitter& em = *lights[li];
                    for (int s = 0; s < N; ++s) {
                        EmitterSample es;
                        if (!em.sample(o, sampler.get2D(key, s, 2 + 2 * (uint32_t)li), es))
                            continue;
                        const float c = n.dot(es.wi);
                        if (c <= 0 || es.pdf <= 0) continue;
                        const float tfar = std::isinf(es.dist)
                                               ? std::numeric_limits<float>::infinity()
                                               : es.dist * (1.f - 1e-4f) - eps;
                        if (tfar <= 0 || rs->occluded(o, es.wi, 0.f, tfar, false)) continue;
                        E += es.L * (c / es.pdf / N);
                    }
                }
                direct[id] = Vec3f(E[2], E[1], E[0]);  // RGB → BGR
                for (int s = 0; s < N; ++s) {
                    const Vec2f r = sampler.get2D(key, s, 0);
                    const float rad = std::sqrt(r[0]), phi = float(2 * CV_PI) * r[1];
                    const float x = rad * std::cos(phi), y = rad * std::sin(phi);
                    const float z = std::sqrt(std::max(0.f, 1.f - r[0]));
                    const Vec3f d = normalize(t1 * x + t2 * y + n * z);
                    SurfaceHit h;
                    GatherHit gh{-2, 0, 0};
                    if (rs->intersect(o, d, 0.f, std::numeric_limits<float>::infinity(), h,
                                      false)) {
                        if (h.kind == GeometryKind::ROOM) {
                            gh.face = (int8_t)std::min(std::max(h.prim_id / 2, 0), 5);
                            gh.u = h.uv[0];
                            gh.v = h.uv[1];
                        } else if (h.kind == GeometryKind::PROXY) {
                            gh.face = -1;
                        }
                    }
                    hits[(size_t)id * N + s] = gh;
                }
            }
        }
    });

    // Per-face means of the observed radiance (pass-1 estimate for unseen texels).
    Vec3f room_mean(0, 0, 0);
    int room_n = 0;
    Vec3f face_mean[6];
    bool face_seen[6];
    for (int f = 0; f < 6; ++f) {
        face_seen[f] = !L[f].empty() && countNonZero(seen[f]) > 0;
        if (face_seen[f]) {
            face_mean[f] = maskedMean(L[f], seen[f], Vec3f(0, 0, 0));
            const int n = countNonZero(seen[f]);
            room_mean += face_mean[f] * (float)n;
            room_n += n;
        }
    }
    if (room_n > 0) room_mean *= 1.f / room_n;
    for (int f = 0; f < 6; ++f)
        if (!face_seen[f]) face_mean[f] = room_mean;

    Mat Egrid[6];  // G×G CV_32FC3 per face (BGR)
    for (int f = 0; f < 6; ++f)
        Egrid[f] = Mat(G, G, CV_32FC3);
    Vec3f face_albedo[6];  // mean albedo of the seen texels (previous pass)
    Vec3f room_albedo(0.5f, 0.5f, 0.5f);
    std::map<std::string, Mat> A, Efull;
    for (int it = 0; it < p.iterations; ++it) {
        // Irradiance at the grid points.
        std::vector<Mat> Enew(6);
        for (int f = 0; f < 6; ++f)
            Enew[f] = Mat(G, G, CV_32FC3);
        parallel_for_(Range(0, 6 * G), [&](const Range& rr) {
            for (int row = rr.start; row < rr.end; ++row) {
                const int f = row / G, gi = row % G;
                for (int gj = 0; gj < G; ++gj) {
                    const int id = row * G + gj;
                    Vec3f sum(0, 0, 0);
                    for (int s = 0; s < N; ++s) {
                        const GatherHit& h = hits[(size_t)id * N + s];
                        if (h.face == -1) {
                            sum += room_mean;
                        } else if (h.face >= 0) {
                            const int g = h.face;
                            bool known = false;
                            if (face_seen[g]) {
                                const Mat& S = seen[g];
                                const int x =
                                    std::min(std::max((int)(h.u * S.cols), 0), S.cols - 1);
                                const int y =
                                    std::min(std::max((int)((1.f - h.v) * S.rows), 0), S.rows - 1);
                                known = S.at<uchar>(y, x) != 0;
                            }
                            if (known)
                                sum += lookupUV(L[g], h.u, h.v);
                            else if (it == 0)
                                sum += face_mean[g];
                            else {
                                const Vec3f e = lookupUV(Egrid[g], h.u, h.v);
                                const Vec3f a = face_albedo[g];
                                sum +=
                                    Vec3f(a[0] * e[0], a[1] * e[1], a[2] * e[2]) * float(1 / CV_PI);
                            }
                        }
                    }
                    Enew[f].at<Vec3f>(gi, gj) = direct[id] + sum * float(CV_PI / N);
                }
            }
        });
        for (int f = 0; f < 6; ++f)
            Egrid[f] = Enew[f];
        // Albedo per face.
        A.clear();
        Efull.clear();
        Vec3f asum(0, 0, 0);
        int an = 0;
        for (int f = 0; f < 6; ++f) {
            if (L[f].empty()) continue;
            Mat E;
            resize(Egrid[f], E, L[f].size(), 0, 0, INTER_LINEAR);
            Mat a(L[f].size(), CV_32FC3);
            parallel_for_(Range(0, a.rows), [&](const Range& rr) {
                for (int y = rr.start; y < rr.end; ++y) {
                    const Vec3f* l = L[f].ptr<Vec3f>(y);
                    const Vec3f* e = E.ptr<Vec3f>(y);
                    Vec3f* o = a.ptr<Vec3f>(y);
                    for (int x = 0; x < a.cols; ++x)
                        for (int c = 0; c < 3; ++c)
                            o[x][c] =
                                e[x][c] > 0
                                    ? std::min(1.f, std::max(0.f, float(CV_PI) * l[x][c] / e[x][c]))
                                    : 0.f;
                }
            });
            if (face_seen[f]) {
                face_albedo[f] = maskedMean(a, seen[f], room_albedo);
                const int n = countNonZero(seen[f]);
                asum += face_albedo[f] * (float)n;
                an += n;
            }
            A[names[f]] = a;
            Efull[names[f]] = E;
        }
        if (an > 0) room_albedo = asum * (1.f / an);
        for (int f = 0; f < 6; ++f)
            if (!face_seen[f]) face_albedo[f] = room_albedo;
    }
    // Unseen texels: the face's mean albedo.
    for (auto& kv : A) {
        const int f = Room::faceIndex(kv.first);
        const Vec3f a = face_albedo[f];
        kv.second.setTo(Scalar(a[0], a[1], a[2]), seen[f] == 0);
    }
    albedo = A;
    if (irradiance) *irradiance = Efull;
}

}  // namespace vbme
}  // namespace cv
