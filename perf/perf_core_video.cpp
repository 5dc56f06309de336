// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Video decoding and encoding, frames per second, at 640x480 and 1920x1080: vbme's VideoReader
// / VideoSink (FFmpeg's libraries) against OpenCV's VideoCapture / VideoWriter (the path they
// replace) in the same run. items_per_second is frames per second (wall clock), cpu_ms the
// process's CPU milliseconds per frame (all threads; what a loaded machine changes little),
// load the machine's load average at the end. The fast Y'CbCr
// conversion is measured by a second run with VBME_YUV=fast in the environment.
//   build/perf/vbme_perf_core_video --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/videoio.hpp>

#include <stdlib.h>
#include <time.h>
#include <unistd.h>

using namespace cv;
using namespace cv::vbme;

namespace {

const int kFrames = 30;

// A scratch folder of this process, removed at exit.
struct Scratch {
    std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                ("vbme-perf-core-video-" + std::to_string(::getpid()));
    Scratch() { std::filesystem::create_directories(dir); }
    ~Scratch() {
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
    }
    std::string operator/(const std::string& n) const { return (dir / n).string(); }
};
Scratch& scratch() {
    static Scratch s;
    return s;
}

Size sizeOf(int64_t w) {
    return w == 640 ? Size(640, 480) : Size(1920, 1080);
}

// Textured frames with motion (what an encoder meets in footage), made once per size.
const std::vector<Mat>& frames(Size size) {
    static std::map<int, std::vector<Mat>> cache;
    auto& v = cache[size.width];
    if (v.empty()) {
        Mat tex(size.height, size.width + 4 * kFrames, CV_8UC3);
        RNG rng(3);
        rng.fill(tex, RNG::UNIFORM, 0, 256);
        GaussianBlur(tex, tex, Size(0, 0), 2.0);
        for (int i = 0; i < kFrames; ++i) {
            Mat f = tex(Rect(4 * i, 0, size.width, size.height)).clone();
            circle(f, Point(size.width / 4 + 8 * i, size.height / 2), size.height / 6,
                   Scalar(40, 80, 220), FILLED);
            v.push_back(f);
        }
    }
    return v;
}

// One file per size and codec for the decoders: H.264 as vbme writes it by default (what
// phones and editors deliver), FFV1 (lossless, as the perf and test clips of material editing).
const std::string& clip(Size size, bool ffv1 = false) {
    static std::map<int, std::string> files;
    auto& dir = scratch();
    auto& f = files[size.width * 2 + (ffv1 ? 1 : 0)];
    if (f.empty()) {
        f = dir / ("clip_" + std::to_string(size.width) + (ffv1 ? ".mkv" : ".mp4"));
        VideoSinkOptions so;
        if (ffv1) so.codec = "ffv1";
        VideoSink s(f, 30, size, so);
        for (const Mat& m : frames(size))
            s.write(m);
        s.close();
    }
    return f;
}

// CPU seconds of the whole process (every thread: the codecs' own threads included).
double processCpu() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// Counters beside items_per_second (wall-clock frames/s): cpu_ms, the process's CPU
// milliseconds per frame (all threads), and load, the load average of the machine.
void setCpuCounters(benchmark::State& st, double cpu_s, int64_t frames) {
    st.counters["cpu_ms"] = frames > 0 ? 1000 * cpu_s / frames : 0.0;
    double l[1] = {0};
    st.counters["load"] = getloadavg(l, 1) == 1 ? l[0] : -1.0;
}

void BM_Decode_vbme(benchmark::State& st) {
    const Size size = sizeOf(st.range(0));
    const std::string& f = clip(size, st.range(1) == 1);
    Mat m;
    int64_t n = 0;
    const double cpu0 = processCpu();
    for (auto _ : st) {
        VideoReader r(f);
        while (r.read(m))
            ++n;
    }
    setCpuCounters(st, processCpu() - cpu0, n);
    st.SetItemsProcessed(n);
}


void BM_Decode_OpenCV(benchmark::State& st) {
    const Size size = sizeOf(st.range(0));
    const std::string& f = clip(size, st.range(1) == 1);
    Mat m;
    int64_t n = 0;
    const double cpu0 = processCpu();
    for (auto _ : st) {
        VideoCapture c(f, CAP_FFMPEG);
        while (c.read(m))
            ++n;
    }
    setCpuCounters(st, processCpu() - cpu0, n);
    st.SetItemsProcessed(n);
}

// vbme's default encoding; with a second argument 1, x264's preset medium (the default before
// superfast) at the same CRF
void BM_Encode_vbme(benchmark::State& st) {
    const Size size = sizeOf(st.range(0));
    const auto& fr = frames(size);
    auto& dir = scratch();
    VideoSinkOptions opt;
    if (st.range(1) == 1) opt.preset = "medium";
    int64_t n = 0;
    const double cpu0 = processCpu();
    for (auto _ : st) {
        VideoSink s(dir / "out.mp4", 30, size, opt);
        for (const Mat& m : fr)
            s.write(m);
        s.close();
        n += (int64_t)fr.size();
    }
    setCpuCounters(st, processCpu() - cpu0, n);
    st.SetItemsProcessed(n);
    st.counters["kbit_per_s"] =
        (double)std::filesystem::file_size(dir / "out.mp4") * 8 / (kFrames / 30.0) / 1000;
}

void BM_Encode_OpenCV(benchmark::State& st) {
    const Size size = sizeOf(st.range(0));
    const auto& fr = frames(size);
    auto& dir = scratch();
    int64_t n = 0;
    const double cpu0 = processCpu();
    for (auto _ : st) {
        VideoWriter w(dir / "out.mp4", CAP_FFMPEG, VideoWriter::fourcc('a', 'v', 'c', '1'), 30,
                      size);
        for (const Mat& m : fr)
            w.write(m);
        w.release();
        n += (int64_t)fr.size();
    }
    setCpuCounters(st, processCpu() - cpu0, n);
    st.SetItemsProcessed(n);
    st.counters["kbit_per_s"] =
        (double)std::filesystem::file_size(dir / "out.mp4") * 8 / (kFrames / 30.0) / 1000;
}

}  // namespace

// second argument: 0 H.264, 1 FFV1
BENCHMARK(BM_Decode_vbme)
    ->Args({640, 0})
    ->Args({1920, 0})
    ->Args({640, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Decode_OpenCV)
    ->Args({640, 0})
    ->Args({1920, 0})
    ->Args({640, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
// second argument: 0 vbme's default (x264 superfast), 1 x264 medium
BENCHMARK(BM_Encode_vbme)
    ->Args({640, 0})
    ->Args({640, 1})
    ->Args({1920, 0})
    ->Args({1920, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Encode_OpenCV)->Arg(640)->Arg(1920)->Unit(benchmark::kMillisecond)->UseRealTime();
