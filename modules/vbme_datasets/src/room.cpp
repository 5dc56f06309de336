// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Synthetic box-room pictures: an oracle for the calibration tests and benchmarks.
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/calib/projection.hpp"
#include "opencv2/vbme/datasets/room.hpp"

namespace cv {
namespace vbme {

namespace {

constexpr int kShift = 8;

Point toFixed(const Point2d& p) {
    return toFixedPoint(p, kShift);
}

/** Corners of a box face, in world coordinates: on the face's plane (Room::faceAxis(), the
minimum side for even faces), running from the face's minimum corner along the lower-numbered
axis first. Built from the box's own coordinates so that shared corners are exactly equal. */
std::vector<Vec3d> faceCorners(const Room& r, int face) {
    const int ax = Room::faceAxis(face);
    const int u = ax == 0 ? 1 : 0, v = ax == 2 ? 1 : 2;
    std::vector<Vec3d> c(4);
    for (int k = 0; k < 4; ++k) {
        c[k][ax] = face % 2 == 0 ? r.min[ax] : r.max[ax];
        c[k][u] = (k == 1 || k == 2) ? r.max[u] : r.min[u];
        c[k][v] = k >= 2 ? r.max[v] : r.min[v];
    }
    return c;
}

}  // namespace

Mat drawSyntheticRoom(const Camera& camera, const Room& room, double tile, double noise_sigma,
                      int seed) {
    CV_Assert(camera.image_size.area() > 0 && tile > 0);
    Mat img(camera.image_size, CV_8UC3, Scalar::all(0));
    static const double grey[6] = {95, 215, 150, 175, 125, 195};
    const double near_z = 0.02;
    for (int f = 0; f < 6; ++f) {
        const std::vector<Point2d> px = projectPolygon(camera, faceCorners(room, f), near_z);
        if (px.size() < 3) continue;
        std::vector<Point> fx;
        for (const auto& p : px)
            fx.push_back(toFixed(p));
        const Scalar col(grey[f] * 0.9, grey[f], grey[f] * 1.05);
        fillPoly(img, std::vector<std::vector<Point>>{fx}, col, LINE_AA, kShift);
    }
    // Pattern lines along the axes on every face.
    for (int f = 0; f < 6; ++f) {
        const int ax = Room::faceAxis(f);
        const double coord = (f % 2 == 0) ? room.min[ax] : room.max[ax];
        const int u = (ax + 1) % 3, v = (ax + 2) % 3;
        const Scalar col = Scalar::all(grey[f] - 60);
        for (int dir = 0; dir < 2; ++dir) {
            const int along = dir == 0 ? u : v, across = dir == 0 ? v : u;
            const double first = std::ceil((room.min[across] + 1e-9) / tile) * tile;
            for (double c = first; c < room.max[across] - 1e-9; c += tile) {
                Vec3d a, b;
                a[ax] = b[ax] = coord;
                a[across] = b[across] = c;
                a[along] = room.min[along];
                b[along] = room.max[along];
                Point2d pa, pb;
                if (!projectSegment(camera, a, b, pa, pb, near_z)) continue;
                line(img, toFixed(pa), toFixed(pb), col, 2, LINE_AA, kShift);
            }
        }
    }
    if (noise_sigma > 0) {
        RNG rng((uint64)seed * 7919 + 1);
        Mat noise(img.size(), CV_32FC3);
        rng.fill(noise, RNG::NORMAL, 0, noise_sigma);
        Mat f;
        img.convertTo(f, CV_32FC3);
        f += noise;
        f.convertTo(img, CV_8UC3);
    }
    return img;
}

}  // namespace vbme
}  // namespace cv
