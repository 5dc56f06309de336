// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The material-editing pipeline end to end (runMaterialEdit: decode, tracking, shape,
// inpainting, environment, lighting, rendering, compositing, encode) on a rendered 640×480
// clip of a rolling orange ball (RenderedBallClip, 24 frames, 8 spp), edited to chrome and to
// glass. Frames/second of the whole pipeline are the "fps" counter; the seconds per frame of
// each stage are reported as counters too.
//
// The clip is rendered once and cached in $TMPDIR/vbme-perf-material-edit-v1-640x480-24f-8spp
// (delete it to render again); all cores are used, as `vbme material-edit` does by default.
//
//   vbme_perf_pipeline_material_edit --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include <stdlib.h>

#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/rendered_ball_clip.hpp>
#include <opencv2/vbme/pipeline/material_edit.hpp>

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

void BM_MaterialEdit(benchmark::State& state, const char* material, bool h264 = false) {
    const Clip& c = clip();
    MaterialEditParams p;
    p.video = h264 ? c.video_h264 : c.video;
    p.first_mask = c.mask;
    p.out = (c.dir / (std::string("out_") + material + ".mp4")).string();
    p.material = Material::preset(material);
    p.focal = c.focal;
    p.force = true;
    Progress::setEnabled(false);
    std::vector<std::pair<std::string, double>> stages;
    int frames = 0;
    for (auto _ : state) {
        const PipelineReport r = runMaterialEdit(p);
        frames += r.frames_processed;
        if (stages.empty())
            stages = r.seconds;
        else
            for (size_t i = 0; i < stages.size() && i < r.seconds.size(); ++i)
                stages[i].second += r.seconds[i].second;
    }
    state.counters["fps"] = benchmark::Counter(frames, benchmark::Counter::kIsRate);
    for (const auto& [name, s] : stages)
        state.counters[name + "_ms"] = frames > 0 ? 1000 * s / frames : 0.0;  // per frame
    state.SetLabel(std::string(material) + ", 640x480, " + std::to_string(c.frames) + " frames" +
                   (h264 ? ", H.264 input" : ", FFV1 input"));
}

void BM_Chrome(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome");
}
void BM_Glass(benchmark::State& s) {
    BM_MaterialEdit(s, "glass");
}
// H.264 input, with the default Y'CbCr conversion (swscale's RGB path) and with the fast one
// (VBME_YUV=fast, read once per process: run this benchmark alone with the variable set to
// measure it)
void BM_Chrome_H264(benchmark::State& s) {
    BM_MaterialEdit(s, "chrome", true);
}
BENCHMARK(BM_Chrome)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Chrome_H264)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);
BENCHMARK(BM_Glass)->Unit(benchmark::kSecond)->UseRealTime()->MinTime(1.0);

}  // namespace
