// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme render: path trace a scene file to OpenEXR (and optionally a PNG/JPEG).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct RenderOptions {
    std::string scene, out, png, cameras, filter = "box", integrator = "path", lights = "uniform";
    int spp = 0, max_depth = 0, threads = 0, width = 0, height = 0, frame = -1;
    long long seed = -1;
    float clamp = 0;
    bool no_objects = false, preview = false, no_lens = false;
    // differential rendering
    bool differential = false, independent = false;
    std::string background, composite, mask = "projected", frame_seeds = "fixed", shadows = "ratio";
    float alpha = 1.f;
    // adaptive sampling of --differential (vbme insert's defaults: --spp is the budget, a pixel
    // takes adaptive_min_spp … 4 × spp samples)
    int adaptive_min_spp = 2;
    float adaptive_error = 0.5f;
    CommonOptions common;
};

std::string lowerExt(const std::string& p) {
    std::string e = std::filesystem::path(p).extension().string();
    for (auto& c : e)
        c = char(std::tolower((unsigned char)c));
    return e;
}

// The header attribute of a render through a lens (Camera::k1; none without one, so renders of
// pinhole cameras keep their headers).
void addLensAttribute(std::map<std::string, std::string>& attr, const cv::vbme::Camera& camera) {
    if (camera.k1 != 0) attr["vbme.k1"] = cv::format("%.17g", camera.k1);
}

void runDifferential(const RenderOptions& o, const cv::vbme::Scene& scene,
                     const cv::vbme::Camera& camera, const cv::vbme::Renderer::Params& p) {
    using namespace cv::vbme;
    // The frame first: a wrong size is bad input, found before any rendering.
    const cv::Mat frame = imreadChecked(o.background, cv::IMREAD_ANYDEPTH | cv::IMREAD_COLOR);
    if (frame.size() != camera.image_size)
        CV_Error(cv::Error::StsBadSize,
                 cv::format("--background '%s' is %dx%d, the render is %dx%d (use --width/--height "
                            "or a frame of the render's size)",
                            o.background.c_str(), frame.cols, frame.rows, camera.image_size.width,
                            camera.image_size.height));
    if (frame.depth() != CV_8U && frame.depth() != CV_16U)
        CV_Error(cv::Error::StsBadArg,
                 "--background '" + o.background + "': expected an 8- or 16-bit image");
    DifferentialRenderer::Params dp;
    dp.render = p;
    dp.independent = o.independent;
    // adaptive sampling (one pass only), as vbme insert: --spp stays the budget, ≤ 4 × spp a pixel
    const bool adaptive = o.adaptive_min_spp > 0 && !o.independent;
    dp.render.adaptive_min_spp = adaptive ? std::min(o.adaptive_min_spp, p.spp) : 0;
    dp.render.adaptive_error = o.adaptive_error;
    dp.render.adaptive_roulette = 0;
    if (adaptive) dp.render.spp = 4 * p.spp;
    dp.coverage = parseCoverage(o.mask);
    cv::Ptr<RenderScene> rs = RenderScene::create(scene);
    DifferentialImages im;
    RenderStats st;
    // through the lens (camera.k1): rendered over the pinhole camera of everything the lens
    // shows, then warped to it, as vbme insert does
    const Camera cover = lensCoverCamera(camera);
    {
        Progress progress("render", (int64)cover.image_size.area() * (o.independent ? 2 : 1));
        st = DifferentialRenderer::create(dp)->render(*rs, cover, im, &progress);
    }
    distortLayersK1(im, camera, cover);
    CompositeParams cp;
    cp.alpha = o.alpha;
    cp.response = camera.response;
    cp.shadows = parseShadows(o.shadows, "--shadows");
    cv::Mat linear;
    compositeDifferential(frame, im, linear, cp);
    std::map<std::string, std::string> attr = {
        {"vbme.version", VBME_VERSION},
        {"vbme.commandLine", commandLine()},
        {"vbme.seed", std::to_string(p.seed)},
        {"vbme.spp", std::to_string(p.spp)},
        {"vbme.maxDepth", std::to_string(p.max_depth)},
        {"vbme.scene", o.scene},
        {"vbme.background", o.background},
        {"vbme.alpha", cv::format("%g", o.alpha)},
        {"vbme.shadows", o.shadows},
        {"vbme.response", toString(camera.response)},
        {"vbme.sampling",
         o.independent ? std::string("independent")
         : adaptive    ? cv::format("correlated, adaptive %d..%d spp, error %g, roulette 0",
                                    dp.render.adaptive_min_spp, dp.render.spp, o.adaptive_error)
                       : std::string("correlated")},
        {"vbme.samplesPerPixel",
         cv::format("%.3f", im.samples.empty() ? (double)p.spp : cv::mean(im.samples)[0])}};
    addLensAttribute(attr, camera);
    writeDifferentialExr(o.out, im, linear, attr);
    if (!o.composite.empty()) {
        cv::Mat enc;
        encodeComposite(linear, enc, camera.response, frame.depth());
        imwriteAtomic(o.composite, enc);
    }
    if (!o.png.empty()) {
        cv::Mat enc;
        if (o.preview)
            previewExposure(im.obj, enc);
        else
            encode(im.obj, enc, camera.response, CV_8U);
        imwriteAtomic(o.png, enc);
    }
    std::printf(
        "rendered %dx%d with and without the objects in %.2f s, %.2f samples/pixel "
        "(%s samples), %.3g paths/s\n",
        camera.image_size.width, camera.image_size.height, st.seconds,
        im.samples.empty() ? (double)p.spp : cv::mean(im.samples)[0],
        o.independent ? "independent" : "shared", st.seconds > 0 ? st.paths / st.seconds : 0.0);
}

void runRender(const RenderOptions& o) {
    using namespace cv::vbme;
    checkOverwrite(o.out, o.common.force);
    if (!o.png.empty()) checkOverwrite(o.png, o.common.force);
    if (!o.composite.empty()) checkOverwrite(o.composite, o.common.force);

    const Scene scene = Scene::read(o.scene);
    for (const std::string& w : scene.warnings())
        std::fprintf(stderr, "vbme: warning: %s: %s\n", o.scene.c_str(), w.c_str());
    Camera camera = scene.camera;
    if (!o.cameras.empty()) {
        const CameraPath path = CameraPath::read(o.cameras);
        if (o.frame < 0 || o.frame >= (int)path.frames.size())
            CV_Error(cv::Error::StsOutOfRange,
                     cv::format("--frame %d: the camera path '%s' has %d frames (0 … %d)", o.frame,
                                o.cameras.c_str(), (int)path.frames.size(),
                                (int)path.frames.size() - 1));
        if (path.k1 != 0 && std::abs(path.k1 - scene.camera.k1) > 1e-9)
            CV_Error(cv::Error::StsBadArg,
                     cv::format("the camera path '%s' records the lens k1 = %g, the scene's camera "
                                "k1 = %g",
                                o.cameras.c_str(), path.k1, scene.camera.k1));
        camera = path.camera((size_t)o.frame);
        camera.response = scene.camera.response;
        camera.k1 = scene.camera.k1;
        if (camera.image_size.area() <= 0) camera.image_size = scene.image_size;
    }
    if (o.width > 0) camera = camera.scaled(cv::Size(o.width, o.height));
    if (o.no_lens) camera.k1 = 0;

    Renderer::Params p = Renderer::Params::fromScene(scene.render);
    if (o.spp > 0) p.spp = o.spp;
    if (o.max_depth > 0) p.max_depth = o.max_depth;
    if (o.seed >= 0) p.seed = (uint64)o.seed;
    if (!o.cameras.empty()) p.seed = frameSeed(p.seed, o.frame, parseFrameSeeding(o.frame_seeds));
    p.threads = o.threads;
    p.filter = parseFilter(o.filter);
    p.clamp = o.clamp;
    p.integrator = o.integrator == "reference" ? Renderer::REFERENCE : Renderer::PATH;
    p.with_objects = !o.no_objects;
    p.light_selection = Renderer::parseLightSelection(o.lights);

    if (o.differential) {
        runDifferential(o, scene, camera, p);
        return;
    }
    cv::Ptr<RenderScene> rs = RenderScene::create(scene);
    cv::Ptr<Renderer> renderer = Renderer::create(p);
    RenderImages img;
    RenderStats st;
    const Camera cover = lensCoverCamera(camera);  // the lens's whole view (camera itself: none)
    {
        Progress progress("render", (int64)cover.image_size.area());
        st = renderer->render(*rs, cover, img, &progress);
    }
    for (cv::Mat* m : {&img.color, &img.albedo, &img.normal, &img.object, &img.mask})
        if (!m->empty()) distortImageK1(*m, *m, camera, cover);
    if (!img.samples.empty())
        distortImageK1(img.samples, img.samples, camera, cover, cv::INTER_NEAREST);
    std::map<std::string, std::string> attr = {{"vbme.version", VBME_VERSION},
                                               {"vbme.commandLine", commandLine()},
                                               {"vbme.seed", std::to_string(p.seed)},
                                               {"vbme.spp", std::to_string(p.spp)},
                                               {"vbme.maxDepth", std::to_string(p.max_depth)},
                                               {"vbme.scene", o.scene}};
    addLensAttribute(attr, camera);
    writeExr(o.out, img, attr);
    if (!o.png.empty()) {
        cv::Mat enc;
        if (o.preview)
            previewExposure(img.color, enc);
        else
            encode(img.color, enc, camera.response, CV_8U);
        imwriteAtomic(o.png, enc);
    }
    const int threads = o.threads > 0 ? o.threads : (int)std::thread::hardware_concurrency();
    std::printf("rendered %dx%d in %.2f s, %d samples/pixel, %.3g paths/s (%d threads)\n",
                camera.image_size.width, camera.image_size.height, st.seconds, p.spp,
                st.seconds > 0 ? st.paths / st.seconds : 0.0, threads);
}

void setupRender(CLI::App& app) {
    auto o = std::make_shared<RenderOptions>();
    app.footer(
        "Path trace a scene file (YAML/JSON, see doc/DESIGN.md) with next-event estimation and\n"
        "MIS. Writes a 32-bit float OpenEXR with channels R,G,B, albedo.R/G/B, N.X/Y/Z, object\n"
        "(fraction of paths that met an `objects:` mesh) and mask (fraction of camera rays\n"
        "that see one first), with the vbme version, the\n"
        "command line and the seed in its header. The result is bitwise identical for any\n"
        "--threads. Options left out take the scene's `render:` settings. With a lens in the\n"
        "scene (camera.k1) the images are as that lens shows them: rendered in the pinhole\n"
        "camera over everything the lens sees, then warped to it (header vbme.k1).");
    app.add_option("--scene", o->scene, "Scene file (YAML/JSON)")->required();
    app.add_option("--out", o->out, "Output OpenEXR file (.exr)")->required();
    app.add_option("--png", o->png,
                   "Also write an 8-bit image (PNG/JPEG) encoded with the camera response");
    app.add_flag("--preview", o->preview,
                 "Encode --png with a LuxRender-style exposure (ISO 320, f/2.8, 1 s, gamma 2.2) "
                 "instead of the camera response");
    app.add_option("--spp", o->spp, "Samples per pixel (default: the scene's)")
        ->check(CLI::PositiveNumber);
    app.add_option("--max-depth", o->max_depth, "Maximum number of bounces (default: the scene's)")
        ->check(CLI::PositiveNumber);
    app.add_option("--threads", o->threads, "Worker threads (default: all cores)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--seed", o->seed, "Sampler seed (default: the scene's)")
        ->check(CLI::NonNegativeNumber);
    auto* w = app.add_option("--width", o->width, "Render width (K is scaled)")
                  ->check(CLI::PositiveNumber);
    auto* h = app.add_option("--height", o->height, "Render height (K is scaled)")
                  ->check(CLI::PositiveNumber);
    w->needs(h);
    h->needs(w);
    auto* cams =
        app.add_option("--cameras", o->cameras,
                       "Camera-path file (YAML): its frame --frame replaces the scene's camera");
    auto* fr = app.add_option("--frame", o->frame, "Frame index in --cameras (from 0)")
                   ->check(CLI::NonNegativeNumber);
    cams->needs(fr);
    fr->needs(cams);
    app.add_option("--frame-seeds", o->frame_seeds,
                   "Seed across the frames of --cameras: fixed (the same sample pattern in every "
                   "frame, the default) or per-frame (hashed from the seed and --frame)")
        ->check(CLI::IsMember({"fixed", "per-frame"}))
        ->needs(cams);
    app.add_option("--filter", o->filter, "Pixel filter")
        ->check(CLI::IsMember({"box", "gaussian"}));
    app.add_option("--clamp", o->clamp, "Firefly clamp on a sample's largest channel (0: off)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--integrator", o->integrator,
                   "path (NEE + MIS) or reference (BSDF sampling only)")
        ->check(CLI::IsMember({"path", "reference"}));
    app.add_option("--light-selection", o->lights,
                   "How each vertex picks the light to sample: uniform or (mostly) by power")
        ->check(CLI::IsMember({"uniform", "power"}));
    app.add_flag("--no-lens", o->no_lens,
                 "Render the pinhole camera even when the scene has a lens (camera.k1): the "
                 "undistorted image, the same size");
    app.add_flag(
        "--no-objects", o->no_objects,
        "Render without the scene's objects: (the background pass of differential rendering)");
    auto* diff = app.add_flag("--differential", o->differential,
                              "Differential rendering: render with and without the objects in one "
                              "pass (same samples) and composite onto --background; the EXR gets "
                              "R,G,B (composite), obj.*, noobj.*, diff.*, mask, object");
    auto* bg = app.add_option("--background", o->background,
                              "The input frame to composite onto (display-encoded with the scene "
                              "camera's response, the render's size)");
    auto* comp = app.add_option("--composite", o->composite,
                                "Also write the composite encoded with the camera response "
                                "(.png; 16-bit if the background is)");
    auto* ind = app.add_flag("--independent", o->independent,
                             "Give the two renders unrelated samples (two passes; for comparison)");
    auto* al = app.add_option("--alpha", o->alpha, "Scale of the difference term (default 1)");
    auto* sh = app.add_option("--shadows", o->shadows,
                              "Shadows (negative difference): ratio (the frame loses the fraction "
                              "of light the render loses) or additive (frame + difference)")
                   ->check(CLI::IsMember({"ratio", "additive"}))
                   ->capture_default_str();
    auto* mk = app.add_option("--mask", o->mask,
                              "Coverage mask M: projected (triangles, 8x8 per pixel) or rays "
                              "(the renderer's camera rays)")
                   ->check(CLI::IsMember({"projected", "rays"}));
    auto* amin = app.add_option("--adaptive-min-spp", o->adaptive_min_spp,
                                "Adaptive sampling (as vbme insert, on by default): samples "
                                "every pixel takes first; a pixel where no path met an object "
                                "stops there, others go on until --adaptive-error is met, at "
                                "most 4 x --spp (0: off, every pixel takes --spp; off with "
                                "--independent)")
                     ->check(CLI::NonNegativeNumber)
                     ->capture_default_str();
    auto* aerr = app.add_option("--adaptive-error", o->adaptive_error,
                                "Adaptive sampling's target: 95 % half-width of a composite "
                                "pixel in 8-bit display values")
                     ->check(CLI::Range(1e-3, 255.0))
                     ->capture_default_str();
    diff->needs(bg);
    for (auto* opt : {bg, comp, ind, al, sh, mk, amin, aerr})
        opt->needs(diff);
    addCommonOptions(app, o->common);
    app.callback([o] {
        if (lowerExt(o->out) != ".exr") throw CLI::ValidationError("--out", "must be an .exr file");
        if (!o->png.empty()) {
            const std::string e = lowerExt(o->png);
            if (e != ".png" && e != ".jpg" && e != ".jpeg")
                throw CLI::ValidationError("--png", "must be a .png or .jpg file");
        }
        if (!o->composite.empty() && lowerExt(o->composite) != ".png")
            throw CLI::ValidationError("--composite", "must be a .png file");
        if (o->differential && o->no_objects)
            throw CLI::ValidationError("--differential", "excludes --no-objects");
        applyCommonOptions(o->common);
        runRender(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("render",
                      "Path trace a scene file to OpenEXR (deterministic, multi-threaded)",
                      setupRender);

}  // namespace vbme_app
