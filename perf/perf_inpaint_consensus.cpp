// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Object removal speed at 640×480: frames/s of the consensus fill (as `vbme inpaint --video`
// runs it: homography + dense flow, shadow removal; and as material editing's removal stage
// runs it: no alignment, shadows kept) against the earlier nearest-frame fill
// (VideoInpainter) in the same run, with the PSNR of each inside the hole.
//
//   vbme_perf_inpaint_consensus --benchmark_counters_tabular=true
//   OPENCV_FOR_THREADS_NUM=2 ... for the 2-core figure
#include <benchmark/benchmark.h>

#include <cmath>
#include <ctime>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/inpaint.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

/** Multi-scale colour noise over a gradient, with a few straight edges. */
Mat sceneImage(Size s, int seed) {
    RNG rng(seed);
    Mat acc(s, CV_32FC3);
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            acc.at<Vec3f>(y, x) =
                Vec3f(0.3f + 0.4f * x / s.width, 0.4f, 0.3f + 0.4f * y / s.height);
    for (double sigma : {1.0, 4.0}) {
        Mat n(s, CV_32FC3);
        rng.fill(n, RNG::UNIFORM, -0.15, 0.15);
        GaussianBlur(n, n, Size(0, 0), sigma);
        acc += n * (sigma == 1.0 ? 1.0 : 3.0);
    }
    Mat img;
    acc.convertTo(img, CV_8UC3, 255);
    line(img, Point(0, s.height / 3), Point(s.width, s.height / 2), Scalar(40, 40, 40), 6);
    line(img, Point(s.width / 2, 0), Point(s.width / 3, s.height), Scalar(220, 220, 220), 4);
    return img;
}

double psnrIn(const Mat& a, const Mat& b, const Mat& mask) {
    Mat d;
    absdiff(a, b, d);
    d.convertTo(d, CV_32F);
    d = d.mul(d);
    d.setTo(0, mask == 0);
    const Scalar s = sum(d);
    const double mse = (s[0] + s[1] + s[2]) / (3.0 * std::max(1, countNonZero(mask)));
    return mse < 1e-12 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse);
}

/** 24 frames: a ball of radius 40 px moving 12 px per frame with a soft shadow (60 % of the
light) beside it; the camera pans by `pan` pixels per frame. */
struct Clip {
    std::vector<Mat> frames, masks, bgs;
};
Clip makeClip(int pan) {
    const Size size(640, 480);
    const int n = 24;
    const Mat world = sceneImage(Size(size.width + pan * n, size.height), 3);
    Clip c;
    for (int t = 0; t < n; ++t) {
        const Point ctr(100 + t * 12, 260);
        const Mat bg = world(Rect(pan * t, 0, size.width, size.height)).clone();
        Mat shade(size, CV_32F, Scalar(1));
        ellipse(shade, ctr + Point(45, 30), Size(55, 22), 0, 0, 360, Scalar(0.6), FILLED);
        GaussianBlur(shade, shade, Size(0, 0), 4);
        Mat f;
        bg.convertTo(f, CV_32FC3);
        Mat sh3;
        cvtColor(shade, sh3, COLOR_GRAY2BGR);
        f = f.mul(sh3);
        f.convertTo(f, CV_8UC3);
        circle(f, ctr, 40, Scalar(30, 30, 220), FILLED, LINE_AA);
        Mat m = Mat::zeros(size, CV_8U);
        circle(m, ctr, 43, Scalar(255), FILLED);
        c.frames.push_back(f);
        c.masks.push_back(m);
        c.bgs.push_back(bg);
    }
    return c;
}

double cpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

template <class Make>
void run(benchmark::State& state, const Clip& c, Make make) {
    double psnr = 0, cpu = 0;
    for (auto _ : state) {
        const double t0 = cpuSeconds();
        auto inp = make();
        Mat out;
        psnr = 0;
        size_t k = 0;
        auto drain = [&] {
            while (inp->pop(out)) {
                psnr += psnrIn(out, c.bgs[k], c.masks[k]);
                ++k;
            }
        };
        for (size_t t = 0; t < c.frames.size(); ++t) {
            inp->push(c.frames[t], c.masks[t]);
            drain();
        }
        inp->finish();
        drain();
        cpu += cpuSeconds() - t0;
    }
    // CPU milliseconds per frame, all threads (the machine is shared: wall-clock frames/s
    // depend on the load)
    state.counters["cpu_ms"] = 1000 * cpu / double(state.iterations() * c.frames.size());
    state.SetItemsProcessed(state.iterations() * (int64)c.frames.size());
    state.counters["fps"] = benchmark::Counter(double(state.iterations() * c.frames.size()),
                                               benchmark::Counter::kIsRate);
    state.counters["psnr_hole_dB"] = psnr / c.frames.size();
}

// Args: method (0 nearest-frame VideoInpainter, 1 consensus as material editing runs it: no
// alignment, shadows kept; 2 consensus, no alignment, shadows removed; 3 consensus as `vbme
// inpaint --video` runs it: homography + flow, shadows removed), camera pan (px per frame).
void BM_Removal640x480(benchmark::State& state) {
    const int method = (int)state.range(0);
    const Clip c = makeClip((int)state.range(1));
    Mat lab;
    cvtColor(c.frames[0](Rect(0, 0, 8, 8)), lab, COLOR_BGR2Lab);  // lazy Lab tables: not timed
    if (method == 0) {
        run(state, c, [] { return VideoInpainter::create(); });
        state.SetLabel("nearest (VideoInpainter)");
        return;
    }
    ConsensusInpainter::Params p;
    p.alignment = method == 3 ? CONSENSUS_ALIGN_FLOW : CONSENSUS_ALIGN_NONE;
    p.shadows = method == 1 ? SHADOWS_KEEP : SHADOWS_REMOVE;
    if (method == 1) p.temporal_radius = 8;  // material editing: --lookahead 8
    run(state, c, [&] { return ConsensusInpainter::create(p); });
    static const char* names[] = {"", "consensus none keep (material-edit)",
                                  "consensus none remove", "consensus flow remove (inpaint)"};
    state.SetLabel(names[method]);
}
BENCHMARK(BM_Removal640x480)
    ->ArgsProduct({{0, 1, 2, 3}, {0, 4}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
