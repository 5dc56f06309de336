// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme_render against Embree's own `pathtracer` (Debian embree-tools) on the same scene: an
// open box room (floor, back and left walls) with the Stanford bunny, diffuse materials, one
// distant light with a 5° half-angle and a constant ambient environment.
//
// Reads $VBME_DATA/meshes/stanford-bunny.obj (VBME_DATA defaults to ../shared/data beside the
// source tree). The peer has no timer of its own: it is timed at N and 2N samples per pixel and the
// difference is taken, so that loading and BVH building cancel. It writes 8-bit linear values
// clamped to [0,1]; images are compared in those units.
//
//   vbme_perf_render_pathtracer --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

const Vec3d kEye(2.2, -3.0, 1.4), kTarget(-0.2, 0.3, 0.45);
const double kFovY = 45.0;
const double kSunRadiance = 125.7, kSunHalfAngle = 5.0, kAmbient = 0.3;
const Vec3d kToSun = normalize(Vec3d(0.4, -0.3, 1.0));

std::string peerExe() {
    for (const char* p :
         {"/usr/bin/pathtracer", "/usr/bin/embree3_pathtracer", "/usr/local/bin/pathtracer"})
        if (std::filesystem::exists(p)) return p;
    return "";
}

struct Bench {
    std::string dir, obj, error;
    Scene scene;
    Ptr<RenderScene> rs;

    Bench() {
        const char* env = std::getenv("VBME_DATA");
        const std::string data = env ? env : VBME_DEFAULT_DATA;
        const std::string bunny = data + "/meshes/stanford-bunny.obj";
        if (!std::filesystem::exists(bunny)) {
            error = "missing " + bunny + " (set VBME_DATA)";
            return;
        }
        dir = (std::filesystem::temp_directory_path() /
               ("vbme-perf-render-" + std::to_string(::getpid())))
                  .string();
        std::filesystem::create_directories(dir);
        obj = dir + "/scene.obj";
        // Room quads (normals into the box) + the bunny, scaled ×5, y-up → z-up, on the floor.
        std::ofstream o(obj);
        o << "mtllib scene.mtl\n";
        const double q[3][4][3] = {
            {{-1.5, -1.5, 0}, {1.5, -1.5, 0}, {1.5, 1.5, 0}, {-1.5, 1.5, 0}},
            {{-1.5, 1.5, 0}, {1.5, 1.5, 0}, {1.5, 1.5, 2}, {-1.5, 1.5, 2}},
            {{-1.5, -1.5, 0}, {-1.5, 1.5, 0}, {-1.5, 1.5, 2}, {-1.5, -1.5, 2}}};
        for (auto& f : q)
            for (auto& v : f)
                o << "v " << v[0] << " " << v[1] << " " << v[2] << "\n";
        std::ifstream in(bunny);
        std::string line;
        std::vector<Vec3d> bv;
        std::vector<std::string> faces;
        double ymin = 1e30;
        while (std::getline(in, line)) {
            if (line.rfind("v ", 0) == 0) {
                std::istringstream ss(line.substr(2));
                Vec3d v;
                ss >> v[0] >> v[1] >> v[2];
                bv.push_back(v);
                ymin = std::min(ymin, v[1]);
            } else if (line.rfind("f ", 0) == 0) {
                faces.push_back(line);
            }
        }
        char buf[128];
        for (const auto& v : bv) {
            std::snprintf(buf, sizeof buf, "v %.6f %.6f %.6f\n", 5 * v[0], -5 * v[2],
                          5 * (v[1] - ymin));
            o << buf;
        }
        o << "usemtl room\nf 1 2 3 4\nf 5 6 7 8\nf 9 10 11 12\nusemtl bunny\n";
        for (const auto& f : faces) {
            std::istringstream ss(f.substr(2));
            std::string a;
            o << "f";
            while (ss >> a)
                o << " " << (std::stoi(a.substr(0, a.find('/'))) + 12);
            o << "\n";
        }
        o.close();
        std::ofstream(dir + "/scene.mtl") << "newmtl room\nKd 0.6 0.6 0.6\nKs 0 0 0\n\n"
                                             "newmtl bunny\nKd 0.8 0.7 0.6\nKs 0 0 0\n";
        Light sun;
        sun.type = Light::DISTANT;
        sun.to_light = kToSun;
        sun.radiance = Vec3d::all(kSunRadiance);
        sun.half_angle_deg = kSunHalfAngle;
        Light sky;
        sky.type = Light::ENVIRONMENT;
        sky.radiance = Vec3d::all(kAmbient);
        scene.lights = {sun, sky};
        SceneObject so;
        so.mesh = obj;
        scene.objects = {so};
        rs = RenderScene::create(scene);
    }
    ~Bench() {
        if (!dir.empty()) std::filesystem::remove_all(dir);
    }
    Camera camera(Size sz) const {
        const double f = 0.5 * sz.height / std::tan(kFovY * CV_PI / 360.0);
        Camera c = vbme_test::lookAt(kEye, kTarget, f, sz);
        c.response = Response::LINEAR;
        return c;
    }
    // Runs the peer; returns wall seconds (negative on failure).
    double runPeer(Size sz, int spp, int depth, int threads, const std::string& out) const {
        auto num = [](double v) { return cv::format("%g", v); };
        // Embree's --distantlight takes the direction the light travels and its radiance;
        // its half-angle is in degrees.
        const std::vector<std::string> argv = {peerExe(),
                                               "-i",
                                               obj,
                                               "--vp",
                                               num(kEye[0]),
                                               num(kEye[1]),
                                               num(kEye[2]),
                                               "--vi",
                                               num(kTarget[0]),
                                               num(kTarget[1]),
                                               num(kTarget[2]),
                                               "--vu",
                                               "0",
                                               "0",
                                               "1",
                                               "--fov",
                                               num(kFovY),
                                               "--size",
                                               std::to_string(sz.width),
                                               std::to_string(sz.height),
                                               "--distantlight",
                                               num(-kToSun[0]),
                                               num(-kToSun[1]),
                                               num(-kToSun[2]),
                                               num(kSunRadiance),
                                               num(kSunRadiance),
                                               num(kSunRadiance),
                                               num(kSunHalfAngle),
                                               "--ambientlight",
                                               num(kAmbient),
                                               num(kAmbient),
                                               num(kAmbient),
                                               "--spp",
                                               std::to_string(spp),
                                               "--max-path-length",
                                               std::to_string(depth),
                                               "--threads",
                                               std::to_string(threads),
                                               "-o",
                                               out};
        const ProcessResult r = runProcess(argv);
        return r.ok() ? r.seconds : -1.0;
    }
};

Bench& bench() {
    static Bench b;
    return b;
}

double g_vbme_rate = 0, g_peer_rate = 0;

// vbme: paths/s at 320×240, path length 8, 1 or 2 threads.
void BM_VbmeRender(benchmark::State& state) {
    Bench& b = bench();
    if (!b.error.empty()) return state.SkipWithError(b.error.c_str());
    Renderer::Params p;
    p.spp = (int)state.range(0);
    p.max_depth = 8;
    p.threads = (int)state.range(1);
    p.aovs = false;
    Ptr<Renderer> r = Renderer::create(p);
    RenderImages img;
    RenderStats st;
    double seconds = 0;
    int64 paths = 0;
    for (auto _ : state) {
        st = r->render(*b.rs, b.camera(Size(320, 240)), img);
        seconds += st.seconds;
        paths += st.paths;
        state.SetIterationTime(st.seconds);
    }
    state.counters["paths/s"] = paths / seconds;
    state.counters["rays/path"] = double(st.rays) / st.paths;
    if (p.threads == 2) g_vbme_rate = paths / seconds;
}
BENCHMARK(BM_VbmeRender)
    ->Args({16, 1})
    ->Args({16, 2})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

// The peer at the same size, spp, path length and threads: (2N − N) samples timed.
void BM_EmbreePathtracer(benchmark::State& state) {
    Bench& b = bench();
    if (!b.error.empty()) return state.SkipWithError(b.error.c_str());
    if (peerExe().empty())
        return state.SkipWithError("Embree's pathtracer not found (apt install embree-tools)");
    const int n = (int)state.range(0), threads = (int)state.range(1);
    const Size sz(320, 240);
    double extra = 0;
    for (auto _ : state) {
        const double t1 = b.runPeer(sz, n, 8, threads, b.dir + "/peer_n.ppm");
        const double t2 = b.runPeer(sz, 2 * n, 8, threads, b.dir + "/peer_2n.ppm");
        if (t1 < 0 || t2 < 0) return state.SkipWithError("pathtracer failed");
        extra = t2 - t1;
        state.SetIterationTime(std::max(extra, 1e-6));
    }
    const double rate = double(sz.area()) * n / std::max(extra, 1e-6);
    state.counters["paths/s"] = rate;
    if (threads == 2) g_peer_rate = rate;
}
BENCHMARK(BM_EmbreePathtracer)
    ->Args({16, 1})
    ->Args({16, 2})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// Ratio of the two (2 threads each): > 1 means vbme is faster.
void BM_Ratio(benchmark::State& state) {
    for (auto _ : state)
        benchmark::DoNotOptimize(g_vbme_rate);
    if (g_vbme_rate <= 0 || g_peer_rate <= 0)
        return state.SkipWithError("run the two benchmarks above first");
    state.counters["vbme/embree"] = g_vbme_rate / g_peer_rate;
}
BENCHMARK(BM_Ratio)->Iterations(1);

// A 640×480, 32-spp frame (path length 8, all threads).
void BM_Vbme640x480x32(benchmark::State& state) {
    Bench& b = bench();
    if (!b.error.empty()) return state.SkipWithError(b.error.c_str());
    Renderer::Params p;
    p.spp = 32;
    p.max_depth = 8;
    Ptr<Renderer> r = Renderer::create(p);
    RenderImages img;
    for (auto _ : state)
        state.SetIterationTime(r->render(*b.rs, b.camera(Size(640, 480)), img).seconds);
}
BENCHMARK(BM_Vbme640x480x32)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(1);

// RMSE between the two renderers' images at high spp, in the peer's units (8-bit linear,
// clamped): path length 1 (direct light: both unbiased) and 8.
void BM_CompareImages(benchmark::State& state) {
    Bench& b = bench();
    if (!b.error.empty()) return state.SkipWithError(b.error.c_str());
    if (peerExe().empty()) return state.SkipWithError("Embree's pathtracer not found");
    const int depth = (int)state.range(0), spp = (int)state.range(1);
    const Size sz(160, 120);
    double rmse = 0, mean_vbme = 0, mean_peer = 0;
    for (auto _ : state) {
        const std::string out = b.dir + "/cmp.ppm";
        if (b.runPeer(sz, spp, depth, 0, out) < 0) return state.SkipWithError("pathtracer failed");
        Mat peer = imread(out, IMREAD_COLOR);
        Renderer::Params p;
        p.spp = spp;
        p.max_depth = depth;
        RenderImages img;
        Renderer::create(p)->render(*b.rs, b.camera(sz), img);
        Mat mine;
        img.color.convertTo(mine, CV_8UC3, 255.0);  // clamp and round like the peer
        Mat d;
        absdiff(mine, peer, d);
        d.convertTo(d, CV_32F);
        rmse = std::sqrt(mean(Mat(d.mul(d)).reshape(1))[0]);
        mean_vbme = mean(mine.reshape(1))[0];
        mean_peer = mean(peer.reshape(1))[0];
        imwrite(std::filesystem::temp_directory_path().string() + "/vbme_perf_render_compare_d" +
                    std::to_string(depth) + ".png",
                [&] {
                    Mat both;
                    hconcat(peer, mine, both);
                    return both;
                }());
    }
    state.counters["rmse_8bit"] = rmse;
    state.counters["mean_vbme"] = mean_vbme;
    state.counters["mean_embree"] = mean_peer;
}
BENCHMARK(BM_CompareImages)
    ->Args({1, 256})
    ->Args({8, 256})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
