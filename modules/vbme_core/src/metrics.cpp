// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Image-comparison figures shared by the tests, benchmarks and `vbme demo`.
#include "opencv2/vbme/core/metrics.hpp"

#include <cmath>
#include <limits>

namespace cv {
namespace vbme {

double regionPsnr(InputArray a_, InputArray b_, InputArray region_, double* sse_out,
                  double* count_out) {
    const Mat a = a_.getMat(), b = b_.getMat();
    CV_Assert(a.size() == b.size() && a.type() == b.type() && a.depth() == CV_8U);
    Mat region = region_.getMat();
    if (region.empty()) region = Mat(a.size(), CV_8U, Scalar(255));
    CV_Assert(region.size() == a.size() && region.type() == CV_8UC1);
    Mat d;
    absdiff(a, b, d);
    d.convertTo(d, CV_64F);
    d = d.mul(d);
    const double pixels = countNonZero(region);
    const Scalar m = pixels > 0 ? mean(d, region) : Scalar::all(0);
    double sse = 0;
    for (int k = 0; k < a.channels(); ++k)
        sse += m[k] * pixels;
    const double count = pixels * a.channels();
    if (sse_out) *sse_out = sse;
    if (count_out) *count_out = count;
    if (count == 0 || sse == 0) return std::numeric_limits<double>::infinity();
    return 10 * std::log10(255.0 * 255.0 / (sse / count));
}

}  // namespace vbme
}  // namespace cv
