// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme insert: synthetic objects in a hand-held video of a room (thesis chapter 5).
#include "opencv2/vbme/pipeline/insertion.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/calib/camera_tracking.hpp"
#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/inpaint/exemplar.hpp"
#include "opencv2/vbme/render/albedo.hpp"
#include "opencv2/vbme/render/differential.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "opencv2/vbme/render/light_estimation.hpp"
#include "opencv2/vbme/render/room_texture.hpp"
#include "opencv2/vbme/render/scene.hpp"

namespace cv {
namespace vbme {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// ------------------------------------------------------------------ hashing (FNV-1a, 64 bit)

struct Hasher {
    uint64 h = 1469598103934665603ull;
    void bytes(const void* data, size_t n) {
        const unsigned char* p = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < n; ++i) {
            h ^= p[i];
            h *= 1099511628211ull;
        }
    }
    void str(const std::string& s) {
        const uint64 n = s.size();
        bytes(&n, sizeof n);
        bytes(s.data(), s.size());
    }
    void num(double v) { bytes(&v, sizeof v); }
    void num(int64 v) { bytes(&v, sizeof v); }
    void file(const std::string& path) {
        std::ifstream in(path, std::ios::binary);
        if (!in) {
            str("<missing " + path + ">");
            return;
        }
        std::vector<char> buf(1 << 16);
        while (in) {
            in.read(buf.data(), (std::streamsize)buf.size());
            bytes(buf.data(), (size_t)in.gcount());
        }
    }
    void mat(const Mat& m) {
        num((int64)m.rows);
        num((int64)m.cols);
        num((int64)m.type());
        for (int y = 0; y < m.rows; ++y)
            bytes(m.ptr(y), m.cols * m.elemSize());
    }
    std::string hex() const { return format("%016llx", (unsigned long long)h); }
};

// An advisory lock (flock) on a file of the work folder, released by the kernel when the
// process ends, even by kill -9. Several `vbme insert` on one work folder (a render farm's
// tasks, or the same command started twice by mistake) take the folder's lock to prepare and
// to assemble the video, and one lock per frame while rendering it. (On NFS, Linux emulates
// flock with POSIX locks, which the lock daemon shares between machines.)
class FileLock {
public:
    FileLock() = default;
    FileLock(const FileLock&) = delete;
    FileLock& operator=(const FileLock&) = delete;
    ~FileLock() { release(); }
    // Takes the lock; with @p wait false returns false at once when another process holds it.
    bool acquire(const std::string& path, bool wait) {
        release();
        fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd_ < 0)
            CV_Error(Error::StsError,
                     "cannot create the lock file '" + path + "': " + std::strerror(errno));
        int r;
        do {
            r = ::flock(fd_, LOCK_EX | (wait ? 0 : LOCK_NB));
        } while (r != 0 && errno == EINTR);
        if (r != 0) {
            const int err = errno;
            ::close(fd_);
            fd_ = -1;
            if (!wait && err == EWOULDBLOCK) return false;
            CV_Error(Error::StsError, "cannot lock '" + path + "': " + std::strerror(err));
        }
        path_ = path;
        return true;
    }
    void release() {
        if (fd_ < 0) return;
        ::flock(fd_, LOCK_UN);
        ::close(fd_);
        fd_ = -1;
    }

private:
    int fd_ = -1;
    std::string path_;
};

// Takes the work folder's lock, saying so when another process holds it.
void lockWork(FileLock& lock, const std::string& work, bool quiet) {
    const std::string path = (fs::path(work) / "work.lock").string();
    if (lock.acquire(path, false)) return;
    if (!quiet)
        std::fprintf(stderr, "vbme: another vbme insert holds '%s': waiting for it\n",
                     path.c_str());
    lock.acquire(path, true);
}

std::string frameFile(const std::string& work, int i) {
    return (fs::path(work) / "frames" / format("frame_%05d.png", i)).string();
}

std::string exrFile(const std::string& work, int i) {
    return (fs::path(work) / "exr" / format("frame_%05d.exr", i)).string();
}

Camera pathCamera(const CameraPath& path, int i, const Scene& scene) {
    Camera c = path.camera((size_t)i);
    c.response = scene.camera.response;
    c.image_size = scene.image_size;
    return c;
}

// Fills texels no frame saw with exemplar inpainting: the linear texture is normalised,
// encoded to 8 bits (sRGB curve), inpainted, and only the unseen texels are decoded back.
// Large textures are filled at a reduced size (longer side 256) and the fill upsampled: the
// unseen texels only light the object indirectly or show in its reflections, so their detail
// matters little, and exemplar filling of megapixel holes would dominate the preparation.
void fillUnseen(Mat& linear, const Mat& seen) {
    Mat hole;
    compare(seen, 0, hole, CMP_EQ);
    const int n_hole = countNonZero(hole);
    if (n_hole == 0) return;
    if (n_hole == (int)hole.total()) {  // nothing seen: mid-grey rather than noise
        linear.setTo(Scalar::all(0.18));
        return;
    }
    std::vector<float> vals;
    vals.reserve(linear.total() * 3);
    for (int y = 0; y < linear.rows; ++y) {
        const Vec3f* row = linear.ptr<Vec3f>(y);
        const uchar* s = seen.ptr<uchar>(y);
        for (int x = 0; x < linear.cols; ++x)
            if (s[x])
                for (int c = 0; c < 3; ++c)
                    vals.push_back(row[x][c]);
    }
    const size_t k = std::min(vals.size() - 1, (size_t)(0.995 * (double)vals.size()));
    std::nth_element(vals.begin(), vals.begin() + (long)k, vals.end());
    const float norm = std::max(vals[k], 1e-6f);
    const int side = std::max(linear.cols, linear.rows);
    const double f = side > 256 ? 256.0 / side : 1.0;
    Mat small = linear, small_hole = hole;
    if (f < 1) {
        const Size sz(std::max(1, cvRound(linear.cols * f)), std::max(1, cvRound(linear.rows * f)));
        resize(linear, small, sz, 0, 0, INTER_AREA);
        resize(hole, small_hole, sz, 0, 0, INTER_AREA);
        small_hole = small_hole > 0;  // any unseen source texel: fill
        if (countNonZero(small_hole) == (int)small_hole.total()) {
            linear.setTo(Scalar::all(0.18), hole);
            return;
        }
    }
    Mat scaled = small / norm, enc8;
    encode(scaled, enc8, Response::SRGB, CV_8U);
    ExemplarInpainter::Params ip;
    ip.patch_size = std::max(3, std::min(9, (std::min(small.rows, small.cols) / 16) | 1));
    Mat filled;
    ExemplarInpainter::create(ip)->inpaint(enc8, small_hole, filled);
    Mat lin;
    linearize(filled, lin, Response::SRGB);
    lin *= norm;
    if (f < 1) resize(lin, lin, linear.size(), 0, 0, INTER_LINEAR);
    lin.copyTo(linear, hole);
}

// The light estimate as stored in the prepared scene.
void writeEstimate(FileStorage& fs, const LightEstimate& e) {
    fs << "scale"
       << "[";
    for (const Vec3d& s : e.scale)
        fs << "[:" << s[0] << s[1] << s[2] << "]";
    fs << "]";
    fs << "gains"
       << "[:";
    for (double g : e.gains)
        fs << g;
    fs << "]";
    fs << "error_before" << e.error_before << "error_after" << e.error_after << "iterations"
       << e.iterations << "pixels_used" << e.pixels_used;
}

LightEstimate readEstimate(const FileNode& n) {
    LightEstimate e;
    for (const FileNode& s : n["scale"])
        e.scale.push_back(readVec3(s, "vbme_prepared.lights.scale"));
    for (const FileNode& g : n["gains"])
        e.gains.push_back((double)g);
    e.error_before = (double)n["error_before"];
    e.error_after = (double)n["error_after"];
    e.iterations = (int)n["iterations"];
    e.pixels_used = (int)n["pixels_used"];
    return e;
}

struct Prepared {
    Scene scene;
    LightEstimate lights;
};

// Reads <work>/prepared_scene.yml if it exists, is complete and was made from @p hash.
// Returns 0 if absent, 1 if reusable (fills @p out), −1 if made from something else.
int readPrepared(const std::string& path, const std::string& hash, Prepared& out,
                 std::string& found_hash) {
    if (!fs::exists(path)) return 0;
    FileStorage f;
    try {
        f.open(path, FileStorage::READ);
    } catch (const cv::Exception&) {
        return -1;
    }
    if (!f.isOpened()) return -1;
    const FileNode rec = f["vbme_prepared"];
    if (rec.empty() || !rec["hash"].isString()) return -1;
    found_hash = (std::string)rec["hash"];
    if (found_hash != hash) return -1;
    Scene s = Scene::read(path);
    for (const auto& kv : s.room.textures)
        if (!fs::exists(kv.second)) return 0;  // incomplete: prepare again
    out.scene = s;
    out.lights = readEstimate(rec["lights"]);
    return 1;
}

}  // namespace

// ------------------------------------------------------------------ object bounds / placement

void objectWorldBounds(const SceneObject& object, Vec3d& lo, Vec3d& hi) {
    Scene s;
    s.image_size = Size(1, 1);
    s.objects.push_back(object);
    Ptr<RenderScene> rs = RenderScene::create(s);
    Vec3f l, h;
    rs->bounds(l, h);
    lo = Vec3d(l[0], l[1], l[2]);
    hi = Vec3d(h[0], h[1], h[2]);
}

Matx44d placeOnFloor(const Scene& scene, const SceneObject& object, Point2d px) {
    if (!scene.has_room) CV_Error(Error::StsBadArg, "--place: the scene has no room (no floor)");
    const Camera& cam = scene.camera;
    const Size sz = scene.image_size;
    if (px.x < -0.5 || px.y < -0.5 || px.x > sz.width - 0.5 || px.y > sz.height - 0.5)
        CV_Error(Error::StsOutOfRange,
                 format("--place %g,%g: the pixel lies outside the %dx%d frame", px.x, px.y,
                        sz.width, sz.height));
    const Vec3d o = cam.center(), d = cam.rayDirection(px);
    const double floor_z = scene.room.min[2];
    const double tt = d[2] < -1e-12 ? (floor_z - o[2]) / d[2] : -1;
    if (!(tt > 0))
        CV_Error(Error::StsBadArg,
                 format("--place %g,%g: the frame-0 ray through this pixel does not meet the "
                        "floor (it looks %s); pick a pixel that shows the floor",
                        px.x, px.y, d[2] >= 0 ? "level or upwards" : "away from it"));
    const Vec3d P = o + tt * d;
    const Room& r = scene.room;
    if (P[0] < r.min[0] || P[0] > r.max[0] || P[1] < r.min[1] || P[1] > r.max[1])
        CV_Error(Error::StsBadArg,
                 format("--place %g,%g: the ray meets the floor plane at (%.3f, %.3f), outside "
                        "the room's floor [%.3f, %.3f] x [%.3f, %.3f]; pick a pixel that shows "
                        "the floor",
                        px.x, px.y, P[0], P[1], r.min[0], r.max[0], r.min[1], r.max[1]));
    // Bounds of the object with its rotation / scale but no translation.
    SceneObject tmp = object;
    tmp.world_from_object(0, 3) = tmp.world_from_object(1, 3) = tmp.world_from_object(2, 3) = 0;
    Vec3d lo, hi;
    objectWorldBounds(tmp, lo, hi);
    const Vec3d bottom((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]);
    const Vec3d T = P - bottom;
    Matx44d M = tmp.world_from_object;
    M(0, 3) = T[0];
    M(1, 3) = T[1];
    M(2, 3) = T[2];
    const Vec3d nlo = lo + T, nhi = hi + T;
    const double eps = 1e-6 * norm(r.max - r.min);
    for (int a = 0; a < 3; ++a)
        if (nlo[a] < r.min[a] - eps || nhi[a] > r.max[a] + eps)
            CV_Error(Error::StsBadArg,
                     format("--place %g,%g: the object placed at (%.3f, %.3f, %.3f) would reach "
                            "[%.3f, %.3f, %.3f] … [%.3f, %.3f, %.3f], outside the room "
                            "[%.3f, %.3f, %.3f] … [%.3f, %.3f, %.3f]; pick a pixel further "
                            "from the walls",
                            px.x, px.y, P[0], P[1], P[2], nlo[0], nlo[1], nlo[2], nhi[0], nhi[1],
                            nhi[2], r.min[0], r.min[1], r.min[2], r.max[0], r.max[1], r.max[2]));
    return M;
}

// ------------------------------------------------------------------ report

void InsertionReport::write(const std::string& path) const {
    AtomicFile out(path);
    {
        FileStorage f(out.tempPath(), FileStorage::WRITE);
        if (!f.isOpened()) CV_Error(Error::StsError, "cannot write the report '" + path + "'");
        f << "frames_total" << frames_total << "frames_rendered" << frames_rendered
          << "frames_skipped" << frames_skipped << "frames_busy" << frames_busy << "video_written"
          << (int)video_written;
        f << "missing_frames"
          << "[:";
        for (int m : missing)
            f << m;
        f << "]";
        f << "spp" << spp << "prepared_scene_reused" << (int)prepared_reused;
        f << "seconds"
          << "{";
        for (const auto& kv : seconds)
            f << kv.first << kv.second;
        f << "}";
        f << "seconds_per_frame" << seconds_per_frame;
        f << "white_scale" << white_scale;
        f << "lights"
          << "{";
        writeEstimate(f, lights);
        f << "}";
    }
    out.commit();
}

// ------------------------------------------------------------------ the pipeline

InsertionReport runInsertion(const InsertionParams& p) {
    InsertionReport rep;
    for (const char* k : {"tracking", "textures", "albedo", "lights", "render", "encode"})
        rep.seconds[k] = 0;

    // ---- options
    if (p.texture_mode != "accumulate" && p.texture_mode != "per-frame")
        CV_Error(Error::StsBadArg,
                 "texture_mode '" + p.texture_mode + "': expected accumulate or per-frame");
    if (p.albedo != "irradiance" && p.albedo != "retinex")
        CV_Error(Error::StsBadArg, "albedo '" + p.albedo + "': expected irradiance or retinex");
    if (p.lights != "nnls" && p.lights != "hill-climb" && p.lights != "none")
        CV_Error(Error::StsBadArg, "lights '" + p.lights + "': expected nnls, hill-climb or none");
    if (p.out.empty()) CV_Error(Error::StsBadArg, "no output video given (--out)");
    if (p.spp < 0) CV_Error(Error::StsBadArg, "spp must be positive");
    checkOverwrite(p.out, p.force);
    const std::string work =
        !p.work.empty()
            ? p.work
            : (fs::path(p.out).parent_path() / (fs::path(p.out).stem().string() + "_work"))
                  .string();
    rep.work = work;

    // ---- inputs
    Scene scene = Scene::read(p.scene);
    if (!scene.has_room)
        CV_Error(Error::StsBadArg,
                 "scene '" + p.scene + "': no room (insertion needs the room box)");
    if (!p.quiet)
        for (const std::string& w : scene.warnings())
            std::fprintf(stderr, "vbme: warning: %s: %s\n", p.scene.c_str(), w.c_str());
    if (scene.objects.empty())
        CV_Error(Error::StsBadArg,
                 "scene '" + p.scene + "': no objects: to insert (add an `objects:` entry)");
    int n = 0;
    Hasher video_hash;
    {
        // HDR input is converted to sRGB-encoded BT.709, which only the `srgb` response describes
        VideoReadOptions ro;
        if (scene.camera.response != Response::SRGB) {
            ro.hdr = HdrPolicy::Refuse;
            ro.purpose = "insert with camera.response " + toString(scene.camera.response) +
                         " (HDR input is converted to sRGB-encoded frames; use response srgb)";
        }
        VideoReader reader(p.video, ro);
        if (reader.frameSize() != scene.image_size)
            CV_Error(Error::StsBadSize,
                     format("the scene '%s' is for %dx%d images but the video '%s' has %dx%d "
                            "frames (annotate a frame of this video)",
                            p.scene.c_str(), scene.image_size.width, scene.image_size.height,
                            p.video.c_str(), reader.frameSize().width, reader.frameSize().height));
        // Count the frames and fingerprint their pixels (container counts may be approximate).
        Mat f;
        while (reader.read(f)) {
            video_hash.mat(f);
            ++n;
        }
        video_hash.num(reader.fps());
    }
    if (n == 0) CV_Error(Error::StsBadArg, "video '" + p.video + "' has no frames");
    rep.frames_total = n;
    const int first = p.first, end = p.end < 0 ? n : p.end;
    if (first < 0 || first >= end || end > n)
        CV_Error(Error::StsOutOfRange,
                 format("frames %d:%d: the video '%s' has %d frames (expected 0 <= A < B <= %d)",
                        first, end, p.video.c_str(), n, n));

    // ---- placement and the room check
    if (p.has_place)
        scene.objects[0].world_from_object = placeOnFloor(scene, scene.objects[0], p.place);
    {
        const Room& r = scene.room;
        const double eps = 1e-6 * norm(r.max - r.min);
        for (size_t i = 0; i < scene.objects.size(); ++i) {
            Vec3d lo, hi;
            objectWorldBounds(scene.objects[i], lo, hi);
            for (int a = 0; a < 3; ++a)
                if (lo[a] < r.min[a] - eps || hi[a] > r.max[a] + eps)
                    CV_Error(Error::StsBadArg,
                             format("objects[%d] ('%s') spans [%.3f, %.3f, %.3f] … [%.3f, %.3f, "
                                    "%.3f], outside the room [%.3f, %.3f, %.3f] … [%.3f, %.3f, "
                                    "%.3f] (check world_from_object, or use --place)",
                                    (int)i, scene.objects[i].mesh.c_str(), lo[0], lo[1], lo[2],
                                    hi[0], hi[1], hi[2], r.min[0], r.min[1], r.min[2], r.max[0],
                                    r.max[1], r.max[2]));
        }
    }

    // ---- from here to the first frame, one process at a time per work folder
    fs::create_directories(work);
    FileLock work_lock;
    lockWork(work_lock, work, p.quiet);

    // ---- camera path
    CameraPath path;
    std::string path_file = p.cameras;
    if (!p.cameras.empty()) {
        path = CameraPath::read(p.cameras);
    } else {
        path_file = (fs::path(work) / "cameras.yml").string();
        if (fs::exists(path_file)) {
            path = CameraPath::read(path_file);
        } else {
            const auto t0 = Clock::now();
            path = trackCameraVideo(p.video, scene, (fs::path(work) / "tracking").string());
            path.write(path_file);
            rep.seconds["tracking"] = secondsSince(t0);
        }
    }
    if ((int)path.frames.size() < n)
        CV_Error(Error::StsBadArg,
                 format("the camera path '%s' has %d frames but the video '%s' has %d (one pose "
                        "per video frame is needed)",
                        path_file.c_str(), (int)path.frames.size(), p.video.c_str(), n));
    if (path.image_size.area() > 0 && path.image_size != scene.image_size)
        CV_Error(Error::StsBadSize,
                 format("the camera path '%s' is for %dx%d images, the scene for %dx%d",
                        path_file.c_str(), path.image_size.width, path.image_size.height,
                        scene.image_size.width, scene.image_size.height));

    // ---- fingerprint of everything the prepared scene depends on
    Hasher h;
    h.str("vbme-insert-prepared-v1");
    h.str(VBME_VERSION);
    h.file(p.scene);
    for (const auto* list : {&scene.objects, &scene.proxies})
        for (const SceneObject& o : *list)
            h.file(o.mesh);
    for (const CameraPath::Frame& fr : path.frames) {
        h.bytes(fr.R.val, sizeof fr.R.val);
        h.bytes(fr.t.val, sizeof fr.t.val);
    }
    h.bytes(path.K.val, sizeof path.K.val);
    h.num((int64)video_hash.h);
    h.num((int64)n);
    h.str(p.texture_mode);
    h.str(p.albedo);
    h.str(p.lights);
    h.num((int64)p.per_frame_gain);
    h.num(p.white);
    h.num((int64)p.has_place);
    if (p.has_place) {
        h.num(p.place.x);
        h.num(p.place.y);
    }
    const std::string hash = h.hex();

    const int old_threads = getNumThreads();
    if (p.threads > 0) setNumThreads(p.threads);
    struct RestoreThreads {
        int n;
        ~RestoreThreads() { setNumThreads(n); }
    } restore_threads{old_threads};

    fs::create_directories(work);
    const std::string prepared_path = (fs::path(work) / "prepared_scene.yml").string();
    Prepared prep;
    std::string found_hash;
    const int state = readPrepared(prepared_path, hash, prep, found_hash);
    if (state < 0 && !p.force)
        CV_Error(Error::StsBadArg,
                 format("the work folder '%s' holds a prepared scene made from other inputs or "
                        "options (fingerprint %s, these inputs give %s): use another --work, "
                        "delete it, or pass --force to prepare it again",
                        work.c_str(), found_hash.empty() ? "unknown" : found_hash.c_str(),
                        hash.c_str()));
    if (state < 0) {  // --force: the old preparation and its frames go
        fs::remove(prepared_path);
        fs::remove_all(fs::path(work) / "frames");
        fs::remove_all(fs::path(work) / "exr");
    }
    if (state == 1) {
        rep.prepared_reused = true;
        rep.lights = prep.lights;
    } else {
        // ---- textures: the video's frames (every stride-th, at most ~24) linearised with the
        // camera response, projected onto the room's faces.
        auto t0 = Clock::now();
        const bool accumulate = p.texture_mode == "accumulate";
        RoomTextureParams tp;
        tp.accumulate = accumulate;
        Ptr<RoomTextureAccumulator> acc =
            RoomTextureAccumulator::create(scene.room, pathCamera(path, 0, scene), tp);
        const int stride = accumulate ? std::max(1, (n + 23) / 24) : n;
        std::vector<int> tex_frames;
        for (int i = 0; i < n; i += stride)
            tex_frames.push_back(i);
        // light estimation: up to four frames of them, spread over the video
        std::vector<int> light_frames;
        const int nl = std::min<int>(4, (int)tex_frames.size());
        for (int k = 0; k < nl; ++k)
            light_frames.push_back(tex_frames[(size_t)k * tex_frames.size() / nl]);
        std::vector<Mat> lframes;
        std::vector<Camera> lcams;
        {
            VideoReader reader(p.video);
            Progress progress("textures", (int64)tex_frames.size());
            Mat f, lin;
            const int last = std::max(tex_frames.back(), light_frames.back());
            for (int i = 0; i <= last && reader.read(f); ++i) {
                const bool want_tex = i % stride == 0;
                const bool want_light =
                    std::find(light_frames.begin(), light_frames.end(), i) != light_frames.end();
                if (!want_tex && !want_light) continue;
                if (want_tex) {
                    linearize(f, lin, scene.camera.response);
                    acc->add(lin, pathCamera(path, i, scene));
                    progress.tick();
                }
                if (want_light) {
                    lframes.push_back(f.clone());
                    lcams.push_back(pathCamera(path, i, scene));
                }
            }
        }
        std::map<std::string, Mat> radiance, seen;
        acc->textures(radiance, seen);
        const fs::path tex_dir = fs::path(work) / "textures";
        std::map<std::string, Mat> observed;  // before filling: the albedo stage wants L unknown
        for (auto& kv : radiance) {
            observed[kv.first] = kv.second.clone();
            fillUnseen(kv.second, seen[kv.first]);
            Mat enc;
            encode(kv.second, enc, scene.camera.response, CV_8U);
            imwriteAtomic((tex_dir / (kv.first + ".png")).string(), enc);
            imwriteAtomic((tex_dir / (kv.first + "_seen.png")).string(), seen[kv.first]);
        }
        rep.seconds["textures"] = secondsSince(t0);

        // ---- albedo
        t0 = Clock::now();
        Scene room_scene = scene;  // the real room: no objects, no textures yet
        room_scene.objects.clear();
        room_scene.room.textures.clear();
        std::map<std::string, Mat> albedo;
        if (p.albedo == "irradiance") {
            // The scale: scale all lights until the whitest surfaces (99th percentile of the
            // raw π·L/E, largest channel, seen unclipped texels) have albedo p.white. E is nearly
            // proportional to the lights' power (the indirect part, gathered from the observed
            // radiance, is not), so a few fixed-point steps converge.
            IrradianceAlbedoParams ap;
            for (int it = 0; it < 6; ++it) {
                std::map<std::string, Mat> irr;
                irradianceAlbedo(room_scene, observed, seen, albedo, ap, &irr);
                if (!(p.white > 0)) break;
                std::vector<float> raw;
                for (const auto& kv : observed) {
                    const Mat& L = kv.second;
                    const Mat& E = irr[kv.first];
                    const Mat& sn = seen[kv.first];
                    for (int y = 0; y < L.rows; ++y)
                        for (int x = 0; x < L.cols; ++x) {
                            if (!sn.at<uchar>(y, x)) continue;
                            const Vec3f l = L.at<Vec3f>(y, x), e = E.at<Vec3f>(y, x);
                            // clipped texels (the lights themselves, highlights) say
                            // nothing about albedo: their L is a lower bound
                            if (std::max({l[0], l[1], l[2]}) >= 0.95f) continue;
                            float m = 0;
                            for (int c = 0; c < 3; ++c)
                                if (e[c] > 0) m = std::max(m, float(CV_PI) * l[c] / e[c]);
                            raw.push_back(m);
                        }
                }
                if (raw.empty()) break;
                std::nth_element(raw.begin(), raw.begin() + raw.size() * 99 / 100, raw.end());
                const double q = raw[raw.size() * 99 / 100];
                if (!(q > 0)) break;
                const double k = q / p.white;  // lights × k brings the white point to p.white
                rep.white_scale *= k;
                if (std::abs(k - 1) < 0.01) break;
                LightEstimate uniform;
                uniform.scale.assign(room_scene.lights.size(), Vec3d(k, k, k));
                applyLightEstimate(room_scene, uniform);
            }
        } else {
            for (const auto& kv : radiance)
                retinexAlbedo(kv.second, albedo[kv.first]);
        }
        const fs::path alb_dir = fs::path(work) / "albedo";
        for (const auto& kv : albedo) {
            RenderImages img;
            img.color = kv.second;
            const std::string f = (alb_dir / (kv.first + ".exr")).string();
            writeExr(f, img, {{"vbme.version", VBME_VERSION}, {"vbme.prepared", hash}});
            room_scene.room.textures[kv.first] = fs::absolute(f).lexically_normal().string();
        }
        rep.seconds["albedo"] = secondsSince(t0);

        // ---- lights
        t0 = Clock::now();
        LightEstimate est;
        if (p.lights != "none") {
            LightEstimationParams lp;
            lp.method = p.lights == "nnls" ? LightEstimationParams::NNLS
                                           : LightEstimationParams::HILL_CLIMB;
            lp.per_frame_gain = p.per_frame_gain;
            est = estimateLights(room_scene, lframes, lcams, lp);
            applyLightEstimate(room_scene, est);
        } else {
            est.scale.assign(scene.lights.size(), Vec3d(1, 1, 1));
            est.gains.assign(lframes.size(), 1.0);
        }
        rep.lights = est;
        rep.seconds["lights"] = secondsSince(t0);

        // ---- the prepared scene: albedo textures, scaled lights, objects placed
        Scene prepared = room_scene;
        prepared.objects = scene.objects;
        const std::string tmp = (fs::path(work) / "prepared_scene.partial.yml").string();
        prepared.write(tmp);
        {
            FileStorage rec(".yml", FileStorage::WRITE | FileStorage::MEMORY);
            rec << "vbme_prepared"
                << "{";
            rec << "hash" << hash << "vbme_version" << VBME_VERSION;
            rec << "scene" << fs::absolute(p.scene).lexically_normal().string();
            rec << "video" << fs::absolute(p.video).lexically_normal().string();
            rec << "cameras" << fs::absolute(path_file).lexically_normal().string();
            rec << "frames" << n << "texture_mode" << p.texture_mode << "texture_frames"
                << (int)tex_frames.size() << "albedo" << p.albedo << "lights_method" << p.lights
                << "per_frame_gain" << (int)p.per_frame_gain << "white" << p.white << "white_scale"
                << rep.white_scale;
            if (p.has_place)
                rec << "place"
                    << "[:" << p.place.x << p.place.y << "]";
            rec << "lights"
                << "{";
            writeEstimate(rec, est);
            rec << "}";
            rec << "}";
            std::string body = rec.releaseAndGetString();
            const size_t pos = body.find("---");
            if (pos != std::string::npos) body = body.substr(body.find('\n', pos) + 1);
            std::ofstream app(tmp, std::ios::app);
            app << body;
            if (!app) CV_Error(Error::StsError, "cannot write '" + tmp + "'");
        }
        fs::rename(tmp, prepared_path);
        prep.scene = Scene::read(prepared_path);
        prep.lights = est;
    }

    // ---- per frame: differential render + composite
    Renderer::Params rp = Renderer::Params::fromScene(prep.scene.render);
    if (p.spp > 0) rp.spp = p.spp;
    rp.threads = p.threads;
    rp.seed = frameSeed(prep.scene.render.seed, 0, SEEDS_FIXED);
    rep.spp = rp.spp;
    rp.texture_cone = (float)p.texture_cone;
    if (p.adaptive_min_spp > 0) {  // spp stays the reported budget; a pixel takes ≤ 4 × spp
        rp.adaptive_min_spp = std::min(p.adaptive_min_spp, rp.spp);
        rp.adaptive_error = (float)p.adaptive_error;
        rp.adaptive_roulette = (float)p.adaptive_roulette;
        rp.spp *= 4;
    }
    {
        // the frames folder records the settings its frames were made with
        const std::string settings = (fs::path(work) / "frames" / "settings.yml").string();
        std::string want = format("%s spp=%d max_depth=%d seed=%llu", hash.c_str(), rep.spp,
                                  rp.max_depth, (unsigned long long)rp.seed);
        if (rp.adaptive_min_spp > 0 || rp.texture_cone > 0)
            want += format(" adaptive=%d,%g,%g texture_cone=%g", rp.adaptive_min_spp,
                           rp.adaptive_error, rp.adaptive_roulette, rp.texture_cone);
        if (fs::exists(settings)) {
            FileStorage f(settings, FileStorage::READ);
            const std::string have = f.isOpened() ? (std::string)f["made_with"] : std::string();
            if (have != want) {
                if (!p.force)
                    CV_Error(Error::StsBadArg,
                             "the frames in '" + (fs::path(work) / "frames").string() +
                                 "' were made with other settings (" + have + "; now " + want +
                                 "): use another --work, or --force to render them again");
                fs::remove_all(fs::path(work) / "frames");
                fs::remove_all(fs::path(work) / "exr");
            }
        }
        if (!fs::exists(settings)) {
            AtomicFile af(settings);
            {
                FileStorage f(af.tempPath(), FileStorage::WRITE);
                f << "made_with" << want;
            }
            af.commit();
        }
    }

    if (p.prepare_only) {
        rep.write((fs::path(work) / "report.yml").string());
        return rep;
    }
    work_lock.release();

    DifferentialRenderer::Params dp;
    dp.render = rp;
    Ptr<DifferentialRenderer> renderer = DifferentialRenderer::create(dp);
    Ptr<RenderScene> rscene;
    CompositeParams cp;
    cp.response = prep.scene.camera.response;
    {
        int todo = 0;
        for (int i = first; i < end; ++i)
            if (!fs::exists(frameFile(work, i))) ++todo;
        VideoReader reader(p.video);
        Progress progress("insert", todo);
        Mat f, linear, enc;
        double render_seconds = 0;
        for (int i = 0; i < end && reader.read(f); ++i) {
            if (i < first) continue;
            const std::string out_file = frameFile(work, i);
            if (fs::exists(out_file)) {
                ++rep.frames_skipped;
                continue;
            }
            // claim the frame: another process rendering it holds its lock (skip it); a
            // frame finished while we looked is there once we hold the lock
            FileLock frame_lock;
            const std::string lock_file = out_file + ".lock";
            if (!frame_lock.acquire(lock_file, false)) {
                ++rep.frames_busy;
                continue;
            }
            if (fs::exists(out_file)) {
                ++rep.frames_skipped;
                continue;
            }
            const auto t0 = Clock::now();
            if (!rscene) rscene = RenderScene::create(prep.scene);
            const Camera cam = pathCamera(path, i, prep.scene);
            DifferentialImages im;
            renderer->render(*rscene, cam, im);
            compositeDifferential(f, im.obj, im.diff, im.mask, linear, cp);
            encodeComposite(linear, enc, cp.response, f.depth());
            if (p.keep_exr) {
                const std::map<std::string, std::string> attr = {
                    {"vbme.version", VBME_VERSION},
                    {"vbme.commandLine", p.command_line},
                    {"vbme.seed", std::to_string(rp.seed)},
                    {"vbme.spp", std::to_string(rep.spp)},
                    {"vbme.maxDepth", std::to_string(rp.max_depth)},
                    {"vbme.frame", std::to_string(i)},
                    {"vbme.scene", p.scene},
                    {"vbme.video", p.video},
                    {"vbme.prepared", hash},
                    {"vbme.response", toString(cp.response)},
                    {"vbme.sampling", rp.adaptive_min_spp > 0
                                          ? format("correlated, adaptive %d..%d spp, error %g, "
                                                   "roulette %g",
                                                   rp.adaptive_min_spp, rp.spp, rp.adaptive_error,
                                                   rp.adaptive_roulette)
                                          : std::string("correlated")},
                    {"vbme.textureCone", format("%g", rp.texture_cone)}};
                writeDifferentialExr(exrFile(work, i), im, linear, attr);
            }
            imwriteAtomic(out_file, enc);  // last: its presence means the frame is done
            std::error_code ec;
            fs::remove(lock_file, ec);
            frame_lock.release();
            render_seconds += secondsSince(t0);
            ++rep.frames_rendered;
            progress.tick();
        }
        progress.finish();
        rep.seconds["render"] = render_seconds;
        rep.seconds_per_frame = rep.frames_rendered ? render_seconds / rep.frames_rendered : 0;
    }

    // ---- the output video, when every frame is there (one process assembles it)
    lockWork(work_lock, work, p.quiet);
    for (int i = 0; i < n; ++i)
        if (!fs::exists(frameFile(work, i))) rep.missing.push_back(i);
    if (rep.missing.empty() && !p.force && fs::exists(p.out)) {
        rep.video_written = true;  // made meanwhile by another process on this work folder
    } else if (rep.missing.empty()) {
        const auto t0 = Clock::now();
        // the input's timestamps, colour tags and audio are carried by the sink. A video file
        // is written under a temporary name of ours, read back, then renamed: a short write (a
        // full disk) the encoder did not report leaves no partial video under the output name
        const bool pattern = p.out.find('%') != std::string::npos;
        std::unique_ptr<AtomicFile> vout;
        if (!pattern) vout.reset(new AtomicFile(p.out));
        const std::string target = vout ? vout->tempPath() : p.out;
        VideoReader reader(p.video);
        VideoSink sink(target, reader.fps(), scene.image_size,
                       sinkOptionsFrom(reader, p.out, p.encode));
        Progress progress("encode", n);
        double t = -1;
        for (int i = 0; i < n; ++i) {
            t = reader.read(noArray()) ? reader.timestamp() : t + 1.0 / reader.fps();
            sink.write(imreadChecked(frameFile(work, i), IMREAD_COLOR), t);
            progress.tick();
        }
        progress.finish();
        sink.close();
        if (vout) {
            int readable = 0;
            try {
                VideoReader check(target);
                while (check.read(noArray()))
                    ++readable;
            } catch (const cv::Exception&) {
            }
            if (readable < n) {
                std::error_code ec;
                fs::remove(target, ec);
                CV_Error(Error::StsError,
                         format("the video '%s' came out incomplete (%d of %d frames readable; "
                                "disk full?): not written; the frames are kept in '%s', run the "
                                "command again to write it",
                                p.out.c_str(), readable, n, (fs::path(work) / "frames").c_str()));
            }
            vout->commit();
        }
        rep.video_written = true;
        rep.seconds["encode"] = secondsSince(t0);
    }
    rep.write((fs::path(work) / "report.yml").string());
    return rep;
}

}  // namespace vbme
}  // namespace cv
