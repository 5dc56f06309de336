// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme bench: whole-pipeline figures on input made in code (per-stage figures are in perf/).
#include <chrono>
#include <cstdio>

#include <opencv2/core/utility.hpp>
#include <opencv2/vbme/track.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct BenchOptions {
    std::string what = "track";
    int width = 640, height = 480, frames = 300, threads = 1;
};

// Tracking throughput: frames made in memory first, so that only update() is timed.
void benchTrack(const BenchOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    SyntheticBallClip::Params cp;
    cp.size = Size(o.width, o.height);
    cp.frames = 32;  // periodic: frame 31 leads back to frame 0
    const SyntheticBallClip clip(cp);
    std::vector<Mat> frames;
    for (int i = 0; i < cp.frames; ++i) frames.push_back(clip.frame(i));
    Mat first_mask, mask;
    diskMask(cp.size, clip.truth(0), first_mask);
    for (bool window : {true, false}) {
        ObjectTracker::Params p;
        p.use_search_window = window;
        // Accuracy over one period, untimed; then the timed run on a fresh tracker.
        double iou = 0;
        Ptr<ObjectTracker> t = ObjectTracker::create(p);
        t->init(frames[0], first_mask);
        for (int i = 0; i < cp.frames; ++i) {
            Mat truth;
            t->update(frames[i], mask);
            diskMask(cp.size, clip.truth(i), truth);
            iou += maskIoU(mask, truth) / cp.frames;
        }
        t = ObjectTracker::create(p);
        t->init(frames[0], first_mask);
        const auto t0 = std::chrono::steady_clock::now();
        for (int i = 0; i < o.frames; ++i) t->update(frames[i % cp.frames], mask);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("track %dx%d %-12s %8.1f frames/s  (%d frames in %.2f s, %d thread%s, mean IoU %.3f)\n", o.width,
                    o.height, window ? "window" : "whole-frame", o.frames / s, o.frames, s, o.threads,
                    o.threads == 1 ? "" : "s", iou);
    }
    std::printf("thesis (2013, 2.8 GHz dual core): ~6 frames/s\n");
}

void setupBench(CLI::App& app) {
    auto o = std::make_shared<BenchOptions>();
    app.add_option("what", o->what, "What to measure")->check(CLI::IsMember({"track"}))->capture_default_str();
    app.add_option("--width", o->width, "Frame width")->check(CLI::Range(64, 8192))->capture_default_str();
    app.add_option("--height", o->height, "Frame height")->check(CLI::Range(64, 8192))->capture_default_str();
    app.add_option("--frames", o->frames, "Frames to process")->check(CLI::Range(1, 1000000))->capture_default_str();
    app.add_option("--threads", o->threads, "OpenCV threads")->check(CLI::Range(1, 256))->capture_default_str();
    app.callback([o] {
        cv::setNumThreads(o->threads);
        if (o->what == "track") benchTrack(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("bench", "Measure whole-pipeline speed on input made in code", setupBench);

}  // namespace vbme_app
