// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/track/object_tracker.hpp"
#include "opencv2/vbme/core/params.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <type_traits>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "disk_fitter.hpp"
#include "opencv2/vbme/core/fileio.hpp"

namespace cv {
namespace vbme {

ObjectTracker::Params::Params() = default;

void ObjectTracker::Params::read(const FileNode& fn) {
    ParamsIn in(fn, "tracker parameters");
    in("h_bins", h_bins);
    in("s_bins", s_bins);
    in("threshold", threshold);
    in("open_size", open_size);
    in("close_size", close_size);
    in("fill_holes", fill_holes);
    in("use_search_window", use_search_window);
    in("window_scale", window_scale);
    in("window_margin", window_margin);
    in("neutral_highlights", neutral_highlights);
    in("highlight_min_value", highlight_min_value);
    in("highlight_max_saturation", highlight_max_saturation);
    in("lost_threshold", lost_threshold);
    in("model_update_rate", model_update_rate);
    in("min_update_confidence", min_update_confidence);
    in("min_step", min_step);
    in("colour_model", colour_model);
    in("min_init_iou", min_init_iou);
    in("max_init_overlap", max_init_overlap);
    in("predict_motion", predict_motion);
    in("max_radius_change", max_radius_change);
    in("evidence_confidence", evidence_confidence);
    in("edge_refine", edge_refine);
    in("redetect", redetect);
    in("redetect_threshold", redetect_threshold);
    in.finish();
    check();
}

void ObjectTracker::Params::check() const {
    const char* w = "tracker parameters";
    checkParam(h_bins >= 1 && h_bins <= 180, w, "h_bins", h_bins, "1..180");
    checkParam(s_bins >= 1 && s_bins <= 256, w, "s_bins", s_bins, "1..256");
    checkParam(threshold >= 0 && threshold < 1, w, "threshold", threshold, "[0, 1)");
    checkParam(open_size >= 0 && open_size <= 255, w, "open_size", open_size, "0..255");
    checkParam(close_size >= 0 && close_size <= 255, w, "close_size", close_size, "0..255");
    checkParam(window_scale > 0 && window_scale <= 100, w, "window_scale", window_scale,
               "(0, 100]");
    checkParam(window_margin >= 0 && window_margin <= 100000, w, "window_margin", window_margin,
               "0..100000 pixels");
    checkParam(highlight_min_value >= 0 && highlight_min_value <= 256, w, "highlight_min_value",
               highlight_min_value, "0..256");
    checkParam(highlight_max_saturation >= -1 && highlight_max_saturation <= 255, w,
               "highlight_max_saturation", highlight_max_saturation, "-1..255");
    checkParam(lost_threshold >= 0 && lost_threshold <= 1, w, "lost_threshold", lost_threshold,
               "[0, 1]");
    checkParam(model_update_rate >= 0 && model_update_rate <= 1, w, "model_update_rate",
               model_update_rate, "[0, 1]");
    checkParam(min_update_confidence >= 0 && min_update_confidence <= 1, w, "min_update_confidence",
               min_update_confidence, "[0, 1]");
    checkParam(min_step > 0 && min_step <= 1, w, "min_step", min_step, "(0, 1]");
    checkParam(colour_model >= TRACK_COLOUR_HS && colour_model <= TRACK_COLOUR_GMM, w,
               "colour_model", colour_model, "0..6 (TrackColourModel)");
    checkParam(min_init_iou >= 0 && min_init_iou <= 1, w, "min_init_iou", min_init_iou, "[0, 1]");
    checkParam(max_init_overlap >= 0 && max_init_overlap <= 1, w, "max_init_overlap",
               max_init_overlap, "[0, 1]");
    checkParam(max_radius_change >= 0 && max_radius_change < 1, w, "max_radius_change",
               max_radius_change, "[0, 1)");
    checkParam(redetect_threshold >= 0 && redetect_threshold <= 1, w, "redetect_threshold",
               redetect_threshold, "[0, 1]");
}

ObjectTracker::Params readTrackerParamsFile(const std::string& path) {
    FileStorage fs = openForReading(path, "the tracker parameters");
    ObjectTracker::Params p;
    try {
        const FileNode n = fs["tracker"].empty() ? fs.root() : fs["tracker"];
        p.read(n);
    } catch (const cv::Exception& e) {
        CV_Error(Error::StsBadArg, path + ": " + e.err);
    }
    return p;
}

void ObjectTracker::Params::write(FileStorage& fs) const {
    fs << "h_bins" << h_bins << "s_bins" << s_bins << "threshold" << threshold;
    fs << "open_size" << open_size << "close_size" << close_size << "fill_holes" << (int)fill_holes;
    fs << "use_search_window" << (int)use_search_window << "window_scale" << window_scale
       << "window_margin" << window_margin;
    fs << "neutral_highlights" << (int)neutral_highlights << "highlight_min_value"
       << highlight_min_value << "highlight_max_saturation" << highlight_max_saturation;
    fs << "lost_threshold" << lost_threshold << "model_update_rate" << model_update_rate
       << "min_update_confidence" << min_update_confidence << "min_step" << min_step;
    fs << "colour_model" << colour_model << "min_init_iou" << min_init_iou << "max_init_overlap"
       << max_init_overlap << "predict_motion" << (int)predict_motion << "max_radius_change"
       << max_radius_change << "evidence_confidence" << (int)evidence_confidence << "redetect"
       << (int)redetect << "redetect_threshold" << redetect_threshold;
    fs << "edge_refine" << (int)edge_refine;
}

ObjectTracker::~ObjectTracker() = default;

namespace {

// A pixel whose colour cannot be trusted: a specular highlight (bright, unsaturated) or a
// clipped pixel (a channel at the top of the range). The thesis's HS model uses both tests;
// the joint colour models keep lightness, so a pale object's bright pixels are colour there and
// only clipped pixels are unknown.
inline bool clippedPixel(const uchar* bgr) {
    return bgr[0] >= 254 || bgr[1] >= 254 || bgr[2] >= 254;
}
inline bool unreliablePixel(const Vec3b& bgr, const Vec3b& hsv, const ObjectTracker::Params& p) {
    const bool spec = hsv[2] >= p.highlight_min_value && hsv[1] <= p.highlight_max_saturation;
    return spec || clippedPixel(&bgr[0]);
}

// Colour cells: BGR quantised to 5 bits per channel (32768 cells). The joint models classify a
// pixel with one look-up of its cell, whatever the colour space the histograms live in.
constexpr int kCellBits = 5, kCells = 1 << (3 * kCellBits);
inline int cellOf(const uchar* bgr) {
    return ((bgr[0] >> 3) << 10) | ((bgr[1] >> 3) << 5) | (bgr[2] >> 3);
}

const char* modelName(int m) {
    switch (m) {
        case TRACK_COLOUR_HS:
            return "HS 30x32 (thesis)";
        case TRACK_COLOUR_LAB8:
            return "Lab 8x8x8";
        case TRACK_COLOUR_LAB16:
            return "Lab 16x16x16";
        case TRACK_COLOUR_HSV:
            return "HSV 12x8x8";
        case TRACK_COLOUR_GMM:
            return "Lab Gaussian mixture 3+6";
        case TRACK_COLOUR_AB:
            return "ab 16x16";
        default:
            return "?";
    }
}

// Bin of every colour cell in the colour space of model @p m; returns the number of bins.
int cellBins(int m, std::vector<int>& bins) {
    // Lab and HSV of every cell centre, computed once (thread-safe static initialisation).
    static const std::pair<Mat, Mat> spaces = [] {
        Mat c(kCells, 1, CV_8UC3), l, h;
        for (int i = 0; i < kCells; ++i)
            c.at<Vec3b>(i) = Vec3b(uchar(((i >> 10) & 31) * 8 + 4), uchar(((i >> 5) & 31) * 8 + 4),
                                   uchar((i & 31) * 8 + 4));
        cvtColor(c, l, COLOR_BGR2Lab);
        cvtColor(c, h, COLOR_BGR2HSV);
        return std::make_pair(l, h);
    }();
    const Mat &lab = spaces.first, &hsv = spaces.second;
    bins.resize(kCells);
    int n = 0;
    for (int i = 0; i < kCells; ++i) {
        const Vec3b L = lab.at<Vec3b>(i), H = hsv.at<Vec3b>(i);
        switch (m) {
            case TRACK_COLOUR_LAB8:
                bins[i] = ((L[0] >> 5) << 6) | ((L[1] >> 5) << 3) | (L[2] >> 5);
                n = 512;
                break;
            case TRACK_COLOUR_LAB16:
                bins[i] = ((L[0] >> 4) << 8) | ((L[1] >> 4) << 4) | (L[2] >> 4);
                n = 4096;
                break;
            case TRACK_COLOUR_HSV:
                bins[i] = (std::min(11, H[0] * 12 / 180) << 6) | ((H[1] >> 5) << 3) | (H[2] >> 5);
                n = 768;
                break;
            case TRACK_COLOUR_AB:
                bins[i] = ((L[1] >> 4) << 4) | (L[2] >> 4);
                n = 256;
                break;
            default:
                CV_Error(Error::StsBadArg, "cellBins: not a joint colour model");
        }
    }
    return n;
}

// [1 2 1]/4 along each axis of a 16×16×16 histogram: a colour seen on frame 0 lends weight to
// its neighbours, so a ball that darkens a little keeps its class.
void smooth16(std::vector<float>& h) {
    std::vector<float> t(h.size());
    const int stride[3] = {256, 16, 1};
    for (int ax = 0; ax < 3; ++ax) {
        const int s = stride[ax];
        for (int i = 0; i < 4096; ++i) {
            const int c = (i / s) % 16;
            const float a = c > 0 ? h[i - s] : h[i], b = c < 15 ? h[i + s] : h[i];
            t[i] = 0.25f * a + 0.5f * h[i] + 0.25f * b;
        }
        h.swap(t);
    }
}

void normalise(std::vector<float>& h) {
    double s = 0;
    for (float v : h)
        s += v;
    if (s > 0)
        for (float& v : h)
            v = float(v / s);
}

// Bhattacharyya coefficient of two normalised histograms (1 = identical, 0 = disjoint).
double bhattacharyya(const std::vector<float>& a, const std::vector<float>& b) {
    double s = 0;
    for (size_t i = 0; i < a.size(); ++i)
        s += std::sqrt(double(a[i]) * b[i]);
    return s;
}

// A disk found with at least this confidence sets the radius re-detection expects.
constexpr float kGoodConfidence = 0.75f;

int oddAtMost(float x, int cap) {
    int n = std::max(1, (int)std::floor(x));
    if (n % 2 == 0) --n;
    return std::min(std::max(1, n), cap);
}

class ObjectTrackerImpl final : public ObjectTracker {
public:
    explicit ObjectTrackerImpl(const Params& p) : p_(p) {
        for (int k = 0; k < kRimRays; ++k) {
            rim_cos_[k] = (float)std::cos(2 * CV_PI * k / kRimRays);
            rim_sin_[k] = (float)std::sin(2 * CV_PI * k / kRimRays);
        }
    }

    void init(InputArray _frame, InputArray _mask) override {
        Mat frame = _frame.getMat(), mask = _mask.getMat();
        if (frame.empty() || frame.type() != CV_8UC3)
            CV_Error(Error::StsBadArg, "init: expected an 8-bit BGR first frame");
        if (mask.empty())
            CV_Error(Error::StsBadArg, "init: the first-frame mask is empty (no image)");
        if (mask.size() != frame.size())
            CV_Error(Error::StsBadArg, format("init: mask is %dx%d but the frame is %dx%d",
                                              mask.cols, mask.rows, frame.cols, frame.rows));
        if (mask.channels() != 1)
            CV_Error(Error::StsBadArg, "init: the mask must have one channel");
        Mat m;
        if (mask.depth() != CV_8U)
            mask.convertTo(m, CV_8U);
        else
            m = mask;
        m = m != 0;
        const int n = countNonZero(m);
        if (n == 0) CV_Error(Error::StsBadArg, "init: the first-frame mask marks no object pixel");
        if (n == (int)m.total())
            CV_Error(Error::StsBadArg,
                     "init: the first-frame mask marks every pixel (no background to learn)");
        initialised_ = false;
        size_ = frame.size();
        hsv_.create(size_, CV_8UC3);
        fg_.create(size_, CV_8UC1);
        unknown_.create(size_, CV_8UC1);
        cleaned_.create(size_, CV_8UC1);
        padded_.create(size_.height + 2, size_.width + 2, CV_8UC1);
        votes_.create(size_, CV_8SC1);
        const Disk d0 = fitDisk(m);
        prev_ = d0;
        r_good_ = d0.radius;
        have_prev_found_ = false;
        vel_ = Point2f(0, 0);
        dr_ = 0;
        lost_run_ = 0;
        have_velocity_ = false;

        // Training pixels: the mask (object), a ring around it and the rest of the frame
        // (background); unreliable pixels are left out.
        Mat unk_hs(size_, CV_8UC1), unk_clip(size_, CV_8UC1);
        cvtColor(frame, hsv_, COLOR_BGR2HSV);
        for (int y = 0; y < size_.height; ++y) {
            const Vec3b* c = frame.ptr<Vec3b>(y);
            const Vec3b* h = hsv_.ptr<Vec3b>(y);
            uchar* a = unk_hs.ptr<uchar>(y);
            uchar* b = unk_clip.ptr<uchar>(y);
            for (int x = 0; x < size_.width; ++x) {
                a[x] = unreliablePixel(c[x], h[x], p_) ? 255 : 0;
                b[x] = clippedPixel(&c[x][0]) ? 255 : 0;
            }
        }
        const int rr = std::max(4, cvRound(0.6f * std::max(d0.radius, 4.f)));
        Mat grown;
        dilate(m, grown, getStructuringElement(MORPH_ELLIPSE, Size(2 * rr + 1, 2 * rr + 1)));
        const Mat ring = grown & ~m, rest = ~grown;

        // Candidates: the thesis's model alone, or (AUTO) every joint model; each is checked
        // on frame 0 and the one agreeing best with the mask is kept.
        std::vector<int> cands;
        if (p_.colour_model == TRACK_COLOUR_AUTO)
            cands = {TRACK_COLOUR_GMM, TRACK_COLOUR_LAB8, TRACK_COLOUR_LAB16, TRACK_COLOUR_HSV,
                     TRACK_COLOUR_AB};
        else
            cands = {p_.colour_model};
        const Rect win = windowAround(d0, 0);
        double best_iou = -1;
        int best = -1;
        std::string report;
        for (int c : cands) {
            model_ = c;
            if (c == TRACK_COLOUR_HS) {
                Mat fg_px = m.clone(), bg_px = ~m;
                if (p_.neutral_highlights) {
                    fg_px.setTo(0, unk_hs);
                    bg_px.setTo(0, unk_hs);
                }
                hueSatHistogram(hsv_, fg_px, hist_fg_, p_.h_bins, p_.s_bins);
                hueSatHistogram(hsv_, bg_px, hist_bg_, p_.h_bins, p_.s_bins);
                rebuildTable();
            } else {
                learn(frame, m & ~unk_clip, ring & ~unk_clip, rest & ~unk_clip);
            }
            const double iou = selfCheck(frame, m, win, d0.radius);
            const double bc = c == TRACK_COLOUR_HS ? -1 : bhattacharyya(hfg_, hbg_);
            report += format("%s%s: IoU %.3f", report.empty() ? "" : ", ", modelName(c), iou);
            if (bc >= 0) report += format(" (Bhattacharyya overlap %.3f)", bc);
            // A model whose object and background histograms overlap this much does not
            // separate them, whatever frame 0's segmentation happens to show.
            const bool separates = bc < 0 || bc <= p_.max_init_overlap;
            if (!separates) report += " (overlap too high)";
            if (separates && iou > best_iou + 0.01) {
                best_iou = iou;
                best = c;
            }
        }
        if (best < 0) {
            best = cands.front();
            best_iou = 0;
        }
        report_ = "frame-0 self-check: " + report + "; chosen " + modelName(best);
        init_iou_ = best_iou;
        if (best_iou < p_.min_init_iou)
            CV_Error(Error::StsError,
                     format("init: the object cannot be told from its background by colour on "
                            "frame 0: the best colour model (%s) segments frame 0 with IoU "
                            "%.2f against the mask, below min_init_iou %.2f, or overlaps more "
                            "than max_init_overlap %.2f (%s). Tracking would follow the "
                            "background; refusing.",
                            modelName(best), best_iou, p_.min_init_iou, p_.max_init_overlap,
                            report.c_str()));
        if (best != model_) {  // rebuild the chosen model
            model_ = best;
            learn(frame, m & ~unk_clip, ring & ~unk_clip, rest & ~unk_clip);
        }
        rim_ref_ = rimContrastMedian(frame, d0);
        // Edge refinement is used when it brings frame 0's disk closer to the mask than the
        // colour fit alone (a ball whose shaded side the colours miss); on a ball the colours
        // cover, the colour fit is kept (textured floors have edges of their own).
        edge_on_ = false;
        if (p_.edge_refine) {
            selfCheck(frame, m, win, d0.radius);
            makeVotes(win);
            const Point2f off((float)win.x, (float)win.y);
            DiskFitParams fp;
            fp.min_step = p_.min_step;
            fp.min_radius = std::max(2.f, d0.radius * (1 - p_.max_radius_change));
            if (p_.max_radius_change > 0) fp.max_radius = d0.radius * (1 + p_.max_radius_change);
            const Disk dl = fitter_.fit(Disk(d0.center - off, d0.radius), fp);
            const Disk dc(dl.center + off, dl.radius);
            const Disk de = refineOnEdges(frame, dc, d0.radius, fp);
            Mat a, b;
            diskMask(size_, dc, a);
            diskMask(size_, de, b);
            const double ic = maskIoU(a, m), ie = maskIoU(b, m);
            edge_on_ = ie > ic + 0.02;
            report_ += format(
                "; disk on frame 0: colour fit IoU %.3f, edge-refined IoU %.3f -> "
                "edge refinement %s",
                ic, ie, edge_on_ ? "on" : "off");
        }
        // Frame 0's own fill and surroundings under the chosen model are the reference: a pale
        // ball whose shaded side the colours cannot claim keeps full marks when it looks as it
        // did on frame 0.
        fill_ref_ = surround_ref_ = 1.f;
        selfCheck(frame, m, win, d0.radius);
        {
            Result r0;
            r0.disk = d0;
            score(frame, win, r0, nullptr);
            fill_ref_ = std::max(0.2f, r0.fill);
            surround_ref_ = std::max(0.2f, r0.surround);
        }
        initialised_ = true;
    }

    Result update(InputArray _frame, OutputArray _mask) override {
        if (!initialised_) CV_Error(Error::StsError, "update: call init() first");
        Mat frame = _frame.getMat();
        if (frame.size() != size_ || frame.type() != CV_8UC3)
            CV_Error(Error::StsBadArg, format("update: expected an 8-bit BGR frame of %dx%d",
                                              size_.width, size_.height));
        // Prediction (constant velocity over the frames since the last good disk).
        const int gap = lost_run_ + 1;
        Disk pred = prev_;
        if (p_.predict_motion && have_velocity_) {
            pred.center += vel_ * (float)gap;
            const float m = p_.max_radius_change > 0 ? p_.max_radius_change : 1.f;
            const float dr = std::max(-m * prev_.radius, std::min(m * prev_.radius, dr_));
            pred.radius = std::max(2.f, prev_.radius + dr * gap);
        }
        const bool grow_window = !p_.redetect;
        window_ = p_.use_search_window ? windowAround(pred, grow_window ? lost_run_ : 0)
                                       : Rect(0, 0, size_.width, size_.height);
        Result r = track(frame, window_, pred, true);
        if (!r.found && p_.redetect) {
            Result rd = redetect(frame);
            if (rd.found) r = rd;
        }
        if (r.found) {
            if (r.redetected || !have_prev_found_) {
                // No velocity yet: one position does not tell how the ball moves (a ball
                // already rolling on frame 0 must not be judged against standing still).
                vel_ = Point2f(0, 0);
                dr_ = 0;
                have_velocity_ = false;
            } else {
                const Point2f v = (r.disk.center - prev_.center) * (1.f / gap);
                const float dr = (r.disk.radius - prev_.radius) / gap;
                vel_ = have_velocity_ ? 0.5f * (vel_ + v) : v;
                dr_ = have_velocity_ ? 0.5f * (dr_ + dr) : dr;
                have_velocity_ = true;
            }
            have_prev_found_ = true;
            prev_ = r.disk;
            if (r.confidence >= kGoodConfidence) r_good_ = r.disk.radius;
            lost_run_ = 0;
            if (p_.model_update_rate > 0 && r.confidence >= p_.min_update_confidence)
                updateModel(frame, Disk(r.disk.center - Point2f((float)window_.x, (float)window_.y),
                                        r.disk.radius));
        } else {
            r.disk = prev_;
            ++lost_run_;
        }
        if (_mask.needed()) {
            if (r.found)
                diskMask(size_, r.disk, _mask);
            else
                _mask.create(size_, CV_8UC1), _mask.setTo(Scalar::all(0));
        }
        return r;
    }

    Mat lastForeground() const override {
        Mat out(size_, CV_8UC1, Scalar(0));
        if (!window_.empty()) cleaned_(window_).copyTo(out(window_));
        return out;
    }
    Rect lastSearchWindow() const override { return window_; }
    Mat ratioTable() const override {
        if (model_ == TRACK_COLOUR_HS) return ratio_.clone();
        Mat r(1, nbins_, CV_32F);
        for (int i = 0; i < nbins_; ++i) {
            const float a = hfg_[i], b = hbg_[i];
            r.at<float>(i) = a + b > 0 ? a / (a + b) : 0.f;
        }
        return r;
    }
    const Params& params() const override { return p_; }
    int colourModel() const override { return model_; }
    double initSelfCheckIoU() const override { return init_iou_; }
    std::string initReport() const override { return report_; }

private:
    Rect windowAround(const Disk& d, int lost_run) const {
        const Rect full(0, 0, size_.width, size_.height);
        if (d.radius <= 0) return full;
        // Each lost frame doubles the window (without re-detection), so a ball that left it is
        // found again.
        const float grow = std::pow(2.f, (float)std::min(lost_run, 8));
        const float speed = p_.predict_motion ? (float)norm(vel_) : 0.f;
        const float half = (p_.window_scale * d.radius + p_.window_margin + speed) * grow;
        Rect w((int)std::floor(d.center.x - half), (int)std::floor(d.center.y - half),
               (int)std::ceil(2 * half) + 1, (int)std::ceil(2 * half) + 1);
        w &= full;
        return w.area() > 0 ? w : full;
    }

    // Learns model_ from object pixels and background pixels (a ring around the object and the
    // rest of the frame, weighted equally).
    void learn(const Mat& frame, const Mat& fg, const Mat& ring, const Mat& rest) {
        if (model_ == TRACK_COLOUR_GMM) {
            nbins_ = kCells;
            bins_.resize(kCells);
            for (int i = 0; i < kCells; ++i)
                bins_[i] = i;
            hfg_ = gmmDensity(frame, fg, Mat(), 3);
            hbg_ = ring_weight_ > 0 ? gmmDensity(frame, ring, rest, 6)
                                    : gmmDensity(frame, rest, Mat(), 6);
        } else {
            nbins_ = cellBins(model_, bins_);
            hfg_ = histogram(frame, fg);
            const std::vector<float> hr = histogram(frame, ring), hx = histogram(frame, rest);
            hbg_.assign(nbins_, 0.f);
            const float wr = hr.empty() ? 0.f : ring_weight_;
            for (int i = 0; i < nbins_; ++i)
                hbg_[i] = wr * (hr.empty() ? 0.f : hr[i]) + (1 - wr) * (hx.empty() ? 0.f : hx[i]);
        }
        if (hfg_.empty()) hfg_.assign(nbins_, 0.f);
        rebuildLut();
    }

    // A Gaussian mixture in Lab (k-means clusters, each a full-covariance Gaussian) of the
    // pixels under @p a (and, with equal weight, @p b), evaluated at every colour cell's centre
    // and normalised over the cells.
    std::vector<float> gmmDensity(const Mat& frame, const Mat& a, const Mat& b, int K) const {
        Mat f32, lab;
        std::vector<Vec3f> pts;
        std::vector<float> wts;
        const Mat* masks[2] = {&a, &b};
        Mat labf;
        frame.convertTo(f32, CV_32F, 1.0 / 255);
        cvtColor(f32, labf, COLOR_BGR2Lab);
        for (int k = 0; k < 2; ++k) {
            if (masks[k]->empty()) continue;
            const int n = countNonZero(*masks[k]);
            if (n == 0) continue;
            const int stride = std::max(1, n / 6000);
            int seen = 0;
            std::vector<Vec3f> here;
            for (int y = 0; y < labf.rows; ++y) {
                const uchar* m = masks[k]->ptr<uchar>(y);
                const Vec3f* l = labf.ptr<Vec3f>(y);
                for (int x = 0; x < labf.cols; ++x)
                    if (m[x] && (seen++ % stride) == 0) here.push_back(l[x]);
            }
            for (const Vec3f& v : here) {
                pts.push_back(v);
                wts.push_back(1.f / here.size());
            }
        }
        std::vector<float> dens(kCells, 0.f);
        if ((int)pts.size() < K) return {};
        Mat samples((int)pts.size(), 3, CV_32F, pts.data()), labels, centers;
        theRNG().state = 0x12345;  // deterministic clusters
        kmeans(samples, K, labels, TermCriteria(TermCriteria::COUNT + TermCriteria::EPS, 20, 0.1),
               2, KMEANS_PP_CENTERS, centers);
        struct G {
            Vec3d mu;
            Matx33d icov;
            double w = 0, norm = 0;
        };
        std::vector<G> gs(K);
        std::vector<double> wsum(K, 0);
        for (size_t i = 0; i < pts.size(); ++i) {
            const int l = labels.at<int>((int)i);
            gs[l].mu += Vec3d(pts[i]) * wts[i];
            wsum[l] += wts[i];
        }
        std::vector<Matx33d> cov(K, Matx33d::zeros());
        for (int k = 0; k < K; ++k)
            if (wsum[k] > 0) gs[k].mu *= 1.0 / wsum[k];
        for (size_t i = 0; i < pts.size(); ++i) {
            const int l = labels.at<int>((int)i);
            const Vec3d d = Vec3d(pts[i]) - gs[l].mu;
            cov[l] += (d * d.t()) * wts[i];
        }
        double total = 0;
        for (double w : wsum)
            total += w;
        for (int k = 0; k < K; ++k) {
            if (wsum[k] <= 0) continue;
            // Floor of 2 Lab units (σ) per axis: noise and quantisation.
            const Matx33d c = cov[k] * (1.0 / wsum[k]) + Matx33d::eye() * 4.0;
            gs[k].icov = c.inv();
            gs[k].w = wsum[k] / total;
            gs[k].norm = gs[k].w / std::sqrt(std::max(1e-12, determinant(c)));
        }
        static const Mat cell_lab = [] {
            Mat c(kCells, 1, CV_8UC3), f, l;
            for (int i = 0; i < kCells; ++i)
                c.at<Vec3b>(i) = Vec3b(uchar(((i >> 10) & 31) * 8 + 4),
                                       uchar(((i >> 5) & 31) * 8 + 4), uchar((i & 31) * 8 + 4));
            c.convertTo(f, CV_32F, 1.0 / 255);
            cvtColor(f, l, COLOR_BGR2Lab);
            return l;
        }();
        double s = 0;
        for (int i = 0; i < kCells; ++i) {
            const Vec3d x(cell_lab.at<Vec3f>(i));
            double p = 0;
            for (const G& g : gs) {
                if (g.w <= 0) continue;
                const Vec3d d = x - g.mu;
                const double q = d.dot(g.icov * d);
                if (q < 60) p += g.norm * std::exp(-0.5 * q);
            }
            dens[i] = (float)p;
            s += p;
        }
        if (s > 0)
            for (float& v : dens)
                v = float(v / s);
        return dens;
    }

    std::vector<float> histogram(const Mat& bgr, const Mat& mask) const {
        std::vector<float> h(nbins_, 0.f);
        int n = 0;
        for (int y = 0; y < bgr.rows; ++y) {
            const uchar* c = bgr.ptr<uchar>(y);
            const uchar* m = mask.ptr<uchar>(y);
            for (int x = 0; x < bgr.cols; ++x)
                if (m[x]) {
                    h[bins_[cellOf(c + 3 * x)]] += 1.f;
                    ++n;
                }
        }
        if (n == 0) return {};
        if (model_ == TRACK_COLOUR_LAB16) smooth16(h);
        normalise(h);
        return h;
    }

    // Cell look-up: 255·f with f = p(bin | object) / (p(bin | object) + p(bin | background)).
    void rebuildLut() {
        lut_.resize(kCells);
        std::vector<uchar> per_bin(nbins_);
        for (int i = 0; i < nbins_; ++i) {
            const float a = hfg_[i], b = hbg_[i];
            per_bin[i] = a > 0 ? (uchar)cvRound(255.f * a / (a + b)) : 0;
        }
        for (int i = 0; i < kCells; ++i)
            lut_[i] = per_bin[bins_[i]];
        thr8_ = (int)std::floor(p_.threshold * 255.f);
    }

    // f > T for every (h, s) byte pair, so that classification is one look-up per pixel.
    void rebuildTable() {
        foregroundRatio(hist_fg_, hist_bg_, ratio_);
        table_.create(180, 256, CV_8UC1);
        for (int h = 0; h < 180; ++h)
            for (int s = 0; s < 256; ++s) {
                const int hb = std::min(p_.h_bins - 1, h * p_.h_bins / 180),
                          sb = s * p_.s_bins / 256;
                table_.at<uchar>(h, s) = ratio_.at<float>(hb, sb) > p_.threshold ? 255 : 0;
            }
    }

    // Object / unknown pixels of the window (views into the full-frame buffers).
    void classify(const Mat& frame, const Rect& w) {
        const Mat img = frame(w);
        Mat fg = fg_(w), unk = unknown_(w);
        if (model_ == TRACK_COLOUR_HS) {
            Mat hsv = hsv_(w);
            cvtColor(img, hsv, COLOR_BGR2HSV);
            const uchar* table = table_.ptr<uchar>();
            for (int y = 0; y < hsv.rows; ++y) {
                const Vec3b* c = img.ptr<Vec3b>(y);
                const Vec3b* h = hsv.ptr<Vec3b>(y);
                uchar* f = fg.ptr<uchar>(y);
                uchar* u = unk.ptr<uchar>(y);
                for (int x = 0; x < hsv.cols; ++x) {
                    f[x] = table[h[x][0] * 256 + h[x][1]];
                    u[x] = (p_.neutral_highlights && unreliablePixel(c[x], h[x], p_)) ? 255 : 0;
                }
            }
            return;
        }
        const uchar* lut = lut_.data();
        const int thr = thr8_;
        const bool neutral = p_.neutral_highlights;
        for (int y = 0; y < img.rows; ++y) {
            const uchar* c = img.ptr<uchar>(y);
            uchar* f = fg.ptr<uchar>(y);
            uchar* u = unk.ptr<uchar>(y);
            for (int x = 0; x < img.cols; ++x, c += 3) {
                f[x] = lut[cellOf(c)] > thr ? 255 : 0;
                u[x] = (neutral && clippedPixel(c)) ? 255 : 0;
            }
        }
    }

    const Mat& element(int size) {
        Mat& e = elements_[size];
        if (e.empty()) e = getStructuringElement(MORPH_ELLIPSE, Size(size, size));
        return e;
    }

    // Opening, closing, hole filling (thesis §4.1), with elements no larger than the ball
    // allows (a far ball of radius 8 would vanish under a 9×9 opening).
    void clean(const Rect& w, float radius) {
        Mat fg = fg_(w), cleaned = cleaned_(w);
        const int os = oddAtMost(0.6f * radius, p_.open_size),
                  cs = oddAtMost(0.8f * radius, p_.close_size);
        const bool open = p_.open_size > 1 && os > 1, close = p_.close_size > 1 && cs > 1;
        // Only the object pixels' bounding box grown by the elements' reach can change (the
        // opening stays inside the box; the closing's dilation reaches cs/2 beyond it and its
        // erosion reads cs/2 further): the filters run on that region alone, with the same
        // result as on the whole window, whose other pixels stay background.
        Rect roi = boundingRect(fg);
        cleaned.setTo(Scalar::all(0));
        if (roi.empty()) return;
        const int reach = (open ? os / 2 : 0) + (close ? cs : 0) + 2;
        roi = Rect(roi.x - reach, roi.y - reach, roi.width + 2 * reach, roi.height + 2 * reach) &
              Rect(0, 0, w.width, w.height);
        const Mat src = fg(roi);
        Mat dst = cleaned(roi);
        // The region is a view into full-frame buffers: BORDER_ISOLATED keeps the filters from
        // reading the pixels around it.
        const int border = BORDER_CONSTANT | BORDER_ISOLATED;
        if (open)
            morphologyEx(src, dst, MORPH_OPEN, element(os), Point(-1, -1), 1, border,
                         morphologyDefaultBorderValue());
        else
            src.copyTo(dst);
        if (close)
            morphologyEx(dst, dst, MORPH_CLOSE, element(cs), Point(-1, -1), 1, border,
                         morphologyDefaultBorderValue());
        if (p_.fill_holes) fillHolesInPlace(dst);
    }

    // fillHoles() on a view, with the padded buffer kept across frames.
    void fillHolesInPlace(Mat& m) {
        if (padded_.rows < m.rows + 2 || padded_.cols < m.cols + 2)
            padded_.create(std::max(padded_.rows, m.rows + 2), std::max(padded_.cols, m.cols + 2),
                           CV_8UC1);
        Mat pad = padded_(Rect(0, 0, m.cols + 2, m.rows + 2));
        pad.row(0).setTo(Scalar::all(0));
        pad.row(pad.rows - 1).setTo(Scalar::all(0));
        pad.col(0).setTo(Scalar::all(0));
        pad.col(pad.cols - 1).setTo(Scalar::all(0));
        Mat inner = pad(Rect(1, 1, m.cols, m.rows));
        m.copyTo(inner);  // the cleaned pixels are 0 or 255
        floodFill(pad, Point(0, 0), Scalar(128), nullptr, Scalar(0), Scalar(0), 4);
        // 128: background reached from the border; 0: holes; 255: object.
        compare(inner, Scalar(128), m, CMP_NE);
    }

    double selfCheck(const Mat& frame, const Mat& mask, const Rect& w, float radius) {
        classify(frame, w);
        clean(w, radius);
        return maskIoU(cleaned_(w), mask(w));
    }

    void makeVotes(const Rect& w) {
        const Mat cleaned = cleaned_(w), unk = unknown_(w);
        Mat votes = votes_(w);
        for (int y = 0; y < votes.rows; ++y) {
            const uchar* c = cleaned.ptr<uchar>(y);
            const uchar* u = unk.ptr<uchar>(y);
            schar* v = votes.ptr<schar>(y);
            if (p_.neutral_highlights) {
                for (int x = 0; x < votes.cols; ++x)
                    v[x] = c[x] ? 1 : (u[x] ? 0 : -1);
            } else {
                for (int x = 0; x < votes.cols; ++x)
                    v[x] = c[x] ? 1 : -1;
            }
        }
        fitter_.setVotes(votes);
    }

    // Tracks inside window @p w from the prediction @p pred.
    Result track(const Mat& frame, const Rect& w, const Disk& pred, bool use_prediction) {
        classify(frame, w);
        clean(w, pred.radius);
        makeVotes(w);
        const Point2f off((float)w.x, (float)w.y);
        DiskFitParams fp;
        fp.min_step = p_.min_step;
        if (p_.max_radius_change > 0 && p_.evidence_confidence) {
            const int gap = lost_run_ + 1;
            fp.min_radius =
                std::max(2.f, prev_.radius * std::pow(1 - p_.max_radius_change, (float)gap));
            fp.max_radius = prev_.radius * std::pow(1 + p_.max_radius_change, (float)gap);
        }
        Disk best;
        double best_q = -1e300;
        // Start from the thesis's median initialisation and from the predicted disk; keep the
        // better fit (the prediction keeps a fast ball from being lost to a nearby blob).
        const Disk starts[2] = {fitter_.initial(), Disk(pred.center - off, pred.radius)};
        for (const Disk& s : starts) {
            if (s.radius <= 0) continue;
            const Disk d = fitter_.fit(s, fp);
            const double q = fitter_.quality(d);
            if (q > best_q) {
                best_q = q;
                best = d;
            }
        }
        Result r;
        if (best.radius > 0) {
            r.disk = Disk(best.center + off, best.radius);
            if (edge_on_) r.disk = refineOnEdges(frame, r.disk, pred.radius, fp);
            score(frame, w, r, use_prediction ? &pred : nullptr);
        }
        r.found = r.confidence >= p_.lost_threshold && best.radius > 0;
        return r;
    }

    // Whole-frame search: every blob of object colour of a plausible size is fitted with a disk
    // and scored without the motion model; the best one above redetect_threshold wins.
    Result redetect(const Mat& frame) {
        const Rect full(0, 0, size_.width, size_.height);
        // The expected radius: that of the last confident disk. Not extrapolated: the disks
        // found while the ball was disappearing behind something shrink faster than the ball.
        const float r_ref = r_good_;
        classify(frame, full);
        clean(full, r_ref);
        makeVotes(full);
        Mat labels, stats, centroids;
        const int n = connectedComponentsWithStats(cleaned_, labels, stats, centroids, 8, CV_32S);
        std::vector<std::pair<int, int>> blobs;  // (area, label)
        const double amin = CV_PI * 0.09 * r_ref * r_ref, amax = CV_PI * 9.0 * r_ref * r_ref;
        for (int i = 1; i < n; ++i) {
            const int a = stats.at<int>(i, CC_STAT_AREA);
            if (a >= amin && a <= amax) blobs.emplace_back(a, i);
        }
        std::sort(blobs.rbegin(), blobs.rend());
        if (blobs.size() > 8) blobs.resize(8);
        Result best;
        DiskFitParams fp;
        fp.min_step = p_.min_step;
        fp.min_radius = std::max(2.f, 0.3f * r_ref);
        fp.max_radius = 3.f * r_ref;
        for (const auto& b : blobs) {
            const Point2f c((float)centroids.at<double>(b.second, 0),
                            (float)centroids.at<double>(b.second, 1));
            const float rad = std::sqrt(b.first / (float)CV_PI);
            Result r;
            r.disk = fitter_.fit(Disk(c, rad), fp);
            // The ball may have changed size while lost: the silhouette is bounded by the
            // radius the motion model predicts.
            if (edge_on_) r.disk = refineOnEdges(frame, r.disk, r_ref, fp, 0.6f, 1.5f);
            score(frame, full, r, nullptr);
            // Consistency with the last good disk carried on by the motion model, loosely (the
            // ball may have changed course while hidden): size, and position within a spread
            // growing with the frames lost.
            const int gap = lost_run_ + 1;
            const Point2f expect = prev_.center + vel_ * (float)gap;
            const float spread = 2.f * r_ref + 0.5f * (float)norm(vel_) * gap + 4.f * gap;
            const float e = std::log(r.disk.radius / r_ref) / 0.5f,
                        ep = (float)norm(r.disk.center - expect) / spread;
            r.motion = std::exp(-0.5f * (e * e + ep * ep));
            if (p_.evidence_confidence)
                r.confidence = std::cbrt(r.fill * r.surround * r.rim) * (0.5f + 0.5f * r.motion);
            if (r.confidence > best.confidence) best = r;
        }
        window_ = full;
        best.redetected = true;
        best.found = best.disk.radius > 0 && best.confidence >= p_.redetect_threshold &&
                     best.confidence >= p_.lost_threshold;
        return best;
    }

    // Rim candidates: along K rays from the disk's centre, the local maxima of the colour edge
    // strength (L1 of the summed-BGR difference across 2 pixels) between lo and hi times the
    // radius, the strongest kRimCands of them down to a third of the ray's strongest. Several
    // per ray: beside a ball, a darker object (a box's edge, the shadow's far side) can give a
    // stronger edge than the ball's own silhouette, and the consensus below picks between them.
    static constexpr int kRimRays = 48, kRimCands = 3;
    struct RimCand {
        Point2f p;
        float strength = 0;
    };
    void rimCandidates(const Mat& frame, const Disk& d, float lo, float hi,
                       std::vector<RimCand>& cands, std::vector<int>& count) const {
        cands.assign(kRimRays * kRimCands, RimCand());
        count.assign(kRimRays, 0);
        const int s0 = std::max(1, (int)std::floor(lo * d.radius)),
                  s1 = std::max(s0 + 2, (int)std::ceil(hi * d.radius));
        float prof[512], grad[512];
        if (s1 + 3 > 512) return;
        for (int k = 0; k < kRimRays; ++k) {
            const float ca = rim_cos_[k], sa = rim_sin_[k];
            bool inside = true;
            for (int s = s0 - 1; s <= s1 + 1; ++s) {
                // Summed channels, bilinear between the four nearest pixels.
                const float fx = d.center.x + s * ca, fy = d.center.y + s * sa;
                const int x = (int)std::floor(fx), y = (int)std::floor(fy);
                if (x < 0 || y < 0 || x + 1 >= size_.width || y + 1 >= size_.height) {
                    inside = false;
                    break;
                }
                const float ax = fx - x, ay = fy - y;
                const uchar* c0 = frame.ptr<uchar>(y) + 3 * x;
                const uchar* c1 = frame.ptr<uchar>(y + 1) + 3 * x;
                const float t =
                    (1 - ax) * float(c0[0] + c0[1] + c0[2]) + ax * float(c0[3] + c0[4] + c0[5]);
                const float b =
                    (1 - ax) * float(c1[0] + c1[1] + c1[2]) + ax * float(c1[3] + c1[4] + c1[5]);
                prof[s - s0 + 1] = (1 - ay) * t + ay * b;
            }
            if (!inside) continue;
            float gmax = 0;
            for (int i = 1; i <= s1 - s0 + 1; ++i) {
                grad[i] = std::abs(prof[i + 1] - prof[i - 1]);
                gmax = std::max(gmax, grad[i]);
            }
            if (gmax <= 0) continue;
            RimCand* out = &cands[k * kRimCands];
            int& n = count[k];
            const int last = s1 - s0 + 1;
            for (int i = 1; i <= last; ++i) {
                const float g = grad[i];
                if (g < gmax / 3) continue;
                if ((i > 1 && g < grad[i - 1]) || (i < last && g < grad[i + 1])) continue;
                // Keep the kRimCands strongest peaks, ordered by strength.
                int j = n < kRimCands ? n++ : kRimCands - 1;
                if (j == kRimCands - 1 && n == kRimCands && out[j].strength >= g) continue;
                while (j > 0 && out[j - 1].strength < g) {
                    out[j] = out[j - 1];
                    --j;
                }
                // Sub-sample peak: the vertex of the parabola through the peak and its
                // neighbours.
                float off = 0;
                if (i > 1 && i < last) {
                    const float l = grad[i - 1], r = grad[i + 1], den = l - 2 * g + r;
                    if (den < 0) off = std::max(-0.5f, std::min(0.5f, 0.5f * (l - r) / den));
                }
                const float s = float(i - 1 + s0) + off;
                out[j].p = Point2f(d.center.x + s * ca, d.center.y + s * sa);
                out[j].strength = g;
            }
        }
    }

    // The disk moved onto the ball's silhouette: a consensus circle through the rim candidates
    // (circles through three candidates of three rays, the one that most rays agree with),
    // then a least-squares circle (Kåsa's algebraic fit) through each agreeing ray's nearest
    // candidate, twice. Kept only if most rays agree and the radius stays in bounds.
    Disk refineOnEdges(const Mat& frame, const Disk& start, float r_pred, const DiskFitParams& fp,
                       float r_lo = 0.7f, float r_hi = 1.4f) const {
        (void)fp;  // the colour fit's radius bounds may have dragged it down with a shaded side
                   // the colours miss: the silhouette is bounded by the prediction instead
        const int K = kRimRays;
        Disk probe = start;
        probe.radius = std::max(start.radius, r_pred);
        std::vector<RimCand>& cands = rim_cands_;
        std::vector<int>& count = rim_count_;
        rimCandidates(frame, probe, 0.5f, 1.6f, cands, count);
        int rays = 0;
        for (int k = 0; k < K; ++k)
            rays += count[k] > 0;
        if (rays < K / 2) return start;
        const float rmin = r_lo * r_pred, rmax = r_hi * r_pred;
        const float max_shift = std::max(start.radius, r_pred);
        auto tolOf = [](float r) { return 1.5f + 0.08f * r; };
        // Rays agreeing with circle c (a candidate within the tolerance), or -1 if c is out of
        // bounds.
        auto agree = [&](const Disk& c) {
            if (!(c.radius >= rmin && c.radius <= rmax)) return -1;
            if (norm(c.center - start.center) > max_shift) return -1;
            const float tol = tolOf(c.radius);
            int n = 0;
            for (int k = 0; k < K; ++k)
                for (int j = 0; j < count[k]; ++j) {
                    const RimCand& q = cands[k * kRimCands + j];
                    if (std::abs((float)norm(q.p - c.center) - c.radius) <= tol) {
                        ++n;
                        break;
                    }
                }
            return n;
        };
        // Hypotheses: the rays' strongest candidates on three rays a third of a turn apart
        // (every rotation), and random triples of candidates (fixed seed: deterministic).
        Disk best;
        int best_n = -1;
        auto tryTriple = [&](const Point2f& a, const Point2f& b, const Point2f& c) {
            const double ax = a.x, ay = a.y, bx = b.x, by = b.y, cx = c.x, cy = c.y;
            const double dd = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
            if (std::abs(dd) < 1e-6) return;
            const double a2 = ax * ax + ay * ay, b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
            const double ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / dd;
            const double uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / dd;
            const Disk h(Point2f((float)ux, (float)uy),
                         (float)std::sqrt((ax - ux) * (ax - ux) + (ay - uy) * (ay - uy)));
            const int n = agree(h);
            if (n > best_n) {
                best_n = n;
                best = h;
            }
        };
        for (int k = 0; k < K / 3; ++k) {
            const int a = k, b = k + K / 3, c = k + 2 * K / 3;
            if (count[a] && count[b] && count[c])
                tryTriple(cands[a * kRimCands].p, cands[b * kRimCands].p, cands[c * kRimCands].p);
        }
        RNG rng(0x5eed);
        for (int it = 0; it < 120; ++it) {
            int ks[3], found = 0;
            for (int tries = 0; tries < 12 && found < 3; ++tries) {
                const int k = rng.uniform(0, K);
                bool dup = count[k] == 0;
                for (int j = 0; j < found; ++j)
                    dup = dup || std::abs(ks[j] - k) < 4 || std::abs(ks[j] - k) > K - 4;
                if (!dup) ks[found++] = k;
            }
            if (found < 3) continue;
            tryTriple(cands[ks[0] * kRimCands + rng.uniform(0, count[ks[0]])].p,
                      cands[ks[1] * kRimCands + rng.uniform(0, count[ks[1]])].p,
                      cands[ks[2] * kRimCands + rng.uniform(0, count[ks[2]])].p);
        }
        if (best_n < K / 2) return start;
        // Least squares: the strongest edge of every ray near the consensus circle (between
        // 0.8 and 1.2 times its radius; edges below a third of the median strength do not
        // vote), weighted by its strength (a motion-blurred side has a weak, broad edge whose
        // peak noise moves; the sharp sides hold the circle), points farther than the
        // tolerance from the fit dropped, three times.
        Disk c = best;
        const Disk near = c;
        rimCandidates(frame, near, 0.8f, 1.2f, cands, count);
        std::vector<float> str;
        for (int k = 0; k < K; ++k)
            if (count[k]) str.push_back(cands[k * kRimCands].strength);
        if ((int)str.size() < K / 2) return start;
        std::nth_element(str.begin(), str.begin() + str.size() / 2, str.end());
        const float weak = str[str.size() / 2] / 3;
        bool use[kRimRays];
        for (int k = 0; k < K; ++k)
            use[k] = count[k] && cands[k * kRimCands].strength >= weak;
        for (int it = 0; it < 3; ++it) {
            Matx33d A = Matx33d::zeros();
            Vec3d bb(0, 0, 0);
            int n = 0;
            for (int k = 0; k < K; ++k) {
                if (!use[k]) continue;
                // Kåsa: minimise Σ (x² + y² + D x + E y + F)², centred for conditioning.
                const Point2f& q = cands[k * kRimCands].p;
                const double x = q.x - near.center.x, y = q.y - near.center.y;
                const Vec3d row(x, y, 1);
                const double wgt = cands[k * kRimCands].strength;
                A += row * row.t() * wgt;
                bb += row * (-(x * x + y * y)) * wgt;
                ++n;
            }
            if (n < K / 3) return start;
            Vec3d sol;
            if (!solve(Mat(A), Mat(bb), sol, DECOMP_SVD)) return start;
            const double cx = -sol[0] / 2, cy = -sol[1] / 2;
            const double r2 = cx * cx + cy * cy - sol[2];
            if (!(r2 > 0)) return start;
            c = Disk(Point2f(float(cx + near.center.x), float(cy + near.center.y)),
                     (float)std::sqrt(r2));
            const float tol = tolOf(c.radius);
            for (int k = 0; k < K; ++k)
                use[k] = count[k] && cands[k * kRimCands].strength >= weak &&
                         std::abs((float)norm(cands[k * kRimCands].p - c.center) - c.radius) <= tol;
        }
        if (!(c.radius >= rmin && c.radius <= rmax)) return start;
        if (norm(c.center - start.center) > max_shift) return start;
        return c;
    }

    // Median colour contrast across the rim (BGR L1 / 3) between 0.7 r and 1.35 r.
    void rimContrast(const Mat& frame, const Disk& d, float* out) const {
        const int K = 32;
        for (int k = 0; k < K; ++k) {
            const float a = float(2 * CV_PI * k / K), ca = std::cos(a), sa = std::sin(a);
            auto px = [&](float s) {
                const int x =
                    std::min(size_.width - 1, std::max(0, cvRound(d.center.x + s * d.radius * ca)));
                const int y = std::min(size_.height - 1,
                                       std::max(0, cvRound(d.center.y + s * d.radius * sa)));
                return frame.ptr<Vec3b>(y)[x];
            };
            const Vec3b i = px(0.7f), o = px(1.35f);
            out[k] = (std::abs(i[0] - o[0]) + std::abs(i[1] - o[1]) + std::abs(i[2] - o[2])) / 3.f;
        }
    }
    // Fraction of the 32 rim directions whose contrast reaches 35 % of frame 0's median.
    float rimSupport(const Mat& frame, const Disk& d) const {
        float c[32];
        rimContrast(frame, d, c);
        const float need = std::max(6.f, 0.35f * rim_ref_);
        int edges = 0;
        for (float v : c)
            edges += v >= need;
        return edges / 32.f;
    }
    float rimContrastMedian(const Mat& frame, const Disk& d) const {
        float c[32];
        rimContrast(frame, d, c);
        std::nth_element(c, c + 16, c + 32);
        return c[16];
    }

    // Evidence for disk r.disk (frame coordinates): colour fill inside, background around,
    // rim edges, agreement with the prediction.
    void score(const Mat& frame, const Rect& w, Result& r, const Disk* pred) const {
        const Disk d = r.disk;
        int in = 0, in_obj = 0, ring = 0, ring_obj = 0;
        const float r_in2 = d.radius * d.radius, r_a = 1.2f * d.radius, r_b = 1.6f * d.radius;
        const int y0 = std::max(w.y, (int)std::ceil(d.center.y - r_b));
        const int y1 = std::min(w.y + w.height - 1, (int)std::floor(d.center.y + r_b));
        const int x0 = std::max(w.x, (int)std::ceil(d.center.x - r_b));
        const int x1 = std::min(w.x + w.width - 1, (int)std::floor(d.center.x + r_b));
        for (int y = y0; y <= y1; ++y) {
            const uchar* c = cleaned_.ptr<uchar>(y);
            const uchar* u = unknown_.ptr<uchar>(y);
            const float dy = y - d.center.y;
            for (int x = x0; x <= x1; ++x) {
                const float dx = x - d.center.x, q = dx * dx + dy * dy;
                if (q <= r_in2) {
                    if (c[x])
                        ++in_obj, ++in;
                    else if (!u[x])
                        ++in;
                } else if (q >= r_a * r_a && q <= r_b * r_b && !u[x]) {
                    ++ring;
                    if (c[x]) ++ring_obj;
                }
            }
        }
        if (!p_.evidence_confidence) {
            // The thesis-era confidence: IoU of the disk with the cleaned object pixels.
            int disk_px = 0, inter = 0, unk_in = 0;
            for (int y = y0; y <= y1; ++y) {
                const uchar* c = cleaned_.ptr<uchar>(y);
                const uchar* u = unknown_.ptr<uchar>(y);
                const float dy = y - d.center.y;
                for (int x = x0; x <= x1; ++x) {
                    const float dx = x - d.center.x;
                    if (dx * dx + dy * dy > r_in2) continue;
                    ++disk_px;
                    if (c[x])
                        ++inter;
                    else if (u[x])
                        ++unk_in;
                }
            }
            const int fg_total = countNonZero(cleaned_(w));
            const int uni = (disk_px - unk_in) + fg_total - inter;
            r.confidence = uni > 0 ? float(inter) / uni : 0.f;
            r.fill = in > 0 ? float(in_obj) / in : 0.f;
            r.surround = ring > 0 ? 1.f - float(ring_obj) / ring : 1.f;
            r.rim = 1.f;
            r.motion = 1.f;
            return;
        }
        r.fill = std::min(1.f, (in > 0 ? float(in_obj) / in : 0.f) / fill_ref_);
        r.surround = std::min(1.f, (ring > 0 ? 1.f - float(ring_obj) / ring : 1.f) / surround_ref_);
        r.rim = rimSupport(frame, d);
        r.motion = 1.f;
        if (pred && have_velocity_) {
            const float s = 0.5f * pred->radius + 2.f + 0.5f * (float)norm(vel_);
            const float ep = (float)norm(d.center - pred->center) / s;
            const float er =
                std::log(std::max(1e-3f, d.radius) / std::max(1e-3f, pred->radius)) / 0.25f;
            r.motion = std::exp(-0.5f * (ep * ep + er * er));
        }
        r.confidence = std::cbrt(r.fill * r.surround * r.rim) * (0.5f + 0.5f * r.motion);
    }

    // Slow model update: blend histograms of the current object (disk shrunk by 15 %) and of
    // its surroundings in the window (outside the disk grown by 15 %).
    void updateModel(const Mat& frame, const Disk& d) {
        const Mat unk = unknown_(window_);
        Mat inside(window_.size(), CV_8UC1, Scalar(0)),
            outside(window_.size(), CV_8UC1, Scalar(255));
        circle(inside, Point(cvRound(d.center.x), cvRound(d.center.y)), cvRound(d.radius * 0.85f),
               Scalar(255), FILLED);
        circle(outside, Point(cvRound(d.center.x), cvRound(d.center.y)), cvRound(d.radius * 1.15f),
               Scalar(0), FILLED);
        if (p_.neutral_highlights) {
            inside.setTo(0, unk);
            outside.setTo(0, unk);
        }
        const float a = p_.model_update_rate;
        if (model_ != TRACK_COLOUR_HS) {
            const Mat img = frame(window_);
            const std::vector<float> hf = histogram(img, inside), hb = histogram(img, outside);
            for (int i = 0; i < nbins_; ++i) {
                if (!hf.empty()) hfg_[i] = (1 - a) * hfg_[i] + a * hf[i];
                if (!hb.empty()) hbg_[i] = (1 - a) * hbg_[i] + a * hb[i];
            }
            rebuildLut();
            return;
        }
        const Mat hsv = hsv_(window_);
        Mat hf, hb;
        hueSatHistogram(hsv, inside, hf, p_.h_bins, p_.s_bins);
        hueSatHistogram(hsv, outside, hb, p_.h_bins, p_.s_bins);
        if (countNonZero(hf)) addWeighted(hist_fg_, 1 - a, hf, a, 0, hist_fg_);
        if (countNonZero(hb)) addWeighted(hist_bg_, 1 - a, hb, a, 0, hist_bg_);
        double mf = 0, mb = 0;
        minMaxLoc(hist_fg_, nullptr, &mf);
        minMaxLoc(hist_bg_, nullptr, &mb);
        if (mf > 0) hist_fg_ *= 1.0 / mf;
        if (mb > 0) hist_bg_ *= 1.0 / mb;
        rebuildTable();
    }

    Params p_;
    Size size_;
    bool initialised_ = false;
    int model_ = TRACK_COLOUR_HS;
    double init_iou_ = 0;
    std::string report_;
    // Thesis HS model.
    Mat hist_fg_, hist_bg_, ratio_, table_;
    // Joint colour models: cell → bin, bin histograms, cell → 255·f.
    int nbins_ = 0, thr8_ = 127;
    float ring_weight_ = 0.5f;  // share of the ring in the background model
    std::vector<int> bins_;
    std::vector<float> hfg_, hbg_;
    std::vector<uchar> lut_;
    std::map<int, Mat> elements_;
    Mat hsv_, fg_, unknown_, cleaned_, votes_, padded_;  // full-frame buffers; the window is a view
    detail::DiskFitter fitter_;
    Disk prev_;
    Point2f vel_;
    float r_good_ = 0;  // radius of the last disk found with kGoodConfidence
    float dr_ = 0, rim_ref_ = 0, fill_ref_ = 1, surround_ref_ = 1;
    bool have_velocity_ = false, have_prev_found_ = false, edge_on_ = false;
    int lost_run_ = 0;
    Rect window_;
    float rim_cos_[kRimRays], rim_sin_[kRimRays];
    mutable std::vector<RimCand> rim_cands_;
    mutable std::vector<int> rim_count_;
};

}  // namespace

Ptr<ObjectTracker> ObjectTracker::create(const Params& params) {
    params.check();
    return makePtr<ObjectTrackerImpl>(params);
}

}  // namespace vbme
}  // namespace cv
