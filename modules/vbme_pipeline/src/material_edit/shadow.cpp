// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, shadow stage (with shadows "remove"): the original object's cast shadow is
// measured as an attenuation map (original frame / filled background, linear) and the new
// object casts a shadow fitting its material: the same map for opaque materials and chrome, a
// lighter shadow with a caustic core for glass. What is approximated:
// doc/vbme_pipeline_material_edit.md, "The new object's shadow".
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

namespace {

const double kAttenSigma = 0.5;  // the attenuation's Gaussian (pixels), after a 3×3 median

/** Fills the pixels of @p need in @p A from the pixels of weight @p W (0 or 1) by push-pull:
the weighted image and the weights are halved in size (area averages) down to a few pixels, then
each level takes the weighted mean where it has weight and the coarser level's estimate for
the rest (est = A·W + (1 − W)·coarser, W the level's mean weight). */
void pushPullFill(Mat& A, const Mat& W, const Mat& need) {
    std::vector<Mat> aw(1), w(1, W);
    {
        Mat W3;
        cvtColor(W, W3, COLOR_GRAY2BGR);
        aw[0] = A.mul(W3);
    }
    while (aw.back().cols > 2 || aw.back().rows > 2) {
        const Size s((aw.back().cols + 1) / 2, (aw.back().rows + 1) / 2);
        Mat a2, w2;
        resize(aw.back(), a2, s, 0, 0, INTER_AREA);
        resize(w.back(), w2, s, 0, 0, INTER_AREA);
        aw.push_back(a2);
        w.push_back(w2);
    }
    Mat est;
    for (int k = (int)aw.size() - 1; k >= 0; --k) {
        Mat up;
        if (est.empty())
            up = Mat(aw[k].size(), CV_32FC3, Scalar::all(1));  // nothing known: unshadowed
        else
            resize(est, up, aw[k].size(), 0, 0, INTER_LINEAR);
        est.create(aw[k].size(), CV_32FC3);
        for (int y = 0; y < est.rows; ++y) {
            const Vec3f* a = aw[k].ptr<Vec3f>(y);
            const float* ww = w[k].ptr<float>(y);
            const Vec3f* u = up.ptr<Vec3f>(y);
            Vec3f* e = est.ptr<Vec3f>(y);
            for (int x = 0; x < est.cols; ++x) {
                const float wc = std::min(1.f, std::max(0.f, ww[x]));
                e[x] = a[x] + (1 - wc) * u[x];  // a = wc × the known pixels' mean
            }
        }
    }
    est.copyTo(A, need);
}

/** Hemispherical average of the unpolarised Fresnel reflectance of a dielectric of index
@p ior seen from air (cosine-weighted), by a midpoint sum. */
double meanFresnel(double ior) {
    const int n = 256;
    double sum = 0;
    for (int i = 0; i < n; ++i) {
        const double ci = (i + 0.5) / n;  // cos θi, uniform in cos² with the weight 2 cos θ dcos
        const double si2 = std::max(0.0, 1 - ci * ci), st2 = si2 / (ior * ior);
        const double ct = std::sqrt(std::max(0.0, 1 - st2));
        const double rs = (ci - ior * ct) / (ci + ior * ct), rp = (ior * ci - ct) / (ior * ci + ct);
        sum += 0.5 * (rs * rs + rp * rp) * 2 * ci / n;
    }
    return sum;
}

}  // namespace

ShadowKind shadowKindOf(const Material& m) {
    return m.type == Material::DIELECTRIC ? SHADOW_GLASS : SHADOW_OPAQUE;
}

bool measureCastShadow(const Mat& frame8, Response response, const Mat& filled_lin,
                       const Mat& shadow_mask, const Mat& hole, Point2f center, float radius,
                       double smooth, CastShadow& out) {
    out = CastShadow();
    if (shadow_mask.empty() || countNonZero(shadow_mask) == 0) return false;
    // Everything is done in a window around the shadow and the hole (a whole-frame dilation
    // by half the radius cost more than the rest of this stage).
    const int rim = 2 * (int)std::ceil(smooth) + 1;
    const int g = std::max(1, (int)std::ceil(0.5 * radius));
    const int pad = 3 * (int)std::ceil(smooth) + 2;
    const int pad0 = rim + g + pad + 2;
    Rect w0 = boundingRect(shadow_mask) | boundingRect(hole);
    w0 = Rect(w0.x - pad0, w0.y - pad0, w0.width + 2 * pad0, w0.height + 2 * pad0) &
         Rect(Point(), frame8.size());
    const Mat sm = shadow_mask(w0), ho = hole(w0);
    // The region: the detected shadow grown to take in the penumbra, and the hole (whose
    // pixels were the object's: its part of the shadow is completed from around it).
    Mat D;
    dilate(sm, D, getStructuringElement(MORPH_ELLIPSE, Size(2 * rim + 1, 2 * rim + 1)));
    // Only the parts of it that reach the object (half a radius beyond the hole): a ball's
    // cast shadow touches it where it stands; darker patches further away are the fill's
    // (misaligned texture), not the object's.
    {
        Mat near, labels;
        dilate(ho, near, getStructuringElement(MORPH_ELLIPSE, Size(2 * g + 1, 2 * g + 1)));
        const int n = connectedComponents(D, labels, 8, CV_32S);
        std::vector<uchar> touches(n, 0);
        for (int y = 0; y < D.rows; ++y) {
            const int* l = labels.ptr<int>(y);
            const uchar* nr = near.ptr<uchar>(y);
            for (int x = 0; x < D.cols; ++x)
                if (l[x] > 0 && nr[x]) touches[l[x]] = 1;
        }
        for (int y = 0; y < D.rows; ++y) {
            const int* l = labels.ptr<int>(y);
            uchar* d = D.ptr<uchar>(y);
            for (int x = 0; x < D.cols; ++x)
                if (d[x] && !touches[l[x]]) d[x] = 0;
        }
        if (countNonZero(D) == 0) return false;
    }
    Mat region = D | ho;
    Rect lroi = boundingRect(region);
    lroi = Rect(lroi.x - pad, lroi.y - pad, lroi.width + 2 * pad, lroi.height + 2 * pad) &
           Rect(Point(), w0.size());
    const Rect roi = lroi + w0.tl();
    Mat Ir;
    linearize(frame8(roi), Ir, response);
    const Mat Dr = D(lroi), Hr = ho(lroi), Br = filled_lin(roi);
    // The attenuation frame / background on the grown shadow, 1 elsewhere; weight 0 in the
    // hole.
    Mat A(roi.size(), CV_32FC3, Scalar::all(1)), W(roi.size(), CV_32F, Scalar(1));
    for (int y = 0; y < roi.height; ++y) {
        const uchar* d = Dr.ptr<uchar>(y);
        const uchar* h = Hr.ptr<uchar>(y);
        const Vec3f* i = Ir.ptr<Vec3f>(y);
        const Vec3f* b = Br.ptr<Vec3f>(y);
        Vec3f* a = A.ptr<Vec3f>(y);
        float* w = W.ptr<float>(y);
        for (int x = 0; x < roi.width; ++x) {
            if (h[x]) {
                a[x] = Vec3f(0, 0, 0);
                w[x] = 0;
                continue;
            }
            if (!d[x]) continue;
            for (int c = 0; c < 3; ++c)
                a[x][c] = std::min(1.f, std::max(0.02f, (i[x][c] + 1e-4f) / (b[x][c] + 1e-4f)));
        }
    }
    // Denoised lightly (a 3×3 median, then a Gaussian of σ = kAttenSigma by normalised
    // convolution): the frame's noise and the fill's texture mismatch are not the shadow, but
    // a contact shadow's edge is sharp (σ = 2 px lost 10 dB against the footage on the Blender
    // clip, doc/vbme_pipeline_material_edit.md).
    {
        Mat Am;
        medianBlur(A, Am, 3);
        for (int y = 0; y < roi.height; ++y) {
            const uchar* d = Dr.ptr<uchar>(y);
            const uchar* h = Hr.ptr<uchar>(y);
            const Vec3f* am = Am.ptr<Vec3f>(y);
            Vec3f* a = A.ptr<Vec3f>(y);
            for (int x = 0; x < roi.width; ++x)
                if (d[x] && !h[x]) a[x] = am[x];
        }
        std::vector<Mat> ch;
        split(A, ch);
        for (Mat& c : ch) {
            Mat cw = c.mul(W);
            GaussianBlur(cw, c, Size(0, 0), kAttenSigma);
        }
        Mat Wb;
        GaussianBlur(W, Wb, Size(0, 0), kAttenSigma);
        Mat AW;
        merge(ch, AW);
        for (int y = 0; y < roi.height; ++y) {
            const uchar* d = Dr.ptr<uchar>(y);
            const uchar* h = Hr.ptr<uchar>(y);
            const float* wb = Wb.ptr<float>(y);
            const Vec3f* aw = AW.ptr<Vec3f>(y);
            Vec3f* a = A.ptr<Vec3f>(y);
            for (int x = 0; x < roi.width; ++x)
                if (d[x] && !h[x] && wb[x] > 1e-3f) a[x] = aw[x] / wb[x];
        }
    }
    // The hole: completed from its surroundings (the object's contact shadow continues under
    // its margin).
    pushPullFill(A, W, Hr);
    out.roi = roi;
    out.atten = A;
    out.region = region(lroi).clone();
    out.hole = Hr.clone();
    // The deficit-weighted centroid of the shadow outside the object's disk: its offset from
    // the disk's centre points away from the key light (in the image).
    double sw = 0, sx = 0, sy = 0;
    for (int y = 0; y < roi.height; ++y) {
        const Vec3f* a = A.ptr<Vec3f>(y);
        const uchar* r = out.region.ptr<uchar>(y);
        for (int x = 0; x < roi.width; ++x) {
            if (!r[x]) continue;
            const float px = (float)(x + roi.x), py = (float)(y + roi.y);
            const float dx = px - center.x, dy = py - center.y;
            if (dx * dx + dy * dy <= radius * radius) continue;
            const double d = std::max(0.0, 1.0 - (a[x][0] + a[x][1] + a[x][2]) / 3.0);
            sw += d;
            sx += d * px;
            sy += d * py;
        }
    }
    out.deficit_area = sw;
    if (sw > 0) out.offset = Point2f((float)(sx / sw) - center.x, (float)(sy / sw) - center.y);
    out.found = sw > 1.0;
    return out.found;
}

void glassShadow(const CastShadow& s, Point2f center, const Material& m, Mat& atten) {
    const Mat& A = s.atten;
    atten = A.clone();
    if (!s.found) return;
    // Of the key light the sphere intercepts, the part transmitted through both surfaces,
    // (1 − F̄)², is focused by the ball lens; a share kCore of it into the core, the rest
    // spread over the shadow as it was (the rim's rays, strongly deflected).
    const double F = meanFresnel(std::max(1.0001, m.ior));
    const double tau = (1 - F) * (1 - F);
    const double kCore = 0.7;
    // Core: a broad Gaussian (σ = half the shadow's equivalent radius: the floor lies before
    // the ball lens's focus, 1.5 radii from its centre for IOR 1.5, so the refracted beam is
    // still a patch, not a point) at the shadow's deficit centroid, which lies on the line from
    // the ball away from the key light. Size and position were revised against Cycles' glass
    // truth (test_pipeline_material_edit_shadow.cpp): a focused core (σ = 0.2) placed a
    // quarter radius beyond the centroid was 2.5–3× too bright and 6–8 px too far.
    const double Rs = std::sqrt(std::max(1.0, s.deficit_area) / CV_PI);
    const Point2f core = center + s.offset;
    const double sigma = std::max(1.0, 0.5 * Rs);
    // The core only where the shadow is (its support: the deficit relative to the deepest).
    double dmax = 0;
    for (int y = 0; y < A.rows; ++y)
        for (int x = 0; x < A.cols; ++x) {
            const Vec3f a = A.at<Vec3f>(y, x);
            dmax = std::max(dmax, 1.0 - (a[0] + a[1] + a[2]) / 3.0);
        }
    if (dmax <= 0) return;
    Mat G(A.size(), CV_32F);
    double sumG = 0;
    Vec3d sumD(0, 0, 0);
    for (int y = 0; y < A.rows; ++y)
        for (int x = 0; x < A.cols; ++x) {
            const Vec3f a = A.at<Vec3f>(y, x);
            const double d = 1.0 - (a[0] + a[1] + a[2]) / 3.0;
            const double dx = x + s.roi.x - core.x, dy = y + s.roi.y - core.y;
            const double g = std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma)) *
                             std::min(1.0, std::max(0.0, d / (0.5 * dmax)));
            G.at<float>(y, x) = (float)g;
            sumG += g;
            if (!s.hole.at<uchar>(y, x))  // the light under the ball stays hidden under it
                for (int c = 0; c < 3; ++c)
                    sumD[c] += 1.0 - a[c];
        }
    // Where the core falls outside the shadow's support, its light is lost rather than
    // pushed onto the support's far tail.
    sumG = std::max(sumG, 0.5 * 2 * CV_PI * sigma * sigma);
    // Tinted glass (absorption) colours what it transmits; the absorption is per metre and the
    // ball's size in metres unknown: a ball of 0.1 m is assumed.
    Vec3d t;
    for (int c = 0; c < 3; ++c)
        t[c] = tau * std::exp(-m.absorption[c] * 0.1);
    for (int y = 0; y < A.rows; ++y)
        for (int x = 0; x < A.cols; ++x) {
            const Vec3f a = A.at<Vec3f>(y, x);
            Vec3f& o = atten.at<Vec3f>(y, x);
            const double g = G.at<float>(y, x) / sumG;
            for (int c = 0; c < 3; ++c) {
                const double d = 1.0 - a[c];
                o[c] = (float)(1.0 - d + t[c] * ((1 - kCore) * d + kCore * sumD[c] * g));
            }
        }
}

void castShadow(const CastShadow& s, const Mat& atten, Mat& background_lin) {
    if (!s.found) return;
    Mat B = background_lin(s.roi);
    for (int y = 0; y < B.rows; ++y) {
        const uchar* r = s.region.ptr<uchar>(y);
        const Vec3f* a = atten.ptr<Vec3f>(y);
        Vec3f* b = B.ptr<Vec3f>(y);
        for (int x = 0; x < B.cols; ++x)
            if (r[x]) b[x] = b[x].mul(a[x]);
    }
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
