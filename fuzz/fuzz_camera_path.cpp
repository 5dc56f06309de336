// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the camera-path file (cv::vbme::CameraPath::read), vbme track-camera's output
// and vbme insert's --cameras.
#include <opencv2/vbme/core/camera_path.hpp>

#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = vbme_fuzz::writeInput(data, size, "cameras.yml");
    vbme_fuzz::expectCleanError(path, [&] {
        const cv::vbme::CameraPath p = cv::vbme::CameraPath::read(path);
        for (size_t i = 0; i < p.frames.size(); ++i)
            (void)p.camera(i);
    });
    return 0;
}
