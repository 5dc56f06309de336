// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Joint bilateral denoising of the difference layer of a differential render.
#include <cmath>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "opencv2/vbme/render/differential.hpp"

namespace cv {
namespace vbme {

void denoiseDifference(DifferentialImages& layers, InputArray guide_in, int radius) {
    CV_Assert(radius >= 1);
    CV_Assert(layers.diff.type() == CV_32FC3 && layers.mask.type() == CV_32FC1 &&
              layers.mask.size() == layers.diff.size());
    const Mat g_in = guide_in.getMat();
    CV_Assert(g_in.size() == layers.diff.size() && g_in.channels() == 3);
    Mat guide;
    const double scale = g_in.depth() == CV_8U    ? 1 / 255.0
                         : g_in.depth() == CV_16U ? 1 / 65535.0
                                                  : 1.0;
    g_in.convertTo(guide, CV_32FC3, scale);
    const Mat src = layers.diff.clone();
    const Mat& mask = layers.mask;
    const int r = radius;
    const float ss = 2.f / float(r * r), sr = 1.f / (2 * 0.1f * 0.1f);
    std::vector<float> spatial(size_t(2 * r + 1) * (2 * r + 1));
    for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx)
            spatial[size_t(dy + r) * (2 * r + 1) + (dx + r)] = float(dx * dx + dy * dy) * ss;
    Mat& dst = layers.diff;
    parallel_for_(Range(0, src.rows), [&](const Range& rows) {
        for (int y = rows.start; y < rows.end; ++y)
            for (int x = 0; x < src.cols; ++x) {
                if (mask.at<float>(y, x) > 0) continue;
                const Vec3f g0 = guide.at<Vec3f>(y, x);
                Vec3f acc(0, 0, 0);
                float wsum = 0;
                bool any = false;
                for (int dy = -r; dy <= r; ++dy) {
                    const int yy = y + dy;
                    if (yy < 0 || yy >= src.rows) continue;
                    const float* m = mask.ptr<float>(yy);
                    const Vec3f* d = src.ptr<Vec3f>(yy);
                    const Vec3f* g = guide.ptr<Vec3f>(yy);
                    for (int dx = -r; dx <= r; ++dx) {
                        const int xx = x + dx;
                        if (xx < 0 || xx >= src.cols || m[xx] > 0) continue;
                        if (d[xx] != Vec3f(0, 0, 0)) any = true;
                        const Vec3f dg = g[xx] - g0;
                        const float w = std::exp(-spatial[size_t(dy + r) * (2 * r + 1) + (dx + r)] -
                                                 dg.dot(dg) * sr);
                        acc += w * d[xx];
                        wsum += w;
                    }
                }
                if (any && wsum > 0) dst.at<Vec3f>(y, x) = acc * (1 / wsum);
            }
    });
}

}  // namespace vbme
}  // namespace cv
