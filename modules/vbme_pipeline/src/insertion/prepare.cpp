// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// prepareInsertion: the preparation stages in order (inputs, camera path, room textures,
// albedo, lights) and the prepared scene's record, reused when the inputs have not changed.
#include <algorithm>
#include <filesystem>

#include "insertion/stages.hpp"

namespace cv {
namespace vbme {

namespace fs = std::filesystem;
using namespace insertion;

Camera PreparedInsertion::camera(int i) const {
    return pathCamera(path, i, scene);
}

namespace {

// The path tracer's settings of every frame.
Renderer::Params frameRenderParams(const InsertionParams& p, const Scene& prepared) {
    Renderer::Params rp = Renderer::Params::fromScene(prepared.render);
    if (p.spp > 0) rp.spp = p.spp;
    rp.threads = p.threads;
    rp.seed = frameSeed(prepared.render.seed, 0, SEEDS_FIXED);
    rp.texture_cone = (float)p.texture_cone;
    if (p.adaptive_min_spp > 0) {  // spp stays the reported budget; a pixel takes ≤ 4 × spp
        rp.adaptive_min_spp = std::min(p.adaptive_min_spp, rp.spp);
        rp.adaptive_error = (float)p.adaptive_error;
        rp.adaptive_roulette = (float)p.adaptive_roulette;
        rp.spp *= 4;
    }
    return rp;
}

}  // namespace

namespace {

PreparedInsertion prepareLimited(const InsertionParams& p, const PipelineProgress& progress,
                                 PipelineReport* report) {
    p.check();
    const std::string work = p.workFolder();
    if (report) report->work = work;

    Inputs in = readInputs(p, progress, report);
    if (report) report->frames_total = in.video.frames;
    GrainModel grain;  // the footage's noise, from the kept frames
    {
        ScopedTimer timer(stageSeconds(report, "grain"));
        grain = footageGrain(p, in.video.kept);
    }
    fs::create_directories(work);
    std::string path_file;
    CameraPath path = cameraPath(p, in, work, path_file, report);
    const std::string fp = fingerprint(p, in, path);

    PreparedInsertion out;
    out.path = path;
    out.frames = in.video.frames;
    out.timestamps = in.video.timestamps;
    out.fingerprint = fp;
    out.work = work;

    const std::string prepared_path = (fs::path(work) / "prepared_scene.yml").string();
    PreparedRecord rec;
    std::string found;
    const int state = readPrepared(prepared_path, fp, out.scene, rec, found);
    if (state < 0 && !p.force)
        CV_Error(Error::StsBadArg,
                 format("the work folder '%s' holds a prepared scene made from other inputs or "
                        "options (fingerprint %s, these inputs give %s): use another --work, "
                        "delete it, or pass --force to prepare it again",
                        work.c_str(), found.empty() ? "unknown" : found.c_str(), fp.c_str()));
    if (state < 0) {  // --force: the old preparation and its frames go
        fs::remove(prepared_path);
        fs::remove_all(fs::path(work) / "frames");
        fs::remove_all(fs::path(work) / "exr");
    }
    if (state == 1) {
        out.reused = true;
    } else {
        const Scene& scene = in.scene;
        RoomRadiance radiance;
        {
            ScopedTimer timer(stageSeconds(report, "textures"));
            radiance = roomTextures(p, in, path, work, progress);
        }
        if (radiance.exposure) {  // every frame's gain against the room model
            ScopedTimer timer(stageSeconds(report, "exposure"));
            std::vector<int> texels;
            rec.gains = exposureGains(p, scene, path, *radiance.exposure, in.video.frames, progress,
                                      nullptr, &texels);
            rec.exposure_texels_min = *std::min_element(texels.begin(), texels.end());
        }
        if (p.shutter < 0) {  // motion blur: the shutter from the room's edges
            ScopedTimer timer(stageSeconds(report, "shutter"));
            if (progress) progress("shutter", 0, 1);
            rec.shutter_estimate = estimateShutter(scene, path, in.video.frames, work, p.video,
                                                   &rec.shutter_frame, &rec.shutter_motion_px);
            if (progress) progress("shutter", 1, 1);
        }
        in.video.kept.clear();     // the frames are no longer needed
        Scene room_scene = scene;  // the real room: no objects, no textures yet
        room_scene.objects.clear();
        room_scene.room.textures.clear();
        {
            ScopedTimer timer(stageSeconds(report, "albedo"));
            if (progress) progress("albedo", 0, 1);
            rec.white_scale = roomAlbedo(p, radiance, room_scene, work, fp);
            if (progress) progress("albedo", 1, 1);
        }
        {
            ScopedTimer timer(stageSeconds(report, "lights"));
            if (progress) progress("lights", 0, 1);
            rec.lights = roomLights(p, radiance, room_scene);
            if (progress) progress("lights", 1, 1);
        }
        // the prepared scene: albedo textures, scaled lights, objects placed
        Scene prepared = room_scene;
        prepared.objects = scene.objects;
        rec.fingerprint = fp;
        rec.scene = p.scene;
        rec.video = p.video;
        rec.cameras = path_file;
        rec.frames = in.video.frames;
        rec.texture_frames = radiance.texture_frames;
        writePrepared(prepared_path, prepared, p, rec);
        out.scene = Scene::read(prepared_path);
    }
    out.lights = rec.lights;
    out.white_scale = rec.white_scale;
    out.gains = rec.gains;
    out.gains.resize(out.frames, Vec3d(1, 1, 1));  // exposure off
    out.render = frameRenderParams(p, out.scene);
    out.composite.response = out.scene.camera.response;
    out.composite.shadows = p.shadows;
    out.denoise = p.denoise;
    // grain and motion blur
    out.grain = grain;
    out.grain_on = p.grain == InsertionParams::GRAIN_AUTO && grain.reliable;
    out.shutter = p.shutter;
    if (p.shutter < 0) {
        if (rec.shutter_estimate < -1) {  // a record from before the estimate: estimate now
            ScopedTimer timer(stageSeconds(report, "shutter"));
            if (progress) progress("shutter", 0, 1);
            rec.shutter_estimate = estimateShutter(out.scene, out.path, out.frames, work, p.video,
                                                   &rec.shutter_frame, &rec.shutter_motion_px);
            if (progress) progress("shutter", 1, 1);
        }
        // no motion to measure: a half-frame shutter (the blur it gives is then small)
        out.shutter = rec.shutter_estimate >= 0 ? rec.shutter_estimate : 0.5;
    }
    const bool shutter_estimated = p.shutter < 0 && rec.shutter_estimate >= 0;
    if (report) {
        report->setFigure("grain_on", out.grain_on ? 1 : 0);
        report->setFigure("grain_reliable", grain.reliable ? 1 : 0);
        report->setFigure("grain_sigma", grain.meanSigma());
        report->setFigure("grain_blur", grain.blur);
        report->setFigure("grain_correlation", grain.correlation);
        report->setFigure("grain_pixels", grain.pixels);
        for (size_t b = 0; b < grain.level.size(); ++b) {
            report->setFigure(format("grain_%d_level", (int)b), grain.level[b]);
            for (int c = 0; c < 3; ++c)
                report->setFigure(format("grain_%d_sigma_%c", (int)b, "bgr"[c]), grain.sigma[b][c]);
        }
        report->setFigure("shutter", out.shutter);
        report->setFigure("shutter_estimated", shutter_estimated ? 1 : 0);
        report->setFigure("shutter_frame", rec.shutter_frame);
        report->setFigure("shutter_motion_px", rec.shutter_motion_px);
        report->setFigure("prepared_reused", out.reused ? 1 : 0);
        report->setFigure("white_scale", out.white_scale);
        for (size_t i = 0; i < out.lights.scale.size(); ++i)
            for (int c = 0; c < 3; ++c)
                report->setFigure(format("light%d_scale_%c", (int)i, "rgb"[c]),
                                  out.lights.scale[i][c]);
        std::vector<std::pair<std::string, double>> gains;
        gains.reserve(3 * out.frames);
        for (int i = 0; i < out.frames; ++i)
            for (int c = 0; c < 3; ++c)
                gains.emplace_back(format("gain_%d_%c", i, "bgr"[c]), out.gains[i][c]);
        report->setFigures(gains);
        report->setFigure("exposure_texels_min", rec.exposure_texels_min);
    }
    return out;
}

}  // namespace

PreparedInsertion prepareInsertion(const InsertionParams& p, const PipelineProgress& progress,
                                   PipelineReport* report) {
    PreparedInsertion out;
    runLimited(p.threads, [&] { out = prepareLimited(p, progress, report); });
    return out;
}

}  // namespace vbme
}  // namespace cv
