// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The browser test's oracle: draws the synthetic room of doc/annotation_format.md's worked
// example (known camera) as a one-frame video, and writes the true camera and room with the
// exact image positions of the world points the test clicks (Camera::project of the truth).
//
//   vbme_test_annotate_fixture <folder>  →  <folder>/frames/00000.png, <folder>/truth.json,
//                                            <folder>/cube.obj
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room.hpp>

using namespace cv;
using namespace cv::vbme;

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: vbme_test_annotate_fixture <folder>\n");
        return 2;
    }
    const std::string out = argv[1];
    std::filesystem::create_directories(out + "/frames");
    // f = 420 px, 1.55 m above the floor, turned 28° left, looking 10° down.
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
    const Vec3d win[4] = {{-0.9, 3.0, 1.0}, {0.3, 3.0, 1.0}, {0.3, 3.0, 2.1}, {-0.9, 3.0, 2.1}};
    std::vector<Point> wp;
    for (const auto& X : win)
        wp.push_back(truth.project(X));
    fillConvexPoly(img, wp, Scalar(235, 245, 250), LINE_AA);
    imwriteAtomic(out + "/frames/00000.png", img);

    auto px = [&](double x, double y, double z) {
        const Point2d p = truth.project(Vec3d(x, y, z));
        return format("[%.4f, %.4f]", p.x, p.y);
    };
    auto seg = [&](Vec3d a, Vec3d b) {
        const Point2d p = truth.project(a), q = truth.project(b);
        return format("[%.4f, %.4f, %.4f, %.4f]", p.x, p.y, q.x, q.y);
    };
    std::ofstream f(out + "/truth.json");
    f << "{\n  \"focal\": 420, \"camera_height\": 1.55,\n";
    f << format("  \"room\": {\"min\": [%g, %g, %g], \"max\": [%g, %g, %g]},\n", room.min[0],
                room.min[1], room.min[2], room.max[0], room.max[1], room.max[2]);
    // Floor tile joints: along x (y = 2, 2.5, 3) and along y (x = -1.5, -1, -0.5).
    f << "  \"group_x\": [" << seg({-2.0, 2.0, 0}, {-0.6, 2.0, 0}) << ", "
      << seg({-2.0, 2.5, 0}, {-0.6, 2.5, 0}) << ", " << seg({-2.0, 3.0, 0}, {-0.6, 3.0, 0})
      << "],\n";
    f << "  \"group_y\": [" << seg({-1.5, 2.0, 0}, {-1.5, 3.0, 0}) << ", "
      << seg({-1.0, 2.0, 0}, {-1.0, 3.0, 0}) << ", " << seg({-0.5, 2.0, 0}, {-0.5, 3.0, 0})
      << "],\n";
    f << "  \"floor_back\": [" << px(-1.5, 3.0, 0) << ", " << px(0.0, 3.0, 0) << "],\n";
    f << "  \"corner_back_left\": [" << px(-2.2, 3.0, 1.2) << "],\n";
    f << "  \"ceiling_back\": [" << px(-1.6, 3.0, 2.7) << "],\n";
    f << "  \"faces\": {\"right\": 2.6, \"front\": -1.4},\n";
    f << "  \"place\": " << px(-1.0, 2.3, 0) << ",\n";
    f << "  \"window\": [" << px(win[0][0], win[0][1], win[0][2]) << ", "
      << px(win[1][0], win[1][1], win[1][2]) << ", " << px(win[2][0], win[2][1], win[2][2]) << ", "
      << px(win[3][0], win[3][1], win[3][2]) << "]\n}\n";
    f.close();
    // The object to place: a standing 0.4 m cube (bounding-box bottom centre at the origin).
    std::ofstream cube(out + "/cube.obj");
    for (int i = 0; i < 8; ++i)
        cube << "v " << (i & 1 ? 0.2 : -0.2) << " " << (i & 2 ? 0.2 : -0.2) << " "
             << (i & 4 ? 0.4 : 0.0) << "\n";
    cube << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    std::printf("wrote %s/frames/00000.png and %s/truth.json\n", out.c_str(), out.c_str());
    return f ? 0 : 1;
}
