// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme insert: synthetic objects in a hand-held video of a room, lit by the room, composited
// by differential rendering (thesis chapter 5). A thin wrapper around cv::vbme::runInsertion.
#include <algorithm>
#include <cstdio>
#include <map>
#include <regex>

#include <opencv2/vbme/pipeline/insertion.hpp>

#include "command.hpp"
#include "pipeline_progress.hpp"

namespace vbme_app {

namespace {

struct InsertOptions {
    cv::vbme::InsertionParams p;
    std::string place, frames;
    // the command line's words for InsertionParams' enums
    std::string texture_mode = "accumulate", albedo = "irradiance", lights = "nnls",
                shadows = "ratio";
    std::string exposure = "auto";
    std::string grain = "auto", shutter = "auto";  // grain and motion blur
    CommonOptions common;
};

template <class E>
E fromWord(const std::string& word, std::initializer_list<E> values) {
    for (E v : values)
        if (cv::vbme::toString(v) == word) return v;
    throw CLI::ValidationError("'" + word + "' is not a valid choice");
}

void parseOptions(InsertOptions& o) {
    static const std::string num = R"(\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*)";
    if (!o.place.empty()) {
        std::smatch m;
        if (!std::regex_match(o.place, m, std::regex(num + "," + num)))
            throw CLI::ValidationError(
                "--place", "expected a frame-0 pixel as u,v (e.g. 320,400), got '" + o.place + "'");
        o.p.has_place = true;
        o.p.place = cv::Point2d(std::stod(m[1]), std::stod(m[2]));
    }
    if (!o.frames.empty()) {
        std::smatch m;
        if (!std::regex_match(o.frames, m, std::regex(R"((\d+):(\d*))")))
            throw CLI::ValidationError(
                "--frames", "expected A:B (frames A to B-1, from 0) or A: (to the end), got '" +
                                o.frames + "'");
        o.p.first = std::stoi(m[1]);
        o.p.end = m[2].length() ? std::stoi(m[2]) : -1;
        if (o.p.end >= 0 && o.p.end <= o.p.first)
            throw CLI::ValidationError("--frames", "A:B needs A < B, got '" + o.frames + "'");
    }
    using P = cv::vbme::InsertionParams;
    o.p.texture_mode = fromWord(o.texture_mode, {P::TEXTURE_ACCUMULATE, P::TEXTURE_PER_FRAME});
    o.p.albedo = fromWord(o.albedo, {P::ALBEDO_IRRADIANCE, P::ALBEDO_RETINEX});
    o.p.lights = fromWord(o.lights, {P::LIGHTS_NNLS, P::LIGHTS_HILL_CLIMB, P::LIGHTS_NONE});
    o.p.shadows = cv::vbme::parseShadows(o.shadows, "--shadows");
    o.p.exposure = fromWord(o.exposure, {P::EXPOSURE_AUTO, P::EXPOSURE_OFF});
    // grain and motion blur
    o.p.grain = fromWord(o.grain, {P::GRAIN_AUTO, P::GRAIN_OFF});
    if (o.shutter == "auto") {
        o.p.shutter = -1;
    } else if (o.shutter == "off") {
        o.p.shutter = 0;
    } else {
        std::smatch m;
        if (!std::regex_match(o.shutter, m, std::regex(num)) || std::stod(m[1]) < 0 ||
            std::stod(m[1]) > 1)
            throw CLI::ValidationError("--shutter",
                                       "expected auto, off or a fraction of the "
                                       "frame interval in [0, 1], got '" +
                                           o.shutter + "'");
        o.p.shutter = std::stod(m[1]);
    }
}

void runInsert(InsertOptions& o) {
    using namespace cv::vbme;
    o.p.force = o.common.force;
    o.p.command_line = commandLine();
    // The command owns its process: OpenCV's own loops (texture accumulation, resizing) honour
    // --threads too; the library limits only the work it starts (runLimited()).
    if (o.p.threads > 0) cv::setNumThreads(o.p.threads);
    if (!o.common.quiet) {
        const Scene scene = Scene::read(o.p.scene);
        for (const std::string& w : scene.warnings())
            std::fprintf(stderr, "vbme: warning: %s: %s\n", o.p.scene.c_str(), w.c_str());
    }
    const PipelineReport r = runInsertion(o.p, progressBars("insert"));
    const bool reused = r.figure("prepared_reused") != 0;
    if (o.p.prepare_only) {
        std::printf(
            "prepared %s for %d frames (%s); render them with --frames A:B and the same --work, "
            "--scene, --video (and one --spp for all the render runs)\n",
            r.work.c_str(), r.frames_total, reused ? "reused" : "made now");
        return;
    }
    std::printf(
        "frames %d:%d of %d: %d rendered, %d already done, %d being rendered by another process "
        "(%.2f s/frame at %d spp)\n",
        o.p.first, o.p.end < 0 ? r.frames_total : o.p.end, r.frames_total, r.frames_processed,
        r.frames_skipped, r.frames_busy, r.figure("seconds_per_frame"), (int)r.figure("spp"));
    std::string stages;
    for (const auto& kv : r.seconds)
        stages += cv::format("%s%s %.1f", stages.empty() ? "" : ", ", kv.first.c_str(), kv.second);
    std::printf("stages (s): %s%s\n", stages.c_str(), reused ? " (prepared scene reused)" : "");
    for (int i = 0; r.figure(cv::format("light%d_scale_r", i), -1) >= 0; ++i)
        std::printf("light %d scaled by (%.4g, %.4g, %.4g)\n", i,
                    r.figure(cv::format("light%d_scale_r", i)),
                    r.figure(cv::format("light%d_scale_g", i)),
                    r.figure(cv::format("light%d_scale_b", i)));
    if (o.p.exposure == cv::vbme::InsertionParams::EXPOSURE_AUTO) {
        double lo = 1e9, hi = 0;
        for (const auto& kv : r.figures)  // gain_<i>_<c>: one pass, however long the video
            if (kv.first.compare(0, 5, "gain_") == 0) {
                lo = std::min(lo, kv.second);
                hi = std::max(hi, kv.second);
            }
        if (hi > 0)
            std::printf(
                "exposure: frame gains %.3f … %.3f against frame 0 (per frame in report.yml)\n", lo,
                hi);
    }
    if (r.video_written) {
        std::printf("written: %s (report %s/report.yml)\n", o.p.out.c_str(), r.work.c_str());
    } else {
        std::string list;
        for (size_t i = 0; i < r.missing.size() && i < 20; ++i)
            list += (i ? " " : "") + std::to_string(r.missing[i]);
        if (r.missing.size() > 20) list += " …";
        std::printf(
            "%d of %d frames still missing (%s): %s not written yet; run the remaining "
            "--frames (same --work) to finish\n",
            (int)r.missing.size(), r.frames_total, list.c_str(), o.p.out.c_str());
    }
}

void setupInsert(CLI::App& app) {
    auto o = std::make_shared<InsertOptions>();
    app.footer(
        "Inserts the scene's objects: into a hand-held video of a room (thesis chapter 5).\n"
        "Stages: camera path (--cameras, or camera tracking with COLMAP into <work>/tracking),\n"
        "room textures from the video (every k-th frame, at most ~24 frames, linearised with\n"
        "the camera response; unseen texels inpainted), albedo, light estimation, then per\n"
        "frame a differential render (shared samples, fixed seed) composited onto the input\n"
        "frame. Work folder (default <out>_work): prepared_scene.yml (reused when made from\n"
        "the same inputs and options), frames/frame_%05d.png (frames already there are skipped:\n"
        "an interrupted run resumes), exr/ (--keep-exr), report.yml. The output video is\n"
        "written, with the input's audio, once every frame exists, so several machines can\n"
        "split one video with --frames A:B over a shared --work. See doc/vbme_pipeline_insert.md.");
    app.add_option("--video", o->p.video, "Input video file, image folder or %05d pattern")
        ->required();
    app.add_option("--scene", o->p.scene,
                   "Frame-0 scene file (vbme calibrate's output with objects:)")
        ->required();
    app.add_option("--cameras", o->p.cameras,
                   "Camera-path YAML (vbme track-camera); without it the camera is tracked");
    app.add_option("--out", o->p.out, "Output video (.mp4, .mkv, .avi) or %05d image pattern")
        ->required();
    app.add_option("--place", o->place,
                   "u,v: put objects[0]'s bounding-box bottom on the floor where this frame-0 "
                   "pixel looks");
    app.add_option("--spp", o->p.spp, "Samples per pixel (default: the scene's render.spp)")
        ->check(CLI::PositiveNumber);
    app.add_option("--frames", o->frames,
                   "A:B: render only frames A … B-1 (from 0; 'A:' to the end), e.g. one "
                   "machine's share of a render farm");
    app.add_flag("--prepare-only", o->p.prepare_only,
                 "Only prepare the work folder (camera path, textures, albedo, lights), render "
                 "nothing (the first run that renders records its sampling for the others): a "
                 "render farm prepares once, then its tasks run "
                 "--frames A:B (see vbme farm slurm)");
    app.add_option("--work", o->p.work, "Work folder (default: <out without extension>_work)");
    app.add_flag("--keep-exr", o->p.keep_exr,
                 "Keep per-frame multi-layer OpenEXRs (R,G,B composite, obj, noobj, diff, mask) "
                 "in <work>/exr");
    app.add_option("--texture-mode", o->texture_mode,
                   "accumulate: room textures from frames over the whole video; per-frame: "
                   "the thesis's frame-0 textures")
        ->check(CLI::IsMember({"accumulate", "per-frame"}))
        ->capture_default_str();
    app.add_option("--albedo", o->albedo,
                   "irradiance: texture / irradiance of the room's lights; retinex: Retinex "
                   "shading removal")
        ->check(CLI::IsMember({"irradiance", "retinex"}))
        ->capture_default_str();
    app.add_option("--lights", o->lights,
                   "Light estimation: nnls, hill-climb (thesis Eq. 5.1) or none (keep the "
                   "scene's powers)")
        ->check(CLI::IsMember({"nnls", "hill-climb", "none"}))
        ->capture_default_str();
    app.add_option("--white", o->p.white,
                   "Largest albedo of the room's surfaces: the light powers are raised (never "
                   "lowered) until the whitest surfaces reach it, for --albedo irradiance "
                   "(0: keep the annotated powers)")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    app.add_option("--shadows", o->shadows,
                   "How the objects' shadows go onto the footage: ratio (the footage loses the "
                   "fraction of light the model loses; never negative, follows the exposure) "
                   "or additive (Eq. 5.2: footage + with - without)")
        ->check(CLI::IsMember({"ratio", "additive"}))
        ->capture_default_str();
    app.add_flag("--per-frame-gain", o->p.per_frame_gain,
                 "Light estimation also fits one exposure gain per frame (auto-exposure)");
    // exposure and white balance per frame
    app.add_option("--exposure", o->exposure,
                   "auto: estimate each frame's exposure and white balance (per-channel gains) "
                   "against the room, build the room at frame 0's exposure and render the object "
                   "at each frame's; off: take every frame at one exposure")
        ->check(CLI::IsMember({"auto", "off"}))
        ->capture_default_str();
    app.add_option("--exposure-smooth", o->p.exposure_smooth,
                   "Half-width in frames of the gains' smoothing over time (0: none)")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    app.add_option("--grain", o->grain,
                   "auto: measure the footage's noise and add it to the object's pixels when "
                   "the measure is reliable; off: add none")
        ->check(CLI::IsMember({"auto", "off"}))
        ->capture_default_str();
    app.add_option("--shutter", o->shutter,
                   "Exposure as a fraction of the frame interval for the object's motion blur "
                   "from the camera path (e.g. 0.5); auto: estimated from the blur of the "
                   "room's edges; off: no motion blur")
        ->capture_default_str();
    app.add_option("--adaptive-min-spp", o->p.adaptive_min_spp,
                   "Adaptive sampling (on by default): samples every pixel takes first; a "
                   "pixel where no path met the object stops there, others go on until "
                   "--adaptive-error is met, at most 4 x --spp (0: off, every pixel takes --spp)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    app.add_option("--adaptive-error", o->p.adaptive_error,
                   "Adaptive sampling's target: 95 % half-width of a composite pixel in 8-bit "
                   "display values")
        ->check(CLI::Range(1e-3, 255.0))
        ->capture_default_str();
    app.add_option("--adaptive-roulette", o->p.adaptive_roulette,
                   "Probability that a pixel where no path met the object still goes on "
                   "(unbiased, noisier; 0: its difference stays exactly 0)")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    app.add_option("--texture-cone", o->p.texture_cone,
                   "Texture filtering after diffuse bounces: ray cone spread in radians (0: "
                   "off)")
        ->check(CLI::Range(0.0, 3.2))
        ->capture_default_str();
    app.add_option("--denoise", o->p.denoise,
                   "Denoise each frame's difference layer outside the objects with a joint "
                   "bilateral filter of this radius in pixels, guided by the frame (0: off)")
        ->check(CLI::Range(0, 16))
        ->capture_default_str();
    app.add_option("--threads", o->p.threads, "Worker threads (default: all cores)")
        ->check(CLI::NonNegativeNumber);
    addVideoOutputOptions(app, o->p.encode);
    addCommonOptions(app, o->common);
    app.callback([o] {
        parseOptions(*o);
        applyCommonOptions(o->common);
        runInsert(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("insert",
                      "Insert synthetic objects into a hand-held video of a room (differential "
                      "rendering)",
                      setupInsert);

}  // namespace vbme_app
