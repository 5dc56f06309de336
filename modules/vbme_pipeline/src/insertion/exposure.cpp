// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion: exposure and white balance per frame (issue 21). The room is static, so a frame's
// linear radiance is its per-channel gain times the room's radiance at the reference exposure.
// Frames are compared with the room on the room's faces, at a reduced resolution: each frame is
// linearised, rectified onto the faces (rectifyFace) and its usable texels kept (seen, not
// clipped, neither too dark nor too bright, away from the inserted objects and the proxies).
// 1. The texture frames' gains: robust log-ratios of every pair of overlapping frames, solved
//    by least squares with frame 0 (the annotated frame) as the reference.
// 2. The room model at the reference exposure: the mean of the texture frames divided by their
//    gains; the room textures and the light frames are built from frames normalised the same way.
// 3. Every frame's gain: the robust log-ratio of the frame and the model, then smoothed over
//    time (robust local quadratic fit).
// The gains scale the rendered layers before compositing (applyFrameGain).
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "insertion/stages.hpp"
#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/render/placement.hpp"
#include "opencv2/vbme/render/room_texture.hpp"

namespace cv {
namespace vbme {
namespace insertion {

namespace {

constexpr int kMinTexels = 30;  // fewer usable texels: no estimate from that comparison
constexpr int kMaxSide = 480;   // frames are compared at most this size (longer side)

// Robust mean of @p v: the mean of the values within 3 scaled MADs of the median.
// @p v is reordered.
double robustMean(std::vector<float>& v) {
    CV_Assert(!v.empty());
    const size_t mid = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + mid, v.end());
    const double med = v[mid];
    std::vector<float> dev(v.size());
    for (size_t k = 0; k < v.size(); ++k)
        dev[k] = std::abs(v[k] - (float)med);
    std::nth_element(dev.begin(), dev.begin() + mid, dev.end());
    const double cut = 3 * 1.4826 * dev[mid];
    double s = 0;
    int n = 0;
    for (float x : v)
        if (std::abs(x - med) <= cut) {
            s += x;
            ++n;
        }
    return n ? s / n : med;
}

// Log-ratios log(a) − log(b) per channel over the texels usable in both.
// Returns the number of texels; @p r receives the robust means (when enough texels).
int compare(const FaceObservation& a, const FaceObservation& b, Vec3d& r) {
    std::vector<float> d[3];
    for (const auto& kv : a.log) {
        const auto itb = b.log.find(kv.first);
        if (itb == b.log.end()) continue;
        const Mat& la = kv.second;
        const Mat& lb = itb->second;
        const Mat& oa = a.ok.at(kv.first);
        const Mat& ob = b.ok.at(kv.first);
        for (int y = 0; y < la.rows; ++y) {
            const Vec3f* pa = la.ptr<Vec3f>(y);
            const Vec3f* pb = lb.ptr<Vec3f>(y);
            const uchar* ma = oa.ptr<uchar>(y);
            const uchar* mb = ob.ptr<uchar>(y);
            for (int x = 0; x < la.cols; ++x)
                if (ma[x] && mb[x])
                    for (int c = 0; c < 3; ++c)
                        d[c].push_back(pa[x][c] - pb[x][c]);
        }
    }
    const int n = (int)d[0].size();
    if (n >= kMinTexels)
        for (int c = 0; c < 3; ++c)
            r[c] = robustMean(d[c]);
    return n;
}

// Points on the surface of the box [lo, hi] (an 8×8 grid on each face).
std::vector<Vec3d> boxSurface(const Vec3d& lo, const Vec3d& hi) {
    std::vector<Vec3d> pts;
    const int n = 8;
    for (int ax = 0; ax < 3; ++ax)
        for (int side = 0; side < 2; ++side)
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    const int u = (ax + 1) % 3, v = (ax + 2) % 3;
                    Vec3d p;
                    p[ax] = side ? hi[ax] : lo[ax];
                    p[u] = lo[u] + (hi[u] - lo[u]) * i / (n - 1);
                    p[v] = lo[v] + (hi[v] - lo[v]) * j / (n - 1);
                    pts.push_back(p);
                }
    return pts;
}

// Fills the convex hull of the projections of @p pts (those in front of the camera) into @p m.
void fillProjectedHull(const std::vector<Vec3d>& pts, const Camera& cam, Mat& m) {
    std::vector<Point> px;
    for (const Vec3d& p : pts) {
        double depth = 0;
        const Point2d q = cam.project(p, &depth);
        if (depth <= 1e-3) continue;
        const double lim = 4.0 * (m.cols + m.rows);  // far off-screen points: clamp
        px.emplace_back(cvRound(std::max(-lim, std::min(lim, q.x))),
                        cvRound(std::max(-lim, std::min(lim, q.y))));
    }
    if (px.size() < 3) return;
    std::vector<Point> hull;
    convexHull(px, hull);
    fillConvexPoly(m, hull, Scalar(255));
}

}  // namespace

Mat influenceMask(const Scene& scene, const Camera& cam) {
    Mat m(cam.image_size, CV_8U, Scalar(0));
    for (const SceneObject& o : scene.objects) {
        // the object with room for its shadow and the light it reflects: its box grown by its
        // size on every side, down to the floor
        Vec3d lo, hi;
        objectWorldBounds(o, lo, hi);
        const Vec3d size = hi - lo;
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::max(scene.room.min[a], lo[a] - size[a]);
            hi[a] = std::min(scene.room.max[a], hi[a] + size[a]);
        }
        lo[2] = scene.room.min[2];
        fillProjectedHull(boxSurface(lo, hi), cam, m);
    }
    for (const SceneObject& o : scene.proxies) {  // real geometry in front of the room's faces
        Vec3d lo, hi;
        objectWorldBounds(o, lo, hi);
        const Vec3d pad = 0.05 * (hi - lo);
        fillProjectedHull(boxSurface(lo - pad, hi + pad), cam, m);
    }
    return m;
}

ExposureEstimator::ExposureEstimator(const Scene& scene, const Camera& first_camera)
    : scene_(scene) {
    const Size full = first_camera.image_size;
    const double s = std::min(1.0, (double)kMaxSide / std::max(full.width, full.height));
    small_ = Size(std::max(1, cvRound(full.width * s)), std::max(1, cvRound(full.height * s)));
    RoomTextureParams tp;
    tp.texel_scale = 0.5;  // a texel averages about 2×2 pixels where the face is sharpest
    tp.min_size = 8;
    tp.max_size = 256;
    const Camera c = first_camera.scaled(small_);
    for (const std::string& f : Room::faceNames())
        sizes_[f] = chooseFaceTextureSize(scene.room, f, c, tp);
    lo_ = linearize(24.f / 255.f, scene.camera.response);
    hi_ = linearize(0.96f, scene.camera.response);
}

FaceObservation ExposureEstimator::observe(const Mat& frame, const Camera& cam) const {
    CV_Assert(frame.type() == CV_8UC3 || frame.type() == CV_16UC3 || frame.type() == CV_32FC3);
    FaceObservation out;
    Mat lin, enc;
    linearize(frame, lin, scene_.camera.response);
    const double unit = frame.depth() == CV_8U ? 255.0 : frame.depth() == CV_16U ? 65535.0 : 1.0;
    frame.convertTo(enc, CV_32FC3, 1.0 / unit);
    // what must not be compared: clipped pixels (channel 0), the objects' influence and the
    // proxies (channel 1); any part of such a pixel in a texel drops the texel
    std::vector<Mat> ch;
    split(enc, ch);
    Mat clipped = max(max(ch[0], ch[1]), ch[2]) >= 0.98f;
    Mat aux_ch[3] = {Mat(), Mat(), Mat::zeros(frame.size(), CV_32F)};
    clipped.convertTo(aux_ch[0], CV_32F, 1.0 / 255);
    influenceMask(scene_, cam).convertTo(aux_ch[1], CV_32F, 1.0 / 255);
    Mat aux;
    merge(aux_ch, 3, aux);
    Camera c = cam;
    if (small_ != frame.size()) {
        resize(lin, lin, small_, 0, 0, INTER_AREA);  // in linear light: exact for a gain
        resize(aux, aux, small_, 0, 0, INTER_AREA);
        c = cam.scaled(small_);
    }
    for (const std::string& f : Room::faceNames()) {
        Mat tex, valid, atex, avalid;
        rectifyFace(lin, c, scene_.room, f, sizes_.at(f), tex, valid);
        if (countNonZero(valid) == 0) continue;
        rectifyFace(aux, c, scene_.room, f, sizes_.at(f), atex, avalid);
        Mat ok = valid.clone();
        for (int y = 0; y < tex.rows; ++y) {
            const Vec3f* t = tex.ptr<Vec3f>(y);
            const Vec3f* a = atex.ptr<Vec3f>(y);
            uchar* o = ok.ptr<uchar>(y);
            for (int x = 0; x < tex.cols; ++x) {
                if (!o[x]) continue;
                bool use = a[x][0] < 1e-3f && a[x][1] < 1e-3f;
                for (int k = 0; k < 3 && use; ++k)
                    use = t[x][k] >= lo_ && t[x][k] <= hi_;
                o[x] = use ? 255 : 0;
            }
        }
        if (countNonZero(ok) == 0) continue;
        Mat lg;
        log(max(tex, 1e-6f), lg);
        out.log[f] = lg;
        out.ok[f] = ok;
    }
    return out;
}

std::vector<Vec3d> ExposureEstimator::alignFrames(const std::vector<FaceObservation>& obs) {
    const int n = (int)obs.size();
    std::vector<Vec3d> gains(n, Vec3d(1, 1, 1));
    model_ = FaceObservation();
    if (n == 0) return gains;
    // normal equations of Σ w_ab (x_a − x_b − r_ab)² per channel, x_0 = 0
    Mat A = Mat::zeros(n, n, CV_64F);
    Mat b = Mat::zeros(n, 3, CV_64F);
    double wsum = 0;
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            Vec3d r;
            const int cnt = compare(obs[i], obs[j], r);
            if (cnt < kMinTexels) continue;
            const double w = cnt;
            wsum += w;
            A.at<double>(i, i) += w;
            A.at<double>(j, j) += w;
            A.at<double>(i, j) -= w;
            A.at<double>(j, i) -= w;
            for (int c = 0; c < 3; ++c) {
                b.at<double>(i, c) += w * r[c];
                b.at<double>(j, c) -= w * r[c];
            }
        }
    // a weak pull of consecutive frames together keeps frames that overlap no other solvable
    const double lambda = 1e-3 * std::max(1.0, wsum / n);
    for (int i = 0; i + 1 < n; ++i) {
        A.at<double>(i, i) += lambda;
        A.at<double>(i + 1, i + 1) += lambda;
        A.at<double>(i, i + 1) -= lambda;
        A.at<double>(i + 1, i) -= lambda;
    }
    if (n > 1) {
        Mat x;
        solve(A(Rect(1, 1, n - 1, n - 1)), b.rowRange(1, n), x, DECOMP_CHOLESKY);
        for (int i = 1; i < n; ++i)
            for (int c = 0; c < 3; ++c)
                gains[i][c] = std::exp(x.at<double>(i - 1, c));
    }
    // the model: the mean of the normalised frames
    std::map<std::string, Mat> sum, count;
    for (int i = 0; i < n; ++i)
        for (const auto& kv : obs[i].log) {
            Mat& m = sum[kv.first];
            Mat& cnt = count[kv.first];
            if (m.empty()) {
                m = Mat::zeros(kv.second.size(), CV_32FC3);
                cnt = Mat::zeros(kv.second.size(), CV_32F);
            }
            Mat norm_tex;
            exp(kv.second, norm_tex);
            multiply(norm_tex, Scalar(1 / gains[i][0], 1 / gains[i][1], 1 / gains[i][2]), norm_tex);
            add(m, norm_tex, m, obs[i].ok.at(kv.first));
            add(cnt, Scalar(1), cnt, obs[i].ok.at(kv.first));
        }
    for (auto& kv : sum) {
        const Mat& cnt = count[kv.first];
        Mat c3;
        merge(std::vector<Mat>(3, max(cnt, 1.f)), c3);
        divide(kv.second, c3, kv.second);
        model_.ok[kv.first] = cnt > 0;
        log(max(kv.second, 1e-6f), model_.log[kv.first]);
    }
    return gains;
}

Vec3d ExposureEstimator::frameGain(const FaceObservation& o, int* texels) const {
    Vec3d r(0, 0, 0);
    const int n = compare(o, model_, r);
    if (texels) *texels = n;
    if (n < kMinTexels) return Vec3d(1, 1, 1);
    return Vec3d(std::exp(r[0]), std::exp(r[1]), std::exp(r[2]));
}

std::vector<Vec3d> smoothGains(const std::vector<Vec3d>& raw, const std::vector<int>& texels,
                               int half_window) {
    const int n = (int)raw.size();
    CV_Assert((int)texels.size() == n && half_window >= 0);
    std::vector<int> valid;
    for (int i = 0; i < n; ++i)
        if (texels[i] >= kMinTexels) valid.push_back(i);
    std::vector<Vec3d> out(n, Vec3d(1, 1, 1));
    if (valid.empty()) return out;
    for (int c = 0; c < 3; ++c) {
        std::vector<double> y(n), w(n, 0.0), fit(n);
        for (int i : valid) {
            y[i] = std::log(raw[i][c]);
            w[i] = 1;
        }
        // robust local quadratic fit in a window of ±h frames; two reweightings (Tukey's
        // biweight of the residuals against the fit) drop single-frame outliers
        for (int iter = 0; iter < 3; ++iter) {
            for (int t = 0; t < n; ++t) {
                int h = half_window;
                Matx33d M = Matx33d::zeros();
                Vec3d v(0, 0, 0);
                int pts = 0;
                for (;; ++h) {  // widen the window until it holds a valid frame
                    M = Matx33d::zeros();
                    v = Vec3d(0, 0, 0);
                    pts = 0;
                    for (int s = std::max(0, t - h); s <= std::min(n - 1, t + h); ++s) {
                        if (w[s] <= 0) continue;
                        const double d = s - t;
                        const Vec3d phi(1, d, d * d);
                        M += w[s] * phi * phi.t();
                        v += w[s] * y[s] * phi;
                        ++pts;
                    }
                    if (pts > 0 || h >= n) break;
                }
                if (pts == 0) {
                    fit[t] = 0;
                    continue;
                }
                // as many terms as the points allow: constant, line, parabola
                const int terms = std::min(3, pts);
                Mat Ms = Mat(M)(Rect(0, 0, terms, terms)), vs = Mat(v).rowRange(0, terms), x;
                if (!solve(Ms, vs, x, DECOMP_SVD) || !std::isfinite(x.at<double>(0)))
                    x = Mat(vs / M(0, 0)).rowRange(0, 1);
                fit[t] = x.at<double>(0);
            }
            if (iter == 2) break;
            std::vector<double> res;
            for (int i : valid)
                res.push_back(std::abs(y[i] - fit[i]));
            std::nth_element(res.begin(), res.begin() + res.size() / 2, res.end());
            const double s = std::max(1e-3, 1.4826 * res[res.size() / 2]);
            for (int i : valid) {
                const double u = (y[i] - fit[i]) / (4.685 * s);
                w[i] = std::abs(u) < 1 ? (1 - u * u) * (1 - u * u) : 0.0;
            }
        }
        for (int t = 0; t < n; ++t)
            out[t][c] = std::exp(fit[t]);
    }
    return out;
}

std::vector<Vec3d> exposureGains(const InsertionParams& p, const Scene& scene,
                                 const CameraPath& path, const ExposureEstimator& est, int frames,
                                 const PipelineProgress& progress, std::vector<Vec3d>* raw,
                                 std::vector<int>* texels) {
    std::vector<Vec3d> g(frames, Vec3d(1, 1, 1));
    std::vector<int> cnt(frames, 0);
    VideoReader reader(p.video);
    Mat f;
    for (int i = 0; i < frames && reader.read(f); ++i) {
        undistortImageK1(f, f, scene.camera);  // compared with the pinhole room model
        g[i] = est.frameGain(est.observe(f, pathCamera(path, i, scene)), &cnt[i]);
        if (progress) progress("exposure", i + 1, frames);
    }
    if (raw) *raw = g;
    if (texels) *texels = cnt;
    return smoothGains(g, cnt, p.exposure_smooth);
}

void applyFrameGain(DifferentialImages& im, const Vec3d& g) {
    if (g == Vec3d(1, 1, 1)) return;
    const Scalar s(g[0], g[1], g[2]);
    for (Mat* m : {&im.obj, &im.noobj, &im.diff})
        if (!m->empty()) multiply(*m, s, *m);
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
