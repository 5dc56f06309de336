// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Scene builders shared by the vbme_render tests: meshes written as small OBJ files.
#ifndef VBME_TEST_RENDER_UTIL_HPP
#define VBME_TEST_RENDER_UTIL_HPP

#include <cmath>
#include <fstream>
#include <string>

#include <opencv2/vbme/render.hpp>

namespace vbme_test {

/** @brief Writes a UV sphere (radius 1 at the origin, outward normals, smooth vertex normals)
as OBJ; @p mtl names an MTL file to reference and @p usemtl a material in it (optional). */
inline void writeSphereObj(const std::string& path, int stacks = 48, int slices = 96,
                           const std::string& mtl = "", const std::string& usemtl = "") {
    std::ofstream f(path);
    if (!mtl.empty()) f << "mtllib " << mtl << "\n";
    if (!usemtl.empty()) f << "usemtl " << usemtl << "\n";
    const double pi = 3.14159265358979323846;
    for (int i = 0; i <= stacks; ++i) {
        const double th = pi * i / stacks;
        for (int j = 0; j <= slices; ++j) {
            const double ph = 2 * pi * j / slices;
            const double x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph),
                         z = std::cos(th);
            f << "v " << x << " " << y << " " << z << "\nvn " << x << " " << y << " " << z << "\n";
            f << "vt " << double(j) / slices << " " << 1.0 - double(i) / stacks << "\n";
        }
    }
    auto id = [&](int i, int j) { return i * (slices + 1) + j + 1; };
    for (int i = 0; i < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
            // counter-clockwise seen from outside
            if (i != 0)
                f << "f " << a << "/" << a << "/" << a << " " << b << "/" << b << "/" << b << " "
                  << d << "/" << d << "/" << d << "\n";
            if (i != stacks - 1)
                f << "f " << b << "/" << b << "/" << b << " " << c << "/" << c << "/" << c << " "
                  << d << "/" << d << "/" << d << "\n";
        }
}

/** @brief Writes an axis-aligned cube of side @p side (outward faces, flat) as OBJ: centred at
the origin, or with @p standing its bounding-box bottom centre at the origin (z from 0 to side),
as an object placed on a floor. */
inline void writeCubeObj(const std::string& path, const std::string& mtl = "",
                         const std::string& usemtl = "", double side = 1.0, bool standing = false) {
    std::ofstream f(path);
    if (!mtl.empty()) f << "mtllib " << mtl << "\n";
    if (!usemtl.empty()) f << "usemtl " << usemtl << "\n";
    const double h = side / 2, z0 = standing ? 0.0 : -h, z1 = standing ? side : h;
    for (int i = 0; i < 8; ++i)
        f << "v " << ((i & 1) ? h : -h) << " " << ((i & 2) ? h : -h) << " " << ((i & 4) ? z1 : z0)
          << "\n";
    // vertex index = 1 + x + 2y + 4z; faces counter-clockwise seen from outside
    f << "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
}

/** @brief A camera at @p eye looking at @p target with world z up (OpenCV axes). */
inline cv::vbme::Camera lookAt(const cv::Vec3d& eye, const cv::Vec3d& target, double f,
                               cv::Size size) {
    cv::vbme::Camera c = cv::vbme::Camera::fromFocal(f, size);
    const cv::Vec3d z = cv::normalize(target - eye);
    cv::Vec3d up(0, 0, 1);
    if (std::abs(z.dot(up)) > 0.999) up = cv::Vec3d(0, 1, 0);
    const cv::Vec3d x = cv::normalize(z.cross(up));  // image right
    const cv::Vec3d y = z.cross(x);                  // image down
    for (int k = 0; k < 3; ++k) {
        c.R(0, k) = x[k];
        c.R(1, k) = y[k];
        c.R(2, k) = z[k];
    }
    c.t = -(c.R * eye);
    return c;
}

/** @brief A 4×4 world_from_object of a uniform scale @p s and translation @p t. */
inline cv::Matx44d placement(double s, const cv::Vec3d& t) {
    return cv::Matx44d(s, 0, 0, t[0], 0, s, 0, t[1], 0, 0, s, t[2], 0, 0, 0, 1);
}

/** @brief A lambertian material. */
inline cv::vbme::Material lambertian(const cv::Vec3d& albedo) {
    cv::vbme::Material m;
    m.type = cv::vbme::Material::LAMBERTIAN;
    m.albedo = albedo;
    return m;
}

}  // namespace vbme_test

#endif
