// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Private: the room box faces in vbme_render's texture orientation (shared by the room
// texture, albedo and light estimation stages). Must match RenderSceneImpl::addRoom().
#ifndef VBME_RENDER_ROOM_FACES_HPP
#define VBME_RENDER_ROOM_FACES_HPP

#include <string>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {
namespace render_detail {

/** A face rectangle: bottom-left corner, image-right and image-up edge vectors (world, metres),
unit normal into the room. Texel (col, row) of a W×H texture is the point
bl + u·right + v·up with u = (col + ½)/W, v = 1 − (row + ½)/H. */
struct RoomFace {
    Vec3d bl, right, up, n;
};

/** Index of @p name in Room::faceNames() (floor, ceiling, left, right, front, back), or throws. */
inline int roomFaceIndex(const std::string& name) {
    const std::vector<std::string>& f = Room::faceNames();
    for (int i = 0; i < (int)f.size(); ++i)
        if (f[i] == name) return i;
    CV_Error(Error::StsBadArg,
             "room face '" + name + "' is not one of floor, ceiling, left, right, front, back");
}

/** The face of index @p i (Room::faceNames() order; same as the render scene's triangles
2i, 2i+1 of the room geometry). */
inline RoomFace roomFace(const Room& room, int i) {
    const Vec3d lo = room.min, hi = room.max;
    const Vec3d ex(hi[0] - lo[0], 0, 0), ey(0, hi[1] - lo[1], 0), ez(0, 0, hi[2] - lo[2]);
    RoomFace F;
    switch (i) {
        case 0:
            F = {lo, ex, ey, Vec3d()};
            break;  // floor
        case 1:
            F = {Vec3d(lo[0], hi[1], hi[2]), ex, -ey, Vec3d()};
            break;  // ceiling
        case 2:
            F = {lo, ey, ez, Vec3d()};
            break;  // left
        case 3:
            F = {Vec3d(hi[0], hi[1], lo[2]), -ey, ez, Vec3d()};
            break;  // right
        case 4:
            F = {Vec3d(hi[0], lo[1], lo[2]), -ex, ez, Vec3d()};
            break;  // front
        default:
            F = {Vec3d(lo[0], hi[1], lo[2]), ex, ez, Vec3d()};
            break;  // back
    }
    F.n = normalize(F.right.cross(F.up));
    return F;
}

/** Bilinear lookup of a CV_32FC3 image at texture coordinates (u, v) (Texture convention,
clamped at the edges), BGR order. */
inline Vec3f lookupUV(const Mat& img, float u, float v) {
    const float x = u * img.cols - 0.5f, y = (1.f - v) * img.rows - 0.5f;
    const float xc = std::min(std::max(x, 0.f), float(img.cols - 1));
    const float yc = std::min(std::max(y, 0.f), float(img.rows - 1));
    const int x0 = std::min((int)xc, img.cols - 2 < 0 ? 0 : img.cols - 2);
    const int y0 = std::min((int)yc, img.rows - 2 < 0 ? 0 : img.rows - 2);
    const int x1 = std::min(x0 + 1, img.cols - 1), y1 = std::min(y0 + 1, img.rows - 1);
    const float ax = xc - x0, ay = yc - y0;
    const Vec3f* r0 = img.ptr<Vec3f>(y0);
    const Vec3f* r1 = img.ptr<Vec3f>(y1);
    return (r0[x0] * (1.f - ax) + r0[x1] * ax) * (1.f - ay) +
           (r1[x0] * (1.f - ax) + r1[x1] * ax) * ay;
}

}  // namespace render_detail
}  // namespace vbme
}  // namespace cv

#endif
