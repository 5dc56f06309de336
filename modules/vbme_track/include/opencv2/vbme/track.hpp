// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_TRACK_HPP
#define OPENCV_VBME_TRACK_HPP

/**
@defgroup vbme_track vbme_track: object tracking and shape recovery

Tracks a uniformly coloured ball through a video (thesis §4.1) and recovers its shape
(§4.2): a hue–saturation colour model learnt from the first frame's mask classifies pixels,
morphology cleans the result, and a disk is fitted by hill climbing on the agreement quality
(Eq. 4.6). The disk gives a sphere's height map and normals in the OpenCV camera frame.
See doc/vbme_track.md for a tutorial.
*/

#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/track/disk.hpp"
#include "opencv2/vbme/track/object_tracker.hpp"
#include "opencv2/vbme/track/shape.hpp"
#include "opencv2/vbme/track/video_tracking.hpp"

#endif
