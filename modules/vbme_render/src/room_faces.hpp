// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Private: look-up of a room face texture at texture coordinates (shared by the room texture,
// albedo and light estimation stages). The faces themselves are cv::vbme::Room::face().
#ifndef VBME_RENDER_ROOM_FACES_HPP
#define VBME_RENDER_ROOM_FACES_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/core/utility.hpp"

namespace cv {
namespace vbme {
namespace render_detail {

/** Bilinear lookup of a CV_32FC3 image at texture coordinates (u, v) (Texture convention,
clamped at the edges), BGR order. */
inline Vec3f lookupUV(const Mat& img, float u, float v) {
    return bilinear<Vec3f>(img, u * img.cols - 0.5f, (1.f - v) * img.rows - 0.5f);
}

}  // namespace render_detail
}  // namespace vbme
}  // namespace cv

#endif
