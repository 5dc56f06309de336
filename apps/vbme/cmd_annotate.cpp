// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme annotate: a local web page to mark up a room frame (line groups, room points, lights)
// with live feedback from the calibration, writing the annotation file of
// doc/annotation_format.md and optionally the calibrated scene.
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <thread>

#include <pthread.h>

#include "annotate/annotate_server.hpp"
#include "command.hpp"

namespace vbme_app {

namespace {

struct AnnotateOptions {
    AnnotateConfig config;
    int port = 0;
    CommonOptions common;
};

void runAnnotate(AnnotateOptions& o) {
    namespace fs = std::filesystem;
    AnnotateConfig& c = o.config;
    // Outputs are checked before any work; reopening the output itself is allowed.
    const bool reopening = !c.annotation.empty() && fs::exists(c.out) && fs::exists(c.annotation) &&
                           fs::equivalent(c.out, c.annotation);
    if (!reopening) cv::vbme::checkOverwrite(c.out, o.common.force);
    if (!c.scene_out.empty()) cv::vbme::checkOverwrite(c.scene_out, o.common.force);
    if (!c.annotation.empty()) cv::vbme::FrameAnnotation::read(c.annotation);  // fail early

    if (!o.common.quiet) std::printf("reading %s …\n", c.video.c_str());
    auto session = std::make_shared<AnnotateSession>(c, loadPickerFrames(c.video, c.frame));

    // SIGINT/SIGTERM are taken by this thread (sigwait) and stop the server cleanly.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

    AnnotateServer server(session, o.port);
    std::printf("open %s in a browser (Ctrl-C to stop); save writes %s%s%s\n",
                session->url().c_str(), c.out.c_str(), c.scene_out.empty() ? "" : " and ",
                c.scene_out.c_str());
    std::fflush(stdout);
    std::thread serving([&] { server.run(); });
    int sig = 0;
    sigwait(&stop_signals, &sig);
    server.stop();
    serving.join();
    if (!o.common.quiet) std::printf("stopped\n");
}

void setupAnnotate(CLI::App& app) {
    auto o = std::make_shared<AnnotateOptions>();
    app.footer(
        "Starts a local web server (127.0.0.1 only) and prints the address of a page on which\n"
        "the room frame is marked up: line groups (detected segments are offered, grouped by\n"
        "vanishing point), room points, light polygons. Every edit is calibrated at once and\n"
        "the result drawn over the frame: focal length, horizon, vanishing points, the fitted\n"
        "room box, the lights, each segment's residual, warnings and what is still missing.\n"
        "Save writes --out in the format of doc/annotation_format.md (and --scene-out, the\n"
        "scene of 'vbme calibrate'). The address holds a random token; only this program's own\n"
        "page is served. Tutorial: doc/vbme_annotate.md.");
    app.add_option("--video", o->config.video, "Video file, image folder or %05d pattern")
        ->required();
    app.add_option("--frame", o->config.frame,
                   "Frame to annotate (from 0; default 0, the frame 'vbme insert' uses)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--annotation", o->config.annotation, "Annotation file to reopen")
        ->check(CLI::ExistingFile);
    app.add_option("--out", o->config.out, "Annotation file written by Save (.yml or .json)")
        ->required();
    app.add_option("--scene-out", o->config.scene_out,
                   "Also write the calibrated scene file on Save (as 'vbme calibrate --out')");
    app.add_option("--object", o->config.object,
                   "A mesh (OBJ, …) to place on the floor with a progressive differential-render "
                   "preview; Save then adds it to --scene-out")
        ->check(CLI::ExistingFile);
    app.add_option("--port", o->port, "Port on 127.0.0.1 (default: a free one)")
        ->check(CLI::Range(1, 65535));
    addCommonOptions(app, o->common);
    app.callback([o] {
        applyCommonOptions(o->common);
        runAnnotate(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("annotate",
                      "Mark up a room frame in the browser (lines, room, lights) with live "
                      "calibration feedback",
                      setupAnnotate);

}  // namespace vbme_app
