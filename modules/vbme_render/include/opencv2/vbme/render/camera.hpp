// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_CAMERA_HPP
#define OPENCV_VBME_RENDER_CAMERA_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief The render-side pinhole camera: primary rays from a cv::vbme::Camera.

The ray through image point (x, y) (pixel centres at integers, DESIGN convention) starts at
the camera centre −Rᵀt and has direction Rᵀ K⁻¹ (x, y, 1)ᵀ, normalised, so a world point that
cv::projectPoints maps to (x, y) lies on it. Rendering at another size uses
cv::vbme::Camera::scaled() first.
*/
class CV_EXPORTS PinholeCamera {
public:
    /** @brief An identity camera (call the other constructor). */
    PinholeCamera();
    /** @brief From a camera with its image size set. */
    explicit PinholeCamera(const Camera& camera);
    /** @brief The camera. */
    const Camera& camera() const { return camera_; }
    /** @brief The image size. */
    Size imageSize() const { return camera_.image_size; }
    /** @brief Ray through image point @p px: @p origin (the camera centre) and unit
    direction @p dir, both in world coordinates. */
    void generateRay(const Point2f& px, Vec3f& origin, Vec3f& dir) const;
    /** @brief The unit directions of the rays through the @p n image points @p px, into
    @p dirs[0 … n): the same bits as generateRay() on each point, four at a time in SSE
    registers where there is SSE2 (the square roots and divisions of four rays in one
    instruction each instead of one dependent chain per ray). The rays start at origin(). */
    void generateRays(const Point2f* px, int n, Vec3f* dirs) const;
    /** @brief The rays' origin: the camera centre −Rᵀt in world coordinates. */
    const Vec3f& origin() const { return origin_; }
    /** @brief Projects a world point to image coordinates (same as cv::projectPoints with
    rvec = Rodrigues(R), tvec = t, no distortion). */
    Point2d project(const Vec3d& X_world) const { return camera_.project(X_world); }

private:
    Camera camera_;
    Matx33f world_from_pixel_;  // Rᵀ K⁻¹
    Vec3f origin_;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
