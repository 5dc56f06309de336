// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Unseen texels of the room textures, filled by exemplar inpainting.
#include <algorithm>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/inpaint/exemplar.hpp"
#include "opencv2/vbme/render/room_texture.hpp"

namespace cv {
namespace vbme {

void fillUnseenTexels(InputOutputArray texture_linear, InputArray seen_) {
    CV_Assert(texture_linear.type() == CV_32FC3 && seen_.type() == CV_8UC1 &&
              seen_.size() == texture_linear.size());
    Mat linear = texture_linear.getMat();
    const Mat seen = seen_.getMat();
    Mat hole;
    compare(seen, 0, hole, CMP_EQ);
    const int n_hole = countNonZero(hole);
    if (n_hole == 0) return;
    if (n_hole == (int)hole.total()) {  // nothing seen: mid-grey rather than noise
        linear.setTo(Scalar::all(0.18));
        return;
    }
    std::vector<float> vals;
    vals.reserve(linear.total() * 3);
    for (int y = 0; y < linear.rows; ++y) {
        const Vec3f* row = linear.ptr<Vec3f>(y);
        const uchar* s = seen.ptr<uchar>(y);
        for (int x = 0; x < linear.cols; ++x)
            if (s[x])
                for (int c = 0; c < 3; ++c)
                    vals.push_back(row[x][c]);
    }
    const size_t k = std::min(vals.size() - 1, (size_t)(0.995 * (double)vals.size()));
    std::nth_element(vals.begin(), vals.begin() + (long)k, vals.end());
    const float norm = std::max(vals[k], 1e-6f);
    const int side = std::max(linear.cols, linear.rows);
    const double f = side > 256 ? 256.0 / side : 1.0;
    Mat small = linear, small_hole = hole;
    if (f < 1) {
        const Size sz(std::max(1, cvRound(linear.cols * f)), std::max(1, cvRound(linear.rows * f)));
        resize(linear, small, sz, 0, 0, INTER_AREA);
        resize(hole, small_hole, sz, 0, 0, INTER_AREA);
        small_hole = small_hole > 0;  // any unseen source texel: fill
        if (countNonZero(small_hole) == (int)small_hole.total()) {
            linear.setTo(Scalar::all(0.18), hole);
            return;
        }
    }
    Mat scaled = small / norm, enc8;
    encode(scaled, enc8, Response::SRGB, CV_8U);
    ExemplarInpainter::Params ip;
    ip.patch_size = std::max(3, std::min(9, (std::min(small.rows, small.cols) / 16) | 1));
    Mat filled;
    ExemplarInpainter::create(ip)->inpaint(enc8, small_hole, filled);
    Mat lin;
    linearize(filled, lin, Response::SRGB);
    lin *= norm;
    if (f < 1) resize(lin, lin, linear.size(), 0, 0, INTER_LINEAR);
    lin.copyTo(linear, hole);
}

}  // namespace vbme
}  // namespace cv
