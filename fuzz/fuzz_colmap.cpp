// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: one file of a COLMAP text model (cv::vbme::ColmapModel::readText), chosen by
// VBME_FUZZ_COLMAP_FILE (cameras.txt, images.txt or points3D.txt); the other two are empty
// (a valid, empty model).
#include <filesystem>
#include <fstream>

#include <opencv2/vbme/calib/colmap.hpp>

#include "fuzz_util.hpp"

#ifndef VBME_FUZZ_COLMAP_FILE
#define VBME_FUZZ_COLMAP_FILE "cameras.txt"
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string dir = vbme_fuzz::scratchDir() + "/model";
    std::filesystem::create_directories(dir);
    for (const char* name : {"cameras.txt", "images.txt", "points3D.txt"})
        std::ofstream(dir + "/" + name, std::ios::trunc);
    const std::string path =
        vbme_fuzz::writeInput(data, size, std::string("model/") + VBME_FUZZ_COLMAP_FILE);
    vbme_fuzz::expectCleanError(path, [&] { (void)cv::vbme::ColmapModel::readText(dir); });
    return 0;
}
