// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The material-editing pipeline (thesis chapter 4): track → shape → inpaint → environment →
// lighting fit → re-render → composite, streamed frame by frame.
#include "opencv2/vbme/pipeline/material_edit.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <future>
#include <memory>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/inpaint.hpp"
#include "opencv2/vbme/render/environment.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "opencv2/vbme/render/relighting.hpp"
#include "opencv2/vbme/track.hpp"

namespace cv {
namespace vbme {

namespace fs = std::filesystem;

Material parseMaterialSpec(const std::string& spec) {
    std::string list;
    for (const auto& n : Material::presetNames())
        list += (list.empty() ? "" : ", ") + n;
    if (spec.empty())
        CV_Error(Error::StsBadArg,
                 "no material given (expected a preset: " + list + "; or a material file)");
    const std::string ext = fs::path(spec).extension().string();
    std::error_code ec;
    const bool looks_file = ext == ".yml" || ext == ".yaml" || ext == ".json" || ext == ".xml" ||
                            spec.find('/') != std::string::npos;
    if (fs::is_regular_file(spec, ec)) return readMaterialFile(spec);
    if (looks_file)
        CV_Error(Error::StsBadArg, "material file '" + spec +
                                       "' does not exist (expected a preset: " + list +
                                       "; or an existing YAML/JSON material file)");
    const auto names = Material::presetNames();
    if (std::find(names.begin(), names.end(), spec) == names.end())
        CV_Error(Error::StsBadArg, "unknown material '" + spec + "' (expected a preset: " + list +
                                       "; or a YAML/JSON file with a top-level material: map)");
    return Material::preset(spec);
}

void parseLightSpec(const std::string& spec, bool& fixed, Vec3d& to_light) {
    if (spec == "auto") {
        fixed = false;
        return;
    }
    const std::string pre = "fixed:";
    if (spec.compare(0, pre.size(), pre) == 0) {
        double v[3];
        char tail = 0;
        if (std::sscanf(spec.c_str() + pre.size(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) ==
            3) {
            const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            if (n > 0 && std::isfinite(n)) {
                fixed = true;
                to_light = Vec3d(v[0], v[1], v[2]) / n;
                return;
            }
        }
    }
    CV_Error(Error::StsBadArg, "invalid light '" + spec +
                                   "' (expected 'auto' or 'fixed:x,y,z', a non-zero direction "
                                   "towards the light in camera coordinates: x right, y down, "
                                   "z forward)");
}

void MaterialEditReport::print(FILE* f) const {
    std::fprintf(f, "%-12s %10s %10s\n", "stage", "seconds", "frames/s");
    for (const auto& s : seconds)
        std::fprintf(f, "%-12s %10.3f %10.1f\n", s.first.c_str(), s.second,
                     s.second > 0 ? frames / s.second : 0.0);
    std::fprintf(f, "%-12s %10.3f %10.1f\n", "total", total_seconds,
                 total_seconds > 0 ? frames / total_seconds : 0.0);
    std::fprintf(f, "frames %d, lost %d; hole pixels from other frames %d, by exemplars %d\n",
                 frames, frames_lost, pixels_temporal, pixels_exemplar);
}

namespace {

using Clock = std::chrono::steady_clock;

enum Stage {
    DECODE,
    TRACKING,
    SHAPE,
    INPAINTING,
    ENVIRONMENT,
    LIGHTING,
    RENDERING,
    COMPOSITING,
    ENCODE,
    NSTAGES
};
const char* kStageNames[NSTAGES] = {"decode",     "tracking",    "shape",
                                    "inpainting", "environment", "lighting",
                                    "rendering",  "compositing", "encode"};

struct StageTimer {
    double* acc;
    Clock::time_point t0 = Clock::now();
    explicit StageTimer(double& a) : acc(&a) {}
    ~StageTimer() { *acc += std::chrono::duration<double>(Clock::now() - t0).count(); }
};

/** Removes a staging folder unless released. */
struct Staging {
    fs::path dir;
    bool keep = false;
    ~Staging() {
        if (!dir.empty() && !keep) {
            std::error_code ec;
            fs::remove_all(dir, ec);
        }
    }
};

/** Per-frame state travelling through the background fill. */
struct FrameItem {
    int index = 0;
    Mat frame;  // original 8-bit BGR
    Mat hole;   // CV_8U full frame, 255 = hole
    Point2f center;
    float radius = 0;
    Rect hole_box;
};

/** The object's removal: vbme_inpaint's ConsensusInpainter (a robust vote of the frames within
±radius that see each hole pixel, without alignment for a static camera or aligned by
homography and dense flow), with the frames' bookkeeping alongside. */
class RemovalFill {
public:
    explicit RemovalFill(const ConsensusInpainter::Params& p)
        : ci_(ConsensusInpainter::create(p)) {}
    void push(FrameItem&& it) {
        ci_->push(it.frame, it.hole);
        q_.push_back(std::move(it));
    }
    void finish() { ci_->finish(); }
    bool pop(FrameItem& it, Mat& filled) {
        ConsensusInpainter::FrameStats st;
        if (!ci_->pop(filled, &st)) return false;
        it = std::move(q_.front());
        q_.pop_front();
        temporal += st.temporal + st.previous;
        exemplar += st.exemplar;
        return true;
    }
    int temporal = 0, exemplar = 0;

private:
    Ptr<ConsensusInpainter> ci_;
    std::deque<FrameItem> q_;
};

/** Sub-pixel refinement of a tracked disk against the inpainted background: along 64 rays
from the centre, the coverage `α = (I − B)·(F − B)/|F − B|²` (I the frame, B the background, F
the frame just inside the rim, all linear) falls through 0.5 at the edge; a circle is fitted
to those edge points (algebraic least squares). Rays of low contrast are skipped; the disk is
kept unless at least 16 rays remain and the change is under 1.5 px. */
void refineDisk(const Mat& I, const Mat& B, Point2f& c, float& r) {
    if (r < 6) return;
    auto at = [](const Mat& m, float x, float y, Vec3f& v) {
        if (x < 0 || y < 0 || x > m.cols - 1.001f || y > m.rows - 1.001f) return false;
        const int x0 = (int)x, y0 = (int)y;
        const float fx = x - x0, fy = y - y0;
        v = (m.at<Vec3f>(y0, x0) * (1 - fx) + m.at<Vec3f>(y0, x0 + 1) * fx) * (1 - fy) +
            (m.at<Vec3f>(y0 + 1, x0) * (1 - fx) + m.at<Vec3f>(y0 + 1, x0 + 1) * fx) * fy;
        return true;
    };
    std::vector<Point2f> pts;
    const int kRays = 64;
    for (int k = 0; k < kRays; k++) {
        const float a = (float)(2 * CV_PI * k / kRays), ux = std::cos(a), uy = std::sin(a);
        Vec3f F;
        if (!at(I, c.x + ux * (r - 1.25f), c.y + uy * (r - 1.25f), F)) continue;
        float prev_alpha = 1.f, prev_rho = r - 1.25f, edge = -1;
        bool ok = true;
        for (float rho = r - 1.f; rho <= r + 2.5f; rho += 0.25f) {
            Vec3f v, b;
            if (!at(I, c.x + ux * rho, c.y + uy * rho, v) ||
                !at(B, c.x + ux * rho, c.y + uy * rho, b)) {
                ok = false;
                break;
            }
            const Vec3f fb = F - b;
            const float den = fb.dot(fb);
            if (den < 0.02f * 0.02f) {
                ok = false;
                break;
            }
            const float alpha = (v - b).dot(fb) / den;
            if (alpha < 0.5f) {
                edge = prev_rho +
                       (rho - prev_rho) * (prev_alpha - 0.5f) / std::max(1e-6f, prev_alpha - alpha);
                break;
            }
            prev_alpha = alpha;
            prev_rho = rho;
        }
        if (ok && edge > 0) pts.push_back(Point2f(c.x + ux * edge, c.y + uy * edge));
    }
    if ((int)pts.size() < 16) return;
    // x² + y² + D x + E y + G = 0, solved for (D, E, G) in the least-squares sense.
    Mat A((int)pts.size(), 3, CV_64F), b((int)pts.size(), 1, CV_64F), sol;
    for (int i = 0; i < (int)pts.size(); i++) {
        const double x = pts[i].x - c.x, y = pts[i].y - c.y;  // centred for conditioning
        A.at<double>(i, 0) = x;
        A.at<double>(i, 1) = y;
        A.at<double>(i, 2) = 1;
        b.at<double>(i) = -(x * x + y * y);
    }
    if (!solve(A, b, sol, DECOMP_SVD)) return;
    const double cx = -sol.at<double>(0) / 2, cy = -sol.at<double>(1) / 2;
    const double rr = std::sqrt(std::max(0.0, cx * cx + cy * cy - sol.at<double>(2)));
    if (std::abs(cx) > 1.5 || std::abs(cy) > 1.5 || std::abs(rr - r) > 1.5) return;
    c = Point2f((float)(c.x + cx), (float)(c.y + cy));
    r = (float)rr;
}

/** Restores OpenCV's thread count on scope exit. */
struct ThreadScope {
    int saved;
    explicit ThreadScope(int n) : saved(getNumThreads()) {
        if (n > 0) setNumThreads(n);
    }
    ~ThreadScope() { setNumThreads(saved); }
};

}  // namespace

MaterialEditReport runMaterialEdit(const MaterialEditParams& p) {
    const auto t_start = Clock::now();
    MaterialEditReport report;
    double sec[NSTAGES] = {0};

    // ---- Check every input before any output is written.
    if (p.video.empty()) CV_Error(Error::StsBadArg, "material-edit: no input video given");
    if (p.first_mask.empty())
        CV_Error(Error::StsBadArg, "material-edit: no first-frame mask given");
    if (p.out.empty()) CV_Error(Error::StsBadArg, "material-edit: no output video given");
    if (p.inpaint != "background" && p.inpaint != "video")
        CV_Error(Error::StsBadArg, "material-edit: unknown inpaint mode '" + p.inpaint +
                                       "' (expected 'background' for a static camera or 'video')");
    if (p.focal < 0 || !std::isfinite(p.focal))
        CV_Error(Error::StsBadArg, "material-edit: the focal length must be > 0 pixels (or 0)");
    if (p.max_lost < 0 || p.lookahead < 0 || p.samples < 1 || p.env_every < 1 ||
        p.env_size.width < 8 || p.env_size.height < 4 || p.light_half_angle_deg <= 0 ||
        p.light_half_angle_deg >= 80 || p.background_depth <= 0 || p.hole_margin < 0)
        CV_Error(Error::StsBadArg,
                 "material-edit: invalid settings (expected max_lost ≥ 0, lookahead ≥ 0, "
                 "samples ≥ 1, env_every ≥ 1, env_size ≥ 8×4, light_half_angle_deg in (0, 80), "
                 "background_depth > 0, hole_margin ≥ 0)");
    bool fixed_light = false;
    Vec3d fixed_dir;
    parseLightSpec(p.light, fixed_light, fixed_dir);
    const Response response = parseResponse(p.response);
    const ShadowMode shadows = parseShadowMode(p.shadows);
    checkOverwrite(p.out, p.force);
    const fs::path inter = p.intermediates;
    if (!inter.empty()) {
        std::error_code ec;
        if (fs::exists(inter, ec) && !fs::is_directory(inter, ec))
            CV_Error(Error::StsBadArg,
                     "intermediates folder '" + p.intermediates + "' exists and is not a folder");
        checkOverwrite((inter / maskFileName(0)).string(), p.force);
        checkOverwrite((inter / "background.mkv").string(), p.force);
        checkOverwrite((inter / "env_00000.exr").string(), p.force);
    }
    std::unique_ptr<EnvironmentMap> user_env;
    if (!p.env.empty()) user_env.reset(new EnvironmentMap(EnvironmentMap::load(p.env)));

    VideoReadOptions read_opt;
    if (p.response != "srgb") {
        read_opt.hdr = HdrPolicy::Refuse;
        read_opt.purpose = "material-edit with --response " + p.response +
                           " (HDR input is converted to sRGB-encoded frames; use --response srgb)";
    }
    VideoReader reader(p.video, read_opt);
    Mat frame;
    {
        StageTimer t(sec[DECODE]);
        if (!reader.read(frame))
            CV_Error(Error::StsBadArg, "video '" + p.video + "' holds no frame");
    }
    const Size size = frame.size();
    // the first-frame mask: readable, of the video's size, marking some but not all pixels
    Mat first_mask = readObjectMask(p.first_mask, size);

    ThreadScope threads(p.threads);
    const double focal = p.focal > 0 ? p.focal : focalFromFov(size.width, 60.0);
    // A level camera looking along world +y (z up): X_cam = R·X_world.
    const Matx33f cam_from_world(1, 0, 0, 0, 0, -1, 0, 1, 0);
    const Matx33f world_from_cam = cam_from_world.t();

    // ---- Outputs (temporary names until the end).
    VideoSink sink(p.out, reader.fps(), size, sinkOptionsFrom(reader, p.out, p.encode));
    Staging staging;
    std::unique_ptr<VideoSink> bg_sink;
    if (!inter.empty()) {
        fs::create_directories(inter);
        staging.dir = inter / format(".material-edit-%d", (int)::getpid());
        fs::remove_all(staging.dir);
        fs::create_directories(staging.dir);
        bg_sink.reset(new VideoSink((staging.dir / "background.mkv").string(), reader.fps(), size));
    }

    Ptr<ObjectTracker> tracker = ObjectTracker::create();
    {
        StageTimer t(sec[TRACKING]);
        tracker->init(frame, first_mask);
    }
    ExemplarInpainter::Params ep;
    ep.method = PATCH_SEARCH_PATCHMATCH;
    ConsensusInpainter::Params cp;
    cp.exemplar = ep;
    cp.temporal_radius = std::max(1, p.lookahead);
    cp.alignment = p.inpaint == "video" ? CONSENSUS_ALIGN_FLOW : CONSENSUS_ALIGN_NONE;
    cp.shadows = shadows;
    RemovalFill fill(cp);

    Progress progress("material-edit", std::max(0, reader.frameCount()));
    Disk last_good;
    int consecutive_lost = 0;
    Mat out8, bg_lin, big_lin, rendered, crop_lin, normals, fit_mask, comp;

    std::future<void> encoding;
    auto processDone = [&](FrameItem& it, Mat& filled) {
        Point2f c = it.center;
        float r = it.radius;
        {
            StageTimer t(sec[ENVIRONMENT]);
            linearize(filled, bg_lin, response);
        }
        const Rect big = Rect(Point(cvFloor(c.x - r - 6), cvFloor(c.y - r - 6)),
                              Point(cvCeil(c.x + r + 7), cvCeil(c.y + r + 7))) &
                         Rect(Point(0, 0), size);
        {
            StageTimer t(sec[LIGHTING]);
            linearize(it.frame(big), big_lin, response);
        }
        if (p.refine_disk) {
            StageTimer t(sec[SHAPE]);
            Point2f local = c - Point2f((float)big.x, (float)big.y);
            refineDisk(big_lin, bg_lin(big), local, r);
            c = local + Point2f((float)big.x, (float)big.y);
        }
        const Rect box = Rect(Point(cvFloor(c.x - r - 1), cvFloor(c.y - r - 1)),
                              Point(cvCeil(c.x + r + 2), cvCeil(c.y + r + 2))) &
                         Rect(Point(0, 0), size);
        // Shape: orthographic sphere normals over the disk (thesis §4.2) and the fit's mask.
        {
            StageTimer t(sec[SHAPE]);
            normals.create(box.size(), CV_32FC3);
            fit_mask.create(box.size(), CV_8U);
            for (int y = 0; y < box.height; y++)
                for (int x = 0; x < box.width; x++) {
                    const float px = (float)(x + box.x), py = (float)(y + box.y);
                    const float dx = px - c.x, dy = py - c.y;
                    const bool in = dx * dx + dy * dy <= (r - 1.5f) * (r - 1.5f);
                    normals.at<Vec3f>(y, x) = in ? sphereNormalAt(px, py, c, r) : Vec3f(0, 0, 0);
                    fit_mask.at<uchar>(y, x) = in ? 255 : 0;
                }
        }
        // Environment: from the inpainted frame (or the user's map).
        EnvironmentMap frame_env(Vec3f(0, 0, 0));
        {
            StageTimer t(sec[ENVIRONMENT]);
            if (!user_env) {
                // The map has env_size.height/π pixels per radian; the disk needs no more
                // than radius/(π/2): shrink the frame first so that the mapping stays cheap.
                const float disk_r = 0.5f * std::min(size.width, size.height);
                const double k = std::min(1.0, 0.5 * p.env_size.height / disk_r);
                Mat small = bg_lin;
                if (k < 1.0) resize(bg_lin, small, Size(), k, k, INTER_AREA);
                const Mat eq = imageDiskToEnvironment(
                    small, Point2f(0.5f * (small.cols - 1), 0.5f * (small.rows - 1)),
                    0.5f * std::min(small.cols, small.rows), cam_from_world, p.env_size);
                frame_env = EnvironmentMap(eq);
                if (!inter.empty() && it.index % p.env_every == 0) {
                    Mat ch[3];
                    split(eq, ch);
                    writeExrChannels((staging.dir / format("env_%05d.exr", it.index)).string(),
                                     {{"R", ch[2]}, {"G", ch[1]}, {"B", ch[0]}});
                }
            }
        }
        const EnvironmentMap& env = user_env ? *user_env : frame_env;
        // Lighting: the original object as a light probe.
        LightingFit fit;
        {
            StageTimer t(sec[LIGHTING]);
            crop_lin = big_lin(box - big.tl());
            LightFitParams lp;
            lp.fixed_direction = fixed_light;
            lp.fixed_to_light =
                Vec3f((float)fixed_dir[0], (float)fixed_dir[1], (float)fixed_dir[2]);
            fit = fitLighting(crop_lin, normals, fit_mask, lp);
        }
        report.disks.push_back(Vec3f(c.x, c.y, r));
        report.to_light.push_back(Vec3d(fit.to_light[0], fit.to_light[1], fit.to_light[2]));
        report.fit_rms.push_back(fit.rms);
        report.albedo.push_back(Vec3d(fit.albedo[0], fit.albedo[1], fit.albedo[2]));
        // Rendering: key light + image-based environment with the fitted ambient.
        {
            StageTimer t(sec[RENDERING]);
            SphereRefraction refr;
            refr.background = bg_lin;
            refr.center = c;
            refr.radius = r;
            refr.focal = focal;
            refr.background_depth = (float)p.background_depth;
            ImageShader::Params ip;
            ip.samples = p.samples;
            ip.world_from_camera = world_from_cam;
            CombinationShader shader;
            if (fit.irradiance.dot(fit.irradiance) > 0)
                shader.add(makePtr<AreaLightShader>(p.material, fit.to_light, fit.irradiance,
                                                    (float)(p.light_half_angle_deg * CV_PI / 180),
                                                    p.samples));
            shader.add(makePtr<ImageShader>(p.material, &env, &fit.ambient, &refr, ip));
            // Into its own image: glass refraction reads the background while others are written.
            renderSphere(bg_lin, c, r, focal, shader, rendered);
        }
        {
            StageTimer t(sec[COMPOSITING]);
            out8 = filled.clone();
            if (!box.empty()) {
                encode(rendered(box), comp, response, CV_8U);
                comp.copyTo(out8(box));
            }
        }
        // Encoding runs in its own thread, overlapping the next frame's work.
        if (encoding.valid()) encoding.get();
        encoding =
            std::async(std::launch::async, [&, out = out8, filled, hole = it.hole, index = it.index,
                                            time = reader.timestamps()[it.index]] {
                StageTimer t(sec[ENCODE]);
                sink.write(out, time);
                if (bg_sink) bg_sink->write(filled);
                if (!inter.empty())
                    imwriteAtomic((staging.dir / maskFileName(index)).string(), hole);
            });
        report.frames++;
        progress.tick();
    };

    auto drain = [&] {
        FrameItem it;
        Mat filled;
        for (;;) {
            bool got;
            {
                StageTimer t(sec[INPAINTING]);
                got = fill.pop(it, filled);
            }
            if (!got) break;
            processDone(it, filled);
        }
    };

    int index = 0;
    do {
        FrameItem it;
        it.index = index;
        {
            StageTimer t(sec[TRACKING]);
            const ObjectTracker::Result res = tracker->update(frame);
            if (res.found) {
                last_good = res.disk;
                consecutive_lost = 0;
            } else {
                report.frames_lost++;
                ++consecutive_lost;
                if (index == 0) last_good = fitDisk(first_mask);
                if (consecutive_lost > p.max_lost)
                    CV_Error(Error::StsError,
                             format("material-edit: the object was lost at frame %d (tracking "
                                    "confidence %.2f below %.2f); nothing was written. Check "
                                    "that the object stays in view and keeps its colour, or "
                                    "allow short losses with max_lost (--max-lost N keeps the "
                                    "last disk for up to N frames)",
                                    index, res.confidence, tracker->params().lost_threshold));
            }
            it.center = last_good.center;
            it.radius = last_good.radius;
        }
        {
            StageTimer t(sec[SHAPE]);
            const float rh = it.radius + (float)p.hole_margin;
            it.hole = Mat::zeros(size, CV_8U);
            circle(it.hole, Point(cvRound(it.center.x * 16), cvRound(it.center.y * 16)),
                   cvRound(rh * 16), Scalar(255), FILLED, LINE_8, 4);
            it.hole_box = Rect(Point(cvFloor(it.center.x - rh - 2), cvFloor(it.center.y - rh - 2)),
                               Point(cvCeil(it.center.x + rh + 3), cvCeil(it.center.y + rh + 3))) &
                          Rect(Point(0, 0), size);
            it.frame = frame;
        }
        {
            StageTimer t(sec[INPAINTING]);
            fill.push(std::move(it));
        }
        // Decode the next frame in its own thread while this one is processed.
        Mat next_frame;
        std::future<bool> decoding = std::async(std::launch::async, [&] {
            StageTimer t(sec[DECODE]);
            return reader.read(next_frame);
        });
        drain();
        ++index;
        if (!decoding.get()) break;
        frame = next_frame;  // the queue keeps its own reference to the previous frame
    } while (true);
    {
        StageTimer t(sec[INPAINTING]);
        fill.finish();
    }
    drain();

    if (encoding.valid()) encoding.get();
    {
        StageTimer t(sec[ENCODE]);
        sink.close();
        if (bg_sink) bg_sink->close();
        if (!inter.empty()) {
            for (const auto& e : fs::directory_iterator(staging.dir)) {
                const fs::path dst = inter / e.path().filename();
                std::error_code ec;
                fs::remove(dst, ec);
                fs::rename(e.path(), dst);
            }
        }
    }
    progress.finish();
    report.pixels_temporal = fill.temporal;
    report.pixels_exemplar = fill.exemplar;
    for (int s = 0; s < NSTAGES; s++)
        report.seconds.emplace_back(kStageNames[s], sec[s]);
    report.total_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
    return report;
}

}  // namespace vbme
}  // namespace cv
