// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Room box from clicked points; light polygons ray-cast onto the box.
#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/calib/frame_calibration.hpp"
#include "room_internal.hpp"

namespace cv {
namespace vbme {
namespace detail {

int faceIndex(const std::string& name, const std::string& field) {
    const int i = Room::findFace(name);
    if (i < 0)
        CV_Error(Error::StsBadArg, field + ": unknown face '" + name +
                                       "' (expected floor, ceiling, left, right, front or back)");
    return i;
}

static int wallIndex(const std::string& name, const std::string& field) {
    const int f = faceIndex(name, field);
    if (f <= 1)
        CV_Error(Error::StsBadArg,
                 field + ": '" + name + "' is not a wall (expected left, right, front or back)");
    return f;
}

static const char* axisName(int a) {
    return a == 0 ? "x" : (a == 1 ? "y" : "z");
}

/** Mean and standard deviation. */
static void meanStd(const std::vector<double>& v, double& mean, double& sd) {
    mean = 0;
    for (double x : v)
        mean += x;
    mean /= v.size();
    sd = 0;
    for (double x : v)
        sd += (x - mean) * (x - mean);
    sd = std::sqrt(sd / v.size());
}

void solveFaces(const Camera& camera, const RoomAnnotation& ann, bool use_numbers, double value[6],
                bool known[6]) {
    for (int i = 0; i < 6; ++i)
        known[i] = false;
    value[0] = 0;
    known[0] = true;  // the floor is z = 0
    const Vec3d C = camera.center();
    if (use_numbers)
        for (const auto& kv : ann.faces) {
            const int f = faceIndex(kv.first, "room.faces." + kv.first);
            if (f == 0) {
                if (std::abs(kv.second) > 1e-12)
                    CV_Error(Error::StsBadArg,
                             "room.faces.floor: the floor is at z = 0 by "
                             "convention; remove it or set it to 0");
                continue;
            }
            value[f] = kv.second;
            known[f] = true;
        }
    // Edges between a horizontal plane (floor z = 0 or ceiling) and a wall.
    struct Edge {
        int plane;  // 0 floor, 1 ceiling
        int wall;
        const std::vector<Point2d>* pts;
        std::string field;
    };
    std::vector<Edge> edges;
    for (const auto& kv : ann.floor_edges)
        edges.push_back({0, wallIndex(kv.first, "room.floor_edges." + kv.first), &kv.second,
                         "room.floor_edges." + kv.first});
    for (const auto& kv : ann.ceiling_edges)
        edges.push_back({1, wallIndex(kv.first, "room.ceiling_edges." + kv.first), &kv.second,
                         "room.ceiling_edges." + kv.first});
    for (const auto& e : edges)
        if (e.pts->empty()) CV_Error(Error::StsBadArg, e.field + ": expected at least one point");
    for (const auto& c : ann.wall_corners) {
        const int a = wallIndex(c.wall_a, "room.wall_corners"),
                  b = wallIndex(c.wall_b, "room.wall_corners");
        if (Room::faceAxis(a) == Room::faceAxis(b))
            CV_Error(Error::StsBadArg, "room.wall_corners: walls '" + c.wall_a + "' and '" +
                                           c.wall_b +
                                           "' are parallel; a corner joins a "
                                           "left/right wall and a front/back wall");
        if (c.points.empty())
            CV_Error(Error::StsBadArg, "room.wall_corners: a corner has no points");
    }
    for (int pass = 0; pass < 8; ++pass) {
        bool changed = false;
        for (const auto& e : edges) {
            const int ax = Room::faceAxis(e.wall);
            const int other = 1 - ax;
            if (!known[e.plane] && !known[e.wall]) continue;
            if (known[e.plane] && known[e.wall]) continue;
            std::vector<double> vals, others;
            for (const auto& px : *e.pts) {
                const Vec3d d = camera.rayDirection(px);
                if (known[e.plane]) {
                    // Ray-cast onto the horizontal plane, read the wall coordinate.
                    const double z = value[e.plane];
                    const double s = (z - C[2]) / d[2];
                    if (!(s > 0) || std::abs(d[2]) < 1e-9)
                        CV_Error(
                            Error::StsBadArg,
                            format("%s: point (%.1f, %.1f) looks %s the horizon, so it "
                                   "cannot be on the %s edge",
                                   e.field.c_str(), px.x, px.y, e.plane == 0 ? "above" : "below",
                                   e.plane == 0 ? "floor" : "ceiling"));
                    const Vec3d X = C + s * d;
                    vals.push_back(X[ax]);
                    others.push_back(X[other]);
                } else {
                    // Ray-cast onto the wall, read the height.
                    const double s = (value[e.wall] - C[ax]) / d[ax];
                    if (!(s > 0) || std::abs(d[ax]) < 1e-9)
                        CV_Error(
                            Error::StsBadArg,
                            format("%s: the ray through (%.1f, %.1f) does not reach the "
                                   "%s wall",
                                   e.field.c_str(), px.x, px.y, Room::faceNames()[e.wall].c_str()));
                    vals.push_back(C[2] + s * d[2]);
                }
            }
            double mean, sd;
            meanStd(vals, mean, sd);
            if (!known[e.wall]) {
                if (others.size() >= 2) {
                    double mo, so;
                    meanStd(others, mo, so);
                    if (sd > so && sd > 0.05 * std::abs(mean))
                        CV_Error(Error::StsBadArg,
                                 format("%s: the points run along %s, not along the %s wall "
                                        "(constant %s); left/right are x = min/max, front/back "
                                        "y = min/max, and the camera faces back (+y)",
                                        e.field.c_str(), axisName(ax),
                                        Room::faceNames()[e.wall].c_str(), axisName(ax)));
                }
                const bool is_max = e.wall == 3 || e.wall == 5;
                if ((is_max && !(mean > 0)) || (!is_max && !(mean < 0)))
                    CV_Error(Error::StsBadArg,
                             format("%s: the points put the %s wall at %s = %.3f, on the wrong "
                                    "side of the camera (expected %s 0); check the wall's name",
                                    e.field.c_str(), Room::faceNames()[e.wall].c_str(),
                                    axisName(ax), mean, is_max ? ">" : "<"));
                value[e.wall] = mean;
                known[e.wall] = true;
            } else {
                value[e.plane] = mean;
                known[e.plane] = true;
            }
            changed = true;
        }
        for (const auto& c : ann.wall_corners) {
            const int a = wallIndex(c.wall_a, "room.wall_corners");
            const int b = wallIndex(c.wall_b, "room.wall_corners");
            const int wx = Room::faceAxis(a) == 0 ? a : b, wy = Room::faceAxis(a) == 0 ? b : a;
            if (known[wx] == known[wy]) continue;
            std::vector<double> vals;
            for (const auto& px : c.points) {
                const Vec3d d = camera.rayDirection(px);
                // The corner (x_c, y_c) lies on the ray's plan-view half-line from the camera.
                if (known[wy]) {
                    const double s = (value[wy] - C[1]) / d[1];
                    if (!(s > 0))
                        CV_Error(Error::StsBadArg,
                                 format("room.wall_corners: point (%.1f, %.1f) does not look "
                                        "towards the %s wall",
                                        px.x, px.y, Room::faceNames()[wy].c_str()));
                    vals.push_back(C[0] + s * d[0]);
                } else {
                    const double s = (value[wx] - C[0]) / d[0];
                    if (!(s > 0))
                        CV_Error(Error::StsBadArg,
                                 format("room.wall_corners: point (%.1f, %.1f) does not look "
                                        "towards the %s wall",
                                        px.x, px.y, Room::faceNames()[wx].c_str()));
                    vals.push_back(C[1] + s * d[1]);
                }
            }
            double mean, sd;
            meanStd(vals, mean, sd);
            value[known[wy] ? wx : wy] = mean;
            known[known[wy] ? wx : wy] = true;
            changed = true;
        }
        if (!changed) break;
    }
}

}  // namespace detail

Room fitRoom(const Camera& camera, const RoomAnnotation& ann) {
    double value[6];
    bool known[6];
    detail::solveFaces(camera, ann, true, value, known);
    std::string missing;
    for (int i = 0; i < 6; ++i)
        if (!known[i]) missing += (missing.empty() ? "" : ", ") + Room::faceNames()[i];
    if (!missing.empty())
        CV_Error(Error::StsBadArg,
                 "room: face(s) " + missing +
                     " undetermined; click points on a wall's floor edge "
                     "(room.floor_edges.<wall>), a wall corner (room.wall_corners), the ceiling "
                     "edge (room.ceiling_edges.<wall>), or give the coordinate "
                     "(room.faces: { <face>: metres })");
    Room r;
    r.min = Vec3d(value[2], value[4], value[0]);
    r.max = Vec3d(value[3], value[5], value[1]);
    const Vec3d C = camera.center();
    for (int k = 0; k < 3; ++k)
        if (!(r.min[k] < C[k] && C[k] < r.max[k]))
            CV_Error(Error::StsBadArg,
                     format("room: the camera (%.3f, %.3f, %.3f) is not inside the box "
                            "[%.3f, %.3f] × [%.3f, %.3f] × [%.3f, %.3f] (check the annotation "
                            "and the camera height)",
                            C[0], C[1], C[2], r.min[0], r.max[0], r.min[1], r.max[1], r.min[2],
                            r.max[2]));
    return r;
}

std::string faceSeenAt(const Camera& camera, const Room& room, const Point2d& px) {
    const Vec3d C = camera.center(), d = camera.rayDirection(px);
    double best = 1e300;
    int face = -1;
    for (int f = 0; f < 6; ++f) {
        const int ax = Room::faceAxis(f);
        const double coord = (f % 2 == 0) ? room.min[ax] : room.max[ax];
        if (std::abs(d[ax]) < 1e-12) continue;
        const double s = (coord - C[ax]) / d[ax];
        if (s > 0 && s < best) {
            best = s;
            face = f;
        }
    }
    if (face < 0)
        CV_Error(Error::StsBadArg, "faceSeenAt: the ray leaves no face (camera outside?)");
    return Room::faceNames()[face];
}

Vec3d meanLinearRGB(InputArray image, const std::vector<Point2d>& polygon, Response response) {
    Mat img = image.getMat();
    CV_Assert(img.type() == CV_8UC3);
    if (polygon.size() < 3) CV_Error(Error::StsBadArg, "light polygon: expected at least 3 points");
    std::vector<Point> pts;
    const int shift = 4;
    for (const auto& p : polygon)
        pts.emplace_back(cvRound(p.x * (1 << shift)), cvRound(p.y * (1 << shift)));
    Mat mask = Mat::zeros(img.size(), CV_8U);
    fillPoly(mask, std::vector<std::vector<Point>>{pts}, Scalar(255), LINE_8, shift);
    const Rect box = boundingRect(mask);
    if (box.area() == 0 || countNonZero(mask(box)) == 0)
        CV_Error(Error::StsBadArg, "light polygon covers no pixel of the image");
    Mat lin;
    linearize(img(box), lin, response);
    const Scalar m = mean(lin, mask(box));
    return Vec3d(m[2], m[1], m[0]);
}

Light projectLight(const Camera& camera, const Room& room, const LightAnnotation& la,
                   InputArray image, Response response) {
    if (la.polygon.size() < 3)
        CV_Error(Error::StsBadArg, format("light polygon has %d point(s); expected at least 3",
                                          (int)la.polygon.size()));
    Point2d centre(0, 0);
    for (const auto& p : la.polygon)
        centre += p;
    centre *= 1.0 / la.polygon.size();
    const std::string face = la.face.empty() ? faceSeenAt(camera, room, centre) : la.face;
    const int f = detail::faceIndex(face, "light.face");
    const int ax = Room::faceAxis(f);
    const double coord = (f % 2 == 0) ? room.min[ax] : room.max[ax];
    const Vec3d C = camera.center();
    Light L;
    L.type = Light::POLYGON;
    for (size_t i = 0; i < la.polygon.size(); ++i) {
        const Vec3d d = camera.rayDirection(la.polygon[i]);
        const double s = std::abs(d[ax]) > 1e-12 ? (coord - C[ax]) / d[ax] : -1;
        if (!(s > 0))
            CV_Error(Error::StsBadArg,
                     format("light polygon point %d (%.1f, %.1f) does not look towards the %s "
                            "face it is said to lie on",
                            (int)i, la.polygon[i].x, la.polygon[i].y, face.c_str()));
        Vec3d X = C + s * d;
        for (int k = 0; k < 3; ++k)
            X[k] = std::min(std::max(X[k], room.min[k]), room.max[k]);
        X[ax] = coord;
        L.corners.push_back(X);
    }
    Vec3d inward(0, 0, 0);
    inward[ax] = (f % 2 == 0) ? 1 : -1;
    const Vec3d nrm = L.polygonNormal();
    if (norm(nrm) == 0)
        CV_Error(Error::StsBadArg, "light polygon is degenerate (no area on its face)");
    if (nrm.dot(inward) < 0) std::reverse(L.corners.begin(), L.corners.end());
    if (la.has_radiance)
        L.radiance = la.radiance;
    else if (!image.empty())
        L.radiance = meanLinearRGB(image, la.polygon, response);
    else
        L.radiance = Vec3d(1, 1, 1);
    return L;
}

}  // namespace vbme
}  // namespace cv
