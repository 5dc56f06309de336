// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme bench: whole-pipeline figures on input made in code (per-stage figures are in perf/).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/vbme/track.hpp>
#if __has_include(<opencv2/vbme/render.hpp>)
#include <opencv2/vbme/render.hpp>
#define VBME_BENCH_RENDER 1
#endif
#if __has_include(<opencv2/vbme/pipeline.hpp>)
#include <opencv2/vbme/pipeline.hpp>
#define VBME_BENCH_PIPELINE 1
#endif

#include "command.hpp"

namespace vbme_app {

namespace {

struct BenchOptions {
    std::string what = "track";
    int width = 640, height = 480, frames = 300, threads = 1, spp = 32;
};

// Tracking throughput: frames made in memory first, so that only update() is timed.
void benchTrack(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    SyntheticBallClip::Params cp;
    cp.size = Size(o.width, o.height);
    cp.frames = 32;  // periodic: frame 31 leads back to frame 0
    const SyntheticBallClip clip(cp);
    std::vector<Mat> frames;
    for (int i = 0; i < cp.frames; ++i)
        frames.push_back(clip.frame(i));
    Mat first_mask, mask;
    diskMask(cp.size, clip.truth(0), first_mask);
    // The thesis's tracker, then each stage of issue 13 added in turn (the cost of each), then
    // the default without the window.
    ObjectTracker::Params thesis;
    thesis.colour_model = TRACK_COLOUR_HS;
    thesis.evidence_confidence = thesis.predict_motion = thesis.edge_refine = false;
    thesis.redetect = false;
    thesis.max_radius_change = 0;
    thesis.min_init_iou = 0;
    std::vector<std::pair<std::string, ObjectTracker::Params>> configs;
    configs.emplace_back("thesis HS", thesis);
    ObjectTracker::Params p = thesis;
    p.colour_model = TRACK_COLOUR_AUTO;
    configs.emplace_back("+colour model", p);
    p.predict_motion = true;
    p.max_radius_change = ObjectTracker::Params().max_radius_change;
    configs.emplace_back("+motion", p);
    p.evidence_confidence = true;
    configs.emplace_back("+evidence", p);
    p.edge_refine = true;
    configs.emplace_back("+edge refine", p);
    p.redetect = true;
    configs.emplace_back("default", p);
    p.use_search_window = false;
    configs.emplace_back("default, whole frame", p);
    double base_fps = 0;
    for (const auto& cfg : configs) {
        const ObjectTracker::Params& p = cfg.second;
        // Accuracy over one period, untimed; then the timed run on a fresh tracker.
        double iou = 0;
        Ptr<ObjectTracker> t = ObjectTracker::create(p);
        t->init(frames[0], first_mask);
        for (int i = 0; i < cp.frames; ++i) {
            Mat truth;
            t->update(frames[i], mask);
            diskMask(cp.size, clip.truth(i), truth);
            iou += maskIoU(mask, truth) / cp.frames;
        }
        t = ObjectTracker::create(p);
        t->init(frames[0], first_mask);
        const auto t0 = std::chrono::steady_clock::now();
        for (int i = 0; i < o.frames; ++i)
            t->update(frames[i % cp.frames], mask);
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const double fps = o.frames / s;
        if (base_fps == 0) base_fps = fps;
        std::printf(
            "track %dx%d %-22s %8.1f frames/s  %.2fx thesis  (%d frames in %.2f s, %d thread%s, "
            "mean IoU %.3f)\n",
            o.width, o.height, cfg.first.c_str(), fps, fps / base_fps, o.frames, s, o.threads,
            o.threads == 1 ? "" : "s", iou);
    }
    std::printf("thesis (2013, 2.8 GHz dual core): ~6 frames/s\n");
}

#ifdef VBME_BENCH_RENDER
// Differential rendering on the Stanford bunny in a closed box under a ceiling light: one
// render, the one-pass differential render and two separate renders, at equal samples.
void benchDifferential(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    const char* env = std::getenv("VBME_DATA");
    const std::string bunny =
        std::string(env ? env : "../shared/data") + "/meshes/stanford-bunny.obj";
    if (!std::filesystem::exists(bunny))
        CV_Error(Error::StsError,
                 "'" + bunny + "' not found: set VBME_DATA to the folder holding meshes/");
    double ymin = 1e30;  // the bunny is y-up: its lowest point goes on the floor
    {
        std::ifstream in(bunny);
        std::string line;
        while (std::getline(in, line))
            if (line.rfind("v ", 0) == 0) {
                std::istringstream ss(line.substr(2));
                double x, y;
                ss >> x >> y;
                ymin = std::min(ymin, y);
            }
    }
    Scene scene;
    scene.image_size = Size(o.width, o.height);
    scene.has_room = true;
    scene.room.min = Vec3d(-1.5, -1.5, 0);
    scene.room.max = Vec3d(1.5, 1.5, 2.5);
    Light light;
    light.type = Light::POLYGON;  // wound counter-clockwise seen from below: lights the room
    light.corners = {Vec3d(-0.4, 0.4, 2.5), Vec3d(0.4, 0.4, 2.5), Vec3d(0.4, -0.4, 2.5),
                     Vec3d(-0.4, -0.4, 2.5)};
    light.radiance = Vec3d(10, 10, 10);
    scene.lights = {light};
    SceneObject obj;
    obj.mesh = bunny;
    obj.world_from_object =
        Matx44d(5, 0, 0, 0, 0, 0, -5, 0, 0, 5, 0, -5 * ymin, 0, 0, 0, 1);  // ×5, z up
    obj.has_material = true;
    obj.material.albedo = Vec3d(0.8, 0.7, 0.6);
    scene.objects = {obj};
    // Camera at (0.9, −1.4, 1.2) looking at (0, 0.1, 0.35), 50° vertical field of view.
    const Vec3d eye(0.9, -1.4, 1.2), z = normalize(Vec3d(0, 0.1, 0.35) - eye);
    const Vec3d x = normalize(z.cross(Vec3d(0, 0, 1))), y = z.cross(x);
    scene.camera =
        Camera::fromFocal(0.5 * o.height / std::tan(25.0 * CV_PI / 180.0), scene.image_size);
    scene.camera.R = Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
    scene.camera.t = -(scene.camera.R * eye);
    const Ptr<RenderScene> rs = RenderScene::create(scene);

    Renderer::Params rp;
    rp.spp = o.spp;
    rp.max_depth = 8;
    RenderImages single;
    const double t_single = Renderer::create(rp)->render(*rs, scene.camera, single).seconds;
    double t[2];
    DifferentialImages im[2];
    for (int m = 0; m < 2; ++m) {
        DifferentialRenderer::Params dp;
        dp.render = rp;
        dp.method = m == 0 ? DifferentialRenderer::ONE_PASS : DifferentialRenderer::TWO_PASS;
        t[m] = DifferentialRenderer::create(dp)->render(*rs, scene.camera, im[m]).seconds;
    }
    const double same = norm(im[0].diff, im[1].diff, NORM_INF);
    std::printf("differential %dx%d, %d spp, max depth 8, bunny in a box (%d threads):\n", o.width,
                o.height, o.spp, getNumThreads());
    std::printf("  one render            %7.2f s  1.00x\n", t_single);
    std::printf("  one-pass differential %7.2f s  %.2fx\n", t[0], t[0] / t_single);
    std::printf("  two separate renders  %7.2f s  %.2fx\n", t[1], t[1] / t_single);
    std::printf("  largest |diff| difference between the two: %g\n", same);
}
#endif

#ifdef VBME_BENCH_PIPELINE
// The insertion pipeline on a rendered hand-held room sequence with its true cameras (so COLMAP
// is not timed): every stage of runInsertion, and seconds per frame against one plain render
// of the same frame with the object (the peer measured in the same run).
void benchInsert(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    namespace fs = std::filesystem;
    const fs::path dir =
        fs::temp_directory_path() / format("vbme-bench-insert-%dx%d", o.width, o.height);
    SyntheticInsertionSequence::Params sp;
    sp.size = Size(o.width, o.height);
    sp.frames = 3;
    sp.spp = 8;  // the input only; the timed renders use --spp
    const SyntheticInsertionSequence seq(dir.string(), sp);
    std::printf("insert: rendering a %d-frame %dx%d input (cached in %s)\n", sp.frames, o.width,
                o.height, dir.string().c_str());
    seq.writeVideos();
    fs::remove_all(dir / "work");
    InsertionParams ip;
    ip.video = seq.inputVideoPath();
    ip.scene = seq.trueScenePath();
    ip.cameras = seq.trueCamerasPath();
    ip.out = (dir / "inserted.mkv").string();
    ip.work = (dir / "work").string();
    ip.spp = o.spp;
    ip.force = true;
    ip.quiet = true;
    const InsertionReport rep = runInsertion(ip);

    const Scene scene = Scene::read(seq.trueScenePath());
    Renderer::Params rp;
    rp.spp = o.spp;
    rp.max_depth = scene.render.max_depth;
    RenderImages single;
    const double t_single =
        Renderer::create(rp)->render(*RenderScene::create(scene), seq.cameras()[0], single).seconds;
    std::printf("insert %dx%d, %d spp, max depth %d, %d frames (%d threads):\n", o.width, o.height,
                o.spp, rp.max_depth, rep.frames_rendered, getNumThreads());
    for (const auto& kv : rep.seconds)
        std::printf("  %-10s %8.2f s\n", kv.first.c_str(), kv.second);
    std::printf(
        "  per frame (differential render + composite) %.2f s = %.2fx one plain render "
        "(%.2f s)\n",
        rep.seconds_per_frame, rep.seconds_per_frame / t_single, t_single);
    std::printf("thesis (2013, LuxRender, 603x804, 32 spp): ~15-20 min per frame\n");
}
#endif

void setupBench(CLI::App& app) {
    auto o = std::make_shared<BenchOptions>();
    app.add_option("what", o->what,
                   "What to measure: track (tracking throughput), differential (one-pass "
                   "differential rendering vs one and two renders; reads "
                   "$VBME_DATA/meshes/stanford-bunny.obj) or insert (vbme insert's stages and "
                   "seconds per frame on a rendered 3-frame room sequence, vs one plain render)")
        ->check(CLI::IsMember({"track", "differential", "insert"}))
        ->capture_default_str();
    app.add_option("--spp", o->spp, "Samples per pixel (differential, insert)")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    app.add_option("--width", o->width, "Frame width")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    app.add_option("--height", o->height, "Frame height")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    app.add_option("--frames", o->frames, "Frames to process (track)")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    app.add_option("--threads", o->threads,
                   "OpenCV threads for track (differential and insert render on all cores)")
        ->check(CLI::Range(1, 256))
        ->capture_default_str();
    app.callback([o] {
        cv::setNumThreads(o->threads);
        if (o->what == "track") benchTrack(*o);
#ifdef VBME_BENCH_RENDER
        if (o->what == "differential") {
            cv::setNumThreads(-1);
            benchDifferential(*o);
        }
#else
        if (o->what == "differential")
            CV_Error(cv::Error::StsError, "vbme was built without vbme_render");
#endif
#ifdef VBME_BENCH_PIPELINE
        if (o->what == "insert") {
            cv::setNumThreads(-1);
            benchInsert(*o);
        }
#else
        if (o->what == "insert")
            CV_Error(cv::Error::StsError, "vbme was built without vbme_pipeline");
#endif
    });
}

}  // namespace

VBME_REGISTER_COMMAND("bench", "Measure whole-pipeline speed on input made in code", setupBench);

}  // namespace vbme_app
