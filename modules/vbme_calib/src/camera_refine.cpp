// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "camera_refine.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <opencv2/calib3d.hpp>

#include <sys/resource.h>

namespace cv {
namespace vbme {
namespace detail {

namespace {

// Reprojection residual of a world point in a camera (angle-axis + translation), fixed K.
struct Reprojection {
    Reprojection(double u, double v, const Matx33d& K)
        : u(u), v(v), fx(K(0, 0)), fy(K(1, 1)), cx(K(0, 2)), cy(K(1, 2)) {}
    template <typename T>
    bool operator()(const T* pose, const T* X, T* r) const {
        T p[3];
        ceres::AngleAxisRotatePoint(pose, X, p);
        p[0] += pose[3];
        p[1] += pose[4];
        p[2] += pose[5];
        if (p[2] <= T(1e-6)) {
            r[0] = r[1] = T(0);
            return true;
        }
        r[0] = T(fx) * p[0] / p[2] + T(cx) - T(u);
        r[1] = T(fy) * p[1] / p[2] + T(cy) - T(v);
        return true;
    }
    double u, v, fx, fy, cx, cy;
};

// A point tied to a face plane: X[axis] = value, σ = sigma.
struct OnPlane {
    OnPlane(int axis, double value, double sigma) : axis(axis), value(value), sigma(sigma) {}
    template <typename T>
    bool operator()(const T* X, T* r) const {
        r[0] = (X[axis] - T(value)) / T(sigma);
        return true;
    }
    int axis;
    double value, sigma;
};

// Second difference of three consecutive camera centres and rotations, scaled by 1/σ.
struct Smooth {
    Smooth(double sigma_t, double sigma_r) : st(sigma_t), sr(sigma_r) {}
    template <typename T>
    bool operator()(const T* a, const T* b, const T* c, T* r) const {
        // Centres C = −Rᵀ t.
        T Ca[3], Cb[3], Cc[3], na[3], nb[3], nc[3];
        for (int k = 0; k < 3; ++k)
            na[k] = -a[k], nb[k] = -b[k], nc[k] = -c[k];
        ceres::AngleAxisRotatePoint(na, a + 3, Ca);
        ceres::AngleAxisRotatePoint(nb, b + 3, Cb);
        ceres::AngleAxisRotatePoint(nc, c + 3, Cc);
        for (int k = 0; k < 3; ++k) {
            r[k] = -(Ca[k] - T(2) * Cb[k] + Cc[k]) / T(st);
            r[3 + k] =
                (a[k] - T(2) * b[k] + c[k]) / T(sr);  // small rotations: angle-axis differences
        }
        return true;
    }
    double st, sr;
};

}  // namespace

double processCpuSeconds() {
    double s = 0;
    for (int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
        rusage u{};
        getrusage(who, &u);
        s += u.ru_utime.tv_sec + u.ru_stime.tv_sec +
             1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
    }
    return s;
}

RefineSummary refineTrack(const ColmapModel& model, const std::vector<std::string>& names,
                          const Scene& frame0, const Matx33d& M, const Vec3d& c, double s,
                          double plane_tolerance, double smooth_sigma, CameraPath& path,
                          std::map<long long, Vec3d>* world_points) {
    RefineSummary sum;
    const Matx33d K = frame0.camera.K;
    // Poses of the registered frames (angle-axis, t).
    std::map<int, int> frame_of_image;  // COLMAP image id → video frame
    std::vector<std::array<double, 6>> poses(names.size());
    std::vector<bool> registered(names.size(), false);
    for (size_t i = 0; i < names.size(); ++i) {
        const ColmapImage* im = model.imageByName(names[i]);
        if (!im || path.frames[i].source != CameraPath::SFM) continue;
        frame_of_image[im->id] = (int)i;
        registered[i] = true;
        Vec3d rvec;
        Rodrigues(Mat(path.frames[i].R), rvec);
        poses[i] = {rvec[0],
                    rvec[1],
                    rvec[2],
                    path.frames[i].t[0],
                    path.frames[i].t[1],
                    path.frames[i].t[2]};
    }
    // Points in the world: X_w = Mᵀ (s X_sfm − c).
    std::map<long long, std::array<double, 3>> points;
    for (const auto& kv : model.points) {
        const Vec3d X = M.t() * (s * kv.second.xyz - c);
        points[kv.first] = {X[0], X[1], X[2]};
    }
    ceres::Problem problem;
    double se = 0;
    for (const auto& [image_id, frame] : frame_of_image) {
        const ColmapImage& im = model.images.at(image_id);
        for (size_t k = 0; k < im.xys.size(); ++k) {
            const long long id = im.point3d_ids[k];
            auto it = points.find(id);
            if (id < 0 || it == points.end()) continue;
            const Reprojection rep(im.xys[k].x - 0.5, im.xys[k].y - 0.5, K);
            double r[2];
            rep(poses[frame].data(), it->second.data(), r);
            se += r[0] * r[0] + r[1] * r[1];
            ++sum.observations;
            problem.AddResidualBlock(
                new ceres::AutoDiffCostFunction<Reprojection, 2, 6, 3>(new Reprojection(rep)),
                new ceres::HuberLoss(1.0), poses[frame].data(), it->second.data());
        }
    }
    if (sum.observations == 0) return sum;
    sum.rms_before = std::sqrt(se / sum.observations);
    // Points on the box faces.
    const Room& room = frame0.room;
    for (auto& [id, X] : points) {
        if (!problem.HasParameterBlock(X.data())) continue;
        ++sum.points;
        int best_axis = -1;
        double best_d = plane_tolerance, value = 0;
        for (int a = 0; a < 3; ++a)
            for (double v : {room.min[a], room.max[a]}) {
                const double d = std::abs(X[a] - v);
                if (d < best_d) best_d = d, best_axis = a, value = v;
            }
        if (best_axis < 0) continue;
        ++sum.plane_points;
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<OnPlane, 1, 3>(new OnPlane(best_axis, value, 0.01)),
            new ceres::HuberLoss(1.0), X.data());
    }
    // Optional smoothness on consecutive registered frames.
    if (smooth_sigma > 0) {
        for (size_t i = 2; i < names.size(); ++i)
            if (registered[i] && registered[i - 1] && registered[i - 2])
                // A Whittaker-style smoother: second differences cost more as the smoothing
                // width grows (σ ∝ 1/width², as for a smoothing spline of that width).
                problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Smooth, 6, 6, 6, 6>(
                                             new Smooth(0.002 / (smooth_sigma * smooth_sigma),
                                                        0.0005 / (smooth_sigma * smooth_sigma))),
                                         nullptr, poses[i - 2].data(), poses[i - 1].data(),
                                         poses[i].data());
    }
    if (registered[0]) problem.SetParameterBlockConstant(poses[0].data());  // the annotated frame
    ceres::Solver::Options opt;
    opt.linear_solver_type = ceres::SPARSE_SCHUR;
    opt.max_num_iterations = 50;
    opt.num_threads = 1;  // repeatable
    ceres::Solver::Summary summary;
    ceres::Solve(opt, &problem, &summary);
    sum.iterations = (int)summary.iterations.size();

    se = 0;
    for (const auto& [image_id, frame] : frame_of_image) {
        const ColmapImage& im = model.images.at(image_id);
        for (size_t k = 0; k < im.xys.size(); ++k) {
            auto it = points.find(im.point3d_ids[k]);
            if (im.point3d_ids[k] < 0 || it == points.end()) continue;
            double r[2];
            Reprojection(im.xys[k].x - 0.5, im.xys[k].y - 0.5, K)(poses[frame].data(),
                                                                  it->second.data(), r);
            se += r[0] * r[0] + r[1] * r[1];
        }
    }
    sum.rms_after = std::sqrt(se / sum.observations);
    if (world_points)
        for (const auto& [id, X] : points)
            if (problem.HasParameterBlock(X.data())) (*world_points)[id] = Vec3d(X[0], X[1], X[2]);
    for (size_t i = 0; i < names.size(); ++i) {
        if (!registered[i]) continue;
        Mat R;
        Rodrigues(Vec3d(poses[i][0], poses[i][1], poses[i][2]), R);
        path.frames[i].R = Matx33d(R);
        path.frames[i].t = Vec3d(poses[i][3], poses[i][4], poses[i][5]);
    }
    return sum;
}

namespace {

// Camera of a pose (angle-axis, t) with intrinsics K.
Camera cameraOf(const std::array<double, 6>& p, const Matx33d& K) {
    Camera c;
    c.K = K;
    Mat R;
    Rodrigues(Vec3d(p[0], p[1], p[2]), R);
    c.R = Matx33d(R);
    c.t = Vec3d(p[3], p[4], p[5]);
    return c;
}

// Reprojection error (pixels) of X in camera c at px; infinite behind the camera.
double reprojError(const Camera& c, const Vec3d& X, const Point2f& px) {
    const Vec3d p = c.R * X + c.t;
    if (p[2] <= 1e-6) return std::numeric_limits<double>::infinity();
    const double u = c.K(0, 0) * p[0] / p[2] + c.K(0, 2), v = c.K(1, 1) * p[1] / p[2] + c.K(1, 2);
    return std::hypot(u - px.x, v - px.y);
}

}  // namespace

GlobalRefineSummary refineAllFrames(const std::vector<CornerTrack>& tracks, const Scene& frame0,
                                    double plane_tolerance, const std::vector<bool>& posed,
                                    CameraPath& path) {
    GlobalRefineSummary sum;
    const Matx33d K = frame0.camera.K, Kinv = K.inv();
    const size_t n = path.frames.size();
    CV_Assert(posed.size() == n);
    std::vector<std::array<double, 6>> poses(n);
    std::vector<Camera> cams(n);
    for (size_t i = 0; i < n; ++i) {
        if (!posed[i]) continue;
        Vec3d rvec;
        Rodrigues(Mat(path.frames[i].R), rvec);
        const Vec3d& t = path.frames[i].t;
        poses[i] = {rvec[0], rvec[1], rvec[2], t[0], t[1], t[2]};
        cams[i] = cameraOf(poses[i], K);
    }
    // Points: DLT where the rays diverge enough, else on the room box.
    struct Obs {
        int frame;
        Point2f px;
    };
    std::vector<std::array<double, 3>> points;
    std::vector<std::vector<Obs>> obs;
    std::vector<double> sigma;
    const double min_angle = std::cos(1.0 * CV_PI / 180);
    for (const CornerTrack& tr : tracks) {
        std::vector<Obs> o;
        for (size_t k = 0; k < tr.frames.size(); ++k)
            if (posed[tr.frames[k]]) o.push_back({tr.frames[k], tr.px[k]});
        if (o.size() < 3) continue;
        std::vector<Vec3d> dirs;
        Mat A((int)o.size() * 2, 4, CV_64F);
        for (size_t k = 0; k < o.size(); ++k) {
            const Camera& c = cams[o[k].frame];
            const Vec3d x = Kinv * Vec3d(o[k].px.x, o[k].px.y, 1);
            dirs.push_back(normalize(c.R.t() * x));
            for (int r = 0; r < 2; ++r) {
                // x[r] (R_2 X + t_2) - (R_r X + t_r) = 0
                double* a = A.ptr<double>(2 * (int)k + r);
                for (int j = 0; j < 3; ++j)
                    a[j] = x[r] * c.R(2, j) - c.R(r, j);
                a[3] = x[r] * c.t[2] - c.t[r];
            }
        }
        double min_cos = 1;
        for (size_t k = 1; k < dirs.size(); ++k)
            min_cos = std::min(min_cos, dirs[0].dot(dirs[k]));
        Vec3d X;
        if (min_cos < min_angle) {
            Mat w, u, vt;
            SVD::compute(A, w, u, vt, SVD::MODIFY_A);
            const double h = vt.at<double>(3, 3);
            if (std::abs(h) < 1e-12) continue;
            X = Vec3d(vt.at<double>(3, 0), vt.at<double>(3, 1), vt.at<double>(3, 2)) / h;
        } else {
            const Camera& c = cams[o[0].frame];
            const double z = boxDepthAt(c, frame0.room, Point2d(o[0].px.x, o[0].px.y));
            if (!std::isfinite(z)) continue;
            X = c.R.t() * (z * (Kinv * Vec3d(o[0].px.x, o[0].px.y, 1)) - c.t);
        }
        std::vector<double> err;
        for (const Obs& b : o)
            err.push_back(reprojError(cams[b.frame], X, b.px));
        std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
        if (!(err[err.size() / 2] < 3.0)) continue;
        points.push_back({X[0], X[1], X[2]});
        obs.push_back(o);
        sigma.push_back(tr.sigma);
    }
    sum.points = (int)points.size();
    if (points.empty()) return sum;

    ceres::Problem problem;
    std::vector<std::vector<ceres::ResidualBlockId>> blocks(points.size());
    for (size_t p = 0; p < points.size(); ++p) {
        for (const Obs& b : obs[p]) {
            blocks[p].push_back(problem.AddResidualBlock(
                new ceres::AutoDiffCostFunction<Reprojection, 2, 6, 3>(
                    new Reprojection(b.px.x, b.px.y, K)),
                new ceres::ScaledLoss(new ceres::HuberLoss(sigma[p]), 1.0 / (sigma[p] * sigma[p]),
                                      ceres::TAKE_OWNERSHIP),
                poses[b.frame].data(), points[p].data()));
            ++sum.total_observations;
        }
        const Room& room = frame0.room;
        int best_axis = -1;
        double best_d = plane_tolerance, value = 0;
        for (int a = 0; a < 3; ++a)
            for (double v : {room.min[a], room.max[a]}) {
                const double d = std::abs(points[p][a] - v);
                if (d < best_d) best_d = d, best_axis = a, value = v;
            }
        if (best_axis < 0) continue;
        ++sum.plane_points;
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<OnPlane, 1, 3>(new OnPlane(best_axis, value, 0.01)),
            new ceres::HuberLoss(1.0), points[p].data());
    }
    if (posed[0]) problem.SetParameterBlockConstant(poses[0].data());
    ceres::Solver::Options opt;
    opt.linear_solver_type = ceres::SPARSE_SCHUR;
    opt.max_num_iterations = 30;
    opt.num_threads = 1;  // repeatable
    const double max_err = 2.0;
    std::vector<std::vector<bool>> inlier(points.size());
    for (int round = 0; round < 3; ++round) {
        ceres::Solver::Summary summary;
        ceres::Solve(opt, &problem, &summary);
        for (size_t i = 0; i < n; ++i)
            if (posed[i]) cams[i] = cameraOf(poses[i], K);
        // Remove the observations that stay far from their point's projection.
        bool removed = false;
        for (size_t p = 0; p < points.size(); ++p) {
            inlier[p].resize(obs[p].size(), true);
            const Vec3d X(points[p][0], points[p][1], points[p][2]);
            for (size_t k = 0; k < obs[p].size(); ++k) {
                if (!inlier[p][k]) continue;
                if (reprojError(cams[obs[p][k].frame], X, obs[p][k].px) > max_err) {
                    if (round < 2) problem.RemoveResidualBlock(blocks[p][k]);
                    inlier[p][k] = false;
                    removed = true;
                }
            }
        }
        if (!removed) break;
    }
    std::vector<double> frame_se(n, 0);
    std::vector<int> frame_count(n, 0);
    double se = 0;
    for (size_t p = 0; p < points.size(); ++p) {
        const Vec3d X(points[p][0], points[p][1], points[p][2]);
        for (size_t k = 0; k < obs[p].size(); ++k) {
            if (!inlier[p][k]) continue;
            const double e = reprojError(cams[obs[p][k].frame], X, obs[p][k].px);
            se += e * e;
            ++sum.observations;
            frame_se[obs[p][k].frame] += e * e;
            ++frame_count[obs[p][k].frame];
        }
    }
    sum.rms = sum.observations ? std::sqrt(se / sum.observations) : 0;
    // Points on a face of the room box at the end: a track that does not fit the annotated room
    // (a wrong focal length, a wrong box) leaves fewer of them there.
    int on_face = 0;
    std::vector<double> face_dist;
    for (const auto& X : points) {
        double best = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a)
            for (double v : {frame0.room.min[a], frame0.room.max[a]})
                best = std::min(best, std::abs(X[a] - v));
        on_face += best < plane_tolerance;
        face_dist.push_back(best);
    }
    sum.on_face_fraction = double(on_face) / points.size();
    std::nth_element(face_dist.begin(), face_dist.begin() + face_dist.size() / 2, face_dist.end());
    sum.median_face_distance = face_dist[face_dist.size() / 2];
    for (size_t i = 0; i < n; ++i)
        if (frame_count[i])
            sum.worst_frame_rms =
                std::max(sum.worst_frame_rms, std::sqrt(frame_se[i] / frame_count[i]));
    for (size_t i = 0; i < n; ++i) {
        if (!posed[i]) continue;
        path.frames[i].R = cams[i].R;
        path.frames[i].t = cams[i].t;
    }
    return sum;
}

}  // namespace detail
}  // namespace vbme
}  // namespace cv
