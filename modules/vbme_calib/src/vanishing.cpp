// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Vanishing points, focal length and rotation from parallel-line groups; automatic
// Manhattan-frame detection from LSD segments.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lm.hpp"
#include "manhattan.hpp"
#include "opencv2/vbme/calib/frame_calibration.hpp"
#include "opencv2/vbme/core/params.hpp"

namespace cv {
namespace vbme {

AxisHint parseAxisHint(const std::string& name, const std::string& field) {
    std::string s = name;
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    if (s == "any" || s.empty()) return AxisHint::ANY;
    if (s == "horizontal") return AxisHint::HORIZONTAL;
    if (s == "vertical") return AxisHint::VERTICAL;
    CV_Error(Error::StsBadArg,
             field + ": unknown axis '" + name + "' (expected any, horizontal or vertical)");
}

std::string toString(AxisHint h) {
    switch (h) {
        case AxisHint::HORIZONTAL:
            return "horizontal";
        case AxisHint::VERTICAL:
            return "vertical";
        default:
            return "any";
    }
}

Camera FrameCalibration::camera() const {
    Camera c;
    c.K = K;
    c.R = R;
    c.image_size = image_size;
    return c;
}

namespace {

/** Unit homogeneous line through two points, scaled so that (a, b) is a unit normal. */
Vec3d lineThrough(const Vec3d& p, const Vec3d& q) {
    Vec3d l = p.cross(q);
    const double n = std::hypot(l[0], l[1]);
    return n > 0 ? l / n : l;
}

/** Signed distance of point @p p (pixels) to the line joining midpoint @p m and VP @p v. */
inline double vpLineDistance(const Vec2d& p, const Vec2d& m, const Vec3d& v) {
    // L = (m, 1) × v
    const double a = m[1] * v[2] - v[1];
    const double b = v[0] - m[0] * v[2];
    const double c = m[0] * v[1] - m[1] * v[0];
    const double n = std::hypot(a, b);
    if (n < 1e-300) return norm(p - m);
    return (a * p[0] + b * p[1] + c) / n;
}

/** A segment prepared for fitting: endpoints and midpoint in pixels, weight, world axis. */
struct FitSegment {
    Vec2d p1, p2, m;
    double w = 1;
    int axis = -1;
};

Vec3d normalizeHomogeneous(Vec3d v) {
    const double n = norm(v);
    if (n > 0) v /= n;
    if (v[2] < 0) v = -v;
    return v;
}

/** Refines rotation (and focal, principal point) so that every segment points at the
vanishing point `K D e_axis` of its axis. D's columns are directions in camera coordinates. */
void refineFrame(const std::vector<FitSegment>& segs, Matx33d& K, Matx33d& D, bool refine_f,
                 bool refine_pp) {
    if (segs.empty()) return;
    const int n = 3 + (refine_f ? 1 : 0) + (refine_pp ? 2 : 0);
    const int m = static_cast<int>(segs.size());
    if (m < n) return;  // not enough constraints to refine: keep the closed form
    const Matx33d K0 = K, D0 = D;
    auto build = [&](const Eigen::VectorXd& x, Matx33d& Kx, Matx33d& Dx) {
        Matx33d dR;
        Rodrigues(Vec3d(x[0], x[1], x[2]), dR);
        Dx = dR * D0;
        Kx = K0;
        int k = 3;
        if (refine_f) {
            const double f = K0(0, 0) * std::exp(x[k++]);
            Kx(0, 0) = Kx(1, 1) = f;
        }
        if (refine_pp) {
            Kx(0, 2) = K0(0, 2) + x[k++];
            Kx(1, 2) = K0(1, 2) + x[k++];
        }
    };
    auto residuals = [&](const Eigen::VectorXd& x, Eigen::VectorXd& r) {
        Matx33d Kx, Dx;
        build(x, Kx, Dx);
        Vec3d vp[3];
        for (int a = 0; a < 3; ++a)
            vp[a] = Kx * Vec3d(Dx(0, a), Dx(1, a), Dx(2, a));
        for (int i = 0; i < m; ++i) {
            const FitSegment& s = segs[i];
            r[i] = std::sqrt(s.w) * vpLineDistance(s.p1, s.m, vp[s.axis]);
        }
    };
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
    detail::levenbergMarquardt(residuals, x, m, 100);
    build(x, K, D);
}

double rmsDistance(const std::vector<FitSegment>& segs, const Matx33d& K, const Matx33d& D) {
    double s2 = 0;
    for (const auto& s : segs) {
        const Vec3d v = K * Vec3d(D(0, s.axis), D(1, s.axis), D(2, s.axis));
        const double d = vpLineDistance(s.p1, s.m, v);
        s2 += d * d;
    }
    return segs.empty() ? 0 : std::sqrt(s2 / segs.size());
}

/** Focal length (in the units of the coordinates) from vanishing points given relative to
the principal point: least squares of (x_i·x_j + f² w_i w_j) = 0 over all pairs. Returns f²
and the conditioning denominator. */
double focalSquaredLS(const std::vector<Vec3d>& u, double* denom) {
    double num = 0, den = 0;
    for (size_t i = 0; i < u.size(); ++i)
        for (size_t j = i + 1; j < u.size(); ++j) {
            const double p = u[i][0] * u[j][0] + u[i][1] * u[j][1];
            const double q = u[i][2] * u[j][2];
            num += p * q;
            den += q * q;
        }
    if (denom) *denom = den;
    return den > 0 ? -num / den : 0;
}

}  // namespace

Vec3d estimateVanishingPoint(const std::vector<Vec4d>& segments, const std::string& name) {
    const size_t n = segments.size();
    if (n < 2)
        CV_Error(Error::StsBadArg,
                 format("line group '%s' has %d segment(s); a vanishing point needs at least 2",
                        name.c_str(), (int)n));
    // Normalising similarity: centroid of the endpoints, RMS distance → sqrt(2).
    Vec2d c(0, 0);
    double total_len = 0;
    for (size_t i = 0; i < n; ++i) {
        const Vec4d& s = segments[i];
        const double len = std::hypot(s[2] - s[0], s[3] - s[1]);
        if (!(len > 1e-9) || !std::isfinite(len))
            CV_Error(Error::StsBadArg,
                     format("line group '%s': segment %d has zero length (both "
                            "endpoints at (%g, %g)); expected two distinct points",
                            name.c_str(), (int)i, s[0], s[1]));
        c += Vec2d(s[0] + s[2], s[1] + s[3]) * 0.5;
        total_len += len;
    }
    c /= double(n);
    // Collinearity: total least-squares line through all endpoints.
    Matx22d cov = Matx22d::zeros();
    for (const auto& s : segments)
        for (int e = 0; e < 2; ++e) {
            const Vec2d d(s[2 * e] - c[0], s[2 * e + 1] - c[1]);
            cov += d * d.t();
        }
    Matx21d ev;
    Matx22d evec;
    eigen(cov, ev, evec);
    const Vec2d normal(evec(1, 0), evec(1, 1));  // smallest eigenvalue's vector
    double max_off = 0, scale2 = 0;
    const double extent = std::sqrt(std::max(ev(0), 0.0) / (2.0 * n));
    for (const auto& s : segments)
        for (int e = 0; e < 2; ++e) {
            const Vec2d d(s[2 * e] - c[0], s[2 * e + 1] - c[1]);
            max_off = std::max(max_off, std::abs(d.dot(normal)));
            scale2 += d.dot(d);
        }
    if (max_off <= std::min(1.5, 0.01 * extent))
        CV_Error(Error::StsBadArg,
                 format("line group '%s': all %d segments lie on one image line, so their "
                        "vanishing point is undetermined; draw at least two distinct lines",
                        name.c_str(), (int)n));
    const double scale = std::sqrt(scale2 / (2.0 * n)) / std::sqrt(2.0);
    auto toN = [&](double x, double y) { return Vec3d((x - c[0]) / scale, (y - c[1]) / scale, 1); };

    Matx33d M = Matx33d::zeros();
    const double mean_len = total_len / n;
    for (const auto& s : segments) {
        const Vec3d l = lineThrough(toN(s[0], s[1]), toN(s[2], s[3]));
        const double w = std::hypot(s[2] - s[0], s[3] - s[1]) / mean_len;
        M += w * (l * l.t());
    }
    Matx31d evals;
    Matx33d evecs;
    eigen(M, evals, evecs);
    Vec3d v(evecs(2, 0), evecs(2, 1), evecs(2, 2));

    if (n > 2) {
        // Refine: endpoints' distances to the lines from each midpoint to the VP.
        std::vector<FitSegment> fs(n);
        for (size_t i = 0; i < n; ++i) {
            const Vec4d& s = segments[i];
            const Vec3d a = toN(s[0], s[1]), b = toN(s[2], s[3]);
            fs[i].p1 = Vec2d(a[0], a[1]);
            fs[i].p2 = Vec2d(b[0], b[1]);
            fs[i].m = (fs[i].p1 + fs[i].p2) * 0.5;
            fs[i].w = std::hypot(s[2] - s[0], s[3] - s[1]) / mean_len;
        }
        // Tangent basis at v.
        Vec3d e1 = std::abs(v[0]) < 0.9 ? Vec3d(1, 0, 0) : Vec3d(0, 1, 0);
        e1 = normalize(e1 - v * v.dot(e1));
        const Vec3d e2 = v.cross(e1);
        const Vec3d v0 = v;
        auto res = [&](const Eigen::VectorXd& x, Eigen::VectorXd& r) {
            const Vec3d vv = normalize(v0 + x[0] * e1 + x[1] * e2);
            for (size_t i = 0; i < n; ++i)
                r[i] = std::sqrt(fs[i].w) * vpLineDistance(fs[i].p1, fs[i].m, vv);
        };
        Eigen::VectorXd x = Eigen::VectorXd::Zero(2);
        detail::levenbergMarquardt(res, x, static_cast<int>(n), 50);
        v = normalize(v0 + x[0] * e1 + x[1] * e2);
    }
    // Back to pixels.
    const Vec3d vp(scale * v[0] + c[0] * v[2], scale * v[1] + c[1] * v[2], v[2]);
    return normalizeHomogeneous(vp);
}

double focalFromVanishingPoints(const Vec3d& v1, const Vec3d& v2, const Point2d& pp) {
    auto finite = [](const Vec3d& v) {
        return std::abs(v[2]) > 1e-12 * std::max(std::abs(v[0]), std::abs(v[1]));
    };
    if (!finite(v1) || !finite(v2))
        CV_Error(Error::StsBadArg,
                 "a vanishing point is at infinity (its lines are parallel in the image): the "
                 "focal length cannot be found from this pair; expected two finite points");
    const Vec2d a(v1[0] / v1[2] - pp.x, v1[1] / v1[2] - pp.y);
    const Vec2d b(v2[0] / v2[2] - pp.x, v2[1] / v2[2] - pp.y);
    const double f2 = -a.dot(b);
    if (!(f2 > 0))
        CV_Error(Error::StsBadArg,
                 format("vanishing points (%.1f, %.1f) and (%.1f, %.1f) are not those of "
                        "orthogonal directions for principal point (%.1f, %.1f): expected them on "
                        "opposite sides of it ((v1-c)·(v2-c) < 0), got %g",
                        a[0] + pp.x, a[1] + pp.y, b[0] + pp.x, b[1] + pp.y, pp.x, pp.y, -f2));
    return std::sqrt(f2);
}

Point2d orthocenter(const Point2d& a, const Point2d& b, const Point2d& c) {
    // Altitude from a ⟂ (c − b), from b ⟂ (c − a).
    const Point2d bc = c - b, ac = c - a;
    const double det = bc.x * ac.y - bc.y * ac.x;
    const double scale = std::max(norm(bc), 1.0) * std::max(norm(ac), 1.0);
    if (std::abs(det) < 1e-9 * scale)
        CV_Error(Error::StsBadArg,
                 "orthocenter: the three vanishing points are collinear; "
                 "expected a proper triangle");
    // Solve bc·H = bc·a, ac·H = ac·b.
    const double r1 = bc.dot(a), r2 = ac.dot(b);
    return Point2d((r1 * ac.y - r2 * bc.y) / det, (bc.x * r2 - ac.x * r1) / det);
}

Matx33d rotationFromDirections(const std::vector<Vec3d>& dirs, const std::vector<AxisHint>& hints,
                               std::vector<int>* axis_of) {
    const size_t n = dirs.size();
    if (n != 2 && n != 3)
        CV_Error(Error::StsBadArg,
                 format("rotationFromDirections: got %d directions, expected 2 or 3", (int)n));
    if (!hints.empty() && hints.size() != n)
        CV_Error(Error::StsBadArg, "rotationFromDirections: expected one hint per direction");
    std::vector<AxisHint> h(3, AxisHint::ANY);
    for (size_t i = 0; i < hints.size(); ++i)
        h[i] = hints[i];
    // Nearest orthonormal set to the measurements.
    Mat A((int)n, 3, CV_64F);
    for (size_t i = 0; i < n; ++i) {
        const Vec3d d = normalize(dirs[i]);
        for (int k = 0; k < 3; ++k)
            A.at<double>((int)i, k) = d[k];
    }
    Mat w, u, vt;
    SVD::compute(A, w, u, vt);
    if (w.at<double>((int)n - 1) < 1e-6)
        CV_Error(Error::StsBadArg,
                 "rotationFromDirections: the directions are parallel; "
                 "expected orthogonal ones");
    Mat O = u * vt;  // n × 3, orthonormal rows
    Vec3d c[3];
    for (size_t i = 0; i < n; ++i)
        c[i] = Vec3d(O.at<double>((int)i, 0), O.at<double>((int)i, 1), O.at<double>((int)i, 2));
    if (n == 2) {
        c[2] = c[0].cross(c[1]);
        const bool v0 = h[0] == AxisHint::VERTICAL, v1 = h[1] == AxisHint::VERTICAL;
        if (v0 || v1)
            h[2] = AxisHint::HORIZONTAL;
        else if (h[0] == AxisHint::HORIZONTAL && h[1] == AxisHint::HORIZONTAL)
            h[2] = AxisHint::VERTICAL;
    }
    int vert = -1, nvert = 0;
    for (int i = 0; i < 3; ++i)
        if (h[i] == AxisHint::VERTICAL) {
            vert = i;
            ++nvert;
        }
    if (nvert > 1)
        CV_Error(Error::StsBadArg,
                 "more than one line group is marked vertical; expected at "
                 "most one");
    if (vert < 0) {
        double best = -1;
        for (int i = 0; i < 3; ++i)
            if (h[i] != AxisHint::HORIZONTAL && std::abs(c[i][1]) > best) {
                best = std::abs(c[i][1]);
                vert = i;
            }
        if (vert < 0)
            CV_Error(Error::StsBadArg,
                     "three line groups are marked horizontal; at most two "
                     "world directions are horizontal");
    }
    Vec3d z = c[vert];
    if (z[1] > 0) z = -z;  // world up is image up (camera y points down)
    const int ha = (vert + 1) % 3, hb = (vert + 2) % 3;
    const int iy = std::abs(c[ha][2]) >= std::abs(c[hb][2]) ? ha : hb;
    const int ix = iy == ha ? hb : ha;
    Vec3d y = c[iy];
    if (y[2] < 0) y = -y;  // +y points away from the camera
    const Vec3d x = y.cross(z);
    Matx33d R;
    for (int k = 0; k < 3; ++k) {
        R(k, 0) = x[k];
        R(k, 1) = y[k];
        R(k, 2) = z[k];
    }
    if (axis_of) {
        axis_of->assign(n, 0);
        for (size_t i = 0; i < n; ++i)
            (*axis_of)[i] = (int)i == vert ? 2 : ((int)i == iy ? 1 : ((int)i == ix ? 0 : -1));
    }
    return orthonormalize(R);
}

void placeCamera(Camera& camera, double height) {
    if (!(height > 0) || !std::isfinite(height))
        CV_Error(Error::StsBadArg,
                 format("camera height %g: expected a positive height above the floor (metres)",
                        height));
    camera.t = -(camera.R * Vec3d(0, 0, height));
}

// ---------------------------------------------------------------------------------------------
// VanishingPointCalibrator

VanishingPointCalibrator::Params::Params() {}

void VanishingPointCalibrator::Params::read(const FileNode& node) {
    ParamsIn in(node, "vanishing-point parameters");
    in("focal", focal);
    if (const FileNode n = in.take("principal_point"); !n.empty()) {
        Mat p = readMatrix(n, 1, 2, "principal_point");
        principal_point = Point2d(p.at<double>(0), p.at<double>(1));
    }
    in("principal_point_from_orthocenter", principal_point_from_orthocenter);
    in("min_segment_length", min_segment_length);
    in("max_segments", max_segments);
    in("inlier_angle_deg", inlier_angle_deg);
    in("ransac_iterations", ransac_iterations);
    in("min_focal", min_focal);
    in("max_focal", max_focal);
    in("seed", seed);
    in("min_confidence", min_confidence);
    in.choice("method", method, {{"global", GLOBAL}, {"ransac", RANSAC}});
    in("focal_prior", focal_prior);
    in("focal_prior_sigma", focal_prior_sigma);
    in("estimate_distortion", estimate_distortion);
    in("fld_pass", fld_pass);
    in("fld_pass_below_confidence", fld_pass_below_confidence);
    in("edgel_scoring", edgel_scoring);
    in("pass_weight", pass_weight);
    in("upright_prior", upright_prior);
    in.finish();
    check();
}

void VanishingPointCalibrator::Params::check() const {
    const char* w = "vanishing-point parameters";
    checkParam(focal >= 0 && std::isfinite(focal), w, "focal", focal, ">= 0 pixels (0: estimate)");
    checkParam(min_segment_length >= 0, w, "min_segment_length", min_segment_length,
               ">= 0 pixels (0: 3 % of the diagonal)");
    checkParam(max_segments >= 3, w, "max_segments", max_segments, ">= 3");
    checkParam(inlier_angle_deg > 0 && inlier_angle_deg < 90, w, "inlier_angle_deg",
               inlier_angle_deg, "(0, 90) degrees");
    checkParam(ransac_iterations >= 1, w, "ransac_iterations", ransac_iterations, ">= 1");
    checkParam(min_focal > 0, w, "min_focal", min_focal, "> 0 (units of max(width, height))");
    checkParam(max_focal > min_focal, w, "max_focal", max_focal, "> min_focal");
    checkParam(min_confidence >= 0 && min_confidence <= 1, w, "min_confidence", min_confidence,
               "[0, 1]");
    checkParam(method == GLOBAL || method == RANSAC, w, "method", method,
               "GLOBAL (0) or RANSAC (1)");
    checkParam(focal_prior >= 0, w, "focal_prior", focal_prior, ">= 0 pixels (0: none)");
    checkParam(focal_prior_sigma > 0, w, "focal_prior_sigma", focal_prior_sigma, "> 0");
    checkParam(fld_pass_below_confidence >= 0 && std::isfinite(fld_pass_below_confidence), w,
               "fld_pass_below_confidence", fld_pass_below_confidence, ">= 0 (above 1: always)");
    checkParam(pass_weight >= 0 && std::isfinite(pass_weight), w, "pass_weight", pass_weight,
               ">= 0 (0: every segment alike)");
    checkParam(upright_prior >= 0 && std::isfinite(upright_prior), w, "upright_prior",
               upright_prior, ">= 0 degrees (0: off)");
}

void VanishingPointCalibrator::Params::write(FileStorage& fs) const {
    fs << "focal" << focal;
    fs << "principal_point"
       << "[:" << principal_point.x << principal_point.y << "]";
    fs << "principal_point_from_orthocenter" << (int)principal_point_from_orthocenter;
    fs << "min_segment_length" << min_segment_length << "max_segments" << max_segments;
    fs << "inlier_angle_deg" << inlier_angle_deg << "ransac_iterations" << ransac_iterations;
    fs << "min_focal" << min_focal << "max_focal" << max_focal << "seed" << seed;
    fs << "min_confidence" << min_confidence;
    fs << "method" << (method == RANSAC ? "ransac" : "global");
    fs << "focal_prior" << focal_prior << "focal_prior_sigma" << focal_prior_sigma;
    fs << "estimate_distortion" << (int)estimate_distortion;
    fs << "fld_pass" << (int)fld_pass << "fld_pass_below_confidence" << fld_pass_below_confidence;
    fs << "edgel_scoring" << (int)edgel_scoring;
    fs << "pass_weight" << pass_weight;
    fs << "upright_prior" << upright_prior;
}

Point2d undistortPointK1(const Point2d& p, double f, const Point2d& c, double k1) {
    if (!(f > 0)) CV_Error(Error::StsBadArg, "undistortPointK1: expected a positive focal length");
    const double xd = (p.x - c.x) / f, yd = (p.y - c.y) / f;
    double xu = xd, yu = yd;
    for (int it = 0; it < 20; ++it) {
        const double s = std::max(0.2, 1 + k1 * (xu * xu + yu * yu));
        xu = xd / s;
        yu = yd / s;
    }
    return Point2d(c.x + f * xu, c.y + f * yu);
}

Point2d distortPointK1(const Point2d& p, double f, const Point2d& c, double k1) {
    if (!(f > 0)) CV_Error(Error::StsBadArg, "distortPointK1: expected a positive focal length");
    const double x = (p.x - c.x) / f, y = (p.y - c.y) / f;
    const double s = 1 + k1 * (x * x + y * y);
    return Point2d(c.x + f * x * s, c.y + f * y * s);
}

std::vector<ManhattanProposal> detectManhattanProposals(
    InputArray image, const VanishingPointCalibrator::Params& params, int max_proposals) {
    VanishingPointCalibrator::Params p = params;
    p.method = VanishingPointCalibrator::Params::GLOBAL;
    return detail::proposeManhattan(detail::toGray8(image), p, max_proposals);
}

namespace {

class VanishingPointCalibratorImpl : public VanishingPointCalibrator {
public:
    explicit VanishingPointCalibratorImpl(const Params& p) : p_(p) {
        CV_Assert(p_.inlier_angle_deg > 0 && p_.ransac_iterations > 0 && p_.max_segments > 2);
        CV_Assert(p_.min_focal > 0 && p_.max_focal > p_.min_focal);
    }
    const Params& params() const override { return p_; }

    Point2d principalPoint(Size size) const {
        return p_.principal_point.x >= 0 && p_.principal_point.y >= 0 ? p_.principal_point
                                                                      : imageCenter(size);
    }

    FrameCalibration calibrate(const std::vector<LineGroup>& groups, Size size) const override {
        if (size.width <= 0 || size.height <= 0)
            CV_Error(Error::StsBadArg, "calibrate: expected a positive image size");
        if (groups.size() < 2)
            CV_Error(Error::StsBadArg,
                     format("got lines of %d direction(s); the focal length and rotation need "
                            "line groups for at least two orthogonal directions",
                            (int)groups.size()));
        if (groups.size() > 3)
            CV_Error(Error::StsBadArg,
                     format("got %d line groups; expected 2 or 3 (one per world axis)",
                            (int)groups.size()));
        const int n = (int)groups.size();
        std::vector<Vec3d> vps(n);
        for (int i = 0; i < n; ++i) {
            const std::string nm = groups[i].name.empty() ? format("#%d", i) : groups[i].name;
            vps[i] = estimateVanishingPoint(groups[i].segments, nm);
        }
        for (int i = 0; i < n; ++i)
            for (int j = i + 1; j < n; ++j)
                if (norm(vps[i].cross(vps[j])) < 1e-9)
                    CV_Error(Error::StsBadArg,
                             format("line groups '%s' and '%s' have the same vanishing point; "
                                    "expected lines of different world directions",
                                    groups[i].name.c_str(), groups[j].name.c_str()));
        // Principal point.
        Point2d pp = principalPoint(size);
        bool orthocentre = false;
        const double W = std::max(size.width, size.height);
        auto isFinite = [&](const Vec3d& v) {
            return std::abs(v[2]) * 1e3 * W > std::hypot(v[0], v[1]);
        };
        if (p_.principal_point_from_orthocenter && n == 3 && isFinite(vps[0]) && isFinite(vps[1]) &&
            isFinite(vps[2])) {
            pp = orthocenter(Point2d(vps[0][0] / vps[0][2], vps[0][1] / vps[0][2]),
                             Point2d(vps[1][0] / vps[1][2], vps[1][1] / vps[1][2]),
                             Point2d(vps[2][0] / vps[2][2], vps[2][1] / vps[2][2]));
            orthocentre = true;
        }
        // Focal length: least squares over the pairs, in units of W around pp.
        double f = p_.focal;
        if (f <= 0) {
            std::vector<Vec3d> u(n);
            for (int i = 0; i < n; ++i)
                u[i] = normalize(Vec3d((vps[i][0] - pp.x * vps[i][2]) / W,
                                       (vps[i][1] - pp.y * vps[i][2]) / W, vps[i][2]));
            double den = 0;
            const double f2 = focalSquaredLS(u, &den);
            int nfinite = 0;
            std::string inf_names;
            for (int i = 0; i < n; ++i) {
                if (std::abs(u[i][2]) > 1e-3)
                    ++nfinite;
                else
                    inf_names += (inf_names.empty() ? "'" : ", '") + groups[i].name + "'";
            }
            if (nfinite < 2)
                CV_Error(Error::StsBadArg,
                         "the vanishing point of line group(s) " + inf_names +
                             " is at infinity (the lines are parallel in the image), so the "
                             "focal length is undetermined; annotate a direction whose lines "
                             "converge, or give the focal length");
            if (!(f2 > 0))
                CV_Error(Error::StsBadArg,
                         "the vanishing points are not those of orthogonal directions (they lie "
                         "on the same side of the principal point, giving f² ≤ 0); check that "
                         "each line group holds lines of one world direction");
            f = std::sqrt(f2) * W;
            (void)den;
        }
        Matx33d K(f, 0, pp.x, 0, f, pp.y, 0, 0, 1);
        const Matx33d Kinv = K.inv();
        std::vector<Vec3d> dirs(n);
        std::vector<AxisHint> hints(n);
        for (int i = 0; i < n; ++i) {
            dirs[i] = normalize(Kinv * vps[i]);
            hints[i] = groups[i].axis;
        }
        std::vector<int> axis_of;
        Matx33d R = rotationFromDirections(dirs, hints, &axis_of);

        FrameCalibration out;
        out.image_size = size;
        std::vector<FitSegment> segs;
        double total_len = 0;
        for (int i = 0; i < n; ++i)
            for (const auto& s : groups[i].segments)
                total_len += std::hypot(s[2] - s[0], s[3] - s[1]);
        const double mean_len = total_len / std::max<size_t>(1, [&] {
                                    size_t c = 0;
                                    for (const auto& g : groups)
                                        c += g.segments.size();
                                    return c;
                                }());
        for (int i = 0; i < n; ++i)
            for (const auto& s : groups[i].segments) {
                FitSegment fs;
                fs.p1 = Vec2d(s[0], s[1]);
                fs.p2 = Vec2d(s[2], s[3]);
                fs.m = (fs.p1 + fs.p2) * 0.5;
                fs.w = std::hypot(s[2] - s[0], s[3] - s[1]) / mean_len;
                fs.axis = axis_of[i];
                segs.push_back(fs);
                out.segments.emplace_back((float)s[0], (float)s[1], (float)s[2], (float)s[3]);
                out.labels.push_back(axis_of[i]);
                out.support[axis_of[i]]++;
            }
        refineFrame(segs, K, R, p_.focal <= 0, orthocentre);
        R = orthonormalize(R);
        out.K = K;
        out.R = R;
        for (int a = 0; a < 3; ++a)
            out.vanishing_points[a] = normalizeHomogeneous(K * Vec3d(R(0, a), R(1, a), R(2, a)));
        out.rms_px = rmsDistance(segs, K, R);
        out.confidence = 1;
        return out;
    }

    void detectSegments(InputArray image, std::vector<Vec4f>& segments) const override {
        if (p_.method == Params::GLOBAL) {
            detail::detectSegmentsMerged(detail::toGray8(image), p_, segments);
            return;
        }
        const Mat gray = detail::toGray8(image);
        Ptr<LineSegmentDetector> lsd = createLineSegmentDetector(LSD_REFINE_STD);
        std::vector<Vec4f> raw;
        lsd->detect(gray, raw);
        const double diag = std::hypot(gray.cols, gray.rows);
        const double minlen = p_.min_segment_length > 0 ? p_.min_segment_length : 0.03 * diag;
        segments.clear();
        for (const auto& s : raw)
            if (std::hypot(s[2] - s[0], s[3] - s[1]) >= minlen) segments.push_back(s);
        std::stable_sort(segments.begin(), segments.end(), [](const Vec4f& a, const Vec4f& b) {
            return std::hypot(a[2] - a[0], a[3] - a[1]) > std::hypot(b[2] - b[0], b[3] - b[1]);
        });
        if ((int)segments.size() > p_.max_segments) segments.resize(p_.max_segments);
    }

    FrameCalibration detect(InputArray image) const override {
        const Size size = image.size();
        if (p_.method == Params::GLOBAL) {
            FrameCalibration out =
                detail::proposeManhattan(detail::toGray8(image), p_, 1)[0].calibration;
            if (out.confidence < p_.min_confidence)
                CV_Error(Error::StsError,
                         format("automatic detection is not confident (%.2f < %.2f: %d/%d/%d "
                                "segments per direction); annotate the lines by hand",
                                out.confidence, p_.min_confidence, out.support[0], out.support[1],
                                out.support[2]));
            return out;
        }
        std::vector<Vec4f> segs;
        detectSegments(image, segs);
        const int n = (int)segs.size();
        if (n < 6)
            CV_Error(Error::StsError,
                     format("automatic detection found only %d line segments; expected at least "
                            "6 (annotate the lines by hand)",
                            n));
        const double W = std::max(size.width, size.height);
        const Point2d pp = principalPoint(size);
        // Normalised coordinates: (x − pp) / W.
        struct S {
            Vec3d l;
            Vec2d m, u;
            double len;
        };
        std::vector<S> sn(n);
        std::vector<double> cum(n);
        double total = 0;
        for (int i = 0; i < n; ++i) {
            const Vec4f& s = segs[i];
            const Vec3d a((s[0] - pp.x) / W, (s[1] - pp.y) / W, 1),
                b((s[2] - pp.x) / W, (s[3] - pp.y) / W, 1);
            sn[i].l = lineThrough(a, b);
            sn[i].m = Vec2d((a[0] + b[0]) / 2, (a[1] + b[1]) / 2);
            sn[i].u = normalize(Vec2d(b[0] - a[0], b[1] - a[1]));
            sn[i].len = std::hypot(s[2] - s[0], s[3] - s[1]);
            total += sn[i].len;
            cum[i] = total;
        }
        const double sin_thr = std::sin(p_.inlier_angle_deg * CV_PI / 180);
        auto angleSin = [&](const S& s, const Vec3d& v) {
            const double tx = v[0] - s.m[0] * v[2], ty = v[1] - s.m[1] * v[2];
            const double tn = std::hypot(tx, ty);
            if (tn < 1e-12) return 1.0;
            return std::abs(s.u[0] * ty - s.u[1] * tx) / tn;
        };
        auto score = [&](const Vec3d* V, std::vector<int>* labels) {
            double sc = 0;
            for (int i = 0; i < n; ++i) {
                double best = sin_thr;
                int ba = -1;
                for (int a = 0; a < 3; ++a) {
                    const double sa = angleSin(sn[i], V[a]);
                    if (sa < best) {
                        best = sa;
                        ba = a;
                    }
                }
                if (ba >= 0) sc += sn[i].len * (1 - (best / sin_thr) * (best / sin_thr));
                if (labels) (*labels)[i] = ba;
            }
            return sc;
        };
        RNG rng((uint64)(0x9e3779b97f4a7c15ull ^ (uint64)(p_.seed + 1)));
        auto pick = [&]() {
            const double r = rng.uniform(0.0, total);
            return int(std::lower_bound(cum.begin(), cum.end(), r) - cum.begin()) % n;
        };
        const bool known_f = p_.focal > 0;
        const double fk = p_.focal / W;
        double best_score = -1, best_f = 0;
        Matx33d bestD;
        for (int it = 0; it < p_.ransac_iterations; ++it) {
            const int i = pick(), j = pick();
            if (i == j) continue;
            const Vec3d v1 = sn[i].l.cross(sn[j].l);
            if (norm(v1) < 1e-12) continue;
            double f;
            Vec3d d1, d2;
            if (known_f) {
                const int k = pick();
                if (k == i || k == j) continue;
                f = fk;
                d1 = normalize(Vec3d(v1[0] / f, v1[1] / f, v1[2]));
                const Vec3d nk(sn[k].l[0] * f, sn[k].l[1] * f, sn[k].l[2]);  // K^T l
                d2 = d1.cross(nk);
                if (norm(d2) < 1e-9) continue;
                d2 = normalize(d2);
            } else {
                const int k = pick(), l = pick();
                if (k == l || k == i || k == j || l == i || l == j) continue;
                const Vec3d v2 = sn[k].l.cross(sn[l].l);
                const Vec3d a = normalize(v1), b = normalize(v2);
                if (std::abs(a[2]) < 1e-6 || std::abs(b[2]) < 1e-6) continue;
                const double f2 = -(a[0] * b[0] + a[1] * b[1]) / (a[2] * b[2]);
                if (!(f2 > p_.min_focal * p_.min_focal && f2 < p_.max_focal * p_.max_focal))
                    continue;
                f = std::sqrt(f2);
                d1 = normalize(Vec3d(a[0] / f, a[1] / f, a[2]));
                d2 = normalize(Vec3d(b[0] / f, b[1] / f, b[2]));
            }
            const Vec3d d3 = d1.cross(d2);
            Vec3d V[3] = {Vec3d(f * d1[0], f * d1[1], d1[2]), Vec3d(f * d2[0], f * d2[1], d2[2]),
                          Vec3d(f * d3[0], f * d3[1], d3[2])};
            const double sc = score(V, nullptr);
            if (sc > best_score) {
                best_score = sc;
                best_f = f;
                for (int r = 0; r < 3; ++r) {
                    bestD(r, 0) = d1[r];
                    bestD(r, 1) = d2[r];
                    bestD(r, 2) = d3[r];
                }
            }
        }
        if (best_score <= 0)
            CV_Error(Error::StsError,
                     "automatic detection found no pair of orthogonal vanishing points with a "
                     "plausible focal length; annotate the lines by hand or give the focal length");
        // Refine on inliers, re-label, refine again (pixel coordinates).
        Matx33d K(best_f * W, 0, pp.x, 0, best_f * W, pp.y, 0, 0, 1);
        Matx33d D = bestD;
        std::vector<int> labels(n, -1);
        std::vector<FitSegment> fit;
        const double mean_len = total / n;
        for (int round = 0; round < 3; ++round) {
            // labels from the current model (normalised coordinates)
            const double f = K(0, 0) / W;
            Vec3d V[3];
            for (int a = 0; a < 3; ++a)
                V[a] = Vec3d(f * D(0, a) + (K(0, 2) - pp.x) / W * D(2, a),
                             f * D(1, a) + (K(1, 2) - pp.y) / W * D(2, a), D(2, a));
            score(V, &labels);
            fit.clear();
            for (int i = 0; i < n; ++i) {
                if (labels[i] < 0) continue;
                FitSegment fs;
                fs.p1 = Vec2d(segs[i][0], segs[i][1]);
                fs.p2 = Vec2d(segs[i][2], segs[i][3]);
                fs.m = (fs.p1 + fs.p2) * 0.5;
                fs.w = sn[i].len / mean_len;
                fs.axis = labels[i];
                fit.push_back(fs);
            }
            if (round < 2) refineFrame(fit, K, D, !known_f, false);
        }
        int support[3] = {0, 0, 0};
        double support_len[3] = {0, 0, 0}, inlier_len = 0;
        for (int i = 0; i < n; ++i)
            if (labels[i] >= 0) {
                support[labels[i]]++;
                support_len[labels[i]] += sn[i].len;
                inlier_len += sn[i].len;
            }
        int order[3] = {0, 1, 2};
        std::sort(order, order + 3, [&](int a, int b) { return support[a] > support[b]; });
        if (support[order[1]] < 3)
            CV_Error(Error::StsError,
                     format("automatic detection found only one line direction (%d segments; "
                            "the next has %d); expected at least two orthogonal directions",
                            support[order[0]], support[order[1]]));
        const double fK = K(0, 0);
        if (fK < p_.min_focal * W || fK > p_.max_focal * W)
            CV_Error(Error::StsError,
                     format("automatic detection gave an implausible focal length %.1f px "
                            "(expected %.0f–%.0f); annotate the lines by hand",
                            fK, p_.min_focal * W, p_.max_focal * W));
        // DESIGN axes.
        std::vector<Vec3d> dirs(3);
        for (int a = 0; a < 3; ++a)
            dirs[a] = Vec3d(D(0, a), D(1, a), D(2, a));
        std::vector<int> axis_of;
        Matx33d R = rotationFromDirections(dirs, {}, &axis_of);
        FrameCalibration out;
        out.image_size = size;
        out.K = K;
        out.R = R;
        out.segments = segs;
        out.labels.resize(n);
        for (int i = 0; i < n; ++i)
            out.labels[i] = labels[i] < 0 ? -1 : axis_of[labels[i]];
        for (int a = 0; a < 3; ++a)
            out.support[axis_of[a]] = support[a];
        for (auto& fs : fit)
            fs.axis = axis_of[fs.axis];
        for (int a = 0; a < 3; ++a)
            out.vanishing_points[a] = normalizeHomogeneous(K * Vec3d(R(0, a), R(1, a), R(2, a)));
        out.rms_px = rmsDistance(fit, K, R);
        const double frac = inlier_len / total;
        const double second = support_len[order[1]] / total;
        out.confidence = std::min(1.0, frac) * std::min(1.0, second / 0.1) *
                         std::min(1.0, support[order[1]] / 4.0);
        if (out.confidence < p_.min_confidence)
            CV_Error(Error::StsError,
                     format("automatic detection is not confident (%.2f < %.2f: %.0f %% of the "
                            "segments' length explained, %d/%d/%d segments per direction); "
                            "annotate the lines by hand",
                            out.confidence, p_.min_confidence, 100 * frac, support[0], support[1],
                            support[2]));
        return out;
    }

private:
    Params p_;
};

}  // namespace

Ptr<VanishingPointCalibrator> VanishingPointCalibrator::create(const Params& params) {
    return makePtr<VanishingPointCalibratorImpl>(params);
}

}  // namespace vbme
}  // namespace cv
