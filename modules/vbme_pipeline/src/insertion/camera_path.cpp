// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion stage 2: the camera path, one pose per video frame: given (--cameras), found in the
// work folder, or tracked (vbme_calib's trackCameraVideo, COLMAP) into <work>/tracking.
#include <filesystem>

#include "insertion/stages.hpp"
#include "opencv2/vbme/calib/camera_tracking.hpp"

namespace cv {
namespace vbme {
namespace insertion {

namespace fs = std::filesystem;

Camera pathCamera(const CameraPath& path, int i, const Scene& scene) {
    Camera c = path.camera((size_t)i);
    c.response = scene.camera.response;
    c.k1 = scene.camera.k1;
    c.image_size = scene.image_size;
    return c;
}

CameraPath cameraPath(const InsertionParams& p, const Inputs& in, const std::string& work,
                      std::string& path_file, PipelineReport* report) {
    const Scene& scene = in.scene;
    const int n = in.video.frames;
    CameraPath path;
    path_file = p.cameras;
    if (!p.cameras.empty()) {
        path = CameraPath::read(p.cameras);
    } else {
        path_file = (fs::path(work) / "cameras.yml").string();
        if (fs::exists(path_file)) {
            path = CameraPath::read(path_file);
        } else {
            ScopedTimer timer(stageSeconds(report, "tracking"));
            path = trackCameraVideo(p.video, scene, (fs::path(work) / "tracking").string());
            path.write(path_file);
        }
    }
    if ((int)path.frames.size() < n)
        CV_Error(Error::StsBadArg,
                 format("the camera path '%s' has %d frames but the video '%s' has %d (one pose "
                        "per video frame is needed)",
                        path_file.c_str(), (int)path.frames.size(), p.video.c_str(), n));
    // a path without k1 (another tracker, known poses) is taken as the pinhole camera's poses
    if (path.k1 != 0 && std::abs(path.k1 - scene.camera.k1) > 1e-9)
        CV_Error(Error::StsBadArg,
                 format("the camera path '%s' was tracked on frames undistorted with k1 = %g, but "
                        "the scene's camera has k1 = %g: track the camera again with this "
                        "scene (or give the path's k1 in the scene)",
                        path_file.c_str(), path.k1, scene.camera.k1));
    if (path.image_size.area() > 0 && path.image_size != scene.image_size)
        CV_Error(Error::StsBadSize,
                 format("the camera path '%s' is for %dx%d images, the scene for %dx%d",
                        path_file.c_str(), path.image_size.width, path.image_size.height,
                        scene.image_size.width, scene.image_size.height));
    return path;
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
