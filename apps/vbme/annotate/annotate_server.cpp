// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "annotate_server.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <sstream>

#include <httplib.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib/projection.hpp>
#include <opencv2/vbme/pipeline/insertion.hpp>
#include <opencv2/vbme/render.hpp>

namespace vbme_app {

using json = nlohmann::json;
using namespace cv::vbme;

namespace {

AnnotateReply jsonReply(const json& j, int status = 200) {
    return {status, "application/json", j.dump()};
}

AnnotateReply errorReply(int status, const std::string& message) {
    return jsonReply(json{{"error", message}}, status);
}

/** Thrown inside request handling for a 4xx reply. */
struct RequestError {
    int status;
    std::string message;
};

std::string randomToken() {
    std::random_device rd;
    static const char* hex = "0123456789abcdef";
    std::string t;
    for (int i = 0; i < 32; ++i)
        t += hex[rd() & 15];
    return t;
}

/** Comparison whose time does not depend on where the strings differ. */
bool sameSecret(const std::string& a, const std::string& b) {
    if (a.size() != b.size()) return false;
    unsigned char d = 0;
    for (size_t i = 0; i < a.size(); ++i)
        d |= (unsigned char)(a[i] ^ b[i]);
    return d == 0;
}

json point(const cv::Point2d& p) {
    return json::array({p.x, p.y});
}

/** The request body as JSON; 400 when it is not. */
json parseBody(const AnnotateRequest& r) {
    try {
        json j = json::parse(r.body);
        if (!j.is_object()) throw RequestError{400, "the request body must be a JSON object"};
        return j;
    } catch (const json::parse_error& e) {
        throw RequestError{400, std::string("the request body is not JSON: ") + e.what()};
    }
}

/** Reads an annotation given as the JSON form of doc/annotation_format.md with the library's
own reader (so that the page and the files agree). 400 with the reader's message when bad. */
FrameAnnotation annotationFromJson(const json& j) {
    if (!j.is_object()) throw RequestError{400, "annotation: expected a JSON object"};
    FrameAnnotation a;
    try {
        const std::string text = j.empty() ? std::string("{}") : j.dump();
        cv::FileStorage fs(
            text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_JSON);
        if (!fs.isOpened()) throw RequestError{400, "annotation: cannot parse"};
        if (j.empty()) return a;
        a.read(fs.root(), "annotation");
    } catch (const cv::Exception& e) {
        throw RequestError{400, "annotation: " + e.err};
    }
    return a;
}

/** The JSON form of an annotation, as the page edits it. */
json annotationToJson(const FrameAnnotation& a) {
    cv::FileStorage fs(
        "a.json", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_JSON);
    a.write(fs);
    return json::parse(fs.releaseAndGetString());
}

/** Drops what is still being drawn (groups with fewer than two segments, polygons with fewer
than three points, corners without points) and says so. */
json withoutUnfinished(json a, std::vector<std::string>& notes) {
    if (a.contains("lines") && a["lines"].is_array()) {
        json kept = json::array();
        for (const auto& g : a["lines"]) {
            const std::string name = g.value("name", std::string("group"));
            const size_t n =
                g.contains("segments") && g["segments"].is_array() ? g["segments"].size() : 0;
            if (n >= 2)
                kept.push_back(g);
            else
                notes.push_back("line group '" + name + "' has " + std::to_string(n) +
                                " segment(s): it needs two or more (left out)");
        }
        a["lines"] = kept;
        if (kept.empty()) a.erase("lines");
    }
    if (a.contains("lights") && a["lights"].is_array()) {
        json kept = json::array();
        int i = 0;
        for (const auto& l : a["lights"]) {
            const size_t n =
                l.contains("polygon") && l["polygon"].is_array() ? l["polygon"].size() : 0;
            if (n >= 3)
                kept.push_back(l);
            else
                notes.push_back("light " + std::to_string(i) + " has " + std::to_string(n) +
                                " corner(s): a polygon needs three or more (left out)");
            ++i;
        }
        a["lights"] = kept;
        if (kept.empty()) a.erase("lights");
    }
    if (a.contains("room") && a["room"].is_object()) {
        json& room = a["room"];
        for (const char* key : {"floor_edges", "ceiling_edges"})
            if (room.contains(key) && room[key].is_object()) {
                json kept = json::object();
                for (auto it = room[key].begin(); it != room[key].end(); ++it)
                    if (it.value().is_array() && !it.value().empty()) kept[it.key()] = it.value();
                room[key] = kept;
                if (kept.empty()) room.erase(key);
            }
        if (room.contains("wall_corners") && room["wall_corners"].is_array()) {
            json kept = json::array();
            for (const auto& c : room["wall_corners"])
                if (c.contains("points") && c["points"].is_array() && !c["points"].empty())
                    kept.push_back(c);
            room["wall_corners"] = kept;
            if (kept.empty()) room.erase("wall_corners");
        }
        if (room.contains("faces") && room["faces"].is_object() && room["faces"].empty())
            room.erase("faces");
        if (room.empty()) a.erase("room");
    }
    return a;
}

/** Whether two image segments cross (proper intersection). */
bool segmentsCross(cv::Point2d a, cv::Point2d b, cv::Point2d c, cv::Point2d d) {
    auto orient = [](cv::Point2d p, cv::Point2d q, cv::Point2d r) {
        return (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
    };
    const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a),
                 o4 = orient(c, d, b);
    return o1 * o2 < 0 && o3 * o4 < 0;
}

/** Whether the lens of @p cam (k1) maps the pinhole pixel @p p one-to-one into the clicked frame:
always for k1 ≥ 0; for barrel distortion (k1 < 0) inside the fold, |x|² < 1 / (3 |k1|). */
bool insideFold(const Camera& cam, const cv::Point2d& p) {
    if (cam.k1 >= 0) return true;
    const double x = (p.x - cam.K(0, 2)) / cam.K(0, 0), y = (p.y - cam.K(1, 2)) / cam.K(1, 1);
    return x * x + y * y < 1 / (3 * std::abs(cam.k1));
}

/** The straight pinhole segment a-b (undistorted pixels) as the lens of @p cam shows it in the
clicked frame: @p n pieces [x1, y1, x2, y2] between distorted points (pieces with an end beyond
the fold are left out). One piece, a-b itself, when k1 = 0. */
json distortedPieces(const Camera& cam, const cv::Point2d& a, const cv::Point2d& b, int n = 16) {
    json pieces = json::array();
    if (cam.k1 == 0) {
        pieces.push_back(json::array({a.x, a.y, b.x, b.y}));
        return pieces;
    }
    for (int i = 0; i < n; ++i) {
        const cv::Point2d p = a + (b - a) * (double(i) / n), q = a + (b - a) * (double(i + 1) / n);
        if (!insideFold(cam, p) || !insideFold(cam, q)) continue;
        const cv::Point2d dp = cam.distortPixel(p), dq = cam.distortPixel(q);
        pieces.push_back(json::array({dp.x, dp.y, dq.x, dq.y}));
    }
    return pieces;
}

/** The image line through a homogeneous point and a pixel, clipped to the image, or an empty
array when the point is at infinity in no usable way. */
json horizonLine(const Camera& cam) {
    // The horizon is the image of the plane at infinity's z = 0 line: l = K^-T R e_z.
    const cv::Matx33d Kinv = cam.K.inv();
    const cv::Vec3d n(cam.R(0, 2), cam.R(1, 2), cam.R(2, 2));
    const cv::Vec3d l = Kinv.t() * n;
    const double w = cam.image_size.width - 1.0, h = cam.image_size.height - 1.0;
    // Intersect with the image's left and right borders (x = 0, x = w) when not vertical.
    if (std::abs(l[1]) < 1e-12) return json::array();
    const double y0 = -(l[2]) / l[1], y1 = -(l[0] * w + l[2]) / l[1];
    (void)h;
    return json::array({0.0, y0, w, y1});
}

/** Residual (pixels) of a segment against a vanishing point: distance of its endpoints to the
line joining its midpoint and the point. */
double segmentResidual(const cv::Vec4d& s, const cv::Vec3d& vp) {
    const cv::Vec3d m((s[0] + s[2]) / 2, (s[1] + s[3]) / 2, 1);
    cv::Vec3d l = m.cross(vp);
    const double n = std::hypot(l[0], l[1]);
    if (n < 1e-12) return 0;
    return std::abs(l[0] * s[0] + l[1] * s[1] + l[2]) / n;
}

/** The intersection of the pair of segments that most others pass through (within 1 px),
ties broken by the smaller sum of residuals: a vanishing point that one wrong segment among
three or more consistent ones does not move. */
cv::Vec3d consensusVanishingPoint(const std::vector<cv::Vec4d>& segs) {
    cv::Vec3d best(0, 0, 0);
    int best_count = -1;
    double best_sum = 1e300;
    for (size_t i = 0; i < segs.size(); ++i)
        for (size_t j = i + 1; j < segs.size(); ++j) {
            const cv::Vec3d li = cv::Vec3d(segs[i][0], segs[i][1], 1)
                                     .cross(cv::Vec3d(segs[i][2], segs[i][3], 1)),
                            lj = cv::Vec3d(segs[j][0], segs[j][1], 1)
                                     .cross(cv::Vec3d(segs[j][2], segs[j][3], 1));
            cv::Vec3d v = li.cross(lj);
            const double n = cv::norm(v);
            if (n < 1e-12) continue;
            v /= n;
            int count = 0;
            double sum = 0;
            for (const auto& s : segs) {
                const double r = segmentResidual(s, v);
                count += r < 1.0;
                sum += std::min(r, 10.0);
            }
            if (count > best_count || (count == best_count && sum < best_sum)) {
                best = v;
                best_count = count;
                best_sum = sum;
            }
        }
    return best;
}

/** The twelve edges of the room box projected (clipped to the part in front of the camera); with
a lens distortion (cam.k1) each edge is a chain of short pieces as the lens shows it. */
json boxEdges(const Camera& cam, const Room& room) {
    json edges = json::array();
    const cv::Vec3d lo = room.min, hi = room.max;
    auto corner = [&](int i) {
        return cv::Vec3d(i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]);
    };
    for (int i = 0; i < 8; ++i)
        for (int bit : {1, 2, 4})
            if (!(i & bit)) {
                cv::Point2d a, b;
                if (projectSegment(cam, corner(i), corner(i | bit), a, b))
                    for (const auto& piece : distortedPieces(cam, a, b))
                        edges.push_back(piece);
            }
    return edges;
}

/** The object of the page's placement: `place` [u, v] (a frame pixel on the floor), `scale`
and `rotate_deg` (about world z), as placeOnFloor() puts it for `vbme insert --place`. */
SceneObject placedObject(const Scene& scene, const std::string& mesh, const json& placement) {
    if (!placement.is_object() || !placement.contains("place") || !placement["place"].is_array() ||
        placement["place"].size() != 2 || !placement["place"][0].is_number() ||
        !placement["place"][1].is_number())
        throw RequestError{400,
                           "placement: expected {\"place\": [u, v], \"scale\": s, "
                           "\"rotate_deg\": a}"};
    const double scale = placement.value("scale", 1.0);
    const double deg = placement.value("rotate_deg", 0.0);
    if (!(scale > 0) || scale > 100) throw RequestError{400, "placement: scale out of range"};
    SceneObject obj;
    obj.mesh = mesh;
    const double a = deg * CV_PI / 180, c = std::cos(a) * scale, s = std::sin(a) * scale;
    obj.world_from_object = cv::Matx44d(c, -s, 0, 0, s, c, 0, 0, 0, 0, scale, 0, 0, 0, 0, 1);
    const cv::Point2d px(placement["place"][0].get<double>(), placement["place"][1].get<double>());
    try {
        obj.world_from_object = placeOnFloor(scene, obj, px);
    } catch (const cv::Exception& e) {
        throw RequestError{422, "placement: " + e.err};
    }
    return obj;
}

}  // namespace

std::map<int, cv::Mat> loadPickerFrames(const std::string& video, int frame, int max_frames) {
    VideoReader reader(video);
    const int count = reader.frameCount();
    const int step = count > 0 ? std::max(1, (count + max_frames - 1) / max_frames) : 15;
    std::map<int, cv::Mat> frames;
    cv::Mat f;
    for (int i = 0;; ++i) {
        const bool wanted = i == frame || (i % step == 0 && (int)frames.size() < max_frames);
        if (!wanted && i > frame && (int)frames.size() >= max_frames) break;
        if (!reader.read(f)) break;
        if (wanted) frames[i] = f.clone();
    }
    if (!frames.count(frame))
        CV_Error(cv::Error::StsBadArg,
                 cv::format("%s: has no frame %d (frames from 0)", video.c_str(), frame));
    return frames;
}

AnnotateSession::AnnotateSession(AnnotateConfig config, std::map<int, cv::Mat> frames)
    : config_(std::move(config)), frames_(std::move(frames)), token_(randomToken()) {
    if (frames_.empty()) CV_Error(cv::Error::StsBadArg, "annotate: no frames");
    if (!frames_.count(config_.frame)) config_.frame = frames_.begin()->first;
}

std::string AnnotateSession::url() const {
    return "http://127.0.0.1:" + std::to_string(port_) + "/" + token_ + "/";
}

AnnotateReply AnnotateSession::handle(const AnnotateRequest& r) const {
    // DNS rebinding: a page served from another name that resolves to 127.0.0.1 sends its own
    // Host; cross-site requests carry a foreign Origin.
    const std::string port = std::to_string(port_);
    const auto host = r.headers.find("host");
    if (host == r.headers.end() ||
        (host->second != "127.0.0.1:" + port && host->second != "localhost:" + port))
        return errorReply(403, "forbidden: Host must be 127.0.0.1:" + port);
    const auto origin = r.headers.find("origin");
    if (origin != r.headers.end() && origin->second != "http://127.0.0.1:" + port &&
        origin->second != "http://localhost:" + port)
        return errorReply(403, "forbidden: foreign Origin '" + origin->second + "'");
    // The token is the first path component.
    const std::string& p = r.path;
    const size_t slash = p.find('/', 1);
    const std::string given =
        p.size() > 1 ? p.substr(1, slash == std::string::npos ? std::string::npos : slash - 1)
                     : std::string();
    if (!sameSecret(given, token_)) return errorReply(403, "forbidden: missing or wrong token");
    if (slash == std::string::npos)
        return {301, "text/plain", "/" + token_ + "/"};  // location given by the server
    if (r.body.size() > config_.max_body)
        return errorReply(413, cv::format("request body larger than %zu bytes", config_.max_body));
    try {
        return route(r, p.substr(slash + 1));
    } catch (const RequestError& e) {
        return errorReply(e.status, e.message);
    } catch (const cv::Exception& e) {
        return errorReply(500, e.err);
    } catch (const std::exception& e) {
        return errorReply(500, e.what());
    }
}

AnnotateReply AnnotateSession::route(const AnnotateRequest& r, const std::string& rest) const {
    const bool get = r.method == "GET" || r.method == "HEAD";
    if (rest.rfind("api/", 0) != 0) {
        if (!get) throw RequestError{405, "method not allowed"};
        const std::string name = rest.empty() ? "index.html" : rest;
        for (const auto& a : embeddedAssets())
            if (name == a.name)
                return {200, a.content_type, std::string((const char*)a.data, a.size)};
        throw RequestError{404, "not found: " + name};
    }
    const std::string api = rest.substr(4);
    if (api == "info" && get) return info();
    if (api == "frame" && get) return frame(r);
    if (api == "suggestions" && get) return suggestions(r);
    if (api == "calibrate" && r.method == "POST") return calibrate(r);
    if (api == "save" && r.method == "POST") return save(r);
    if (api == "preview" && r.method == "POST") return preview(r);
    if (api == "info" || api == "frame" || api == "suggestions" || api == "calibrate" ||
        api == "save" || api == "preview")
        throw RequestError{405, "method not allowed for api/" + api};
    throw RequestError{404, "no such API: " + api};
}

const cv::Mat& AnnotateSession::frameOf(const std::string& text) const {
    int i = config_.frame;
    if (!text.empty()) {
        char* end = nullptr;
        const long v = std::strtol(text.c_str(), &end, 10);
        if (*end || v < 0 || v > 1000000000)
            throw RequestError{400, "frame index '" + text + "' is not a non-negative integer"};
        i = (int)v;
    }
    const auto it = frames_.find(i);
    if (it == frames_.end())
        throw RequestError{404, cv::format("frame %d is not among the picker's frames", i)};
    return it->second;
}

AnnotateReply AnnotateSession::info() const {
    json frames = json::array();
    for (const auto& kv : frames_)
        frames.push_back(kv.first);
    const cv::Mat& f = frames_.at(config_.frame);
    json j{{"video", config_.video},   {"frame", config_.frame},
           {"frames", frames},         {"image_size", {f.cols, f.rows}},
           {"out", config_.out},       {"scene_out", config_.scene_out},
           {"object", config_.object}, {"annotation", nullptr}};
    if (!config_.annotation.empty() && std::filesystem::exists(config_.annotation))
        j["annotation"] = annotationToJson(FrameAnnotation::read(config_.annotation));
    return jsonReply(j);
}

AnnotateReply AnnotateSession::frame(const AnnotateRequest& r) const {
    const auto it = r.query.find("i");
    const cv::Mat& f = frameOf(it == r.query.end() ? std::string() : it->second);
    std::vector<uchar> buf;
    if (r.query.count("thumb")) {
        cv::Mat t;
        const double s = 160.0 / f.cols;
        cv::resize(f, t, cv::Size(), s, s, cv::INTER_AREA);
        cv::imencode(".jpg", t, buf, {cv::IMWRITE_JPEG_QUALITY, 85});
        return {200, "image/jpeg", std::string(buf.begin(), buf.end())};
    }
    cv::imencode(".png", f, buf);  // lossless: the user clicks on the real pixels
    return {200, "image/png", std::string(buf.begin(), buf.end())};
}

AnnotateReply AnnotateSession::suggestions(const AnnotateRequest& r) const {
    const auto it = r.query.find("i");
    const std::string text = it == r.query.end() ? std::string() : it->second;
    const cv::Mat& f = frameOf(text);
    const int index = text.empty() ? config_.frame : std::atoi(text.c_str());
    {
        std::lock_guard<std::mutex> lock(mutex_);
        const auto c = suggestion_cache_.find(index);
        if (c != suggestion_cache_.end()) return {200, "application/json", c->second};
    }
    auto cal = VanishingPointCalibrator::create();
    json j{{"segments", json::array()},
           {"warnings", json::array()},
           {"proposals", json::array()},
           {"selected", -1}};
    try {
        // Ranked Manhattan frames, all offered to the user (the page lists them and regroups
        // the segments by the one chosen). The first is what detect() returns; below the same
        // minimum confidence it is not preselected: the segments stay ungrouped until the user
        // chooses a proposal or draws the lines.
        const auto props = detectManhattanProposals(f, cal->params(), 3);
        const FrameCalibration& fc = props[0].calibration;
        const bool confident = fc.confidence >= cal->params().min_confidence;
        for (size_t i = 0; i < fc.segments.size(); ++i) {
            const cv::Vec4f& s = fc.segments[i];
            j["segments"].push_back(
                {{"s", {s[0], s[1], s[2], s[3]}}, {"axis", confident ? fc.labels[i] : -1}});
        }
        j["focal"] = fc.focal();
        j["confidence"] = fc.confidence;
        for (const auto& p : props)
            j["proposals"].push_back({{"focal", p.calibration.focal()},
                                      {"focal_rel_sigma", p.calibration.focal_rel_sigma},
                                      {"confidence", p.confidence},
                                      {"ambiguous", p.ambiguous},
                                      {"note", p.note},
                                      {"axes", p.calibration.labels}});
        if (confident)
            j["selected"] = 0;
        else
            j["warnings"].push_back(cv::format(
                "automatic detection is not confident (%.2f < %.2f): the segments are shown "
                "ungrouped; choose one of the proposals or draw the lines",
                fc.confidence, cal->params().min_confidence));
    } catch (const cv::Exception& e) {
        std::vector<cv::Vec4f> segs;
        cal->detectSegments(f, segs);
        for (const auto& s : segs)
            j["segments"].push_back({{"s", {s[0], s[1], s[2], s[3]}}, {"axis", -1}});
        j["warnings"].push_back("no vanishing points found automatically (" + e.err +
                                "): the segments are shown ungrouped");
    }
    const std::string body = j.dump();
    std::lock_guard<std::mutex> lock(mutex_);
    suggestion_cache_[index] = body;
    return {200, "application/json", body};
}

AnnotateReply AnnotateSession::calibrate(const AnnotateRequest& r) const {
    const json body = parseBody(r);
    const auto fi = body.find("frame");
    const cv::Mat& image = frameOf(fi == body.end()          ? std::string()
                                   : fi->is_number_integer() ? std::to_string(fi->get<long>())
                                                             : std::string("?"));
    if (!body.contains("annotation"))
        throw RequestError{400, "expected {\"annotation\": {...}, \"frame\": N}"};
    std::vector<std::string> warnings;
    const json cleaned = withoutUnfinished(body["annotation"], warnings);
    const FrameAnnotation ann = annotationFromJson(cleaned);

    json out{{"ok", false}, {"warnings", json::array()}, {"missing", json::array()}};
    json& missing = out["missing"];
    const cv::Size size = image.size();
    if (ann.image_size.area() > 0 && ann.image_size != size)
        throw RequestError{
            400, cv::format("annotation: image_size %dx%d but the frame is %dx%d",
                            ann.image_size.width, ann.image_size.height, size.width, size.height)};
    // Light polygons whose edges cross are clicked out of order.
    for (size_t i = 0; i < ann.lights.size(); ++i) {
        const auto& P = ann.lights[i].polygon;
        const size_t n = P.size();
        bool crossed = false;
        for (size_t a = 0; a < n && !crossed; ++a)
            for (size_t b = a + 2; b < n && !crossed; ++b) {
                if (a == 0 && b == n - 1) continue;
                crossed = segmentsCross(P[a], P[(a + 1) % n], P[b], P[(b + 1) % n]);
            }
        if (crossed)
            warnings.push_back(cv::format(
                "light %d: its polygon's edges cross (corners clicked out of order): click "
                "them in order around the light",
                (int)i));
    }
    if (ann.lines.size() < 2) {
        missing.push_back(
            cv::format("lines: %d of 2 line groups (two world directions, two or "
                       "more segments each)",
                       (int)ann.lines.size()));
    }
    const double height = ann.camera_height;
    if (height <= 0 && ann.room_height <= 0 && ann.room.faces.empty())
        missing.push_back(
            "scale: the camera height (or the room height with a ceiling edge, "
            "or a known face)");
    if (ann.room.empty())
        missing.push_back(
            "room: floor edges, wall corners, ceiling edges or "
            "known faces to locate the box");

    FrameCalibration fc;
    std::vector<LineGroup> lines = ann.lines;
    bool have_camera = false;
    if (ann.lines.size() >= 2 || (ann.lines.size() == 1 && false)) {
        VanishingPointCalibrator::Params vp;
        if (ann.focal > 0) vp.focal = ann.focal;
        if (ann.principal_point.x >= 0 && ann.principal_point.y >= 0)
            vp.principal_point = ann.principal_point;
        vp.principal_point_from_orthocenter = ann.principal_point_from_orthocenter;
        try {
            // With the annotation's k1 the clicks are undistorted as vbme calibrate does
            // (calibrateLinesWithK1): K, R, the vanishing points and rms_px are those of the
            // undistorted frame, `lines` the clicked segments undistorted at the focal found.
            fc = calibrateLinesWithK1(*VanishingPointCalibrator::create(vp), ann.lines, size,
                                      ann.k1, &lines);
            have_camera = true;
            // Two segments of a direction meet at any focal: with two such groups only, every
            // focal searched fits exactly and k1 does not tell it (a k1 = -0.2 lens: 3.6 % off).
            bool more_than_two = ann.lines.size() > 2;
            for (const LineGroup& g : ann.lines)
                more_than_two = more_than_two || g.segments.size() > 2;
            if (ann.k1 != 0 && !more_than_two && vp.focal <= 0)
                warnings.push_back(
                    "with the annotation's k1 two groups of two segments do not determine the "
                    "focal length: add a third segment to a group");
        } catch (const cv::Exception& e) {
            warnings.push_back(e.err);
        }
    }
    if (have_camera) {
        Camera cam = fc.camera();
        cam.k1 = fc.k1;
        // As vbme calibrate without a room: the given height, else the default one.
        placeCamera(cam, ann.camera_height > 0 ? ann.camera_height
                                               : FrameCalibrationOptions().default_camera_height);
        const double f = fc.focal();
        out["focal"] = f;
        out["fov_deg"] = {2 * std::atan2(size.width * 0.5, f) * 180 / CV_PI,
                          2 * std::atan2(size.height * 0.5, f) * 180 / CV_PI};
        out["principal_point"] = {cam.K(0, 2), cam.K(1, 2)};
        out["rms_px"] = fc.rms_px;
        out["k1"] = cam.k1;
        // The horizon: a straight line of the undistorted frame; with k1 also as the curve the
        // clicked frame shows (points), which the page draws.
        out["horizon"] = horizonLine(cam);
        if (cam.k1 != 0 && out["horizon"].size() == 4) {
            const json& hl = out["horizon"];
            const double w = size.width;
            const cv::Point2d a(hl[0].get<double>(), hl[1].get<double>()),
                b(hl[2].get<double>(), hl[3].get<double>());
            // beyond the frame's sides: barrel distortion pulls them in
            const cv::Point2d u = (b - a) * (1.0 / std::max(1.0, b.x - a.x));
            json curve = json::array();
            for (const auto& piece : distortedPieces(cam, a - u * w, b + u * w, 48)) {
                if (curve.empty()) curve.push_back({piece[0], piece[1]});
                curve.push_back({piece[2], piece[3]});
            }
            out["horizon_curve"] = curve;
        }
        json vps = json::array();
        for (int a = 0; a < 3; ++a) {
            const cv::Vec3d& v = fc.vanishing_points[a];
            json e{{"axis", a}, {"support", fc.support[a]}};
            if (std::abs(v[2]) > 1e-9) {
                // `point` in the clicked frame (the limit of the distorted images of the
                // direction's lines); with k1 also `point_undistorted`, and no `point` when the
                // lens's map folds before it (barrel distortion, far vanishing points).
                const cv::Point2d p(v[0] / v[2], v[1] / v[2]);
                if (cam.k1 != 0) e["point_undistorted"] = {p.x, p.y};
                if (insideFold(cam, p)) {
                    const cv::Point2d d = cam.distortPixel(p);
                    e["point"] = {d.x, d.y};
                }
            } else
                e["direction"] = {v[0], v[1]};
            vps.push_back(e);
        }
        out["vanishing_points"] = vps;
        // Residual of every segment against its axis's vanishing point, per group. An
        // outlier is far off compared with the typical (median) segment, so that one gross
        // error does not hide itself by inflating the threshold.
        // Groups of three or more segments are measured against their consensus vanishing
        // point (the intersection of the pair that most other segments agree with), so that
        // an error is not absorbed by the least-squares fit it spoils.
        // With k1 they are measured on the undistorted segments (pixels of the undistorted
        // frame), where the lines are straight.
        std::vector<cv::Vec3d> consensus(lines.size());
        for (size_t g = 0; g < lines.size(); ++g)
            consensus[g] = consensusVanishingPoint(lines[g].segments);
        json residuals = json::array();
        std::vector<double> all;
        size_t k = 0;
        for (size_t g = 0; g < ann.lines.size(); ++g) {
            json rg{{"name", ann.lines[g].name}, {"axis", -1}, {"residuals", json::array()}};
            for (size_t s = 0; s < ann.lines[g].segments.size(); ++s, ++k) {
                const int axis = k < fc.labels.size() ? fc.labels[k] : -1;
                rg["axis"] = axis;
                const auto& segs = lines[g].segments;
                double res = 0;
                if (segs.size() >= 3) {
                    res = segmentResidual(segs[s], consensus[g]);
                } else if (axis >= 0) {
                    res = segmentResidual(segs[s], fc.vanishing_points[axis]);
                }
                rg["residuals"].push_back(res);
                all.push_back(res);
            }
            residuals.push_back(rg);
        }
        std::vector<double> sorted = all;
        std::sort(sorted.begin(), sorted.end());
        const double median = sorted.empty() ? 0 : sorted[sorted.size() / 2];
        const double outlier_px = std::max(1.5, 4 * median);
        out["outlier_px"] = outlier_px;
        for (const auto& rg : residuals) {
            int s = 0;
            for (const auto& v : rg["residuals"]) {
                ++s;
                if (v.get<double>() > outlier_px)
                    warnings.push_back(cv::format(
                        "line group '%s', segment %d is %.1f px off its vanishing point (an "
                        "outlier: wrong group, or an end misplaced)",
                        rg["name"].get<std::string>().c_str(), s, v.get<double>()));
            }
        }
        out["groups"] = residuals;
        int axes_seen[3] = {0, 0, 0};
        for (const auto& g : residuals)
            if (g["axis"].get<int>() >= 0) axes_seen[g["axis"].get<int>()]++;
        for (int a = 0; a < 3; ++a)
            if (axes_seen[a] > 1)
                warnings.push_back(
                    cv::format("%d line groups were given the same world axis %c: "
                               "each group should be another direction",
                               axes_seen[a], "xyz"[a]));
        const double fmax = std::max(size.width, size.height);
        if (f < 0.3 * fmax || f > 6 * fmax)
            warnings.push_back(
                cv::format("focal %.0f px is implausible for a %dx%d frame: check "
                           "the line groups",
                           f, size.width, size.height));
        // Room and lights through the library's own driver.
        FrameCalibrationOptions opt;
        if (!ann.room.empty() || !ann.lights.empty()) {
            try {
                FrameAnnotation a = ann;
                const Scene scene = calibrateFrame(image, a, opt, nullptr);
                cam = scene.camera;
                if (scene.has_room) {
                    out["room"] = {
                        {"min", {scene.room.min[0], scene.room.min[1], scene.room.min[2]}},
                        {"max", {scene.room.max[0], scene.room.max[1], scene.room.max[2]}},
                        {"edges", boxEdges(cam, scene.room)}};
                    json lights = json::array();
                    for (const Light& L : scene.lights) {
                        json poly = json::array();
                        for (const cv::Vec3d& X : L.corners)
                            poly.push_back(point(cam.projectDistorted(X)));
                        lights.push_back(
                            {{"polygon", poly},
                             {"radiance", {L.radiance[0], L.radiance[1], L.radiance[2]}}});
                    }
                    out["lights"] = lights;
                }
            } catch (const cv::Exception& e) {
                const std::string& m = e.err;
                if (m.find("undetermined") != std::string::npos ||
                    m.find("camera height is unknown") != std::string::npos)
                    missing.push_back(m);
                else
                    warnings.push_back(m);
            }
        }
        if (ann.camera_height <= 0 && ann.room.empty())
            warnings.push_back("camera height unknown: 1.6 m assumed (give camera_height)");
        const cv::Vec3d C = cam.center();
        const cv::Vec3d v(cam.R(2, 0), cam.R(2, 1), cam.R(2, 2));
        out["camera"] = {
            {"center", {C[0], C[1], C[2]}},
            {"heading_deg", std::atan2(v[0], v[1]) * 180 / CV_PI},
            {"elevation_deg", std::asin(std::max(-1.0, std::min(1.0, v[2]))) * 180 / CV_PI}};
        out["ok"] = true;
    }
    out["complete"] = have_camera && out.contains("room") && missing.empty();
    for (const auto& w : warnings)
        out["warnings"].push_back(w);
    return jsonReply(out);
}

AnnotateReply AnnotateSession::save(const AnnotateRequest& r) const {
    const json body = parseBody(r);
    if (!body.contains("annotation"))
        throw RequestError{400, "expected {\"annotation\": {...}, \"frame\": N}"};
    const auto fi = body.find("frame");
    const cv::Mat& image = frameOf(fi == body.end()          ? std::string()
                                   : fi->is_number_integer() ? std::to_string(fi->get<long>())
                                                             : std::string("?"));
    // Unfinished items are refused, not silently dropped.
    std::vector<std::string> unfinished;
    withoutUnfinished(body["annotation"], unfinished);
    if (!unfinished.empty())
        throw RequestError{422, "not saved: " + unfinished.front() + "; finish or delete it first"};
    FrameAnnotation ann = annotationFromJson(body["annotation"]);
    if (ann.image_size.area() == 0) ann.image_size = image.size();
    json out{{"saved", json::array()}};
    std::lock_guard<std::mutex> lock(mutex_);
    ann.write(config_.out);
    out["saved"].push_back(config_.out);
    if (!config_.scene_out.empty()) {
        try {
            FrameCalibrationOptions opt;
            Scene scene = calibrateFrame(image, ann, opt, nullptr);
            if (!config_.object.empty() && body.contains("placement") &&
                !body["placement"].is_null()) {
                scene.objects.push_back(placedObject(scene, config_.object, body["placement"]));
                const json& p = body["placement"]["place"];
                out["place"] = p;
                out["insert_hint"] =
                    cv::format("vbme insert --scene %s --place %.1f,%.1f …",
                               config_.scene_out.c_str(), p[0].get<double>(), p[1].get<double>());
            }
            scene.write(config_.scene_out);
            out["saved"].push_back(config_.scene_out);
        } catch (const cv::Exception& e) {
            out["scene_error"] = "scene not written: " + e.err;
        }
    }
    std::printf("saved %s\n", config_.out.c_str());
    std::fflush(stdout);
    return jsonReply(out);
}

AnnotateReply AnnotateSession::preview(const AnnotateRequest& r) const {
    if (config_.object.empty())
        throw RequestError{404, "no object to preview: start vbme annotate with --object"};
    const json body = parseBody(r);
    if (!body.contains("annotation") || !body.contains("placement"))
        throw RequestError{400,
                           "expected {\"annotation\": {...}, \"placement\": {...}, "
                           "\"frame\": N, \"spp\": n}"};
    const auto fi = body.find("frame");
    const cv::Mat& image = frameOf(fi == body.end()          ? std::string()
                                   : fi->is_number_integer() ? std::to_string(fi->get<long>())
                                                             : std::string("?"));
    const int spp = body.value("spp", 1);
    if (spp < 1 || spp > 256) throw RequestError{400, "spp: expected 1 … 256"};
    std::vector<std::string> unfinished;
    const FrameAnnotation ann =
        annotationFromJson(withoutUnfinished(body["annotation"], unfinished));
    Scene scene;
    try {
        scene = calibrateFrame(image, ann, FrameCalibrationOptions(), nullptr);
    } catch (const cv::Exception& e) {
        throw RequestError{422, "no preview until the calibration succeeds: " + e.err};
    }
    if (!scene.has_room)
        throw RequestError{422, "no preview without the room box: annotate the room first"};
    scene.objects.push_back(placedObject(scene, config_.object, body["placement"]));
    // A differential render of the object into the frame (the room with its default grey
    // material and the annotated lights: a preview, not vbme insert's estimated albedo).
    DifferentialRenderer::Params p;
    p.render.spp = spp;
    p.render.seed = 1;
    p.render.max_depth = 4;
    p.coverage_supersampling = 4;
    // Rendered at half resolution (a preview: the noise of few samples dominates) and
    // enlarged to the frame.
    Camera half = scene.camera;
    half.image_size = cv::Size((image.cols + 1) / 2, (image.rows + 1) / 2);
    half.K(0, 0) *= 0.5;
    half.K(1, 1) *= 0.5;
    half.K(0, 2) = (half.K(0, 2) + 0.5) * 0.5 - 0.5;
    half.K(1, 2) = (half.K(1, 2) + 0.5) * 0.5 - 0.5;
    DifferentialImages layers;
    {
        const cv::Ptr<RenderScene> rs = RenderScene::create(scene);
        DifferentialRenderer::create(p)->render(*rs, half, layers);
    }
    for (cv::Mat* m : {&layers.obj, &layers.noobj, &layers.diff, &layers.mask})
        cv::resize(*m, *m, image.size(), 0, 0, cv::INTER_LINEAR);
    cv::Mat linear, encoded;
    CompositeParams cp;
    cp.response = scene.camera.response;
    cp.shadows = CompositeParams::SHADOWS_RATIO;  // as vbme insert composites
    compositeDifferential(image, layers, linear, cp);
    encodeComposite(linear, encoded, scene.camera.response, CV_8U);
    std::vector<uchar> buf;
    cv::imencode(".png", encoded, buf);
    return {200, "image/png", std::string(buf.begin(), buf.end())};
}

// ---------------------------------------------------------------------------------------------

struct AnnotateServer::Impl {
    std::shared_ptr<AnnotateSession> session;
    httplib::Server server;
};

AnnotateServer::AnnotateServer(std::shared_ptr<AnnotateSession> session, int port)
    : impl_(new Impl) {
    impl_->session = session;
    httplib::Server& s = impl_->server;
    s.set_payload_max_length(4 << 20);  // the HTTP layer's bound; the API's is max_body
    s.set_keep_alive_max_count(100);
    s.set_read_timeout(10, 0);
    auto handler = [this](const httplib::Request& req, httplib::Response& res) {
        AnnotateRequest r;
        r.method = req.method;
        r.path = req.path;
        for (const auto& kv : req.params)
            r.query[kv.first] = kv.second;
        for (const auto& kv : req.headers) {
            std::string k = kv.first;
            std::transform(k.begin(), k.end(), k.begin(), ::tolower);
            r.headers[k] = kv.second;
        }
        r.body = req.body;
        const AnnotateReply a = impl_->session->handle(r);
        res.status = a.status;
        if (a.status == 301) {
            res.set_header("Location", a.body);
            res.set_content(a.body, "text/plain");
        } else {
            res.set_content(a.body, a.content_type.c_str());
        }
        res.set_header("Cache-Control", "no-store");
        res.set_header("X-Content-Type-Options", "nosniff");
        res.set_header("Referrer-Policy", "no-referrer");
        res.set_header("Content-Security-Policy",
                       "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
                       "style-src 'self' 'unsafe-inline'");
    };
    s.Get(".*", handler);
    s.Post(".*", handler);
    s.Put(".*", handler);
    s.Delete(".*", handler);
    s.Options(".*", handler);
    if (port > 0) {
        if (!s.bind_to_port("127.0.0.1", port))
            CV_Error(cv::Error::StsError,
                     cv::format("annotate: cannot listen on 127.0.0.1:%d (in use?)", port));
        port_ = port;
    } else {
        port_ = s.bind_to_any_port("127.0.0.1");
        if (port_ <= 0) CV_Error(cv::Error::StsError, "annotate: cannot listen on 127.0.0.1");
    }
    session->setPort(port_);
}

AnnotateServer::~AnnotateServer() {
    stop();
}

void AnnotateServer::run() {
    impl_->server.listen_after_bind();
}

void AnnotateServer::stop() {
    if (impl_ && impl_->server.is_running()) impl_->server.stop();
}

}  // namespace vbme_app
