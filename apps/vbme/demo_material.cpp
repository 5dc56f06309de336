// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme demo, part "material": renders a clip of an orange ball rolling on a textured floor
// (with its ground truth), tracks it as `vbme track` does, then edits it to chrome and to glass
// exactly as `vbme material-edit` does, and scores what can be scored against the truth.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/rendered_ball_clip.hpp>
#include <opencv2/vbme/pipeline/material_edit.hpp>
#include <opencv2/vbme/track.hpp>

#include "demo.hpp"

namespace vbme_app {

namespace {

namespace fs = std::filesystem;
using namespace cv;
using namespace cv::vbme;

double angleDeg(const Vec3d& a, const Vec3d& b) {
    const double c = a.dot(b) / (norm(a) * norm(b));
    return std::acos(std::max(-1.0, std::min(1.0, c))) * 180 / CV_PI;
}

}  // namespace

DemoResult runMaterialDemo(const DemoContext& ctx) {
    DemoResult result;
    const fs::path dir = ctx.dir;
    const std::string input = (dir / "input.mkv").string(),
                      first_mask = (dir / "first_mask.png").string(),
                      truth_csv = (dir / "truth.csv").string(),
                      overlay = (dir / "track_overlay.mp4").string(),
                      normals = (dir / "normals_00000.png").string(),
                      track_dir = (dir / "track").string(), chrome = (dir / "chrome.mp4").string(),
                      glass = (dir / "glass.mp4").string(),
                      chrome_steps = (dir / "chrome_steps").string();
    for (const std::string& f :
         {input, first_mask, truth_csv, overlay, normals, chrome, glass, chrome_steps})
        checkOverwrite(f, ctx.force);
    if (ctx.force) {  // a fresh run: no stale intermediates of an earlier one
        std::error_code ec;
        fs::remove_all(chrome_steps, ec);
    }

    // 1. The input a user would bring: a clip of a matte orange ball rolling on a tiled floor in
    //    front of a wall, lit by a key light and a sky, path traced; plus the frame-0 mask.
    RenderedBallClip::Params cp;
    cp.size = Size(ctx.width, ctx.height);
    cp.frames = ctx.frames > 0 ? ctx.frames : 60;
    cp.spp = ctx.spp > 0 ? ctx.spp : 8;
    const RenderedBallClip clip(cp);
    std::printf("demo material: rendering a %d-frame %dx%d clip of a rolling ball (%d spp) -> %s\n",
                cp.frames, cp.size.width, cp.size.height, cp.spp, input.c_str());
    auto t0 = std::chrono::steady_clock::now();
    clip.write(input, first_mask);
    clip.writeTruth(truth_csv);
    const double render_s = secondsSince(t0);
    result.figures.push_back(
        format("input: %d frames %dx%d path traced at %d spp in %.1f s "
               "(%.2f s/frame)",
               cp.frames, cp.size.width, cp.size.height, cp.spp, render_s, render_s / cp.frames));

    // 2. Tracking, as `vbme track` does it, with the overlay to watch; scored from the masks it
    //    saved against the ball's projected disk.
    TrackVideoOptions to;
    to.overlay = overlay;
    to.force = ctx.force;
    const TrackVideoSummary ts =
        trackVideo(input, imreadChecked(first_mask, IMREAD_GRAYSCALE), track_dir, to);
    double iou_sum = 0, iou_min = 1, err_sum = 0, err_max = 0;
    const int n = (int)ts.results.size();
    for (int i = 0; i < n; ++i) {
        Mat got = imreadChecked((fs::path(track_dir) / maskFileName(i)).string(), IMREAD_GRAYSCALE),
            truth;
        diskMask(cp.size, clip.truthDisk(i), truth);
        const double iou = maskIoU(got, truth);
        iou_sum += iou;
        iou_min = std::min(iou_min, iou);
        const double err = norm(ts.results[i].disk.center - clip.truthDisk(i).center);
        err_sum += err;
        err_max = std::max(err_max, err);
    }
    result.figures.push_back(
        format("tracking (vbme track): %d frames at %.0f frames/s, %d lost; IoU vs truth mean "
               "%.3f, worst %.3f; centre error mean %.2f px, worst %.2f px",
               n, ts.seconds > 0 ? n / ts.seconds : 0.0, ts.lost, n ? iou_sum / n : 0.0, iou_min,
               n ? err_sum / n : 0.0, err_max));
    {  // Sphere normals recovered from the frame-0 disk (the shape stage), as a picture.
        Mat height, mask, nrm, picture;
        sphereHeightMap(cp.size, ts.results[0].disk, height);
        diskMask(cp.size, ts.results[0].disk, mask);
        heightToNormals(height, mask, nrm, NORMALS_CENTRAL);
        normalMapImage(nrm, picture);
        imwriteAtomic(normals, picture);
    }

    // 3. The edits, as `vbme material-edit --material chrome|glass` would run them.
    const Vec3d truth_light = clip.truthLightDirCamera();
    struct Edit {
        const char* material;
        std::string out, steps;
    };
    for (const Edit& e : {Edit{"chrome", chrome, chrome_steps}, Edit{"glass", glass, ""}}) {
        MaterialEditParams mp;
        mp.video = input;
        mp.first_mask = first_mask;
        mp.out = e.out;
        mp.material = Material::preset(e.material);
        mp.shadows = shadowModeFor(mp.material);  // --shadows auto, the command's default
        mp.focal = clip.focal();
        mp.intermediates = e.steps;
        mp.force = ctx.force;
        mp.encode = ctx.encode;
        std::printf("demo material: editing the ball to %s -> %s\n", e.material, e.out.c_str());
        std::vector<MaterialEditor::FrameResult> frames;
        const PipelineReport r = runMaterialEdit(mp, PipelineProgress(), &frames);
        std::ostringstream table;
        r.print(table);
        std::fputs(table.str().c_str(), stdout);
        result.figures.push_back(format(
            "%s edit: %d frames in %.1f s (%.2f frames/s), %d lost", e.material, r.frames_processed,
            r.total_seconds, r.total_seconds > 0 ? r.frames_processed / r.total_seconds : 0.0,
            r.frames_lost));
        if (e.steps.size() && !frames.empty()) {  // the light fit is the same for both edits
            double mean = 0, worst = 0;
            for (const auto& f : frames) {
                const double a = angleDeg(f.to_light, truth_light);
                mean += a;
                worst = std::max(worst, a);
            }
            mean /= frames.size();
            const Vec3d l0 = frames[0].to_light / norm(frames[0].to_light);
            result.figures.push_back(format(
                "key light fitted to the ball's shading (camera coords): frame 0 (%.2f, "
                "%.2f, %.2f) vs truth (%.2f, %.2f, %.2f); angle error mean %.1f deg, "
                "worst %.1f deg",
                l0[0], l0[1], l0[2], truth_light[0], truth_light[1], truth_light[2], mean, worst));
        }
        if (e.steps.size() && !frames.empty()) {
            const Vec3d a = frames[0].albedo;
            result.figures.push_back(
                format("albedo estimated on frame 0 (RGB) (%.3f, %.3f, %.3f) vs truth (%.3f, "
                       "%.3f, %.3f) (equal up to the light's unknown strength)",
                       a[0], a[1], a[2], cp.albedo[0], cp.albedo[1], cp.albedo[2]));
        }
        result.watch.push_back(e.out + "  (the ball edited to " + e.material + ")");
    }
    result.watch.push_back(overlay + "  (the tracked disk drawn on the input)");
    result.watch.push_back(input + "  (the rendered input; truth in " + truth_csv +
                           ", intermediates of the chrome edit in " + chrome_steps + ")");
    return result;
}

}  // namespace vbme_app
