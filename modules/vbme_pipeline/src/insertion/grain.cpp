// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Grain: the footage's noise measured per intensity, channel and spatial correlation
// (measureGrain), and matching noise added to the pixels the inserted objects replace
// (addGrain; the insertion's frame step addFrameGrain).
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "insertion/stages.hpp"
#include "opencv2/vbme/pipeline/camera_match.hpp"

namespace cv {
namespace vbme {

namespace {

const double kResidualSigma = 1.0;  // the high-pass residual: I − G(σ = 1 px) * I
const double kHistStep = 0.02;      // |residual| histogram step (code values)
const int kHistBins = 2000;         // … up to 40 code values
const double kMadToSigma = 1.0 / 0.6744897501960817;

// Gaussian blur of σ px with a kernel of ±3σ (σ = 0: a copy).
void gaussian(const Mat& src, Mat& dst, double sigma) {
    if (sigma <= 0) {
        src.copyTo(dst);
        return;
    }
    const int k = 2 * (int)std::ceil(3 * sigma) + 1;
    GaussianBlur(src, dst, Size(k, k), sigma, sigma, BORDER_REFLECT101);
}

// Σ w² of the 2-D Gaussian kernel of gaussian(): the variance of blurred unit white noise.
double kernelEnergy(double sigma) {
    if (sigma <= 0) return 1;
    const int k = 2 * (int)std::ceil(3 * sigma) + 1;
    const Mat g = getGaussianKernel(k, sigma, CV_64F);
    const double e1 = g.dot(g);
    return e1 * e1;
}

// The median of a histogram of |r| (kHistStep bins), as a robust σ of r.
double histSigma(const std::vector<double>& h) {
    double total = 0;
    for (double v : h)
        total += v;
    if (total <= 0) return 0;
    double acc = 0;
    for (size_t i = 0; i < h.size(); ++i) {
        if (acc + h[i] >= total / 2) {
            const double frac = h[i] > 0 ? (total / 2 - acc) / h[i] : 0;
            return (i + frac) * kHistStep * kMadToSigma;
        }
        acc += h[i];
    }
    return h.size() * kHistStep * kMadToSigma;
}

// Correlation of neighbouring residuals (right and down) over pairs where both pixels are
// selected and neither is beyond `clip` (outliers: edges that passed the selection).
void accumulateCorrelation(const Mat& r, const Mat& sel, double clip, double& sxy, double& sxx) {
    for (int y = 0; y + 1 < r.rows; ++y) {
        const float* a = r.ptr<float>(y);
        const float* b = r.ptr<float>(y + 1);
        const uchar* sa = sel.ptr<uchar>(y);
        const uchar* sb = sel.ptr<uchar>(y + 1);
        for (int x = 0; x + 1 < r.cols; ++x) {
            if (!sa[x] || std::abs(a[x]) > clip) continue;
            if (sa[x + 1] && std::abs(a[x + 1]) <= clip) {
                sxy += a[x] * a[x + 1];
                sxx += 0.5 * (a[x] * a[x] + a[x + 1] * a[x + 1]);
            }
            if (sb[x] && std::abs(b[x]) <= clip) {
                sxy += a[x] * b[x];
                sxx += 0.5 * (a[x] * a[x] + b[x] * b[x]);
            }
        }
    }
}

// The estimator run on synthetic noise of unit variance blurred by `blur` px: the residual's
// robust σ (= σ_residual / σ_noise) and its neighbour correlation.
struct Calibration {
    std::vector<double> blur, ratio, corr;
};

const Calibration& calibration() {
    static const Calibration cal = [] {
        Calibration c;
        const double blurs[] = {0, 0.3, 0.45, 0.6, 0.75, 0.9, 1.05, 1.25, 1.5, 2.0};
        RNG rng(0x6a09e667f3bcc909ull);
        for (double b : blurs) {
            Mat n(256, 256, CV_32F);
            rng.fill(n, RNG::NORMAL, 0, 1);
            Mat nb;
            gaussian(n, nb, b);
            nb *= 1.0 / std::sqrt(kernelEnergy(b));
            Mat s, r;
            gaussian(nb, s, kResidualSigma);
            r = nb - s;
            const Rect inner(8, 8, 240, 240);  // away from the reflected border
            Mat ri = r(inner).clone();
            std::vector<double> h(kHistBins, 0);
            for (int y = 0; y < ri.rows; ++y)
                for (int x = 0; x < ri.cols; ++x)
                    h[std::min(kHistBins - 1, (int)(std::abs(ri.at<float>(y, x)) / kHistStep))] +=
                        1;
            const double sr = histSigma(h);
            double sxy = 0, sxx = 0;
            accumulateCorrelation(ri, Mat(ri.size(), CV_8U, Scalar(1)), 4 * sr, sxy, sxx);
            c.blur.push_back(b);
            c.ratio.push_back(sr);
            c.corr.push_back(sxx > 0 ? sxy / sxx : 0);
        }
        return c;
    }();
    return cal;
}

// Linear interpolation of y at x over a monotone (either direction) table xs.
double interpolate(const std::vector<double>& xs, const std::vector<double>& ys, double x) {
    const bool inc = xs.back() > xs.front();
    auto before = [&](double a, double b) { return inc ? a <= b : a >= b; };
    if (before(x, xs.front())) return ys.front();
    if (before(xs.back(), x)) return ys.back();
    for (size_t i = 0; i + 1 < xs.size(); ++i)
        if (before(x, xs[i + 1])) {
            const double d = xs[i + 1] - xs[i];
            const double f = d != 0 ? (x - xs[i]) / d : 0;
            return ys[i] + f * (ys[i + 1] - ys[i]);
        }
    return ys.back();
}

}  // namespace

Vec3d GrainModel::sigmaAt(double v) const {
    if (level.empty()) return Vec3d(0, 0, 0);
    if (v <= level.front()) return sigma.front();
    if (v >= level.back()) return sigma.back();
    for (size_t i = 0; i + 1 < level.size(); ++i)
        if (v <= level[i + 1]) {
            const double f = (v - level[i]) / (level[i + 1] - level[i]);
            return sigma[i] * (1 - f) + sigma[i + 1] * f;
        }
    return sigma.back();
}

double GrainModel::meanSigma() const {
    double s = 0, n = 0;
    for (size_t i = 0; i < sigma.size(); ++i) {
        const double w = i < count.size() ? count[i] : 1;
        s += w * (sigma[i][0] + sigma[i][1] + sigma[i][2]) / 3;
        n += w;
    }
    return n > 0 ? s / n : 0;
}

GrainModel measureGrain(const std::vector<Mat>& frames, const GrainParams& gp) {
    CV_Assert(gp.bins >= 1 && gp.bins <= 256);
    CV_Assert(gp.flat_fraction > 0 && gp.flat_fraction <= 1);
    const int B = gp.bins;
    const double bin_width = 256.0 / B;
    // |residual| histograms per bin and channel
    std::vector<std::vector<double>> hist((size_t)B * 3, std::vector<double>(kHistBins, 0));
    std::vector<int> count(B, 0);
    std::vector<int> count_c((size_t)B * 3, 0);  // per bin and channel
    double sxy = 0, sxx = 0;
    int pixels = 0;
    for (const Mat& frame : frames) {
        if (frame.empty()) continue;
        CV_Assert(frame.type() == CV_8UC3 || frame.type() == CV_16UC3);
        Mat f;
        frame.convertTo(f, CV_32FC3, frame.depth() == CV_16U ? 255.0 / 65535.0 : 1.0);
        Mat s, r;
        gaussian(f, s, kResidualSigma);
        r = f - s;
        // flatness: the largest gradient over the channels of a smoother image (σ = 2, so that
        // the selection hardly depends on the noise the residual measures)
        Mat s2, gx, gy, mag;
        gaussian(f, s2, 2.0);
        Sobel(s2, gx, CV_32F, 1, 0, 3);
        Sobel(s2, gy, CV_32F, 0, 1, 3);
        magnitude(gx.reshape(1), gy.reshape(1), mag);
        mag = mag.reshape(3);
        std::vector<Mat> mc;
        split(mag, mc);
        Mat g = max(max(mc[0], mc[1]), mc[2]);
        // the flattest fraction, away from a 4 px border
        const int border = 4;
        if (f.cols <= 2 * border + 2 || f.rows <= 2 * border + 2) continue;
        const Rect inner(border, border, f.cols - 2 * border, f.rows - 2 * border);
        std::vector<float> gv;
        gv.reserve(inner.area());
        for (int y = inner.y; y < inner.br().y; ++y)
            for (int x = inner.x; x < inner.br().x; ++x)
                gv.push_back(g.at<float>(y, x));
        const size_t kth = std::min(gv.size() - 1, (size_t)(gp.flat_fraction * gv.size()));
        std::nth_element(gv.begin(), gv.begin() + kth, gv.end());
        const float thr = gv[kth];
        Mat sel = Mat::zeros(f.size(), CV_8U);
        sel(inner).setTo(1, g(inner) <= thr);
        std::vector<Mat> rc, sc;
        split(r, rc);
        split(s, sc);
        for (int c = 0; c < 3; ++c) {
            std::vector<double> all(kHistBins, 0);
            for (int y = 0; y < f.rows; ++y) {
                const uchar* m = sel.ptr<uchar>(y);
                const float* rr = rc[c].ptr<float>(y);
                const float* ss = sc[c].ptr<float>(y);
                for (int x = 0; x < f.cols; ++x) {
                    if (!m[x]) continue;
                    const int b = std::min(B - 1, std::max(0, (int)(ss[x] / bin_width)));
                    const int hb = std::min(kHistBins - 1, (int)(std::abs(rr[x]) / kHistStep));
                    hist[(size_t)b * 3 + c][hb] += 1;
                    all[hb] += 1;
                    ++count_c[(size_t)b * 3 + c];
                    if (c == 0) {
                        ++count[b];
                        ++pixels;
                    }
                }
            }
            accumulateCorrelation(rc[c], sel, 4 * std::max(0.1, histSigma(all)), sxy, sxx);
        }
    }
    GrainModel m;
    m.pixels = pixels;
    const Calibration& cal = calibration();
    m.correlation = sxx > 0 ? sxy / sxx : cal.corr.front();
    m.blur = interpolate(cal.corr, cal.blur, m.correlation);
    const double ratio = interpolate(cal.blur, cal.ratio, m.blur);
    // bins with enough pixels (per channel); the others take the nearest such bin's value
    int good_bins = 0;
    for (int b = 0; b < B; ++b)
        good_bins += count[b] >= gp.min_bin_pixels ? 1 : 0;
    m.reliable = good_bins >= gp.min_reliable_bins;
    if (good_bins == 0) return m;
    m.level.resize(B);
    m.count = count;
    m.sigma.assign(B, Vec3d(0, 0, 0));
    for (int b = 0; b < B; ++b)
        m.level[b] = (b + 0.5) * bin_width;
    for (int c = 0; c < 3; ++c) {
        std::vector<int> good;
        for (int b = 0; b < B; ++b)
            if (count_c[(size_t)b * 3 + c] >= gp.min_bin_pixels) good.push_back(b);
        if (good.empty()) {  // this channel is nowhere flat enough: all of its pixels
            for (int b = 0; b < B; ++b)
                if (count_c[(size_t)b * 3 + c] > 0) good.push_back(b);
            if (good.empty()) continue;
        }
        for (int b = 0; b < B; ++b) {
            int src = good.front();
            for (int gb : good)
                if (std::abs(gb - b) < std::abs(src - b)) src = gb;
            m.sigma[b][c] = histSigma(hist[(size_t)src * 3 + c]) / ratio;
        }
    }
    return m;
}

Vec3d regionNoise(InputArray linear_in, InputArray region_in, Response response) {
    const Mat lin = linear_in.getMat(), region = region_in.getMat();
    CV_Assert(lin.type() == CV_32FC3);
    CV_Assert(region.type() == CV_8UC1 && region.size() == lin.size());
    Mat d, s;
    encode(lin, d, response, CV_32F);
    d *= 255.0;
    gaussian(d, s, kResidualSigma);
    const Mat r = d - s;
    std::vector<std::vector<double>> h(3, std::vector<double>(kHistBins, 0));
    int n = 0;
    for (int y = 0; y < r.rows; ++y)
        for (int x = 0; x < r.cols; ++x)
            if (region.at<uchar>(y, x)) {
                ++n;
                for (int c = 0; c < 3; ++c)
                    h[c][std::min(kHistBins - 1,
                                  (int)(std::abs(r.at<Vec3f>(y, x)[c]) / kHistStep))] += 1;
            }
    if (n < 20) return Vec3d(0, 0, 0);
    const double ratio = calibration().ratio.front();  // a render's noise is white
    return Vec3d(histSigma(h[0]), histSigma(h[1]), histSigma(h[2])) * (1.0 / ratio);
}

void addGrain(InputOutputArray linear_io, InputArray weight_in, const GrainModel& model,
              Response response, uint64 seed, const Vec3d& present) {
    Mat lin = linear_io.getMat();
    const Mat w = weight_in.getMat();
    CV_Assert(lin.type() == CV_32FC3);
    CV_Assert(w.type() == CV_32FC1 && w.size() == lin.size());
    if (model.sigma.empty()) return;
    RNG rng(seed ? seed : 0x9e3779b97f4a7c15ull);
    Mat n(lin.size(), CV_32FC3);
    rng.fill(n, RNG::NORMAL, 0, 1);
    if (model.blur > 0) {
        Mat nb;
        gaussian(n, nb, model.blur);
        n = nb * (1.0 / std::sqrt(kernelEnergy(model.blur)));
    }
    for (int y = 0; y < lin.rows; ++y) {
        Vec3f* L = lin.ptr<Vec3f>(y);
        const float* W = w.ptr<float>(y);
        const Vec3f* N = n.ptr<Vec3f>(y);
        for (int x = 0; x < lin.cols; ++x) {
            const float wx = std::min(1.f, std::max(0.f, W[x]));
            if (wx <= 0) continue;
            // the footage's part (1 − w) brings its own noise, the object's part w the render's
            const double keep = (1.0 - wx) * (1.0 - wx);
            for (int c = 0; c < 3; ++c) {
                const float v = encode(L[x][c], response);  // display, [0, 1]
                const double sf = model.sigmaAt(255.0 * v)[c];
                const double add2 =
                    (1 - keep) * sf * sf - (double)wx * wx * present[c] * present[c];
                if (add2 <= 0) continue;
                const float vn =
                    std::min(1.f, std::max(0.f, v + (float)(std::sqrt(add2) / 255.0) * N[x][c]));
                L[x][c] = linearize(vn, response);
            }
        }
    }
}

namespace insertion {

GrainModel footageGrain(const InsertionParams& p, const std::map<int, Mat>& kept) {
    GrainModel m;
    if (p.grain == InsertionParams::GRAIN_OFF) return m;
    std::vector<Mat> frames;
    for (const auto& kv : kept) {  // at most 8, spread over the kept frames
        frames.push_back(kv.second);
    }
    if (frames.size() > 8) {
        std::vector<Mat> spread;
        for (int k = 0; k < 8; ++k)
            spread.push_back(frames[k * frames.size() / 8]);
        frames.swap(spread);
    }
    return measureGrain(frames);
}

void addFrameGrain(const PreparedInsertion& prepared, int i, const DifferentialImages& layers,
                   Mat& linear) {
    if (!prepared.grain_on) return;
    const uint64 seed = frameSeed(prepared.render.seed ^ 0x677261696eull, i, SEEDS_PER_FRAME);
    // the render's own noise, on the objects' interior (full coverage, 2 px in)
    Mat inner = layers.mask >= 1.f;
    erode(inner, inner, getStructuringElement(MORPH_ELLIPSE, Size(5, 5)));
    const Vec3d present = regionNoise(layers.obj, inner, prepared.scene.camera.response);
    addGrain(linear, layers.mask, prepared.grain, prepared.scene.camera.response, seed, present);
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
