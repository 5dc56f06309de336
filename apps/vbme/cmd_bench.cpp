// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme bench: whole-pipeline figures on input made in code (per-stage figures are in perf/).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/datasets.hpp>
#include <opencv2/vbme/track.hpp>
#if __has_include(<opencv2/vbme/render.hpp>)
#include <opencv2/vbme/render.hpp>
#define VBME_BENCH_RENDER 1
#endif
#if __has_include(<opencv2/vbme/calib/camera_tracking.hpp>)
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/calib/camera_tracking.hpp>
#define VBME_BENCH_CALIB 1
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
    int ref_spp = 4096;         // insert: samples of the cached reference (0: no reference)
    int repeat = 3;             // render-peer, insert: interleaved rounds (the fastest counts)
    int max_depth = 4;          // render-peer: path length of both renderers
    int path_batch = -1;        // render-peer: Renderer::Params::path_batch (-1: its default)
    int min_spp = 2;            // insert: adaptive sampling's minimum (vbme insert's default)
    int adaptive_max_spp = 0;   // insert: adaptive sampling's maximum (0: 4 × --spp, as insert)
    double error = 0.5;         // insert: adaptive sampling's target (8-bit display values)
    double texture_cone = 0.1;  // insert: texture filtering variants: cone spread (radians)
    double roulette = 0;        // insert: adaptive variant: untouched pixels going on
    int denoise = 1;            // insert: radius of the denoised variants (vbme insert's default)
    int ref_chunk_spp = 256;    // insert: the reference is rendered and cached in chunks of this
    bool ref_only = false;      // insert: only render the reference's missing chunks
    bool ref_cached_only = false;  // insert: the reference from the cached chunks only
    std::vector<double> errors;    // insert: more variants: insert's setting at these targets
    std::vector<int> min_spps;     // insert: more variants: insert's setting at these minimums
    std::string cache;    // insert: where the reference is cached (default: the build folder's
                          // vbme-bench-cache, else ./vbme-bench-cache)
    bool moving = false;  // denoise: a hand-held (moving) camera instead of a static one
    std::string clip, methods = "keyframes,full";  // track-camera
    std::string colmap_database;  // track-camera: keyframes' COLMAP database to replay
    int seed = 0;                 // track-camera: COLMAP's first random seed
};

// CPU seconds of this process (self) and of its waited-for children.
double cpuSeconds(int who) {
    rusage u{};
    getrusage(who, &u);
    return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// CPU seconds of the calling thread.
double threadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// Tracking throughput: frames made in memory first, so that only update() is timed. Either
// the synthetic periodic clip (--width, --height) or, with --clip DIR, a real clip: DIR/clip.mp4,
// DIR/first_mask.png and optionally DIR/truth.csv (frame,cx,cy,r,visible_fraction; as written
// by scripts/blender/track_ball_clip.py), run from its first frame in whole passes.
void benchTrack(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    std::vector<Mat> frames;
    std::vector<Disk> truth;  // per frame; radius 0 = not scored
    bool periodic = true;
    Mat first_mask, mask;
    Size size(o.width, o.height);
    if (o.clip.empty()) {
        SyntheticBallClip::Params cp;
        cp.size = size;
        cp.frames = 32;  // periodic: frame 31 leads back to frame 0
        const SyntheticBallClip clip(cp);
        for (int i = 0; i < cp.frames; ++i) {
            frames.push_back(clip.frame(i));
            truth.push_back(clip.truth(i));
        }
        diskMask(cp.size, clip.truth(0), first_mask);
    } else {
        periodic = false;
        VideoReader reader(o.clip + "/clip.mp4");
        Mat f;
        while (reader.read(f))
            frames.push_back(f.clone());
        first_mask = imread(o.clip + "/first_mask.png", IMREAD_GRAYSCALE);
        if (frames.empty() || first_mask.empty() || first_mask.size() != frames[0].size())
            CV_Error(Error::StsError,
                     "bench track: '" + o.clip + "' needs clip.mp4 and first_mask.png of its size");
        size = frames[0].size();
        truth.assign(frames.size(), Disk());
        std::ifstream in(o.clip + "/truth.csv");
        std::string line;
        std::getline(in, line);  // header
        while (std::getline(in, line)) {
            int i = -1;
            float cx, cy, r, vis;
            if (std::sscanf(line.c_str(), "%d,%f,%f,%f,%f", &i, &cx, &cy, &r, &vis) == 5 &&
                i >= 0 && i < (int)truth.size() && vis >= 0.85f)
                truth[i] = Disk(Point2f(cx, cy), r);
        }
    }
    const int n = (int)frames.size();
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
    // Accuracy over the clip (one period), untimed: mean IoU over the frames with a truth.
    std::vector<double> iou(configs.size(), 0.0);
    for (size_t c = 0; c < configs.size(); ++c) {
        Ptr<ObjectTracker> t = ObjectTracker::create(configs[c].second);
        t->init(frames[0], first_mask);
        int scored = 0;
        for (int i = 0; i < n; ++i) {
            t->update(frames[i], mask);
            if (truth[i].radius <= 0) continue;
            Mat tm;
            diskMask(size, truth[i], tm);
            iou[c] += maskIoU(mask, tm);
            ++scored;
        }
        iou[c] /= std::max(1, scored);
    }
    // Timed: --repeat interleaved rounds of every configuration on a fresh tracker; the fastest
    // round counts. A periodic clip runs --frames frames in a loop; a real clip runs whole
    // passes from its first frame (a fresh tracker each, init() not timed) until --frames are
    // done. Frames/s per core from this thread's CPU time (the machine may be shared: wall time
    // then measures the other jobs too), wall-clock frames/s beside it.
    const int passes = periodic ? 1 : (o.frames + n - 1) / n;
    const int count = periodic ? o.frames : passes * n;
    std::vector<double> cpu(configs.size(), 1e30), wall(configs.size(), 1e30);
    for (int round = 0; round < o.repeat; ++round)
        for (size_t c = 0; c < configs.size(); ++c) {
            double cs = 0, ws = 0;
            for (int pass = 0; pass < passes; ++pass) {
                Ptr<ObjectTracker> t = ObjectTracker::create(configs[c].second);
                t->init(frames[0], first_mask);
                const int m = periodic ? o.frames : n;
                const double c0 = threadCpuSeconds();
                const auto t0 = std::chrono::steady_clock::now();
                for (int i = 0; i < m; ++i)
                    t->update(frames[i % n], mask);
                ws += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                cs += threadCpuSeconds() - c0;
            }
            wall[c] = std::min(wall[c], ws);
            cpu[c] = std::min(cpu[c], cs);
        }
    const double base = count / cpu[0];
    double prev = 0;
    for (size_t c = 0; c < configs.size(); ++c) {
        const double fps = count / cpu[c];
        const double ms = 1e3 * cpu[c] / count;
        // The stage's cost: CPU time per frame added to the configuration above it.
        const std::string stage = c == 0 ? "" : format("%+.3f ms/frame", ms - prev);
        prev = ms;
        std::printf(
            "track %dx%d %-22s %8.1f frames/s per core  %.2fx thesis  %.3f ms/frame %-17s "
            "(wall %.1f frames/s; %d frames, best of %d, %d thread%s, mean IoU %.3f)\n",
            size.width, size.height, configs[c].first.c_str(), fps, fps / base, ms, stage.c_str(),
            count / wall[c], count, o.repeat, o.threads, o.threads == 1 ? "" : "s", iou[c]);
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

#ifdef VBME_BENCH_RENDER
// ---- The peer scene: an open box room (floor, three walls) with a sphere and a box, diffuse,
// lit by one point light (no ambient light: Embree's pathtracer counts it twice past the first
// bounce). Written as OBJ + MTL for Embree's `pathtracer` and read by vbme from the same file.
struct PeerScene {
    std::string dir, obj;
    cv::vbme::Scene scene;
    cv::Ptr<cv::vbme::RenderScene> rs;
    cv::Ptr<cv::vbme::RenderScene> rs_fast;    // Embree's fast kernels alone, as the peer runs
    cv::Ptr<cv::vbme::RenderScene> rs_robust;  // Embree's robust mode on every ray
    cv::Vec3d eye{1.1, -3.4, 1.6}, target{-0.1, 0.3, 0.5}, light{0.4, -0.6, 1.9};
    double intensity = 8.0, fov_y = 45.0;

    PeerScene() {
        using namespace cv;
        using namespace cv::vbme;
        dir = (std::filesystem::temp_directory_path() /
               ("vbme-bench-peer-" + std::to_string(::getpid())))
                  .string();
        std::filesystem::create_directories(dir);
        obj = dir + "/scene.obj";
        std::ofstream o(obj);
        o << "mtllib scene.mtl\n";
        int nv = 0;
        auto quad = [&](const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
            for (const Vec3d* v : {&a, &b, &c, &d})
                o << "v " << (*v)[0] << " " << (*v)[1] << " " << (*v)[2] << "\n";
            o << "f " << nv + 1 << " " << nv + 2 << " " << nv + 3 << " " << nv + 4 << "\n";
            nv += 4;
        };
        o << "usemtl room\n";  // faces counter-clockwise seen from inside the room
        quad({-1.5, -1.5, 0}, {1.5, -1.5, 0}, {1.5, 1.5, 0}, {-1.5, 1.5, 0});
        quad({-1.5, 1.5, 0}, {1.5, 1.5, 0}, {1.5, 1.5, 2.5}, {-1.5, 1.5, 2.5});
        quad({-1.5, -1.5, 0}, {-1.5, 1.5, 0}, {-1.5, 1.5, 2.5}, {-1.5, -1.5, 2.5});
        quad({1.5, 1.5, 0}, {1.5, -1.5, 0}, {1.5, -1.5, 2.5}, {1.5, 1.5, 2.5});
        o << "usemtl box\n";  // a 0.6 m box, faces counter-clockwise seen from outside
        {
            const double x0 = -0.9, x1 = -0.3, y0 = 0.2, y1 = 0.8, z1 = 0.6;
            quad({x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1});
            quad({x0, y0, 0}, {x1, y0, 0}, {x1, y0, z1}, {x0, y0, z1});
            quad({x1, y1, 0}, {x0, y1, 0}, {x0, y1, z1}, {x1, y1, z1});
            quad({x1, y0, 0}, {x1, y1, 0}, {x1, y1, z1}, {x1, y0, z1});
            quad({x0, y1, 0}, {x0, y0, 0}, {x0, y0, z1}, {x0, y1, z1});
        }
        o << "usemtl ball\n";  // a UV sphere of radius 0.45 on the floor
        {
            const int nu = 48, nvv = 24;
            const Vec3d c(0.5, 0.1, 0.45);
            const double r = 0.45;
            const int base = nv + 1;
            for (int j = 0; j <= nvv; ++j)
                for (int i = 0; i < nu; ++i) {
                    const double th = CV_PI * j / nvv, ph = 2 * CV_PI * i / nu;
                    o << "v " << c[0] + r * std::sin(th) * std::cos(ph) << " "
                      << c[1] + r * std::sin(th) * std::sin(ph) << " " << c[2] + r * std::cos(th)
                      << "\n";
                    ++nv;
                }
            for (int j = 0; j < nvv; ++j)
                for (int i = 0; i < nu; ++i) {
                    const int a = base + j * nu + i, b = base + j * nu + (i + 1) % nu;
                    const int c2 = a + nu, d = b + nu;
                    o << "f " << a << " " << c2 << " " << d << "\n";
                    o << "f " << a << " " << d << " " << b << "\n";
                }
        }
        o.close();
        std::ofstream(dir + "/scene.mtl") << "newmtl room\nKd 0.6 0.6 0.6\nKs 0 0 0\n\n"
                                             "newmtl box\nKd 0.3 0.5 0.8\nKs 0 0 0\n\n"
                                             "newmtl ball\nKd 0.8 0.5 0.3\nKs 0 0 0\n";
        Light l;
        l.type = Light::POINT;
        l.position = light;
        l.intensity = Vec3d::all(intensity);
        scene.lights = {l};
        SceneObject so;
        so.mesh = obj;
        scene.objects = {so};
        rs = RenderScene::create(scene);
        RenderScene::Params fast;
        fast.robust = false;
        fast.retrace_leaks = false;
        rs_fast = RenderScene::create(scene, fast);
        RenderScene::Params robust;
        robust.robust = true;
        rs_robust = RenderScene::create(scene, robust);
    }
    ~PeerScene() {
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
    }
    cv::vbme::Camera camera(cv::Size sz) const {
        using namespace cv;
        const double f = 0.5 * sz.height / std::tan(fov_y * CV_PI / 360.0);
        vbme::Camera c = vbme::Camera::fromFocal(f, sz);
        const Vec3d z = normalize(target - eye), x = normalize(z.cross(Vec3d(0, 0, 1))),
                    y = z.cross(x);
        c.R = Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
        c.t = -(c.R * eye);
        c.response = vbme::Response::LINEAR;
        return c;
    }
    static std::string exe() {
        for (const char* p : {"/usr/bin/pathtracer", "/usr/bin/embree3_pathtracer"})
            if (std::filesystem::exists(p)) return p;
        return "";
    }
    // Runs Embree's pathtracer; wall seconds in *wall, children's CPU seconds returned in *cpu.
    bool runPeer(cv::Size sz, int spp, int depth, int threads, const std::string& out, double* wall,
                 double* cpu) const {
        auto num = [](double v) { return cv::format("%g", v); };
        const std::vector<std::string> argv = {exe(),
                                               "-i",
                                               obj,
                                               "--vp",
                                               num(eye[0]),
                                               num(eye[1]),
                                               num(eye[2]),
                                               "--vi",
                                               num(target[0]),
                                               num(target[1]),
                                               num(target[2]),
                                               "--vu",
                                               "0",
                                               "0",
                                               "1",
                                               "--fov",
                                               num(fov_y),
                                               "--size",
                                               std::to_string(sz.width),
                                               std::to_string(sz.height),
                                               "--pointlight",
                                               num(light[0]),
                                               num(light[1]),
                                               num(light[2]),
                                               num(intensity),
                                               num(intensity),
                                               num(intensity),
                                               "--spp",
                                               std::to_string(spp),
                                               "--max-path-length",
                                               std::to_string(depth),
                                               "--threads",
                                               std::to_string(threads),
                                               "-o",
                                               out};
        const double c0 = cpuSeconds(RUSAGE_CHILDREN);
        const cv::vbme::ProcessResult r = cv::vbme::runProcess(argv);
        *wall = r.seconds;
        *cpu = cpuSeconds(RUSAGE_CHILDREN) - c0;
        return r.ok();
    }
};

// vbme against Embree's own pathtracer on PeerScene: equal size, spp, path length, threads.
// The peer has no timer of its own: it runs at N and 2N spp and the difference is timed, so
// that loading and BVH building cancel. The images are compared by 16×16 block means in the
// peer's units (8-bit linear, clamped).
void benchRenderPeer(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    if (PeerScene::exe().empty())
        CV_Error(Error::StsError, "Embree's pathtracer not found (apt install embree-tools)");
    const PeerScene ps;
    const Size sz(o.width, o.height);
    const int threads = o.threads > 1 ? o.threads : 2;
    Renderer::Params rp;
    rp.spp = o.spp;
    rp.max_depth = o.max_depth;
    rp.threads = threads;
    rp.aovs = false;
    if (o.path_batch >= 0) rp.path_batch = o.path_batch;
    const Ptr<Renderer> r = Renderer::create(rp);
    std::printf(
        "render-peer %dx%d, %d spp, path length %d, %d threads, %d rounds, path batch %d "
        "(point-lit room with a sphere and a box):\n",
        sz.width, sz.height, o.spp, o.max_depth, threads, o.repeat, rp.path_batch);
    std::vector<double> ratio_wall, ratio_cpu, ratio_cpu_fast, ratio_cpu_robust;
    double best_v = 1e30, best_p = 1e30;
    RenderImages img, img_fast, img_robust;
    Mat peer;
    for (int round = 0; round < o.repeat; ++round) {
        const double c0 = cpuSeconds(RUSAGE_SELF);
        const RenderStats st = r->render(*ps.rs, ps.camera(sz), img);
        const double v_cpu = cpuSeconds(RUSAGE_SELF) - c0;
        const double c1f = cpuSeconds(RUSAGE_SELF);
        r->render(*ps.rs_fast, ps.camera(sz), img_fast);
        const double v_cpu_fast = cpuSeconds(RUSAGE_SELF) - c1f;
        const double c1r = cpuSeconds(RUSAGE_SELF);
        r->render(*ps.rs_robust, ps.camera(sz), img_robust);
        const double v_cpu_robust = cpuSeconds(RUSAGE_SELF) - c1r;
        double w1, c1, w2, c2;
        const std::string out = ps.dir + "/peer.ppm";
        if (!ps.runPeer(sz, o.spp, o.max_depth, threads, ps.dir + "/peer_n.ppm", &w1, &c1) ||
            !ps.runPeer(sz, 2 * o.spp, o.max_depth, threads, out, &w2, &c2))
            CV_Error(Error::StsError, "Embree's pathtracer failed");
        peer = imread(out, IMREAD_COLOR);
        const double paths = double(sz.area()) * o.spp;
        const double pw = paths / std::max(w2 - w1, 1e-6), pc = paths / std::max(c2 - c1, 1e-6);
        const double vw = paths / st.seconds, vc = paths / std::max(v_cpu, 1e-6);
        ratio_wall.push_back(vw / pw);
        ratio_cpu.push_back(vc / pc);
        ratio_cpu_fast.push_back(paths / std::max(v_cpu_fast, 1e-6) / pc);
        ratio_cpu_robust.push_back(paths / std::max(v_cpu_robust, 1e-6) / pc);
        best_v = std::min(best_v, st.seconds);
        best_p = std::min(best_p, w2 - w1);
        std::printf(
            "  round %d: vbme %.3f s (%.0f paths/s wall, %.0f paths/s CPU), pathtracer "
            "%.3f s (%.0f paths/s wall, %.0f paths/s CPU): %.2fx wall, %.2fx CPU; fast kernels "
            "alone: %.2fx CPU; robust mode on every ray: %.2fx CPU\n",
            round + 1, st.seconds, vw, vc, w2 - w1, pw, pc, vw / pw, vc / pc, ratio_cpu_fast.back(),
            ratio_cpu_robust.back());
    }
    auto median = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        return v[v.size() / 2];
    };
    // Image agreement (the 2N-spp peer image against vbme's N-spp one, block means).
    Mat mine;
    img.color.convertTo(mine, CV_8UC3, 255.0);
    const int B = 16;
    double se = 0, sum_v = 0, sum_p = 0, worst = 0;
    int blocks = 0;
    for (int y = 0; y + B <= sz.height; y += B)
        for (int x = 0; x + B <= sz.width; x += B) {
            const Rect rc(x, y, B, B);
            const double mv = mean(mine(rc).reshape(1))[0], mp = mean(peer(rc).reshape(1))[0];
            se += (mv - mp) * (mv - mp);
            worst = std::max(worst, std::abs(mv - mp));
            sum_v += mv;
            sum_p += mp;
            ++blocks;
        }
    const double rmse = std::sqrt(se / std::max(blocks, 1));
    const double mean_v = sum_v / std::max(blocks, 1), mean_p = sum_p / std::max(blocks, 1);
    const bool agree = std::abs(mean_v - mean_p) <= 0.03 * mean_p + 0.5 && rmse <= 3.0;
    std::printf(
        "  images: mean %.2f (vbme) vs %.2f (pathtracer) 8-bit linear; %dx%d block means "
        "differ by %.2f RMS, %.2f at most: %s\n",
        mean_v, mean_p, B, B, rmse, worst, agree ? "agree" : "DISAGREE");
    std::printf(
        "  vbme/pathtracer paths/s: %.2fx (wall, median of %d), %.2fx (CPU), %.2fx "
        "(fastest vs fastest)\n",
        median(ratio_wall), o.repeat, median(ratio_cpu), best_p / best_v);
    Mat diff_fast, diff_robust;
    absdiff(img.color, img_fast.color, diff_fast);
    absdiff(img.color, img_robust.color, diff_robust);
    std::printf(
        "  Embree's fast kernels alone (RenderScene::Params::retrace_leaks = false, as the peer "
        "runs): %.2fx (CPU, median); mean |difference| from the default %.2g (linear)\n",
        median(ratio_cpu_fast), mean(diff_fast.reshape(1))[0]);
    std::printf(
        "  Embree's robust mode on every ray (RenderScene::Params::robust = true): %.2fx (CPU, "
        "median); mean |difference| from the default %.2g (linear)\n",
        median(ratio_cpu_robust), mean(diff_robust.reshape(1))[0]);
    const std::string png =
        (std::filesystem::temp_directory_path() / "vbme_bench_peer.png").string();
    Mat both;
    hconcat(peer, mine, both);
    imwrite(png, both);
    std::printf("  side by side (pathtracer | vbme): %s\n", png.c_str());
}
#endif

#ifdef VBME_BENCH_CALIB
// Camera tracking: seconds per frame, per-stage times and accuracy per frame class of the
// keyframe + PnP method and of full COLMAP on the same clip with known cameras: a folder made by
// scripts/blender/camera_track_clip.py (--clip) or a rendered textured room made here.
void benchTrackCamera(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    namespace fs = std::filesystem;
    fs::path frames;
    Scene scene;
    std::vector<Camera> truth;
    if (!o.clip.empty()) {
        const fs::path clip(o.clip);
        frames = fs::exists(clip / "clip.mkv") ? clip / "clip.mkv" : clip / "frames";
        scene = Scene::read((clip / "scene.yml").string());
        const CameraPath t = CameraPath::read((clip / "truth.yml").string());
        for (size_t i = 0; i < t.frames.size(); ++i)
            truth.push_back(t.camera(i));
    } else {
        const fs::path dir = fs::temp_directory_path() / format("vbme-bench-track-camera-%dx%d-%d",
                                                                o.width, o.height, o.frames);
        frames = dir / "frames";
        scene = syntheticRoomScene(Size(o.width, o.height), 0.8 * o.width);
        // 1 cm per frame, at most 1 m (a longer walk leaves the 4 x 5 m room)
        truth = handheldCameraPath(scene.camera, o.frames, std::min(0.01 * o.frames, 1.0), 0.01,
                                   0.5, 5);
        if (!fs::exists(dir / "complete")) {
            fs::create_directories(frames);
            const auto textures = makeRoomTextures(3, 1024);
            Progress progress("render room frames", o.frames);
            for (int i = 0; i < o.frames; ++i) {
                imwrite((frames / format("frame_%05d.png", i)).string(),
                        renderTexturedRoom(truth[i], scene.room, textures, 2));
                progress.tick();
            }
            progress.finish();
            std::ofstream((dir / "complete").string()) << o.frames << "\n";
        }
        std::printf("track-camera: rendered textured room, %d frames %dx%d (cached in %s)\n",
                    o.frames, o.width, o.height, dir.string().c_str());
    }
    const int n = (int)truth.size();
    auto rotDeg = [](const Matx33d& a, const Matx33d& b) {
        const Matx33d d = a * b.t();
        return std::acos(std::max(-1.0, std::min(1.0, (trace(d) - 1) / 2))) * 180 / CV_PI;
    };
    struct Accuracy {
        double ate = 0, worst = 0, worst_rot = 0;
    };
    auto evaluate = [&](const std::string& label, const CameraPath& path,
                        const CameraTrackingReport& r) {
        Accuracy all;
        std::printf(
            "%s: %.1f s for %d frames = %.3f s/frame; %d keyframes, %d SfM, %d PnP, %d "
            "interpolated; reprojection RMS %.3f px (refined %.3f), PnP inlier RMS %.3f "
            "px\n",
            label.c_str(), r.seconds, n, r.seconds / n, r.keyframes, r.registered, r.pnp,
            r.interpolated, r.reprojection_rms, r.refined_rms, r.pnp_rms);
        std::string st;
        for (const auto& kv : r.stage_seconds)
            st += format("  %s %.1f s", kv.first.c_str(), kv.second);
        std::printf("  stages (wall):%s\n", st.c_str());
        st.clear();
        double cpu_sum = 0;
        for (const auto& kv : r.stage_cpu_seconds) {
            st += format("  %s %.3f", kv.first.c_str(), kv.second / n);
            cpu_sum += kv.second;
        }
        std::printf("  stages (CPU s/frame):%s  = %.3f CPU s/frame\n", st.c_str(), cpu_sum / n);
        if (r.ba_points > 0) {
            std::string moves;
            for (double v : r.ba_pass_moves)
                moves += format(" %.1f", 1000 * v);
            std::printf(
                "  joint adjustment%s: %d points, %d observations, RMS %.3f px (worst frame %.3f "
                "px), %.1f %% of the points on the box's faces; %zu pass(es), each moving a "
                "frame by at most (mm):%s\n",
                r.ba_applied ? "" : " (not applied)", r.ba_points, r.ba_observations, r.ba_rms,
                r.ba_worst_frame_rms, 100 * r.ba_on_face, r.ba_pass_moves.size(), moves.c_str());
        }
        std::string spreads;
        for (double v : r.mapper_scale_spreads)
            spreads += format(" %.4f", v);
        std::printf(
            "  confidence: scale spread %.4f (mapper runs:%s), points %.2f mm from the box's "
            "faces: %s\n",
            r.scale.spread, spreads.empty() ? " reused" : spreads.c_str(), 1000 * r.face_distance,
            r.confident ? "confident" : ("NOT confident: " + r.doubt).c_str());
        for (int src = -1; src < 3; ++src) {
            double se = 0, worst = 0, worst_rot = 0;
            int count = 0;
            for (int i = 0; i < n && i < (int)path.frames.size(); ++i) {
                if (src >= 0 && path.frames[i].source != src) continue;
                const Camera est = path.camera(i);
                const double e = norm(est.center() - truth[i].center());
                se += e * e;
                worst = std::max(worst, e);
                worst_rot = std::max(worst_rot, rotDeg(est.R, truth[i].R));
                ++count;
            }
            if (src < 0 && count) all = {std::sqrt(se / count), worst, worst_rot};
            if (count)
                std::printf(
                    "  %-12s %3d frames: ATE %.2f cm, worst %.2f cm, worst rotation "
                    "%.3f deg\n",
                    src < 0 ? "all" : CameraPath::sourceName((CameraPath::Source)src).c_str(),
                    count, 100 * std::sqrt(se / count), 100 * worst, worst_rot);
        }
        std::fflush(stdout);
        return all;
    };
    const fs::path work = fs::temp_directory_path() / "vbme-bench-track-camera-work";
    // The database to replay is copied first: it may lie in the work folder emptied below.
    const fs::path replay_db = fs::temp_directory_path() / "vbme-bench-track-camera-replay.db";
    if (!o.colmap_database.empty()) {
        fs::copy_file(o.colmap_database, replay_db, fs::copy_options::overwrite_existing);
        std::printf("track-camera: replaying the COLMAP database %s\n", o.colmap_database.c_str());
    }
    double full_spf = 0, key_spf = 0, full_cpu = 0, key_cpu = 0;
    Accuracy full_acc, key_acc;
    for (const std::string method : {"keyframes", "full"}) {
        if (o.methods.find(method) == std::string::npos) continue;
        fs::remove_all(work / method);
        CameraTrackingOptions opt;
        opt.method =
            method == "full" ? CameraTrackingOptions::FULL : CameraTrackingOptions::KEYFRAMES;
        opt.colmap.random_seed = o.seed;
        if (method == "keyframes" && !o.colmap_database.empty())
            opt.colmap.database = replay_db.string();
        CameraTrackingReport r;
        const double cpu0 = (cpuSeconds(RUSAGE_SELF) + cpuSeconds(RUSAGE_CHILDREN));
        const CameraPath path =
            trackCameraVideo(frames.string(), scene, (work / method).string(), opt, &r);
        const double cpu = (cpuSeconds(RUSAGE_SELF) + cpuSeconds(RUSAGE_CHILDREN)) - cpu0;
        (method == "full" ? full_acc : key_acc) = evaluate(method, path, r);
        std::printf("  CPU time (vbme and COLMAP): %.1f s = %.3f CPU s/frame\n", cpu, cpu / n);
        (method == "full" ? full_spf : key_spf) = r.seconds / n;
        (method == "full" ? full_cpu : key_cpu) = cpu / n;
        if (method == "keyframes") {
            // The same keyframes and PnP without the joint adjustment (COLMAP's run reused).
            opt.global_refine = false;
            const CameraPath no_joint =
                trackCameraVideo(frames.string(), scene, (work / method).string(), opt, &r);
            evaluate("keyframes + PnP without the joint adjustment", no_joint, r);
            // The same keyframes with the other frames interpolated (COLMAP's run reused).
            opt.pnp = false;
            const int keyframes = r.keyframes;
            const CameraPath interp =
                trackCameraVideo(frames.string(), scene, (work / method).string(), opt, &r);
            evaluate("keyframes, others interpolated (no PnP)", interp, r);
            if (o.methods.find("stride") != std::string::npos) {
                // As many keyframes at a fixed stride, the others by PnP.
                opt.pnp = true;
                opt.global_refine = true;
                opt.stride = std::max(2, (n + keyframes - 1) / std::max(1, keyframes));
                fs::remove_all(work / "stride");
                try {
                    const CameraPath strided = trackCameraVideo(
                        frames.string(), scene, (work / "stride").string(), opt, &r);
                    evaluate(format("fixed stride %d + PnP", opt.stride), strided, r);
                } catch (const cv::Exception& e) {
                    std::printf("fixed stride %d + PnP: failed: %s\n", opt.stride, e.err.c_str());
                }
            }
        }
    }
    double load[3] = {0, 0, 0};
    getloadavg(load, 3);
    std::printf("summary on %d frames (load average %.2f %.2f %.2f):\n", n, load[0], load[1],
                load[2]);
    if (key_cpu > 0)
        std::printf(
            "  keyframes + PnP + joint adjustment: %.3f CPU s/frame (%.3f wall s/frame); all "
            "frames ATE %.2f cm, worst %.2f cm, worst rotation %.3f deg\n",
            key_cpu, key_spf, 100 * key_acc.ate, 100 * key_acc.worst, key_acc.worst_rot);
    if (full_cpu > 0)
        std::printf(
            "  full COLMAP:                        %.3f CPU s/frame (%.3f wall s/frame); all "
            "frames ATE %.2f cm, worst %.2f cm, worst rotation %.3f deg\n",
            full_cpu, full_spf, 100 * full_acc.ate, 100 * full_acc.worst, full_acc.worst_rot);
    if (full_cpu > 0 && key_cpu > 0)
        std::printf("  keyframes + PnP: %.1fx less CPU per frame than full COLMAP (%.1fx wall)\n",
                    full_cpu / key_cpu, full_spf / key_spf);
}
#endif

#ifdef VBME_BENCH_PIPELINE
// The insertion pipeline on a rendered hand-held room sequence with its true cameras (so COLMAP
// is not timed): every stage of runInsertion, and seconds per frame against one plain render
// of the same frame with the object (the peer measured in the same run).
// With --denoise R, the last setting again with its difference layer denoised
// (denoiseDifference, as vbme insert --denoise R).
// The difference layer's denoising (vbme insert --denoise R), on a static camera or, with
// --moving, a hand-held one (the demo room's walk at its speed, 0.6 m in 24 frames). The
// footage's frames are renders with a seed each (their noise changes from frame to frame, as a
// sensor's does); the insertion's differential render uses one seed in every frame, as vbme
// insert does (so on a static camera it is the same in every frame), with vbme insert's
// sampling defaults; a high-spp render per frame (seeds of their own) is the reference. Per
// frame, the change the insertion makes in display values, E = composite − footage, is compared
// with the reference's E on the same footage: RMSE (error), and the mean |E(t+1) − E(t)|
// (flicker) over the pixels outside the object's coverage where the difference layer is not 0
// (in frame t or t+1). With a moving camera E changes also because the view does, as the
// reference's own flicker shows; what the insertion adds above it is its noise's flicker, also
// printed as the mean |e(t+1) − e(t)| of its error e = E − the reference's E (which holds the
// reference's own noise too).
void benchDenoise(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    namespace fs = std::filesystem;
    const int R = o.denoise > 0 ? o.denoise : 1;
    const int frames = std::max(2, std::min(o.frames, 24));
    const fs::path dir =
        fs::temp_directory_path() / format("vbme-bench-denoise-%dx%d%s", o.width, o.height,
                                           o.moving ? format("-moving%d", frames).c_str() : "");
    SyntheticInsertionSequence::Params sp;
    sp.size = Size(o.width, o.height);
    sp.frames = o.moving ? frames : 1;
    sp.spp = 8;  // the footage
    if (o.moving) {
        sp.travel *= frames / 24.0;  // the demo's walking speed
    } else {
        sp.travel = 0;
        sp.shake_m = 0;
        sp.shake_deg = 0;
    }
    const SyntheticInsertionSequence seq(dir.string(), sp);
    const Scene& scene = seq.trueScene();
    auto camera = [&](int t) { return seq.cameras()[o.moving ? t : 0]; };
    std::vector<Mat> footage(frames);
    for (int t = 0; t < frames; ++t) {
        Mat truth, region;
        seq.renderFrame(o.moving ? t : 0, footage[t], truth, region, sp.seed + 1000 + t);
    }
    const Ptr<RenderScene> rs = RenderScene::create(scene);
    CompositeParams cp;
    cp.response = camera(0).response;
    cp.shadows = CompositeParams::SHADOWS_RATIO;
    auto display = [&](const Mat& bg, const DifferentialImages& im) {
        Mat d;
        compositeDifferentialDisplay(bg, im, d, cp);
        return d;
    };
    // vbme insert's sampling defaults (adaptive 2 .. 4 × spp, texture cone 0.1), one seed
    DifferentialRenderer::Params dp;
    dp.render.spp = 4 * o.spp;
    dp.render.max_depth = scene.render.max_depth;
    dp.render.seed = scene.render.seed;
    dp.render.adaptive_min_spp = o.min_spp;
    dp.render.adaptive_error = (float)o.error;
    dp.render.texture_cone = (float)o.texture_cone;
    DifferentialRenderer::Params rp = dp;
    rp.render.spp = o.ref_spp > 0 ? o.ref_spp : 1024;
    rp.render.adaptive_min_spp = 0;
    std::printf("denoise: %dx%d %s camera, %d footage frames; reference %d spp per frame ...\n",
                o.width, o.height, o.moving ? "hand-held (moving)" : "static", frames,
                rp.render.spp);
    std::fflush(stdout);
    std::vector<DifferentialImages> im(o.moving ? frames : 1), ref(o.moving ? frames : 1);
    double paths = 0;
    for (size_t t = 0; t < im.size(); ++t) {
        paths += DifferentialRenderer::create(dp)->render(*rs, camera((int)t), im[t]).paths;
        rp.render.seed = scene.render.seed + 0x5eed + t;
        Progress progress(format("reference %d/%d", (int)t + 1, (int)ref.size()),
                          (int64)camera((int)t).image_size.area());
        DifferentialRenderer::create(rp)->render(*rs, camera((int)t), ref[t], &progress);
    }
    auto layersAt = [&](const std::vector<DifferentialImages>& v,
                        int t) -> const DifferentialImages& { return v[o.moving ? t : 0]; };
    // where it matters: outside the coverage, where the difference layer is not 0
    std::vector<Mat> regions(frames);
    for (int t = 0; t < frames; ++t) {
        const DifferentialImages& l = layersAt(im, t);
        regions[t] = Mat(l.diff.size(), CV_8U, Scalar(0));
        for (int y = 0; y < l.diff.rows; ++y)
            for (int x = 0; x < l.diff.cols; ++x)
                regions[t].at<uchar>(y, x) =
                    l.mask.at<float>(y, x) == 0 && l.diff.at<Vec3f>(y, x) != Vec3f(0, 0, 0);
    }
    const int n_region = countNonZero(regions[0]);
    struct Result {
        std::string name;
        double rmse = 0, flicker = 0, error_flicker = 0, ms = 0;
    };
    std::vector<Result> res;
    for (int r : {0, R}) {
        Result out;
        out.name = r ? format("denoised (r %d)", r) : std::string("not denoised");
        Mat prev_e, prev_ref_e;
        double flick = 0, flick_ref = 0, flick_err = 0, se = 0;
        for (int t = 0; t < frames; ++t) {
            DifferentialImages layers = layersAt(im, t);
            layers.diff = layers.diff.clone();
            const double c0 = cpuSeconds(RUSAGE_SELF);
            if (r) denoiseDifference(layers, footage[t], r);
            out.ms += 1000 * (cpuSeconds(RUSAGE_SELF) - c0) / frames;
            Mat bg;
            footage[t].convertTo(bg, CV_32FC3);
            const Mat e = display(footage[t], layers) - bg;
            const Mat ref_e = display(footage[t], layersAt(ref, t)) - bg;
            Mat d = e - ref_e;
            se += mean(Mat(d.mul(d)).reshape(1))[0] / frames;
            if (t > 0) {
                const Mat region = regions[t] | regions[t - 1];
                flick += mean(abs(e - prev_e), region)[0] / (frames - 1);
                flick_ref += mean(abs(ref_e - prev_ref_e), region)[0] / (frames - 1);
                flick_err +=
                    mean(abs((e - ref_e) - (prev_e - prev_ref_e)), region)[0] / (frames - 1);
            }
            prev_e = e;
            prev_ref_e = ref_e;
        }
        out.rmse = std::sqrt(se);
        out.flicker = flick;
        out.error_flicker = flick_err;
        res.push_back(out);
        if (!r) {
            Result rr;
            rr.name = "reference";
            rr.flicker = flick_ref;
            res.push_back(rr);
        }
    }
    double footage_flicker = 0;
    for (int t = 1; t < frames; ++t) {
        Mat a, b;
        footage[t].convertTo(a, CV_32FC3);
        footage[t - 1].convertTo(b, CV_32FC3);
        footage_flicker += mean(abs(a - b), regions[t] | regions[t - 1])[0] / (frames - 1);
    }
    std::printf(
        "  insertion render: %.1f spp mean; region (outside the coverage, difference != 0): "
        "%d pixels in frame 0; footage's own frame-to-frame change there %.3f\n",
        paths / (double(footage[0].total()) * im.size()), n_region, footage_flicker);
    for (const Result& r : res) {
        if (r.name == "reference")
            std::printf("  %-20s flicker %.3f (8-bit display, mean |E(t+1) - E(t)|)\n",
                        r.name.c_str(), r.flicker);
        else
            std::printf(
                "  %-20s RMSE %.3f against the reference, flicker %.3f, its error's flicker "
                "%.3f (mean |e(t+1) - e(t)|, e = E - the reference's E; 8-bit display), "
                "%.1f ms CPU per frame\n",
                r.name.c_str(), r.rmse, r.flicker, r.error_flicker, r.ms);
    }
}

// FNV-1a over bytes, continuing from @p h.
uint64_t fnv1a(const void* data, size_t n, uint64_t h = 1469598103934665603ull) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i)
        h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

uint64_t fnv1aFile(const std::filesystem::path& file, uint64_t h) {
    std::ifstream in(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    h = fnv1a(file.filename().string().data(), file.filename().string().size(), h);
    return fnv1a(bytes.data(), bytes.size(), h);
}

// Sum of differential layers (for averaging renders of equal spp).
void addLayers(cv::vbme::DifferentialImages& sum, const cv::vbme::DifferentialImages& im) {
    auto add = [](cv::Mat& s, const cv::Mat& m) {
        if (m.empty()) return;
        if (s.empty())
            s = m.clone();
        else
            s += m;
    };
    add(sum.obj, im.obj);
    add(sum.noobj, im.noobj);
    add(sum.diff, im.diff);
    add(sum.mask, im.mask);
    add(sum.object, im.object);
}

cv::vbme::DifferentialImages scaledLayers(const cv::vbme::DifferentialImages& sum, double s) {
    cv::vbme::DifferentialImages out;
    auto sc = [s](const cv::Mat& m) { return m.empty() ? cv::Mat() : cv::Mat(m * s); };
    out.obj = sc(sum.obj);
    out.noobj = sc(sum.noobj);
    out.diff = sc(sum.diff);
    out.mask = sc(sum.mask);
    out.object = sc(sum.object);
    return out;
}

double rmseOf(const cv::Mat& a, const cv::Mat& b) {
    cv::Mat d = a - b;
    return std::sqrt(cv::mean(cv::Mat(d.mul(d)).reshape(1))[0]);
}

// The default folder of the bench's cached renders: the build folder's vbme-bench-cache when
// the program runs from its build folder, else ./vbme-bench-cache.
std::filesystem::path defaultBenchCache() {
#ifdef VBME_BUILD_DIR
    if (std::filesystem::is_directory(VBME_BUILD_DIR))
        return std::filesystem::path(VBME_BUILD_DIR) / "vbme-bench-cache";
#endif
    return std::filesystem::current_path() / "vbme-bench-cache";
}

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
    const InsertionParams insert_defaults = ip;  // every sampling field at vbme insert's default
    if (!o.ref_only) {
        const PipelineReport rep = runInsertion(ip);
        std::printf("insert %dx%d, %d frames, vbme insert's defaults (%d spp), %d threads:\n",
                    o.width, o.height, rep.frames_processed, (int)rep.figure("spp"),
                    getNumThreads());
        for (const auto& kv : rep.seconds)
            std::printf("  %-10s %8.2f s\n", kv.first.c_str(), kv.second);
        std::printf("  per frame (differential render + composite) %.2f s\n",
                    rep.figure("seconds_per_frame"));
    } else {
        InsertionParams pp = ip;
        pp.prepare_only = true;
        runInsertion(pp);
    }

    // Frame 0 again, from the prepared scene, with each sampling setting; the composite's
    // error against a high-spp reference (other seeds) in 8-bit display values.
    const Scene scene = Scene::read((dir / "work" / "prepared_scene.yml").string());
    Camera cam = seq.cameras()[0];
    cam.response = scene.camera.response;
    cam.image_size = scene.image_size;
    Mat bg;
    {
        VideoReader reader(seq.inputVideoPath());
        reader.read(bg);
    }
    const Ptr<RenderScene> rs = RenderScene::create(scene);
    CompositeParams cp;
    cp.response = cam.response;
    cp.shadows = CompositeParams::SHADOWS_RATIO;  // as vbme insert composites
    auto display = [&](const DifferentialImages& im) {
        Mat d;
        compositeDifferentialDisplay(bg, im, d, cp);
        return d;
    };
    Renderer::Params base;
    base.max_depth = scene.render.max_depth;
    base.seed = scene.render.seed;

    // The reference: uniform renders of --ref-chunk-spp each with seeds of their own (base
    // seed + 0x5eed + k), each cached as a multi-layer EXR (written to a temporary name, then
    // renamed) under a key of everything the render depends on: the prepared scene (its
    // temporary folder's name left out), the files it reads, frame 0 of the footage, the chunk
    // spp, path length and seed. Their layers are averaged; the even and odd chunks' averages
    // (two independent halves) give the reference's own noise.
    Mat ref;
    double ref_noise = 0;
    int ref_spp = 0;
    if (o.ref_spp > 0) {
        std::string text;
        {
            std::ifstream in(dir / "work" / "prepared_scene.yml");
            std::stringstream ss;
            ss << in.rdbuf();
            text = ss.str();
        }
        for (size_t at; (at = text.find(dir.string())) != std::string::npos;)
            text.replace(at, dir.string().size(), "<dir>");
        uint64_t key = fnv1a(text.data(), text.size());
        std::vector<fs::path> inputs;
        for (const auto& e : fs::recursive_directory_iterator(dir / "work" / "albedo"))
            if (e.is_regular_file()) inputs.push_back(e.path());
        std::sort(inputs.begin(), inputs.end());
        inputs.push_back(dir / "object.obj");
        for (const fs::path& f : inputs)
            key = fnv1aFile(f, key);
        CV_Assert(bg.isContinuous());
        key = fnv1a(bg.data, bg.total() * bg.elemSize(), key);
        const int64 settings[3] = {o.ref_chunk_spp, base.max_depth, (int64)base.seed};
        key = fnv1a(settings, sizeof(settings), key);
        const fs::path cache = (o.cache.empty() ? defaultBenchCache() : fs::path(o.cache)) /
                               format("insert-ref-%dx%d-%dspp-%016llx", o.width, o.height,
                                      o.ref_chunk_spp, (unsigned long long)key);
        fs::create_directories(cache);
        const int chunks = (o.ref_spp + o.ref_chunk_spp - 1) / o.ref_chunk_spp;
        std::printf("  reference: %d chunks of %d spp (seeds of their own), cached in %s\n", chunks,
                    o.ref_chunk_spp, cache.string().c_str());
        std::fflush(stdout);
        DifferentialImages sum[2];
        int count[2] = {0, 0};
        for (int k = 0; k < chunks; ++k) {
            const fs::path file = cache / format("chunk-%04d.exr", k);
            DifferentialImages im;
            if (fs::exists(file)) {
                im = readDifferentialExr(file.string());
            } else if (o.ref_cached_only) {
                continue;
            } else {
                DifferentialRenderer::Params dp;
                dp.render = base;
                dp.render.spp = o.ref_chunk_spp;
                dp.render.seed = base.seed + 0x5eed + k;
                Progress progress(format("reference chunk %d/%d", k + 1, chunks),
                                  (int64)bg.total());
                const RenderStats st =
                    DifferentialRenderer::create(dp)->render(*rs, cam, im, &progress);
                progress.finish();
                const std::string tmp = file.string() + format(".tmp%d.exr", (int)getpid());
                writeDifferentialExr(tmp, im);
                fs::rename(tmp, file);
                std::printf("  reference chunk %d/%d: %.1f s\n", k + 1, chunks, st.seconds);
                std::fflush(stdout);
            }
            addLayers(sum[k % 2], im);
            ++count[k % 2];
        }
        if (o.ref_only) return;
        if (count[0] + count[1] < 2)
            CV_Error(Error::StsError,
                     format("the reference needs at least 2 cached chunks (%d found in %s)",
                            count[0] + count[1], cache.string().c_str()));
        DifferentialImages all;
        addLayers(all, sum[0]);
        addLayers(all, sum[1]);
        const double a = count[0], b = count[1];
        ref = display(scaledLayers(all, 1.0 / (a + b)));
        const double halves =
            rmseOf(display(scaledLayers(sum[0], 1 / a)), display(scaledLayers(sum[1], 1 / b)));
        // var(A − B) = v (1/a + 1/b) for a chunk's variance v; the whole has v / (a + b)
        ref_noise = halves * std::sqrt(a * b) / (a + b);
        ref_spp = (count[0] + count[1]) * o.ref_chunk_spp;
        std::printf(
            "  reference: %d spp (%d of %d chunks%s); its two halves differ by RMSE %.3f, so its "
            "own noise is %.3f (8-bit display)\n",
            ref_spp, count[0] + count[1], chunks,
            count[0] + count[1] < chunks ? ", NOT the asked --ref-spp" : "", halves, ref_noise);
    }
    struct Variant {
        std::string name;
        Renderer::Params p;
        int denoise = 0;  // radius of the difference layer's filter (denoiseDifference; 0: off)
        double best = 1e30, cpu = 1e30, rmse = -1, spp = 0, untouched = 0;
    };
    auto adaptive = [&](Renderer::Params p, int min_spp, double error) {
        p.spp = o.adaptive_max_spp > 0 ? o.adaptive_max_spp : 4 * o.spp;
        p.adaptive_min_spp = min_spp;
        p.adaptive_error = (float)error;
        p.adaptive_roulette = (float)o.roulette;
        return p;
    };
    Renderer::Params uniform = base;
    uniform.spp = o.spp;
    Renderer::Params cone = base;
    cone.texture_cone = (float)o.texture_cone;
    const std::string ad =
        format("adaptive %d..%d, error %.2g", o.min_spp,
               o.adaptive_max_spp > 0 ? o.adaptive_max_spp : 4 * o.spp, o.error) +
        (o.roulette > 0 ? format(", roulette %.2g", o.roulette) : "");
    const std::string tc = format("cone %.2g", o.texture_cone);
    const std::string dn = o.denoise > 0 ? format(", denoise %d", o.denoise) : std::string();
    Renderer::Params uniform_cone = uniform;
    uniform_cone.texture_cone = (float)o.texture_cone;
    std::vector<Variant> vs = {
        {format("uniform %d spp", o.spp), uniform},
        {format("uniform %d spp, ", o.spp) + tc, uniform_cone},
    };
    if (o.denoise > 0) vs.push_back({format("uniform %d spp", o.spp) + dn, uniform, o.denoise});
    vs.push_back({ad, adaptive(base, o.min_spp, o.error)});
    vs.push_back({ad + ", " + tc, adaptive(cone, o.min_spp, o.error)});
    if (o.denoise > 0) {
        vs.push_back({ad + dn, adaptive(base, o.min_spp, o.error), o.denoise});
        vs.push_back({ad + ", " + tc + dn, adaptive(cone, o.min_spp, o.error), o.denoise});
    }
    const int max_spp = o.adaptive_max_spp > 0 ? o.adaptive_max_spp : 4 * o.spp;
    for (double e : o.errors)
        vs.push_back({format("adaptive %d..%d, error %.2g, ", o.min_spp, max_spp, e) + tc + dn,
                      adaptive(cone, o.min_spp, e), o.denoise});
    for (int m : o.min_spps)
        vs.push_back({format("adaptive %d..%d, error %.2g, ", m, max_spp, o.error) + tc + dn,
                      adaptive(cone, m, o.error), o.denoise});
    // vbme insert's defaults, whatever the options above say
    {
        Renderer::Params p = base;
        p.spp = o.spp;
        p.texture_cone = (float)insert_defaults.texture_cone;
        if (insert_defaults.adaptive_min_spp > 0) {
            p.adaptive_min_spp = std::min(insert_defaults.adaptive_min_spp, p.spp);
            p.adaptive_error = (float)insert_defaults.adaptive_error;
            p.adaptive_roulette = (float)insert_defaults.adaptive_roulette;
            p.spp *= 4;
        }
        vs.push_back({"vbme insert's defaults", p, insert_defaults.denoise});
    }
    double load0[3] = {0, 0, 0}, load1[3] = {0, 0, 0};
    getloadavg(load0, 3);
    for (int round = 0; round < o.repeat; ++round)
        for (auto& v : vs) {
            DifferentialRenderer::Params dp;
            dp.render = v.p;
            DifferentialImages im;
            const double c0 = cpuSeconds(RUSAGE_SELF);
            const auto t0 = std::chrono::steady_clock::now();
            const RenderStats st = DifferentialRenderer::create(dp)->render(*rs, cam, im);
            if (v.denoise > 0) denoiseDifference(im, bg, v.denoise);
            const Mat disp = display(im);
            const double wall =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            v.cpu = std::min(v.cpu, cpuSeconds(RUSAGE_SELF) - c0);
            v.best = std::min(v.best, wall);
            v.spp = double(st.paths) / bg.total();
            v.untouched = double(st.pixels_untouched) / bg.total();
            if (!ref.empty()) v.rmse = rmseOf(disp, ref);
        }
    getloadavg(load1, 3);
    std::printf(
        "  frame 0, %dx%d, %d threads, fastest of %d rounds, load average %.1f at the start and "
        "%.1f at the end (wall s/frame; CPU s/frame of this process, all threads):\n",
        o.width, o.height, getNumThreads(), o.repeat, load0[0], load1[0]);
    for (const auto& v : vs) {
        std::printf(
            "  %-56s %7.2f s wall %7.2f s CPU (%.2fx uniform) %6.1f spp, %4.1f %% untouched",
            v.name.c_str(), v.best, v.cpu, v.cpu / vs[0].cpu, v.spp, 100 * v.untouched);
        if (v.rmse >= 0)
            std::printf("  RMSE %.3f (%.3f without the reference's noise)", v.rmse,
                        std::sqrt(std::max(0.0, v.rmse * v.rmse - ref_noise * ref_noise)));
        std::printf("\n");
    }
    if (!ref.empty()) {
        const Variant* best = nullptr;
        for (const auto& v : vs)
            if (v.rmse <= vs[0].rmse && (!best || v.cpu < best->cpu)) best = &v;
        std::printf(
            "  equal quality (RMSE <= uniform %d spp's %.3f against the %d-spp reference): "
            "fastest is \"%s\", %.2f CPU s/frame (%.2f s wall), %.1fx less CPU than uniform\n",
            o.spp, vs[0].rmse, ref_spp, best->name.c_str(), best->cpu, best->best,
            vs[0].cpu / best->cpu);
    }
#ifdef VBME_BENCH_RENDER
    if (!PeerScene::exe().empty()) {
        const PeerScene ps;
        double wall, cpu;
        if (ps.runPeer(Size(o.width, o.height), o.spp, base.max_depth, 0, ps.dir + "/yardstick.ppm",
                       &wall, &cpu))
            std::printf(
                "  yardstick: one Embree pathtracer frame of the render-peer scene, "
                "%dx%d, %d spp, path length %d: %.2f s (%.2f s CPU, with loading)\n",
                o.width, o.height, o.spp, base.max_depth, wall, cpu);
    }
#endif
    std::printf("thesis (2013, LuxRender, 603x804, 32 spp): ~15-20 min per frame\n");
}
#endif

void setupBench(CLI::App& app) {
    auto o = std::make_shared<BenchOptions>();
    app.add_option(
           "what", o->what,
           "What to measure: track (tracking throughput), differential (one-pass "
           "differential rendering vs one and two renders; reads "
           "$VBME_DATA/meshes/stanford-bunny.obj) or insert (vbme insert's stages and "
           "seconds per frame on a rendered 3-frame room sequence, then frame 0 with uniform and "
           "adaptive sampling and the composite's RMSE against a cached high-spp "
           "reference) or denoise (vbme insert --denoise R on a static camera: error against a "
           "--ref-spp reference and flicker over --frames footage frames, with and without) or "
           "render-peer (vbme against Embree's pathtracer on one OBJ "
           "scene: paths/s ratio and image agreement) or track-camera (seconds per frame, "
           "stage times and accuracy of the keyframe + PnP method and of full COLMAP on a clip "
           "with known cameras)")
        ->check(CLI::IsMember(
            {"track", "differential", "insert", "denoise", "render-peer", "track-camera"}))
        ->capture_default_str();
    app.add_option("--spp", o->spp, "Samples per pixel (differential, insert)")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    app.add_option("--ref-spp", o->ref_spp,
                   "insert: samples per pixel of the reference, rendered in chunks of "
                   "--ref-chunk-spp with seeds of their own and cached (0: no reference, no "
                   "RMSE)")
        ->check(CLI::Range(0, 1000000))
        ->capture_default_str();
    app.add_option("--ref-chunk-spp", o->ref_chunk_spp,
                   "insert: samples per pixel of one cached chunk of the reference")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    app.add_flag("--ref-only", o->ref_only,
                 "insert: only render the reference's missing chunks (e.g. in the background, "
                 "niced), then stop");
    app.add_flag("--ref-cached-only", o->ref_cached_only,
                 "insert: make the reference of the chunks already cached (at least 2; the spp "
                 "it reaches is printed), render none");
    app.add_option("--errors", o->errors,
                   "insert: more variants: adaptive + texture cone + denoise at these adaptive "
                   "targets (comma-separated)")
        ->delimiter(',');
    app.add_option("--min-spps", o->min_spps,
                   "insert: more variants: adaptive + texture cone + denoise at these minimum "
                   "spp (comma-separated)")
        ->delimiter(',');
    app.add_option("--repeat", o->repeat,
                   "track, insert, render-peer: interleaved rounds (the fastest / median counts)")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    app.add_option("--max-depth", o->max_depth, "render-peer: path length of both renderers")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    app.add_option("--path-batch", o->path_batch,
                   "render-peer: paths of a pixel vbme advances together (0: one at a time; "
                   "default: Renderer::Params' default)")
        ->check(CLI::Range(0, 64));
    app.add_option("--min-spp", o->min_spp,
                   "insert: minimum samples of the adaptive variant (default: vbme insert's)")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    app.add_option("--max-spp", o->adaptive_max_spp,
                   "insert: maximum samples of the adaptive variant (0: 4 x --spp, as vbme "
                   "insert)")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    app.add_option("--error", o->error,
                   "insert: target of the adaptive variant (95 % half-width, 8-bit display)")
        ->check(CLI::Range(1e-3, 255.0))
        ->capture_default_str();
    app.add_option("--texture-cone", o->texture_cone,
                   "insert: spread (radians) of the texture-filtering variants' ray cone")
        ->check(CLI::Range(1e-4, 3.2))
        ->capture_default_str();
    app.add_option("--roulette", o->roulette,
                   "insert: adaptive variant's probability that an untouched pixel goes on")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    app.add_option("--denoise", o->denoise,
                   "insert: radius of the denoised variants' joint bilateral filter of the "
                   "difference layer (vbme insert --denoise; 0: no denoised variants); denoise: "
                   "the radius measured")
        ->check(CLI::Range(0, 16))
        ->capture_default_str();
    app.add_flag("--moving", o->moving,
                 "denoise: a hand-held camera walking at the demo's speed (0.6 m in 24 frames) "
                 "instead of a static one");
    app.add_option("--cache", o->cache,
                   "insert: folder of the cached reference (default: vbme-bench-cache in the build "
                   "folder, else in the current folder)");
    app.add_option("--width", o->width, "Frame width")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    app.add_option("--height", o->height, "Frame height")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    app.add_option("--frames", o->frames, "Frames to process (track; denoise: up to 24)")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    app.add_option(
        "--clip", o->clip,
        "track: a folder with clip.mp4, first_mask.png and optionally truth.csv (as in "
        "test/data/track_pale_ball); track-camera: a folder with clip.mkv or frames/, scene.yml "
        "and truth.yml (as "
        "written by scripts/blender/camera_track_clip.py); default: a textured room rendered here "
        "(--frames, --width, --height)");
    app.add_option("--methods", o->methods,
                   "track-camera: any of keyframes, full, stride (as many keyframes as the "
                   "keyframe method chose, at a fixed stride; needs keyframes), comma-separated")
        ->capture_default_str();
    app.add_option("--colmap-database", o->colmap_database,
                   "track-camera: a COLMAP database left by an earlier keyframe run on the same "
                   "clip (WORK/database.db): the keyframe method maps it instead of extracting "
                   "and matching, which replays that run (COLMAP's matching is not repeatable, "
                   "its mapper is); its later steps (mapping again, COLMAP again) run as usual")
        ->check(CLI::ExistingFile);
    app.add_option("--seed", o->seed,
                   "track-camera: COLMAP's random seed (the mapper's first run; retries add 1, 2, "
                   "...)")
        ->check(CLI::Range(0, 1000000))
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
#ifdef VBME_BENCH_RENDER
        if (o->what == "render-peer") benchRenderPeer(*o);
#else
        if (o->what == "render-peer")
            CV_Error(cv::Error::StsError, "vbme was built without vbme_render");
#endif
#ifdef VBME_BENCH_CALIB
        if (o->what == "track-camera") benchTrackCamera(*o);
#else
        if (o->what == "track-camera")
            CV_Error(cv::Error::StsError, "vbme was built without vbme_calib");
#endif
#ifdef VBME_BENCH_PIPELINE
        if (o->what == "insert") {
            cv::setNumThreads(-1);
            benchInsert(*o);
        }
        if (o->what == "denoise") {
            cv::setNumThreads(-1);
            benchDenoise(*o);
        }
#else
        if (o->what == "insert" || o->what == "denoise")
            CV_Error(cv::Error::StsError, "vbme was built without vbme_pipeline");
#endif
    });
}

}  // namespace

VBME_REGISTER_COMMAND("bench", "Measure whole-pipeline speed on input made in code", setupBench);

}  // namespace vbme_app
