// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Calibrates one frame of a synthetic room: draws the room with a known camera, writes the
// picture and an annotation file (the worked example of doc/annotation_format.md), calibrates
// it both from the annotation and automatically, and compares with the known camera.
//
//   vbme_sample_calib_synthetic_room [out_folder]
//   vbme calibrate --image out/room.png --annotation out/room_annotation.yml --out scene.yml
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room.hpp>

using namespace cv;
using namespace cv::vbme;

static Point2d px(const Camera& c, double x, double y, double z) {
    const Point2d p = c.project(Vec3d(x, y, z));
    if (!Rect2d(0, 0, c.image_size.width, c.image_size.height).contains(p))
        std::printf("note: (%g, %g, %g) is outside the image\n", x, y, z);
    return Point2d(std::round(p.x * 10) / 10, std::round(p.y * 10) / 10);  // clicked to 0.1 px
}

int main(int argc, char** argv) {
    const std::string out = argc > 1 ? argv[1] : "calib_example";
    std::filesystem::create_directories(out);

    // The truth: a 4.8 × 4.4 × 2.7 m room, a camera 1.55 m above the floor, f = 420 px,
    // turned 28° to the left of the back wall's normal, looking 10° down.
    Camera truth = Camera::fromFocal(420, Size(640, 480));
    Matx33d yaw, pitch, R0(1, 0, 0, 0, 0, -1, 0, 1, 0);
    Rodrigues(Vec3d(0, 0, -28 * CV_PI / 180), yaw);
    Rodrigues(Vec3d(10 * CV_PI / 180, 0, 0), pitch);
    truth.R = pitch * R0 * yaw;
    placeCamera(truth, 1.55);
    Room room;
    room.min = Vec3d(-2.2, -1.4, 0);
    room.max = Vec3d(2.6, 3.0, 2.7);
    Mat img = drawSyntheticRoom(truth, room, 0.5, 1.5, 7);
    // A bright window on the back wall.
    const Vec3d win[4] = {{-0.9, 3.0, 1.0}, {0.3, 3.0, 1.0}, {0.3, 3.0, 2.1}, {-0.9, 3.0, 2.1}};
    std::vector<Point> wp;
    for (const auto& X : win)
        wp.push_back(truth.project(X));
    fillConvexPoly(img, wp, Scalar(235, 245, 250), LINE_AA);
    imwriteAtomic(out + "/room.png", img);

    // The annotation a person would make: two line groups on the floor tiles, two floor edges,
    // one wall corner, one ceiling edge, the front wall (behind the camera) as a number, and
    // the window.
    FrameAnnotation ann;
    ann.image_size = img.size();
    ann.camera_height = 1.55;
    LineGroup gx, gy;
    gx.name = "floor_x";
    gx.axis = AxisHint::HORIZONTAL;
    gy.name = "floor_y";
    gy.axis = AxisHint::HORIZONTAL;
    for (double y : {2.0, 2.5, 3.0}) {
        const Point2d a = px(truth, -2.0, y, 0), b = px(truth, -0.6, y, 0);
        gx.segments.emplace_back(a.x, a.y, b.x, b.y);
    }
    for (double x : {-1.5, -1.0, -0.5}) {
        const Point2d a = px(truth, x, 2.0, 0), b = px(truth, x, 3.0, 0);
        gy.segments.emplace_back(a.x, a.y, b.x, b.y);
    }
    ann.lines = {gx, gy};
    ann.room.floor_edges["back"] = {px(truth, -1.5, 3.0, 0), px(truth, 0.0, 3.0, 0)};
    ann.room.wall_corners.push_back({"back", "left", {px(truth, -2.2, 3.0, 1.2)}});
    ann.room.ceiling_edges["back"] = {px(truth, -1.6, 3.0, 2.7)};
    ann.room.faces["right"] = 2.6;   // not in view: measured
    ann.room.faces["front"] = -1.4;  // behind the camera
    LightAnnotation window;
    for (const auto& X : win)
        window.polygon.push_back(px(truth, X[0], X[1], X[2]));
    window.face = "back";
    ann.lights = {window};
    ann.write(out + "/room_annotation.yml");

    // Calibrate from the annotation, then automatically.
    FrameCalibrationOptions opt;
    FrameCalibration fc;
    const Scene scene = calibrateFrame(img, ann, opt, &fc);
    scene.write(out + "/scene.yml");
    Mat overlay;
    drawCalibrationOverlay(img, overlay, scene, fc);
    imwriteAtomic(out + "/overlay.png", overlay);

    auto rotErr = [&](const Matx33d& R) {
        const Matx33d D = R.t() * truth.R;
        return std::acos(std::min(1.0, (trace(D) - 1) / 2)) * 180 / CV_PI;
    };
    std::printf("annotation: focal %.2f px (true 420), rotation error %.3f deg\n", fc.focal(),
                rotErr(fc.R));
    std::printf(
        "            room [%.3f, %.3f] x [%.3f, %.3f] x [%.3f, %.3f] "
        "(true [-2.2, 2.6] x [-1.4, 3.0] x [0, 2.7])\n",
        scene.room.min[0], scene.room.max[0], scene.room.min[1], scene.room.max[1],
        scene.room.min[2], scene.room.max[2]);
    const FrameCalibration autofc = VanishingPointCalibrator::create()->detect(img);
    std::printf(
        "automatic: focal %.2f px, rotation error %.3f deg, confidence %.2f, "
        "%d/%d/%d segments\n",
        autofc.focal(), rotErr(autofc.R), autofc.confidence, autofc.support[0], autofc.support[1],
        autofc.support[2]);
    std::printf("wrote %s/{room.png, room_annotation.yml, scene.yml, overlay.png}\n", out.c_str());
    return 0;
}
