// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read/write/check of the track module's params structs: every field survives a round trip,
// unknown keys and out-of-range values are refused by name.
#include <gtest/gtest.h>

#include "opencv2/vbme/track/disk.hpp"
#include "opencv2/vbme/track/object_tracker.hpp"
#include "opencv2/vbme/track/video_tracking.hpp"
#include "params_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using namespace vbme_test;

namespace {

ObjectTracker::Params changedTracker() {
    ObjectTracker::Params p;
    p.h_bins = 20;
    p.s_bins = 16;
    p.threshold = 0.4f;
    p.open_size = 7;
    p.close_size = 11;
    p.fill_holes = false;
    p.use_search_window = false;
    p.window_scale = 3.f;
    p.window_margin = 10;
    p.neutral_highlights = false;
    p.highlight_min_value = 240;
    p.highlight_max_saturation = 60;
    p.lost_threshold = 0.25f;
    p.model_update_rate = 0.125f;
    p.min_update_confidence = 0.75f;
    p.min_step = 0.5f;
    p.colour_model = TRACK_COLOUR_LAB16;
    p.min_init_iou = 0.375f;
    p.max_init_overlap = 0.75f;
    p.predict_motion = false;
    p.max_radius_change = 0.25f;
    p.evidence_confidence = false;
    p.edge_refine = false;
    p.redetect = false;
    p.redetect_threshold = 0.5f;
    return p;
}

}  // namespace

TEST(TrackParams, ObjectTrackerParams) {
    expectRoundTrip(changedTracker());
    expectUnknownKeyRefused<ObjectTracker::Params>("h_bins");
    ObjectTracker::Params bad;
    bad.h_bins = 0;
    expectRejected(bad, "h_bins");
    bad = ObjectTracker::Params();
    bad.colour_model = 7;
    expectRejected(bad, "colour_model");
    bad = ObjectTracker::Params();
    bad.min_step = 0;
    expectRejected(bad, "min_step");
}

TEST(TrackParams, DiskFitParams) {
    DiskFitParams p;
    p.min_step = 1.f;
    p.max_iterations = 500;
    p.min_radius = 3.f;
    p.max_radius = 40.f;
    expectRoundTrip(p);
    expectUnknownKeyRefused<DiskFitParams>("min_radius");
    DiskFitParams bad;
    bad.min_step = -0.5f;
    expectRejected(bad, "min_step");
    bad = DiskFitParams();
    bad.max_radius = 1.f;  // below min_radius
    expectRejected(bad, "max_radius");
}

TEST(TrackParams, TrackVideoOptions) {
    TrackVideoOptions o;
    o.params = changedTracker();
    o.overlay = "overlay.mp4";
    o.overlay_encode = changedVideoSinkOptions();
    o.force = true;
    expectRoundTrip(o);
    expectUnknownKeyRefused<TrackVideoOptions>("overlay");
    TrackVideoOptions bad;
    bad.params.s_bins = 300;
    expectRejected(bad, "s_bins");
    bad = TrackVideoOptions();
    bad.overlay_encode.crf = -1;
    expectRejected(bad, "crf");
}
