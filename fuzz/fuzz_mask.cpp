// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the first-frame mask (cv::vbme::readObjectMask, as vbme material-edit reads it;
// vbme track decodes it with the same cv::imread and checks it in trackVideo), a PNG file; once
// without and once with an expected size.
#include <opencv2/vbme/core/fileio.hpp>

#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = vbme_fuzz::writeInput(data, size, "mask.png");
    vbme_fuzz::expectCleanError(path, [&] {
        const cv::Mat m = cv::vbme::readObjectMask(path);
        if (m.type() != CV_8UC1) vbme_fuzz::finding("the mask is not 8-bit single channel");
    });
    vbme_fuzz::expectCleanError(path,
                                [&] { (void)cv::vbme::readObjectMask(path, cv::Size(8, 8)); });
    return 0;
}
