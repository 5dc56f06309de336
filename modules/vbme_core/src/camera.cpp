// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/camera.hpp"

#include <cmath>
#include <limits>
#include <mutex>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

Point2d imageCenter(Size size) {
    return Point2d((size.width - 1) * 0.5, (size.height - 1) * 0.5);
}

Camera Camera::fromFocal(double f, Size size) {
    Camera c;
    Point2d pp = imageCenter(size);
    c.K = Matx33d(f, 0, pp.x, 0, f, pp.y, 0, 0, 1);
    c.image_size = size;
    return c;
}

double Camera::focalFromFov(int width, double hfov_deg) {
    if (!(width > 0 && hfov_deg > 0 && hfov_deg < 180))
        CV_Error(Error::StsBadArg,
                 format("focalFromFov: width %d, field of view %g degrees; expected a positive "
                        "width and a field of view in (0, 180) degrees",
                        width, hfov_deg));
    return 0.5 * width / std::tan(0.5 * hfov_deg * CV_PI / 180.0);
}

Point2d Camera::project(const Vec3d& X_world, double* depth) const {
    Vec3d Xc = camFromWorld(X_world);
    if (depth) *depth = Xc[2];
    Vec3d p = K * Xc;
    return Point2d(p[0] / p[2], p[1] / p[2]);
}

Vec3d Camera::rayDirection(const Point2d& px) const {
    Vec3d d_cam = K.inv() * Vec3d(px.x, px.y, 1.0);
    return normalize(R.t() * d_cam);
}

Camera Camera::scaled(Size size) const {
    CV_Assert(image_size.width > 0 && image_size.height > 0);
    const double sx = double(size.width) / image_size.width;
    const double sy = double(size.height) / image_size.height;
    Camera c = *this;
    c.K(0, 0) *= sx;
    c.K(0, 1) *= sx;
    c.K(0, 2) = (K(0, 2) + 0.5) * sx - 0.5;
    c.K(1, 1) *= sy;
    c.K(1, 2) = (K(1, 2) + 0.5) * sy - 0.5;
    c.image_size = size;
    return c;
}

Point2d Camera::distortPixel(const Point2d& p) const {
    if (k1 == 0) return p;
    const Vec3d x = K.inv() * Vec3d(p.x, p.y, 1.0);
    const double s = 1 + k1 * (x[0] * x[0] + x[1] * x[1]);
    const Vec3d q = K * Vec3d(x[0] * s, x[1] * s, 1.0);
    return Point2d(q[0], q[1]);
}

Point2d Camera::undistortPixel(const Point2d& p) const {
    if (k1 == 0) return p;
    const Vec3d xd = K.inv() * Vec3d(p.x, p.y, 1.0);
    const double rd = std::hypot(xd[0], xd[1]);
    if (rd == 0) return p;
    // r (1 + k1 r²) = rd for r, within the monotonic branch (r² < 1 / (3 |k1|) when k1 < 0)
    const double r_max = k1 < 0 ? 1 / std::sqrt(3 * -k1) : std::numeric_limits<double>::infinity();
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (k1 < 0 && rd > r_max * (1 + k1 * r_max * r_max)) return Point2d(nan, nan);
    double r = std::min(rd, 0.999 * r_max);
    for (int it = 0; it < 50; ++it) {
        const double g = r * (1 + k1 * r * r) - rd, dg = 1 + 3 * k1 * r * r;
        if (!(dg > 0)) return Point2d(nan, nan);
        const double step = g / dg;
        r = std::min(std::max(r - step, 0.0), 0.999999 * r_max);
        if (std::abs(step) < 1e-14 * (1 + r)) break;
    }
    const double s = r / rd;
    const Vec3d q = K * Vec3d(xd[0] * s, xd[1] * s, 1.0);
    return Point2d(q[0], q[1]);
}

namespace {
// remap() maps: for each destination pixel, the source pixel f(p) (NaN → outside).
template <class F>
void pixelMaps(Size size, F f, Mat& mx, Mat& my) {
    mx.create(size, CV_32F);
    my.create(size, CV_32F);
    parallel_for_(Range(0, size.height), [&](const Range& rows) {
        for (int y = rows.start; y < rows.end; ++y) {
            float* px = mx.ptr<float>(y);
            float* py = my.ptr<float>(y);
            for (int x = 0; x < size.width; ++x) {
                const Point2d q = f(Point2d(x, y));
                const bool ok = std::isfinite(q.x) && std::isfinite(q.y);
                px[x] = ok ? (float)q.x : -1e6f;
                py[x] = ok ? (float)q.y : -1e6f;
            }
        }
    });
}

// The last maps of each direction, reused while K, k1, the other camera's K and the size stay (a
// video's frames, a render's layers). Fresh Mats on a change, so maps handed out before stay
// valid.
struct MapCache {
    std::mutex m;
    Matx33d K, K_other;
    double k1 = 0;
    Size size;
    Mat mx, my;
};

template <class F>
void cachedMaps(MapCache& c, const Camera& cam, const Matx33d& K_other, Size size, F f, Mat& mx,
                Mat& my) {
    std::lock_guard<std::mutex> lock(c.m);
    if (c.mx.empty() || c.k1 != cam.k1 || c.K != cam.K || c.K_other != K_other || c.size != size) {
        Mat nx, ny;
        pixelMaps(size, f, nx, ny);
        c.mx = nx;
        c.my = ny;
        c.K = cam.K;
        c.K_other = K_other;
        c.k1 = cam.k1;
        c.size = size;
    }
    mx = c.mx;
    my = c.my;
}
MapCache undistort_maps, distort_maps;

// Pixels of camera `from` as the same rays' pixels of camera `to` (same pose and focal lengths):
// the homography to · from⁻¹, inverted once per map rather than at every pixel; the identity
// when the K are equal, so the same-camera warps are unchanged.
struct ChangeK {
    bool identity;
    Matx33d H;
    ChangeK(const Matx33d& from, const Matx33d& to)
        : identity(from == to), H(identity ? Matx33d::eye() : Matx33d(to * from.inv())) {}
    Point2d operator()(const Point2d& p) const {
        if (identity) return p;
        const Vec3d q = H * Vec3d(p.x, p.y, 1.0);
        return Point2d(q[0] / q[2], q[1] / q[2]);
    }
};
}  // namespace

void undistortImageK1(InputArray distorted, OutputArray undistorted, const Camera& cam,
                      int interpolation, int border_mode) {
    Camera target = cam;
    target.image_size = distorted.size();
    undistortImageK1(distorted, undistorted, cam, target, interpolation, border_mode);
}

void undistortImageK1(InputArray distorted, OutputArray undistorted, const Camera& cam,
                      const Camera& target, int interpolation, int border_mode) {
    const Mat src = distorted.getMat();
    if (cam.k1 == 0 && target.K == cam.K && target.image_size == src.size()) {
        if (undistorted.getObj() != distorted.getObj()) src.copyTo(undistorted);
        return;
    }
    Mat mx, my;
    cachedMaps(
        undistort_maps, cam, target.K, target.image_size,
        [&, toCam = ChangeK(target.K, cam.K)](const Point2d& p) {
            return cam.distortPixel(toCam(p));
        },
        mx, my);
    Mat out;
    remap(src, out, mx, my, interpolation, border_mode);
    undistorted.assign(out);
}

void distortImageK1(InputArray undistorted, OutputArray distorted, const Camera& cam,
                    int interpolation) {
    Camera source = cam;
    source.image_size = undistorted.size();
    Camera c = cam;
    c.image_size = undistorted.size();
    distortImageK1(undistorted, distorted, c, source, interpolation);
}

void distortImageK1(InputArray undistorted, OutputArray distorted, const Camera& cam,
                    const Camera& source, int interpolation) {
    const Mat src = undistorted.getMat();
    if (cam.k1 == 0 && source.K == cam.K && cam.image_size == src.size()) {
        if (undistorted.getObj() != distorted.getObj()) src.copyTo(distorted);
        return;
    }
    CV_Assert(cam.image_size.area() > 0);
    Mat mx, my;
    cachedMaps(
        distort_maps, cam, source.K, cam.image_size,
        [&, toSource = ChangeK(cam.K, source.K)](const Point2d& p) {
            return toSource(cam.undistortPixel(p));
        },
        mx, my);
    Mat out;
    remap(src, out, mx, my, interpolation, BORDER_CONSTANT, Scalar::all(0));
    distorted.assign(out);
}

Camera lensCoverCamera(const Camera& cam) {
    if (cam.k1 >= 0) return cam;
    CV_Assert(cam.image_size.area() > 0);
    const int w = cam.image_size.width, h = cam.image_size.height;
    // The undistorted region of the frame is bounded by the undistorted frame border (the radial
    // map keeps the border outside); border pixels beyond the fold count at the fold's radius.
    const double r_fold = 1 / std::sqrt(3 * -cam.k1);
    const Matx33d Ki = cam.K.inv();
    double x0 = 0, y0 = 0, x1 = w - 1, y1 = h - 1;
    auto add = [&](double x, double y) {
        Point2d q = cam.undistortPixel(Point2d(x, y));
        if (!std::isfinite(q.x)) {  // beyond the fold: the same direction at the fold's radius
            const Vec3d n = Ki * Vec3d(x, y, 1.0);
            const double s = r_fold / std::hypot(n[0], n[1]);
            const Vec3d p = cam.K * Vec3d(n[0] * s, n[1] * s, 1.0);
            q = Point2d(p[0], p[1]);
        }
        x0 = std::min(x0, q.x);
        y0 = std::min(y0, q.y);
        x1 = std::max(x1, q.x);
        y1 = std::max(y1, q.y);
    };
    for (int x = 0; x < w; ++x) {
        add(x, 0);
        add(x, h - 1);
    }
    for (int y = 0; y < h; ++y) {
        add(0, y);
        add(w - 1, y);
    }
    const int pad = 2;  // the bilinear warp's neighbours
    const int left = std::max(0, (int)std::ceil(-x0) + pad),
              top = std::max(0, (int)std::ceil(-y0) + pad);
    const int right = std::max(0, (int)std::ceil(x1 - (w - 1)) + pad);
    const int bottom = std::max(0, (int)std::ceil(y1 - (h - 1)) + pad);
    Camera c = cam;
    c.K(0, 2) += left;
    c.K(1, 2) += top;
    c.image_size = Size(w + left + right, h + top + bottom);
    return c;
}

Matx44d Camera::camFromWorldMatrix() const {
    Matx44d M = Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            M(r, c) = R(r, c);
        M(r, 3) = t[r];
    }
    return M;
}

void Camera::write(FileStorage& fs) const {
    fs << "K" << Mat(K);
    fs << "R" << Mat(R);
    fs << "t" << Mat(t);
    fs << "response" << toString(response);
    if (k1 != 0) fs << "k1" << k1;
}

void Camera::read(const FileNode& node) {
    if (node.empty() || !node.isMap())
        CV_Error(Error::StsParseError, "camera: expected a map with K, R, t");
    K = Matx33d(readMatrix(node["K"], 3, 3, "camera.K"));
    if (!node["R"].empty()) R = Matx33d(readMatrix(node["R"], 3, 3, "camera.R"));
    if (!node["t"].empty()) t = Vec3d(readMatrix(node["t"], 3, 1, "camera.t"));
    if (!node["response"].empty()) response = parseResponse((std::string)node["response"]);
    k1 = 0;
    if (!node["k1"].empty()) {
        if (!node["k1"].isReal() && !node["k1"].isInt())
            CV_Error(Error::StsParseError, "camera.k1: expected a number");
        k1 = (double)node["k1"];
        if (!(std::abs(k1) < 10))
            CV_Error(Error::StsBadArg,
                     format("camera.k1: %g is not a plausible radial distortion coefficient "
                            "(expected |k1| < 10, in normalised coordinates x = K^-1 p)",
                            k1));
    }
    const double det = cv::determinant(Mat(R));
    if (std::abs(det - 1.0) > 1e-3)
        CV_Error(Error::StsBadArg,
                 format("camera.R: not a rotation (determinant %.6f, expected 1)", det));
    if (K(2, 2) == 0 || K(0, 0) <= 0 || K(1, 1) <= 0)
        CV_Error(Error::StsBadArg, "camera.K: focal lengths must be positive and K(2,2) = 1");
}

Matx33d orthonormalize(const Matx33d& R) {
    Mat w, u, vt;
    SVD::compute(Mat(R), w, u, vt);
    Mat Ro = u * vt;
    if (determinant(Ro) < 0) {
        u.col(2) *= -1;
        Ro = u * vt;
    }
    return Matx33d(Ro);
}

}  // namespace vbme
}  // namespace cv
