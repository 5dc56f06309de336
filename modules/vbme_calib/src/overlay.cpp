// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Projections clipped to the front of a camera, and the calibration overlay.
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/calib/frame_calibration.hpp"
#include "opencv2/vbme/calib/projection.hpp"

namespace cv {
namespace vbme {

bool projectSegment(const Camera& camera, const Vec3d& a, const Vec3d& b, Point2d& pa, Point2d& pb,
                    double near_z) {
    Vec3d ca = camera.camFromWorld(a), cb = camera.camFromWorld(b);
    if (ca[2] < near_z && cb[2] < near_z) return false;
    if (ca[2] < near_z) ca = ca + (cb - ca) * ((near_z - ca[2]) / (cb[2] - ca[2]));
    if (cb[2] < near_z) cb = cb + (ca - cb) * ((near_z - cb[2]) / (ca[2] - cb[2]));
    const Vec3d pa3 = camera.K * ca, pb3 = camera.K * cb;
    pa = Point2d(pa3[0] / pa3[2], pa3[1] / pa3[2]);
    pb = Point2d(pb3[0] / pb3[2], pb3[1] / pb3[2]);
    return true;
}

std::vector<Point2d> projectPolygon(const Camera& cam, const std::vector<Vec3d>& poly,
                                    double near_z) {
    std::vector<Vec3d> in, out;
    for (const auto& p : poly)
        in.push_back(cam.camFromWorld(p));
    for (size_t i = 0; i < in.size(); ++i) {
        const Vec3d& a = in[i];
        const Vec3d& b = in[(i + 1) % in.size()];
        const bool ia = a[2] >= near_z, ib = b[2] >= near_z;
        if (ia) out.push_back(a);
        if (ia != ib) out.push_back(a + (b - a) * ((near_z - a[2]) / (b[2] - a[2])));
    }
    std::vector<Point2d> px;
    for (const auto& c : out) {
        const Vec3d p = cam.K * c;
        px.emplace_back(p[0] / p[2], p[1] / p[2]);
    }
    return px;
}

Point toFixedPoint(const Point2d& p, int shift) {
    // Pixel centres at integers: OpenCV's fixed-point drawing uses the same convention.
    const double s = 1 << shift;
    const double lim = 1e6;
    return Point(cvRound(std::max(-lim, std::min(lim, p.x)) * s),
                 cvRound(std::max(-lim, std::min(lim, p.y)) * s));
}

namespace {

constexpr int kShift = 8;

Point toFixed(const Point2d& p) {
    return toFixedPoint(p, kShift);
}

}  // namespace

/** The straight image polyline @p pts (closed when @p closed) as the lens with radial
coefficient @p k1 shows it in an image of @p size: each edge cut into pieces of at most 8 px,
every point distorted (distortPointK1). Points beyond the image's corners (undistorted radius
over 1.2 × theirs) or where the model folds back (barrel: r² ≥ 1 / (3 |k1|)) are dropped,
which splits the polyline into runs. A single unchanged run for k1 = 0. */
static std::vector<std::vector<Point>> bent(const std::vector<Point2d>& pts, bool closed,
                                            const Camera& cam, double k1, Size size) {
    std::vector<std::vector<Point>> runs(1);
    const Point2d c(cam.K(0, 2), cam.K(1, 2));
    const double f = cam.K(0, 0);
    const size_t n = pts.size();
    if (n == 0) return {};
    if (k1 == 0) {
        for (const auto& p : pts)
            runs[0].push_back(toFixed(p));
        if (closed) runs[0].push_back(runs[0].front());
        return runs;
    }
    double r_corner = 0;
    for (const Point2d q : {Point2d(0, 0), Point2d(size.width - 1, 0), Point2d(0, size.height - 1),
                            Point2d(size.width - 1, size.height - 1)})
        r_corner = std::max(r_corner, norm(undistortPointK1(q, f, c, k1) - c) / f);
    double r_lim = 1.2 * r_corner;
    if (k1 < 0) r_lim = std::min(r_lim, 0.99 / std::sqrt(3 * -k1));
    auto add = [&](const Point2d& p) {
        if (norm(p - c) / f < r_lim)
            runs.back().push_back(toFixed(distortPointK1(p, f, c, k1)));
        else if (!runs.back().empty())
            runs.emplace_back();
    };
    const size_t ne = closed ? n : n - 1;
    for (size_t i = 0; i < ne; ++i) {
        const Point2d a = pts[i], b = pts[(i + 1) % n];
        const int steps = std::max(1, (int)std::ceil(norm(b - a) / 8.0));
        for (int k = 0; k < steps; ++k)
            add(a + (b - a) * (double(k) / steps));
    }
    add(closed ? pts[0] : pts.back());
    std::vector<std::vector<Point>> out;
    for (auto& r : runs)
        if (r.size() >= 2) out.push_back(std::move(r));
    return out;
}

void drawCalibrationOverlay(InputArray image, OutputArray overlay_, const Scene& scene,
                            const FrameCalibration& fc) {
    Mat src = image.getMat();
    CV_Assert(!src.empty());
    Mat out;
    if (src.type() == CV_8UC1)
        cvtColor(src, out, COLOR_GRAY2BGR);
    else {
        CV_Assert(src.type() == CV_8UC3);
        out = src.clone();
    }
    const Camera& cam = scene.camera;
    const Scalar axis_col[3] = {Scalar(60, 60, 255), Scalar(60, 220, 60), Scalar(255, 120, 40)};
    const int thick = std::max(1, (int)std::lround(std::max(out.cols, out.rows) / 500.0));
    // Light polygons (filled, translucent).
    if (!scene.lights.empty()) {
        Mat layer = out.clone();
        for (const auto& l : scene.lights) {
            if (l.type != Light::POLYGON) continue;
            std::vector<Point2d> px = projectPolygon(cam, l.corners, 0.02);
            if (px.size() < 3) continue;
            const auto runs = bent(px, true, cam, fc.k1, out.size());
            if (runs.empty()) continue;
            std::vector<Point> fx;
            for (const auto& r : runs)
                fx.insert(fx.end(), r.begin(), r.end());
            fillPoly(layer, std::vector<std::vector<Point>>{fx}, Scalar(0, 230, 255), LINE_AA,
                     kShift);
            polylines(out, std::vector<std::vector<Point>>{fx}, true, Scalar(0, 200, 255), thick,
                      LINE_AA, kShift);
        }
        addWeighted(layer, 0.35, out, 0.65, 0, out);
    }
    // Segments coloured by axis.
    for (size_t i = 0; i < fc.segments.size(); ++i) {
        const Vec4f& s = fc.segments[i];
        const int a = i < fc.labels.size() ? fc.labels[i] : -1;
        line(out, toFixed(Point2d(s[0], s[1])), toFixed(Point2d(s[2], s[3])),
             a >= 0 ? axis_col[a] : Scalar(128, 128, 128), thick, LINE_AA, kShift);
    }
    // Box wireframe.
    if (scene.has_room) {
        const Vec3d& a = scene.room.min;
        const Vec3d& b = scene.room.max;
        for (int e = 0; e < 12; ++e) {
            const int axis = e / 4, k = e % 4;
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;
            Vec3d p, q;
            p[u] = q[u] = (k & 1) ? b[u] : a[u];
            p[v] = q[v] = (k & 2) ? b[v] : a[v];
            p[axis] = a[axis];
            q[axis] = b[axis];
            Point2d pa, pb;
            if (projectSegment(cam, p, q, pa, pb, 0.02))
                polylines(out, bent({pa, pb}, false, cam, fc.k1, out.size()), false,
                          Scalar(255, 255, 255), thick + 1, LINE_AA, kShift);
        }
    }
    // Horizon: image of the plane's line at infinity, l = K^-T R e_z.
    {
        const Vec3d z(cam.R(0, 2), cam.R(1, 2), cam.R(2, 2));
        const Vec3d l = cam.K.inv().t() * z;
        if (std::abs(l[1]) > 1e-12 * std::abs(l[0])) {
            // Across the image, or with distortion across the wider undistorted view (bent()
            // keeps the part that is seen).
            const double x0 = fc.k1 == 0 ? 0 : -out.cols,
                         x1 = fc.k1 == 0 ? out.cols - 1 : 2 * out.cols;
            const double y0 = -(l[2] + l[0] * x0) / l[1], y1 = -(l[2] + l[0] * x1) / l[1];
            polylines(out, bent({Point2d(x0, y0), Point2d(x1, y1)}, false, cam, fc.k1, out.size()),
                      false, Scalar(255, 0, 255), thick, LINE_AA, kShift);
        }
    }
    // Vanishing points (when within three image sizes) with rays to the image centre.
    const Point2d centre = imageCenter(out.size());
    for (int a = 0; a < 3; ++a) {
        const Vec3d v = fc.vanishing_points[a];
        if (std::abs(v[2]) < 1e-12) continue;
        const Point2d p(v[0] / v[2], v[1] / v[2]);
        if (std::abs(p.x - centre.x) > 3 * out.cols || std::abs(p.y - centre.y) > 3 * out.rows)
            continue;
        circle(out, toFixed(p), 6 * thick << kShift, axis_col[a], thick + 1, LINE_AA, kShift);
        line(out, toFixed(p), toFixed(centre), axis_col[a], 1, LINE_AA, kShift);
        const char* nm[3] = {"x", "y", "z"};
        putText(out, std::string("VP ") + nm[a], Point(cvRound(p.x) + 8, cvRound(p.y) - 8),
                FONT_HERSHEY_SIMPLEX, 0.5 * thick, axis_col[a], thick, LINE_AA);
    }
    const double fov = 2 * std::atan2(out.cols * 0.5, cam.K(0, 0)) * 180 / CV_PI;
    std::string caption = format("f = %.1f px (hfov %.1f deg), confidence %.2f, rms %.2f px",
                                 cam.K(0, 0), fov, fc.confidence, fc.rms_px);
    if (fc.k1 != 0) caption += format(", k1 %.4f", fc.k1);
    putText(out, caption, Point(10, 20), FONT_HERSHEY_SIMPLEX, 0.5 * thick, Scalar(0, 0, 0),
            3 * thick, LINE_AA);
    putText(out, caption, Point(10, 20), FONT_HERSHEY_SIMPLEX, 0.5 * thick, Scalar(255, 255, 255),
            thick, LINE_AA);
    out.copyTo(overlay_);
}

}  // namespace vbme
}  // namespace cv
