// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_DATASETS_ROOM_HPP
#define OPENCV_VBME_DATASETS_ROOM_HPP

#include <opencv2/core.hpp>
#include <opencv2/vbme/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_datasets
//! @{

/** @brief Draws a box room seen by a camera inside it, for tests, benchmarks and demos.

Each face is filled with its own grey level and carries a pattern of lines along the room's
axes (floor tiles, wall panels), drawn anti-aliased with sub-pixel precision, so that line
detectors find the three Manhattan directions. Only cv::vbme::Camera::project and OpenCV
drawing are used: the picture is an independent oracle for the calibration code.
@param camera the camera (its image_size is the output size); it must be inside @p room.
@param room the box.
@param tile spacing of the pattern lines (metres).
@param noise_sigma standard deviation of Gaussian pixel noise added (8-bit levels).
@param seed seed of the noise.
@return 8-bit BGR image. */
CV_EXPORTS Mat drawSyntheticRoom(const Camera& camera, const Room& room, double tile = 0.5,
                                 double noise_sigma = 0, int seed = 0);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
