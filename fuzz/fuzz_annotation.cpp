// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the first-frame annotation file (cv::vbme::FrameAnnotation::read), the input of
// vbme calibrate and of the annotate tool.
#include <opencv2/vbme/calib/frame_calibration.hpp>

#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = vbme_fuzz::writeInput(data, size, "annotation.yml");
    vbme_fuzz::expectCleanError(path, [&] { (void)cv::vbme::FrameAnnotation::read(path); });
    return 0;
}
