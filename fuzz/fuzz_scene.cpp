// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the scene file (cv::vbme::Scene::read), YAML or JSON by VBME_FUZZ_EXT.
// A scene that reads must also write and read back (the file contract is a round trip).
#include <opencv2/vbme/core/scene.hpp>

#include "fuzz_util.hpp"

#ifndef VBME_FUZZ_EXT
#define VBME_FUZZ_EXT ".yml"
#endif

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = vbme_fuzz::writeInput(data, size, "scene" VBME_FUZZ_EXT);
    vbme_fuzz::expectCleanError(path, [&] {
        const cv::vbme::Scene s = cv::vbme::Scene::read(path);
        (void)s.warnings();
        const std::string again = vbme_fuzz::scratchDir() + "/again" VBME_FUZZ_EXT;
        s.write(again);
        try {
            const cv::vbme::Scene t = cv::vbme::Scene::read(again);
            if (t.image_size != s.image_size || t.lights.size() != s.lights.size() ||
                t.objects.size() != s.objects.size() || t.render.spp != s.render.spp)
                vbme_fuzz::finding("the scene read back differs from the one written");
        } catch (const cv::Exception& e) {
            vbme_fuzz::finding("a scene that was read cannot be read back once written: " + e.err);
        }
    });
    return 0;
}
