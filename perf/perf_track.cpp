// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme_track benchmarks: each stage and a whole ObjectTracker::update() on synthetic clips,
// single-threaded (cv::setNumThreads(1)). Frames/second are reported as the "fps" counter.
//
//   vbme_perf_track --benchmark_filter=Update
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/datasets/ball_clip.hpp>
#include <opencv2/vbme/track.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

// 16 frames of a periodic clip (frame 15 leads smoothly back to frame 0), kept in memory.
struct Frames {
    std::vector<Mat> frames;
    Mat first_mask;
    explicit Frames(Size size) {
        SyntheticBallClip::Params p;
        p.size = size;
        p.frames = 16;
        SyntheticBallClip clip(p);
        for (int i = 0; i < p.frames; ++i) frames.push_back(clip.frame(i));
        diskMask(size, clip.truth(0), first_mask);
    }
};

const Frames& framesFor(Size size) {
    static Frames vga(Size(640, 480)), hd(Size(1280, 720));
    return size.width == 640 ? vga : hd;
}

Size sizeArg(const benchmark::State& s) { return s.range(0) == 0 ? Size(640, 480) : Size(1280, 720); }
void setLabel(benchmark::State& s) { s.SetLabel(s.range(0) == 0 ? "640x480" : "1280x720"); }
void fps(benchmark::State& s) {
    s.counters["fps"] = benchmark::Counter((double)s.iterations(), benchmark::Counter::kIsRate);
}

void BM_Update(benchmark::State& state, bool window) {
    setNumThreads(1);
    const Frames& f = framesFor(sizeArg(state));
    ObjectTracker::Params p;
    p.use_search_window = window;
    Ptr<ObjectTracker> t = ObjectTracker::create(p);
    t->init(f.frames[0], f.first_mask);
    Mat mask;
    size_t i = 0;
    for (auto _ : state) {
        ObjectTracker::Result r = t->update(f.frames[i++ % f.frames.size()], mask);
        benchmark::DoNotOptimize(r);
    }
    setLabel(state);
    fps(state);
}
void BM_UpdateWindow(benchmark::State& s) { BM_Update(s, true); }
void BM_UpdateWholeFrame(benchmark::State& s) { BM_Update(s, false); }
BENCHMARK(BM_UpdateWindow)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_UpdateWholeFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_StageHsvAndRatio(benchmark::State& state) {
    setNumThreads(1);
    const Frames& f = framesFor(sizeArg(state));
    Mat hsv, hf, hb, ratio, prob;
    cvtColor(f.frames[0], hsv, COLOR_BGR2HSV);
    hueSatHistogram(hsv, f.first_mask, hf, 30, 32);
    hueSatHistogram(hsv, ~f.first_mask, hb, 30, 32);
    foregroundRatio(hf, hb, ratio);
    for (auto _ : state) {
        cvtColor(f.frames[1], hsv, COLOR_BGR2HSV);
        backProjectRatio(hsv, ratio, prob);
        benchmark::DoNotOptimize(prob.data);
    }
    setLabel(state);
    fps(state);
}
BENCHMARK(BM_StageHsvAndRatio)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_StageCleanMask(benchmark::State& state) {
    setNumThreads(1);
    const Frames& f = framesFor(sizeArg(state));
    Mat noisy = f.first_mask.clone(), out;
    randu(noisy(Rect(0, 0, noisy.cols, noisy.rows / 8)), 0, 2);
    for (auto _ : state) {
        cleanMask(noisy, out, 9, 13, true);
        benchmark::DoNotOptimize(out.data);
    }
    setLabel(state);
    fps(state);
}
BENCHMARK(BM_StageCleanMask)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_StageFitDisk(benchmark::State& state) {
    const Frames& f = framesFor(sizeArg(state));
    for (auto _ : state) {
        Disk d = fitDisk(f.first_mask);
        benchmark::DoNotOptimize(d);
    }
    setLabel(state);
    fps(state);
}
BENCHMARK(BM_StageFitDisk)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_StageShape(benchmark::State& state) {
    const Frames& f = framesFor(sizeArg(state));
    const Disk d = fitDisk(f.first_mask);
    Mat h, n;
    for (auto _ : state) {
        sphereHeightMap(f.first_mask.size(), d, h);
        heightToNormals(h, f.first_mask, n, NORMALS_CENTRAL);
        benchmark::DoNotOptimize(n.data);
    }
    setLabel(state);
    fps(state);
}
BENCHMARK(BM_StageShape)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
