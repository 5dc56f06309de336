// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme material-edit: re-render a filmed ball in another material (thesis chapter 4).
#include <cstdio>
#include <memory>
#include <string>

#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/pipeline/material_edit.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct MaterialEditOptions {
    cv::vbme::MaterialEditParams params;
    std::string material;
    CommonOptions common;
};

void setupMaterialEdit(CLI::App& app) {
    auto opt = std::make_shared<MaterialEditOptions>();
    auto& p = opt->params;
    app.footer(
        "Re-render a filmed ball in another material: track it from the frame-0 mask, recover "
        "its shape, remove it by inpainting, build an environment from the background, fit the "
        "lighting to the ball's own shading, and composite the re-rendered ball.\n"
        "  vbme material-edit --video IN.mp4 --mask FIRST.png --material chrome --out OUT.mp4\n"
        "Materials: presets (chrome, gold, copper, silver, mirror, glass, ice, blue, red, matte, "
        "white) or a YAML/JSON file with a top-level material: map.\n"
        "The camera is taken as static and level; a lost track stops the run (see --max-lost).");
    app.add_option("--video", p.video, "Input video file, image folder or pattern")->required();
    app.add_option("--mask", p.first_mask, "8-bit mask of the object in frame 0 (255 = object)")
        ->required();
    app.add_option("--material", opt->material, "Preset name or material file")->required();
    app.add_option("--out", p.out, "Edited video (or numbered images, e.g. out/%05d.png)")
        ->required();
    app.add_option("--light", p.light,
                   "auto (fitted to the ball's shading per frame) or fixed:x,y,z (direction "
                   "towards the light, camera coordinates)");
    app.add_option("--focal", p.focal, "Focal length in pixels (default: 60 degree horizontal FOV)")
        ->check(CLI::PositiveNumber);
    app.add_option("--env", p.env, "Equirectangular HDR/EXR environment instead of the frames'")
        ->check(CLI::ExistingFile);
    app.add_option("--save-intermediates", p.intermediates,
                   "Folder for mask_%05d.png, background.mkv and env_%05d.exr");
    app.add_option("--threads", p.threads, "Worker threads (0: all cores)")
        ->check(CLI::Range(0, 1024));
    app.add_option("--max-lost", p.max_lost,
                   "Consecutive frames the ball may be lost (the last disk is kept); more stop "
                   "the run")
        ->check(CLI::Range(0, 1000000));
    app.add_option("--inpaint", p.inpaint,
                   "background (static camera, fast) or video (aligned neighbours, slower)")
        ->check(CLI::IsMember({"background", "video"}));
    app.add_option("--shadows", p.shadows,
                   "The original ball's cast shadow: keep (default; the new ball casts none of "
                   "its own) or remove")
        ->check(CLI::IsMember({"keep", "remove"}));
    app.add_option("--response", p.response, "Camera response: srgb, gamma2.2 or linear")
        ->check(CLI::IsMember({"srgb", "gamma2.2", "linear"}));
    app.add_option("--samples", p.samples, "Samples per pixel for rough lobes")
        ->check(CLI::Range(1, 4096));
    addVideoOutputOptions(app, p.encode);
    addCommonOptions(app, opt->common);
    app.callback([opt] {
        applyCommonOptions(opt->common);
        opt->params.force = opt->common.force;
        opt->params.material = cv::vbme::parseMaterialSpec(opt->material);
        const cv::vbme::MaterialEditReport r = cv::vbme::runMaterialEdit(opt->params);
        if (!opt->common.quiet) r.print(stderr);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("material-edit",
                      "Re-render a filmed ball in another material (chrome, glass, ...)",
                      setupMaterialEdit);

}  // namespace vbme_app
