// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme calibrate: camera, room box and lights of one frame from an annotation and/or
// automatically detected vanishing points.
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/calib.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct CalibrateOptions {
    std::string image, video, annotation, out, overlay;
    int frame = -1;
    bool auto_detect = false, no_exif = false;
    double camera_height = 0, focal = 0, focal_35mm = 0;
    std::string distortion, method = "global", principal_point;
    bool edgels = false, no_edgels = false;  // given explicitly (the edge pixels are on by default)
    int proposals = 0;
    CommonOptions common;
};

cv::Mat readFrame(const std::string& video, int index) {
    cv::vbme::VideoReader reader(video);
    cv::Mat f;
    for (int i = 0; i <= index; ++i)
        if (!reader.read(f))
            CV_Error(cv::Error::StsBadArg, cv::format("%s: has only %d frame(s); frame %d asked",
                                                      video.c_str(), i, index));
    return f;
}

void runCalibrate(const CalibrateOptions& o) {
    using namespace cv::vbme;
    // Outputs are checked before any work.
    checkOverwrite(o.out, o.common.force);
    if (!o.overlay.empty()) checkOverwrite(o.overlay, o.common.force);

    FrameAnnotation ann;
    if (!o.annotation.empty()) ann = FrameAnnotation::read(o.annotation);
    if (ann.lines.empty() && !o.auto_detect)
        CV_Error(cv::Error::StsBadArg,
                 (o.annotation.empty() ? std::string("no annotation")
                                       : "the annotation '" + o.annotation + "' has no 'lines'") +
                     ": give line groups in the annotation or detect them with --auto");
    const cv::Mat image = !o.image.empty() ? imreadChecked(o.image, cv::IMREAD_COLOR)
                                           : readFrame(o.video, o.frame < 0 ? 0 : o.frame);
    FrameCalibrationOptions opt;
    opt.auto_detect = o.auto_detect;
    opt.camera_height = o.camera_height;
    opt.vp.focal = o.focal;
    opt.vp.method = o.method == "ransac" ? VanishingPointCalibrator::Params::RANSAC
                                         : VanishingPointCalibrator::Params::GLOBAL;
    if (o.focal_35mm > 0) {  // 35 mm equivalent: the 43.27 mm diagonal of a 36×24 mm frame
        opt.vp.focal_prior = focalFrom35mm(o.focal_35mm, image.size());
    } else if (o.focal <= 0 && !o.image.empty() && !o.no_exif) {
        // the photograph's own EXIF, when it has one
        const ExifFocal ex = readExifFocal(o.image);
        std::string source;
        const double f = ex.focalPixels(image.size(), &source);
        if (f > 0) {
            opt.vp.focal_prior = f;
            std::printf(
                "focal prior from the EXIF of %s%s: %.1f px (%s; %g mm, %g mm 35 mm "
                "equivalent); --focal-35mm or --no-exif to override\n",
                o.image.c_str(),
                ex.model.empty() ? "" : (" (" + ex.make + " " + ex.model + ")").c_str(), f,
                source.c_str(), ex.focal_mm, ex.focal_35mm);
        }
    }
    if (!o.principal_point.empty()) {
        // "x,y" in pixels of this image (pixel centres at integers); overrides the annotation's
        double x = 0, y = 0;
        char tail = 0;
        if (std::sscanf(o.principal_point.c_str(), "%lf ,%lf %c", &x, &y, &tail) != 2 ||
            !std::isfinite(x) || !std::isfinite(y))
            CV_Error(cv::Error::StsBadArg, "--principal-point '" + o.principal_point +
                                               "': expected two numbers 'x,y' in pixels");
        if (x < 0 || y < 0 || x > image.cols - 1 || y > image.rows - 1)
            CV_Error(cv::Error::StsBadArg,
                     cv::format("--principal-point (%g, %g) is outside the %dx%d image", x, y,
                                image.cols, image.rows));
        opt.vp.principal_point = cv::Point2d(x, y);
    }
    opt.vp.estimate_distortion = o.distortion == "k1";
    opt.vp.edgel_scoring = !o.no_edgels;
    if ((o.edgels || o.no_edgels) && !(ann.lines.empty() && o.auto_detect))
        CV_Error(cv::Error::StsBadArg,
                 std::string(o.edgels ? "--edgels" : "--no-edgels") +
                     " applies to automatic detection only (--auto without annotated lines)");
    if (opt.vp.estimate_distortion && !(ann.lines.empty() && o.auto_detect))
        CV_Error(cv::Error::StsBadArg,
                 "--distortion k1 is estimated by automatic detection only (--auto without "
                 "annotated lines)");
    if (o.proposals > 0 && ann.lines.empty() && o.auto_detect) {
        // Ranked alternatives for the annotator; the first is the one calibrated below.
        const auto props = detectManhattanProposals(image, opt.vp, o.proposals);
        for (size_t i = 0; i < props.size(); ++i) {
            const FrameCalibration& c = props[i].calibration;
            std::printf(
                "proposal %d: focal %.1f px (±%.1f %%), score %.3f, confidence %.2f%s%s%s\n",
                (int)i + 1, c.focal(), 100 * c.focal_rel_sigma, props[i].score, props[i].confidence,
                opt.vp.estimate_distortion ? cv::format(", k1 %.4f", c.k1).c_str() : "",
                props[i].note.empty() ? "" : "; ", props[i].note.c_str());
        }
    }
    if (o.camera_height <= 0 && ann.camera_height <= 0 && ann.room.empty())
        std::fprintf(stderr,
                     "vbme: warning: camera height unknown; placing the camera %.2f m above the "
                     "floor (give --camera-height)\n",
                     opt.default_camera_height);
    if (!ann.lines.empty() && o.auto_detect)
        std::printf("using the annotation's %d line group(s); --auto not needed\n",
                    (int)ann.lines.size());
    FrameCalibration fc;
    const Scene scene = calibrateFrame(image, ann, opt, &fc);

    if (!o.overlay.empty()) {
        cv::Mat ov;
        drawCalibrationOverlay(image, ov, scene, fc);
        imwriteAtomic(o.overlay, ov);
    }
    scene.write(o.out);

    const cv::Vec3d C = scene.camera.center();
    const cv::Matx33d& R = scene.camera.R;
    // Viewing direction in the world: heading from +y towards +x, elevation above horizontal.
    const cv::Vec3d v(R(2, 0), R(2, 1), R(2, 2));
    const double heading = std::atan2(v[0], v[1]) * 180 / CV_PI;
    const double elevation = std::asin(std::max(-1.0, std::min(1.0, v[2]))) * 180 / CV_PI;
    std::printf(
        "focal %.1f px%s (horizontal fov %.1f deg), principal point (%.1f, %.1f)\n",
        scene.camera.K(0, 0),
        fc.focal_rel_sigma > 0 ? cv::format(" ±%.1f %%", 100 * fc.focal_rel_sigma).c_str() : "",
        2 * std::atan2(image.cols * 0.5, scene.camera.K(0, 0)) * 180 / CV_PI, scene.camera.K(0, 2),
        scene.camera.K(1, 2));
    if (opt.vp.estimate_distortion || fc.k1 != 0)
        std::printf(
            "radial distortion k1 %.4f%s (x_d = x (1 + k1 |x|^2), x = K^-1 p; written to the "
            "scene's camera: track-camera and insert undistort the frames with it)\n",
            fc.k1, opt.vp.estimate_distortion ? "" : " (the annotation's)");
    std::printf(
        "camera at (%.3f, %.3f, %.3f) m, heading %.1f deg, elevation %.1f deg; "
        "segments x/y/z %d/%d/%d, rms %.2f px, confidence %.2f\n",
        C[0], C[1], C[2], heading, elevation, fc.support[0], fc.support[1], fc.support[2],
        fc.rms_px, fc.confidence);
    if (scene.has_room)
        std::printf("room [%.3f, %.3f] x [%.3f, %.3f] x [%.3f, %.3f] m, %d light(s)\n",
                    scene.room.min[0], scene.room.max[0], scene.room.min[1], scene.room.max[1],
                    scene.room.min[2], scene.room.max[2], (int)scene.lights.size());
    std::printf("wrote %s%s%s\n", o.out.c_str(), o.overlay.empty() ? "" : " and ",
                o.overlay.c_str());
}

void setupCalibrate(CLI::App& app) {
    auto o = std::make_shared<CalibrateOptions>();
    app.footer(
        "Camera (focal length, rotation, position), room box and light polygons of one frame.\n"
        "Vanishing points come from the annotation's line groups or, with --auto, from line\n"
        "segments detected in the image (annotated lines override). The output is the scene\n"
        "file of doc/DESIGN.md, ready for 'vbme render'. The annotation format is described in\n"
        "doc/annotation_format.md.");
    auto img = app.add_option("--image", o->image, "The frame to calibrate (image file)");
    auto vid = app.add_option("--video", o->video,
                              "A video file, image folder or pattern; the frame is --frame");
    img->excludes(vid);
    app.add_option("--frame", o->frame, "Frame index in --video (from 0; default 0)")
        ->check(CLI::NonNegativeNumber)
        ->needs(vid);
    app.add_option("--annotation", o->annotation,
                   "Annotation file (YAML/JSON): lines, room points, light polygons");
    app.add_flag("--auto", o->auto_detect, "Detect the vanishing points automatically");
    app.add_option("--camera-height", o->camera_height,
                   "Camera height above the floor in metres (overrides the annotation)")
        ->check(CLI::PositiveNumber);
    app.add_option("--focal", o->focal, "Known focal length in pixels (default: estimated)")
        ->check(CLI::PositiveNumber);
    app.add_option("--focal-35mm", o->focal_35mm,
                   "Focal length prior, 35 mm equivalent (e.g. from EXIF), for --auto")
        ->check(CLI::PositiveNumber);
    app.add_flag("--no-exif", o->no_exif,
                 "Do not take a focal length prior from the --image's EXIF (FocalLengthIn35mmFilm "
                 "or FocalLength with the focal plane resolution), which is used by default when "
                 "neither --focal nor --focal-35mm is given");
    app.add_option("--principal-point", o->principal_point,
                   "Known principal point 'x,y' in pixels (pixel centres at integers; from a "
                   "camera calibration), overriding the annotation's; default: the image centre. "
                   "On photographs whose principal point is off centre, views down a corridor get "
                   "their focal length wrong without it (doc/vbme_calib.md, Limits)");
    app.add_option("--distortion", o->distortion,
                   "Also estimate lens distortion with --auto: 'k1' (one radial coefficient, "
                   "from the straightness of the lines); written to the scene's camera (k1), which "
                   "track-camera and insert then undistort the frames with")
        ->check(CLI::IsMember({"k1"}));
    app.add_option("--method", o->method,
                   "Automatic search: 'global' (exhaustive over vanishing-point candidates, "
                   "default) or 'ransac' (the previous method)")
        ->check(CLI::IsMember({"global", "ransac"}));
    auto* edg = app.add_flag(
        "--edgels", o->edgels,
        "With --auto: also find and score Manhattan frames with every edge pixel (the default; "
        "more right answers on hard photographs, about 1.5x the time of --no-edgels; see "
        "doc/vbme_calib.md)");
    app.add_flag("--no-edgels", o->no_edgels,
                 "With --auto: the line segments alone, without the edge pixels (faster)")
        ->excludes(edg);
    app.add_option("--proposals", o->proposals,
                   "With --auto: print this many ranked Manhattan frames with confidences")
        ->check(CLI::Range(1, 10));
    app.add_option("--out", o->out, "Output scene file (.yml or .json)")->required();
    app.add_option("--overlay", o->overlay,
                   "Also write the frame with the box, vanishing points and lights drawn (PNG)");
    addCommonOptions(app, o->common);
    app.callback([o] {
        if (o->image.empty() && o->video.empty())
            throw CLI::ValidationError("--image/--video", "give the frame: --image or --video");
        if (o->annotation.empty() && !o->auto_detect)
            throw CLI::ValidationError("--annotation/--auto",
                                       "give an --annotation, or --auto to detect the lines");
        applyCommonOptions(o->common);
        runCalibrate(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("calibrate",
                      "Camera, room box and lights of one frame from an annotation or "
                      "automatically detected vanishing points",
                      setupCalibrate);

}  // namespace vbme_app
