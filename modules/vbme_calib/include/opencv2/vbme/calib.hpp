// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CALIB_HPP
#define OPENCV_VBME_CALIB_HPP

/**
@defgroup vbme_calib vbme_calib: camera and room calibration

Single-frame calibration of the object-insertion pipeline (thesis §5.1.1): two or three sets of
lines that are parallel in the world give orthogonal vanishing points, hence the focal length
and the camera's rotation @cite Caprile1990 @cite Guillou2000; the vanishing points can also be
found automatically from OpenCV's line segments @cite vonGioi2012 with a RANSAC Manhattan-frame
search @cite Coughlan1999 @cite Kosecka2002. The room is a box placed and sized in that camera
from a few clicked points, and light sources are image polygons ray-cast onto the box faces.

Camera tracking of the whole video (thesis §5.2.2–5.2.3): COLMAP @cite Schoenberger2016 run as a
program through its text models, aligned to the annotated room by a robust Eq. 5.3 and refined
with Ceres in the room frame (camera_tracking.hpp).
*/

#include "opencv2/vbme/calib/frame_calibration.hpp"
#include "opencv2/vbme/calib/camera_tracking.hpp"
#include "opencv2/vbme/calib/colmap.hpp"
#include "opencv2/vbme/calib/projection.hpp"
#include "opencv2/vbme/calib/exif.hpp"

#endif
