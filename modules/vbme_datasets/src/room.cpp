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
    // Pixel centres at integers: OpenCV's fixed-point drawing uses the same convention.
    const double s = 1 << kShift;
    const double lim = 1e6;
    return Point(cvRound(std::max(-lim, std::min(lim, p.x)) * s),
                 cvRound(std::max(-lim, std::min(lim, p.y)) * s));
}

/** Corners of a box face, in world coordinates. */
std::vector<Vec3d> faceCorners(const Room& r, int face) {
    const Vec3d& a = r.min;
    const Vec3d& b = r.max;
    switch (face) {
        case 0:
            return {{a[0], a[1], a[2]}, {b[0], a[1], a[2]}, {b[0], b[1], a[2]}, {a[0], b[1], a[2]}};
        case 1:
            return {{a[0], a[1], b[2]}, {b[0], a[1], b[2]}, {b[0], b[1], b[2]}, {a[0], b[1], b[2]}};
        case 2:
            return {{a[0], a[1], a[2]}, {a[0], b[1], a[2]}, {a[0], b[1], b[2]}, {a[0], a[1], b[2]}};
        case 3:
            return {{b[0], a[1], a[2]}, {b[0], b[1], a[2]}, {b[0], b[1], b[2]}, {b[0], a[1], b[2]}};
        case 4:
            return {{a[0], a[1], a[2]}, {b[0], a[1], a[2]}, {b[0], a[1], b[2]}, {a[0], a[1], b[2]}};
        default:
            return {{a[0], b[1], a[2]}, {b[0], b[1], a[2]}, {b[0], b[1], b[2]}, {a[0], b[1], b[2]}};
    }
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
        const int ax = f <= 1 ? 2 : (f <= 3 ? 0 : 1);
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
