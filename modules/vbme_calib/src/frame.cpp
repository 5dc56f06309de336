// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Annotation file IO and the single-frame calibration driver.
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/calib/frame_calibration.hpp"
#include "opencv2/vbme/core/yaml_guard.hpp"
#include "room_internal.hpp"

namespace cv {
namespace vbme {

namespace {

std::vector<double> readNumbers(const FileNode& n, const std::string& field) {
    std::vector<double> v;
    if (!n.isSeq()) CV_Error(Error::StsParseError, field + ": expected a sequence of numbers");
    for (auto it = n.begin(); it != n.end(); ++it) {
        const FileNode e = *it;
        if (e.isSeq()) {
            for (auto jt = e.begin(); jt != e.end(); ++jt) {
                if (!(*jt).isReal() && !(*jt).isInt())
                    CV_Error(Error::StsParseError, field + ": expected numbers");
                v.push_back((double)*jt);
            }
        } else if (e.isReal() || e.isInt()) {
            v.push_back((double)e);
        } else {
            CV_Error(Error::StsParseError, field + ": expected numbers");
        }
    }
    return v;
}

Point2d readPoint(const FileNode& n, const std::string& field) {
    const std::vector<double> v = readNumbers(n, field);
    if (v.size() != 2) CV_Error(Error::StsParseError, field + ": expected a point [x, y]");
    return Point2d(v[0], v[1]);
}

std::vector<Point2d> readPoints(const FileNode& n, const std::string& field) {
    std::vector<Point2d> pts;
    if (!n.isSeq())
        CV_Error(Error::StsParseError, field + ": expected a sequence of [x, y] points");
    int i = 0;
    for (auto it = n.begin(); it != n.end(); ++it, ++i)
        pts.push_back(readPoint(*it, field + "[" + std::to_string(i) + "]"));
    return pts;
}

void writePoints(FileStorage& fs, const std::string& key, const std::vector<Point2d>& pts) {
    if (!key.empty()) fs << key;
    fs << "[";
    for (const auto& p : pts)
        fs << "[:" << p.x << p.y << "]";
    fs << "]";
}

std::map<std::string, std::vector<Point2d>> readEdges(const FileNode& n, const std::string& field) {
    std::map<std::string, std::vector<Point2d>> m;
    if (n.empty()) return m;
    if (!n.isMap()) CV_Error(Error::StsParseError, field + ": expected a map wall → points");
    for (auto it = n.begin(); it != n.end(); ++it) {
        const FileNode e = *it;
        m[e.name()] = readPoints(e, field + "." + e.name());
    }
    return m;
}

/** A string value. FileStorage's YAML reader keeps a trailing "# comment" in plain scalars
(`face: back  # the window`): drop it and the surrounding blanks. */
std::string str(const FileNode& n) {
    std::string v = (std::string)n;
    const size_t hash = v.find(" #");
    if (hash != std::string::npos) v = v.substr(0, hash);
    const size_t b = v.find_first_not_of(" \t"), e = v.find_last_not_of(" \t");
    return b == std::string::npos ? std::string() : v.substr(b, e - b + 1);
}

}  // namespace

FrameAnnotation FrameAnnotation::read(const std::string& path) {
    FileStorage fs;
    try {
        // Hand-written YAML often lacks FileStorage's "%YAML:1.0" first line: add it.
        std::ifstream in(path, std::ios::binary);
        if (!in) CV_Error(Error::StsObjectNotFound, path + ": cannot open the annotation file");
        std::stringstream ss;
        ss << in.rdbuf();
        std::string text = ss.str();
        const std::string ext = path.size() >= 4 ? path.substr(path.find_last_of('.') + 1) : "";
        const bool json = ext == "json" || ext == "JSON";
        if (!json) checkYamlTopLevel(text, path);
        if (!json && text.compare(0, 5, "%YAML") != 0) text = "%YAML:1.0\n" + text;
        fs.open(text, FileStorage::READ | FileStorage::MEMORY |
                          (json ? FileStorage::FORMAT_JSON : FileStorage::FORMAT_YAML));
    } catch (const cv::Exception& e) {
        if (e.code == Error::StsObjectNotFound) throw;
        CV_Error(Error::StsParseError, path + ": cannot parse the annotation file: " + e.err);
    } catch (const std::exception& e) {  // OpenCV's parsers may throw std::length_error
        CV_Error(Error::StsParseError,
                 path + ": cannot parse the annotation file: " + std::string(e.what()));
    }
    if (!fs.isOpened())
        CV_Error(Error::StsObjectNotFound, path + ": cannot open the annotation file");
    FrameAnnotation a;
    try {
        a.read(fs.root(), path);
    } catch (const cv::Exception& e) {
        CV_Error(e.code, path + ": " + e.err);
    }
    return a;
}

void FrameAnnotation::read(const FileNode& root, const std::string& source) {
    *this = FrameAnnotation();
    if (!root.isMap()) CV_Error(Error::StsParseError, source + ": expected a map at top level");
    if (!root["image_size"].empty()) {
        image_size = readImageSize(root["image_size"], "image_size");
    }
    auto num = [&](const char* key, double& v) {
        const FileNode n = root[key];
        if (n.empty()) return;
        if (!n.isReal() && !n.isInt())
            CV_Error(Error::StsParseError, std::string(key) + ": expected a number");
        v = (double)n;
    };
    num("focal", focal);
    num("camera_height", camera_height);
    num("room_height", room_height);
    num("k1", k1);
    if (!(std::abs(k1) < 10))
        CV_Error(Error::StsParseError,
                 format("k1: %g is not a plausible radial distortion coefficient", k1));
    if (camera_height < 0 || room_height < 0 || focal < 0)
        CV_Error(Error::StsParseError,
                 "focal, camera_height, room_height: expected positive numbers");
    const FileNode ppn = root["principal_point"];
    if (!ppn.empty()) {
        if (ppn.isString()) {
            if (str(ppn) != "orthocenter" && str(ppn) != "center")
                CV_Error(Error::StsParseError,
                         "principal_point: expected [x, y], 'center' or 'orthocenter'");
            principal_point_from_orthocenter = str(ppn) == "orthocenter";
        } else {
            principal_point = readPoint(ppn, "principal_point");
        }
    }
    if (!root["response"].empty()) {
        response = parseResponse(str(root["response"]));
        has_response = true;
    }
    const FileNode ln = root["lines"];
    if (!ln.empty()) {
        if (!ln.isSeq())
            CV_Error(Error::StsParseError, "lines: expected a sequence of line groups");
        int gi = 0;
        for (auto it = ln.begin(); it != ln.end(); ++it, ++gi) {
            const FileNode g = *it;
            const std::string f = "lines[" + std::to_string(gi) + "]";
            LineGroup lg;
            lg.name = g["name"].empty() ? format("group%d", gi) : str(g["name"]);
            if (!g["axis"].empty()) lg.axis = parseAxisHint(str(g["axis"]), f + ".axis");
            const FileNode segs = g["segments"];
            if (segs.empty() || !segs.isSeq())
                CV_Error(Error::StsParseError,
                         f + ".segments: expected a sequence of [x1, y1, x2, y2]");
            int si = 0;
            for (auto jt = segs.begin(); jt != segs.end(); ++jt, ++si) {
                const std::vector<double> v =
                    readNumbers(*jt, f + ".segments[" + std::to_string(si) + "]");
                if (v.size() != 4)
                    CV_Error(Error::StsParseError, f + ".segments[" + std::to_string(si) +
                                                       "]: expected [x1, y1, x2, y2]");
                lg.segments.emplace_back(v[0], v[1], v[2], v[3]);
            }
            lines.push_back(lg);
        }
    }
    const FileNode rn = root["room"];
    if (!rn.empty()) {
        if (!rn.isMap()) CV_Error(Error::StsParseError, "room: expected a map");
        room.floor_edges = readEdges(rn["floor_edges"], "room.floor_edges");
        room.ceiling_edges = readEdges(rn["ceiling_edges"], "room.ceiling_edges");
        const FileNode wc = rn["wall_corners"];
        if (!wc.empty()) {
            if (!wc.isSeq())
                CV_Error(Error::StsParseError, "room.wall_corners: expected a sequence");
            int ci = 0;
            for (auto it = wc.begin(); it != wc.end(); ++it, ++ci) {
                const std::string f = "room.wall_corners[" + std::to_string(ci) + "]";
                const FileNode c = *it;
                const FileNode w = c["walls"];
                if (!w.isSeq() || w.size() != 2)
                    CV_Error(Error::StsParseError, f + ".walls: expected two wall names");
                RoomAnnotation::WallCorner corner;
                corner.wall_a = str(w[0]);
                corner.wall_b = str(w[1]);
                corner.points = readPoints(c["points"], f + ".points");
                room.wall_corners.push_back(corner);
            }
        }
        const FileNode fc = rn["faces"];
        if (!fc.empty()) {
            if (!fc.isMap())
                CV_Error(Error::StsParseError, "room.faces: expected a map face → metres");
            for (auto it = fc.begin(); it != fc.end(); ++it) {
                const FileNode e = *it;
                detail::faceIndex(e.name(), "room.faces." + e.name());
                if (!e.isReal() && !e.isInt())
                    CV_Error(Error::StsParseError,
                             "room.faces." + e.name() + ": expected a number");
                room.faces[e.name()] = (double)e;
            }
        }
    }
    const FileNode lt = root["lights"];
    if (!lt.empty()) {
        if (!lt.isSeq()) CV_Error(Error::StsParseError, "lights: expected a sequence");
        int li = 0;
        for (auto it = lt.begin(); it != lt.end(); ++it, ++li) {
            const std::string f = "lights[" + std::to_string(li) + "]";
            const FileNode l = *it;
            LightAnnotation la;
            la.polygon = readPoints(l["polygon"], f + ".polygon");
            if (la.polygon.size() < 3)
                CV_Error(Error::StsParseError, f + ".polygon: expected at least 3 points");
            if (!l["face"].empty()) {
                la.face = str(l["face"]);
                detail::faceIndex(la.face, f + ".face");
            }
            if (!l["radiance"].empty()) {
                la.radiance = readVec3(l["radiance"], f + ".radiance");
                la.has_radiance = true;
            }
            lights.push_back(la);
        }
    }
}

void FrameAnnotation::write(FileStorage& fs) const {
    if (image_size.area() > 0)
        fs << "image_size"
           << "[:" << image_size.width << image_size.height << "]";
    if (focal > 0) fs << "focal" << focal;
    if (k1 != 0) fs << "k1" << k1;
    if (principal_point_from_orthocenter)
        fs << "principal_point"
           << "orthocenter";
    else if (principal_point.x >= 0 && principal_point.y >= 0)
        fs << "principal_point"
           << "[:" << principal_point.x << principal_point.y << "]";
    if (camera_height > 0) fs << "camera_height" << camera_height;
    if (room_height > 0) fs << "room_height" << room_height;
    if (has_response) fs << "response" << toString(response);
    if (!lines.empty()) {
        fs << "lines"
           << "[";
        for (const auto& g : lines) {
            fs << "{"
               << "name" << g.name << "axis" << toString(g.axis) << "segments"
               << "[";
            for (const auto& s : g.segments)
                fs << "[:" << s[0] << s[1] << s[2] << s[3] << "]";
            fs << "]"
               << "}";
        }
        fs << "]";
    }
    if (!room.empty()) {
        fs << "room"
           << "{";
        if (!room.floor_edges.empty()) {
            fs << "floor_edges"
               << "{";
            for (const auto& kv : room.floor_edges)
                writePoints(fs, kv.first, kv.second);
            fs << "}";
        }
        if (!room.ceiling_edges.empty()) {
            fs << "ceiling_edges"
               << "{";
            for (const auto& kv : room.ceiling_edges)
                writePoints(fs, kv.first, kv.second);
            fs << "}";
        }
        writeMapSeq(fs, "wall_corners", room.wall_corners,
                    [&](const RoomAnnotation::WallCorner& c) {
                        fs << "walls"
                           << "[:" << c.wall_a << c.wall_b << "]";
                        writePoints(fs, "points", c.points);
                    });
        if (!room.faces.empty()) {
            fs << "faces"
               << "{";
            for (const auto& kv : room.faces)
                fs << kv.first << kv.second;
            fs << "}";
        }
        fs << "}";
    }
    writeMapSeq(fs, "lights", lights, [&](const LightAnnotation& l) {
        writePoints(fs, "polygon", l.polygon);
        if (!l.face.empty()) fs << "face" << l.face;
        if (l.has_radiance) writeVec3(fs, "radiance", l.radiance);
    });
}

void FrameAnnotation::write(const std::string& path) const {
    AtomicFile out(path);
    {
        FileStorage fs = openForWriting(out);
        write(fs);
    }
    out.commit();
}

FrameCalibration calibrateLinesWithK1(const VanishingPointCalibrator& cal,
                                      const std::vector<LineGroup>& groups, Size size, double k1,
                                      std::vector<LineGroup>* undistorted) {
    if (k1 == 0) {
        if (undistorted) *undistorted = groups;
        return cal.calibrate(groups, size);
    }
    // k1 is relative to K⁻¹ p, so the undistortion depends on the focal length being sought:
    // the focal is the one whose undistorted lines meet their vanishing points best (the
    // calibration's rms residual, 0 for exact clicks at the true focal; a fixed-point iteration
    // of "calibrate, undistort with the focal found" settled on a wrong second root, 2.6 % off).
    // The distorted frame's calibration: the start of the search and its principal point.
    FrameCalibration fc = cal.calibrate(groups, size);
    std::vector<LineGroup> lines_at;
    auto calibrateAt = [&](double f) {
        Camera lens = fc.camera();
        lens.K(0, 0) = lens.K(1, 1) = f;
        lens.k1 = k1;
        std::vector<LineGroup> lines = groups;
        for (LineGroup& g : lines) {
            std::vector<Vec4d> kept;
            for (const Vec4d& s : g.segments) {
                const Point2d a = lens.undistortPixel(Point2d(s[0], s[1]));
                const Point2d b = lens.undistortPixel(Point2d(s[2], s[3]));
                if (!std::isfinite(a.x) || !std::isfinite(b.x)) {  // beyond the fold:
                    FrameCalibration bad;                          // k1 does not fit this focal
                    bad.rms_px = std::numeric_limits<double>::infinity();
                    return bad;
                }
                kept.emplace_back(a.x, a.y, b.x, b.y);
            }
            g.segments = kept;
        }
        try {
            FrameCalibration r = cal.calibrate(lines, size);
            lines_at = lines;
            return r;
        } catch (const cv::Exception&) {  // too few lines left at this focal
            FrameCalibration bad;
            bad.rms_px = std::numeric_limits<double>::infinity();
            return bad;
        }
    };
    // a log grid around the distorted frame's focal, then golden-section search
    const double f0 = fc.focal();
    const int n = 25;
    std::vector<double> fs(n), rms(n);
    int best = 0;
    for (int i = 0; i < n; ++i) {
        fs[i] = f0 * std::pow(2.0, -1.5 + 2.0 * i / (n - 1));  // f0 / 2.8 … 1.4 f0
        rms[i] = calibrateAt(fs[i]).rms_px;
        if (rms[i] < rms[best]) best = i;
    }
    double lo = fs[std::max(0, best - 1)], hi = fs[std::min(n - 1, best + 1)];
    const double g = (std::sqrt(5.0) - 1) / 2;
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double r1 = calibrateAt(x1).rms_px, r2 = calibrateAt(x2).rms_px;
    for (int it = 0; it < 40 && hi - lo > 1e-4 * f0; ++it) {
        if (r1 < r2) {
            hi = x2;
            x2 = x1;
            r2 = r1;
            x1 = hi - g * (hi - lo);
            r1 = calibrateAt(x1).rms_px;
        } else {
            lo = x1;
            x1 = x2;
            r1 = r2;
            x2 = lo + g * (hi - lo);
            r2 = calibrateAt(x2).rms_px;
        }
    }
    fc = calibrateAt(0.5 * (lo + hi));
    if (!std::isfinite(fc.rms_px))
        CV_Error(Error::StsBadArg,
                 "the clicked lines, undistorted with the annotation's k1, "
                 "do not calibrate");
    fc.k1 = k1;
    if (undistorted) *undistorted = lines_at;
    return fc;
}

Scene calibrateFrame(InputArray image_, const FrameAnnotation& ann,
                     const FrameCalibrationOptions& opt, FrameCalibration* calibration) {
    Mat image = image_.getMat();
    if (image.empty()) CV_Error(Error::StsBadArg, "calibrateFrame: the image is empty");
    if (image.type() == CV_8UC1) cvtColor(image, image, COLOR_GRAY2BGR);
    if (image.type() != CV_8UC3)
        CV_Error(Error::StsBadArg, "calibrateFrame: expected an 8-bit BGR image");
    const Size size = image.size();
    if (ann.image_size.area() > 0 && ann.image_size != size)
        CV_Error(Error::StsBadArg,
                 format("the annotation is for a %dx%d image but the image is %dx%d",
                        ann.image_size.width, ann.image_size.height, size.width, size.height));
    VanishingPointCalibrator::Params vp = opt.vp;
    if (vp.focal <= 0 && ann.focal > 0) vp.focal = ann.focal;
    if (vp.principal_point.x < 0 && ann.principal_point.x >= 0 && ann.principal_point.y >= 0)
        vp.principal_point = ann.principal_point;
    if (ann.principal_point_from_orthocenter) vp.principal_point_from_orthocenter = true;
    Ptr<VanishingPointCalibrator> cal = VanishingPointCalibrator::create(vp);
    FrameCalibration fc;
    if (!ann.lines.empty())
        fc = cal->calibrate(ann.lines, size);
    else if (opt.auto_detect)
        fc = cal->detect(image);
    else
        CV_Error(Error::StsBadArg,
                 "the annotation has no 'lines' and automatic detection is off; "
                 "add line groups or detect them automatically (--auto)");
    // A known lens (the annotation's k1) with clicked lines: the lines are taken undistorted
    // (calibrateLinesWithK1(), which the annotator's live calibration uses too).
    if (ann.k1 != 0 && !vp.estimate_distortion) {
        if (ann.lines.empty())
            CV_Error(Error::StsBadArg,
                     "the annotation's k1 is used with its clicked lines; for automatic detection "
                     "estimate it (--distortion k1) or give the lines");
        fc = calibrateLinesWithK1(*cal, ann.lines, size, ann.k1);
    }
    Scene scene;
    scene.image_size = size;
    Camera cam = fc.camera();
    cam.response = ann.has_response ? ann.response : Response::SRGB;
    // With an estimated lens distortion the scene describes the undistorted (pinhole) frame:
    // the clicked room and light points and the light pixels are taken there.
    cam.k1 = fc.k1;
    FrameAnnotation ann_u;
    if (cam.k1 != 0) {
        ann_u = ann;
        auto undist = [&](std::vector<Point2d>& pts) {
            for (Point2d& q : pts)
                q = cam.undistortPixel(q);
        };
        for (auto& kv : ann_u.room.floor_edges)
            undist(kv.second);
        for (auto& kv : ann_u.room.ceiling_edges)
            undist(kv.second);
        for (auto& c : ann_u.room.wall_corners)
            undist(c.points);
        for (auto& l : ann_u.lights)
            undist(l.polygon);
        undistortImageK1(image, image, cam);
    }
    const FrameAnnotation& ann_p = cam.k1 != 0 ? ann_u : ann;
    const double h = opt.camera_height > 0 ? opt.camera_height : ann.camera_height;
    if (!ann_p.room.empty()) {
        if (h > 0) {
            placeCamera(cam, h);
            scene.room = fitRoom(cam, ann_p.room);
        } else {
            // Unknown height: fit in units of the camera height from the clicks alone, then
            // scale by a face whose distance is known (or the room height).
            Camera unit = cam;
            placeCamera(unit, 1.0);
            double value[6];
            bool known[6];
            detail::solveFaces(unit, ann_p.room, false, value, known);
            std::map<std::string, double> given = ann_p.room.faces;
            if (ann_p.room_height > 0) given["ceiling"] = ann_p.room_height;
            double scale = 0;
            for (const auto& kv : given) {
                const int f = detail::faceIndex(kv.first, "room.faces." + kv.first);
                if (f > 0 && known[f] && std::abs(value[f]) > 1e-9 && kv.second / value[f] > 0) {
                    scale = kv.second / value[f];
                    break;
                }
            }
            if (!(scale > 0))
                CV_Error(Error::StsBadArg,
                         "the camera height is unknown: give it (camera_height, --camera-height), "
                         "or the room height with ceiling-edge points (room_height), or the "
                         "distance of a face whose edge is clicked (room.faces)");
            placeCamera(cam, scale);
            RoomAnnotation ra = ann_p.room;
            if (ann_p.room_height > 0 && !ra.faces.count("ceiling"))
                ra.faces["ceiling"] = ann_p.room_height;
            scene.room = fitRoom(cam, ra);
        }
        scene.has_room = true;
    } else {
        placeCamera(cam, h > 0 ? h : opt.default_camera_height);
    }
    if (!ann_p.lights.empty()) {
        if (!scene.has_room)
            CV_Error(Error::StsBadArg,
                     "the annotation has lights but no room: light polygons are "
                     "projected onto the room box; annotate the room");
        for (size_t i = 0; i < ann_p.lights.size(); ++i) {
            try {
                scene.lights.push_back(
                    projectLight(cam, scene.room, ann_p.lights[i], image, cam.response));
            } catch (const cv::Exception& e) {
                CV_Error(e.code, format("lights[%d]: ", (int)i) + e.err);
            }
        }
    }
    scene.camera = cam;
    if (calibration) *calibration = fc;
    return scene;
}

}  // namespace vbme
}  // namespace cv
