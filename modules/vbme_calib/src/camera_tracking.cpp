// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE).
#include "opencv2/vbme/calib/camera_tracking.hpp"

#include "camera_refine.hpp"
#include "opencv2/vbme/core/utility.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace fs = std::filesystem;

namespace cv {
namespace vbme {

double boxDepthAt(const Camera& cam, const Room& room, const Point2d& px, int* face) {
    const Vec3d c = cam.center();
    const Vec3d d_cam = cam.K.inv() * Vec3d(px.x, px.y, 1.0);  // z = 1: t is the depth
    const Vec3d d = cam.R.t() * d_cam;
    double best = std::numeric_limits<double>::infinity();
    int best_face = -1;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0) continue;
        const double t = ((d[a] > 0 ? room.max[a] : room.min[a]) - c[a]) / d[a];
        if (t > 0 && t < best) {
            best = t;
            best_face = a == 2   ? (d[a] > 0 ? 1 : 0)
                        : a == 0 ? (d[a] > 0 ? 3 : 2)
                                 : (d[a] > 0 ? 5 : 4);
        }
    }
    if (face) *face = best_face;
    return best;
}

static ScaleEstimate summarise(const std::vector<double>& r, const std::vector<double>& w,
                               int total) {
    ScaleEstimate s;
    s.total = total;
    s.used = (int)r.size();
    if (r.empty()) return s;
    double sw = 0, m = 0;
    for (size_t i = 0; i < r.size(); ++i)
        sw += w[i], m += w[i] * r[i];
    m /= sw;
    double var = 0;
    for (size_t i = 0; i < r.size(); ++i)
        var += w[i] * (r[i] - m) * (r[i] - m);
    s.scale = m;
    s.spread = std::sqrt(var / sw) / m;
    return s;
}

ScaleEstimate scaleEq53(const std::vector<double>& box, const std::vector<double>& sfm) {
    CV_Assert(box.size() == sfm.size());
    std::vector<double> r, w;
    for (size_t i = 0; i < box.size(); ++i)
        if (sfm[i] > 0 && std::isfinite(box[i])) r.push_back(box[i] / sfm[i]), w.push_back(1);
    return summarise(r, w, (int)box.size());
}

ScaleEstimate scaleRobust(const std::vector<double>& box, const std::vector<double>& sfm,
                          const std::vector<double>& errors, double tolerance) {
    CV_Assert(box.size() == sfm.size() && (errors.empty() || errors.size() == box.size()));
    std::vector<double> all;
    for (size_t i = 0; i < box.size(); ++i)
        if (sfm[i] > 0 && std::isfinite(box[i])) all.push_back(box[i] / sfm[i]);
    if (all.empty()) return summarise({}, {}, (int)box.size());
    std::vector<double> sorted = all;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double med = sorted[sorted.size() / 2];
    std::vector<double> r, w;
    for (size_t i = 0; i < box.size(); ++i) {
        if (!(sfm[i] > 0 && std::isfinite(box[i]))) continue;
        const double ratio = box[i] / sfm[i];
        if (std::abs(ratio - med) > tolerance * med) continue;
        r.push_back(ratio);
        w.push_back(errors.empty() ? 1.0 : 1.0 / (errors[i] + 0.5));
    }
    return summarise(r, w, (int)box.size());
}

double detail::medianFaceDistance(const std::vector<Vec3d>& points, const Room& room) {
    if (points.empty()) return 0;
    std::vector<double> d;
    d.reserve(points.size());
    for (const Vec3d& X : points) {
        double best = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a)
            best = std::min({best, std::abs(X[a] - room.min[a]), std::abs(X[a] - room.max[a])});
        d.push_back(best);
    }
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    return d[d.size() / 2];
}

void detail::judgeConfidence(const CameraTrackingOptions& o, bool joint_adjustment,
                             CameraTrackingReport& r) {
    std::string doubt;
    auto add = [&](const std::string& d) { doubt += (doubt.empty() ? "" : "; ") + d; };
    if (r.scale.spread > o.max_scale_spread)
        add(
            format("the frame-0 points' depths disagree with the room box (scale spread %.4f > "
                   "%.4f): COLMAP's model is likely distorted",
                   r.scale.spread, o.max_scale_spread));
    if (r.face_distance > o.max_face_distance)
        add(format("the track's points lie %.2f mm from the room's faces (median; limit %.2f mm)",
                   1000 * r.face_distance, 1000 * o.max_face_distance));
    if (joint_adjustment && !r.ba_applied)
        add("the joint adjustment came apart and was not applied");
    r.confident = doubt.empty();
    r.doubt = doubt;
}

namespace {

Vec4d slerp(Vec4d a, Vec4d b, double t) {
    double d = a.dot(b);
    if (d < 0) b = -b, d = -d;
    if (d > 0.9995) {
        Vec4d q = a + (b - a) * t;
        return q * (1.0 / norm(q));
    }
    const double th = std::acos(d), s = std::sin(th);
    return a * (std::sin((1 - t) * th) / s) + b * (std::sin(t * th) / s);
}

}  // namespace

int detail::interpolateMissing(CameraPath& path, const std::vector<bool>& have) {
    const size_t n = path.frames.size();
    CV_Assert(have.size() == n);
    if (std::find(have.begin(), have.end(), true) == have.end()) return 0;
    int interpolated = 0;
    for (size_t i = 0; i < n; ++i) {
        if (have[i]) continue;
        int a = (int)i - 1, b = (int)i + 1;
        while (a >= 0 && !have[a])
            --a;
        while (b < (int)n && !have[b])
            ++b;
        CameraPath::Frame& f = path.frames[i];
        f.source = CameraPath::INTERPOLATED;
        ++interpolated;
        if (a < 0 || b >= (int)n) {
            const CameraPath::Frame& nb = path.frames[a < 0 ? b : a];
            f.R = nb.R;
            f.t = nb.t;
            continue;
        }
        const double t = double((int)i - a) / (b - a);
        const CameraPath::Frame &fa = path.frames[a], &fb = path.frames[b];
        const Vec3d ca = -(fa.R.t() * fa.t), cb = -(fb.R.t() * fb.t);
        f.R = rotationFromQuaternion(
            slerp(quaternionFromRotation(fa.R), quaternionFromRotation(fb.R), t));
        f.t = -(f.R * (ca + (cb - ca) * t));
    }
    return interpolated;
}

CameraPath alignToRoom(const ColmapModel& model, const std::vector<std::string>& names,
                       const Scene& frame0, const CameraTrackingOptions& opt,
                       CameraTrackingReport* report) {
    return detail::alignToRoomWithPoints(model, names, frame0, opt, report, nullptr);
}

CameraPath detail::alignToRoomWithPoints(const ColmapModel& model,
                                         const std::vector<std::string>& names, const Scene& frame0,
                                         const CameraTrackingOptions& opt,
                                         CameraTrackingReport* report,
                                         std::map<long long, Vec3d>* world_points) {
    if (names.empty()) CV_Error(Error::StsBadArg, "alignToRoom: no frames");
    if (!frame0.has_room)
        CV_Error(Error::StsBadArg,
                 "alignToRoom: the frame-0 scene has no room box (Eq. 5.3 needs it)");
    const ColmapImage* im0 = model.imageByName(names[0]);
    if (!im0)
        CV_Error(Error::StsError,
                 "frame 0 ('" + names[0] +
                     "') was not registered by structure-from-motion, so the track "
                     "cannot be tied "
                     "to the annotated room");
    const Camera& cam0 = frame0.camera;

    // Eq. 5.3: frame-0 features with a 3D point.
    std::vector<double> box, sfm, err;
    for (size_t k = 0; k < im0->xys.size(); ++k) {
        const long long id = im0->point3d_ids[k];
        if (id < 0) continue;
        auto it = model.points.find(id);
        if (it == model.points.end()) continue;
        const Point2d px(im0->xys[k].x - 0.5,
                         im0->xys[k].y - 0.5);  // COLMAP → vbme pixel centres
        box.push_back(boxDepthAt(cam0, frame0.room, px));
        sfm.push_back((im0->R * it->second.xyz + im0->t)[2]);
        err.push_back(it->second.error);
    }
    const ScaleEstimate sc =
        opt.robust_scale ? scaleRobust(box, sfm, err, opt.scale_tolerance) : scaleEq53(box, sfm);
    if (sc.used < 3)
        CV_Error(Error::StsError, format("too few frame-0 features with a 3D point "
                                         "to fix the scale (%d of %d usable)",
                                         sc.used, sc.total));
    const double s = sc.scale;

    // world → model similarity from frame 0: M = R_0ᵀ R0w, c = R_0ᵀ (t0w − s
    // t_0); then cam_i_from_world = (R_i M, R_i c + s t_i).
    const Matx33d M = im0->R.t() * cam0.R;
    const Vec3d c = im0->R.t() * (cam0.t - s * im0->t);

    CameraPath path;
    path.K = cam0.K;
    path.image_size = frame0.image_size;
    path.frames.resize(names.size());
    std::vector<bool> have(names.size(), false);
    int registered = 0;
    for (size_t i = 0; i < names.size(); ++i) {
        path.frames[i].index = (int)i;
        const ColmapImage* im = model.imageByName(names[i]);
        if (!im) continue;
        path.frames[i].R = im->R * M;
        path.frames[i].t = im->R * c + s * im->t;
        path.frames[i].source = CameraPath::SFM;
        have[i] = true;
        ++registered;
    }
    detail::RefineSummary refined;
    std::map<long long, Vec3d> world;
    if (opt.refine)
        refined = detail::refineTrack(model, names, frame0, M, c, s, opt.plane_tolerance,
                                      opt.smooth_sigma, path, &world);
    else
        for (const auto& kv : model.points)
            world[kv.first] = M.t() * (s * kv.second.xyz - c);
    // Frames the model lacks: interpolate between registered neighbours, hold beyond the ends.
    const int interpolated = detail::interpolateMissing(path, have);
    if (report) {
        report->frames = (int)names.size();
        report->registered = registered;
        report->interpolated = interpolated;
        report->scale = sc;
        double se = 0;
        int n = 0;
        for (const auto& kv : model.points)
            se += kv.second.error * kv.second.error, ++n;
        // Both RMS figures over the same observations when refined (COLMAP's per-point errors
        // otherwise).
        report->reprojection_rms = opt.refine ? refined.rms_before : (n ? std::sqrt(se / n) : 0);
        report->refined_rms = opt.refine ? refined.rms_after : report->reprojection_rms;
        report->plane_points = refined.plane_points;
        std::vector<Vec3d> points;
        points.reserve(world.size());
        for (const auto& kv : world)
            points.push_back(kv.second);
        report->face_distance = detail::medianFaceDistance(points, frame0.room);
        detail::judgeConfidence(opt, false, *report);
    }
    if (world_points) *world_points = std::move(world);
    return path;
}

namespace {

// The model holding frame 0 is the one tied to the annotation (COLMAP may split a video into
// several); align it and fill the report.
CameraPath alignModelWithFrame0(const std::vector<ColmapModel>& models,
                                const std::vector<std::string>& names, const Scene& frame0,
                                const std::string& work_dir, const CameraTrackingOptions& opt,
                                const ScopedTimer& total, CameraTrackingReport* report) {
    const ColmapModel* chosen = nullptr;
    for (const auto& m : models)
        if (!chosen && m.imageByName(names.at(0))) chosen = &m;
    if (!chosen)
        CV_Error(Error::StsError, "COLMAP did not register frame 0 ('" + names[0] +
                                      "') in any of its " + std::to_string(models.size()) +
                                      " model(s); see " + work_dir + "/colmap.log");
    CameraTrackingReport r;
    CameraPath path = alignToRoom(*chosen, names, frame0, opt, &r);
    r.models = (int)models.size();
    if (!r.confident) std::printf("camera tracking: WARNING: %s\n", r.doubt.c_str());
    r.seconds = total.seconds();
    if (report) *report = r;
    return path;
}

}  // namespace

CameraPath trackCameraFrames(const std::string& frames_dir, const std::vector<std::string>& names,
                             const Scene& frame0, const std::string& work_dir,
                             const CameraTrackingOptions& opt, CameraTrackingReport* report) {
    const ScopedTimer total;
    const std::vector<ColmapModel> models =
        runColmapSfM(frames_dir, work_dir, frame0.camera.K, frame0.image_size, opt.colmap);
    return alignModelWithFrame0(models, names, frame0, work_dir, opt, total, report);
}

namespace {
// The video's frames must have the size the frame-0 annotation was made for.
void checkFrameSize(const VideoReader& reader, Size annotated) {
    if (reader.frameSize() != annotated)
        CV_Error(Error::StsBadArg, format("the annotation is for %dx%d images but the video's "
                                          "frames are %dx%d",
                                          annotated.width, annotated.height,
                                          reader.frameSize().width, reader.frameSize().height));
}
}  // namespace

CameraPath trackCameraVideo(const std::string& video, const Scene& frame0,
                            const std::string& work_dir, const CameraTrackingOptions& opt,
                            CameraTrackingReport* report) {
    if (opt.stride < 1) CV_Error(Error::StsBadArg, "stride must be at least 1");
    const ScopedTimer total;
    const double cpu0 = detail::processCpuSeconds();
    if (opt.method == CameraTrackingOptions::KEYFRAMES) {
        // Grey frames in memory (COLMAP's SIFT sees grey images too).
        VideoReader reader(video);
        checkFrameSize(reader, frame0.image_size);
        std::vector<Mat> gray;
        {
            Progress progress("decode frames", std::max(0, reader.frameCount()));
            Mat f;
            while (reader.read(f)) {
                // COLMAP's PINHOLE model and the PnP see the undistorted frames (Camera::k1)
                undistortImageK1(f, f, frame0.camera);
                Mat g;
                if (f.channels() == 1)
                    g = f.clone();
                else
                    cvtColor(f, g, f.channels() == 4 ? COLOR_BGRA2GRAY : COLOR_BGR2GRAY);
                if (g.depth() != CV_8U)
                    g.convertTo(g, CV_8U, g.depth() == CV_16U ? 1.0 / 257 : 1.0);
                gray.push_back(g);
                progress.tick();
            }
            progress.finish();
        }
        if (gray.empty()) CV_Error(Error::StsError, "'" + video + "' holds no frame");
        const double decode = total.seconds(), decode_cpu = detail::processCpuSeconds() - cpu0;
        CameraTrackingReport r;
        CameraPath path = trackCameraKeyframes(gray, frame0, work_dir, opt, &r);
        path.k1 = frame0.camera.k1;
        r.stage_seconds.insert(r.stage_seconds.begin(), {"decode", decode});
        r.stage_cpu_seconds.insert(r.stage_cpu_seconds.begin(), {"decode", decode_cpu});
        r.seconds += decode;
        if (report) *report = r;
        return path;
    }
    const fs::path work(work_dir), frames = work / "frames";
    std::error_code ec;
    fs::create_directories(frames, ec);
    if (ec) CV_Error(Error::StsError, "cannot create '" + frames.string() + "': " + ec.message());

    // 1. Frames (resumable: a marker records a complete extraction with its
    // stride).
    const fs::path marker = frames / "complete.txt";
    std::vector<std::string> names;
    int count = -1, stride = -1;
    {
        std::ifstream m(marker.string());
        double k1 = 0;  // files before lens distortion hold no k1
        if (!(m >> count >> stride) || stride != opt.stride) count = -1;
        if (count > 0 && !(m >> k1)) k1 = 0;
        if (k1 != frame0.camera.k1) count = -1;
    }
    if (count > 0) {
        for (int i = 0; i < count; ++i)
            names.push_back(format("frame_%05d.png", i));
    } else {
        fs::remove(marker, ec);
        fs::remove(work / "colmap_complete.txt", ec);  // COLMAP ran on other frames
        VideoReader reader(video);
        checkFrameSize(reader, frame0.image_size);
        Progress progress("extract frames", std::max(0, reader.frameCount()));
        Mat f;
        for (int i = 0; reader.read(f); ++i) {
            names.push_back(format("frame_%05d.png", i));
            if (i % opt.stride == 0) {
                undistortImageK1(f, f, frame0.camera);  // COLMAP's PINHOLE sees them undistorted
                imwriteAtomic((frames / names.back()).string(), f);
            }
            progress.tick();
        }
        progress.finish();
        detail::writeMarker(marker.string(),
                            format("%zu %d %.17g", names.size(), opt.stride, frame0.camera.k1));
    }
    if (names.empty()) CV_Error(Error::StsError, "'" + video + "' holds no frame");
    std::vector<std::pair<std::string, double>> stage_seconds = {{"extract frames",
                                                                  total.seconds()}},
                                                stage_cpu = {{"extract frames",
                                                              detail::processCpuSeconds() - cpu0}};

    // 2. COLMAP (resumable: reuse a completed run).
    std::vector<ColmapModel> models;
    const fs::path done = work / "colmap_complete.txt";
    if (fs::exists(done, ec)) {
        models = ColmapModel::readTextModels((work / "sparse_txt").string());
    }
    if (models.empty()) {
        std::printf("camera tracking: running COLMAP on %zu frames (log: %s)\n",
                    (names.size() + opt.stride - 1) / opt.stride,
                    (work / "colmap.log").string().c_str());
        std::fflush(stdout);
        models = runColmapSfM(frames.string(), work_dir, frame0.camera.K, frame0.image_size,
                              opt.colmap, &stage_seconds, &stage_cpu);
        detail::writeMarker(done.string(), std::to_string(models.size()));
    } else {
        stage_seconds.emplace_back("colmap (reused)", 0.0);
        stage_cpu.emplace_back("colmap (reused)", 0.0);
    }
    const ScopedTimer t_align;
    const double cpu_align = detail::processCpuSeconds();
    CameraTrackingReport r;
    CameraPath path = alignModelWithFrame0(models, names, frame0, work_dir, opt, total, &r);
    path.k1 = frame0.camera.k1;
    stage_seconds.emplace_back("align", t_align.seconds());
    stage_cpu.emplace_back("align", detail::processCpuSeconds() - cpu_align);
    r.stage_seconds = stage_seconds;
    r.stage_cpu_seconds = stage_cpu;
    r.seconds = total.seconds();
    if (report) *report = r;
    return path;
}

void drawRoomBox(InputOutputArray _image, const Camera& cam, const Room& room, const Scalar& colour,
                 const std::string& caption) {
    Mat img = _image.getMat();
    const Vec3d a = room.min, b = room.max;
    const Vec3d corners[8] = {{a[0], a[1], a[2]}, {b[0], a[1], a[2]}, {b[0], b[1], a[2]},
                              {a[0], b[1], a[2]}, {a[0], a[1], b[2]}, {b[0], a[1], b[2]},
                              {b[0], b[1], b[2]}, {a[0], b[1], b[2]}};
    const int edges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                              {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
    const int thick = std::max(1, img.cols / 400), shift = 4;
    for (const auto& e : edges) {
        Vec3d p = cam.camFromWorld(corners[e[0]]), q = cam.camFromWorld(corners[e[1]]);
        const double near_z = 0.01;
        if (p[2] < near_z && q[2] < near_z) continue;
        if (p[2] < near_z) p = p + (q - p) * ((near_z - p[2]) / (q[2] - p[2]));
        if (q[2] < near_z) q = q + (p - q) * ((near_z - q[2]) / (p[2] - q[2]));
        const Vec3d pp = cam.K * p, qq = cam.K * q;
        auto fixedPt = [&](const Vec3d& h) {
            const double lim = 1e5, x = std::max(-lim, std::min(lim, h[0] / h[2])),
                         y = std::max(-lim, std::min(lim, h[1] / h[2]));
            return Point(cvRound(x * (1 << shift)), cvRound(y * (1 << shift)));
        };
        if (cam.k1 == 0) {
            line(img, fixedPt(pp), fixedPt(qq), colour, thick, LINE_AA, shift);
            continue;
        }
        // bent as the lens (Camera::k1) shows it: 64 pieces, points past the fold of barrel
        // distortion (|x|² ≥ 1 / (3 |k1|)) left out
        std::vector<std::vector<Point>> runs(1);
        for (int k = 0; k <= 64; ++k) {
            const Vec3d X = p + (q - p) * (k / 64.0);
            const double r2 = (X[0] * X[0] + X[1] * X[1]) / (X[2] * X[2]);
            if (cam.k1 < 0 && r2 * 3 * -cam.k1 >= 0.99) {
                if (!runs.back().empty()) runs.emplace_back();
                continue;
            }
            const Vec3d h = cam.K * X;
            const Point2d d = cam.distortPixel(Point2d(h[0] / h[2], h[1] / h[2]));
            runs.back().push_back(fixedPt(Vec3d(d.x, d.y, 1)));
        }
        for (const auto& run : runs)
            if (run.size() > 1) polylines(img, run, false, colour, thick, LINE_AA, shift);
    }
    if (!caption.empty()) {
        const double scale = std::max(0.4, img.cols / 1280.0);
        putText(img, caption, Point(10, 10 + cvRound(22 * scale)), FONT_HERSHEY_SIMPLEX, scale,
                Scalar(0, 0, 0), thick + 2, LINE_AA);
        putText(img, caption, Point(10, 10 + cvRound(22 * scale)), FONT_HERSHEY_SIMPLEX, scale,
                Scalar(255, 255, 255), thick, LINE_AA);
    }
}

void writeBlenderScript(const std::string& script_path, const CameraPath& path, const Room& room,
                        double fps) {
    CV_Assert(path.image_size.area() > 0 && fps > 0);
    const int w = path.image_size.width, h = path.image_size.height, big = std::max(w, h);
    std::ostringstream py;
    py.precision(10);
    py << "# Camera track written by vbme (" << path.frames.size()
       << " frames). Run inside Blender:\n"
       << "#   blender --python " << fs::path(script_path).filename().string() << "\n"
       << "import bpy\nimport mathutils\n\n"
       << "scene = bpy.context.scene\n"
       << "scene.render.resolution_x = " << w << "\nscene.render.resolution_y = " << h << "\n"
       << "scene.render.resolution_percentage = 100\n"
       << "scene.render.fps = " << cvRound(fps)
       << "\nscene.render.fps_base = " << cvRound(fps) / fps << "\n"
       << "scene.frame_start = 1\nscene.frame_end = " << path.frames.size() << "\n\n"
       << "data = bpy.data.cameras.new('vbme_camera')\n"
       << "data.sensor_fit = 'HORIZONTAL'\ndata.sensor_width = 36.0\n"
       << "data.lens = " << path.K(0, 0) * 36.0 / w << "\n"
       << "data.shift_x = " << -(path.K(0, 2) - (w - 1) * 0.5) / big << "\n"
       << "data.shift_y = " << (path.K(1, 2) - (h - 1) * 0.5) / big << "\n"
       << "cam = bpy.data.objects.new('vbme_camera', data)\n"
       << "scene.collection.objects.link(cam)\nscene.camera = cam\ncam.rotation_mode = "
          "'QUATERNION'\n\n"
       << "# world_from_camera per frame, Blender camera axes (x right, y up, looking down -z)\n"
       << "frames = [\n";
    for (const auto& f : path.frames) {
        // OpenCV camera (y down, z forward) → Blender camera (y up, z backward): flip y and z.
        const Matx33d Rw = f.R.t() * Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1);
        const Vec3d C = -(f.R.t() * f.t);
        py << "    ((" << Rw(0, 0) << ", " << Rw(0, 1) << ", " << Rw(0, 2) << ", " << C[0] << "), ("
           << Rw(1, 0) << ", " << Rw(1, 1) << ", " << Rw(1, 2) << ", " << C[1] << "), (" << Rw(2, 0)
           << ", " << Rw(2, 1) << ", " << Rw(2, 2) << ", " << C[2] << "), (0, 0, 0, 1)),\n";
    }
    const Vec3d mid = (room.min + room.max) * 0.5, half = (room.max - room.min) * 0.5;
    py << "]\nfor i, m in enumerate(frames):\n"
       << "    cam.matrix_world = mathutils.Matrix(m)\n"
       << "    cam.keyframe_insert(data_path='location', frame=i + 1)\n"
       << "    cam.keyframe_insert(data_path='rotation_quaternion', frame=i + 1)\n\n"
       << "# The room box (metres, z up) as a wireframe cube.\n"
       << "bpy.ops.mesh.primitive_cube_add(location=(" << mid[0] << ", " << mid[1] << ", " << mid[2]
       << "))\n"
       << "room = bpy.context.active_object\nroom.name = 'vbme_room'\n"
       << "room.scale = (" << half[0] << ", " << half[1] << ", " << half[2] << ")\n"
       << "room.display_type = 'WIRE'\n";
    AtomicFile out(script_path);
    {
        std::ofstream f(out.tempPath());
        f << py.str();
        if (!f) CV_Error(Error::StsError, "cannot write '" + script_path + "'");
    }
    out.commit();
}

ColmapModel toColmapModel(const CameraPath& path) {
    ColmapModel m;
    ColmapCamera cam;
    cam.size = path.image_size;
    cam.params = {path.K(0, 0), path.K(1, 1), path.K(0, 2) + 0.5, path.K(1, 2) + 0.5};
    if (path.k1 != 0) {
        // the video's own (distorted) frames: COLMAP's radial k is vbme's k1 (the same
        // normalised coordinates x = K^-1 p); SIMPLE_RADIAL has one focal length
        if (path.K(0, 0) == path.K(1, 1)) {
            cam.model = "SIMPLE_RADIAL";
            cam.params = {path.K(0, 0), path.K(0, 2) + 0.5, path.K(1, 2) + 0.5, path.k1};
        } else {
            cam.model = "OPENCV";  // fx, fy, cx, cy, k1, k2, p1, p2
            cam.params.insert(cam.params.end(), {path.k1, 0.0, 0.0, 0.0});
        }
    }
    m.cameras[1] = cam;
    for (const auto& f : path.frames) {
        ColmapImage im;
        im.id = f.index + 1;
        im.R = f.R;
        im.t = f.t;
        im.name = format("frame_%05d.png", f.index);
        m.images[im.id] = im;
    }
    return m;
}

}  // namespace vbme
}  // namespace cv
