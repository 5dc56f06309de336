// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Streaming video inpainting: temporal fill from aligned neighbours, then exemplars.
#include <deque>
#include <map>
#include <utility>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "feature_homography.hpp"
#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/inpaint/video.hpp"
#include "pushed_frame.hpp"

namespace cv {
namespace vbme {

VideoInpainter::Params::Params() = default;

void VideoInpainter::Params::read(const FileNode& node) {
    ParamsIn in(node, "video inpainter parameters");
    in("exemplar", exemplar);
    in("temporal_radius", temporal_radius);
    in("max_ring_error", max_ring_error);
    in("ring_width", ring_width);
    in("identity_tolerance", identity_tolerance);
    in("hole_margin", hole_margin);
    in("reuse_previous", reuse_previous);
    in("features", features);
    in("refine_alignment", refine_alignment);
    in.finish();
    check();
}

void VideoInpainter::Params::check() const {
    const char* w = "video inpainter parameters";
    exemplar.check();
    checkParam(temporal_radius >= 0, w, "temporal_radius", temporal_radius, ">= 0");
    checkParam(max_ring_error >= 0, w, "max_ring_error", max_ring_error, ">= 0");
    checkParam(ring_width >= 1, w, "ring_width", ring_width, ">= 1");
    checkParam(identity_tolerance >= 0, w, "identity_tolerance", identity_tolerance, ">= 0");
    checkParam(hole_margin >= 0, w, "hole_margin", hole_margin, ">= 0");
    checkParam(features >= 0, w, "features", features, ">= 0");
}

void VideoInpainter::Params::write(FileStorage& fs) const {
    fs << "exemplar"
       << "{";
    exemplar.write(fs);
    fs << "}";
    fs << "temporal_radius" << temporal_radius;
    fs << "max_ring_error" << max_ring_error;
    fs << "ring_width" << ring_width;
    fs << "identity_tolerance" << identity_tolerance;
    fs << "hole_margin" << hole_margin;
    fs << "reuse_previous" << (int)reuse_previous;
    fs << "features" << features;
    fs << "refine_alignment" << (int)refine_alignment;
}

VideoInpainter::~VideoInpainter() = default;

namespace {

struct Frame {
    int index = 0;
    Mat image;   // CV_8UC3
    Mat hole;    // CV_8UC1, 255 = hole
    Mat usable;  // CV_8UC1, 255 = may be copied into other frames
    bool hasFeatures = false;
    std::vector<KeyPoint> keypoints;
    Mat descriptors;
};

class VideoInpainterImpl CV_FINAL : public VideoInpainter {
public:
    explicit VideoInpainterImpl(const Params& p)
        : p_(p), exemplar_(ExemplarInpainter::create(p.exemplar)) {
        orb_ = ORB::create(std::max(50, p.features));
    }

    void push(InputArray _frame, InputArray _mask) CV_OVERRIDE {
        if (finished_) CV_Error(Error::StsError, "VideoInpainter::push after finish()");
        Frame f;
        f.index = pushed_;
        detail::checkPushedFrame("VideoInpainter", pushed_, _frame, _mask, size_, f.image, f.hole);
        if (p_.hole_margin > 0) {
            Mat grown;
            dilate(f.hole, grown,
                   getStructuringElement(MORPH_ELLIPSE,
                                         Size(2 * p_.hole_margin + 1, 2 * p_.hole_margin + 1)));
            bitwise_not(grown, f.usable);
        } else {
            bitwise_not(f.hole, f.usable);
        }
        window_.push_back(std::move(f));
        ++pushed_;
    }

    void finish() CV_OVERRIDE { finished_ = true; }

    bool pop(OutputArray out, FrameStats* stats) CV_OVERRIDE {
        const int t = next_;
        if (t >= pushed_) return false;
        if (!finished_ && pushed_ <= t + p_.temporal_radius) return false;
        FrameStats st;
        Mat result = process(t, st);
        result.copyTo(out);
        if (stats) *stats = st;
        prev_ = result;
        prevIndex_ = t;
        ++next_;
        // Drop frames no later frame needs, and their cached alignments.
        while (!window_.empty() && window_.front().index < next_ - std::max(1, p_.temporal_radius))
            window_.pop_front();
        for (auto it = homographies_.begin(); it != homographies_.end();) {
            if (std::min(it->first.first, it->first.second) < next_ - p_.temporal_radius - 1)
                it = homographies_.erase(it);
            else
                ++it;
        }
        return true;
    }

    const Params& params() const CV_OVERRIDE { return p_; }

private:
    Frame& frame(int index) {
        for (auto& f : window_)
            if (f.index == index) return f;
        CV_Error(Error::StsInternal, cv::format("frame %d is not in the window", index));
    }

    void ensureFeatures(Frame& f) {
        if (f.hasFeatures) return;
        Mat gray;
        cvtColor(f.image, gray, COLOR_BGR2GRAY);
        orb_->detectAndCompute(gray, f.usable, f.keypoints, f.descriptors);
        f.hasFeatures = true;
    }

    /** Homography mapping frame s's pixels to frame t's; empty if it cannot be estimated. */
    Mat estimate(int t, int s) {
        const auto key = std::make_pair(t, s);
        auto it = homographies_.find(key);
        if (it != homographies_.end()) return it->second;
        Mat H;
        Frame& ft = frame(t);
        Frame& fs = frame(s);
        ensureFeatures(ft);
        ensureFeatures(fs);
        H = detail::featureHomography(fs.keypoints, fs.descriptors, ft.keypoints, ft.descriptors);
        if (!H.empty() && p_.refine_alignment &&
            !detail::nearIdentity(H, size_, p_.identity_tolerance)) {
            // Sub-pixel refinement: corners of frame s tracked into frame t by pyramidal
            // Lucas-Kanade from the positions H predicts, then a homography fitted to them.
            Mat gs, gt;
            cvtColor(fs.image, gs, COLOR_BGR2GRAY);
            cvtColor(ft.image, gt, COLOR_BGR2GRAY);
            H = detail::refineHomographyByFlow(gs, gt, fs.usable, ft.usable, size_, H, 600, 0.5);
        }
        homographies_[key] = H;
        return H;
    }

    /** Warps @p img and @p usable of a frame into frame t's view by @p H (empty = identity). */
    void warp(const Mat& img, const Mat& usable, const Mat& H, Mat& wimg, Mat& wusable) const {
        if (H.empty()) {
            wimg = img;
            wusable = usable;
            return;
        }
        warpPerspective(img, wimg, H, size_, INTER_LINEAR, BORDER_CONSTANT);
        Mat u;
        warpPerspective(usable, u, H, size_, INTER_NEAREST, BORDER_CONSTANT, Scalar(0));
        erode(u, wusable, Mat());  // bilinear taps reach one pixel further
    }

    /** Mean absolute difference on the ring; negative if too little of the ring is seen. */
    static double ringError(const Mat& a, const Mat& b, const Mat& bUsable, const Mat& ring) {
        int64 n = 0, total = 0;
        double sum = 0;
        for (int y = 0; y < a.rows; ++y) {
            const uchar* r = ring.ptr<uchar>(y);
            const uchar* u = bUsable.ptr<uchar>(y);
            const Vec3b* pa = a.ptr<Vec3b>(y);
            const Vec3b* pb = b.ptr<Vec3b>(y);
            for (int x = 0; x < a.cols; ++x) {
                if (!r[x]) continue;
                ++total;
                if (!u[x]) continue;
                ++n;
                sum += (std::abs(pa[x][0] - pb[x][0]) + std::abs(pa[x][1] - pb[x][1]) +
                        std::abs(pa[x][2] - pb[x][2])) /
                       3.0;
            }
        }
        if (n < 16 || n * 4 < total) return -1;
        return sum / double(n);
    }

    Mat process(int t, FrameStats& st) {
        Frame& ft = frame(t);
        st.index = t;
        st.hole = countNonZero(ft.hole);
        Mat out = ft.image.clone();
        if (st.hole == 0) return out;
        Mat rem = ft.hole.clone();
        Mat ring;
        dilate(ft.hole, ring,
               getStructuringElement(MORPH_ELLIPSE,
                                     Size(2 * p_.ring_width + 1, 2 * p_.ring_width + 1)));
        ring.setTo(0, ft.hole);

        // 1. Neighbouring frames, nearest first (earlier before later at equal distance).
        bool prevAligned = false;
        Mat prevH;
        for (int d = 1; d <= p_.temporal_radius && countNonZero(rem) > 0; ++d) {
            for (int s : {t - d, t + d}) {
                if (s < 0 || s >= pushed_ || s < next_ - p_.temporal_radius) continue;
                Frame& fs = frame(s);
                Mat H;
                if (!alignTo(t, s, fs.image, fs.usable, ring, H)) continue;
                if (s == t - 1) {
                    prevAligned = true;
                    prevH = H;
                }
                Mat wimg, wusable;
                warp(fs.image, fs.usable, H, wimg, wusable);
                Mat take;
                bitwise_and(rem, wusable, take);
                const int n = countNonZero(take);
                if (n == 0) continue;
                ++st.neighbours;
                wimg.copyTo(out, take);
                rem.setTo(0, take);
                st.temporal += n;
            }
        }
        // 2. The previous output frame, where it was filled before.
        if (p_.reuse_previous && prevIndex_ == t - 1 && !prev_.empty() && countNonZero(rem) > 0) {
            Mat H = prevH;
            bool ok = prevAligned;
            if (!ok) {
                Mat all(size_, CV_8U, Scalar(255));
                ok = alignTo(t, t - 1, prev_, all, ring, H);
            }
            if (ok) {
                Mat all(size_, CV_8U, Scalar(255));
                Mat wimg, wusable;
                warp(prev_, all, H, wimg, wusable);
                Mat take;
                bitwise_and(rem, wusable, take);
                const int n = countNonZero(take);
                wimg.copyTo(out, take);
                rem.setTo(0, take);
                st.previous = n;
            }
        }
        // 3. Exemplars for the rest.
        st.exemplar = countNonZero(rem);
        if (st.exemplar > 0) {
            Mat filled;
            exemplar_->inpaint(out, rem, filled);
            out = filled;
        }
        return out;
    }

    /** Aligns frame s to frame t and checks it on the ring: H is set to the homography s→t,
    or left empty for the identity. Returns false if no alignment passes the check. */
    bool alignTo(int t, int s, const Mat& simg, const Mat& susable, const Mat& ring, Mat& H) {
        const Frame& ft = frame(t);
        Mat est = estimate(t, s);
        // The identity is always a candidate (static camera, or too little texture for ORB).
        double bestErr = ringError(ft.image, simg, susable, ring);
        Mat best;
        bool ok = bestErr >= 0 && bestErr <= p_.max_ring_error;
        if (!est.empty() && !detail::nearIdentity(est, size_, p_.identity_tolerance)) {
            Mat wimg, wusable;
            warp(simg, susable, est, wimg, wusable);
            const double e = ringError(ft.image, wimg, wusable, ring);
            if (e >= 0 && e <= p_.max_ring_error && (!ok || e < bestErr)) {
                bestErr = e;
                best = est;
                ok = true;
            }
        }
        H = best;
        return ok;
    }

    Params p_;
    Ptr<ExemplarInpainter> exemplar_;
    Ptr<ORB> orb_;
    std::deque<Frame> window_;
    std::map<std::pair<int, int>, Mat> homographies_;
    Size size_;
    int pushed_ = 0, next_ = 0;
    bool finished_ = false;
    Mat prev_;
    int prevIndex_ = -1;
};

}  // namespace

Ptr<VideoInpainter> VideoInpainter::create(const Params& p) {
    p.check();
    return makePtr<VideoInpainterImpl>(p);
}

}  // namespace vbme
}  // namespace cv
