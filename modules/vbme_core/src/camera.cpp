// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/camera.hpp"

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
}

void Camera::read(const FileNode& node) {
    if (node.empty() || !node.isMap())
        CV_Error(Error::StsParseError, "camera: expected a map with K, R, t");
    K = Matx33d(readMatrix(node["K"], 3, 3, "camera.K"));
    if (!node["R"].empty()) R = Matx33d(readMatrix(node["R"], 3, 3, "camera.R"));
    if (!node["t"].empty()) t = Vec3d(readMatrix(node["t"], 3, 1, "camera.t"));
    if (!node["response"].empty()) response = parseResponse((std::string)node["response"]);
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
