// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_INPAINT_HPP
#define OPENCV_VBME_INPAINT_HPP

/**
@defgroup vbme_inpaint vbme_inpaint: exemplar-based inpainting of images and video

Removes an object from an image or a video by filling its region (the hole) with the
surrounding background. Images are filled patch by patch in the order of Criminisi et al.
@cite Criminisi2004, which continues linear structure into the hole first; the best source
patch is found by one of three searches: a local window (the original paper), a global
vantage-point tree (the thesis's choice @cite Yianilos1993), or a global randomised search in
the spirit of PatchMatch @cite Barnes2009 (the default, fastest). Video frames are filled
first from neighbouring frames where the background is seen (aligned by a homography and
checked for consistency), then by exemplars, reusing the previous frame's fill for stability
(VideoInpainter). ConsensusInpainter instead lets many aligned frames vote for each hole pixel
(homography and dense flow), leaves out candidates in the object's shadow, and removes the
object's own cast shadow from the frame.
*/

#include "opencv2/vbme/inpaint/consensus.hpp"
#include "opencv2/vbme/inpaint/exemplar.hpp"
#include "opencv2/vbme/inpaint/video.hpp"

#endif
