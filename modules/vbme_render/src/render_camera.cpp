// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/render/camera.hpp"

namespace cv {
namespace vbme {

PinholeCamera::PinholeCamera() : PinholeCamera(Camera::fromFocal(1.0, Size(1, 1))) {}

PinholeCamera::PinholeCamera(const Camera& camera) : camera_(camera) {
    if (camera.image_size.width <= 0 || camera.image_size.height <= 0)
        CV_Error(Error::StsBadArg, "PinholeCamera: the camera's image_size must be positive");
    if (std::abs(determinant(camera.K)) < 1e-12)
        CV_Error(Error::StsBadArg,
                 "PinholeCamera: K is singular (expected positive focal lengths)");
    world_from_pixel_ = Matx33f(camera.R.t() * camera.K.inv());
    origin_ = Vec3f(camera.center());
}

void PinholeCamera::generateRay(const Point2f& px, Vec3f& origin, Vec3f& dir) const {
    origin = origin_;
    const Vec3f d = world_from_pixel_ * Vec3f(px.x, px.y, 1.f);
    dir = d * (1.f / std::sqrt(d.dot(d)));
}

}  // namespace vbme
}  // namespace cv
