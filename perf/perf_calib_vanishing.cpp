// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Time of automatic vanishing-point calibration (`vbme calibrate --auto`) on a 640×480 frame,
// split into its line-segment detection and the Manhattan-frame search, and of calibration
// from annotated lines.
#include <benchmark/benchmark.h>

#include <fstream>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

Camera benchCamera(Size size) {
    Camera c = Camera::fromFocal(0.85 * size.width, size);
    Matx33d yaw, pitch;
    Rodrigues(Vec3d(0, 0, -27 * CV_PI / 180), yaw);
    Rodrigues(Vec3d(12 * CV_PI / 180, 0, 0), pitch);
    c.R = pitch * Matx33d(1, 0, 0, 0, 0, -1, 0, 1, 0) * yaw;
    placeCamera(c, 1.55);
    return c;
}

Mat benchImage(Size size) {
    Room r;
    r.min = Vec3d(-2.2, -1.4, 0);
    r.max = Vec3d(2.6, 3.6, 2.7);
    return drawSyntheticRoom(benchCamera(size), r, 0.4, 2.0, 1);
}

void BM_AutoCalibrate(benchmark::State& state) {
    const Size size((int)state.range(0), (int)state.range(0) * 3 / 4);
    const Mat img = benchImage(size);
    auto cal = VanishingPointCalibrator::create();
    for (auto _ : state) {
        FrameCalibration fc = cal->detect(img);
        benchmark::DoNotOptimize(fc);
    }
    // The accuracy of the timed call, outside the timing. (Neither user counters nor
    // DoNotOptimize on a double: with Debian's libbenchmark 1.7.1 both gave garbage values.)
    const double f = cal->detect(img).focal();
    state.SetLabel(format("focal %.1f px, error %.2f %%", f,
                          100 * std::abs(f / benchCamera(size).K(0, 0) - 1)));
}
BENCHMARK(BM_AutoCalibrate)->Arg(640)->Arg(1280)->Unit(benchmark::kMillisecond);

// The same without the edge-pixel likelihood (Params::edgel_scoring off, the segments alone: the
// default before session 10): BM_AutoCalibrate's cost over it is the edge pixels'.
void BM_AutoCalibrateSegmentsOnly(benchmark::State& state) {
    const Size size((int)state.range(0), (int)state.range(0) * 3 / 4);
    const Mat img = benchImage(size);
    VanishingPointCalibrator::Params p;
    p.edgel_scoring = false;
    auto cal = VanishingPointCalibrator::create(p);
    for (auto _ : state) {
        FrameCalibration fc = cal->detect(img);
        benchmark::DoNotOptimize(fc);
    }
    const double f = cal->detect(img).focal();
    state.SetLabel(format("focal %.1f px, error %.2f %%", f,
                          100 * std::abs(f / benchCamera(size).K(0, 0) - 1)));
}
BENCHMARK(BM_AutoCalibrateSegmentsOnly)->Arg(640)->Unit(benchmark::kMillisecond);

// The previous RANSAC search (Params::RANSAC) on the same image: the peer of BM_AutoCalibrate.
void BM_AutoCalibrateRansac(benchmark::State& state) {
    const Size size((int)state.range(0), (int)state.range(0) * 3 / 4);
    const Mat img = benchImage(size);
    VanishingPointCalibrator::Params p;
    p.method = VanishingPointCalibrator::Params::RANSAC;
    auto cal = VanishingPointCalibrator::create(p);
    for (auto _ : state) {
        FrameCalibration fc = cal->detect(img);
        benchmark::DoNotOptimize(fc);
    }
    const double f = cal->detect(img).focal();
    state.SetLabel(format("focal %.1f px, error %.2f %%", f,
                          100 * std::abs(f / benchCamera(size).K(0, 0) - 1)));
}
BENCHMARK(BM_AutoCalibrateRansac)->Arg(640)->Unit(benchmark::kMillisecond);

// Three ranked proposals and the plumb-line distortion search (9 κ values) on the same image.
void BM_ProposalsWithDistortion(benchmark::State& state) {
    const Mat img = benchImage(Size(640, 480));
    VanishingPointCalibrator::Params p;
    p.estimate_distortion = true;
    for (auto _ : state) {
        auto props = detectManhattanProposals(img, p, 3);
        benchmark::DoNotOptimize(props.data());
    }
}
BENCHMARK(BM_ProposalsWithDistortion)->Unit(benchmark::kMillisecond);

// The 26 undistorted Blender renders of test/data/calib_rooms (640×480), one image per
// iteration in turn: what `--auto` costs on realistic images. Args 0–2 without the edge pixels
// (Params::edgel_scoring off): 0 the FastLineDetector pass off (LSD segments only); 1 the FLD
// pass when the LSD pass's first proposal's confidence is below
// Params::fld_pass_below_confidence (the default before session 10); 2 the FLD pass on every
// image. 3: the default (1 with the edge pixels, Params::edgel_scoring).
void BM_AutoCalibrateRenderedRooms(benchmark::State& state) {
    static const std::vector<Mat> imgs = [] {
        std::vector<Mat> v;
        const std::string dir = std::string(VBME_TEST_DATA_DIR) + "/calib_rooms/";
        std::ifstream in(dir + "truth.csv");
        std::string line;
        std::getline(in, line);
        while (std::getline(in, line)) {
            std::vector<std::string> t;
            std::stringstream ss(line);
            for (std::string x; std::getline(ss, x, ',');)
                t.push_back(x);
            if (t.size() < 8 || std::stod(t[7]) != 0) continue;  // k1 ≠ 0: not in the set
            Mat img = imread(dir + t[0], IMREAD_COLOR);
            if (!img.empty()) v.push_back(img);
        }
        return v;
    }();
    if (imgs.empty()) {
        state.SkipWithError("test/data/calib_rooms not found");
        return;
    }
    VanishingPointCalibrator::Params p;
    p.fld_pass = state.range(0) > 0;
    if (state.range(0) == 2) p.fld_pass_below_confidence = 2;
    p.edgel_scoring = state.range(0) == 3;
    size_t i = 0, refused = 0;
    for (auto _ : state) {
        try {
            auto props = detectManhattanProposals(imgs[i % imgs.size()], p, 3);
            benchmark::DoNotOptimize(props.data());
        } catch (const cv::Exception&) {
            ++refused;
        }
        ++i;
    }
    state.SetLabel(format("%d images, %d refused calls", (int)imgs.size(), (int)refused));
}
BENCHMARK(BM_AutoCalibrateRenderedRooms)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Arg(3)
    ->Iterations(52)
    ->Unit(benchmark::kMillisecond);

void BM_LineSegments(benchmark::State& state) {
    const Mat img = benchImage(Size(640, 480));
    auto cal = VanishingPointCalibrator::create();
    std::vector<Vec4f> segs;
    for (auto _ : state) {
        cal->detectSegments(img, segs);
        benchmark::DoNotOptimize(segs.data());
    }
    state.SetLabel(format("%d segments", (int)segs.size()));
}
BENCHMARK(BM_LineSegments)->Unit(benchmark::kMillisecond);

void BM_FromAnnotatedLines(benchmark::State& state) {
    const Size size(640, 480);
    const Camera c = benchCamera(size);
    std::vector<LineGroup> groups(3);
    for (int a = 0; a < 3; ++a) {
        groups[a].name = std::string(1, char('x' + a));
        for (int k = 0; k < 5; ++k) {
            Vec3d p(-1.5 + 0.3 * k, 2.0 + 0.2 * k, 0.2 + 0.4 * k), q = p;
            q[a] += 0.8;
            const Point2d u = c.project(p), v = c.project(q);
            groups[a].segments.emplace_back(u.x, u.y, v.x, v.y);
        }
    }
    auto cal = VanishingPointCalibrator::create();
    for (auto _ : state) {
        FrameCalibration fc = cal->calibrate(groups, size);
        benchmark::DoNotOptimize(fc);
    }
}
BENCHMARK(BM_FromAnnotatedLines)->Unit(benchmark::kMicrosecond);

}  // namespace
