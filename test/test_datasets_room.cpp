// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The room generators of vbme_datasets against independent oracles: the textured room rendered
// through vbme_render's room against an exact analytic ray-cast, the drawn room's face colours
// where the camera model says each face is, the hand-held path's start and determinism, the
// floor placement and the torus-knot mesh's bounding box.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/ball_clip.hpp>
#include <opencv2/vbme/datasets/insertion_sequence.hpp>
#include <opencv2/vbme/datasets/room.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

// The exact ray-cast of a textured box (analytic exit point in double precision, the face
// orientation table of DESIGN written out): the independent oracle of renderTexturedRoom().
Mat exactTexturedRoom(const Camera& cam, const Room& room,
                      const std::map<std::string, Mat>& textures, int supersample) {
    CV_Assert(cam.image_size.area() > 0 && supersample >= 1);
    const Vec3d c = cam.center();
    const std::vector<std::string>& faces =
        Room::faceNames();  // floor, ceiling, left, right, front, back
    std::vector<Mat> tex(6);
    for (int f = 0; f < 6; ++f) {
        auto it = textures.find(faces[f]);
        if (it != textures.end()) it->second.convertTo(tex[f], CV_32FC3);
    }
    const Matx33d Kinv = cam.K.inv(), Rt = cam.R.t();
    Mat out(cam.image_size, CV_8UC3);
    parallel_for_(Range(0, out.rows), [&](const Range& rows) {
        for (int y = rows.start; y < rows.end; ++y)
            for (int x = 0; x < out.cols; ++x) {
                Vec3d sum(0, 0, 0);
                for (int sy = 0; sy < supersample; ++sy)
                    for (int sx = 0; sx < supersample; ++sx) {
                        const double px = x - 0.5 + (sx + 0.5) / supersample,
                                     py = y - 0.5 + (sy + 0.5) / supersample;
                        const Vec3d d = Rt * (Kinv * Vec3d(px, py, 1));
                        // Exit point of the ray from inside the box.
                        double tmin = 1e300;
                        int face = 0;
                        for (int a = 0; a < 3; ++a) {
                            if (d[a] == 0) continue;
                            const double tt =
                                ((d[a] > 0 ? room.max[a] : room.min[a]) - c[a]) / d[a];
                            if (tt < tmin) {
                                tmin = tt;
                                // floor/ceiling = z (faces 0/1), left/right = x (2/3),
                                // front/back = y (4/5)
                                face = a == 2   ? (d[a] > 0 ? 1 : 0)
                                       : a == 0 ? (d[a] > 0 ? 3 : 2)
                                                : (d[a] > 0 ? 5 : 4);
                            }
                        }
                        const Vec3d p = c + d * tmin;
                        const Mat& t = tex[face];
                        if (t.empty()) {
                            sum += Vec3d(128, 128, 128);
                            continue;
                        }
                        int ua, va;  // world axes along columns and rows
                        if (face <= 1)
                            ua = 0, va = 1;
                        else if (face <= 3)
                            ua = 1, va = 2;
                        else
                            ua = 0, va = 2;
                        double u = (p[ua] - room.min[ua]) / (room.max[ua] - room.min[ua]);
                        double v = (p[va] - room.min[va]) / (room.max[va] - room.min[va]);
                        // Upright as seen from inside the room (vbme_render's convention):
                        // the ceiling's image up is −y, the right wall's image right is −y,
                        // the front wall's image right is −x.
                        if (face == 1) v = 1 - v;
                        if (face == 3 || face == 4) u = 1 - u;
                        const float tx = float(u * t.cols - 0.5),
                                    ty = float((1 - v) * t.rows - 0.5);
                        const int x0 = std::max(0, std::min(t.cols - 2, (int)std::floor(tx)));
                        const int y0 = std::max(0, std::min(t.rows - 2, (int)std::floor(ty)));
                        const float fx = std::min(1.f, std::max(0.f, tx - x0)),
                                    fy = std::min(1.f, std::max(0.f, ty - y0));
                        const Vec3f a = t.at<Vec3f>(y0, x0), b = t.at<Vec3f>(y0, x0 + 1),
                                    cc = t.at<Vec3f>(y0 + 1, x0), dd = t.at<Vec3f>(y0 + 1, x0 + 1);
                        const Vec3f s =
                            (a * (1 - fx) + b * fx) * (1 - fy) + (cc * (1 - fx) + dd * fx) * fy;
                        sum += Vec3d(s[0], s[1], s[2]);
                    }
                sum *= 1.0 / (supersample * supersample);
                out.at<Vec3b>(y, x) =
                    Vec3b(saturate_cast<uchar>(sum[0]), saturate_cast<uchar>(sum[1]),
                          saturate_cast<uchar>(sum[2]));
            }
    });
    return out;
}

}  // namespace

TEST(DatasetsRoom, TexturedRoomMatchesExactRayCast) {
    const Scene s0 = syntheticRoomScene(Size(320, 240), 260);
    const std::map<std::string, Mat> textures = makeRoomTextures(3, 256);
    const std::vector<Camera> cams = handheldCameraPath(s0.camera, 12, 1.5, 0.01, 0.5, 2);
    int worst = 0;
    double off = 0, any = 0, total = 0, t_new = 0, t_old = 0;
    for (int i : {0, 5, 11}) {
        for (int ss : {1, 2}) {
            auto a = std::chrono::steady_clock::now();
            const Mat got = renderTexturedRoom(cams[i], s0.room, textures, ss);
            auto b = std::chrono::steady_clock::now();
            const Mat want = exactTexturedRoom(cams[i], s0.room, textures, ss);
            auto c = std::chrono::steady_clock::now();
            t_new += std::chrono::duration<double>(b - a).count();
            t_old += std::chrono::duration<double>(c - b).count();
            Mat d;
            absdiff(got, want, d);
            double mx;
            minMaxLoc(d.reshape(1), nullptr, &mx);
            worst = std::max(worst, (int)mx);
            off += countNonZero(d.reshape(1) > 1);
            any += countNonZero(d.reshape(1) > 0);
            total += (double)d.total() * 3;
        }
    }
    std::printf(
        "[ measured ] renderTexturedRoom vs exact ray-cast: max difference %d levels, "
        "%.4f %% of values differ, %.4f %% by more than 1; %.3f s vs %.3f s\n",
        worst, 100 * any / total, 100 * off / total, t_new, t_old);
    // Float rays and texture coordinates against double: a texel boundary may round the
    // other way, nothing more.
    EXPECT_LE(worst, 1);
    EXPECT_LT(any / total, 1e-3);
    EXPECT_EQ(off, 0.0);
    EXPECT_THROW(renderTexturedRoom(Camera::fromFocal(200, Size(64, 48)), s0.room, textures),
                 cv::Exception);  // the default camera stands at the origin, on the floor
}

TEST(DatasetsRoom, DrawnRoomShowsEachFaceWhereTheCameraSeesIt) {
    // Oracle: the camera model. A point in the middle of a floor tile (away from the pattern
    // lines) projects onto a pixel of the floor's colour; same for the back wall.
    const Scene s = syntheticRoomScene(Size(320, 240), 260);
    const Mat img = drawSyntheticRoom(s.camera, s.room, 0.5);
    struct Probe {
        Vec3d world;
        double grey;  // the face's grey level (green channel)
    };
    const Probe probes[] = {{Vec3d(0.25, 2.75, 0.0), 95},   // floor, tile centre
                            {Vec3d(-0.75, 3.25, 0.0), 95},  // floor
                            {Vec3d(0.25, 4.0, 1.25), 195},  // back wall
                            {Vec3d(-0.75, 4.0, 1.75), 195}};
    for (const Probe& p : probes) {
        const Point2d px = s.camera.project(p.world);
        ASSERT_TRUE(Rect(2, 2, img.cols - 4, img.rows - 4).contains(Point(px))) << px;
        const Vec3b v = img.at<Vec3b>(cvRound(px.y), cvRound(px.x));
        EXPECT_NEAR(v[1], p.grey, 1.0) << "at " << px;
    }
}

TEST(DatasetsRoom, HandheldPathStartsAtTheFirstCameraAndIsDeterministic) {
    const Scene s = syntheticRoomScene();
    const std::vector<Camera> a = handheldCameraPath(s.camera, 20, 1.5, 0.01, 0.5, 4);
    const std::vector<Camera> b = handheldCameraPath(s.camera, 20, 1.5, 0.01, 0.5, 4);
    const std::vector<Camera> c = handheldCameraPath(s.camera, 20, 1.5, 0.01, 0.5, 5);
    ASSERT_EQ(a.size(), 20u);
    EXPECT_LT(norm(a[0].center() - s.camera.center()), 0.02);  // at most the hand shake
    double walk = 0, diff = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(norm(a[i].center() - b[i].center()), 0.0);
        diff = std::max(diff, norm(a[i].center() - c[i].center()));
        if (i) walk += norm(a[i].center() - a[i - 1].center());
        const Vec3d p = a[i].center();
        for (int k = 0; k < 3; ++k) {
            EXPECT_GT(p[k], s.room.min[k]);
            EXPECT_LT(p[k], s.room.max[k]);
        }
    }
    std::printf(
        "[ measured ] hand-held path: %.3f m walked (travel 1.5), seeds differ by up to "
        "%.4f m\n",
        walk, diff);
    EXPECT_GT(diff, 0.0);
}

TEST(DatasetsRoom, FloorPlacementStandsUnderThePixel) {
    const Scene s = syntheticRoomScene(Size(320, 240), 260);
    for (const Point2d px : {Point2d(160, 200), Point2d(40, 230), Point2d(300, 170)}) {
        const Matx44d W = floorPlacement(s.camera, s.room, px, 0.3);
        const Vec3d origin(W(0, 3), W(1, 3), W(2, 3));
        EXPECT_NEAR(origin[2], s.room.min[2], 1e-12);
        EXPECT_LT(norm(s.camera.project(origin) - px), 1e-6);
        EXPECT_NEAR(std::atan2(W(1, 0), W(0, 0)), 0.3, 1e-12);
    }
    EXPECT_THROW(floorPlacement(s.camera, s.room, Point2d(160, 5)), cv::Exception);  // sky
}

TEST(DatasetsRoom, TorusKnotStandsOnItsOriginWithTheGivenWidth) {
    vbme_test::ScratchDir dir;
    const std::string obj = dir / "knot.obj";
    writeTorusKnotObj(obj, 0.4, 120, 12);
    std::ifstream in(obj);
    std::string line;
    Vec3d lo(1e9, 1e9, 1e9), hi(-1e9, -1e9, -1e9);
    int vertices = 0, normals = 0;
    while (std::getline(in, line)) {
        std::istringstream ss(line);
        std::string tag;
        ss >> tag;
        if (tag == "vn") ++normals;
        if (tag != "v") continue;
        Vec3d v;
        ss >> v[0] >> v[1] >> v[2];
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], v[k]);
            hi[k] = std::max(hi[k], v[k]);
        }
        ++vertices;
    }
    EXPECT_EQ(vertices, 120 * 12);
    EXPECT_EQ(normals, vertices);
    EXPECT_NEAR(lo[2], 0.0, 1e-9);                  // stands on z = 0
    EXPECT_NEAR(0.5 * (lo[0] + hi[0]), 0.0, 0.01);  // centred
    EXPECT_NEAR(0.5 * (lo[1] + hi[1]), 0.0, 0.01);
    EXPECT_NEAR(std::max(hi[0] - lo[0], hi[1] - lo[1]), 0.4, 0.01);  // the width
}

TEST(DatasetsBallClip, TruthDiskIsWhereTheBallIs) {
    // Oracle: the ball's colour. Without noise, highlight and distractors, pixels well inside the
    // truth disk are orange (OpenCV hue ≤ 25, saturated), pixels well outside it are not.
    SyntheticBallClip::Params p;
    p.size = Size(320, 240);
    p.frames = 10;
    p.noise_sigma = 0;
    p.distractor = false;
    p.highlight = 0;
    const SyntheticBallClip clip(p);
    for (int i : {0, 4, 9}) {
        Disk d;
        const Mat f = clip.frame(i, &d);
        EXPECT_EQ(d.center, clip.truth(i).center);
        Mat hsv, orange;
        cvtColor(f, hsv, COLOR_BGR2HSV);
        inRange(hsv, Scalar(0, 120, 40), Scalar(25, 255, 255), orange);
        Disk inner = d, outer = d;
        inner.radius -= 2;
        outer.radius += 3;
        Mat in_mask, out_mask;
        diskMask(f.size(), inner, in_mask);
        diskMask(f.size(), outer, out_mask);
        const double inside = countNonZero(orange & in_mask) / (double)countNonZero(in_mask);
        const int stray = countNonZero(orange & ~out_mask);
        std::printf(
            "[ measured ] ball clip frame %d: %.4f of the disk is orange, %d orange "
            "pixels outside\n",
            i, inside, stray);
        EXPECT_GT(inside, 0.98);
        EXPECT_EQ(stray, 0);
    }
    p.hide_from = 2;
    p.hide_to = 4;
    Disk hidden;
    SyntheticBallClip(p).frame(3, &hidden);
    EXPECT_EQ(hidden.radius, 0.f);
}
