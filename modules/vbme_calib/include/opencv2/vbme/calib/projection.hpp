// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CALIB_PROJECTION_HPP
#define OPENCV_VBME_CALIB_PROJECTION_HPP

#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/core/camera.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_calib
//! @{

/** @brief Projects a world segment clipped to the part in front of the camera
(z_cam ≥ @p near). Returns false if nothing is in front. */
CV_EXPORTS bool projectSegment(const Camera& camera, const Vec3d& a, const Vec3d& b, Point2d& pa,
                               Point2d& pb, double near = 0.01);

/** @brief Projects a world polygon clipped to the half-space in front of the camera
(z_cam ≥ @p near, Sutherland–Hodgman against that one plane). Returns the image polygon
(pixels), empty or with fewer than three corners when (almost) nothing is in front. */
CV_EXPORTS std::vector<Point2d> projectPolygon(const Camera& camera,
                                               const std::vector<Vec3d>& polygon,
                                               double near = 0.01);

/** @brief Image point @p p in OpenCV's fixed-point drawing coordinates with @p shift fractional
bits (pass the same shift to cv::line, cv::fillPoly, …; pixel centres at integers in both), each
coordinate clamped to ±10⁶ pixels first so that a far projection stays drawable. */
CV_EXPORTS Point toFixedPoint(const Point2d& p, int shift = 8);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
