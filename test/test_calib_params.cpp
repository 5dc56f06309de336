// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read/write/check of the calibration and camera-tracking option structs: every field survives
// a round trip, unknown keys and out-of-range values are refused by name.
#include <gtest/gtest.h>

#include "opencv2/vbme/calib/camera_tracking.hpp"
#include "opencv2/vbme/calib/colmap.hpp"
#include "opencv2/vbme/calib/frame_calibration.hpp"
#include "params_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using namespace vbme_test;

namespace {

VanishingPointCalibrator::Params changedVp() {
    VanishingPointCalibrator::Params p;
    p.focal = 500;
    p.principal_point = Point2d(319.5, 239.5);
    p.principal_point_from_orthocenter = true;
    p.min_segment_length = 20;
    p.max_segments = 200;
    p.inlier_angle_deg = 2.0;
    p.ransac_iterations = 1000;
    p.min_focal = 0.5;
    p.max_focal = 4.0;
    p.seed = 7;
    p.min_confidence = 0.5;
    p.method = VanishingPointCalibrator::Params::RANSAC;
    p.focal_prior = 600;
    p.focal_prior_sigma = 0.2;
    p.estimate_distortion = true;
    p.fld_pass = false;
    p.fld_pass_below_confidence = 0.8;
    p.edgel_scoring = false;
    p.pass_weight = 0.75;
    p.upright_prior = 4;
    return p;
}

ColmapOptions changedColmap() {
    ColmapOptions o;
    o.executable = "/opt/colmap/bin/colmap";
    o.threads = 4;
    o.mapper_threads = 2;
    o.random_seed = 3;
    o.overlap = 5;
    o.vocab_tree = "tree.bin";
    o.max_num_features = 2000;
    o.timeout = 600;
    o.min_model_size = 5;
    o.abs_pose_min_num_inliers = 20;
    o.database = "run1/database.db";
    return o;
}

KeyframeOptions changedKeyframes() {
    KeyframeOptions k;
    k.features = 400;
    k.max_motion = 0.1;
    k.min_overlap = 0.5;
    k.max_gap = 10;
    k.stride = 3;
    k.sift_features = 1024;
    k.overlap = 4;
    return k;
}

}  // namespace

TEST(CalibParams, VanishingPointParams) {
    expectRoundTrip(changedVp());
    expectUnknownKeyRefused<VanishingPointCalibrator::Params>("min_focal");
    VanishingPointCalibrator::Params bad;
    bad.max_focal = 0.2;  // below min_focal
    expectRejected(bad, "max_focal");
    bad = VanishingPointCalibrator::Params();
    bad.min_confidence = 1.5;
    expectRejected(bad, "min_confidence");
}

TEST(CalibParams, FrameCalibrationOptions) {
    FrameCalibrationOptions o;
    o.auto_detect = true;
    o.camera_height = 1.4;
    o.default_camera_height = 1.5;
    o.vp = changedVp();
    expectRoundTrip(o);
    expectUnknownKeyRefused<FrameCalibrationOptions>("auto_detect");
    FrameCalibrationOptions bad;
    bad.default_camera_height = 0;
    expectRejected(bad, "default_camera_height");
    bad = FrameCalibrationOptions();
    bad.vp.inlier_angle_deg = 0;
    expectRejected(bad, "inlier_angle_deg");
}

TEST(CalibParams, ColmapOptions) {
    expectRoundTrip(changedColmap());
    expectUnknownKeyRefused<ColmapOptions>("mapper_threads");
    ColmapOptions bad;
    bad.timeout = -1;
    expectRejected(bad, "timeout");
    bad = ColmapOptions();
    bad.executable.clear();
    expectRejected(bad, "executable");
}

TEST(CalibParams, KeyframeOptions) {
    expectRoundTrip(changedKeyframes());
    expectUnknownKeyRefused<KeyframeOptions>("max_gap");
    KeyframeOptions bad;
    bad.min_overlap = 1.5;
    expectRejected(bad, "min_overlap");
}

TEST(CalibParams, CameraTrackingOptions) {
    CameraTrackingOptions o;
    o.method = CameraTrackingOptions::FULL;
    o.keyframes = changedKeyframes();
    o.pnp = false;
    o.pnp_min_inliers = 30;
    o.pnp_max_rms = 2.0;
    o.global_refine = false;
    o.robust_scale = false;
    o.scale_tolerance = 0.1;
    o.stride = 2;
    o.refine = false;
    o.plane_tolerance = 0.1;
    o.smooth_sigma = 2.0;
    o.max_scale_spread = 0.03;
    o.max_face_distance = 0.004;
    o.mapper_retries = 1;
    o.joint_passes = 2;
    o.colmap = changedColmap();
    expectRoundTrip(o);
    expectUnknownKeyRefused<CameraTrackingOptions>("pnp_max_rms");
    CameraTrackingOptions bad;
    bad.stride = 0;
    expectRejected(bad, "stride");
    bad = CameraTrackingOptions();
    bad.colmap.overlap = 0;
    expectRejected(bad, "overlap");
    bad = CameraTrackingOptions();
    bad.mapper_retries = -1;
    expectRejected(bad, "mapper_retries");
    bad = CameraTrackingOptions();
    bad.joint_passes = 0;
    expectRejected(bad, "joint_passes");
}
