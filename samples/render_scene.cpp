// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Renders a scene file with the vbme_render C++ API and writes an EXR and a PNG (encoded with
// the scene camera's response) next to it.
//
//   vbme_sample_render_scene scene.yml out.exr [spp]
#include <cstdio>
#include <string>

#include <opencv2/vbme/render.hpp>

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s scene.yml out.exr [spp]\n", argv[0]);
        return 2;
    }
    try {
        const cv::vbme::Scene scene = cv::vbme::Scene::read(argv[1]);
        cv::Ptr<cv::vbme::RenderScene> rs = cv::vbme::RenderScene::create(scene);
        cv::vbme::Renderer::Params p = cv::vbme::Renderer::Params::fromScene(scene.render);
        if (argc > 3) p.spp = std::stoi(argv[3]);
        cv::Ptr<cv::vbme::Renderer> renderer = cv::vbme::Renderer::create(p);
        cv::vbme::RenderImages img;
        const cv::vbme::RenderStats st = renderer->render(*rs, scene.camera, img);
        cv::vbme::writeExr(argv[2], img, {{"vbme.seed", std::to_string(p.seed)}});
        cv::Mat png;
        cv::vbme::encode(img.color, png, scene.camera.response);
        std::string png_path = argv[2];
        png_path = png_path.substr(0, png_path.rfind('.')) + ".png";  // out.exr → out.png
        cv::vbme::imwriteAtomic(png_path, png);
        std::printf("%.3f s, %d spp, %.3g paths/s\n", st.seconds, p.spp, st.paths / st.seconds);
    } catch (const cv::Exception& e) {
        std::fprintf(stderr, "error: %s\n", e.err.c_str());
        return 1;
    }
    return 0;
}
