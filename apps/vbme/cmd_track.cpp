// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme track: colour-histogram ball tracking through a video.
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/track.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct TrackOptions {
    std::string video, mask, out, overlay, params_file;
    float threshold = -1, update_rate = -1, min_init_iou = -1;
    std::string colour_model;
    bool no_window = false, no_neutral = false;
    cv::vbme::VideoSinkOptions encode;
    CommonOptions common;
};

void runTrack(const TrackOptions& o) {
    using namespace cv::vbme;
    TrackVideoOptions opt;
    if (!o.params_file.empty()) opt.params = readTrackerParamsFile(o.params_file);
    if (o.threshold >= 0) opt.params.threshold = o.threshold;
    if (o.update_rate >= 0) opt.params.model_update_rate = o.update_rate;
    if (o.no_window) opt.params.use_search_window = false;
    if (o.no_neutral) opt.params.neutral_highlights = false;
    if (!o.colour_model.empty()) {
        static const std::pair<const char*, int> names[] = {
            {"auto", TRACK_COLOUR_AUTO}, {"hs", TRACK_COLOUR_HS},       {"gmm", TRACK_COLOUR_GMM},
            {"lab8", TRACK_COLOUR_LAB8}, {"lab16", TRACK_COLOUR_LAB16}, {"hsv", TRACK_COLOUR_HSV},
            {"ab", TRACK_COLOUR_AB}};
        for (const auto& n : names)
            if (o.colour_model == n.first) opt.params.colour_model = n.second;
    }
    if (o.min_init_iou >= 0) opt.params.min_init_iou = o.min_init_iou;
    opt.overlay = o.overlay;
    opt.overlay_encode = o.encode;
    opt.force = o.common.force;
    const cv::Mat mask = imreadChecked(o.mask, cv::IMREAD_GRAYSCALE);
    const TrackVideoSummary s = trackVideo(o.video, mask, o.out, opt);
    const int n = (int)s.results.size();
    std::printf("%s\n", s.init_report.c_str());
    std::printf(
        "tracked %d frames in %.2f s (%.1f frames/s), lost in %d; masks and track.csv in %s\n", n,
        s.seconds, s.seconds > 0 ? n / s.seconds : 0.0, s.lost, o.out.c_str());
}

void setupTrack(CLI::App& app) {
    auto o = std::make_shared<TrackOptions>();
    app.footer(
        "Track a uniformly coloured ball through a video (colour model chosen on frame 0, "
        "morphology,\ndisk fit refined on edges, motion prediction, evidence confidence, "
        "re-detection when lost).\nRefuses (exit 1) a clip whose ball cannot be told from its "
        "background by colour on frame 0.\n"
        "Writes OUT/mask_%05d.png (255 = object; empty where the object is lost) and "
        "OUT/track.csv\n"
        "(frame,cx,cy,r,confidence; a lost frame keeps its row with the last known disk).");
    app.add_option("--video", o->video,
                   "Input video file, image folder, or pattern like f/%05d.png")
        ->required();
    app.add_option("--mask", o->mask,
                   "Mask of the object in the first frame (PNG, non-zero = object)")
        ->required();
    app.add_option("--out", o->out, "Output folder for the masks and track.csv")->required();
    app.add_option("--overlay", o->overlay,
                   "Also write a video with the tracked disk drawn (e.g. overlay.mp4)");
    app.add_option("--params", o->params_file,
                   "Tracker parameters file (YAML/JSON; a 'tracker' map or the root), as "
                   "ObjectTracker::Params");
    app.add_option("--threshold", o->threshold,
                   "Foreground threshold T on h_fg/(h_fg+h_bg) (default 0.5)")
        ->check(CLI::Range(0.0, 0.999));
    app.add_option("--update-rate", o->update_rate,
                   "Colour-model update weight per frame (default 0: fixed)")
        ->check(CLI::Range(0.0, 1.0));
    app.add_option("--colour-model", o->colour_model,
                   "Colour model: auto (default: the Lab model that best segments frame 0), gmm, "
                   "lab8, lab16, hsv, ab, or hs (the thesis's hue-saturation histograms)")
        ->check(CLI::IsMember({"auto", "hs", "gmm", "lab8", "lab16", "hsv", "ab"}));
    app.add_option("--min-init-iou", o->min_init_iou,
                   "Refuse the clip when the colour model segments frame 0 with an IoU against "
                   "the mask below this (default 0.5; 0 = never refuse)")
        ->check(CLI::Range(0.0, 1.0));
    app.add_flag("--no-window", o->no_window,
                 "Search the whole frame, not a window around the last disk");
    app.add_flag("--no-neutral-highlights", o->no_neutral,
                 "Let highlights and clipped pixels vote as background (the thesis's behaviour)");
    addVideoOutputOptions(app, o->encode);
    addCommonOptions(app, o->common);
    app.callback([o] {
        applyCommonOptions(o->common);
        runTrack(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("track", "Track a coloured ball through a video: per-frame masks and disks",
                      setupTrack);

}  // namespace vbme_app
