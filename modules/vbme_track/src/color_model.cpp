// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The stages of the colour tracker: histograms, ratio, back-projection, morphology, holes.
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/track/object_tracker.hpp"

namespace cv {
namespace vbme {

void hueSatHistogram(InputArray _hsv, InputArray _mask, OutputArray _hist, int h_bins, int s_bins) {
    Mat hsv = _hsv.getMat(), mask = _mask.getMat();
    CV_Assert(hsv.type() == CV_8UC3);
    CV_Assert(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == hsv.size()));
    CV_Assert(h_bins > 0 && h_bins <= 180 && s_bins > 0 && s_bins <= 256);
    _hist.create(h_bins, s_bins, CV_32F);
    Mat hist = _hist.getMat();
    hist.setTo(Scalar::all(0));
    for (int y = 0; y < hsv.rows; ++y) {
        const Vec3b* p = hsv.ptr<Vec3b>(y);
        const uchar* m = mask.empty() ? nullptr : mask.ptr<uchar>(y);
        for (int x = 0; x < hsv.cols; ++x) {
            if (m && !m[x]) continue;
            const int hb = std::min(h_bins - 1, p[x][0] * h_bins / 180);
            const int sb = p[x][1] * s_bins / 256;
            hist.at<float>(hb, sb) += 1.f;
        }
    }
    double mx = 0;
    minMaxLoc(hist, nullptr, &mx);
    if (mx > 0) hist *= 1.0 / mx;
}

void foregroundRatio(InputArray _fg, InputArray _bg, OutputArray _ratio) {
    Mat fg = _fg.getMat(), bg = _bg.getMat();
    CV_Assert(fg.type() == CV_32F && bg.type() == CV_32F && fg.size() == bg.size());
    _ratio.create(fg.size(), CV_32F);
    Mat ratio = _ratio.getMat();
    for (int y = 0; y < fg.rows; ++y)
        for (int x = 0; x < fg.cols; ++x) {
            const float a = fg.at<float>(y, x), b = bg.at<float>(y, x);
            ratio.at<float>(y, x) = a + b > 0 ? a / (a + b) : 0.f;
        }
}

void backProjectRatio(InputArray _hsv, InputArray _ratio, OutputArray _prob) {
    Mat hsv = _hsv.getMat(), ratio = _ratio.getMat();
    CV_Assert(hsv.type() == CV_8UC3 && ratio.type() == CV_32F);
    const int h_bins = ratio.rows, s_bins = ratio.cols;
    _prob.create(hsv.size(), CV_32F);
    Mat prob = _prob.getMat();
    for (int y = 0; y < hsv.rows; ++y) {
        const Vec3b* p = hsv.ptr<Vec3b>(y);
        float* o = prob.ptr<float>(y);
        for (int x = 0; x < hsv.cols; ++x)
            o[x] = ratio.at<float>(std::min(h_bins - 1, p[x][0] * h_bins / 180),
                                   p[x][1] * s_bins / 256);
    }
}

void fillHoles(InputArray _mask, OutputArray _filled) {
    Mat mask = _mask.getMat();
    CV_Assert(mask.type() == CV_8UC1);
    // Pad by one pixel so that one flood fill from a corner reaches all the border's background.
    Mat padded(mask.rows + 2, mask.cols + 2, CV_8UC1, Scalar(0));
    Mat inner = padded(Rect(1, 1, mask.cols, mask.rows));
    threshold(mask, inner, 0, 255, THRESH_BINARY);
    floodFill(padded, Point(0, 0), Scalar(128), nullptr, Scalar(0), Scalar(0), 4);
    // 128: background reached from the border; 0: holes; 255: object.
    _filled.create(mask.size(), CV_8UC1);
    Mat out = _filled.getMat();
    compare(inner, Scalar(128), out, CMP_NE);
}

void cleanMask(InputArray _mask, OutputArray _cleaned, int open_size, int close_size, bool fill) {
    Mat mask = _mask.getMat();
    CV_Assert(mask.type() == CV_8UC1);
    Mat m = mask.clone();  // never modify the caller's mask
    if (open_size > 1)
        morphologyEx(m, m, MORPH_OPEN,
                     getStructuringElement(MORPH_ELLIPSE, Size(open_size, open_size)));
    if (close_size > 1)
        morphologyEx(m, m, MORPH_CLOSE,
                     getStructuringElement(MORPH_ELLIPSE, Size(close_size, close_size)));
    if (fill) fillHoles(m, m);
    m.copyTo(_cleaned);
}

}  // namespace vbme
}  // namespace cv
