// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Differential rendering on a bunny-in-a-box scene at 640×480: the time of the one-pass
// differential render against one render and against two separate renders, and the RMSE of
// the composite against a high-spp reference for shared (correlated) and independent samples.
//
// Scene: a closed 3×3×2.5 m room (albedo 0.8), a 0.8×0.8 m ceiling light of radiance 10, the
// Stanford bunny (×5, Lambertian 0.8/0.7/0.6) on the floor; max_depth 8. The "footage" is the
// reference render without the bunny, encoded as 8-bit sRGB; the reference composite is made
// from a 256-spp one-pass differential render (seed 1000); RMSE is over the whole image, in
// linear radiance.
//
// Reads $VBME_DATA/meshes/stanford-bunny.obj (VBME_DATA defaults to ../shared/data beside the source tree).
//
//   vbme_perf_render_differential --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

const Size kSize(640, 480);

struct Bench {
    std::string error;
    Scene scene;
    Ptr<RenderScene> rs;
    Mat frame;          // the "footage": reference without the bunny, 8-bit sRGB
    Mat ref_composite;  // linear
    bool have_ref = false;

    Bench() {
        const char* env = std::getenv("VBME_DATA");
        const std::string data = env ? env : VBME_DEFAULT_DATA;
        const std::string bunny = data + "/meshes/stanford-bunny.obj";
        if (!std::filesystem::exists(bunny)) {
            error = "missing " + bunny + " (set VBME_DATA)";
            return;
        }
        double ymin = 1e30;  // the bunny is y-up: put its lowest point on the floor
        {
            std::ifstream in(bunny);
            std::string line;
            while (std::getline(in, line))
                if (line.rfind("v ", 0) == 0) {
                    std::istringstream ss(line.substr(2));
                    double x, y, z;
                    ss >> x >> y >> z;
                    ymin = std::min(ymin, y);
                }
        }
        scene.image_size = kSize;
        scene.has_room = true;
        scene.room.min = Vec3d(-1.5, -1.5, 0);
        scene.room.max = Vec3d(1.5, 1.5, 2.5);
        Light l;
        l.type = Light::POLYGON;
        l.corners = {Vec3d(-0.4, 0.4, 2.5), Vec3d(0.4, 0.4, 2.5), Vec3d(0.4, -0.4, 2.5),
                     Vec3d(-0.4, -0.4, 2.5)};
        l.radiance = Vec3d(10, 10, 10);
        scene.lights = {l};
        SceneObject o;
        o.mesh = bunny;
        // (x, y, z) → (5x, −5z, 5(y − ymin)): y-up to z-up, ×5, on the floor.
        o.world_from_object = Matx44d(5, 0, 0, 0, 0, 0, -5, 0, 0, 5, 0, -5 * ymin, 0, 0, 0, 1);
        o.has_material = true;
        o.material = vbme_test::lambertian(Vec3d(0.8, 0.7, 0.6));
        scene.objects = {o};
        const double f = 0.5 * kSize.height / std::tan(50.0 * CV_PI / 360.0);
        scene.camera = vbme_test::lookAt(Vec3d(0.9, -1.4, 1.2), Vec3d(0, 0.1, 0.35), f, kSize);
        rs = RenderScene::create(scene);
    }

    static DifferentialRenderer::Params params(int spp, uint64 seed, bool independent,
                                               int method = DifferentialRenderer::ONE_PASS) {
        DifferentialRenderer::Params p;
        p.render.spp = spp;
        p.render.max_depth = 8;
        p.render.seed = seed;
        p.independent = independent;
        p.method = method;
        return p;
    }

    void makeReference() {
        if (have_ref) return;
        DifferentialImages ref;
        DifferentialRenderer::create(params(256, 1000, false))->render(*rs, scene.camera, ref);
        encode(ref.noobj, frame, Response::SRGB, CV_8U);
        compositeDifferential(frame, ref.obj, ref.diff, ref.mask, ref_composite);
        have_ref = true;
    }

    double rmse(int spp, bool independent) {
        makeReference();
        DifferentialImages im;
        DifferentialRenderer::create(params(spp, 0, independent))->render(*rs, scene.camera, im);
        Mat comp;
        compositeDifferential(frame, im.obj, im.diff, im.mask, comp);
        Mat d = comp - ref_composite;
        d = d.mul(d);
        if (const char* dump = std::getenv("VBME_PERF_DUMP")) {
            Mat enc;
            encode(comp, enc, Response::SRGB, CV_8U);
            imwrite(cv::format("%s/composite_%d_%s.png", dump, spp,
                               independent ? "independent" : "correlated"),
                    enc);
        }
        return std::sqrt(mean(d.reshape(1))[0]);
    }
};

Bench& bench() {
    static Bench b;
    return b;
}

// One plain render with the bunny (AOVs on, as the differential render has them).
void BM_SingleRender(benchmark::State& st) {
    Bench& b = bench();
    if (!b.error.empty()) return st.SkipWithError(b.error.c_str());
    Renderer::Params p = Bench::params((int)st.range(0), 0, false).render;
    RenderImages img;
    for (auto _ : st)
        Renderer::create(p)->render(*b.rs, b.scene.camera, img);
    st.counters["spp"] = (double)st.range(0);
}

// The one-pass differential render (both images).
void BM_DifferentialOnePass(benchmark::State& st) {
    Bench& b = bench();
    if (!b.error.empty()) return st.SkipWithError(b.error.c_str());
    DifferentialImages im;
    for (auto _ : st)
        DifferentialRenderer::create(Bench::params((int)st.range(0), 0, false))
            ->render(*b.rs, b.scene.camera, im);
    st.counters["spp"] = (double)st.range(0);
    st.counters["object_px_frac"] = countNonZero(im.object) / double(kSize.area());
}

// Two separate full renders with the same seed (the plain approach).
void BM_DifferentialTwoPass(benchmark::State& st) {
    Bench& b = bench();
    if (!b.error.empty()) return st.SkipWithError(b.error.c_str());
    DifferentialImages im, one;
    for (auto _ : st)
        DifferentialRenderer::create(
            Bench::params((int)st.range(0), 0, false, DifferentialRenderer::TWO_PASS))
            ->render(*b.rs, b.scene.camera, im);
    DifferentialRenderer::create(Bench::params((int)st.range(0), 0, false))
        ->render(*b.rs, b.scene.camera, one);
    st.counters["spp"] = (double)st.range(0);
    st.counters["maxabs_vs_onepass"] = norm(im.noobj, one.noobj, NORM_INF);
}

// RMSE of the composite against the 256-spp reference (linear radiance).
void BM_CompositeRmse(benchmark::State& st) {
    Bench& b = bench();
    if (!b.error.empty()) return st.SkipWithError(b.error.c_str());
    const int spp = (int)st.range(0);
    const bool independent = st.range(1) != 0;
    double e = 0;
    for (auto _ : st)
        e = b.rmse(spp, independent);
    st.counters["spp"] = spp;
    st.counters["independent"] = independent;
    st.counters["rmse"] = e;
}

// Seeds across frames on a moving camera (8 frames, 160×120, 16 spp, camera sliding 2 cm a
// frame): per-frame RMSE of the composite against a 256-spp reference of that frame, and the
// RMSE of the frame-to-frame change against the reference's change (flicker).
struct FrameRefs {
    std::vector<Camera> cams;
    std::vector<Mat> frames, refs;
};

void BM_FrameSeeds(benchmark::State& st) {
    Bench& b = bench();
    if (!b.error.empty()) return st.SkipWithError(b.error.c_str());
    static FrameRefs fr;
    const int n = 8;
    const Size sz(160, 120);
    if (fr.cams.empty()) {
        for (int i = 0; i < n; ++i) {
            const double f = 0.5 * sz.height / std::tan(50.0 * CV_PI / 360.0);
            const Vec3d step(0.02 * i, 0.01 * i, 0);
            fr.cams.push_back(vbme_test::lookAt(Vec3d(0.9, -1.4, 1.2) + step,
                                                Vec3d(0, 0.1, 0.35) + 0.5 * step, f, sz));
            DifferentialImages ref;
            DifferentialRenderer::create(Bench::params(256, 5000 + i, false))
                ->render(*b.rs, fr.cams[i], ref);
            Mat frame, comp;
            encode(ref.noobj, frame, Response::SRGB, CV_8U);
            compositeDifferential(frame, ref.obj, ref.diff, ref.mask, comp);
            fr.frames.push_back(frame);
            fr.refs.push_back(comp);
        }
    }
    const FrameSeeding mode = st.range(0) ? SEEDS_PER_FRAME : SEEDS_FIXED;
    auto rms = [](const Mat& d) { return std::sqrt(mean(Mat(d.mul(d)).reshape(1))[0]); };
    double e = 0, flicker = 0;
    for (auto _ : st) {
        e = flicker = 0;
        Mat prev;
        for (int i = 0; i < n; ++i) {
            DifferentialImages im;
            DifferentialRenderer::create(Bench::params(16, frameSeed(0, i, mode), false))
                ->render(*b.rs, fr.cams[i], im);
            Mat comp;
            compositeDifferential(fr.frames[i], im.obj, im.diff, im.mask, comp);
            const Mat err = comp - fr.refs[i];
            e += rms(err) / n;
            if (i > 0) flicker += rms(err - prev) / (n - 1);
            prev = err;
        }
    }
    st.counters["per_frame"] = st.range(0);
    st.counters["rmse"] = e;
    st.counters["flicker_rmse"] = flicker;
}

}  // namespace

BENCHMARK(BM_FrameSeeds)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_SingleRender)->Arg(32)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_DifferentialOnePass)->Arg(32)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_DifferentialTwoPass)->Arg(32)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_CompositeRmse)
    ->ArgsProduct({{8, 16, 32, 64}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
