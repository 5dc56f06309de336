// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE). vbme track-camera: camera path of a hand-held video in the
// annotated room's frame (COLMAP).
#include <cstdio>
#include <filesystem>

#include <opencv2/vbme/calib/camera_tracking.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct TrackCameraOptions {
    std::string video, scene, out, work, overlay, colmap = "colmap";
    int stride = 1, threads = 2, overlap = 10, seed = 0, colmap_timeout = 0;
    bool mean_scale = false, no_refine = false;
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
    checkOverwrite(o.out, o.common.force);
    const fs::path out(o.out);
    const std::string colmap_dir = (out.parent_path() / (out.stem().string() + "_colmap")).string();
    if (!o.overlay.empty()) checkOverwrite(o.overlay, o.common.force);
    if (!o.blender.empty()) checkOverwrite(o.blender, o.common.force);
    checkOverwrite((out.parent_path() / (out.stem().string() + "_report.yml")).string(),
                   o.common.force);
    const Scene scene = Scene::read(o.scene);
    const std::string work =
        o.work.empty() ? (out.parent_path() / (out.stem().string() + "_work")).string() : o.work;

    CameraTrackingOptions opt;
    opt.stride = o.stride;
    opt.robust_scale = !o.mean_scale;
    opt.refine = !o.no_refine;
    opt.smooth_sigma = o.smooth;
    opt.colmap.executable = o.colmap;
    opt.colmap.timeout = o.colmap_timeout;
    opt.colmap.threads = o.threads;
    opt.colmap.overlap = o.overlap;
    opt.colmap.random_seed = o.seed;
    opt.colmap.vocab_tree = o.vocab_tree;
    CameraTrackingReport r;
    const CameraPath path = trackCameraVideo(o.video, scene, work, opt, &r);

    if (!o.overlay.empty()) {
        VideoReader reader(o.video);
        VideoSink sink(o.overlay, reader.fps(), reader.frameSize(),
                       sinkOptionsFrom(reader, o.overlay, o.encode));
        Progress progress("overlay", (int64)path.frames.size());
        Mat f;
        for (size_t i = 0; i < path.frames.size() && reader.read(f); ++i) {
            drawRoomBox(
                f, path.camera(i), scene.room,
                path.frames[i].source == CameraPath::SFM ? Scalar(0, 255, 255)
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
    path.write(o.out);
    // The report beside the track.
    const std::string report = (out.parent_path() / (out.stem().string() + "_report.yml")).string();
    {
        AtomicFile rf(report);
        {
            FileStorage fs(rf.tempPath(), FileStorage::WRITE);
            fs << "frames" << r.frames << "registered" << r.registered << "interpolated"
               << r.interpolated << "colmap_models" << r.models << "reprojection_rms_px"
               << r.reprojection_rms << "refined_reprojection_rms_px" << r.refined_rms
               << "points_on_box_faces" << r.plane_points << "scale_m_per_unit" << r.scale.scale
               << "scale_relative_spread" << r.scale.spread << "scale_points_used" << r.scale.used
               << "scale_points_total" << r.scale.total << "seconds" << r.seconds;
        }
        rf.commit();
    }
    std::printf(
        "camera path of %d frames: %d from SfM, %d interpolated (%d COLMAP model(s))\n"
        "reprojection RMS %.3f px (%.3f px after refinement, %d points tied to the box)\n"
        "scale %.5f m per SfM unit from %d of %d frame-0 points (relative spread %.4f)\n"
        "%.1f s (%.2f s/frame); written: %s, %s, COLMAP text model %s\n",
        r.frames, r.registered, r.interpolated, r.models, r.reprojection_rms, r.refined_rms,
        r.plane_points, r.scale.scale, r.scale.used, r.scale.total, r.scale.spread, r.seconds,
        r.frames ? r.seconds / r.frames : 0.0, o.out.c_str(), report.c_str(), colmap_dir.c_str());
}

void setupTrackCamera(CLI::App& app) {
    auto o = std::make_shared<TrackCameraOptions>();
    app.footer(
        "Runs COLMAP (headless, CPU) on the video's frames with the "
        "annotated intrinsics held fixed,\n"
        "aligns the reconstruction to the annotated frame-0 camera and "
        "scales it by the robust Eq. 5.3\n"
        "(feature depths on the room box / SfM depths). Writes the "
        "camera-path YAML (one entry per frame,\n"
        "source sfm or interpolated) and a COLMAP text model beside it "
        "(<out>_colmap/). The work folder\n"
        "(default <out>_work/ beside the output) keeps the frames and "
        "COLMAP's run: a second run resumes.");
    app.add_option("--video", o->video, "Input video file or image folder")->required();
    app.add_option("--scene", o->scene,
                   "Scene file of frame 0 (from vbme calibrate): camera and room")
        ->required();
    app.add_option("--out", o->out, "Output camera-path file (YAML)")->required();
    app.add_option("--work", o->work, "Work folder (frames, COLMAP database and log)");
    app.add_option("--stride", o->stride, "Reconstruct every k-th frame, interpolate the rest")
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
    app.add_option("--overlap", o->overlap, "Sequential matching: neighbours matched per frame")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
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
