// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The material-editing pipeline end to end (runMaterialEdit: decode, tracking, shape,
// inpainting, environment, lighting, rendering, compositing, encode) on a rendered 640×480
// clip of a rolling orange ball (RenderedBallClip, 24 frames, 8 spp), edited to chrome and to
// glass. Frames/second of the whole pipeline are the "fps" counter (wall clock, with the load
// average in "load"); the milliseconds per frame of each stage (wall, in its own thread for
// decode and encode) are counters too, and "cpu_ms" is the process's CPU time per frame, all
// threads. The *_Medium runs encode with x264's preset medium (the default before superfast).
// BM_StageCpu_* run the stages one after another and give each one's CPU time per frame.
// The shadows follow `vbme material-edit`'s default (--shadows auto, shadowModeFor): glass
// removes the ball's shadow and casts its own, chrome keeps it; *_RemoveShadows and
// *_KeepShadows ask for one or the other.
//
// The clip is rendered once and cached in $TMPDIR/vbme-perf-material-edit-v1-640x480-24f-8spp
// (delete it to render again); all cores are used, as `vbme material-edit` does by default.
//
//   vbme_perf_pipeline_material_edit --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <stdlib.h>
#include <time.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/rendered_ball_clip.hpp>
#include <opencv2/vbme/pipeline/material_edit.hpp>
#include <opencv2/vbme/render/environment.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

namespace fs = std::filesystem;

struct Clip {
    fs::path dir;
    std::string video, video_h264, mask;
    double focal = 0;
    int frames = 0;
    Clip() {
        RenderedBallClip::Params p;
        p.size = Size(640, 480);
        p.frames = 24;
        p.spp = 8;
        dir = fs::temp_directory_path() / "vbme-perf-material-edit-v1-640x480-24f-8spp";
        video = (dir / "input.mkv").string();
        mask = (dir / "first_mask.png").string();
        const RenderedBallClip clip(p);
        focal = clip.focal();
        frames = p.frames;
        if (!fs::exists(video) || !fs::exists(mask)) {
            fs::create_directories(dir);
            clip.write(video, mask);  // atomic: an interrupted render leaves no cache
        }
        // the same frames as H.264 (vbme's default encode), as phones and editors deliver them
        video_h264 = (dir / "input_h264.mp4").string();
        if (!fs::exists(video_h264)) {
            VideoReader r(video);
            VideoSink s(video_h264, r.fps(), r.frameSize());
            Mat f;
            while (r.read(f))
                s.write(f);
            s.close();
        }
    }
};

const Clip& clip() {
    static Clip c;
    return c;
}

double cpuSeconds(clockid_t clock) {
    timespec ts{};
    clock_gettime(clock, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double loadAverage() {
    double l[1] = {0};
    return getloadavg(l, 1) == 1 ? l[0] : -1.0;
}

void BM_MaterialEdit(benchmark::State& state, const char* material, bool h264 = false,
                     const char* preset = nullptr, bool remove_shadows = false,
                     bool quality_floor = false, bool keep_shadows = false) {
    const Clip& c = clip();
    MaterialEditParams p;
    p.video = h264 ? c.video_h264 : c.video;
    p.first_mask = c.mask;
    p.out = (c.dir / (std::string("out_") + material + ".mp4")).string();
    p.material = Material::preset(material);
    p.focal = c.focal;
    p.force = true;
    if (preset) p.encode.preset = preset;
    // `vbme material-edit`'s default, --shadows auto: removed and re-cast for glass, kept for
    // chrome; remove_shadows asks for removal whatever the material, keep_shadows for keeping
    p.shadows = shadowModeFor(p.material);
    if (remove_shadows) p.shadows = SHADOWS_REMOVE;  // removed, and re-cast for the material
    if (keep_shadows) p.shadows = SHADOWS_KEEP;
    if (quality_floor) p.encode.min_psnr = 48;  // the overlays' default, asked for here
    Progress::setEnabled(false);
    std::vector<std::pair<std::string, double>> stages;
    int frames = 0;
    double cpu = 0;  // the process's CPU seconds over the runs (all threads)
    for (auto _ : state) {
        const double t0 = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID);
        const PipelineReport r = runMaterialEdit(p);
        cpu += cpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - t0;
        frames += r.frames_processed;
        if (stages.empty())
            stages = r.seconds;
        else
            for (size_t i = 0; i < stages.size() && i < r.seconds.size(); ++i)
                stages[i].second += r.seconds[i].second;
    }
    state.counters["fps"] = benchmark::Counter(frames, benchmark::Counter::kIsRate);
    // CPU milliseconds per frame of the whole run, and the frames/s that 2 idle cores would give
    // at that CPU cost if they were kept busy (an estimate from CPU time, not a measurement)
    state.counters["cpu_ms"] = frames > 0 ? 1000 * cpu / frames : 0.0;
    state.counters["fps_2cores_cpu"] = cpu > 0 ? 2.0 * frames / cpu : 0.0;
    state.counters["load"] = loadAverage();
    for (const auto& [name, s] : stages)
        state.counters[name + "_ms"] = frames > 0 ? 1000 * s / frames : 0.0;  // per frame
    state.SetLabel(std::string(material) + ", 640x480, " + std::to_string(c.frames) + " frames" +
                   (h264 ? ", H.264 input" : ", FFV1 input") +
                   (preset ? std::string(", x264 ") + preset : std::string()) +
                   (p.shadows == SHADOWS_REMOVE ? ", shadows remove" : ", shadows keep") +
                   (quality_floor ? ", quality floor (--min-psnr 48)" : ""));
}

void BM_Chrome(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome");
}
// glass with the command's default shadows (auto: the old shadow removed, a glass one cast)
void BM_Glass(benchmark::State& s) {
    BM_MaterialEdit(s, "glass");
}
// its peer with the original shadow kept (the library's default, MaterialEditParams::shadows)
void BM_Glass_KeepShadows(benchmark::State& s) {
    BM_MaterialEdit(s, "glass", false, nullptr, false, false, true);
}
// H.264 input, with the default Y'CbCr conversion (swscale's RGB path) and with the fast one
// (VBME_YUV=fast, read once per process: run this benchmark alone with the variable set to
// measure it)
void BM_Chrome_H264(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome", true);
}
// the same with x264's preset medium, vbme's default before superfast
void BM_Chrome_Medium(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome", false, "medium");
}
void BM_Chrome_H264_Medium(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome", true, "medium");
}
// shadows "remove": the original shadow removed and the new object's re-cast (shadow.cpp)
void BM_Chrome_RemoveShadows(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome", false, nullptr, true);
}
void BM_Glass_RemoveShadows(benchmark::State& s) {
    BM_MaterialEdit(s, "glass", false, nullptr, true);
}
// with the quality floor's trial encodes (VideoSinkOptions::min_psnr = 48, off by default for
// the edits' outputs), the peer that shows what the floor costs
void BM_Chrome_Floor(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome", false, nullptr, false, true);
}
void BM_Chrome_H264_Floor(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome", true, nullptr, false, true);
}
BENCHMARK(BM_Chrome)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Chrome_Floor)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Chrome_H264_Floor)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Chrome_Medium)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Chrome_H264_Medium)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Chrome_H264)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Glass)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Glass_KeepShadows)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Chrome_RemoveShadows)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Glass_RemoveShadows)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);

// CPU time per frame of each stage, stage after stage (nothing overlaps, so the process's CPU
// clock measures one stage at a time, all its threads included; a loaded machine changes it
// little, unlike wall time):
// - decode_cpu_ms: the whole input decoded (libavcodec's threads and the Y'CbCr conversion);
// - the editor's stages (<stage>_cpu_ms) run on one thread (threads = 1, so OpenCV's parallel
//   loops run serially on the calling thread): the calling thread's CPU time over push() and
//   pop(), split between the stages in proportion to the stage timers of the editor's report
//   (wall time of a single busy thread: the split is exact when that thread is never preempted;
//   editor_cpu_wall tells how close, 1.0 = never preempted);
// - encode_cpu_ms: the edited frames encoded with vbme's default options (x264's own threads);
//   encode_medium_cpu_ms: the same with x264's preset medium, the default before (not in the
//   total).
// total_cpu_ms is their sum: with perfect overlap on N idle cores, the pipeline runs at
// N * 1000 / total_cpu_ms frames/s at most ("fps_2cores_cpu" for N = 2).
void BM_StageCpu(benchmark::State& state, bool h264, bool remove_shadows = false) {
    const Clip& c = clip();
    MaterialEditParams p;
    p.video = h264 ? c.video_h264 : c.video;
    p.first_mask = c.mask;
    p.material = Material::preset("chrome");
    p.focal = c.focal;
    p.threads = 1;
    if (remove_shadows) p.shadows = SHADOWS_REMOVE;
    Progress::setEnabled(false);
    std::map<std::string, double> cpu;  // seconds per stage, summed over the iterations
    int frames = 0;
    for (auto _ : state) {
        std::vector<Mat> in, out;
        double t0 = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID);
        {
            VideoReader r(p.video);
            Mat f;
            while (r.read(f))
                in.push_back(f.clone());
        }
        cpu["decode"] += cpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - t0;
        PipelineReport rep;
        double editor_cpu = 0;
        runLimited(1, [&] {
            const Mat mask = imread(c.mask, IMREAD_GRAYSCALE);
            Ptr<MaterialEditor> e = MaterialEditor::create(p, mask, Ptr<EnvironmentMap>());
            const double t = cpuSeconds(CLOCK_THREAD_CPUTIME_ID);
            Mat o;
            for (const Mat& f : in) {
                e->push(f);
                while (e->pop(o, noArray(), noArray(), noArray()))
                    out.push_back(o.clone());
            }
            e->finish();
            while (e->pop(o, noArray(), noArray(), noArray()))
                out.push_back(o.clone());
            editor_cpu = cpuSeconds(CLOCK_THREAD_CPUTIME_ID) - t;
            rep = e->report();
        });
        double wall = 0;
        for (const auto& s : rep.seconds)
            wall += s.second;
        for (const auto& s : rep.seconds)
            cpu[s.first] += wall > 0 ? s.second * editor_cpu / wall : 0;
        cpu["editor_wall"] += wall;
        cpu["editor_cpu"] += editor_cpu;
        const std::string outp = (c.dir / "stage_cpu_out.mp4").string();
        t0 = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID);
        {
            VideoSink s(outp, 24, out.front().size());
            for (const Mat& f : out)
                s.write(f);
            s.close();
        }
        cpu["encode"] += cpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - t0;
        // the former default, x264 preset medium, for comparison (not in the total)
        t0 = cpuSeconds(CLOCK_PROCESS_CPUTIME_ID);
        {
            VideoSinkOptions o;
            o.preset = "medium";
            VideoSink s(outp, 24, out.front().size(), o);
            for (const Mat& f : out)
                s.write(f);
            s.close();
        }
        cpu["encode_medium"] += cpuSeconds(CLOCK_PROCESS_CPUTIME_ID) - t0;
        frames += (int)in.size();
    }
    double total = 0;
    for (const auto& [name, s] : cpu) {
        if (name == "editor_wall" || name == "editor_cpu") continue;
        state.counters[name + "_cpu_ms"] = 1000 * s / frames;
        if (name == "encode_medium") continue;
        total += s;
    }
    state.counters["editor_cpu_wall"] = cpu["editor_cpu"] / std::max(1e-9, cpu["editor_wall"]);
    state.counters["total_cpu_ms"] = 1000 * total / frames;
    state.counters["fps_2cores_cpu"] = 2.0 * frames / total;
    state.SetLabel(std::string("chrome, 640x480, ") + std::to_string(c.frames) + " frames" +
                   (h264 ? ", H.264 input" : ", FFV1 input") +
                   (remove_shadows ? ", shadows remove" : ""));
}
void BM_StageCpu_FFV1(benchmark::State& s) {
    BM_StageCpu(s, false);
}
void BM_StageCpu_H264(benchmark::State& s) {
    BM_StageCpu(s, true);
}
// shadows "remove": the consensus also votes around the hole to find the shadow, which is
// removed, and the new object's is cast (the "shadow" stage)
void BM_StageCpu_FFV1_RemoveShadows(benchmark::State& s) {
    BM_StageCpu(s, false, true);
}
BENCHMARK(BM_StageCpu_FFV1)->Unit(benchmark::kSecond)->Iterations(2);
BENCHMARK(BM_StageCpu_H264)->Unit(benchmark::kSecond)->Iterations(2);
BENCHMARK(BM_StageCpu_FFV1_RemoveShadows)->Unit(benchmark::kSecond)->Iterations(2);

}  // namespace
