// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE).
#ifndef OPENCV_VBME_DATASETS_ROOM_SEQUENCE_HPP
#define OPENCV_VBME_DATASETS_ROOM_SEQUENCE_HPP

#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_datasets
//! @{

/** @brief Procedural textures for the six faces of a room (8-bit BGR,
display-encoded), keyed by face name: blotchy multi-scale colour noise under
random discs, boxes and strokes, rich in corners and blobs so that feature-based
structure-from-motion can follow a camera. Deterministic in @p seed. */
CV_EXPORTS std::map<std::string, Mat> makeRoomTextures(int seed = 1, int size = 1024);

/** @brief Renders a textured box room as seen from inside by @p camera, through vbme_render's
room: every ray of a @p supersample² grid per pixel is cast into cv::vbme::RenderScene's room box
and the hit face's texture is looked up bilinearly (cv::vbme::Texture, clamped at the edges) at
the hit's texture coordinates, in the texture's own 8-bit levels; the rays are averaged. Albedo
only (no lighting, no noise): an exact image for camera-tracking tests.

Texture orientation: vbme_render's (see cv::vbme::RenderScene; image right / image up):
floor +x / +y, ceiling +x / −y, back +x / +z, front −x / +z, left +y / +z, right −y / +z.
Faces without a texture are mid-grey. Throws cv::Exception when the camera is outside the room.
@return 8-bit BGR image of camera.image_size. */
CV_EXPORTS Mat renderTexturedRoom(const Camera& camera, const Room& room,
                                  const std::map<std::string, Mat>& textures, int supersample = 2);

/** @brief The frame-0 scene of the synthetic sequences: a 4 × 5 × 2.6 m room
(x ∈ [−2, 2], y ∈ [−1, 4], z ∈ [0, 2.6]) and a camera @p height metres above the world
origin facing the back wall (+y), pitched @p pitch_rad down, with focal length @p focal
(pixels) for images of @p size. */
CV_EXPORTS Scene syntheticRoomScene(Size size = Size(320, 240), double focal = 260,
                                    double pitch_rad = 0.25, double height = 1.5);

/** @brief A hand-held camera path starting at @p first: a smooth walk of about
@p travel metres (sideways and forwards) with slow panning, plus hand shake
(random, band-limited) of @p shake_m metres and @p shake_deg degrees.
Deterministic in @p seed. */
CV_EXPORTS std::vector<Camera> handheldCameraPath(const Camera& first, int frames,
                                                  double travel = 1.5, double shake_m = 0.01,
                                                  double shake_deg = 0.5, int seed = 1);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
