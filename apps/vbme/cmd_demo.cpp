// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme demo: the README's main job. Makes its own input (nothing is downloaded) and runs the
// pipelines on it, writing results a person can watch.
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/track.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct DemoOptions {
    std::string out = "vbme-demo";
    int frames = 90;
    int width = 640, height = 480;
    CommonOptions common;
};

void runDemo(const DemoOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    namespace fs = std::filesystem;
    const fs::path dir(o.out);
    const std::string input = (dir / "input.mkv").string(),
                      overlay = (dir / "track_overlay.mp4").string();
    const std::string first_mask = (dir / "first_mask.png").string(),
                      normals = (dir / "normals_00000.png").string();
    for (const std::string& p : {input, overlay, first_mask, normals})
        checkOverwrite(p, o.common.force);

    // 1. A clip with known truth: a shaded orange ball over a textured background, with a
    //    highlight, noise and a blue distractor; stored losslessly (FFV1) like a camera file.
    std::printf("demo: making a %d-frame %dx%d clip with a moving ball -> %s\n", o.frames, o.width,
                o.height, input.c_str());
    SyntheticBallClip::Params cp;
    cp.size = Size(o.width, o.height);
    cp.frames = o.frames;
    const SyntheticBallClip clip(cp);
    {
        VideoSink sink(input, 30, cp.size);
        Progress progress("make clip", o.frames);
        for (int i = 0; i < o.frames; ++i) {
            sink.write(clip.frame(i));
            progress.tick();
        }
        progress.finish();
        sink.close();
    }
    Mat mask;
    diskMask(cp.size, clip.truth(0), mask);
    imwriteAtomic(first_mask, mask);

    // 2. Track it exactly as `vbme track` would.
    TrackVideoOptions opt;
    opt.overlay = overlay;
    opt.force = o.common.force;
    const TrackVideoSummary s = trackVideo(input, mask, (dir / "track").string(), opt);

    // 3. Shape recovery of frame 0, and the score against the truth.
    double iou = 0, err = 0;
    for (int i = 0; i < (int)s.results.size(); ++i) {
        Mat truth, got;
        diskMask(cp.size, clip.truth(i), truth);
        if (s.results[i].found)
            diskMask(cp.size, s.results[i].disk, got);
        else
            got = Mat::zeros(cp.size, CV_8UC1);
        iou += maskIoU(got, truth);
        err += norm(s.results[i].disk.center - clip.truth(i).center);
    }
    iou /= s.results.size();
    err /= s.results.size();
    Mat height, n, picture;
    sphereHeightMap(cp.size, s.results[0].disk, height);
    diskMask(cp.size, s.results[0].disk, mask);
    heightToNormals(height, mask, n, NORMALS_CENTRAL);
    normalMapImage(n, picture);
    imwriteAtomic(normals, picture);

    std::printf(
        "demo: tracked %zu frames at %.0f frames/s (decoding included); mean IoU %.3f, mean centre "
        "error %.2f px against the truth\n",
        s.results.size(), s.seconds > 0 ? s.results.size() / s.seconds : 0.0, iou, err);
    std::printf(
        "demo: watch %s (the tracked disk drawn on the input); masks and track.csv in %s; sphere "
        "normals of frame 0 in %s\n",
        overlay.c_str(), (dir / "track").string().c_str(), normals.c_str());
}

void setupDemo(CLI::App& app) {
    auto o = std::make_shared<DemoOptions>();
    app.footer(
        "Run vbme on input it makes itself (nothing is downloaded): a synthetic clip of a moving\n"
        "orange ball is generated, tracked with `vbme track`'s pipeline, its shape recovered, and "
        "the\n"
        "results written to OUT: input.mkv, track_overlay.mp4 (watch this), track/, "
        "normals_00000.png.");
    app.add_option("--out", o->out, "Output folder")->capture_default_str();
    app.add_option("--frames", o->frames, "Number of frames of the clip")
        ->check(CLI::Range(2, 100000))
        ->capture_default_str();
    app.add_option("--width", o->width, "Frame width")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    app.add_option("--height", o->height, "Frame height")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    addCommonOptions(app, o->common);
    app.callback([o] {
        applyCommonOptions(o->common);
        runDemo(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("demo",
                      "Run the pipelines on a clip vbme makes itself and write videos to watch",
                      setupDemo);

}  // namespace vbme_app
