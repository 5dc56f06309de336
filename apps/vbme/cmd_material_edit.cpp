// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme material-edit: re-render a filmed ball in another material (thesis chapter 4).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/pipeline/material_edit.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

namespace fs = std::filesystem;

/** --material: a preset name (Material::presetNames()) or a material file (YAML/JSON with a
top-level material: map); a clear error naming the valid presets otherwise. */
cv::vbme::Material parseMaterialSpec(const std::string& spec) {
    using cv::vbme::Material;
    std::string list;
    for (const auto& n : Material::presetNames())
        list += (list.empty() ? "" : ", ") + n;
    if (spec.empty())
        CV_Error(cv::Error::StsBadArg,
                 "no material given (expected a preset: " + list + "; or a material file)");
    const std::string ext = fs::path(spec).extension().string();
    std::error_code ec;
    const bool looks_file = ext == ".yml" || ext == ".yaml" || ext == ".json" || ext == ".xml" ||
                            spec.find('/') != std::string::npos;
    if (fs::is_regular_file(spec, ec)) return cv::vbme::readMaterialFile(spec);
    if (looks_file)
        CV_Error(cv::Error::StsBadArg, "material file '" + spec +
                                           "' does not exist (expected a preset: " + list +
                                           "; or an existing YAML/JSON material file)");
    const auto names = Material::presetNames();
    if (std::find(names.begin(), names.end(), spec) == names.end())
        CV_Error(cv::Error::StsBadArg, "unknown material '" + spec +
                                           "' (expected a preset: " + list +
                                           "; or a YAML/JSON file with a top-level material: map)");
    return Material::preset(spec);
}

/** --light: "auto" (fitted to the original object's shading) or "fixed:x,y,z" (direction
towards the light in camera coordinates, normalised; its strength is still fitted). */
void parseLightSpec(const std::string& spec, cv::vbme::MaterialEditParams& p) {
    if (spec == "auto") {
        p.light = cv::vbme::MATERIAL_EDIT_LIGHT_AUTO;
        return;
    }
    const std::string pre = "fixed:";
    if (spec.compare(0, pre.size(), pre) == 0) {
        double v[3];
        char tail = 0;
        if (std::sscanf(spec.c_str() + pre.size(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) ==
            3) {
            const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            if (n > 0 && std::isfinite(n)) {
                p.light = cv::vbme::MATERIAL_EDIT_LIGHT_FIXED;
                p.to_light = cv::Vec3d(v[0], v[1], v[2]) / n;
                return;
            }
        }
    }
    CV_Error(cv::Error::StsBadArg, "invalid light '" + spec +
                                       "' (expected 'auto' or 'fixed:x,y,z', a non-zero direction "
                                       "towards the light in camera coordinates: x right, y "
                                       "down, z forward)");
}

struct MaterialEditOptions {
    cv::vbme::MaterialEditParams params;
    std::string material;
    std::string light = "auto";
    std::string inpaint = "background";
    std::string shadows = "auto";
    std::string response = "srgb";
    std::string report;
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
        "The camera is taken as static and level; a lost track stops the run, or with --max-lost "
        "N up to N lost frames in a row pass through unedited.");
    app.add_option("--video", p.video, "Input video file, image folder or pattern")->required();
    app.add_option("--mask", p.first_mask, "8-bit mask of the object in frame 0 (255 = object)")
        ->required();
    app.add_option("--material", opt->material, "Preset name or material file")->required();
    app.add_option("--out", p.out, "Edited video (or numbered images, e.g. out/%05d.png)")
        ->required();
    app.add_option("--light", opt->light,
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
                   "Consecutive frames the ball may be lost (hidden or not recognised; those "
                   "frames pass through unedited); more stop the run")
        ->check(CLI::Range(0, 1000000));
    app.add_option("--inpaint", opt->inpaint,
                   "background (static camera, fast) or video (aligned neighbours, slower)")
        ->check(CLI::IsMember({"background", "video"}));
    app.add_option("--shadows", opt->shadows,
                   "The original ball's cast shadow: keep (it stays, exactly; the new ball casts "
                   "none of its own), remove (the new ball then casts one fitting its material, "
                   "estimated from the original: the same for opaque and chrome, lighter with a "
                   "caustic core for glass) or auto (default: remove for glass and other "
                   "dielectrics, keep for every other material, whose shadow is the original's)")
        ->check(CLI::IsMember({"auto", "keep", "remove"}));
    app.add_option("--response", opt->response, "Camera response: srgb, gamma2.2 or linear")
        ->check(CLI::IsMember({"srgb", "gamma2.2", "linear"}));
    app.add_option("--samples", p.samples, "Samples per pixel for rough lobes")
        ->check(CLI::Range(1, 4096));
    app.add_option("--report", opt->report,
                   "Write the run's report (seconds per stage, frame counts, hole pixels filled "
                   "from other frames and by exemplars) as YAML or JSON");
    addVideoOutputOptions(app, p.encode);
    addCommonOptions(app, opt->common);
    app.callback([opt] {
        applyCommonOptions(opt->common);
        opt->params.force = opt->common.force;
        auto& p = opt->params;
        // The command owns its process: OpenCV's own loops honour --threads too (the library
        // limits only the work it starts, runLimited()).
        if (p.threads > 0) cv::setNumThreads(p.threads);
        p.material = parseMaterialSpec(opt->material);
        parseLightSpec(opt->light, p);
        p.inpaint = opt->inpaint == "video" ? cv::vbme::MATERIAL_EDIT_INPAINT_VIDEO
                                            : cv::vbme::MATERIAL_EDIT_INPAINT_BACKGROUND;
        p.shadows = opt->shadows == "auto" ? cv::vbme::shadowModeFor(p.material)
                                           : cv::vbme::parseShadowMode(opt->shadows);
        p.response = cv::vbme::parseResponse(opt->response);
        if (!opt->report.empty()) cv::vbme::checkOverwrite(opt->report, p.force);
        std::unique_ptr<cv::vbme::Progress> bar;
        const cv::vbme::PipelineReport r =
            cv::vbme::runMaterialEdit(p, [&bar](const std::string& stage, int64 done, int64 total) {
                if (!bar) bar.reset(new cv::vbme::Progress(stage, total));
                bar->set(done);
            });
        if (bar) bar->finish();
        if (!opt->report.empty()) r.save(opt->report);
        if (!opt->common.quiet) r.print(std::cerr);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("material-edit",
                      "Re-render a filmed ball in another material (chrome, glass, ...)",
                      setupMaterialEdit);

}  // namespace vbme_app
