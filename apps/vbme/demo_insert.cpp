// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme demo, part "insert": renders a hand-held video of a textured room (and the same video
// with an object really in it, the truth), writes the annotation a user would click, then runs
// calibrate -> track-camera -> insert exactly as the commands do and compares with the truth.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/insertion_sequence.hpp>
#include <opencv2/vbme/pipeline/insertion.hpp>

#include "demo.hpp"
#include "pipeline_progress.hpp"

namespace vbme_app {

namespace {

namespace fs = std::filesystem;
using namespace cv;
using namespace cv::vbme;

double rotationErrorDeg(const Matx33d& a, const Matx33d& b) {
    const Matx33d d = a * b.t();
    const double c = std::max(-1.0, std::min(1.0, (d(0, 0) + d(1, 1) + d(2, 2) - 1) / 2));
    return std::acos(c) * 180 / CV_PI;
}

void label(Mat& img, const std::string& text) {
    const int font = FONT_HERSHEY_SIMPLEX;
    const double scale = std::max(0.4, img.rows / 600.0);
    putText(img, text, Point(8, (int)(24 * scale + 4)), font, scale, Scalar(0, 0, 0), 3, LINE_AA);
    putText(img, text, Point(8, (int)(24 * scale + 4)), font, scale, Scalar(255, 255, 255), 1,
            LINE_AA);
}

}  // namespace

DemoResult runInsertionDemo(const DemoContext& ctx) {
    const auto t_start = std::chrono::steady_clock::now();
    DemoResult result;
    const fs::path dir = ctx.dir;
    const std::string inserted = (dir / "inserted.mp4").string(),
                      truth_mp4 = (dir / "truth.mp4").string(),
                      compare_mp4 = (dir / "compare.mp4").string(),
                      scene_file = (dir / "scene.yml").string(),
                      insert_scene = (dir / "scene_with_object.yml").string(),
                      cameras_file = (dir / "cameras.yml").string();
    for (const std::string& f : {inserted, truth_mp4, compare_mp4})
        checkOverwrite(f, ctx.force);
    if (ctx.force)  // a fresh run: stale frames of an earlier run must not be resumed
        for (const char* sub : {"input", "tracking", "insert_work"})
            fs::remove_all(dir / sub);

    // 1. The input a user would bring: the video and the frame-0 annotation.
    SyntheticInsertionSequence::Params gp;
    gp.size = Size(ctx.width, ctx.height);
    if (ctx.frames > 0) gp.frames = ctx.frames;
    if (ctx.spp > 0) gp.spp = ctx.spp;
    std::printf(
        "demo insert: rendering a %d-frame %dx%d hand-held room video (%d spp) and the "
        "truth with the object\n",
        gp.frames, gp.size.width, gp.size.height, gp.spp);
    std::fflush(stdout);
    SyntheticInsertionSequence seq((dir / "input").string(), gp);
    const double gen_spf = seq.writeVideos(false);
    const std::string video = seq.inputVideoPath();
    if (gen_spf > 0)
        result.figures.push_back(
            format("input: %d frames %dx%d path traced at %d spp, %.1f s/frame (input and truth "
                   "in one differential pass)",
                   gp.frames, gp.size.width, gp.size.height, gp.spp, gen_spf));

    // 2. vbme calibrate --video input.mkv --annotation annotation.yml --out scene.yml
    const auto t_cal = std::chrono::steady_clock::now();
    Mat frame0;
    {
        VideoReader reader(video);
        if (!reader.read(frame0)) CV_Error(Error::StsError, "demo: the input video is empty");
    }
    const FrameAnnotation ann = FrameAnnotation::read(seq.annotationPath());
    FrameCalibrationOptions copt;
    FrameCalibration fc;
    Scene scene = calibrateFrame(frame0, ann, copt, &fc);
    {
        Mat ov;
        drawCalibrationOverlay(frame0, ov, scene, fc);
        imwriteAtomic((dir / "calibration_overlay.png").string(), ov);
    }
    scene.write(scene_file);
    const Scene& truth0 = seq.trueScene();
    const double focal_err = scene.camera.K(0, 0) / truth0.camera.K(0, 0) - 1;
    const double rot0_err = rotationErrorDeg(scene.camera.R, truth0.camera.R);
    double room_err = 0;
    for (int k = 0; k < 3; ++k)
        room_err = std::max({room_err, std::abs(scene.room.min[k] - truth0.room.min[k]),
                             std::abs(scene.room.max[k] - truth0.room.max[k])});
    result.figures.push_back(format(
        "calibration from the annotation: focal %.1f px (truth %.1f, error %+.2f %%), rotation "
        "error %.3f deg, room walls within %.1f mm, %.1f s",
        scene.camera.K(0, 0), truth0.camera.K(0, 0), 100 * focal_err, rot0_err, 1000 * room_err,
        secondsSince(t_cal)));

    // 3. vbme track-camera --video input.mkv --scene scene.yml --out cameras.yml
    const auto t_track = std::chrono::steady_clock::now();
    CameraTrackingOptions topt;
    CameraTrackingReport trep;
    std::printf("demo insert: tracking the camera with COLMAP\n");
    std::fflush(stdout);
    const CameraPath path =
        trackCameraVideo(video, scene, (dir / "tracking").string(), topt, &trep);
    path.write(cameras_file);
    const double track_s = secondsSince(t_track);
    {
        double ate2 = 0, worst = 0;
        const auto& truth = seq.cameras();
        const size_t n = std::min(truth.size(), path.frames.size());
        for (size_t i = 0; i < n; ++i) {
            const Camera est = path.camera(i);
            ate2 += std::pow(norm(est.center() - truth[i].center()), 2);
            worst = std::max(worst, rotationErrorDeg(est.R, truth[i].R));
        }
        result.figures.push_back(format(
            "camera tracking (COLMAP keyframes + PnP): %d/%d frames registered (%d by SfM, %d by "
            "PnP), position RMS error %.1f mm, worst rotation error %.3f deg, reprojection %.2f "
            "px, %.1f s",
            trep.registered + trep.pnp, trep.frames, trep.registered, trep.pnp,
            1000 * std::sqrt(ate2 / std::max<size_t>(n, 1)), worst,
            trep.refined_rms > 0 ? trep.refined_rms : trep.reprojection_rms, track_s));
    }

    // 4. The object the user inserts, placed with the calibrated camera; then vbme insert.
    seq.addObject(scene);
    scene.write(insert_scene);
    InsertionParams ip;
    ip.video = video;
    ip.scene = insert_scene;
    ip.cameras = cameras_file;
    ip.out = inserted;
    ip.work = (dir / "insert_work").string();
    ip.force = ctx.force;
    ip.encode = ctx.encode;
    std::printf("demo insert: inserting the object (textures, albedo, lights, %d spp renders)\n",
                gp.spp);
    std::fflush(stdout);
    const PipelineReport irep = runInsertion(ip, progressBars("insert"));
    irep.save((dir / "insert_report.yml").string());
    {
        std::string stages;
        for (const auto& kv : irep.seconds)
            stages +=
                format("%s%s %.1f s", stages.empty() ? "" : ", ", kv.first.c_str(), kv.second);
        result.figures.push_back(format("insertion: %.1f s/frame rendered and composited (%s)",
                                        irep.figure("seconds_per_frame"), stages.c_str()));
    }

    // 5. Compare with the truth where the object changes the picture; videos to watch.
    VideoReader rin(video), rtruth(seq.truthVideoPath());
    std::unique_ptr<VideoReader> rout;
    VideoSink struth(truth_mp4, rin.fps(), gp.size, ctx.encode),
        scomp(compare_mp4, rin.fps(), Size(3 * gp.size.width, gp.size.height), ctx.encode);
    double sse_out = 0, sse_in = 0, count = 0, sse_dout = 0, dcount = 0;
    std::string dframes;
    Mat fin, ftruth, fout;
    for (int i = 0; rin.read(fin) && rtruth.read(ftruth); ++i) {
        // The lossless composite of the work folder; the .mp4 only when it is missing.
        const fs::path png = dir / "insert_work" / "frames" / format("frame_%05d.png", i);
        if (fs::exists(png))
            fout = imreadChecked(png.string());
        else {
            if (!rout) rout = std::make_unique<VideoReader>(inserted);
            if (!rout->read(fout)) break;
        }
        const Mat region = imreadChecked(seq.regionPath(i), IMREAD_GRAYSCALE);
        double s = 0, c = 0;
        regionPsnr(fout, ftruth, region, &s, &c);
        sse_out += s;
        count += c;
        regionPsnr(fin, ftruth, region, &s, &c);
        sse_in += s;
        // The truth video shares every sample with the input (and so with a uniform insertion
        // at its seed and spp); on three frames, also the differential truth: the input plus
        // the object's change at 256 spp with seeds of its own, in the region's box.
        if ((i == 0 || i == gp.frames / 2 || i == gp.frames - 1) && countNonZero(region) > 0) {
            Rect box = boundingRect(region);
            box = Rect(box.x - 8, box.y - 8, box.width + 16, box.height + 16);
            Mat dtruth;
            seq.renderDifferentialTruth(i, fin, 256, 1000 + 2 * i, dtruth, nullptr, box);
            regionPsnr(fout, dtruth, region, &s, &c);
            sse_dout += s;
            dcount += c;
            dframes += format("%s%d", dframes.empty() ? "" : ", ", i);
        }
        struth.write(ftruth);
        Mat a = fin.clone(), b = fout.clone(), t = ftruth.clone();
        label(a, "input");
        label(b, "vbme insert");
        label(t, "truth (object really there)");
        Mat row;
        hconcat(std::vector<Mat>{a, b, t}, row);
        scomp.write(row);
        if (i == 0 || i == gp.frames / 2 || i == gp.frames - 1)
            imwriteAtomic((dir / format("compare_%05d.png", i)).string(), row);
    }
    struth.close();
    scomp.close();
    const double psnr_out = count > 0 ? 10 * std::log10(255.0 * 255 * count / sse_out) : 0,
                 psnr_in = count > 0 ? 10 * std::log10(255.0 * 255 * count / sse_in) : 0;
    result.figures.push_back(
        format("PSNR against the truth video around the object and its shadow: %.2f dB (the "
               "input without the object: %.2f dB; that truth shares the input's samples)",
               psnr_out, psnr_in));
    if (dcount > 0)
        result.figures.push_back(
            format("PSNR against the differential truth (the input plus the object's change, 256 "
                   "spp, seeds of its own; frames %s): %.2f dB",
                   dframes.c_str(), 10 * std::log10(255.0 * 255 * dcount / sse_dout)));
    const double total = secondsSince(t_start);
    result.figures.push_back(
        format("total %.1f s, %.1f s per frame of video", total, total / std::max(gp.frames, 1)));
    result.watch = {inserted, compare_mp4, truth_mp4, (dir / "calibration_overlay.png").string()};
    return result;
}

}  // namespace vbme_app
