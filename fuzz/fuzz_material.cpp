// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the material file (cv::vbme::readMaterialFile), vbme material-edit --material.
#include <opencv2/vbme/core/scene.hpp>

#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = vbme_fuzz::writeInput(data, size, "material.yml");
    vbme_fuzz::expectCleanError(path, [&] { (void)cv::vbme::readMaterialFile(path); });
    return 0;
}
