// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read / write / check of the calibration and camera-tracking option structs
// (VanishingPointCalibrator::Params: in vanishing.cpp).
#include <cmath>

#include "opencv2/vbme/calib/camera_tracking.hpp"
#include "opencv2/vbme/calib/colmap.hpp"
#include "opencv2/vbme/calib/frame_calibration.hpp"
#include "opencv2/vbme/core/params.hpp"

namespace cv {
namespace vbme {

namespace {

template <class T>
void writeMap(FileStorage& fs, const char* key, const T& v) {
    fs << key << "{";
    v.write(fs);
    fs << "}";
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// ColmapOptions

void ColmapOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "colmap options");
    in("executable", executable);
    in("threads", threads);
    in("mapper_threads", mapper_threads);
    in("random_seed", random_seed);
    in("overlap", overlap);
    in("vocab_tree", vocab_tree);
    in("max_num_features", max_num_features);
    in("timeout", timeout);
    in("min_model_size", min_model_size);
    in("abs_pose_min_num_inliers", abs_pose_min_num_inliers);
    in("database", database);
    in.finish();
    check();
}

void ColmapOptions::write(FileStorage& fs) const {
    fs << "executable" << executable << "threads" << threads << "mapper_threads" << mapper_threads
       << "random_seed" << random_seed << "overlap" << overlap << "vocab_tree" << vocab_tree
       << "max_num_features" << max_num_features << "timeout" << timeout << "min_model_size"
       << min_model_size << "abs_pose_min_num_inliers" << abs_pose_min_num_inliers;
    fs << "database" << database;
}

void ColmapOptions::check() const {
    const char* w = "colmap options";
    if (executable.empty())
        CV_Error(Error::StsBadArg,
                 "colmap options.executable = '': expected a program name or path");
    checkParam(threads == -1 || threads >= 1, w, "threads", threads, ">= 1 (-1: all cores)");
    checkParam(mapper_threads == -1 || mapper_threads >= 1, w, "mapper_threads", mapper_threads,
               ">= 1 (-1: all cores)");
    checkParam(random_seed >= 0, w, "random_seed", random_seed, ">= 0");
    checkParam(overlap >= 1, w, "overlap", overlap, ">= 1");
    checkParam(max_num_features >= 1, w, "max_num_features", max_num_features, ">= 1");
    checkParam(timeout >= 0, w, "timeout", timeout, ">= 0 seconds (0: no limit)");
    checkParam(min_model_size >= 2, w, "min_model_size", min_model_size, ">= 2 images");
    checkParam(abs_pose_min_num_inliers >= 3, w, "abs_pose_min_num_inliers",
               abs_pose_min_num_inliers, ">= 3");
}

// ---------------------------------------------------------------------------------------------
// KeyframeOptions

void KeyframeOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "keyframe options");
    in("features", features);
    in("max_motion", max_motion);
    in("min_overlap", min_overlap);
    in("max_gap", max_gap);
    in("stride", stride);
    in("sift_features", sift_features);
    in("overlap", overlap);
    in.finish();
    check();
}

void KeyframeOptions::write(FileStorage& fs) const {
    fs << "features" << features << "max_motion" << max_motion << "min_overlap" << min_overlap
       << "max_gap" << max_gap << "stride" << stride << "sift_features" << sift_features
       << "overlap" << overlap;
}

void KeyframeOptions::check() const {
    const char* w = "keyframe options";
    checkParam(features >= 1, w, "features", features, ">= 1");
    checkParam(max_motion > 0, w, "max_motion", max_motion, "> 0 (fraction of the width)");
    checkParam(min_overlap >= 0 && min_overlap <= 1, w, "min_overlap", min_overlap, "[0, 1]");
    checkParam(max_gap >= 1, w, "max_gap", max_gap, ">= 1 frames");
    checkParam(stride >= 0, w, "stride", stride, ">= 0 (0: keyframe selection)");
    checkParam(sift_features >= 1, w, "sift_features", sift_features, ">= 1");
    checkParam(overlap >= 1, w, "overlap", overlap, ">= 1");
}

// ---------------------------------------------------------------------------------------------
// CameraTrackingOptions

void CameraTrackingOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "camera tracking options");
    in.choice("method", method, {{"keyframes", KEYFRAMES}, {"full", FULL}});
    in("keyframes", keyframes);
    in("pnp", pnp);
    in("pnp_min_inliers", pnp_min_inliers);
    in("pnp_max_rms", pnp_max_rms);
    in("global_refine", global_refine);
    in("robust_scale", robust_scale);
    in("scale_tolerance", scale_tolerance);
    in("stride", stride);
    in("refine", refine);
    in("plane_tolerance", plane_tolerance);
    in("smooth_sigma", smooth_sigma);
    in("max_scale_spread", max_scale_spread);
    in("max_face_distance", max_face_distance);
    in("mapper_retries", mapper_retries);
    in("joint_passes", joint_passes);
    in("colmap", colmap);
    in.finish();
    check();
}

void CameraTrackingOptions::write(FileStorage& fs) const {
    fs << "method" << (method == FULL ? "full" : "keyframes");
    writeMap(fs, "keyframes", keyframes);
    fs << "pnp" << (int)pnp << "pnp_min_inliers" << pnp_min_inliers << "pnp_max_rms" << pnp_max_rms
       << "global_refine" << (int)global_refine << "robust_scale" << (int)robust_scale
       << "scale_tolerance" << scale_tolerance << "stride" << stride << "refine" << (int)refine
       << "plane_tolerance" << plane_tolerance << "smooth_sigma" << smooth_sigma
       << "max_scale_spread" << max_scale_spread << "max_face_distance" << max_face_distance
       << "mapper_retries" << mapper_retries << "joint_passes" << joint_passes;
    writeMap(fs, "colmap", colmap);
}

void CameraTrackingOptions::check() const {
    const char* w = "camera tracking options";
    checkParam(method == KEYFRAMES || method == FULL, w, "method", method,
               "KEYFRAMES (0) or FULL (1)");
    keyframes.check();
    checkParam(pnp_min_inliers >= 4, w, "pnp_min_inliers", pnp_min_inliers, ">= 4");
    checkParam(pnp_max_rms > 0, w, "pnp_max_rms", pnp_max_rms, "> 0 pixels");
    checkParam(scale_tolerance > 0, w, "scale_tolerance", scale_tolerance, "> 0");
    checkParam(stride >= 1, w, "stride", stride, ">= 1");
    checkParam(plane_tolerance > 0, w, "plane_tolerance", plane_tolerance, "> 0 m");
    checkParam(smooth_sigma >= 0, w, "smooth_sigma", smooth_sigma, ">= 0 frames (0: off)");
    checkParam(max_scale_spread > 0, w, "max_scale_spread", max_scale_spread, "> 0");
    checkParam(max_face_distance > 0, w, "max_face_distance", max_face_distance, "> 0 m");
    checkParam(mapper_retries >= 0, w, "mapper_retries", mapper_retries, ">= 0");
    checkParam(joint_passes >= 1, w, "joint_passes", joint_passes, ">= 1");
    colmap.check();
}

// ---------------------------------------------------------------------------------------------
// FrameCalibrationOptions

void FrameCalibrationOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "frame calibration options");
    in("auto_detect", auto_detect);
    in("camera_height", camera_height);
    in("default_camera_height", default_camera_height);
    in("vp", vp);
    in.finish();
    check();
}

void FrameCalibrationOptions::write(FileStorage& fs) const {
    fs << "auto_detect" << (int)auto_detect << "camera_height" << camera_height
       << "default_camera_height" << default_camera_height;
    writeMap(fs, "vp", vp);
}

void FrameCalibrationOptions::check() const {
    const char* w = "frame calibration options";
    checkParam(camera_height >= 0 && std::isfinite(camera_height), w, "camera_height",
               camera_height, ">= 0 m (0: the annotation's)");
    checkParam(default_camera_height > 0 && std::isfinite(default_camera_height), w,
               "default_camera_height", default_camera_height, "> 0 m");
    vp.check();
}

}  // namespace vbme
}  // namespace cv
