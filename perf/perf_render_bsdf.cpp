// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme_render BSDF and environment-map throughput: eval()+pdf() and sample() per model, and
// EnvironmentMap eval/sample/pdf, single-threaded, on pre-drawn random inputs (so the random
// number generator is not measured). Calls/second are reported as the "calls" counter.
//
//   vbme_perf_render_bsdf --benchmark_filter=Sample
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/vbme/render/bsdf.hpp>
#include <opencv2/vbme/render/environment.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

const int kN = 4096;  // inputs cycled through

struct Inputs {
    std::vector<Vec3f> wo, wi;
    std::vector<Vec2f> u;
    std::vector<float> ul;
    Inputs() {
        RNG rng(1);
        for (int i = 0; i < kN; i++) {
            auto dir = [&](bool upper) {
                const float z = upper ? rng.uniform(0.05f, 1.f) : rng.uniform(-1.f, 1.f);
                const float phi = rng.uniform(0.f, 6.2831853f), r = std::sqrt(1 - z * z);
                return Vec3f(r * std::cos(phi), r * std::sin(phi), z);
            };
            wo.push_back(dir(true));
            wi.push_back(dir(false));
            u.push_back(Vec2f(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f)));
            ul.push_back(rng.uniform(0.f, 1.f));
        }
    }
};
const Inputs& inputs() {
    static Inputs in;
    return in;
}

struct Named {
    const char* name;
    Material m;
};
std::vector<Named> materials() {
    Material lam;
    Material phong;
    phong.type = Material::PHONG;
    Material ct;
    ct.type = Material::COOK_TORRANCE;
    ct.roughness = 0.2;
    Material gold = Material::preset("gold");
    gold.roughness = 0.2;
    Material glass = Material::preset("glass");
    Material rough_glass = glass;
    rough_glass.roughness = 0.2;
    Material plastic = Material::preset("blue");
    plastic.roughness = 0.2;
    Material smooth_plastic = plastic;
    smooth_plastic.roughness = 0;
    return {{"lambertian", lam},
            {"phong", phong},
            {"cook_torrance", ct},
            {"conductor_ggx", gold},
            {"mirror", Material::preset("mirror")},
            {"dielectric_smooth", glass},
            {"dielectric_rough", rough_glass},
            {"plastic_rough", plastic},
            {"plastic_smooth", smooth_plastic}};
}

void calls(benchmark::State& s) {
    s.counters["calls"] = benchmark::Counter((double)s.iterations(), benchmark::Counter::kIsRate);
}

void BM_BsdfEvalPdf(benchmark::State& s) {
    const Named nm = materials()[s.range(0)];
    s.SetLabel(nm.name);
    Ptr<Bsdf> b = Bsdf::create(nm.m);
    const Inputs& in = inputs();
    const Vec3f d = b->defaultDiffuse();
    int i = 0;
    for (auto _ : s) {
        const Vec3f f = b->eval(in.wo[i], in.wi[i], d);
        const float p = b->pdf(in.wo[i], in.wi[i], d);
        benchmark::DoNotOptimize(f);
        benchmark::DoNotOptimize(p);
        i = (i + 1) & (kN - 1);
    }
    calls(s);
}

void BM_BsdfSample(benchmark::State& s) {
    const Named nm = materials()[s.range(0)];
    s.SetLabel(nm.name);
    Ptr<Bsdf> b = Bsdf::create(nm.m);
    const Inputs& in = inputs();
    const Vec3f d = b->defaultDiffuse();
    int i = 0;
    BsdfSample bs;
    for (auto _ : s) {
        benchmark::DoNotOptimize(b->sample(in.wo[i], in.u[i], in.ul[i], d, bs));
        benchmark::DoNotOptimize(bs);
        i = (i + 1) & (kN - 1);
    }
    calls(s);
}

void BM_BsdfCreate(benchmark::State& s) {
    // Scene-load cost (the rough plastic integrates its coat albedo table here).
    const Named nm = materials()[s.range(0)];
    s.SetLabel(nm.name);
    for (auto _ : s)
        benchmark::DoNotOptimize(Bsdf::create(nm.m));
    calls(s);
}

const EnvironmentMap& envMap() {
    static EnvironmentMap env = [] {
        Mat img(1024, 2048, CV_32FC3);
        RNG rng(2);
        rng.fill(img, RNG::UNIFORM, 0.f, 1.f);
        img(Rect(700, 200, 8, 6)).setTo(Scalar(5000, 5000, 5000));
        return EnvironmentMap(img);
    }();
    return env;
}

void BM_EnvSample(benchmark::State& s) {
    const EnvironmentMap& env = envMap();
    const Inputs& in = inputs();
    int i = 0;
    for (auto _ : s) {
        Vec3f d;
        float pdf;
        benchmark::DoNotOptimize(env.sample(in.u[i], d, pdf));
        benchmark::DoNotOptimize(pdf);
        i = (i + 1) & (kN - 1);
    }
    s.SetLabel("2048x1024");
    calls(s);
}

void BM_EnvEvalPdf(benchmark::State& s) {
    const EnvironmentMap& env = envMap();
    const Inputs& in = inputs();
    int i = 0;
    for (auto _ : s) {
        benchmark::DoNotOptimize(env.eval(in.wi[i]));
        benchmark::DoNotOptimize(env.pdf(in.wi[i]));
        i = (i + 1) & (kN - 1);
    }
    s.SetLabel("2048x1024");
    calls(s);
}

void BM_EnvBuild(benchmark::State& s) {
    Mat img(1024, 2048, CV_32FC3);
    RNG rng(3);
    rng.fill(img, RNG::UNIFORM, 0.f, 1.f);
    for (auto _ : s)
        benchmark::DoNotOptimize(EnvironmentMap(img));
    s.SetLabel("2048x1024");
}

}  // namespace

BENCHMARK(BM_BsdfEvalPdf)->DenseRange(0, 8);
BENCHMARK(BM_BsdfSample)->DenseRange(0, 8);
BENCHMARK(BM_BsdfCreate)->DenseRange(0, 8);
BENCHMARK(BM_EnvSample);
BENCHMARK(BM_EnvEvalPdf);
BENCHMARK(BM_EnvBuild)->Unit(benchmark::kMillisecond);
