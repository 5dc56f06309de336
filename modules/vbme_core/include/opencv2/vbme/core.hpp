// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_HPP
#define OPENCV_VBME_CORE_HPP

/**
@defgroup vbme_core vbme_core: shared types and IO

The pieces every vbme module builds on: the pinhole camera of the DESIGN conventions
(K, cam_from_world, projection), the scene, material and camera-path files read and written
with cv::FileStorage, the camera response (sRGB, gamma 2.2, linear) used to linearise
display-encoded footage, video / image-sequence input and output, files written under a
temporary name and renamed when complete, and progress reporting for long work.
*/

#include "opencv2/vbme/core/camera.hpp"
#include "opencv2/vbme/core/camera_path.hpp"
#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/core/metrics.hpp"
#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/core/progress.hpp"
#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/core/video.hpp"
#include "opencv2/vbme/version.hpp"

#endif
