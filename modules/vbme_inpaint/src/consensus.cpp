// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Streaming consensus video fill: candidates from aligned frames, robust vote, shadow removal.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <deque>
#include <type_traits>
#include <utility>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "feature_homography.hpp"
#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/inpaint/consensus.hpp"
#include "pushed_frame.hpp"

namespace cv {
namespace vbme {

ShadowMode parseShadowMode(const std::string& name) {
    std::string n = name;
    for (auto& c : n)
        c = (char)std::tolower((unsigned char)c);
    if (n == "keep") return SHADOWS_KEEP;
    if (n == "remove") return SHADOWS_REMOVE;
    CV_Error(Error::StsBadArg, "unknown shadow mode '" + name + "' (expected keep or remove)");
}

std::string toString(ShadowMode m) {
    return m == SHADOWS_KEEP ? "keep" : "remove";
}

ConsensusInpainter::Params::Params() = default;

void ConsensusInpainter::Params::read(const FileNode& node) {
    ParamsIn in(node, "consensus parameters");
    in("exemplar", exemplar);
    in("temporal_radius", temporal_radius);
    in("motion_factor", motion_factor);
    in("min_radius", min_radius);
    in("max_radius", max_radius);
    in("alignment", alignment);
    in("features", features);
    in("local_reach", local_reach);
    in("identity_tolerance", identity_tolerance);
    in("max_ring_error", max_ring_error);
    in("ring_sigma", ring_sigma);
    in("temporal_sigma", temporal_sigma);
    in("hole_margin", hole_margin);
    in("shadow_reach", shadow_reach);
    in("shadow_threshold", shadow_threshold);
    in("zone_weight", zone_weight);
    in("inlier_distance", inlier_distance);
    in("shadows", shadows);
    in("shadow_min_area", shadow_min_area);
    in("shadow_smooth", shadow_smooth);
    in("shadow_relight", shadow_relight);
    in("reuse_previous", reuse_previous);
    in.finish();
    check();
}

void ConsensusInpainter::Params::check() const {
    const char* w = "consensus parameters";
    exemplar.check();
    checkParam(temporal_radius >= 0, w, "temporal_radius", temporal_radius, ">= 0 (0: automatic)");
    checkParam(motion_factor > 0, w, "motion_factor", motion_factor, "> 0");
    checkParam(min_radius >= 1, w, "min_radius", min_radius, ">= 1");
    checkParam(max_radius >= min_radius, w, "max_radius", max_radius, ">= min_radius");
    checkParam(alignment >= CONSENSUS_ALIGN_NONE && alignment <= CONSENSUS_ALIGN_FLOW, w,
               "alignment", alignment, "a ConsensusAlignment (none 0, homography 1, flow 2)");
    checkParam(features >= 0, w, "features", features, ">= 0");
    checkParam(local_reach > 0, w, "local_reach", local_reach, "> 0");
    checkParam(identity_tolerance >= 0, w, "identity_tolerance", identity_tolerance, ">= 0");
    checkParam(max_ring_error >= 0, w, "max_ring_error", max_ring_error, ">= 0");
    checkParam(ring_sigma > 0, w, "ring_sigma", ring_sigma, "> 0");
    checkParam(temporal_sigma > 0, w, "temporal_sigma", temporal_sigma, "> 0");
    checkParam(hole_margin >= 0, w, "hole_margin", hole_margin, ">= 0");
    checkParam(shadow_reach > 0, w, "shadow_reach", shadow_reach, "> 0");
    checkParam(shadow_threshold > 0 && shadow_threshold < 1, w, "shadow_threshold",
               shadow_threshold, "(0, 1)");
    checkParam(zone_weight > 0 && zone_weight <= 1, w, "zone_weight", zone_weight, "(0, 1]");
    checkParam(inlier_distance > 0, w, "inlier_distance", inlier_distance, "> 0");
    checkParam(shadows == SHADOWS_KEEP || shadows == SHADOWS_REMOVE, w, "shadows", shadows,
               "SHADOWS_KEEP (0) or SHADOWS_REMOVE (1)");
    checkParam(shadow_min_area >= 0, w, "shadow_min_area", shadow_min_area, ">= 0");
    checkParam(shadow_smooth > 0, w, "shadow_smooth", shadow_smooth, "> 0 pixels");
}

void ConsensusInpainter::Params::write(FileStorage& fs) const {
    fs << "exemplar"
       << "{";
    exemplar.write(fs);
    fs << "}";
    fs << "temporal_radius" << temporal_radius << "motion_factor" << motion_factor << "min_radius"
       << min_radius << "max_radius" << max_radius << "alignment" << alignment << "features"
       << features << "local_reach" << local_reach << "identity_tolerance" << identity_tolerance
       << "max_ring_error" << max_ring_error << "ring_sigma" << ring_sigma << "temporal_sigma"
       << temporal_sigma << "hole_margin" << hole_margin << "shadow_reach" << shadow_reach
       << "shadow_threshold" << shadow_threshold << "zone_weight" << zone_weight
       << "inlier_distance" << inlier_distance << "shadows" << shadows << "shadow_min_area"
       << shadow_min_area << "shadow_smooth" << shadow_smooth << "shadow_relight"
       << (int)shadow_relight << "reuse_previous" << (int)reuse_previous;
}

ConsensusInpainter::~ConsensusInpainter() = default;

namespace {

const int kRingWidth = 5;
const int kMedoidPool = 8;
// The zone around the hole is first voted on every kZoneGrid-th pixel of every kZoneGrid-th row.
const int kZoneGrid = 4;
// Every kDirectStep-th neighbour's map is refined directly (the others are one link from a
// refined one), with kDirectIterations ECC iterations per round.
const int kDirectStep = 2;
const int kDirectIterations = 15;

struct CFrame {
    int index = 0;
    Mat image;   // CV_8UC3
    Mat gray;    // CV_8U
    Mat hole;    // CV_8U, 255 = hole
    Mat usable;  // 255 = may give candidates (outside hole + margin)
    Mat zone;    // 255 = within reach of the hole (its object's shadow may be there)
    Mat dist;    // CV_32F distance to the hole (large where there is none)
    int area = 0;
    double radius = 0;
    Point2d centroid;
    Mat toPrev;  // CV_64F 3×3: this frame's pixels → the previous frame's (identity if none)
    std::vector<KeyPoint> keypoints;
    Mat descriptors;
};

struct Candidate {
    Mat bgr, lab, usable, zone;
    float weight = 0;
};

using detail::nearIdentity;

inline float lumaOf(const Vec3b& v) {
    return 0.114f * v[0] + 0.587f * v[1] + 0.299f * v[2];
}

/** Largest change of rg-chromaticity (each channel over the sum of the three) that a cast
shadow may make: kShadowChroma plus kShadowNoise levels over the sum (a dark pixel's
chromaticity is noisier). Another surface (a misaligned consensus of another colour) changes
more. Chosen on issue 14's Blender clips: 0.04 + 6 / sum keeps the static clip's shadow pixels
(4 142; both clips' shadow figures unchanged) and drops the pan clip's false
shadows of frames 0-11; 0.04 alone dropped the static clip's shadow region from 41.86 to
30.63 dB, 0.08 alone left part of the false shadows (zone 46.6 dB). */
const float kShadowChroma = 0.04f, kShadowNoise = 6.f;

/** Whether the frame's pixel @p i is the consensus @p b in shadow: darker than it by more than
@p tau in luma, every channel attenuated, and the chromaticity kept within kShadowChroma (a
cast shadow dims a surface about alike in every channel; a misplaced consensus of another
surface, brighter or not, changes the colour as well). */
inline bool shadowOf(const Vec3b& i, const Vec3f& b, float tau) {
    const float yb = 0.114f * b[0] + 0.587f * b[1] + 0.299f * b[2];
    if (!(yb > 1 && lumaOf(i) < (1 - tau) * yb)) return false;
    const float si = i[0] + i[1] + i[2] + 1.5f, sb = b[0] + b[1] + b[2] + 1.5f;
    for (int c = 0; c < 3; ++c) {
        if (i[c] + 0.5f >= b[c] + 0.5f) return false;
        if (std::abs((i[c] + 0.5f) / si - (b[c] + 0.5f) / sb) > kShadowChroma + kShadowNoise / si)
            return false;
    }
    return true;
}

/** Median absolute difference (mean over channels) on a mask; negative if fewer than 16 px. */
double ringError(const Mat& a, const Mat& b, const Mat& mask) {
    std::vector<float> d;
    d.reserve(1024);
    for (int y = 0; y < a.rows; ++y) {
        const uchar* m = mask.ptr<uchar>(y);
        const Vec3b* pa = a.ptr<Vec3b>(y);
        const Vec3b* pb = b.ptr<Vec3b>(y);
        for (int x = 0; x < a.cols; ++x)
            if (m[x])
                d.push_back((std::abs(pa[x][0] - pb[x][0]) + std::abs(pa[x][1] - pb[x][1]) +
                             std::abs(pa[x][2] - pb[x][2])) /
                            3.f);
    }
    if (d.size() < 16) return -1;
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    return d[d.size() / 2];
}

/** Normalised convolution: fills the flow where @p valid is 0 from its valid surroundings. */
void completeFlow(Mat& flow, const Mat& valid, double sigma) {
    Mat w;
    valid.convertTo(w, CV_32F, 1.0 / 255);
    Mat fw;
    {
        std::vector<Mat> ch;
        split(flow, ch);
        ch[0] = ch[0].mul(w);
        ch[1] = ch[1].mul(w);
        merge(ch, fw);
    }
    // The wide blurs at a quarter of the resolution (the completed flow is smooth anyway).
    Mat bw, bfw;
    const double k = sigma >= 8 ? 0.25 : 1.0;
    if (k < 1) {
        Mat sw, sfw;
        resize(w, sw, Size(), k, k, INTER_AREA);
        resize(fw, sfw, Size(), k, k, INTER_AREA);
        GaussianBlur(sw, sw, Size(0, 0), sigma * k);
        GaussianBlur(sfw, sfw, Size(0, 0), sigma * k);
        resize(sw, bw, w.size(), 0, 0, INTER_LINEAR);
        resize(sfw, bfw, w.size(), 0, 0, INTER_LINEAR);
    } else {
        GaussianBlur(w, bw, Size(0, 0), sigma);
        GaussianBlur(fw, bfw, Size(0, 0), sigma);
    }
    for (int y = 0; y < flow.rows; ++y) {
        Vec2f* f = flow.ptr<Vec2f>(y);
        const uchar* v = valid.ptr<uchar>(y);
        const float* b = bw.ptr<float>(y);
        const Vec2f* bf = bfw.ptr<Vec2f>(y);
        for (int x = 0; x < flow.cols; ++x)
            if (!v[x]) f[x] = b[x] > 1e-4f ? bf[x] / b[x] : Vec2f(0, 0);
    }
}

class ConsensusImpl CV_FINAL : public ConsensusInpainter {
public:
    explicit ConsensusImpl(const Params& p)
        : p_(p), exemplar_(ExemplarInpainter::create(p.exemplar)) {
        if (p_.alignment != CONSENSUS_ALIGN_NONE) orb_ = ORB::create(std::max(50, p_.features));
        if (p_.temporal_radius > 0) K_ = p_.temporal_radius;
    }

    void push(InputArray _frame, InputArray _mask) CV_OVERRIDE {
        if (finished_) CV_Error(Error::StsError, "ConsensusInpainter::push after finish()");
        CFrame f;
        f.index = pushed_;
        detail::checkPushedFrame("ConsensusInpainter", pushed_, _frame, _mask, size_, f.image,
                                 f.hole);
        f.area = countNonZero(f.hole);
        if (f.area > 0) {
            const Moments mo = moments(f.hole, true);
            f.centroid = Point2d(mo.m10 / mo.m00, mo.m01 / mo.m00);
            f.radius = std::sqrt(f.area / CV_PI);
            Mat inv;
            bitwise_not(f.hole, inv);
            distanceTransform(inv, f.dist, DIST_L2, 3);
            compare(f.dist, p_.hole_margin, f.usable, CMP_GT);
            compare(f.dist, std::max(1.0, p_.shadow_reach * f.radius), f.zone, CMP_LE);
        } else {
            f.dist = Mat(size_, CV_32F, Scalar(1e6f));
            f.usable = Mat(size_, CV_8U, Scalar(255));
            f.zone = Mat::zeros(size_, CV_8U);
        }
        f.toPrev = Mat::eye(3, 3, CV_64F);
        if (p_.alignment != CONSENSUS_ALIGN_NONE) {
            cvtColor(f.image, f.gray, COLOR_BGR2GRAY);
            orb_->detectAndCompute(f.gray, f.usable, f.keypoints, f.descriptors);
            if (!window_.empty() && window_.back().index == f.index - 1) {
                f.toPrev = f.area > 0 ? estimateLocal(f, window_.back()) : Mat();
                if (f.toPrev.empty()) f.toPrev = estimate(f, window_.back());
                // A link the tracks call the identity (a camera on a stand) stays one.
                if (f.area > 0 && !nearIdentity(f.toPrev, size_, p_.identity_tolerance))
                    f.toPrev = refineLocal(f, window_.back(), f.toPrev, p_.local_reach, 2, 30, 15);
            }
        }
        window_.push_back(std::move(f));
        ++pushed_;
    }

    void finish() CV_OVERRIDE { finished_ = true; }

    bool pop(OutputArray out, FrameStats* stats, OutputArray shadow) CV_OVERRIDE {
        const int t = next_;
        if (t >= pushed_) return false;
        if (K_ < 0) {
            if (!finished_ && pushed_ < p_.max_radius + 1) return false;
            chooseRadius();
        }
        if (!finished_ && pushed_ <= t + K_) return false;
        FrameStats st;
        Mat shadowMask;
        Mat result = process(t, st, shadowMask);
        result.copyTo(out);
        if (shadow.needed()) shadowMask.copyTo(shadow);
        if (stats) *stats = st;
        prev_ = result;
        prevIndex_ = t;
        ++next_;
        while (!window_.empty() && window_.front().index < next_ - std::max(1, K_))
            window_.pop_front();
        return true;
    }

    const Params& params() const CV_OVERRIDE { return p_; }

private:
    CFrame* frame(int index) {
        for (auto& f : window_)
            if (f.index == index) return &f;
        return nullptr;
    }

    /** Homography from frame a's pixels to frame b's (identity if it cannot be estimated). */
    Mat estimate(const CFrame& a, const CFrame& b) {
        Mat H = detail::featureHomography(a.keypoints, a.descriptors, b.keypoints, b.descriptors);
        if (H.empty()) return Mat::eye(3, 3, CV_64F);
        // Sub-pixel refinement: corners of a tracked into b by pyramidal Lucas-Kanade from the
        // positions H predicts, and a homography fitted to them.
        H = detail::refineHomographyByFlow(a.gray, b.gray, a.usable, b.usable, size_, H, 500, 0.7);
        if (nearIdentity(H, size_, p_.identity_tolerance)) return Mat::eye(3, 3, CV_64F);
        return H;
    }

    /** Homography from frame a's pixels to frame b's fitted around a's hole only: the
    background next to the object (typically the ground it stands on) is one plane even when
    the whole view has parallax. Corners within Params::local_reach object radii of the hole
    (outside its margin) are tracked into b by pyramidal Lucas-Kanade, kept if the track
    back lands within 0.5 px, and fitted by RANSAC. Empty if too few corners agree. */
    Mat estimateLocal(const CFrame& a, const CFrame& b) {
        Mat region, far;
        compare(a.dist, p_.hole_margin + 1, region, CMP_GT);
        compare(a.dist, std::max(40.0, p_.local_reach * a.radius), far, CMP_LT);
        bitwise_and(region, far, region);
        std::vector<Point2f> pa, pb, back;
        goodFeaturesToTrack(a.gray, pa, 400, 0.005, 4, region, 5);
        if (pa.size() < 20) return Mat();
        std::vector<uchar> ok, okb;
        std::vector<float> err;
        const TermCriteria tc(TermCriteria::COUNT | TermCriteria::EPS, 30, 0.01);
        calcOpticalFlowPyrLK(a.gray, b.gray, pa, pb, ok, err, Size(21, 21), 4, tc);
        calcOpticalFlowPyrLK(b.gray, a.gray, pb, back, okb, err, Size(21, 21), 4, tc);
        std::vector<Point2f> ra, rb;
        for (size_t k = 0; k < pa.size(); ++k) {
            const Point p(cvRound(pb[k].x), cvRound(pb[k].y));
            if (ok[k] && okb[k] && norm(back[k] - pa[k]) < 0.5 &&
                Rect(Point(), size_).contains(p) && b.usable.at<uchar>(p))
                ra.push_back(pa[k]), rb.push_back(pb[k]);
        }
        if (ra.size() < 20) return Mat();
        std::vector<uchar> inl;
        Mat H = findHomography(ra, rb, RANSAC, 1.0, inl, 2000, 0.999);
        if (H.empty() || countNonZero(inl) < 15) return Mat();
        if (nearIdentity(H, size_, p_.identity_tolerance)) return Mat::eye(3, 3, CV_64F);
        return H;
    }

    /** Refines the homography @p H from frame a's pixels to frame b's by direct image
    alignment around a's hole: the enhanced correlation coefficient (ECC) @cite Evangelidis2008
    over the ring @p reach object radii wide (at least 40 px; outside the hole's margin, and
    where b's own hole is not), in @p rounds rounds (@p iterations ECC iterations in the first,
    @p fineIterations in the others), each dropping the pixels whose residual exceeds three
    times the median (at least 6 levels: the object's shadow, other depths). Corner tracks give
    the plane to about a pixel, which fine repeated texture (floor boards) turns into visible
    seams; the direct fit brings a neighbouring view to within resampling error (measured on
    the panning clip: 37–41 dB against 26–30 dB for the tracks' fit, doc/vbme_inpaint.md).
    Returns @p H unchanged if the fit fails or moves a point two object radii from the hole's
    centre by more than 3 px (a correction, not a new solution). */
    Mat refineLocal(const CFrame& a, const CFrame& b, const Mat& H, double reach, int rounds,
                    int iterations, int fineIterations) {
        Mat region, far;
        compare(a.dist, p_.hole_margin + 1, region, CMP_GT);
        compare(a.dist, std::max(40.0, reach * a.radius), far, CMP_LT);
        bitwise_and(region, far, region);
        const Rect roi = boundingRect(far) & Rect(Point(), size_);
        if (roi.width < 16 || roi.height < 16) return H;
        // The input is cropped to the same size where H maps the ring (OpenCV 4.6's ECC
        // needs template and input of one size when a mask is given), so the warp fitted
        // is close to a translation-free correction.
        std::vector<Point2f> mid = {Point2f(roi.x + 0.5f * roi.width, roi.y + 0.5f * roi.height)},
                             midB;
        perspectiveTransform(mid, midB, H);
        Rect roiB(cvRound(midB[0].x - 0.5 * roi.width), cvRound(midB[0].y - 0.5 * roi.height),
                  roi.width, roi.height);
        roiB.x = std::max(0, std::min(size_.width - roi.width, roiB.x));
        roiB.y = std::max(0, std::min(size_.height - roi.height, roiB.y));
        const Matx33d shiftA(1, 0, roi.x, 0, 1, roi.y, 0, 0, 1);
        const Matx33d shiftB(1, 0, roiB.x, 0, 1, roiB.y, 0, 0, 1);
        const Mat tmpl = a.gray(roi), input = b.gray(roiB), usableB = b.usable(roiB);
        Mat mask = region(roi).clone();
        Mat W;
        Mat(Mat(shiftB.inv()) * H * Mat(shiftA)).convertTo(W, CV_32F);
        for (int round = 0; round < rounds; ++round) {
            Mat ub, m;
            warpPerspective(usableB, ub, W, roi.size(), INTER_NEAREST | WARP_INVERSE_MAP,
                            BORDER_CONSTANT, Scalar(0));
            bitwise_and(mask, ub, m);
            if (countNonZero(m) < 200) return H;
            Mat W2 = W.clone();
            try {
                findTransformECC(tmpl, input, W2, MOTION_HOMOGRAPHY,
                                 TermCriteria(TermCriteria::COUNT | TermCriteria::EPS,
                                              round == 0 ? iterations : fineIterations, 1e-4),
                                 m, round == 0 ? 5 : 3);
            } catch (const cv::Exception&) {
                return H;  // ECC did not converge (too little texture): keep the tracks' fit
            }
            W = W2;
            Mat wb, d;
            warpPerspective(input, wb, W, roi.size(), INTER_LINEAR | WARP_INVERSE_MAP);
            absdiff(wb, tmpl, d);
            std::vector<uchar> v;
            v.reserve(roi.area());
            for (int y = 0; y < d.rows; ++y) {
                const uchar* dd = d.ptr<uchar>(y);
                const uchar* mm = m.ptr<uchar>(y);
                for (int x = 0; x < d.cols; ++x)
                    if (mm[x]) v.push_back(dd[x]);
            }
            std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
            Mat inl;
            compare(d, std::max(6.0, 3.0 * v[v.size() / 2]), inl, CMP_LE);
            bitwise_and(mask, inl, mask);
        }
        Mat R;
        W.convertTo(R, CV_64F);
        R = Mat(shiftB) * R * Mat(shiftA.inv());
        // Sanity: the refinement is a correction, not a new solution.
        const Point2f o((float)a.centroid.x, (float)a.centroid.y);
        const float r = (float)(2 * a.radius);
        std::vector<Point2f> c = {o + Point2f(-r, -r), o + Point2f(r, -r), o + Point2f(-r, r),
                                  o + Point2f(r, r)},
                             p0, p1;
        perspectiveTransform(c, p0, H);
        perspectiveTransform(c, p1, R);
        for (size_t k = 0; k < c.size(); ++k)
            if (norm(p0[k] - p1[k]) > 3.0) return H;
        return R;
    }

    /** Homography mapping frame t's pixels to frame s's (both in the window). */
    Mat mapTo(int t, int s) {
        Mat M = Mat::eye(3, 3, CV_64F);
        if (s < t) {
            for (int f = t; f > s; --f)
                M = frame(f)->toPrev * M;
        } else if (s > t) {
            Mat A = Mat::eye(3, 3, CV_64F);  // s → t
            for (int f = t + 1; f <= s; ++f)
                A = A * frame(f)->toPrev;
            M = A.inv();
        }
        return M;
    }

    /** Homographies from frame t's pixels to each frame s in [first, last] (identity for
    s = t). The chain's links are fitted around each frame's own hole, which moves with the
    object, so that far along the chain they extrapolate the plane from where the object was
    later; each map is therefore refined directly around frame t's hole (refineLocal),
    starting from its refined neighbour one link closer to t, which keeps the start within
    the direct fit's reach. */
    std::vector<Mat> neighbourMaps(int t, int first, int last) {
        std::vector<Mat> maps(last - first + 1);
        maps[t - first] = Mat::eye(3, 3, CV_64F);
        const CFrame* ft = frame(t);
        const bool refine = p_.alignment != CONSENSUS_ALIGN_NONE && ft && ft->area > 0;
        for (int dir = -1; dir <= 1; dir += 2)
            for (int s = t + dir; s >= first && s <= last; s += dir) {
                const Mat& prev = maps[s - dir - first];
                Mat M =
                    dir < 0 ? Mat(frame(s + 1)->toPrev * prev) : Mat(frame(s)->toPrev.inv() * prev);
                if (refine && std::abs(s - t) % kDirectStep == 0 &&
                    !nearIdentity(M, size_, p_.identity_tolerance))
                    M = refineLocal(*ft, *frame(s), M, p_.local_reach, 2, kDirectIterations,
                                    kDirectIterations);
                maps[s - first] = M;
            }
        return maps;
    }

    /** K from the hole's speed against the aligned background over the frames so far. */
    void chooseRadius() {
        std::vector<double> speed, radius;
        for (size_t i = 1; i < window_.size(); ++i) {
            const CFrame& a = window_[i - 1];
            const CFrame& b = window_[i];
            if (a.area == 0 || b.area == 0 || b.index != a.index + 1) continue;
            std::vector<Point2f> pb = {Point2f((float)b.centroid.x, (float)b.centroid.y)}, pa;
            perspectiveTransform(pb, pa, b.toPrev);
            speed.push_back(norm(Point2d(pa[0].x, pa[0].y) - a.centroid));
            radius.push_back(b.radius);
        }
        int K = p_.max_radius;
        if (!speed.empty()) {
            std::nth_element(speed.begin(), speed.begin() + speed.size() / 2, speed.end());
            std::nth_element(radius.begin(), radius.begin() + radius.size() / 2, radius.end());
            const double v = speed[speed.size() / 2], d = 2 * radius[radius.size() / 2];
            if (v > 1e-3) K = (int)std::ceil(p_.motion_factor * d / v);
        }
        K_ = std::max(p_.min_radius, std::min(p_.max_radius, K));
    }

    /** vote()'s working memory: the candidates' rows at the pixel's row (setRow), and what
    is gathered at one pixel. */
    struct VoteScratch {
        std::vector<const uchar*> usable, zone;
        std::vector<const Vec3b*> bgr, lab;
        std::vector<float> w, Y;
        std::vector<uchar> inZone;
        std::vector<Vec3b> c, l;  // colour and Lab of the gathered candidates
        std::vector<std::pair<float, float>> yw;

        void setRow(const std::vector<Candidate>& cands, int y) {
            const size_t n = cands.size();
            usable.resize(n), zone.resize(n), bgr.resize(n), lab.resize(n);
            w.resize(n), Y.resize(n), inZone.resize(n), c.resize(n), l.resize(n);
            for (size_t i = 0; i < n; ++i) {
                usable[i] = cands[i].usable.ptr<uchar>(y);
                zone[i] = cands[i].zone.ptr<uchar>(y);
                bgr[i] = cands[i].bgr.ptr<Vec3b>(y);
                lab[i] = cands[i].lab.ptr<Vec3b>(y);
            }
        }
    };

    static inline int labL1(const Vec3b& a, const Vec3b& b) {
        return std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
    }

    /** The robust vote at column @p x of the row given to VoteScratch::setRow over @p cands:
    leaves out the shadowed candidates, finds the weighted Lab medoid and returns the weighted
    mean of its inliers in @p out. False if no candidate is left. Two shortcuts leave the
    result unchanged: the reference luminance is only sought when some candidate could be dark
    enough to be left out, and the medoid only when the candidates do not all lie within the
    inlier distance of each other. */
    static bool vote(const std::vector<Candidate>& cands, int x, float tau, float zw, float inl,
                     VoteScratch& sc, Vec3f& out, int& excluded) {
        const int n = (int)cands.size();
        float* w = sc.w.data();
        float* Y = sc.Y.data();
        uchar* inZone = sc.inZone.data();
        Vec3b* c = sc.c.data();
        Vec3b* l = sc.l.data();
        int m = 0;
        float ymax = 0;
        for (int i = 0; i < n; ++i)
            if (sc.usable[i][x]) {
                c[m] = sc.bgr[i][x];
                l[m] = sc.lab[i][x];
                Y[m] = lumaOf(c[m]);
                w[m] = cands[i].weight;
                inZone[m] = sc.zone[i][x] != 0;
                ymax = std::max(ymax, Y[m]);
                ++m;
            }
        if (m == 0) return false;
        // A candidate is left out only if it lies in its zone and is darker than (1 - tau)
        // times the reference below, which is at most the brightest candidate's luminance:
        // when no candidate in a zone is that dark, nothing is left out.
        bool mayExclude = false;
        for (int k = 0; k < m && !mayExclude; ++k)
            mayExclude = inZone[k] && Y[k] < (1 - tau) * ymax;
        int kept = 0;
        if (!mayExclude) {
            for (int k = 0; k < m; ++k)
                w[k] = w[k] * (inZone[k] ? zw : 1.f);
            kept = m;
        } else {
            // Unshadowed reference: the weighted median luminance of the candidates outside
            // their zones or, if all are inside, the weighted upper quartile of all (a shadow
            // only darkens).
            auto& yw = sc.yw;
            yw.clear();
            for (int k = 0; k < m; ++k)
                if (!inZone[k]) yw.emplace_back(Y[k], w[k]);
            float q = 0.5f;
            if (yw.empty()) {
                q = 0.75f;
                for (int k = 0; k < m; ++k)
                    yw.emplace_back(Y[k], w[k]);
            }
            std::sort(yw.begin(), yw.end());
            float tot = 0;
            for (auto& e : yw)
                tot += e.second;
            float acc = 0, ref = yw.back().first;
            for (auto& e : yw) {
                acc += e.second;
                if (acc >= q * tot) {
                    ref = e.first;
                    break;
                }
            }
            // Leave out shadowed candidates; down-weight the rest of the zones.
            for (int k = 0; k < m; ++k) {
                if (inZone[k] && Y[k] < (1 - tau) * ref) {
                    ++excluded;
                    continue;
                }
                c[kept] = c[k];
                l[kept] = l[k];
                w[kept] = w[k] * (inZone[k] ? zw : 1.f);
                ++kept;
            }
            if (kept == 0) return false;
        }
        // Every pairwise L1 distance is at most the sum of the per-channel ranges: within the
        // inlier distance, every candidate is an inlier of whichever medoid.
        int lo0 = 255, lo1 = 255, lo2 = 255, hi0 = 0, hi1 = 0, hi2 = 0;
        for (int b = 0; b < kept; ++b) {
            lo0 = std::min(lo0, (int)l[b][0]), hi0 = std::max(hi0, (int)l[b][0]);
            lo1 = std::min(lo1, (int)l[b][1]), hi1 = std::max(hi1, (int)l[b][1]);
            lo2 = std::min(lo2, (int)l[b][2]), hi2 = std::max(hi2, (int)l[b][2]);
        }
        Vec3f sum(0, 0, 0);
        float sw = 0;
        if ((float)((hi0 - lo0) + (hi1 - lo1) + (hi2 - lo2)) <= inl) {
            for (int b = 0; b < kept; ++b) {
                sum += w[b] * Vec3f(c[b][0], c[b][1], c[b][2]);
                sw += w[b];
            }
            out = sum / sw;
            return true;
        }
        // Weighted medoid in Lab, then the weighted mean of its inliers. The medoid is
        // sought among the kMedoidPool heaviest candidates (the earlier of equal weights;
        // cost against all), which bounds the work at kMedoidPool · n distances.
        int pool[kMedoidPool];
        int np = 0;
        for (int k = 0; k < kept; ++k) {
            if (np == kMedoidPool && !(w[k] > w[pool[np - 1]])) continue;
            int j = np < kMedoidPool ? np++ : np - 1;
            for (; j > 0 && w[pool[j - 1]] < w[k]; --j)
                pool[j] = pool[j - 1];
            pool[j] = k;
        }
        int best = 0;
        float bestCost = FLT_MAX;
        for (int q = 0; q < np; ++q) {
            const int a = pool[q];
            float cost = 0;
            for (int b = 0; b < kept && cost < bestCost; ++b)
                cost += w[b] * (float)labL1(l[a], l[b]);
            if (cost < bestCost) {
                bestCost = cost;
                best = a;
            }
        }
        for (int b = 0; b < kept; ++b) {
            if ((float)labL1(l[best], l[b]) > inl) continue;
            sum += w[b] * Vec3f(c[b][0], c[b][1], c[b][2]);
            sw += w[b];
        }
        out = sum / sw;
        return true;
    }

    Mat process(int t, FrameStats& st, Mat& shadowOut) {
        CFrame& ft = *frame(t);
        st.index = t;
        st.radius = K_;
        st.hole = ft.area;
        shadowOut = Mat::zeros(size_, CV_8U);
        Mat out = ft.image.clone();
        if (ft.area == 0) return out;
        const bool removeShadow = p_.shadows == SHADOWS_REMOVE;
        const int reach = (int)std::ceil(std::max(1.0, p_.shadow_reach * ft.radius));
        const Rect hb = boundingRect(ft.hole);
        const int grow = (removeShadow ? reach : p_.hole_margin + kRingWidth) + 2;
        const Rect roi = Rect(hb.x - grow, hb.y - grow, hb.width + 2 * grow, hb.height + 2 * grow) &
                         Rect(Point(), size_);
        const Mat It = ft.image(roi), holeT = ft.hole(roi), distT = ft.dist(roi),
                  zoneT = ft.zone(roi);
        Mat ring;
        {
            Mat a, b;
            compare(distT, p_.hole_margin + 1, a, CMP_GE);
            compare(distT, p_.hole_margin + 1 + kRingWidth, b, CMP_LE);
            bitwise_and(a, b, ring);
        }
        Mat grayT;
        if (p_.alignment == CONSENSUS_ALIGN_FLOW) cvtColor(It, grayT, COLOR_BGR2GRAY);

        // 1. Candidates: every neighbour in the window, aligned to frame t's ROI.
        std::vector<Candidate> cands;
        const Matx33d shift(1, 0, roi.x, 0, 1, roi.y, 0, 0, 1);
        const int first = std::max(0, t - K_), last = std::min(pushed_ - 1, t + K_);
        std::vector<Mat> maps = neighbourMaps(t, first, last);
        for (int s = first; s <= last; ++s) {
            if (s == t) continue;
            CFrame* fs = frame(s);
            if (!fs) continue;
            Candidate c;
            const Mat M = maps[s - first];
            const bool ident = p_.alignment == CONSENSUS_ALIGN_NONE ||
                               nearIdentity(M, size_, p_.identity_tolerance);
            if (ident) {
                c.bgr = fs->image(roi);
                c.usable = fs->usable(roi);
                c.zone = fs->zone(roi);
            } else {
                const Mat Mroi = M * Mat(shift);
                warpPerspective(fs->image, c.bgr, Mroi, roi.size(), INTER_LINEAR | WARP_INVERSE_MAP,
                                BORDER_CONSTANT);
                Mat u;
                warpPerspective(fs->usable, u, Mroi, roi.size(), INTER_NEAREST | WARP_INVERSE_MAP,
                                BORDER_CONSTANT, Scalar(0));
                erode(u, c.usable, Mat());  // bilinear taps reach one pixel further
                warpPerspective(fs->zone, c.zone, Mroi, roi.size(),
                                INTER_NEAREST | WARP_INVERSE_MAP, BORDER_CONSTANT, Scalar(0));
            }
            Mat rv;
            bitwise_and(ring, c.usable, rv);
            double e = ringError(It, c.bgr, rv);
            const double wt = 1.0 / (1.0 + std::abs(s - t) / p_.temporal_sigma);
            bool byFlow = false;
            if (p_.alignment == CONSENSUS_ALIGN_FLOW && e > 1.0) {
                Candidate f;
                if (flowAlign(grayT, holeT, c, f)) {
                    Mat fv;
                    bitwise_and(ring, f.usable, fv);
                    const double ef = ringError(It, f.bgr, fv);
                    if (ef >= 0 && (e < 0 || ef < 0.8 * e)) {
                        e = ef;
                        c = f;
                        byFlow = true;
                    }
                }
            }
            if (e < 0 || e > p_.max_ring_error) continue;
            ++st.neighbours;
            if (byFlow) ++st.flow_aligned;
            c.weight = (float)(std::exp(-(e / p_.ring_sigma) * (e / p_.ring_sigma)) * wt);
            // Lab is converted where the vote reads it only (labAt): a buffer kept from frame to
            // frame, viewed at the ROI's size.
            if (labPool_.size() <= cands.size()) labPool_.emplace_back(size_, CV_8UC3);
            c.lab = labPool_[cands.size()](Rect(Point(), roi.size()));
            cands.push_back(std::move(c));
        }

        // 2. The vote, for the hole and (to find the frame's shadow) the zone around it. The
        // zone is first voted on a grid of every kZoneGrid-th pixel and row; then in full only
        // around the groups of grid points darker than their consensus (grown by the grid's
        // step and the rim the shadow removal blends over), which is where the shadow can be:
        // the zone is about 15 times the hole's area and its vote was most of the removal's
        // time.
        Mat B(roi.size(), CV_32FC3, Scalar::all(0));
        Mat Bok = Mat::zeros(roi.size(), CV_8U);
        Mat voted = Mat::zeros(roi.size(), CV_8U);
        std::vector<int> excludedRows(roi.height, 0);
        const float tau = (float)p_.shadow_threshold, zw = (float)p_.zone_weight;
        const float inl = (float)p_.inlier_distance;
        std::vector<Point> todo;
        auto voteOver = [&](const Mat& need) {
            todo.clear();
            for (int y = 0; y < roi.height; ++y) {
                const uchar* nd = need.ptr<uchar>(y);
                const uchar* vd = voted.ptr<uchar>(y);
                for (int x = 0; x < roi.width; ++x)
                    if (nd[x] && !vd[x]) todo.emplace_back(x, y);
            }
            labAt(cands, todo);
            parallel_for_(Range(0, roi.height), [&](const Range& rows) {
                VoteScratch sc;
                for (int y = rows.start; y < rows.end; ++y) {
                    sc.setRow(cands, y);
                    const uchar* nd = need.ptr<uchar>(y);
                    uchar* vd = voted.ptr<uchar>(y);
                    for (int x = 0; x < roi.width; ++x) {
                        if (!nd[x] || vd[x]) continue;
                        vd[x] = 255;
                        Vec3f v;
                        int excl = 0;
                        bool ok = vote(cands, x, tau, zw, inl, sc, v, excl);
                        excludedRows[y] += excl;
                        if (!ok) continue;
                        B.at<Vec3f>(y, x) = v;
                        Bok.at<uchar>(y, x) = 255;
                    }
                }
            });
        };
        if (!removeShadow) {
            voteOver(holeT);
        } else {
            Mat need = holeT.clone();
            const int S = kZoneGrid;
            const int gy0 = (S - roi.y % S) % S, gx0 = (S - roi.x % S) % S;  // frame's grid
            for (int y = gy0; y < roi.height; y += S) {
                const uchar* z = zoneT.ptr<uchar>(y);
                uchar* nd = need.ptr<uchar>(y);
                for (int x = gx0; x < roi.width; x += S)
                    if (z[x]) nd[x] = 255;
            }
            voteOver(need);
            Mat dark = Mat::zeros(roi.size(), CV_8U);
            for (int y = 0; y < roi.height; ++y) {
                const uchar* h = holeT.ptr<uchar>(y);
                const uchar* ok = Bok.ptr<uchar>(y);
                const Vec3b* i = It.ptr<Vec3b>(y);
                const Vec3f* b = B.ptr<Vec3f>(y);
                uchar* d = dark.ptr<uchar>(y);
                for (int x = 0; x < roi.width; ++x) {
                    if (h[x] || !ok[x]) continue;
                    if (shadowOf(i[x], b[x], tau)) d[x] = 255;
                }
            }
            // Grid points darker than their consensus in ones and twos are noise: the shadow
            // removed covers at least shadow_min_area of the hole (after a 3×3 opening), about
            // 1/S² of that in grid points, so only groups of at least half of it (8-connected
            // on the grid) are voted around.
            const int gh = (roi.height - gy0 + S - 1) / S, gw = (roi.width - gx0 + S - 1) / S;
            if (gh > 0 && gw > 0) {
                Mat grid(gh, gw, CV_8U);
                for (int i = 0; i < gh; ++i) {
                    const uchar* d = dark.ptr<uchar>(gy0 + S * i) + gx0;
                    uchar* g = grid.ptr<uchar>(i);
                    for (int j = 0; j < gw; ++j)
                        g[j] = d[S * j];
                }
                Mat labels, gst, gc;
                connectedComponentsWithStats(grid, labels, gst, gc, 8, CV_32S);
                const int minPts =
                    std::max(2, (int)std::ceil(p_.shadow_min_area * ft.area / (2.0 * S * S)));
                for (int i = 0; i < gh; ++i) {
                    uchar* d = dark.ptr<uchar>(gy0 + S * i) + gx0;
                    const int* l = labels.ptr<int>(i);
                    for (int j = 0; j < gw; ++j)
                        if (l[j] > 0 && gst.at<int>(l[j], CC_STAT_AREA) < minPts) d[S * j] = 0;
                }
            }
            if (countNonZero(dark) > 0) {
                const int g = S + 2 * (int)std::ceil(p_.shadow_smooth) + 1;
                dilate(dark, dark,
                       getStructuringElement(MORPH_ELLIPSE, Size(2 * g + 1, 2 * g + 1)));
                bitwise_and(dark, zoneT, dark);
                voteOver(dark);
            }
        }
        for (int v : excludedRows)
            st.excluded += v;

        // 3. The hole: the consensus where there is one.
        Mat outR = out(roi);
        Mat rest = Mat::zeros(size_, CV_8U);
        for (int y = 0; y < roi.height; ++y) {
            const uchar* h = holeT.ptr<uchar>(y);
            const uchar* ok = Bok.ptr<uchar>(y);
            const Vec3f* b = B.ptr<Vec3f>(y);
            Vec3b* o = outR.ptr<Vec3b>(y);
            uchar* r = rest.ptr<uchar>(y + roi.y) + roi.x;
            for (int x = 0; x < roi.width; ++x) {
                if (!h[x]) continue;
                if (ok[x]) {
                    o[x] = Vec3b(saturate_cast<uchar>(b[x][0]), saturate_cast<uchar>(b[x][1]),
                                 saturate_cast<uchar>(b[x][2]));
                    ++st.temporal;
                } else {
                    r[x] = 255;
                }
            }
        }

        // 4. The frame's own shadow: consistent attenuation against the consensus, re-lit.
        if (removeShadow)
            removeOwnShadow(It, holeT, zoneT, B, Bok, ft.area, outR, shadowOut(roi), st);

        // 5. What no frame sees: the previous output, then exemplars.
        int nrest = countNonZero(rest);
        if (nrest > 0 && p_.reuse_previous && prevIndex_ == t - 1 && !prev_.empty()) {
            Mat M = mapTo(t, t - 1), wprev, wok;
            Mat all(size_, CV_8U, Scalar(255));
            if (nearIdentity(M, size_, p_.identity_tolerance)) {
                wprev = prev_;
                wok = all;
            } else {
                warpPerspective(prev_, wprev, M, size_, INTER_LINEAR | WARP_INVERSE_MAP);
                warpPerspective(all, wok, M, size_, INTER_NEAREST | WARP_INVERSE_MAP,
                                BORDER_CONSTANT, Scalar(0));
                erode(wok, wok, Mat());
            }
            Mat take;
            bitwise_and(rest, wok, take);
            wprev.copyTo(out, take);
            st.previous = countNonZero(take);
            rest.setTo(0, take);
            nrest -= st.previous;
        }
        if (nrest > 0) {
            const Rect b = boundingRect(rest);
            const int m = std::max(48, std::max(b.width, b.height));
            const Rect crop =
                Rect(b.x - m, b.y - m, b.width + 2 * m, b.height + 2 * m) & Rect(Point(), size_);
            Mat filled;
            exemplar_->inpaint(out(crop), rest(crop), filled);
            filled.copyTo(out(crop), rest(crop));
            st.exemplar = nrest;
        }
        return out;
    }

    /** Converts the candidates' colours to Lab at the points @p pts only (the same values as
    converting their whole images). */
    static void labAt(std::vector<Candidate>& cands, const std::vector<Point>& pts) {
        const int n = (int)pts.size();
        if (n == 0) return;
        parallel_for_(Range(0, (int)cands.size()), [&](const Range& r) {
            Mat src(1, n, CV_8UC3), dst;
            for (int i = r.start; i < r.end; ++i) {
                Candidate& c = cands[i];
                Vec3b* s = src.ptr<Vec3b>();
                for (int k = 0; k < n; ++k)
                    s[k] = c.bgr.at<Vec3b>(pts[k]);
                cvtColor(src, dst, COLOR_BGR2Lab);
                const Vec3b* d = dst.ptr<Vec3b>();
                for (int k = 0; k < n; ++k)
                    c.lab.at<Vec3b>(pts[k]) = d[k];
            }
        });
    }

    /** Aligns a homography-warped candidate further by dense DIS flow around the hole. */
    bool flowAlign(const Mat& grayT, const Mat& holeT, const Candidate& in, Candidate& out) {
        if (grayT.cols < 16 || grayT.rows < 16) return false;
        if (!dis_) {
            dis_ = DISOpticalFlow::create(DISOpticalFlow::PRESET_FAST);
        }
        Mat g;
        cvtColor(in.bgr, g, COLOR_BGR2GRAY);
        Mat flow;
        dis_->calc(grayT, g, flow);
        // Valid: seen in both (outside frame t's hole and the neighbour's), not its zone
        // either, where the object's shadow moves with it.
        Mat valid, nh;
        bitwise_not(holeT, nh);
        erode(nh, nh, Mat(), Point(-1, -1), 2);
        bitwise_and(nh, in.usable, valid);
        double r = std::sqrt(std::max(1, countNonZero(holeT)) / CV_PI);
        completeFlow(flow, valid, std::max(4.0, r));
        Mat mapx(flow.size(), CV_32F), mapy(flow.size(), CV_32F);
        for (int y = 0; y < flow.rows; ++y) {
            const Vec2f* f = flow.ptr<Vec2f>(y);
            float* mx = mapx.ptr<float>(y);
            float* my = mapy.ptr<float>(y);
            for (int x = 0; x < flow.cols; ++x) {
                mx[x] = x + f[x][0];
                my[x] = y + f[x][1];
            }
        }
        remap(in.bgr, out.bgr, mapx, mapy, INTER_LINEAR, BORDER_CONSTANT);
        Mat u;
        remap(in.usable, u, mapx, mapy, INTER_NEAREST, BORDER_CONSTANT, Scalar(0));
        erode(u, out.usable, Mat());
        remap(in.zone, out.zone, mapx, mapy, INTER_NEAREST, BORDER_CONSTANT, Scalar(0));
        return true;
    }

    void removeOwnShadow(const Mat& It, const Mat& holeT, const Mat& zoneT, const Mat& B,
                         const Mat& Bok, int holeArea, Mat& outR, Mat shadowR, FrameStats& st) {
        const float tau = (float)p_.shadow_threshold;
        Mat m = Mat::zeros(It.size(), CV_8U);
        for (int y = 0; y < It.rows; ++y) {
            const uchar* h = holeT.ptr<uchar>(y);
            const uchar* z = zoneT.ptr<uchar>(y);
            const uchar* ok = Bok.ptr<uchar>(y);
            const Vec3b* i = It.ptr<Vec3b>(y);
            const Vec3f* b = B.ptr<Vec3f>(y);
            uchar* mm = m.ptr<uchar>(y);
            for (int x = 0; x < It.cols; ++x) {
                if (h[x] || !z[x] || !ok[x]) continue;
                if (shadowOf(i[x], b[x], tau)) mm[x] = 255;
            }
        }
        morphologyEx(m, m, MORPH_OPEN, getStructuringElement(MORPH_ELLIPSE, Size(3, 3)));
        morphologyEx(m, m, MORPH_CLOSE, getStructuringElement(MORPH_ELLIPSE, Size(5, 5)));
        Mat labels, stats, cent;
        const int n = connectedComponentsWithStats(m, labels, stats, cent, 8, CV_32S);
        const int minArea = (int)std::ceil(p_.shadow_min_area * holeArea);
        Mat keep = Mat::zeros(m.size(), CV_8U);
        for (int k = 1; k < n; ++k)
            if (stats.at<int>(k, CC_STAT_AREA) >= minArea) keep.setTo(255, labels == k);
        keep.setTo(0, holeT);
        st.shadow = countNonZero(keep);
        if (st.shadow == 0) return;
        keep.copyTo(shadowR);
        const int rim = 2 * (int)std::ceil(p_.shadow_smooth) + 1;
        Mat D;
        dilate(keep, D, getStructuringElement(MORPH_ELLIPSE, Size(2 * rim + 1, 2 * rim + 1)));
        if (!p_.shadow_relight) {
            // Consensus fill of the shadow and a rim around it, feathered into the frame.
            Mat alpha;
            D.convertTo(alpha, CV_32F, 1.0 / 255);
            GaussianBlur(alpha, alpha, Size(0, 0), 0.5 * p_.shadow_smooth);
            for (int y = 0; y < It.rows; ++y) {
                const uchar* ok = Bok.ptr<uchar>(y);
                const uchar* h = holeT.ptr<uchar>(y);
                const float* al = alpha.ptr<float>(y);
                const Vec3b* i = It.ptr<Vec3b>(y);
                const Vec3f* b = B.ptr<Vec3f>(y);
                Vec3b* o = outR.ptr<Vec3b>(y);
                for (int x = 0; x < It.cols; ++x) {
                    if (h[x] || !ok[x] || al[x] <= 0) continue;
                    for (int c = 0; c < 3; ++c)
                        o[x][c] = saturate_cast<uchar>((1 - al[x]) * i[x][c] + al[x] * b[x][c]);
                }
            }
            return;
        }
        // Re-lighting: the attenuation frame / consensus on the shadow and a rim around it
        // (1 elsewhere), smoothed by normalised convolution over the known pixels (the hole,
        // whose pixels are the object's, must not pull it towards 1); dividing it out keeps
        // the frame's texture.
        Mat A(It.size(), CV_32FC3, Scalar::all(1)), W(It.size(), CV_32F, Scalar(1));
        for (int y = 0; y < It.rows; ++y) {
            const uchar* d = D.ptr<uchar>(y);
            const uchar* ok = Bok.ptr<uchar>(y);
            const uchar* h = holeT.ptr<uchar>(y);
            const Vec3b* i = It.ptr<Vec3b>(y);
            const Vec3f* b = B.ptr<Vec3f>(y);
            Vec3f* a = A.ptr<Vec3f>(y);
            float* w = W.ptr<float>(y);
            for (int x = 0; x < It.cols; ++x) {
                if (h[x]) {
                    a[x] = Vec3f(0, 0, 0);
                    w[x] = 0;
                    continue;
                }
                if (!d[x] || !ok[x]) continue;
                for (int c = 0; c < 3; ++c)
                    a[x][c] = std::min(1.f, std::max(0.05f, (i[x][c] + 0.5f) / (b[x][c] + 0.5f)));
            }
        }
        GaussianBlur(A, A, Size(0, 0), p_.shadow_smooth);
        GaussianBlur(W, W, Size(0, 0), p_.shadow_smooth);
        for (int y = 0; y < It.rows; ++y) {
            const uchar* r = D.ptr<uchar>(y);
            const uchar* h = holeT.ptr<uchar>(y);
            const Vec3b* i = It.ptr<Vec3b>(y);
            const Vec3f* a = A.ptr<Vec3f>(y);
            const float* w = W.ptr<float>(y);
            Vec3b* o = outR.ptr<Vec3b>(y);
            for (int x = 0; x < It.cols; ++x) {
                if (!r[x] || h[x] || w[x] <= 1e-3f) continue;
                for (int c = 0; c < 3; ++c)
                    o[x][c] = saturate_cast<uchar>(i[x][c] * w[x] / std::max(1e-3f, a[x][c]));
            }
        }
    }

    Params p_;
    Ptr<ExemplarInpainter> exemplar_;
    Ptr<ORB> orb_;
    Ptr<DISOpticalFlow> dis_;
    std::vector<Mat> labPool_;  // the candidates' Lab images, kept from frame to frame
    std::deque<CFrame> window_;
    Size size_;
    int pushed_ = 0, next_ = 0, K_ = -1;
    bool finished_ = false;
    Mat prev_;
    int prevIndex_ = -1;
};

}  // namespace

Ptr<ConsensusInpainter> ConsensusInpainter::create(const Params& p) {
    p.check();
    return makePtr<ConsensusImpl>(p);
}

}  // namespace vbme
}  // namespace cv
