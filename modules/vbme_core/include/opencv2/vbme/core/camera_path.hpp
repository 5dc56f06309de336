// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_CAMERA_PATH_HPP
#define OPENCV_VBME_CORE_CAMERA_PATH_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief The camera of every frame of a video, in the room's world frame.

File form (YAML): `K: 3x3`, optionally `k1` (the lens's radial distortion, Camera::k1; the
poses are those of the undistorted frames), and `frames: [ { index, R, t, source }, … ]`, one entry
per video frame in order (`cam_from_world`). `source` says where a pose came from.
*/
struct CV_EXPORTS CameraPath {
    /** @brief Where a frame's pose comes from. */
    enum Source {
        SFM,          //!< registered by structure-from-motion
        PNP,          //!< registered afterwards by PnP against the model's points
        INTERPOLATED  //!< interpolated between neighbouring frames
    };
    /** @brief One frame's pose. */
    struct Frame {
        int index = 0;               //!< video frame index (0-based)
        Matx33d R = Matx33d::eye();  //!< rotation of cam_from_world
        Vec3d t = Vec3d(0, 0, 0);    //!< translation of cam_from_world
        Source source = SFM;         //!< provenance
    };
    Matx33d K = Matx33d::eye();  //!< shared intrinsics
    double k1 = 0;               //!< radial distortion of the frames (Camera::k1); 0: none
    Size image_size;             //!< image size (written when known)
    std::vector<Frame> frames;   //!< one per video frame, in order

    /** @brief The Camera of frame @p i (K, k1, image size and pose). */
    Camera camera(size_t i) const;
    /** @brief Reads a camera-path file; throws cv::Exception naming the field at fault,
    including frames out of order. */
    static CameraPath read(const std::string& path);
    /** @brief Writes the file under a temporary name renamed when complete. */
    void write(const std::string& path) const;
    /** @brief "sfm", "pnp" or "interpolated". */
    static std::string sourceName(Source s);
    /** @brief Parses a source name. */
    static Source parseSource(const std::string& s, const std::string& field = "source");
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
