// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Light power estimation from frames: per-light basis renders, NNLS or the thesis's hill
// climbing (thesis §5.1.3).
#include "opencv2/vbme/render/light_estimation.hpp"
#include "opencv2/vbme/core/params.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/render/integrator.hpp"
#include "opencv2/vbme/render/scene.hpp"

namespace cv {
namespace vbme {

void LightEstimationParams::read(const FileNode& fn) {
    ParamsIn in(fn, "light estimation parameters");
    in.choice("method", method,
              {{"nnls", NNLS}, {"hill-climb", HILL_CLIMB}, {"hill_climb", HILL_CLIMB}});
    in("render_size", render_size);
    in("spp", spp);
    in("max_depth", max_depth);
    in("max_iterations", max_iterations);
    in("tolerance", tolerance);
    in("clip_level", clip_level);
    in("per_frame_gain", per_frame_gain);
    in("seed", seed);
    in.finish();
    check();
}

void LightEstimationParams::check() const {
    const char* w = "light estimation parameters";
    checkParam(method == NNLS || method == HILL_CLIMB, w, "method", method,
               "HILL_CLIMB (0) or NNLS (1)");
    checkParam(render_size.width > 0 && render_size.height > 0, w, "render_size", render_size.width,
               "positive [width, height]");
    checkParam(spp > 0, w, "spp", spp, "> 0");
    checkParam(max_depth > 0, w, "max_depth", max_depth, "> 0");
    checkParam(max_iterations >= 0, w, "max_iterations", max_iterations, ">= 0");
    checkParam(tolerance > 0, w, "tolerance", tolerance, "> 0");
    checkParam(clip_level > 0 && clip_level <= 1, w, "clip_level", clip_level, "(0, 1]");
}

void LightEstimationParams::write(FileStorage& fs) const {
    fs << "method" << (method == NNLS ? "nnls" : "hill-climb");
    fs << "render_size"
       << "[:" << render_size.width << render_size.height << "]";
    fs << "spp" << spp << "max_depth" << max_depth << "max_iterations" << max_iterations
       << "tolerance" << tolerance << "clip_level" << clip_level << "per_frame_gain"
       << (int)per_frame_gain << "seed" << (double)seed;
}

void LightEstimate::write(FileStorage& fs) const {
    fs << "scale"
       << "[";
    for (const Vec3d& s : scale)
        fs << "[:" << s[0] << s[1] << s[2] << "]";
    fs << "]";
    fs << "gains"
       << "[:";
    for (double g : gains)
        fs << g;
    fs << "]";
    fs << "error_before" << error_before << "error_after" << error_after << "iterations"
       << iterations << "pixels_used" << pixels_used;
}

namespace {

/** Lawson–Hanson NNLS on the normal equations: min ½xᵀGx − hᵀx, x ≥ 0. */
std::vector<double> nnlsGram(const Mat& G, const std::vector<double>& h) {
    const int n = (int)h.size();
    std::vector<double> x(n, 0.0);
    std::vector<bool> P(n, false);
    const double tol = 1e-12 * std::max(1.0, norm(G, NORM_INF));
    auto gradient = [&](std::vector<double>& w) {
        for (int i = 0; i < n; ++i) {
            double s = h[i];
            for (int j = 0; j < n; ++j)
                s -= G.at<double>(i, j) * x[j];
            w[i] = s;
        }
    };
    auto solveP = [&](std::vector<double>& z) {
        std::vector<int> idx;
        for (int i = 0; i < n; ++i)
            if (P[i]) idx.push_back(i);
        const int m = (int)idx.size();
        Mat A(m, m, CV_64F), b(m, 1, CV_64F), zz;
        for (int a = 0; a < m; ++a) {
            b.at<double>(a) = h[idx[a]];
            for (int c = 0; c < m; ++c)
                A.at<double>(a, c) = G.at<double>(idx[a], idx[c]);
        }
        solve(A, b, zz, DECOMP_SVD);
        std::fill(z.begin(), z.end(), 0.0);
        for (int a = 0; a < m; ++a)
            z[idx[a]] = zz.at<double>(a);
    };
    std::vector<double> w(n), z(n);
    for (int outer = 0; outer < 3 * n + 10; ++outer) {
        gradient(w);
        int j = -1;
        double best = tol;
        for (int i = 0; i < n; ++i)
            if (!P[i] && w[i] > best) best = w[i], j = i;
        if (j < 0) break;
        P[j] = true;
        for (int inner = 0; inner < 3 * n + 10; ++inner) {
            solveP(z);
            bool feasible = true;
            for (int i = 0; i < n; ++i)
                if (P[i] && z[i] <= 0) feasible = false;
            if (feasible) {
                x = z;
                break;
            }
            double alpha = 1;
            for (int i = 0; i < n; ++i)
                if (P[i] && z[i] <= 0) alpha = std::min(alpha, x[i] / (x[i] - z[i]));
            for (int i = 0; i < n; ++i) {
                x[i] += alpha * (z[i] - x[i]);
                if (P[i] && x[i] <= 1e-15) {
                    P[i] = false;
                    x[i] = 0;
                }
            }
        }
    }
    return x;
}

/** Per-frame, per-channel sums of the fit: Gram matrix, right-hand side, Σ I². */
struct FrameSums {
    Mat G[3];
    std::vector<double> h[3];
    double ii[3] = {0, 0, 0};
};

}  // namespace

LightEstimate estimateLights(const Scene& scene, InputArrayOfArrays frames_,
                             const std::vector<Camera>& cameras, const LightEstimationParams& p) {
    std::vector<Mat> frames;
    frames_.getMatVector(frames);
    if (frames.empty() || frames.size() != cameras.size())
        CV_Error(Error::StsBadArg,
                 "estimateLights: expected one camera per frame, at least one frame");
    if (scene.lights.empty()) CV_Error(Error::StsBadArg, "estimateLights: the scene has no lights");
    if (p.render_size.width < 2 || p.render_size.height < 2 || p.spp < 1 || p.max_depth < 1)
        CV_Error(Error::StsBadArg,
                 "estimateLights: render_size ≥ 2×2, spp and max_depth ≥ 1 expected");
    const int nl = (int)scene.lights.size(), nf = (int)frames.size();
    const Size rsz = p.render_size;

    // Observed low-resolution linear frames and their usable pixels.
    std::vector<Mat> obs(nf), use(nf);
    LightEstimate est;
    for (int f = 0; f < nf; ++f) {
        const Mat& fr = frames[f];
        if (fr.empty() || fr.channels() != 3)
            CV_Error(Error::StsBadArg,
                     "estimateLights: frame " + std::to_string(f) + " must be 3-channel");
        const double unit = fr.depth() == CV_8U ? 255.0 : fr.depth() == CV_16U ? 65535.0 : 1.0;
        Mat enc, clip1, lin;
        fr.convertTo(enc, CV_32FC3, 1.0 / unit);
        std::vector<Mat> ch;
        split(enc, ch);
        clip1 = max(max(ch[0], ch[1]), ch[2]) >= (float)p.clip_level;  // CV_8U 255 = clipped
        linearize(fr.depth() == CV_8U ? fr : enc, lin, scene.camera.response);
        Mat clipf, clip_small;
        clip1.convertTo(clipf, CV_32F);
        resize(lin, obs[f], rsz, 0, 0, INTER_AREA);
        resize(clipf, clip_small, rsz, 0, 0, INTER_AREA);
        // Used: no clipped source pixel in the low-res pixel nor in its 8 neighbours (the
        // unclipped rim of a saturated light is a sliver of very bright emitter whose coverage
        // both the frame and the basis renders estimate noisily).
        Mat touched = clip_small > 0;
        dilate(touched, touched, Mat());
        use[f] = touched == 0;
        est.pixels_used += countNonZero(use[f]);
    }
    if (est.pixels_used == 0)
        CV_Error(Error::StsBadArg, "estimateLights: every pixel is clipped; nothing to fit");

    // Basis renders: one per light and frame.
    Renderer::Params rp;
    rp.spp = p.spp;
    rp.max_depth = p.max_depth;
    rp.seed = p.seed;
    rp.aovs = false;
    rp.with_objects = false;
    Ptr<Renderer> renderer = Renderer::create(rp);
    std::vector<std::vector<Mat>> B(nl, std::vector<Mat>(nf));
    for (int i = 0; i < nl; ++i) {
        Scene si = scene;
        si.objects.clear();
        si.lights = {scene.lights[i]};
        Ptr<RenderScene> rs = RenderScene::create(si);
        for (int f = 0; f < nf; ++f) {
            Camera c = cameras[f];
            if (c.image_size.area() == 0) c.image_size = frames[f].size();
            RenderImages out;
            renderer->render(*rs, c.scaled(rsz), out);
            B[i][f] = out.color;
        }
    }

    // Per-frame sums.
    std::vector<FrameSums> S(nf);
    parallel_for_(Range(0, nf), [&](const Range& r) {
        for (int f = r.start; f < r.end; ++f) {
            FrameSums& fs = S[f];
            for (int c = 0; c < 3; ++c) {
                fs.G[c] = Mat::zeros(nl, nl, CV_64F);
                fs.h[c].assign(nl, 0.0);
            }
            std::vector<Vec3f> b(nl);
            for (int y = 0; y < rsz.height; ++y)
                for (int x = 0; x < rsz.width; ++x) {
                    if (!use[f].at<uchar>(y, x)) continue;
                    const Vec3f I = obs[f].at<Vec3f>(y, x);
                    for (int i = 0; i < nl; ++i)
                        b[i] = B[i][f].at<Vec3f>(y, x);
                    for (int c = 0; c < 3; ++c) {
                        fs.ii[c] += double(I[c]) * I[c];
                        for (int i = 0; i < nl; ++i) {
                            fs.h[c][i] += double(b[i][c]) * I[c];
                            for (int j = 0; j < nl; ++j)
                                fs.G[c].at<double>(i, j) += double(b[i][c]) * b[j][c];
                        }
                    }
                }
        }
    });

    // Model error: relative RMS over all used pixels and channels.
    auto error = [&](const std::vector<std::vector<double>>& s, const std::vector<double>& g) {
        double num = 0, den = 0;
        for (int f = 0; f < nf; ++f)
            for (int c = 0; c < 3; ++c) {
                double sGs = 0, sh = 0;
                for (int i = 0; i < nl; ++i) {
                    sh += s[c][i] * S[f].h[c][i];
                    for (int j = 0; j < nl; ++j)
                        sGs += s[c][i] * S[f].G[c].at<double>(i, j) * s[c][j];
                }
                num += g[f] * g[f] * sGs - 2 * g[f] * sh + S[f].ii[c];
                den += S[f].ii[c];
            }
        return std::sqrt(std::max(0.0, num) / std::max(den, 1e-300));
    };
    auto totals = [&](const std::vector<double>& g, int c, Mat& G, std::vector<double>& h) {
        G = Mat::zeros(nl, nl, CV_64F);
        h.assign(nl, 0.0);
        for (int f = 0; f < nf; ++f) {
            G += S[f].G[c] * (g[f] * g[f]);
            for (int i = 0; i < nl; ++i)
                h[i] += g[f] * S[f].h[c][i];
        }
    };

    std::vector<std::vector<double>> s(3, std::vector<double>(nl, 1.0));
    std::vector<double> gains(nf, 1.0);
    est.error_before = error(s, gains);

    if (p.method == LightEstimationParams::NNLS) {
        const int rounds = p.per_frame_gain ? 20 : 1;
        for (int round = 0; round < rounds; ++round) {
            for (int c = 0; c < 3; ++c) {
                Mat G;
                std::vector<double> h;
                totals(gains, c, G, h);
                s[c] = nnlsGram(G, h);
            }
            est.iterations = round + 1;
            if (!p.per_frame_gain) break;
            double change = 0, gsum = 0;
            std::vector<double> ng(nf);
            for (int f = 0; f < nf; ++f) {
                double num = 0, den = 0;
                for (int c = 0; c < 3; ++c)
                    for (int i = 0; i < nl; ++i) {
                        num += s[c][i] * S[f].h[c][i];
                        for (int j = 0; j < nl; ++j)
                            den += s[c][i] * S[f].G[c].at<double>(i, j) * s[c][j];
                    }
                ng[f] = den > 0 ? num / den : 1.0;
                gsum += ng[f];
            }
            const double m = gsum / nf;
            if (!(m > 0)) break;
            for (int f = 0; f < nf; ++f) {
                ng[f] /= m;
                change = std::max(change, std::abs(ng[f] - gains[f]));
                gains[f] = ng[f];
            }
            for (int c = 0; c < 3; ++c)
                for (double& v : s[c])
                    v *= m;
            if (change < 1e-6) break;
        }
    } else {
        // The thesis's hill climbing (Eq. 5.1). Its error is measured the way one compares two
        // pictures: the mean difference of display-encoded values (0..1), rendered − observed,
        // over the used pixels, each pixel weighted by the light's own share of the render. The
        // gain 15 of Eq. 5.1 suits such errors (a factor ≈ 1 − 7.5·error near 0, while the
        // relative radiance error is ≈ 2.2·error / value, i.e. a 2–11× larger number for mid
        // values): measured with a relative radiance error instead, each step overshot ~7.5×.
        const Response resp = scene.camera.response;
        std::vector<std::vector<double>> best = s;
        double best_err = est.error_before;
        for (int it = 0; it < p.max_iterations; ++it) {
            std::vector<std::vector<double>> num(3, std::vector<double>(nl, 0.0)),
                den(3, std::vector<double>(nl, 0.0));
            for (int f = 0; f < nf; ++f)
                for (int y = 0; y < rsz.height; ++y)
                    for (int x = 0; x < rsz.width; ++x) {
                        if (!use[f].at<uchar>(y, x)) continue;
                        const Vec3f I = obs[f].at<Vec3f>(y, x);
                        for (int c = 0; c < 3; ++c) {
                            double R = 0;
                            for (int j = 0; j < nl; ++j)
                                R += s[c][j] * B[j][f].at<Vec3f>(y, x)[c];
                            R *= gains[f];
                            const double d =
                                encode(float(R), resp) - encode(std::max(I[c], 0.f), resp);
                            for (int i = 0; i < nl; ++i) {
                                const double w = s[c][i] * B[i][f].at<Vec3f>(y, x)[c];
                                num[c][i] += w * d;
                                den[c][i] += w;
                            }
                        }
                    }
            bool done = true;
            std::vector<std::vector<double>> next = s;
            for (int c = 0; c < 3; ++c)
                for (int i = 0; i < nl; ++i) {
                    if (den[c][i] <= 0) continue;  // the light does not reach a used pixel
                    const double err = num[c][i] / den[c][i];
                    if (std::abs(err) >= p.tolerance) done = false;
                    next[c][i] = s[c][i] * 2.0 * (1.0 - 1.0 / (1.0 + std::exp(-15.0 * err)));
                }
            if (done) break;
            s = next;
            est.iterations = it + 1;
            const double e = error(s, gains);
            if (e < best_err) best_err = e, best = s;
        }
        s = best;
    }
    est.error_after = error(s, gains);
    est.gains = gains;
    est.scale.resize(nl);
    for (int i = 0; i < nl; ++i)
        est.scale[i] = Vec3d(s[2][i], s[1][i], s[0][i]);  // BGR fit → RGB scale
    return est;
}

void applyLightEstimate(Scene& scene, const LightEstimate& e) {
    if (e.scale.size() != scene.lights.size())
        CV_Error(Error::StsBadArg, "applyLightEstimate: the estimate has " +
                                       std::to_string(e.scale.size()) + " lights, the scene " +
                                       std::to_string(scene.lights.size()));
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        Light& l = scene.lights[i];
        const Vec3d& s = e.scale[i];
        if (l.type == Light::POINT)
            l.intensity = l.intensity.mul(s);
        else if (l.type == Light::ENVIRONMENT && !l.image.empty())
            l.scale *= (s[0] + s[1] + s[2]) / 3.0;
        else
            l.radiance = l.radiance.mul(s);
    }
}

}  // namespace vbme
}  // namespace cv
