// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the tracker parameter file (cv::vbme::readTrackerParamsFile), vbme track
// --params.
#include <opencv2/vbme/track/object_tracker.hpp>

#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = vbme_fuzz::writeInput(data, size, "tracker.yml");
    vbme_fuzz::expectCleanError(path, [&] { (void)cv::vbme::readTrackerParamsFile(path); });
    return 0;
}
