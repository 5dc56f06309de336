// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_DATASETS_HPP
#define OPENCV_VBME_DATASETS_HPP

/**
@defgroup vbme_datasets vbme_datasets: synthetic data with known answers

Generators of pictures and clips whose ground truth is known exactly, for the tests, the
benchmarks, the samples and `vbme demo`: a drawn ball clip for the tracker (SyntheticBallClip),
a ball clip path traced with vbme_render in any material (RenderedBallClip), a drawn box room
for single-frame calibration (drawSyntheticRoom), textured rooms seen along a hand-held camera
path for camera tracking (makeRoomTextures, renderTexturedRoom, syntheticRoomScene,
handheldCameraPath), and a whole insertion job with its annotation and path-traced truth
(SyntheticInsertionSequence).
*/

#include "opencv2/vbme/datasets/ball_clip.hpp"
#include "opencv2/vbme/datasets/camera_effects.hpp"
#include "opencv2/vbme/datasets/insertion_sequence.hpp"
#include "opencv2/vbme/datasets/rendered_ball_clip.hpp"
#include "opencv2/vbme/datasets/room.hpp"
#include "opencv2/vbme/datasets/room_sequence.hpp"

#endif
