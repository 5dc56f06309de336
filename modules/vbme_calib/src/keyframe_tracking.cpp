// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Camera tracking by keyframes: corners tracked through the video choose the frames COLMAP
// reconstructs; every other frame is registered by PnP against the model's points.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "camera_refine.hpp"
#include "opencv2/vbme/calib/camera_tracking.hpp"
#include "opencv2/vbme/core/utility.hpp"

namespace fs = std::filesystem;

namespace cv {
namespace vbme {

namespace {

// Adds the wall and CPU seconds of a stage to the report when stopped.
class StageTimer {
public:
    StageTimer(CameraTrackingReport& rep, const char* stage)
        : rep_(rep), stage_(stage), cpu0_(detail::processCpuSeconds()) {}
    ~StageTimer() { stop(); }
    void stop() {
        if (stopped_) return;
        stopped_ = true;
        rep_.stage_seconds.emplace_back(stage_, wall_.stop());
        rep_.stage_cpu_seconds.emplace_back(stage_, detail::processCpuSeconds() - cpu0_);
    }

private:
    CameraTrackingReport& rep_;
    const char* stage_;
    double cpu0_;
    ScopedTimer wall_;
    bool stopped_ = false;
};

const Size kWin(21, 21);
const int kLevels = 4;

// Lucas-Kanade from @p a to @p b, kept where the backward track returns within 0.5 px. @p keep
// receives, per input point, whether it was tracked.
void trackLK(const Mat& a, const Mat& b, const std::vector<Point2f>& pa, std::vector<Point2f>& pb,
             std::vector<uchar>& keep) {
    keep.assign(pa.size(), 0);
    pb.clear();
    if (pa.empty()) return;
    const TermCriteria crit(TermCriteria::COUNT | TermCriteria::EPS, 30, 0.01);
    std::vector<uchar> st1, st2;
    std::vector<float> err;
    std::vector<Point2f> back;
    calcOpticalFlowPyrLK(a, b, pa, pb, st1, err, kWin, kLevels, crit);
    calcOpticalFlowPyrLK(b, a, pb, back, st2, err, kWin, kLevels, crit);
    const Rect2f inside(0, 0, (float)a.cols - 1, (float)a.rows - 1);
    for (size_t i = 0; i < pa.size(); ++i) {
        const Point2f d = back[i] - pa[i];
        keep[i] = st1[i] && st2[i] && d.dot(d) < 0.25f && inside.contains(pb[i]);
    }
}

double median(std::vector<double> v) {
    if (v.empty()) return 0;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
}

}  // namespace

namespace {

// The first of COLMAP's models (largest first, ColmapModel::readTextModels()) that holds the
// image @p name, or null.
const ColmapModel* modelHolding(const std::vector<ColmapModel>& models, const std::string& name) {
    for (const auto& m : models)
        if (m.imageByName(name)) return &m;
    return nullptr;
}

// selectKeyframes(), also returning every corner track it followed (when @p tracks is given;
// then the corners are tracked even with a fixed stride).
std::vector<int> selectKeyframesAndTracks(const std::vector<Mat>& gray, const KeyframeOptions& o,
                                          std::vector<detail::CornerTrack>* tracks) {
    const int n = (int)gray.size();
    std::vector<int> keys;
    if (n == 0) return keys;
    if (o.stride > 0) {
        for (int i = 0; i < n; i += o.stride)
            keys.push_back(i);
        if (!tracks) return keys;
    }
    const bool choose = o.stride <= 0;
    CV_Assert(o.features > 0 && o.max_gap >= 1);
    for (const Mat& g : gray)
        CV_Assert(g.type() == CV_8UC1 && g.size() == gray[0].size());
    const double max_motion = o.max_motion * gray[0].cols;
    const int min_dist = std::max(5, gray[0].cols / 64);
    std::vector<Point2f> pts, at_key;  // current positions; positions at the last keyframe
    std::vector<uchar> from_key;       // tracked since the last keyframe
    std::vector<int> id;               // index into *tracks
    auto replenish = [&](const Mat& g, int frame) {
        if ((int)pts.size() >= o.features * 8 / 10) return;
        Mat mask(g.size(), CV_8U, Scalar(255));
        for (const Point2f& p : pts)
            circle(mask, p, min_dist, Scalar(0), -1);
        std::vector<Point2f> add;
        goodFeaturesToTrack(g, add, o.features - (int)pts.size(), 0.01, min_dist, mask);
        for (const Point2f& p : add) {
            pts.push_back(p);
            at_key.push_back(p);
            from_key.push_back(0);
            if (tracks) {
                id.push_back((int)tracks->size());
                tracks->push_back({{frame}, {p}});
            }
        }
    };
    std::vector<int> chosen;
    auto makeKey = [&](int i) {
        chosen.push_back(i);
        at_key = pts;
        from_key.assign(pts.size(), 1);
    };
    replenish(gray[0], 0);
    makeKey(0);
    int key_count = (int)pts.size();
    for (int i = 1; i < n; ++i) {
        std::vector<Point2f> next;
        std::vector<uchar> ok;
        trackLK(gray[i - 1], gray[i], pts, next, ok);
        size_t m = 0;
        for (size_t k = 0; k < pts.size(); ++k)
            if (ok[k]) {
                pts[m] = next[k], at_key[m] = at_key[k], from_key[m] = from_key[k];
                if (tracks) {
                    id[m] = id[k];
                    (*tracks)[id[m]].frames.push_back(i);
                    (*tracks)[id[m]].px.push_back(next[k]);
                }
                ++m;
            }
        pts.resize(m);
        at_key.resize(m);
        from_key.resize(m);
        if (tracks) id.resize(m);
        std::vector<double> motion;
        for (size_t k = 0; k < m; ++k)
            if (from_key[k]) motion.push_back(norm(pts[k] - at_key[k]));
        const bool key = i == n - 1 || i - chosen.back() >= o.max_gap ||
                         (double)motion.size() < o.min_overlap * key_count ||
                         median(motion) > max_motion;
        replenish(gray[i], i);
        if (key) {
            makeKey(i);
            key_count = (int)pts.size();
        }
    }
    return choose ? chosen : keys;
}

}  // namespace

std::vector<int> selectKeyframes(InputArrayOfArrays gray_, const KeyframeOptions& o) {
    std::vector<Mat> gray;
    gray_.getMatVector(gray);
    return selectKeyframesAndTracks(gray, o, nullptr);
}

namespace {

// The 2D features (vbme pixel convention) of a registered frame that have a world point.
struct Seeds {
    std::vector<Point2f> px;
    std::vector<Point3f> X;
};

// At most kSeedsPerCell per cell of a kGrid x kGrid grid over the image, so that the points are
// spread and their count (the cost of tracking them) bounded.
const int kGrid = 16, kSeedsPerCell = 2;

Seeds seedsOf(const ColmapImage& im, const std::map<long long, Vec3d>& world, Size size) {
    Seeds s;
    std::vector<int> used(kGrid * kGrid, 0);
    for (size_t k = 0; k < im.xys.size(); ++k) {
        auto it = world.find(im.point3d_ids[k]);
        if (im.point3d_ids[k] < 0 || it == world.end()) continue;
        const Point2f p((float)(im.xys[k].x - 0.5), (float)(im.xys[k].y - 0.5));
        const int gx = std::min(kGrid - 1, std::max(0, (int)(p.x * kGrid / size.width))),
                  gy = std::min(kGrid - 1, std::max(0, (int)(p.y * kGrid / size.height)));
        if (used[gy * kGrid + gx]++ >= kSeedsPerCell) continue;
        s.px.push_back(p);
        s.X.emplace_back((float)it->second[0], (float)it->second[1], (float)it->second[2]);
    }
    return s;
}

struct PnPResult {
    bool ok = false;
    Matx33d R;
    Vec3d t;
    int inliers = 0;
    double rms = 0;
};

// RANSAC PnP, then Levenberg-Marquardt on the inliers (points fixed), inliers re-collected
// once at the refined pose.
PnPResult solvePose(const std::vector<Point3f>& X, const std::vector<Point2f>& x, const Matx33d& K,
                    const CameraTrackingOptions& opt) {
    PnPResult r;
    if ((int)X.size() < std::max(6, opt.pnp_min_inliers)) return r;
    Vec3d rvec, tvec;
    std::vector<int> inl;
    if (!solvePnPRansac(X, x, K, noArray(), rvec, tvec, false, 200, 2.0f, 0.999, inl,
                        SOLVEPNP_EPNP))
        return r;
    for (int pass = 0; pass < 2; ++pass) {
        if ((int)inl.size() < opt.pnp_min_inliers) return r;
        std::vector<Point3f> Xi;
        std::vector<Point2f> xi;
        for (int k : inl)
            Xi.push_back(X[k]), xi.push_back(x[k]);
        solvePnPRefineLM(Xi, xi, K, noArray(), rvec, tvec);
        std::vector<Point2f> proj;
        projectPoints(X, rvec, tvec, K, noArray(), proj);
        inl.clear();
        double se = 0;
        for (size_t k = 0; k < X.size(); ++k) {
            const Point2f d = proj[k] - x[k];
            const double e2 = d.dot(d);
            if (e2 < 1.5 * 1.5) inl.push_back((int)k), se += e2;
        }
        r.rms = inl.empty() ? 0 : std::sqrt(se / inl.size());
    }
    r.inliers = (int)inl.size();
    Mat R;
    Rodrigues(rvec, R);
    r.R = Matx33d(R);
    r.t = tvec;
    r.ok = r.inliers >= opt.pnp_min_inliers && r.rms <= opt.pnp_max_rms;
    return r;
}

// Largest change of a frame's pose by the joint adjustment that is accepted (metres, radians).
const double kMaxAdjustMove = 0.25, kMaxAdjustTurn = 5 * CV_PI / 180;
// Standard deviation (pixels) given to the corner tracks' positions in the joint adjustment
// (COLMAP's observations: 1 px).
const float kCornerSigma = 3;
// The joint adjustment is set up again at its own poses and run again when its first pass moved a
// frame by more than kFarStart (metres: it started far from its answer, from a distorted COLMAP
// model), then while a pass moves a frame by more than kRepeatMove, at most
// CameraTrackingOptions::joint_passes passes in all. First passes moved a frame by 6.1 mm (rendered
// room, 300 frames) and 9.3-12.2 mm (good models of the Blender clip), 22.0-35.7 mm from distorted
// ones; a second pass cost 0.24 CPU s/frame on the 300 frames and changed nothing there.
const double kFarStart = 0.015, kRepeatMove = 0.005;

std::string frameName(int i) {
    return format("frame_%05d.png", i);
}

}  // namespace

CameraPath trackCameraKeyframes(InputArrayOfArrays gray_, const Scene& frame0,
                                const std::string& work_dir, const CameraTrackingOptions& opt,
                                CameraTrackingReport* report) {
    std::vector<Mat> gray;
    gray_.getMatVector(gray);
    ScopedTimer total;
    const int n = (int)gray.size();
    if (n == 0) CV_Error(Error::StsBadArg, "trackCameraKeyframes: no frames");
    for (int i = 0; i < n; ++i)
        if (gray[i].type() != CV_8UC1 || gray[i].size() != frame0.image_size)
            CV_Error(Error::StsBadArg,
                     format("trackCameraKeyframes: frame %d is not an 8-bit grey image of the "
                            "annotation's size %dx%d",
                            i, frame0.image_size.width, frame0.image_size.height));
    CameraTrackingReport rep;
    KeyframeOptions ko = opt.keyframes;
    if (opt.stride > 1) ko.stride = opt.stride;

    // 1. Keyframes.
    StageTimer t_keys(rep, "keyframes");
    std::vector<detail::CornerTrack> tracks;
    std::vector<int> keys =
        selectKeyframesAndTracks(gray, ko, opt.global_refine ? &tracks : nullptr);
    t_keys.stop();

    // 2. COLMAP on the keyframes (resumable: the same keyframes with a finished run are reused).
    const fs::path work(work_dir), kdir = work / "keyframes";
    std::error_code ec;
    fs::create_directories(work, ec);
    if (ec) CV_Error(Error::StsError, "cannot create '" + work.string() + "': " + ec.message());
    // COLMAP's mapper can fail to initialise, or leave frame 0 out, on keyframes that are too
    // sparse for it (it varies from run to run): then the gaps are halved and COLMAP runs again,
    // up to twice, before the failure is reported.
    std::vector<std::string> names;
    for (int i = 0; i < n; ++i)
        names.push_back(frameName(i));
    std::vector<ColmapModel> models;
    const ColmapModel* model = nullptr;
    // How COLMAP runs on keyframes: few images with fewer features: keep small models (the one
    // holding frame 0 is used) and register keyframes seen through a fast pan on fewer points.
    ColmapOptions co = opt.colmap;
    co.max_num_features = ko.sift_features;
    co.overlap = ko.overlap;
    co.min_model_size = std::min(co.min_model_size, 3);
    co.abs_pose_min_num_inliers = std::min(co.abs_pose_min_num_inliers, 15);
    bool fresh = false;  // COLMAP ran in this call (not reused): its model may be mapped again
    std::string marker_line;
    const fs::path done = work / "colmap_complete.txt";
    // The resume marker of a COLMAP run on @p ks: settings, intrinsics (COLMAP's model is made
    // with them) and keyframes.
    auto markerOf = [&](const std::vector<int>& ks) {
        std::ostringstream key_list;
        const Matx33d& K = frame0.camera.K;
        key_list << ko.sift_features << " " << ko.overlap << " " << opt.colmap.random_seed << " "
                 << opt.colmap.vocab_tree << " "
                 << format("%.10g %.10g %.10g %.10g", K(0, 0), K(1, 1), K(0, 2), K(1, 2));
        // the frames were undistorted with it (trackCameraVideo)
        if (frame0.camera.k1 != 0) key_list << format(" k1 %.10g", frame0.camera.k1);
        // an earlier run's features and matches replayed (ColmapOptions::database)
        if (!co.database.empty()) key_list << " database " << co.database;
        key_list << ":";
        for (int k : ks)
            key_list << " " << k;
        return key_list.str();
    };
    // Every gap between keyframes halved.
    auto denserOf = [](const std::vector<int>& ks) {
        std::vector<int> denser;
        for (size_t k = 0; k < ks.size(); ++k) {
            denser.push_back(ks[k]);
            if (k + 1 < ks.size() && ks[k + 1] - ks[k] > 1)
                denser.push_back((ks[k] + ks[k + 1]) / 2);
        }
        return denser;
    };
    for (int attempt = 0;; ++attempt) {
        const bool can_retry = attempt < 2 && (int)keys.size() < n;
        try {
            models.clear();
            fresh = false;
            {
                std::ifstream in(done.string());
                std::string line;
                std::getline(in, line);
                if (!line.empty() && line == markerOf(keys))
                    models = ColmapModel::readTextModels((work / "sparse_txt").string());
            }
            if (models.empty()) {
                fs::remove(done, ec);
                fs::remove_all(kdir, ec);
                fs::create_directories(kdir, ec);
                for (int k : keys)
                    imwriteAtomic((kdir / frameName(k)).string(), gray[k]);
                std::printf(
                    "camera tracking: %zu keyframes of %d frames; running COLMAP (log: %s)\n",
                    keys.size(), n, (work / "colmap.log").string().c_str());
                std::fflush(stdout);
                models = runColmapSfM(kdir.string(), work_dir, frame0.camera.K, frame0.image_size,
                                      co, &rep.stage_seconds, &rep.stage_cpu_seconds);
                // the marker is written once the model is chosen (below)
                fresh = true;
                marker_line = markerOf(keys);
            } else {
                rep.stage_seconds.emplace_back("colmap (reused)", 0.0);
                rep.stage_cpu_seconds.emplace_back("colmap (reused)", 0.0);
            }
            model = modelHolding(models, names[0]);
            if (!model && !can_retry)
                CV_Error(Error::StsError, "COLMAP did not register frame 0 in any of its " +
                                              std::to_string(models.size()) + " model(s); see " +
                                              (work / "colmap.log").string());
        } catch (const cv::Exception& e) {
            if (!can_retry) throw;
            std::printf("camera tracking: COLMAP failed on %zu keyframes: %s\n", keys.size(),
                        e.err.c_str());
        }
        if (model) break;
        if (!can_retry) break;
        const std::vector<int> denser = denserOf(keys);
        if (denser.size() == keys.size()) break;
        std::printf(
            "camera tracking: no model holds frame 0 with %zu keyframes; retrying with "
            "%zu\n",
            keys.size(), denser.size());
        keys = denser;
    }
    if (!model)
        CV_Error(Error::StsError,
                 "COLMAP did not reconstruct frame 0 even with denser keyframes; "
                 "see " +
                     (work / "colmap.log").string());
    rep.keyframes = (int)keys.size();

    // 3. Alignment to the room (and refinement) of the keyframes.
    StageTimer t_align(rep, "align");
    std::map<long long, Vec3d> world;
    CameraPath path = detail::alignToRoomWithPoints(*model, names, frame0, opt, &rep, &world);
    rep.models = (int)models.size();
    t_align.stop();
    // 3b. A fresh model whose frame-0 depths disagree with the room box (a distorted
    // reconstruction, e.g. from a poor initial pair: on the Blender clip such models left the
    // track 0.6 cm off after the joint adjustment instead of 0.3 cm) is mapped again from the same
    // matches with other seeds; the model with the smallest scale spread is kept.
    if (fresh) {
        rep.mapper_scale_spreads.push_back(rep.scale.spread);
        // Takes another COLMAP run's model (@p alt, aligned as @p r2, @p p2, @p w2) instead of
        // the one held if its spread is smaller and it kept 90 % of the registered keyframes (a
        // model that lost keyframes is not preferred for its spread alone).
        auto adoptIfBetter = [&](const CameraTrackingReport& r2, CameraPath& p2,
                                 std::map<long long, Vec3d>& w2, std::vector<ColmapModel>& alt) {
            if (r2.scale.spread >= rep.scale.spread || 10 * r2.registered < 9 * rep.registered)
                return false;
            rep.frames = r2.frames;
            rep.registered = r2.registered;
            rep.interpolated = r2.interpolated;
            rep.scale = r2.scale;
            rep.reprojection_rms = r2.reprojection_rms;
            rep.refined_rms = r2.refined_rms;
            rep.plane_points = r2.plane_points;
            path = p2;
            world = std::move(w2);
            models = std::move(alt);
            model = modelHolding(models, names[0]);
            rep.models = (int)models.size();
            return true;
        };
        std::string best_dir;  // the retry whose model is kept (empty: the first)
        for (int r = 1; r <= opt.mapper_retries && rep.scale.spread > opt.max_scale_spread; ++r) {
            ColmapOptions cr = co;
            cr.random_seed = co.random_seed + r;
            std::printf(
                "camera tracking: COLMAP's keyframe model looks distorted (scale spread %.4f > "
                "%.4f); mapping again with seed %d\n",
                rep.scale.spread, opt.max_scale_spread, cr.random_seed);
            std::fflush(stdout);
            const std::string name = format("retry%d", r);
            std::vector<ColmapModel> alt;
            try {
                alt = rerunColmapMapper(kdir.string(), work_dir, name, cr, &rep.stage_seconds,
                                        &rep.stage_cpu_seconds);
            } catch (const cv::Exception& e) {
                std::printf("camera tracking: the mapper failed: %s\n", e.err.c_str());
                continue;
            }
            const ColmapModel* m = modelHolding(alt, names[0]);
            if (!m) continue;
            StageTimer t_realign(rep, "align (retry)");
            CameraTrackingReport r2;
            std::map<long long, Vec3d> world2;
            CameraPath p2;
            try {
                p2 = detail::alignToRoomWithPoints(*m, names, frame0, opt, &r2, &world2);
            } catch (const cv::Exception& e) {
                std::printf("camera tracking: the remapped model cannot be aligned: %s\n",
                            e.err.c_str());
                continue;
            }
            t_realign.stop();
            rep.mapper_scale_spreads.push_back(r2.scale.spread);
            if (adoptIfBetter(r2, p2, world2, alt)) best_dir = name;
        }
        // The kept model is what a resumed run reads back.
        if (!best_dir.empty()) {
            fs::remove_all(work / "sparse_txt", ec);
            fs::rename(work / (best_dir + "_txt"), work / "sparse_txt", ec);
            if (ec) CV_Error(Error::StsError, "cannot keep the remapped model: " + ec.message());
        }
        // Still doubtful: the matches themselves may be at fault (COLMAP's feature extraction and
        // matching are not repeatable): COLMAP runs once more on the same keyframes, from new
        // features and matches; its model is kept if its spread is smaller. (Keyframes twice as
        // dense were tried instead: spread 0.0142 but a track 0.53 cm off, against 0.33 cm.)
        if (rep.scale.spread > opt.max_scale_spread && opt.mapper_retries > 0) {
            std::printf(
                "camera tracking: still doubtful (scale spread %.4f); COLMAP again from new "
                "features and matches\n",
                rep.scale.spread);
            std::fflush(stdout);
            fs::remove_all(work / "kept_txt", ec);
            fs::rename(work / "sparse_txt", work / "kept_txt", ec);
            // The doubted run's features and matches are kept for diagnosis (they replay its
            // models: ColmapOptions::database).
            fs::rename(work / "database.db", work / "database_doubted.db", ec);
            bool adopted = false;
            try {
                ColmapOptions cr = co;
                cr.random_seed = co.random_seed + opt.mapper_retries + 1;
                cr.database.clear();  // new features and matches, even when replaying a database
                std::vector<ColmapModel> alt =
                    runColmapSfM(kdir.string(), work_dir, frame0.camera.K, frame0.image_size, cr,
                                 &rep.stage_seconds, &rep.stage_cpu_seconds);
                const ColmapModel* m = modelHolding(alt, names[0]);
                if (m) {
                    StageTimer t_realign(rep, "align (COLMAP again)");
                    CameraTrackingReport r2;
                    std::map<long long, Vec3d> world2;
                    CameraPath p2 =
                        detail::alignToRoomWithPoints(*m, names, frame0, opt, &r2, &world2);
                    t_realign.stop();
                    rep.mapper_scale_spreads.push_back(r2.scale.spread);
                    adopted = adoptIfBetter(r2, p2, world2, alt);
                }
            } catch (const cv::Exception& e) {
                std::printf("camera tracking: COLMAP failed again: %s\n", e.err.c_str());
            }
            if (adopted) {
                fs::remove_all(work / "kept_txt", ec);
            } else {
                fs::remove_all(work / "sparse_txt", ec);
                fs::rename(work / "kept_txt", work / "sparse_txt", ec);
                if (ec) CV_Error(Error::StsError, "cannot restore the kept model: " + ec.message());
            }
        }
        detail::writeMarker(done.string(), marker_line);
    }

    // 4. PnP for every frame COLMAP did not register, from the nearest registered frame on each
    // side.
    StageTimer t_pnp(rep, "pnp");
    std::vector<int> anchors;
    for (int i = 0; i < n; ++i)
        if (path.frames[i].source == CameraPath::SFM) anchors.push_back(i);
    // Correspondences gathered per frame.
    std::vector<std::vector<Point3f>> cX(n);
    std::vector<std::vector<Point2f>> cx(n);
    auto propagate = [&](int a, int stop, int step) {
        const ColmapImage* im = model->imageByName(names[a]);
        if (!im) return;
        Seeds s = seedsOf(*im, world, frame0.image_size);
        for (int i = a + step; i != stop && !s.px.empty(); i += step) {
            std::vector<Point2f> next;
            std::vector<uchar> ok;
            trackLK(gray[i - step], gray[i], s.px, next, ok);
            size_t m = 0;
            for (size_t k = 0; k < s.px.size(); ++k)
                if (ok[k]) s.px[m] = next[k], s.X[m] = s.X[k], ++m;
            s.px.resize(m);
            s.X.resize(m);
            cx[i].insert(cx[i].end(), s.px.begin(), s.px.end());
            cX[i].insert(cX[i].end(), s.X.begin(), s.X.end());
        }
    };
    if (opt.pnp && !anchors.empty()) {
        for (size_t j = 0; j < anchors.size(); ++j) {
            const int a = anchors[j];
            const int prev = j ? anchors[j - 1] : -1;
            const int next = j + 1 < anchors.size() ? anchors[j + 1] : n;
            if (next - a > 1) propagate(a, next, +1);
            if (a - prev > 1) propagate(a, prev, -1);
        }
    }
    int pnp = 0;
    double se = 0, inliers = 0;
    std::vector<bool> have(n, false);
    for (int i = 0; i < n; ++i) {
        CameraPath::Frame& f = path.frames[i];
        have[i] = f.source == CameraPath::SFM;
        if (have[i]) continue;
        const PnPResult r = opt.pnp ? solvePose(cX[i], cx[i], frame0.camera.K, opt) : PnPResult();
        if (r.ok) {
            f.R = r.R;
            f.t = r.t;
            f.source = CameraPath::PNP;
            ++pnp;
            se += r.rms * r.rms * r.inliers;
            inliers += r.inliers;
            have[i] = true;
        }
    }
    t_pnp.stop();
    // 5. Every registered frame (SfM and PnP) adjusted jointly with points triangulated from the
    // corner tracks through the whole video.
    if (opt.global_refine) {
        StageTimer t_ba(rep, "joint adjustment");
        // COLMAP's own observations of its points in the keyframes join the corner tracks: matched
        // across keyframes by descriptor, they do not drift along a track.
        const size_t klt_tracks = tracks.size();
        {
            std::map<long long, detail::CornerTrack> by_point;
            for (int i = 0; i < n; ++i) {
                if (path.frames[i].source != CameraPath::SFM) continue;
                const ColmapImage* im = model->imageByName(names[i]);
                if (!im) continue;
                for (size_t k = 0; k < im->xys.size(); ++k)
                    if (im->point3d_ids[k] >= 0) {
                        detail::CornerTrack& t = by_point[im->point3d_ids[k]];
                        t.frames.push_back(i);
                        t.px.emplace_back((float)(im->xys[k].x - 0.5), (float)(im->xys[k].y - 0.5));
                    }
            }
            for (auto& kv : by_point)
                tracks.push_back(std::move(kv.second));
        }
        // Frame-to-frame corner tracks drift a little along their length (a few tenths of a
        // pixel over tens of frames), COLMAP's matches do not: the corners weigh as positions
        // known to 3 px (chosen on the Blender clip and the rendered rooms: ATE 0.55 -> 0.33 cm,
        // 0.44 -> 0.32 cm and 1.86 -> 1.50 cm against 1 px).
        for (size_t k = 0; k < klt_tracks; ++k)
            tracks[k].sigma = kCornerSigma;
        // The adjustment's points are triangulated, tied to the box's faces and gated at the
        // poses it starts from. From a distorted COLMAP model (PnP alone 2.8 cm off on the
        // Blender clip) one pass stopped at 0.66 cm, still in that model's basin; set up again at
        // the adjusted poses, three passes reached 0.26 cm. So the adjustment is repeated when its
        // first pass moved a frame by more than kFarStart, then while a pass moves one by more
        // than kRepeatMove, up to opt.joint_passes passes.
        const CameraPath before = path;
        detail::GlobalRefineSummary g;
        // The face distance as the first pass leaves it is the confidence: later passes also fit
        // a wrong room better (focal length 5 % off: 1.57 mm after the passes, 2.7-4.2 mm after
        // one, against 0.43-0.47 mm for the right one).
        double first_face_distance = 0;
        // How far the poses are from their SfM/PnP start: an adjustment that moved a frame
        // farther than kMaxAdjustMove / kMaxAdjustTurn has come apart (e.g. a video whose corner
        // tracks do not link all frames) and its poses are not used.
        const auto departure = [&](const CameraPath& p, double& moved, double& turned) {
            moved = turned = 0;
            for (int i = 0; i < n; ++i) {
                if (!have[i]) continue;
                moved = std::max(moved, norm(p.camera(i).center() - before.camera(i).center()));
                const Matx33d d = p.frames[i].R * before.frames[i].R.t();
                turned =
                    std::max(turned, std::acos(std::max(-1.0, std::min(1.0, (trace(d) - 1) / 2))));
            }
        };
        double moved = 0, turned = 0;
        for (int pass = 0; pass < opt.joint_passes; ++pass) {
            const CameraPath start = path;
            const detail::GlobalRefineSummary last = g;
            g = detail::refineAllFrames(tracks, frame0, opt.plane_tolerance, have, path);
            if (pass == 0) first_face_distance = g.median_face_distance;
            double move = 0;
            for (int i = 0; i < n; ++i)
                if (have[i])
                    move = std::max(move, norm(path.camera(i).center() - start.camera(i).center()));
            rep.ba_pass_moves.push_back(move);
            departure(path, moved, turned);
            // A repeat that comes apart is undone and the earlier passes' poses are kept, rather
            // than dropping the whole adjustment for the SfM/PnP poses (on 8 distorted 240x180
            // frames, PipelineInsertDistortion.CameraTrackWithK1BeatsIgnoringIt, that fallback
            // once gave an ATE of 119 mm where a run whose adjustment held gave 24 mm).
            if (pass > 0 && (g.points == 0 || moved > kMaxAdjustMove || turned > kMaxAdjustTurn)) {
                std::printf(
                    "camera tracking: joint adjustment pass %d moved a frame by %.3f m / %.2f deg "
                    "from its SfM/PnP pose; keeping pass %d\n",
                    pass + 1, moved, turned * 180 / CV_PI, pass);
                path = start;
                g = last;
                departure(path, moved, turned);
                break;
            }
            if (g.points == 0 || move <= (pass == 0 ? kFarStart : kRepeatMove) ||
                move > kMaxAdjustMove)
                break;
        }
        rep.ba_applied = g.points > 0 && moved <= kMaxAdjustMove && turned <= kMaxAdjustTurn;
        if (!rep.ba_applied) {
            path = before;
            std::printf(
                "camera tracking: the joint adjustment moved a frame by %.3f m / %.2f deg; "
                "keeping the SfM and PnP poses\n",
                moved, turned * 180 / CV_PI);
        }
        rep.ba_rms = g.rms;
        rep.ba_points = g.points;
        rep.ba_observations = g.observations;
        rep.ba_worst_frame_rms = g.worst_frame_rms;
        rep.ba_on_face = g.on_face_fraction;
        rep.ba_face_distance = first_face_distance;
    }
    if (rep.ba_applied) {
        rep.face_distance = rep.ba_face_distance;
    } else {
        std::vector<Vec3d> points;
        for (const auto& kv : world)
            points.push_back(kv.second);
        rep.face_distance = detail::medianFaceDistance(points, frame0.room);
    }
    detail::judgeConfidence(opt, opt.global_refine, rep);
    if (!rep.confident) std::printf("camera tracking: WARNING: %s\n", rep.doubt.c_str());
    // Frames PnP could not hold: interpolated between the nearest registered ones (SfM or PnP).
    const int interpolated = detail::interpolateMissing(path, have);
    rep.pnp = pnp;
    rep.interpolated = interpolated;
    rep.pnp_rms = inliers > 0 ? std::sqrt(se / inliers) : 0;
    rep.pnp_inliers = pnp ? inliers / pnp : 0;
    rep.seconds = total.stop();
    if (report) *report = rep;
    return path;
}

}  // namespace vbme
}  // namespace cv
