// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/track/shape.hpp"

#include <cmath>

namespace cv {
namespace vbme {

void sphereHeightMap(Size size, const Disk& d, OutputArray _height) {
    _height.create(size, CV_32F);
    Mat h = _height.getMat();
    const float r2 = d.radius * d.radius;
    for (int y = 0; y < size.height; ++y) {
        float* p = h.ptr<float>(y);
        const float dy = y - d.center.y;
        for (int x = 0; x < size.width; ++x) {
            const float dx = x - d.center.x;
            const float q = r2 - dx * dx - dy * dy;
            p[x] = q >= 0 ? std::sqrt(q) : 0.f;
        }
    }
}

void heightToNormals(InputArray _height, InputArray _mask, OutputArray _normals, int method) {
    Mat h = _height.getMat(), mask = _mask.getMat();
    CV_Assert(h.type() == CV_32F);
    CV_Assert(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == h.size()));
    CV_Assert(method == NORMALS_FORWARD || method == NORMALS_CENTRAL);
    _normals.create(h.size(), CV_32FC3);
    Mat n = _normals.getMat();
    n.setTo(Scalar::all(0));
    auto inside = [&](int x, int y) {
        if (x < 0 || y < 0 || x >= h.cols || y >= h.rows) return false;
        return mask.empty() ? h.at<float>(y, x) > 0 : mask.at<uchar>(y, x) != 0;
    };
    // Derivative along one axis at (x, y): the chosen scheme where both neighbours it needs
    // exist, else the one-sided difference that does.
    auto deriv = [&](int x, int y, int ax, int ay) -> float {
        const float c = h.at<float>(y, x);
        const bool fwd = inside(x + ax, y + ay), bwd = inside(x - ax, y - ay);
        if (method == NORMALS_CENTRAL && fwd && bwd)
            return 0.5f * (h.at<float>(y + ay, x + ax) - h.at<float>(y - ay, x - ax));
        if (fwd) return h.at<float>(y + ay, x + ax) - c;
        if (bwd) return c - h.at<float>(y - ay, x - ax);
        return 0.f;
    };
    for (int y = 0; y < h.rows; ++y)
        for (int x = 0; x < h.cols; ++x) {
            if (!inside(x, y)) continue;
            const float hx = deriv(x, y, 1, 0), hy = deriv(x, y, 0, 1);
            // Surface z = −h(x, y) in the camera frame: normal ∝ (−h_x, −h_y, −1).
            Vec3f v(-hx, -hy, -1.f);
            n.at<Vec3f>(y, x) = v * (1.f / (float)norm(v));
        }
}

void sphereNormals(Size size, const Disk& d, OutputArray _normals) {
    _normals.create(size, CV_32FC3);
    Mat n = _normals.getMat();
    const float r2 = d.radius * d.radius;
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            const float dx = x - d.center.x, dy = y - d.center.y, q = r2 - dx * dx - dy * dy;
            n.at<Vec3f>(y, x) =
                q >= 0 ? Vec3f(dx, dy, -std::sqrt(q)) * (1.f / d.radius) : Vec3f(0, 0, 0);
        }
}

void normalMapImage(InputArray _normals, OutputArray _image) {
    Mat n = _normals.getMat();
    CV_Assert(n.type() == CV_32FC3);
    _image.create(n.size(), CV_8UC3);
    Mat img = _image.getMat();
    for (int y = 0; y < n.rows; ++y)
        for (int x = 0; x < n.cols; ++x) {
            const Vec3f v = n.at<Vec3f>(y, x);
            if (v == Vec3f(0, 0, 0)) {
                img.at<Vec3b>(y, x) = Vec3b(0, 0, 0);
                continue;
            }
            const float r = (v[0] + 1) * 0.5f, g = (-v[1] + 1) * 0.5f, b = (-v[2] + 1) * 0.5f;
            img.at<Vec3b>(y, x) =
                Vec3b(saturate_cast<uchar>(b * 255), saturate_cast<uchar>(g * 255),
                      saturate_cast<uchar>(r * 255));
        }
}

}  // namespace vbme
}  // namespace cv
