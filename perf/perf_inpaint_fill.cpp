// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Inpainting speed and quality: each patch search at 640×480 with holes of 3 % and 10 %, the
// PSNR of each search on the test images, and the time per frame of the video mode for a
// ball-sized hole.
//
//   OPENCV_FOR_THREADS_NUM=1 vbme_perf_inpaint_fill --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/inpaint.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

/** A 640×480-like scene: multi-scale colour noise (texture) over a smooth gradient, with a few
straight edges, so that both texture and structure have to be continued. */
Mat sceneImage(Size s, int seed = 1) {
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

Mat diskHole(Size s, double fraction) {
    Mat m = Mat::zeros(s, CV_8U);
    const int r = cvRound(std::sqrt(fraction * s.area() / CV_PI));
    circle(m, Point(s.width / 2, s.height / 2), r, Scalar(255), FILLED);
    return m;
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

// Args: method, hole percent.
void BM_Image640x480(benchmark::State& state) {
    const Size size(640, 480);
    const Mat img = sceneImage(size);
    const Mat hole = diskHole(size, state.range(1) / 100.0);
    ExemplarInpainter::Params p;
    p.method = (int)state.range(0);
    Ptr<ExemplarInpainter> inp = ExemplarInpainter::create(p);
    Mat out, lab;
    cvtColor(img(Rect(0, 0, 8, 8)), lab, COLOR_BGR2Lab);  // OpenCV's lazy Lab tables: not timed
    for (auto _ : state)
        inp->inpaint(img, hole, out);
    state.counters["hole_px"] = countNonZero(hole);
    state.counters["psnr_dB"] = psnrIn(out, img, hole);
    state.SetLabel(toString((PatchSearchMethod)p.method) + " " + std::to_string(state.range(1)) +
                   "%");
}
BENCHMARK(BM_Image640x480)
    ->ArgsProduct({{PATCH_SEARCH_PATCHMATCH, PATCH_SEARCH_VPTREE, PATCH_SEARCH_LOCAL}, {3, 10}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// The test images of test_inpaint_exemplar.cpp (128×96, hole a disk of 0.2·height radius).
Mat testImage(int which, Size s) {
    Mat m(s, CV_8UC3);
    if (which == 3) {  // texture: a 23×17 tile of smoothed noise repeated
        RNG rng(7);
        Mat tile(17, 23, CV_32FC3);
        rng.fill(tile, RNG::UNIFORM, 0, 255);
        GaussianBlur(tile, tile, Size(0, 0), 1.2, 1.2, BORDER_REFLECT);
        normalize(tile, tile, 20, 235, NORM_MINMAX);
        for (int y = 0; y < s.height; ++y)
            for (int x = 0; x < s.width; ++x) {
                const Vec3f v = tile.at<Vec3f>(y % 17, x % 23);
                m.at<Vec3b>(y, x) = Vec3b(saturate_cast<uchar>(v[0]), saturate_cast<uchar>(v[1]),
                                          saturate_cast<uchar>(v[2]));
            }
        return m;
    }
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            if (which == 0)
                m.at<Vec3b>(y, x) =
                    Vec3b(saturate_cast<uchar>(40 + 0.8 * x), saturate_cast<uchar>(60 + 0.9 * y),
                          saturate_cast<uchar>(120 + 0.4 * (x + y)));
            else if (which == 1)
                m.at<Vec3b>(y, x) = ((x / 4) % 2) ? Vec3b(200, 60, 30) : Vec3b(30, 160, 220);
            else
                m.at<Vec3b>(y, x) =
                    ((x / 8 + y / 8) % 2) ? Vec3b(230, 230, 230) : Vec3b(20, 40, 60);
        }
    return m;
}

// Args: method, test image (0 gradient, 1 stripes, 2 checkerboard, 3 texture, 4 scene).
void BM_TestImages(benchmark::State& state) {
    const Size size(128, 96);
    const int which = (int)state.range(1);
    const Mat img = which == 4 ? sceneImage(size) : testImage(which, size);
    Mat hole = Mat::zeros(size, CV_8U);
    circle(hole, Point(64, 48), cvRound(96 * 0.2), Scalar(255), FILLED);
    ExemplarInpainter::Params p;
    p.method = (int)state.range(0);
    p.patch_size = which == 2 ? 13 : 9;
    Ptr<ExemplarInpainter> inp = ExemplarInpainter::create(p);
    Mat out, lab;
    cvtColor(img(Rect(0, 0, 8, 8)), lab, COLOR_BGR2Lab);  // OpenCV's lazy Lab tables: not timed
    for (auto _ : state)
        inp->inpaint(img, hole, out);
    state.counters["psnr_dB"] = psnrIn(out, img, hole);
    static const char* names[] = {"gradient", "stripes", "checkerboard", "texture", "scene"};
    state.SetLabel(toString((PatchSearchMethod)p.method) + " " + names[which]);
}
BENCHMARK(BM_TestImages)
    ->ArgsProduct({{PATCH_SEARCH_PATCHMATCH, PATCH_SEARCH_VPTREE, PATCH_SEARCH_LOCAL},
                   {0, 1, 2, 3, 4}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

// Video: 640×480, a ball of radius 40 px (1.6 % of the frame) crossing a static textured
// scene. Arguments: reuse of the previous fill (0/1), camera pan and ball speed (pixels per
// frame; a slow ball leaves background no frame within the radius shows, filled by
// exemplars). Frames are pushed and popped as the command line does.
void BM_VideoBall640x480(benchmark::State& state) {
    const Size size(640, 480);
    const int n = 24;
    const int pan = (int)state.range(1);    // camera pan, pixels per frame
    const int speed = (int)state.range(2);  // ball, pixels per frame
    const Mat world = sceneImage(Size(size.width + pan * n, size.height), 3);
    std::vector<Mat> frames, masks, bgs;
    for (int t = 0; t < n; ++t) {
        const Point c(80 + t * speed, 240 + cvRound(60 * std::sin(t * 0.3 * speed / 20.0)));
        const Mat bg = world(Rect(pan * t, 0, size.width, size.height)).clone();
        bgs.push_back(bg);
        Mat f = bg.clone(), m = Mat::zeros(size, CV_8U);
        circle(f, c, 40, Scalar(30, 30, 220), FILLED, LINE_AA);
        circle(m, c, 43, Scalar(255), FILLED);
        frames.push_back(f);
        masks.push_back(m);
    }
    VideoInpainter::Params p;
    p.reuse_previous = state.range(0) != 0;
    double psnrSum = 0, wallMs = 0;
    int64 exemplarPx = 0, holePx = 0;
    for (auto _ : state) {
        const int64 t0 = getTickCount();
        Ptr<VideoInpainter> vi = VideoInpainter::create(p);
        Mat out;
        VideoInpainter::FrameStats st;
        psnrSum = 0;
        exemplarPx = holePx = 0;
        auto drain = [&] {
            while (vi->pop(out, &st)) {
                psnrSum += psnrIn(out, bgs[st.index], masks[st.index]);
                exemplarPx += st.exemplar;
                holePx += st.hole;
            }
        };
        for (int t = 0; t < n; ++t) {
            vi->push(frames[t], masks[t]);
            drain();
        }
        vi->finish();
        drain();
        wallMs += (getTickCount() - t0) * 1000.0 / getTickFrequency();
    }
    state.SetItemsProcessed(state.iterations() * n);
    state.counters["wall_ms_per_frame"] = wallMs / (double(n) * state.iterations());
    state.counters["psnr_dB"] = psnrSum / n;
    state.counters["exemplar_share"] = double(exemplarPx) / std::max<int64>(1, holePx);
}
BENCHMARK(BM_VideoBall640x480)
    ->Args({1, 0, 20})
    ->Args({1, 4, 20})
    ->Args({0, 4, 20})
    ->Args({1, 0, 3})
    ->Args({0, 0, 3})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
