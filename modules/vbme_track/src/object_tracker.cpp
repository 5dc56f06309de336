// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/track/object_tracker.hpp"

#include <cmath>
#include <type_traits>

#include <opencv2/imgproc.hpp>

#include "disk_fitter.hpp"

namespace cv {
namespace vbme {

ObjectTracker::Params::Params() = default;

void ObjectTracker::Params::read(const FileNode& fn) {
    if (!fn.isMap() && !fn.empty() && !fn.isNone())
        CV_Error(Error::StsParseError, "tracker parameters: expected a map of name: value");
    auto rd = [&](const char* key, auto& v) {
        using T = std::decay_t<decltype(v)>;
        const FileNode n = fn[key];
        if (!n.empty()) {
            if (!n.isInt() && !n.isReal())
                CV_Error(Error::StsParseError,
                         std::string("tracker parameter '") + key + "': expected a number");
            const double d = (double)n;
            // the conversion itself must be defined: finite and within the type's range
            const double lo = std::is_same<T, bool>::value ? 0 : -1e9,
                         hi = std::is_same<T, bool>::value ? 1 : 1e9;
            if (!(d >= lo && d <= hi))
                CV_Error(
                    Error::StsParseError,
                    format("tracker parameter '%s': %g is out of range [%g, %g]", key, d, lo, hi));
            v = static_cast<T>(d);
        }
    };
    rd("h_bins", h_bins);
    rd("s_bins", s_bins);
    rd("threshold", threshold);
    rd("open_size", open_size);
    rd("close_size", close_size);
    rd("fill_holes", fill_holes);
    rd("use_search_window", use_search_window);
    rd("window_scale", window_scale);
    rd("window_margin", window_margin);
    rd("neutral_highlights", neutral_highlights);
    rd("highlight_min_value", highlight_min_value);
    rd("highlight_max_saturation", highlight_max_saturation);
    rd("lost_threshold", lost_threshold);
    rd("model_update_rate", model_update_rate);
    rd("min_update_confidence", min_update_confidence);
    rd("min_step", min_step);
    validate();
}

void ObjectTracker::Params::validate() const {
    if (h_bins < 1 || h_bins > 180) CV_Error(Error::StsBadArg, "h_bins: expected 1..180");
    if (s_bins < 1 || s_bins > 256) CV_Error(Error::StsBadArg, "s_bins: expected 1..256");
    if (!(threshold >= 0 && threshold < 1))
        CV_Error(Error::StsBadArg, "threshold: expected [0, 1)");
    if (open_size < 0 || open_size > 255) CV_Error(Error::StsBadArg, "open_size: expected 0..255");
    if (close_size < 0 || close_size > 255)
        CV_Error(Error::StsBadArg, "close_size: expected 0..255");
    if (!(window_scale > 0 && window_scale <= 100))
        CV_Error(Error::StsBadArg, "window_scale: expected (0, 100]");
    if (window_margin < 0 || window_margin > 100000)
        CV_Error(Error::StsBadArg, "window_margin: expected 0..100000 pixels");
    if (highlight_min_value < 0 || highlight_min_value > 256)
        CV_Error(Error::StsBadArg, "highlight_min_value: expected 0..256");
    if (highlight_max_saturation < -1 || highlight_max_saturation > 255)
        CV_Error(Error::StsBadArg, "highlight_max_saturation: expected -1..255");
    if (!(lost_threshold >= 0 && lost_threshold <= 1))
        CV_Error(Error::StsBadArg, "lost_threshold: expected [0, 1]");
    if (!(model_update_rate >= 0 && model_update_rate <= 1))
        CV_Error(Error::StsBadArg, "model_update_rate: expected [0, 1]");
    if (!(min_update_confidence >= 0 && min_update_confidence <= 1))
        CV_Error(Error::StsBadArg, "min_update_confidence: expected [0, 1]");
    if (!(min_step > 0 && min_step <= 1)) CV_Error(Error::StsBadArg, "min_step: expected (0, 1]");
}

ObjectTracker::Params readTrackerParamsFile(const std::string& path) {
    FileStorage fs;
    try {
        fs.open(path, FileStorage::READ);
    } catch (const cv::Exception& e) {
        CV_Error(Error::StsParseError, path + ": not a readable YAML/JSON file: " + e.err);
    } catch (const std::exception& e) {  // OpenCV's parsers may throw std::length_error
        CV_Error(Error::StsParseError,
                 path + ": not a readable YAML/JSON file: " + std::string(e.what()));
    }
    if (!fs.isOpened()) CV_Error(Error::StsError, path + ": cannot open the tracker parameters");
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
}

ObjectTracker::~ObjectTracker() = default;

namespace {

// A pixel whose colour cannot be trusted: a specular highlight (bright, unsaturated) or a
// clipped pixel (a channel at the top of the range).
inline bool unreliablePixel(const Vec3b& bgr, const Vec3b& hsv, const ObjectTracker::Params& p) {
    const bool spec = hsv[2] >= p.highlight_min_value && hsv[1] <= p.highlight_max_saturation;
    const bool clip = bgr[0] >= 254 || bgr[1] >= 254 || bgr[2] >= 254;
    return spec || clip;
}

class ObjectTrackerImpl final : public ObjectTracker {
public:
    explicit ObjectTrackerImpl(const Params& p) : p_(p) {
        open_el_ = getStructuringElement(MORPH_ELLIPSE,
                                         Size(std::max(1, p.open_size), std::max(1, p.open_size)));
        close_el_ = getStructuringElement(
            MORPH_ELLIPSE, Size(std::max(1, p.close_size), std::max(1, p.close_size)));
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
        size_ = frame.size();
        hsv_.create(size_, CV_8UC3);
        fg_.create(size_, CV_8UC1);
        unknown_.create(size_, CV_8UC1);
        cleaned_.create(size_, CV_8UC1);
        votes_.create(size_, CV_8SC1);
        cvtColor(frame, hsv_, COLOR_BGR2HSV);
        unreliable(frame, hsv_, unknown_);
        Mat fg_px = m.clone(), bg_px = ~m;
        if (p_.neutral_highlights) {
            fg_px.setTo(0, unknown_);
            bg_px.setTo(0, unknown_);
        }
        hueSatHistogram(hsv_, fg_px, hist_fg_, p_.h_bins, p_.s_bins);
        hueSatHistogram(hsv_, bg_px, hist_bg_, p_.h_bins, p_.s_bins);
        rebuildTable();
        prev_ = fitDisk(m);
        lost_run_ = 0;
        initialised_ = true;
    }

    Result update(InputArray _frame, OutputArray _mask) override {
        if (!initialised_) CV_Error(Error::StsError, "update: call init() first");
        Mat frame = _frame.getMat();
        if (frame.size() != size_ || frame.type() != CV_8UC3)
            CV_Error(Error::StsBadArg, format("update: expected an 8-bit BGR frame of %dx%d",
                                              size_.width, size_.height));

        window_ = searchWindow();
        Mat img = frame(window_), hsv = hsv_(window_), fg = fg_(window_), unk = unknown_(window_);
        Mat cleaned = cleaned_(window_), votes = votes_(window_);
        cvtColor(img, hsv, COLOR_BGR2HSV);
        classify(img, hsv, fg, unk);

        // Clean-up: opening, closing, hole filling (thesis §4.1).
        // The window is a view into full-frame buffers: BORDER_ISOLATED keeps the filters from
        // reading the (stale) pixels around it.
        const int border = BORDER_CONSTANT | BORDER_ISOLATED;
        if (p_.open_size > 1)
            morphologyEx(fg, cleaned, MORPH_OPEN, open_el_, Point(-1, -1), 1, border,
                         morphologyDefaultBorderValue());
        else
            fg.copyTo(cleaned);
        if (p_.close_size > 1)
            morphologyEx(cleaned, cleaned, MORPH_CLOSE, close_el_, Point(-1, -1), 1, border,
                         morphologyDefaultBorderValue());
        if (p_.fill_holes) fillHoles(cleaned, cleaned);

        // Votes: object +1, background −1, unreliable colour 0 (when enabled).
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

        Result r;
        const Point2f off((float)window_.x, (float)window_.y);
        DiskFitParams fp;
        fp.min_step = p_.min_step;
        Disk best;
        double best_q = -1e300;
        // Start from the thesis's median initialisation and from the previous disk; keep the
        // better fit (the previous disk keeps a fast ball from being lost to a nearby blob).
        const Disk starts[2] = {fitter_.initial(), Disk(prev_.center - off, prev_.radius)};
        for (const Disk& s : starts) {
            if (s.radius <= 0) continue;
            const Disk d = fitter_.fit(s, fp);
            const double q = fitter_.quality(d);
            if (q > best_q) {
                best_q = q;
                best = d;
            }
        }
        const int fg_total = countNonZero(cleaned);
        r.confidence = (best.radius > 0 && fg_total > 0) ? confidence(best, cleaned, unk) : 0.f;
        r.found = r.confidence >= p_.lost_threshold;
        if (r.found) {
            r.disk = Disk(best.center + off, best.radius);
            prev_ = r.disk;
            lost_run_ = 0;
            if (p_.model_update_rate > 0 && r.confidence >= p_.min_update_confidence)
                updateModel(best);
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
    Mat ratioTable() const override { return ratio_.clone(); }
    const Params& params() const override { return p_; }

private:
    Rect searchWindow() const {
        const Rect full(0, 0, size_.width, size_.height);
        if (!p_.use_search_window || prev_.radius <= 0) return full;
        // Each lost frame doubles the window, so a ball that left it is found again.
        const float grow = std::pow(2.f, (float)std::min(lost_run_, 8));
        const float half = (p_.window_scale * prev_.radius + p_.window_margin) * grow;
        Rect w((int)std::floor(prev_.center.x - half), (int)std::floor(prev_.center.y - half),
               (int)std::ceil(2 * half) + 1, (int)std::ceil(2 * half) + 1);
        w &= full;
        return w.area() > 0 ? w : full;
    }

    void unreliable(const Mat& bgr, const Mat& hsv, Mat& out) const {
        for (int y = 0; y < bgr.rows; ++y) {
            const Vec3b* c = bgr.ptr<Vec3b>(y);
            const Vec3b* h = hsv.ptr<Vec3b>(y);
            uchar* o = out.ptr<uchar>(y);
            for (int x = 0; x < bgr.cols; ++x)
                o[x] = unreliablePixel(c[x], h[x], p_) ? 255 : 0;
        }
    }

    void classify(const Mat& bgr, const Mat& hsv, Mat& fg, Mat& unk) const {
        const uchar* table = table_.ptr<uchar>();
        for (int y = 0; y < hsv.rows; ++y) {
            const Vec3b* c = bgr.ptr<Vec3b>(y);
            const Vec3b* h = hsv.ptr<Vec3b>(y);
            uchar* f = fg.ptr<uchar>(y);
            uchar* u = unk.ptr<uchar>(y);
            for (int x = 0; x < hsv.cols; ++x) {
                f[x] = table[h[x][0] * 256 + h[x][1]];
                u[x] = (p_.neutral_highlights && unreliablePixel(c[x], h[x], p_)) ? 255 : 0;
            }
        }
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

    // IoU of the disk with the cleaned object pixels of the window; unreliable pixels inside
    // the disk count neither way.
    float confidence(const Disk& d, const Mat& cleaned, const Mat& unk) const {
        int inter = 0, disk_px = 0, unk_in = 0;
        const int y0 = std::max(0, (int)std::ceil(d.center.y - d.radius));
        const int y1 = std::min(cleaned.rows - 1, (int)std::floor(d.center.y + d.radius));
        for (int y = y0; y <= y1; ++y) {
            const float dy = y - d.center.y, w2 = d.radius * d.radius - dy * dy;
            if (w2 < 0) continue;
            const float w = std::sqrt(w2);
            const int x0 = std::max(0, (int)std::ceil(d.center.x - w));
            const int x1 = std::min(cleaned.cols - 1, (int)std::floor(d.center.x + w));
            const uchar* c = cleaned.ptr<uchar>(y);
            const uchar* u = unk.ptr<uchar>(y);
            for (int x = x0; x <= x1; ++x) {
                ++disk_px;
                if (c[x])
                    ++inter;
                else if (u[x])
                    ++unk_in;
            }
        }
        const int fg_total = countNonZero(cleaned);
        const int uni = (disk_px - unk_in) + fg_total - inter;
        return uni > 0 ? float(inter) / uni : 0.f;
    }

    // Slow model update: blend histograms of the current object (disk shrunk by 15 %) and of
    // its surroundings in the window (outside the disk grown by 15 %).
    void updateModel(const Disk& d) {
        const Mat hsv = hsv_(window_), unk = unknown_(window_);
        Mat inside(hsv.size(), CV_8UC1, Scalar(0)), outside(hsv.size(), CV_8UC1, Scalar(255));
        circle(inside, Point(cvRound(d.center.x), cvRound(d.center.y)), cvRound(d.radius * 0.85f),
               Scalar(255), FILLED);
        circle(outside, Point(cvRound(d.center.x), cvRound(d.center.y)), cvRound(d.radius * 1.15f),
               Scalar(0), FILLED);
        if (p_.neutral_highlights) {
            inside.setTo(0, unk);
            outside.setTo(0, unk);
        }
        Mat hf, hb;
        hueSatHistogram(hsv, inside, hf, p_.h_bins, p_.s_bins);
        hueSatHistogram(hsv, outside, hb, p_.h_bins, p_.s_bins);
        const float a = p_.model_update_rate;
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
    Mat hist_fg_, hist_bg_, ratio_, table_;
    Mat open_el_, close_el_;
    Mat hsv_, fg_, unknown_, cleaned_, votes_;  // full-frame buffers; the window is a view
    detail::DiskFitter fitter_;
    Disk prev_;
    int lost_run_ = 0;
    Rect window_;
};

}  // namespace

Ptr<ObjectTracker> ObjectTracker::create(const Params& params) {
    params.validate();
    return makePtr<ObjectTrackerImpl>(params);
}

}  // namespace vbme
}  // namespace cv
