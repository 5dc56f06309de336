// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read/write/check of the inpainters' Params: every field survives a round trip, unknown keys
// and out-of-range values are refused by name.
#include <gtest/gtest.h>

#include "opencv2/vbme/inpaint/consensus.hpp"
#include "opencv2/vbme/inpaint/exemplar.hpp"
#include "opencv2/vbme/inpaint/video.hpp"
#include "params_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using namespace vbme_test;

namespace {

ExemplarInpainter::Params changedExemplar() {
    ExemplarInpainter::Params p;
    p.patch_size = 7;
    p.method = PATCH_SEARCH_VPTREE;
    p.color_space = PATCH_COLOR_RGB;
    p.local_radius = 30;
    p.pm_random_samples = 32;
    p.pm_search_rounds = 3;
    p.pm_band_iterations = 2;
    p.vp_candidates = 50;
    p.vp_dims = 32;
    p.vp_stride = 2;
    p.vp_refine = 1;
    p.vp_max_checks = 1000;
    p.seed = 12345;
    return p;
}

}  // namespace

TEST(InpaintParams, ExemplarParams) {
    expectRoundTrip(changedExemplar());
    expectUnknownKeyRefused<ExemplarInpainter::Params>("patch_size");
    ExemplarInpainter::Params bad;
    bad.patch_size = 8;
    expectRejected(bad, "patch_size");
    bad = ExemplarInpainter::Params();
    bad.vp_stride = 0;
    expectRejected(bad, "vp_stride");
    // create() refuses through check(), naming the field
    EXPECT_NE(thrownBy([&] { ExemplarInpainter::create(bad); }).find("vp_stride"),
              std::string::npos);
}

TEST(InpaintParams, ConsensusParams) {
    ConsensusInpainter::Params p;
    p.exemplar = changedExemplar();
    p.temporal_radius = 5;
    p.motion_factor = 2.5;
    p.min_radius = 3;
    p.max_radius = 10;
    p.alignment = CONSENSUS_ALIGN_HOMOGRAPHY;
    p.features = 800;
    p.local_reach = 4.0;
    p.identity_tolerance = 0.25;
    p.max_ring_error = 10.0;
    p.ring_sigma = 5.0;
    p.temporal_sigma = 4.0;
    p.hole_margin = 3;
    p.shadow_reach = 2.5;
    p.shadow_threshold = 0.1;
    p.zone_weight = 0.75;
    p.inlier_distance = 10.0;
    p.shadows = SHADOWS_KEEP;
    p.shadow_min_area = 0.1;
    p.shadow_smooth = 3.0;
    p.shadow_relight = true;
    p.reuse_previous = false;
    expectRoundTrip(p);
    expectUnknownKeyRefused<ConsensusInpainter::Params>("motion_factor");
    ConsensusInpainter::Params bad;
    bad.max_radius = 2;  // below min_radius
    expectRejected(bad, "max_radius");
    bad = ConsensusInpainter::Params();
    bad.zone_weight = 1.5;
    expectRejected(bad, "zone_weight");
    bad = ConsensusInpainter::Params();
    bad.exemplar.patch_size = 1;  // nested exemplar settings are checked too
    expectRejected(bad, "patch_size");
}

TEST(InpaintParams, VideoInpainterParams) {
    VideoInpainter::Params p;
    p.exemplar = changedExemplar();
    p.temporal_radius = 4;
    p.max_ring_error = 8.0;
    p.ring_width = 3;
    p.identity_tolerance = 0.25;
    p.hole_margin = 2;
    p.reuse_previous = false;
    p.features = 1000;
    p.refine_alignment = false;
    expectRoundTrip(p);
    expectUnknownKeyRefused<VideoInpainter::Params>("ring_width");
    VideoInpainter::Params bad;
    bad.ring_width = 0;
    expectRejected(bad, "ring_width");
}
