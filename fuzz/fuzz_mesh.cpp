// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the mesh loading of the renderer (assimp through cv::vbme::RenderScene), the
// way a scene's `objects:` mesh is loaded, here a Wavefront OBJ file.
#include <opencv2/vbme/render/scene.hpp>

#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string path = vbme_fuzz::writeInput(data, size, "mesh.obj");
    cv::vbme::Scene s;
    s.image_size = cv::Size(32, 24);
    s.camera.image_size = s.image_size;
    cv::vbme::SceneObject o;
    o.mesh = path;
    s.objects.push_back(o);
    vbme_fuzz::expectCleanError(path, [&] { (void)cv::vbme::RenderScene::create(s); });
    return 0;
}
