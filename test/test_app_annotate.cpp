// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Tests of `vbme annotate`'s server: its JSON API called directly (calibration round trip on a
// synthetic room with a known camera, warnings, missing constraints, save, bad requests) and
// its security checks (token, Host, Origin, sizes), also through a real HTTP connection.
#include <gtest/gtest.h>

#ifdef VBME_HAVE_ANNOTATE

#include <filesystem>
#include <fstream>
#include <thread>

#include <httplib.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room.hpp>

#include "annotate_server.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_app::AnnotateConfig;
using vbme_app::AnnotateReply;
using vbme_app::AnnotateRequest;
using vbme_app::AnnotateSession;
namespace fs = std::filesystem;

namespace {

/** f = 450 px, 1.45 m high, turned 20° left, looking 8° down (not the worked example's). */
Camera truthCamera() {
    Camera c = Camera::fromFocal(450, Size(640, 480));
    Matx33d yaw, pitch;
    Rodrigues(Vec3d(0, 0, -20 * CV_PI / 180), yaw);
    Rodrigues(Vec3d(8 * CV_PI / 180, 0, 0), pitch);
    c.R = pitch * Matx33d(1, 0, 0, 0, 0, -1, 0, 1, 0) * yaw;
    placeCamera(c, 1.45);
    return c;
}

Room truthRoom() {
    Room r;
    r.min = Vec3d(-2.0, -1.5, 0);
    r.max = Vec3d(2.4, 3.2, 2.6);
    return r;
}

// Clicks where the lens of c shows the point (c.project() when c.k1 = 0).
std::string pt(const Camera& c, double x, double y, double z) {
    const Point2d p = c.projectDistorted(Vec3d(x, y, z));
    return format("[%.4f, %.4f]", p.x, p.y);
}

std::string seg(const Camera& c, Vec3d a, Vec3d b) {
    const Point2d p = c.projectDistorted(a), q = c.projectDistorted(b);
    return format("[%.4f, %.4f, %.4f, %.4f]", p.x, p.y, q.x, q.y);
}

/** The annotation a person would click on the truth's picture, as the page sends it (through
the lens of c, saying its k1, when c.k1 != 0; @p say_k1 false leaves k1 out). */
std::string annotationJson(const Camera& c, bool with_room = true, bool say_k1 = true,
                           bool more_lines = false) {
    std::string j = "{\"camera_height\": 1.45, ";
    if (c.k1 != 0 && say_k1) j += format("\"k1\": %.17g, ", c.k1);
    j += "\"lines\": [";
    // more_lines: a third segment per group (with two segments
    // per direction any focal makes them meet: a lens's k1 leaves the focal undetermined)
    j += "{\"name\": \"floor_x\", \"axis\": \"horizontal\", \"segments\": [" +
         seg(c, {-1.8, 2.0, 0}, {-0.5, 2.0, 0}) + ", " + seg(c, {-1.8, 3.0, 0}, {-0.5, 3.0, 0}) +
         (more_lines ? ", " + seg(c, {-1.9, 2.5, 0}, {-0.3, 2.5, 0}) : std::string()) + "]},";
    j += "{\"name\": \"floor_y\", \"axis\": \"any\", \"segments\": [" +
         seg(c, {-1.5, 1.5, 0}, {-1.5, 3.0, 0}) + ", " + seg(c, {-0.5, 1.5, 0}, {-0.5, 3.0, 0}) +
         (more_lines ? ", " + seg(c, {-1.0, 1.6, 0}, {-1.0, 3.1, 0}) : std::string()) + "]}";
    j += "]";
    if (with_room) {
        j += ", \"room\": {\"floor_edges\": {\"back\": [" + pt(c, -1.2, 3.2, 0) + ", " +
             pt(c, 0.2, 3.2, 0) + "]}, \"wall_corners\": [{\"walls\": [\"back\", \"left\"], " +
             "\"points\": [" + pt(c, -2.0, 3.2, 1.0) + "]}], \"ceiling_edges\": {\"back\": [" +
             pt(c, -1.0, 3.2, 2.6) + "]}, \"faces\": {\"right\": 2.4, \"front\": -1.5}}";
        j += ", \"lights\": [{\"polygon\": [" + pt(c, -0.8, 3.2, 1.0) + ", " +
             pt(c, 0.2, 3.2, 1.0) + ", " + pt(c, 0.2, 3.2, 2.0) + ", " + pt(c, -0.8, 3.2, 2.0) +
             "]}]";
    }
    return j + "}";
}

struct Api {
    vbme_test::ScratchDir dir;
    Camera cam = truthCamera();
    std::shared_ptr<AnnotateSession> session;
    std::string out = dir / "annotation.yml";
    std::string scene = dir / "scene.yml";

    Api() {
        AnnotateConfig c;
        c.video = "synthetic";
        c.out = out;
        c.scene_out = scene;
        c.max_body = 64 * 1024;
        std::map<int, Mat> frames;
        frames[0] = drawSyntheticRoom(cam, truthRoom(), 0.5, 1.0, 3);
        session = std::make_shared<AnnotateSession>(c, frames);
        session->setPort(8123);
    }

    AnnotateReply call(const std::string& method, const std::string& path,
                       const std::string& body = "",
                       std::map<std::string, std::string> headers = {}) const {
        AnnotateRequest r;
        r.method = method;
        const size_t q = path.find('?');
        r.path = "/" + session->token() + "/" + path.substr(0, q);
        if (q != std::string::npos) {
            const std::string qs = path.substr(q + 1);
            size_t start = 0;
            while (start < qs.size()) {
                size_t amp = qs.find('&', start);
                if (amp == std::string::npos) amp = qs.size();
                const std::string kv = qs.substr(start, amp - start);
                const size_t eq = kv.find('=');
                r.query[kv.substr(0, eq)] = eq == std::string::npos ? "" : kv.substr(eq + 1);
                start = amp + 1;
            }
        }
        r.headers = {{"host", "127.0.0.1:8123"}};
        for (const auto& kv : headers)
            r.headers[kv.first] = kv.second;
        r.body = body;
        return session->handle(r);
    }

    /** A JSON reply parsed by OpenCV's reader (an independent JSON parser). */
    static FileStorage parse(const AnnotateReply& r) {
        return FileStorage(r.body,
                           FileStorage::READ | FileStorage::MEMORY | FileStorage::FORMAT_JSON);
    }
};

std::string calibrateBody(const std::string& annotation) {
    return "{\"frame\": 0, \"annotation\": " + annotation + "}";
}

}  // namespace

TEST(AppAnnotate, CalibrationRoundTripOnKnownCamera) {
    Api api;
    const AnnotateReply r =
        api.call("POST", "api/calibrate", calibrateBody(annotationJson(api.cam)));
    ASSERT_EQ(r.status, 200) << r.body;
    FileStorage fb = Api::parse(r);
    ASSERT_TRUE((int)fb["ok"]);
    EXPECT_TRUE((int)fb["complete"]) << r.body;
    const double f = (double)fb["focal"];
    std::printf("focal %.4f px (true 450)\n", f);
    EXPECT_NEAR(f, 450, 0.45);  // exact clicks: 0.1 %
    // Vanishing points: K R e_i of the truth.
    for (int a = 0; a < 2; ++a) {
        const FileNode vp = fb["vanishing_points"][a];
        ASSERT_FALSE(vp["point"].empty());
        const Vec3d t = api.cam.K * Vec3d(api.cam.R(0, a), api.cam.R(1, a), api.cam.R(2, a));
        const double ex = (double)vp["point"][0] - t[0] / t[2],
                     ey = (double)vp["point"][1] - t[1] / t[2];
        EXPECT_LT(std::hypot(ex, ey), 2.0) << "axis " << a;
    }
    // Horizon: through the vanishing points of horizontal directions, e.g. world (1, 1, 0).
    const FileNode hz = fb["horizon"];
    const Vec3d d = api.cam.K * (api.cam.R * Vec3d(1, 1, 0));
    const double hx = d[0] / d[2], hy = d[1] / d[2];
    const double x0 = hz[0], y0 = hz[1], x1 = hz[2], y1 = hz[3];
    const double dist = std::abs((y1 - y0) * hx - (x1 - x0) * hy + x1 * y0 - y1 * x0) /
                        std::hypot(x1 - x0, y1 - y0);
    EXPECT_LT(dist, 0.5) << "horizon misses a horizontal vanishing point";
    // The room box and its projected edges.
    const Room truth = truthRoom();
    for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR((double)fb["room"]["min"][k], truth.min[k], 0.01) << k;
        EXPECT_NEAR((double)fb["room"]["max"][k], truth.max[k], 0.01) << k;
    }
    EXPECT_GE((int)fb["room"]["edges"].size(), 6);
    ASSERT_EQ((int)fb["lights"].size(), 1);
    const Point2d c0 = api.cam.project(Vec3d(-0.8, 3.2, 1.0));
    bool corner_found = false;  // the light's corner projects back where it was clicked
    for (const auto& p : fb["lights"][0]["polygon"])
        corner_found = corner_found || std::hypot((double)p[0] - c0.x, (double)p[1] - c0.y) < 1.0;
    EXPECT_TRUE(corner_found);
    // Residuals of exact segments are tiny; no warnings.
    for (const auto& g : fb["groups"])
        for (const auto& v : g["residuals"])
            EXPECT_LT((double)v, 0.1);
    EXPECT_EQ(fb["warnings"].size(), 0u) << r.body;
}

// Clicks on a frame filmed through a barrel lens (k1 = -0.2; the truth's points moved where
// that lens shows them) with the annotation's k1: the live calibration (api/calibrate) finds
// the focal `vbme calibrate` (calibrateFrame) finds on the same annotation, and the truth's;
// the vanishing points, the horizon curve and the light it returns are where the lens shows
// them on the clicked frame. The same clicks with k1 left out: the focal is far off.
TEST(AppAnnotate, LiveCalibrationUsesTheAnnotationsK1) {
    Api api;
    Camera lens = api.cam;
    lens.k1 = -0.2;
    const std::string with_k1 = annotationJson(lens, true, true, true),
                      without_k1 = annotationJson(lens, true, false, true);
    const AnnotateReply r = api.call("POST", "api/calibrate", calibrateBody(with_k1));
    ASSERT_EQ(r.status, 200) << r.body;
    FileStorage fb = Api::parse(r);
    ASSERT_TRUE((int)fb["ok"]) << r.body;
    const double f_live = (double)fb["focal"];
    // vbme calibrate's focal on the same annotation
    FileStorage fa(with_k1, FileStorage::READ | FileStorage::MEMORY | FileStorage::FORMAT_JSON);
    FrameAnnotation ann;
    ann.read(fa.root(), "annotation");
    ASSERT_EQ(ann.k1, lens.k1);
    const Scene cli = calibrateFrame(drawSyntheticRoom(api.cam, truthRoom(), 0.5, 1.0, 3), ann,
                                     FrameCalibrationOptions());
    const double f_cli = cli.camera.K(0, 0);
    FileStorage fb0 = Api::parse(api.call("POST", "api/calibrate", calibrateBody(without_k1)));
    ASSERT_TRUE((int)fb0["ok"]);
    const double f_ignored = (double)fb0["focal"];
    std::printf(
        "clicked through a k1 -0.2 lens: live focal %.4f px, vbme calibrate %.4f px (true 450); "
        "k1 left out: %.4f px (%.2f %% off); rms %.4f px, %.4f px\n",
        f_live, f_cli, f_ignored, 100 * std::abs(f_ignored / 450 - 1), (double)fb["rms_px"],
        (double)fb0["rms_px"]);
    EXPECT_LT(std::abs(f_live / f_cli - 1), 1e-3);
    EXPECT_LT(std::abs(f_live / 450 - 1), 1e-3);
    EXPECT_GT(std::abs(f_ignored / 450 - 1), 100 * std::abs(f_live / 450 - 1));
    EXPECT_GT(std::abs(f_ignored / 450 - 1), 0.01);
    // two groups of two segments: any focal fits them exactly, the page says so
    FileStorage fb2 =
        Api::parse(api.call("POST", "api/calibrate", calibrateBody(annotationJson(lens))));
    ASSERT_TRUE((int)fb2["ok"]);
    std::printf("two groups of two segments with k1: live focal %.4f px (%.2f %% off)\n",
                (double)fb2["focal"], 100 * std::abs((double)fb2["focal"] / 450 - 1));
    bool warned = false;
    for (const auto& w : fb2["warnings"])
        warned = warned || ((std::string)w).find("do not determine the focal") != std::string::npos;
    EXPECT_TRUE(warned);
    for (const auto& w : fb["warnings"])
        EXPECT_EQ(((std::string)w).find("do not determine the focal"), std::string::npos);
    EXPECT_NEAR((double)fb["fov_deg"][0], 2 * std::atan2(320, f_cli) * 180 / CV_PI, 0.05);
    EXPECT_EQ((double)fb["k1"], lens.k1);
    // the vanishing points: undistorted, the truth's; on the clicked frame the lens's image of
    // the truth's, or none where the barrel lens folds before it
    int shown = 0;
    for (int a = 0; a < 2; ++a) {
        const FileNode vp = fb["vanishing_points"][a];
        ASSERT_FALSE(vp["point_undistorted"].empty()) << "axis " << a;
        const Vec3d t = api.cam.K * Vec3d(api.cam.R(0, a), api.cam.R(1, a), api.cam.R(2, a));
        const Point2d u(t[0] / t[2], t[1] / t[2]);
        EXPECT_LT(std::hypot((double)vp["point_undistorted"][0] - u.x,
                             (double)vp["point_undistorted"][1] - u.y),
                  2.0)
            << "axis " << a;
        const double r2 =
            std::pow((u.x - api.cam.K(0, 2)) / 450, 2) + std::pow((u.y - api.cam.K(1, 2)) / 450, 2);
        EXPECT_EQ(vp["point"].empty(), r2 >= 1 / (3 * 0.2)) << "axis " << a;
        if (vp["point"].empty()) continue;
        ++shown;
        const Point2d d = lens.distortPixel(u);
        EXPECT_LT(std::hypot((double)vp["point"][0] - d.x, (double)vp["point"][1] - d.y), 2.0)
            << "axis " << a;
    }
    EXPECT_GE(shown, 1);
    // the horizon curve: undistorted, on the truth's horizon line (through the vanishing points
    // of world (1, 1, 0) and (1, -1, 0))
    const Vec3d h1 = api.cam.K * (api.cam.R * Vec3d(1, 1, 0)),
                h2 = api.cam.K * (api.cam.R * Vec3d(1, -1, 0));
    const Vec3d hl = (h1 / h1[2]).cross(h2 / h2[2]);
    const FileNode curve = fb["horizon_curve"];
    ASSERT_GE((int)curve.size(), 10);
    double worst = 0;
    for (const auto& q : curve) {
        const Point2d u = lens.undistortPixel(Point2d((double)q[0], (double)q[1]));
        worst =
            std::max(worst, std::abs(hl[0] * u.x + hl[1] * u.y + hl[2]) / std::hypot(hl[0], hl[1]));
    }
    EXPECT_LT(worst, 0.5) << "horizon curve off the lens's horizon";
    // the room's edges bent by the lens: pieces whose ends, undistorted, lie on the truth's
    // box edges (pinhole lines through projected corners)
    const Room box = truthRoom();
    std::vector<Vec3d> edge_lines;
    for (int i = 0; i < 8; ++i)
        for (int bit : {1, 2, 4})
            if (!(i & bit)) {
                auto corner = [&](int k) {
                    return Vec3d(k & 1 ? box.max[0] : box.min[0], k & 2 ? box.max[1] : box.min[1],
                                 k & 4 ? box.max[2] : box.min[2]);
                };
                const Vec3d A = api.cam.R * corner(i) + api.cam.t,
                            B = api.cam.R * corner(i | bit) + api.cam.t;
                Vec3d l = (api.cam.K * A).cross(api.cam.K * B);
                edge_lines.push_back(l / std::hypot(l[0], l[1]));
            }
    const FileNode edges = fb["room"]["edges"];
    EXPECT_GT((int)edges.size(), 24);  // 16 pieces per visible edge
    double edge_off = 0;
    for (const auto& e : edges)
        for (int k = 0; k < 4; k += 2) {
            const Point2d u = lens.undistortPixel(Point2d((double)e[k], (double)e[k + 1]));
            double best = 1e9;
            for (const Vec3d& l : edge_lines)
                best = std::min(best, std::abs(l[0] * u.x + l[1] * u.y + l[2]));
            edge_off = std::max(edge_off, best);
        }
    std::printf("%d edge pieces, worst %.3f px off the truth's edges (undistorted)\n",
                (int)edges.size(), edge_off);
    EXPECT_LT(edge_off, 1.0);
    // the light's corner where it was clicked (the lens's image), the residuals of exact clicks
    ASSERT_EQ((int)fb["lights"].size(), 1);
    const Point2d c0 = lens.projectDistorted(Vec3d(-0.8, 3.2, 1.0));
    bool corner_found = false;
    for (const auto& p : fb["lights"][0]["polygon"])
        corner_found = corner_found || std::hypot((double)p[0] - c0.x, (double)p[1] - c0.y) < 1.0;
    EXPECT_TRUE(corner_found);
    for (const auto& g : fb["groups"])
        for (const auto& v : g["residuals"])
            EXPECT_LT((double)v, 0.1);
}

TEST(AppAnnotate, OutlierSegmentAndMissingConstraintsAreReported) {
    Api api;
    // Two more x segments, one with an end misplaced by 8 px.
    std::string ann = annotationJson(api.cam, false);
    ann.insert(ann.find("]},"), ", " + seg(api.cam, {-1.8, 2.25, 0}, {-0.5, 2.25, 0}));
    const Point2d a = api.cam.project(Vec3d(-1.8, 2.5, 0)),
                  b = api.cam.project(Vec3d(-0.5, 2.5, 0));
    const size_t at = ann.find("]},");  // end of floor_x's segments
    ann.insert(at, format(", [%.4f, %.4f, %.4f, %.4f]", a.x, a.y, b.x, b.y + 8));
    const AnnotateReply r = api.call("POST", "api/calibrate", calibrateBody(ann));
    ASSERT_EQ(r.status, 200) << r.body;
    FileStorage fb = Api::parse(r);
    std::string warnings, missing;
    for (const auto& w : fb["warnings"])
        warnings += (std::string)w + "\n";
    for (const auto& m : fb["missing"])
        missing += (std::string)m + "\n";
    EXPECT_NE(warnings.find("floor_x', segment 4"), std::string::npos) << warnings;
    const double res3 = fb["groups"][0]["residuals"][3];
    std::printf("misplaced end: residual %.2f px, others", res3);
    for (int g = 0; g < 2; ++g)
        for (int s = 0; s < (int)fb["groups"][g]["residuals"].size(); ++s)
            if (g || s != 3) {
                const double v = fb["groups"][g]["residuals"][s];
                std::printf(" %.2f", v);
                EXPECT_LT(v, (double)fb["outlier_px"]);
            }
    std::printf(" (outlier above %.2f px)\n", (double)fb["outlier_px"]);
    EXPECT_GT(res3, (double)fb["outlier_px"]);
    // A segment of the other direction in a group: the library's orthogonality check speaks.
    std::string mixed = annotationJson(api.cam, false);
    mixed.insert(mixed.find("]},"), ", " + seg(api.cam, {0.5, 1.5, 0}, {0.5, 3.0, 0}));
    FileStorage fbm = Api::parse(api.call("POST", "api/calibrate", calibrateBody(mixed)));
    EXPECT_FALSE((int)fbm["ok"]);
    EXPECT_NE(((std::string)fbm["warnings"][0]).find("one world direction"), std::string::npos);
    EXPECT_NE(missing.find("room"), std::string::npos) << missing;
    EXPECT_FALSE((int)fb["complete"]);

    // One group only, and one half-drawn: lines are missing and the unfinished one is named.
    const std::string one = "{\"lines\": [{\"name\": \"a\", \"segments\": [" +
                            seg(api.cam, {-1.8, 2.0, 0}, {-0.5, 2.0, 0}) + ", " +
                            seg(api.cam, {-1.8, 3.0, 0}, {-0.5, 3.0, 0}) +
                            "]}, {\"name\": \"b\", \"segments\": [" +
                            seg(api.cam, {-1.5, 1.5, 0}, {-1.5, 3.0, 0}) + "]}]}";
    FileStorage fb1 = Api::parse(api.call("POST", "api/calibrate", calibrateBody(one)));
    EXPECT_FALSE((int)fb1["ok"]);
    std::string all;
    for (const auto& m : fb1["missing"])
        all += (std::string)m + "\n";
    for (const auto& w : fb1["warnings"])
        all += (std::string)w + "\n";
    EXPECT_NE(all.find("1 of 2 line groups"), std::string::npos) << all;
    EXPECT_NE(all.find("'b' has 1 segment"), std::string::npos) << all;
    EXPECT_NE(all.find("camera height"), std::string::npos) << all;

    // Crossed light polygon.
    std::string crossed = annotationJson(api.cam);
    const std::string poly = pt(api.cam, -0.8, 3.2, 1.0) + ", " + pt(api.cam, 0.2, 3.2, 1.0) +
                             ", " + pt(api.cam, 0.2, 3.2, 2.0) + ", " + pt(api.cam, -0.8, 3.2, 2.0);
    const std::string bow = pt(api.cam, -0.8, 3.2, 1.0) + ", " + pt(api.cam, 0.2, 3.2, 2.0) + ", " +
                            pt(api.cam, 0.2, 3.2, 1.0) + ", " + pt(api.cam, -0.8, 3.2, 2.0);
    crossed.replace(crossed.find(poly), poly.size(), bow);
    FileStorage fb2 = Api::parse(api.call("POST", "api/calibrate", calibrateBody(crossed)));
    std::string w2;
    for (const auto& w : fb2["warnings"])
        w2 += (std::string)w + "\n";
    EXPECT_NE(w2.find("edges cross"), std::string::npos) << w2;
}

TEST(AppAnnotate, SaveWritesTheAnnotationFormatAndTheScene) {
    Api api;
    ASSERT_FALSE(fs::exists(api.out));
    // Unfinished work is refused and nothing is written.
    const std::string half = "{\"lines\": [{\"name\": \"a\", \"segments\": [[1, 2, 3, 4]]}]}";
    const AnnotateReply bad = api.call("POST", "api/save", calibrateBody(half));
    EXPECT_EQ(bad.status, 422) << bad.body;
    EXPECT_NE(bad.body.find("'a' has 1 segment"), std::string::npos) << bad.body;
    EXPECT_FALSE(fs::exists(api.out));

    const AnnotateReply r = api.call("POST", "api/save", calibrateBody(annotationJson(api.cam)));
    ASSERT_EQ(r.status, 200) << r.body;
    const FrameAnnotation a = FrameAnnotation::read(api.out);
    ASSERT_EQ(a.lines.size(), 2u);
    EXPECT_EQ(a.lines[0].name, "floor_x");
    EXPECT_EQ(a.lines[0].axis, AxisHint::HORIZONTAL);
    const Point2d p = api.cam.project(Vec3d(-1.8, 2.0, 0));
    EXPECT_NEAR(a.lines[0].segments[0][0], p.x, 1e-3);
    EXPECT_NEAR(a.lines[0].segments[0][1], p.y, 1e-3);
    EXPECT_EQ(a.image_size, Size(640, 480));
    EXPECT_EQ(a.camera_height, 1.45);
    EXPECT_EQ(a.room.faces.at("front"), -1.5);
    ASSERT_EQ(a.lights.size(), 1u);
    // The scene is vbme calibrate's.
    const Scene s = Scene::read(api.scene);
    EXPECT_NEAR(s.camera.K(0, 0), 450, 0.45);
    EXPECT_NEAR(s.room.max[1], 3.2, 0.01);
    // Reopening: api/info returns the saved annotation.
    AnnotateConfig c;
    c.video = "synthetic";
    c.out = api.out;
    c.annotation = api.out;
    std::map<int, Mat> frames;
    frames[0] = Mat(480, 640, CV_8UC3, Scalar::all(128));
    AnnotateSession reopened(c, frames);
    reopened.setPort(8123);
    AnnotateRequest req;
    req.method = "GET";
    req.path = "/" + reopened.token() + "/api/info";
    req.headers = {{"host", "localhost:8123"}};
    const AnnotateReply info = reopened.handle(req);
    ASSERT_EQ(info.status, 200);
    FileStorage fi = Api::parse(info);
    EXPECT_EQ((std::string)fi["annotation"]["lines"][1]["name"], "floor_y");
    EXPECT_EQ((int)fi["annotation"]["lines"][0]["segments"].size(), 2);
}

// The suggestions carry the ranked Manhattan-frame proposals (best first, with confidence,
// ambiguity and per-segment axes); the first is the frame of the top-level segments and focal.
TEST(AppAnnotate, SuggestionsCarryRankedProposals) {
    const Api api;
    const AnnotateReply r = api.call("GET", "api/suggestions?i=0");
    ASSERT_EQ(r.status, 200) << r.body;
    FileStorage fs = Api::parse(r);
    const FileNode segs = fs["segments"], props = fs["proposals"];
    ASSERT_TRUE(props.isSeq()) << r.body;
    ASSERT_GE(props.size(), 1u);
    const double f0 = (double)props[0]["focal"];
    EXPECT_DOUBLE_EQ(f0, (double)fs["focal"]);
    EXPECT_LT(std::abs(f0 / api.cam.K(0, 0) - 1), 0.02) << f0;
    EXPECT_GT((double)props[0]["focal_rel_sigma"], 0.0);
    double prev = 2;
    for (const auto& p : props) {
        const double c = (double)p["confidence"];
        EXPECT_LE(c, prev);
        prev = c;
        ASSERT_EQ(p["axes"].size(), segs.size());
    }
    for (size_t i = 0; i < segs.size(); ++i)
        EXPECT_EQ((int)props[0]["axes"][(int)i], (int)segs[(int)i]["axis"]);
    std::printf("suggestions: %d proposals, first focal %.1f px (truth %.1f), confidence %.2f\n",
                (int)props.size(), f0, api.cam.K(0, 0), (double)props[0]["confidence"]);
}

TEST(AppAnnotate, BadRequestsGet4xxWithAMessage) {
    Api api;
    auto expect = [&](const AnnotateReply& r, int status, const std::string& words) {
        EXPECT_EQ(r.status, status) << r.body;
        EXPECT_EQ(r.content_type, "application/json");
        EXPECT_NE(r.body.find(words), std::string::npos) << r.body;
    };
    expect(api.call("POST", "api/calibrate", "not json"), 400, "not JSON");
    expect(api.call("POST", "api/calibrate", "[1, 2]"), 400, "JSON object");
    expect(api.call("POST", "api/calibrate", "{\"frame\": 0}"), 400, "annotation");
    expect(api.call("POST", "api/calibrate", calibrateBody("{\"lines\": 5}")), 400, "lines");
    expect(api.call("POST", "api/calibrate",
                    calibrateBody("{\"camera_height\": \"tall\", \"lines\": []}")),
           400, "camera_height");
    expect(api.call("POST", "api/calibrate", "{\"frame\": 7, \"annotation\": {}}"), 404, "frame 7");
    expect(api.call("GET", "api/frame?i=-3"), 400, "frame index");
    expect(api.call("GET", "api/calibrate"), 405, "method");
    expect(api.call("GET", "api/nothing"), 404, "no such API");
    expect(api.call("GET", "../../etc/passwd"), 404, "not found");
    expect(api.call("POST", "api/calibrate", std::string(70 * 1024, ' ')), 413, "larger");
    // The frame itself.
    const AnnotateReply png = api.call("GET", "api/frame?i=0");
    EXPECT_EQ(png.status, 200);
    EXPECT_EQ(png.content_type, "image/png");
    const Mat decoded =
        imdecode(std::vector<uchar>(png.body.begin(), png.body.end()), IMREAD_COLOR);
    EXPECT_EQ(decoded.size(), Size(640, 480));
}

TEST(AppAnnotate, TokenHostAndOriginAreChecked) {
    Api api;
    AnnotateRequest r;
    r.method = "GET";
    r.headers = {{"host", "127.0.0.1:8123"}};
    r.path = "/" + api.session->token() + "/index.html";
    const AnnotateReply ok = api.session->handle(r);
    EXPECT_EQ(ok.status, 200);
    EXPECT_NE(ok.body.find("app.js"), std::string::npos);

    std::string wrong = api.session->token();
    wrong[5] = wrong[5] == 'a' ? 'b' : 'a';
    for (const std::string& p : {"/" + wrong + "/index.html", std::string("/index.html"),
                                 std::string("/"), "/" + wrong + "/api/info"}) {
        r.path = p;
        EXPECT_EQ(api.session->handle(r).status, 403) << p;
    }
    r.path = "/" + api.session->token() + "/api/info";
    EXPECT_EQ(api.session->handle(r).status, 200);
    r.headers["origin"] = "http://evil.example";
    const AnnotateReply foreign = api.session->handle(r);
    EXPECT_EQ(foreign.status, 403);
    EXPECT_NE(foreign.body.find("Origin"), std::string::npos);
    r.headers["origin"] = "http://127.0.0.1:8123";
    EXPECT_EQ(api.session->handle(r).status, 200);
    r.headers["host"] = "rebound.example:8123";  // DNS rebinding
    EXPECT_EQ(api.session->handle(r).status, 403);
    r.headers.erase("host");
    EXPECT_EQ(api.session->handle(r).status, 403);
}

TEST(AppAnnotate, RealServerOnLoopback) {
    Api api;
    vbme_app::AnnotateServer server(api.session, 0);
    ASSERT_GT(server.port(), 0);
    std::thread t([&] { server.run(); });
    httplib::Client cli("127.0.0.1", server.port());
    cli.set_connection_timeout(5);
    // Wait until it accepts.
    auto page = cli.Get(("/" + api.session->token() + "/").c_str());
    for (int i = 0; i < 100 && !page; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        page = cli.Get(("/" + api.session->token() + "/").c_str());
    }
    ASSERT_TRUE(page);
    EXPECT_EQ(page->status, 200);
    EXPECT_NE(page->get_header_value("Content-Type").find("text/html"), std::string::npos);
    EXPECT_FALSE(page->get_header_value("Content-Security-Policy").empty());
    auto noToken = cli.Get("/api/info");
    ASSERT_TRUE(noToken);
    EXPECT_EQ(noToken->status, 403);
    auto foreign = cli.Get(("/" + api.session->token() + "/api/info").c_str(),
                           {{"Origin", "http://evil.example"}});
    ASSERT_TRUE(foreign);
    EXPECT_EQ(foreign->status, 403);
    auto cal = cli.Post(("/" + api.session->token() + "/api/calibrate").c_str(),
                        calibrateBody(annotationJson(api.cam, false)), "application/json");
    ASSERT_TRUE(cal);
    EXPECT_EQ(cal->status, 200) << cal->body;
    server.stop();
    t.join();
}

TEST(AppAnnotate, ObjectPreviewIsADifferentialRenderIntoTheFrame) {
    vbme_test::ScratchDir dir;
    // A 320x240 version of the known camera, and a standing 0.4 m cube.
    Camera cam = truthCamera();
    cam.image_size = Size(320, 240);
    cam.K = Matx33d(225, 0, 159.5, 0, 225, 119.5, 0, 0, 1);
    {
        std::ofstream cube(dir / "cube.obj");
        for (int i = 0; i < 8; ++i)
            cube << "v " << (i & 1 ? 0.2 : -0.2) << " " << (i & 2 ? 0.2 : -0.2) << " "
                 << (i & 4 ? 0.4 : 0.0) << "\n";
        cube << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    }
    AnnotateConfig c;
    c.video = "synthetic";
    c.out = dir / "a.yml";
    c.object = dir / "cube.obj";
    std::map<int, Mat> frames;
    frames[0] = drawSyntheticRoom(cam, truthRoom(), 0.5, 1.0, 3);
    AnnotateSession s(c, frames);
    s.setPort(8123);
    AnnotateRequest r;
    r.method = "POST";
    r.path = "/" + s.token() + "/api/preview";
    r.headers = {{"host", "127.0.0.1:8123"}};
    const Point2d place = cam.project(Vec3d(-0.8, 2.2, 0));
    r.body = format(
        "{\"frame\": 0, \"spp\": 2, \"annotation\": %s, \"placement\": {\"place\": "
        "[%.3f, %.3f], \"scale\": 1, \"rotate_deg\": 30}}",
        annotationJson(cam).c_str(), place.x, place.y);
    const AnnotateReply rep = s.handle(r);
    ASSERT_EQ(rep.status, 200) << rep.body;
    ASSERT_EQ(rep.content_type, "image/png");
    Mat img = imdecode(std::vector<uchar>(rep.body.begin(), rep.body.end()), IMREAD_COLOR);
    ASSERT_EQ(img.size(), frames[0].size());
    Mat diff;
    absdiff(img, frames[0], diff);
    // The cube's middle: 0.2 m above the placed floor point; the far top-left corner.
    const Point2d mid = cam.project(Vec3d(-0.8, 2.2, 0.2));
    const double at_object = mean(diff(Rect(cvRound(mid.x) - 4, cvRound(mid.y) - 4, 8, 8)))[1];
    const double far_away = mean(diff(Rect(0, 0, 20, 20)))[1];
    std::printf("|preview - frame|: %.1f levels on the object, %.2f in the far corner\n", at_object,
                far_away);
    EXPECT_GT(at_object, 10.0);
    // Far from the object the frame changes by the Monte Carlo noise of the light the cube takes
    // from there, at 2 spp: measured 1.19 levels with ratio shadows (the preview composites as
    // vbme insert does; the preview's lights are the annotation's, far dimmer than the frame, so
    // the relative loss ratio shadows apply is larger than the absolute one), 0.10 additive.
    EXPECT_LT(far_away, 0.05 * at_object);
    // Not on the floor: 422 with the reason; without --object: 404.
    r.body = format("{\"annotation\": %s, \"placement\": {\"place\": [160, 5]}}",
                    annotationJson(cam).c_str());
    EXPECT_EQ(s.handle(r).status, 422);
    Api api;
    EXPECT_EQ(api.call("POST", "api/preview", "{}").status, 404);
}

TEST(AppAnnotate, CommandLineChecksBeforeServing) {
    const std::string exe = VBME_EXE;
    vbme_test::ScratchDir dir;
    fs::create_directories(dir / "frames");
    imwrite(dir / "frames/00000.png", Mat(48, 64, CV_8UC3, Scalar::all(90)));
    auto r = vbme_test::run(exe + " annotate --video " + (dir / "frames"));
    EXPECT_EQ(r.code, 2) << r.output;  // --out is required
    EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
    { std::ofstream(dir / "taken.yml") << "lines: []\n"; }
    r = vbme_test::run(exe + " annotate --video " + (dir / "frames") + " --out " +
                       (dir / "taken.yml"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
    r = vbme_test::run(exe + " annotate --video " + (dir / "frames") + " --frame 3 --out " +
                       (dir / "a.yml"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("frame 3"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "a.yml"));
}

#endif  // VBME_HAVE_ANNOTATE
