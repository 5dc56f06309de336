// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE). vbme track-camera: camera path of a hand-held video in the
// annotated room's frame (COLMAP).
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include <opencv2/vbme/calib/camera_tracking.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct TrackCameraOptions {
    std::string video, scene, out, work, overlay, colmap = "colmap";
    int stride = 1, threads = 2, overlap = 0, seed = 0, features = 0, max_gap = 15,
        colmap_timeout = 0;
    double keyframe_motion = 0.08, min_overlap = 0.6;
    std::string method = "keyframes";
    bool mean_scale = false, no_refine = false, no_pnp = false, no_joint = false;
    double smooth = 0;
    std::string blender;
    std::string vocab_tree;
    cv::vbme::VideoSinkOptions encode;
    CommonOptions common;
};

void runTrackCamera(const TrackCameraOptions& o) {
    using namespace cv;
    using namespace cv::vbme;
    namespace fs = std::filesystem;
    const fs::path out(o.out);
    const std::string colmap_dir = (out.parent_path() / (out.stem().string() + "_colmap")).string();
    const std::string report = (out.parent_path() / (out.stem().string() + "_report.yml")).string();
    const std::string work =
        o.work.empty() ? (out.parent_path() / (out.stem().string() + "_work")).string() : o.work;
    // The outputs, the track last: its presence means the run finished. While they are written
    // their names are listed in <work>/outputs_pending.txt, so that a run killed among them can
    // be rerun (it replaces them) without --force; a finished run removes the list.
    std::vector<std::string> outputs;
    if (!o.overlay.empty()) outputs.push_back(o.overlay);
    if (!o.blender.empty()) outputs.push_back(o.blender);
    outputs.push_back(report);
    outputs.push_back(o.out);
    const std::string pending = (fs::path(work) / "outputs_pending.txt").string();
    std::set<std::string> interrupted;
    {
        std::ifstream in(pending);
        for (std::string line; std::getline(in, line);)
            interrupted.insert(line);
    }
    for (const auto& p : outputs)
        if (!interrupted.count(p)) checkOverwrite(p, o.common.force);
    const Scene scene = Scene::read(o.scene);

    CameraTrackingOptions opt;
    opt.stride = o.stride;
    opt.robust_scale = !o.mean_scale;
    opt.refine = !o.no_refine;
    opt.smooth_sigma = o.smooth;
    opt.colmap.executable = o.colmap;
    opt.colmap.timeout = o.colmap_timeout;
    opt.colmap.threads = o.threads;
    opt.colmap.overlap = o.overlap > 0 ? o.overlap : 10;
    if (o.features > 0) opt.colmap.max_num_features = o.features;
    opt.method =
        o.method == "full" ? CameraTrackingOptions::FULL : CameraTrackingOptions::KEYFRAMES;
    if (o.overlap > 0) opt.keyframes.overlap = o.overlap;
    if (o.features > 0) opt.keyframes.sift_features = o.features;
    opt.keyframes.max_gap = o.max_gap;
    opt.keyframes.max_motion = o.keyframe_motion;
    opt.keyframes.min_overlap = o.min_overlap;
    opt.pnp = !o.no_pnp;
    opt.global_refine = !o.no_joint;
    opt.colmap.random_seed = o.seed;
    opt.colmap.vocab_tree = o.vocab_tree;
    CameraTrackingReport r;
    const CameraPath path = trackCameraVideo(o.video, scene, work, opt, &r);
    {
        AtomicFile pf(pending);
        {
            std::ofstream f(pf.tempPath());
            for (const auto& p : outputs)
                f << p << "\n";
            if (!f.flush()) CV_Error(Error::StsError, "cannot write '" + pending + "'");
        }
        pf.commit();
    }

    if (!o.overlay.empty()) {
        VideoReader reader(o.video);
        // full chroma unless a pixel format is asked for: 4:2:0 blurs the one-pixel box and text
        VideoSinkOptions so = sinkOptionsFrom(reader, o.overlay, o.encode);
        so.full_chroma = true;
        VideoSink sink(o.overlay, reader.fps(), reader.frameSize(), so);
        Progress progress("overlay", (int64)path.frames.size());
        Mat f;
        for (size_t i = 0; i < path.frames.size() && reader.read(f); ++i) {
            drawRoomBox(
                f, path.camera(i), scene.room,
                path.frames[i].source == CameraPath::SFM   ? Scalar(0, 255, 255)
                : path.frames[i].source == CameraPath::PNP ? Scalar(0, 255, 0)
                                                           : Scalar(0, 128, 255),
                format("frame %zu  %s", i, CameraPath::sourceName(path.frames[i].source).c_str()));
            sink.write(f, reader.timestamp());
            progress.tick();
        }
        progress.finish();
        sink.close();
    }
    toColmapModel(path).writeText(colmap_dir);
    if (!o.blender.empty()) {
        VideoReader reader(o.video);
        writeBlenderScript(o.blender, path, scene.room, reader.fps());
    }
    // The report beside the track, then the track.
    {
        AtomicFile rf(report);
        {
            FileStorage fs(rf.tempPath(), FileStorage::WRITE);
            fs << "method" << o.method << "frames" << r.frames << "keyframes" << r.keyframes
               << "registered" << r.registered << "pnp" << r.pnp << "interpolated" << r.interpolated
               << "pnp_rms_px" << r.pnp_rms << "pnp_mean_inliers" << r.pnp_inliers
               << "joint_adjustment_applied" << (int)r.ba_applied << "joint_pass_moves_m"
               << r.ba_pass_moves << "joint_rms_px" << r.ba_rms << "joint_worst_frame_rms_px"
               << r.ba_worst_frame_rms << "joint_points" << r.ba_points << "joint_observations"
               << r.ba_observations << "joint_points_on_box_faces" << r.ba_on_face
               << "colmap_models" << r.models << "reprojection_rms_px" << r.reprojection_rms
               << "refined_reprojection_rms_px" << r.refined_rms << "points_on_box_faces"
               << r.plane_points << "scale_m_per_unit" << r.scale.scale << "scale_relative_spread"
               << r.scale.spread << "scale_points_used" << r.scale.used << "scale_points_total"
               << r.scale.total << "face_distance_m" << r.face_distance << "confident"
               << (int)r.confident << "doubt" << r.doubt << "seconds" << r.seconds
               << "seconds_per_frame" << (r.frames ? r.seconds / r.frames : 0.0);
            auto stageMap = [&](const char* name,
                                const std::vector<std::pair<std::string, double>>& stages) {
                // A stage run more than once (COLMAP again on a doubtful model) is summed: a map
                // holds each key once.
                std::vector<std::pair<std::string, double>> summed;
                for (const auto& st : stages) {
                    std::string key = st.first;
                    for (char& ch : key)
                        if (!std::isalnum((unsigned char)ch)) ch = '_';
                    auto it = std::find_if(summed.begin(), summed.end(),
                                           [&](const auto& kv) { return kv.first == key; });
                    if (it == summed.end())
                        summed.emplace_back(key, st.second);
                    else
                        it->second += st.second;
                }
                fs << name << "{";
                for (const auto& kv : summed)
                    fs << kv.first << kv.second;
                fs << "}";
            };
            fs << "mapper_scale_spreads"
               << "[";
            for (double v : r.mapper_scale_spreads)
                fs << v;
            fs << "]";
            stageMap("stage_seconds", r.stage_seconds);
            stageMap("stage_cpu_seconds", r.stage_cpu_seconds);
        }
        rf.commit();
    }
    path.write(o.out);
    std::error_code ec;
    fs::remove(pending, ec);
    std::string stages;
    for (const auto& st : r.stage_seconds)
        stages += format("%s%s %.1f s", stages.empty() ? "" : ", ", st.first.c_str(), st.second);
    std::printf("method %s: %d keyframes given to COLMAP; stages: %s\n", o.method.c_str(),
                r.keyframes, stages.c_str());
    std::printf(
        "camera path of %d frames: %d from SfM, %d by PnP (inlier RMS %.3f px, %.0f inliers per "
        "frame), %d interpolated (%d COLMAP model(s))\n"
        "joint adjustment%s: %d points, %d observations, RMS %.3f px (worst frame %.3f px), "
        "%.0f %% of the points on the box's faces\n"
        "reprojection RMS %.3f px (%.3f px after refinement, %d points tied to the box)\n"
        "scale %.5f m per SfM unit from %d of %d frame-0 points (relative spread %.4f); points "
        "%.2f mm from the box's faces (median): %s\n"
        "%.1f s (%.2f s/frame); written: %s, %s, COLMAP text model %s\n",
        r.frames, r.registered, r.pnp, r.pnp_rms, r.pnp_inliers, r.interpolated, r.models,
        r.ba_applied ? "" : " (not applied)", r.ba_points, r.ba_observations, r.ba_rms,
        r.ba_worst_frame_rms, 100 * r.ba_on_face, r.reprojection_rms, r.refined_rms, r.plane_points,
        r.scale.scale, r.scale.used, r.scale.total, r.scale.spread, 1000 * r.face_distance,
        r.confident ? "confident" : ("NOT confident: " + r.doubt).c_str(), r.seconds,
        r.frames ? r.seconds / r.frames : 0.0, o.out.c_str(), report.c_str(), colmap_dir.c_str());
}

void setupTrackCamera(CLI::App& app) {
    auto o = std::make_shared<TrackCameraOptions>();
    app.footer(
        "Chooses keyframes by the motion and survival of corners tracked through the video,\n"
        "runs COLMAP (headless, CPU) on the keyframes with the annotated intrinsics held fixed,\n"
        "aligns the reconstruction to the annotated frame-0 camera, scales it by the robust\n"
        "Eq. 5.3 (feature depths on the room box / SfM depths), and registers every other frame\n"
        "by PnP against the model's points (tracked into it from the neighbouring keyframes).\n"
        "--method full runs COLMAP on every frame instead. Writes the camera-path YAML (one entry\n"
        "per frame, source sfm, pnp or interpolated), a report (<out>_report.yml: stage times,\n"
        "counts, errors) and a COLMAP text model (<out>_colmap/). The work folder (default\n"
        "<out>_work/ beside the output) keeps COLMAP's run: a second run resumes. The track is\n"
        "written last; a run killed while writing the outputs is rerun without --force.");
    app.add_option("--video", o->video, "Input video file or image folder")->required();
    app.add_option("--scene", o->scene,
                   "Scene file of frame 0 (from vbme calibrate): camera and room")
        ->required();
    app.add_option("--out", o->out, "Output camera-path file (YAML)")->required();
    app.add_option("--work", o->work, "Work folder (frames, COLMAP database and log)");
    app.add_option("--method", o->method,
                   "keyframes: COLMAP on keyframes chosen by tracked-corner motion and overlap, "
                   "every other frame registered by PnP; full: COLMAP on every (stride-th) frame")
        ->check(CLI::IsMember({"keyframes", "full"}))
        ->capture_default_str();
    app.add_option("--stride", o->stride,
                   "keyframes: a keyframe every k-th frame instead of choosing them (the rest by "
                   "PnP); full: reconstruct every k-th frame, interpolate the rest")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    app.add_option("--overlay", o->overlay,
                   "Also write a video with the room box drawn with each frame's camera");
    app.add_option("--colmap", o->colmap, "The colmap program")->capture_default_str();
    app.add_option("--colmap-timeout", o->colmap_timeout,
                   "Seconds each COLMAP step may run before it is stopped as hung (0: no limit)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    app.add_option("--threads", o->threads, "Threads for feature extraction and matching")
        ->check(CLI::Range(1, 256))
        ->capture_default_str();
    app.add_option("--overlap", o->overlap,
                   "Sequential matching: neighbours matched per image (default 6 keyframes, 10 "
                   "full)")
        ->check(CLI::Range(1, 1000));
    app.add_option("--features", o->features,
                   "SIFT features per image (default 2048 keyframes, 4096 full)")
        ->check(CLI::Range(64, 100000));
    app.add_option("--max-gap", o->max_gap, "keyframes: at most this many frames between keyframes")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    app.add_option("--keyframe-motion", o->keyframe_motion,
                   "keyframes: new keyframe when tracked corners moved this fraction of the width")
        ->check(CLI::Range(0.001, 1.0))
        ->capture_default_str();
    app.add_option("--min-overlap", o->min_overlap,
                   "keyframes: new keyframe when fewer of the last keyframe's corners survive")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    app.add_flag("--no-pnp", o->no_pnp, "keyframes: interpolate the other frames instead of PnP");
    app.add_flag("--no-joint", o->no_joint,
                 "keyframes: skip the joint adjustment of all frames with corner tracks");
    app.add_option("--seed", o->seed, "COLMAP random seed")->capture_default_str();
    app.add_option("--vocab-tree", o->vocab_tree, "Vocabulary-tree file: enables loop detection");
    app.add_option("--smooth", o->smooth,
                   "Smoothness prior on the trajectory, width in frames (0: none)")
        ->check(CLI::Range(0.0, 1000.0))
        ->capture_default_str();
    app.add_flag("--no-refine", o->no_refine,
                 "Skip the Ceres refinement (bundle adjustment with points tied to the box faces)");
    app.add_option("--blender", o->blender,
                   "Also write a Python script that recreates the camera track in Blender");
    app.add_flag("--mean-scale", o->mean_scale,
                 "Use the thesis's plain mean for Eq. 5.3 instead of the robust estimate");
    addVideoOutputOptions(app, o->encode);
    addCommonOptions(app, o->common);
    app.callback([o] {
        applyCommonOptions(o->common);
        runTrackCamera(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("track-camera",
                      "Camera path of a hand-held video in the annotated room (COLMAP)",
                      setupTrackCamera);

}  // namespace vbme_app
