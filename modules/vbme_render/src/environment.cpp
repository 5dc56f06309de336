// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Equirectangular environment maps (Blender's orientation) with importance sampling, and the
// image-disk → two-hemispheres environment for material editing.
#include "opencv2/vbme/render/environment.hpp"

#include <Imath/ImathBox.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/fileio.hpp"
#include "sampling.hpp"

namespace cv {
namespace vbme {

using sampling::kInv2Pi;
using sampling::kPi;

namespace {

inline float luminance(const Vec3f& rgb) {
    return 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2];
}

// Direction in the map's frame → normalised image coordinates (u right, v down) in [0,1).
inline Vec2f directionToUv(const Vec3f& d) {
    float u = 0.5f - std::atan2(d[1], d[0]) * kInv2Pi;
    if (u >= 1.f) u -= 1.f;
    if (u < 0.f) u += 1.f;
    const float v = std::acos(std::min(std::max(d[2], -1.f), 1.f)) / kPi;
    return Vec2f(u, v);
}
// Normalised image coordinates → unit direction in the map's frame.
inline Vec3f uvToDirection(float u, float v) {
    const float phi = (0.5f - u) * 2.f * kPi;
    const float theta = v * kPi;
    const float st = std::sin(theta);
    return Vec3f(st * std::cos(phi), st * std::sin(phi), std::cos(theta));
}

// Reads an OpenEXR file's R, G, B (or Y) channels as linear CV_32FC3 BGR.
Mat readExr(const std::string& path) {
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i dw = file.header().dataWindow();
        const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        const Imf::ChannelList& ch = file.header().channels();
        const bool rgb = ch.findChannel("R") && ch.findChannel("G") && ch.findChannel("B");
        const bool lum = ch.findChannel("Y") != nullptr;
        if (!rgb && !lum)
            CV_Error(Error::StsBadArg, "environment image '" + path +
                                           "' has neither R, G, B nor Y channels (expected an "
                                           "RGB OpenEXR image)");
        Mat img(h, w, CV_32FC3);
        Imf::FrameBuffer fb;
        const size_t xs = sizeof(float) * 3, ys = xs * w;
        char* base = (char*)img.data - (dw.min.x * (ptrdiff_t)xs + dw.min.y * (ptrdiff_t)ys);
        if (rgb) {
            fb.insert("B", Imf::Slice(Imf::FLOAT, base, xs, ys, 1, 1, 0.0));
            fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys, 1, 1, 0.0));
            fb.insert("R", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys, 1, 1, 0.0));
            file.setFrameBuffer(fb);
            file.readPixels(dw.min.y, dw.max.y);
        } else {
            Mat y(h, w, CV_32FC1);
            char* yb = (char*)y.data - (dw.min.x * (ptrdiff_t)sizeof(float) +
                                        dw.min.y * (ptrdiff_t)sizeof(float) * w);
            fb.insert("Y", Imf::Slice(Imf::FLOAT, yb, sizeof(float), sizeof(float) * w, 1, 1, 0.0));
            file.setFrameBuffer(fb);
            file.readPixels(dw.min.y, dw.max.y);
            cvtColor(y, img, COLOR_GRAY2BGR);
        }
        return img;
    } catch (const cv::Exception&) {
        throw;
    } catch (const std::exception& e) {
        CV_Error(Error::StsError,
                 "cannot read OpenEXR environment image '" + path + "': " + e.what());
    }
}

}  // namespace

struct EnvironmentMap::Impl {
    bool constant = true;
    Vec3f radiance;  // constant environment
    Mat rgb;         // CV_32FC3, RGB, scaled
    Matx33f world_from_env, env_from_world;
    sampling::Distribution2D dist;

    // Bilinear lookup at normalised (u, v), wrapping around in u and clamping in v.
    Vec3f lookup(const Vec2f& uv) const {
        const int w = rgb.cols, h = rgb.rows;
        const float px = uv[0] * w - 0.5f, py = uv[1] * h - 0.5f;
        const float fx0 = std::floor(px), fy0 = std::floor(py);
        const float ax = px - fx0, ay = py - fy0;
        int x0 = (int)fx0 % w;
        if (x0 < 0) x0 += w;
        const int x1 = (x0 + 1) % w;
        const int y0 = std::min(std::max((int)fy0, 0), h - 1);
        const int y1 = std::min(std::max((int)fy0 + 1, 0), h - 1);
        const Vec3f* r0 = rgb.ptr<Vec3f>(y0);
        const Vec3f* r1 = rgb.ptr<Vec3f>(y1);
        return (r0[x0] * (1.f - ax) + r0[x1] * ax) * (1.f - ay) +
               (r1[x0] * (1.f - ax) + r1[x1] * ax) * ay;
    }
};

EnvironmentMap::EnvironmentMap(const Mat& equirect, const Matx33f& world_from_env, float scale)
    : impl_(new Impl) {
    CV_Assert(!equirect.empty() && "EnvironmentMap: the equirectangular image is empty");
    CV_Assert(equirect.channels() == 3 &&
              "EnvironmentMap: expected a 3-channel (BGR) equirectangular image");
    CV_Assert(scale >= 0.f && std::isfinite(scale) && "EnvironmentMap: scale must be >= 0");
    Impl& m = *impl_;
    m.constant = false;
    m.world_from_env = world_from_env;
    m.env_from_world = world_from_env.t();
    Mat f;
    equirect.convertTo(f, CV_32F, scale);
    cvtColor(f, m.rgb, COLOR_BGR2RGB);
    // Non-finite or negative radiance would poison the distribution: clamp to [0, max float).
    patchNaNs(m.rgb, 0.0);
    m.rgb = max(m.rgb, 0.0);
    m.rgb = min(m.rgb, (double)std::numeric_limits<float>::max());

    // Sampling weights: luminance·sin θ. Eval is bilinear, so a pixel's cell receives radiance
    // from its 3×3 neighbourhood: the weight is the mean of the pixel's luminance and the
    // neighbourhood's maximum, non-zero wherever the bilinear radiance is.
    const int w = m.rgb.cols, h = m.rgb.rows;
    Mat lum(h, w, CV_32FC1);
    for (int y = 0; y < h; y++) {
        const Vec3f* p = m.rgb.ptr<Vec3f>(y);
        float* l = lum.ptr<float>(y);
        for (int x = 0; x < w; x++)
            l[x] = luminance(p[x]);
    }
    Mat lum_max;
    Mat padded;
    copyMakeBorder(lum, padded, 1, 1, 1, 1, BORDER_REPLICATE);
    if (w > 1) {  // wrap around horizontally
        lum.col(w - 1).copyTo(padded(Rect(0, 1, 1, h)));
        lum.col(0).copyTo(padded(Rect(w + 1, 1, 1, h)));
    }
    dilate(padded, lum_max, Mat::ones(3, 3, CV_8U));
    lum_max = lum_max(Rect(1, 1, w, h));
    Mat weight(h, w, CV_32FC1);
    for (int y = 0; y < h; y++) {
        const float st = std::sin(kPi * (y + 0.5f) / h);
        const float* a = lum.ptr<float>(y);
        const float* b = lum_max.ptr<float>(y);
        float* o = weight.ptr<float>(y);
        for (int x = 0; x < w; x++)
            o[x] = 0.5f * (a[x] + b[x]) * st;
    }
    m.dist.build(weight);
}

EnvironmentMap::EnvironmentMap(const Vec3f& radiance) : impl_(new Impl) {
    impl_->constant = true;
    impl_->radiance = radiance;
    impl_->world_from_env = impl_->env_from_world = Matx33f::eye();
}

EnvironmentMap EnvironmentMap::load(const std::string& path, const Matx33f& world_from_env,
                                    float scale) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    Mat img;
    if (ext == ".exr") {
        if (!std::filesystem::exists(path))
            CV_Error(Error::StsObjectNotFound, "environment image '" + path + "' does not exist");
        img = readExr(path);
    } else {
        img = imreadChecked(path, IMREAD_UNCHANGED);
        if (img.channels() == 1) cvtColor(img, img, COLOR_GRAY2BGR);
        if (img.channels() == 4) cvtColor(img, img, COLOR_BGRA2BGR);
        if (img.depth() != CV_32F && img.depth() != CV_64F)
            CV_Error(Error::StsBadArg, "environment image '" + path +
                                           "' is not a floating-point HDR image (expected .hdr "
                                           "or .exr with linear radiance)");
    }
    return EnvironmentMap(img, world_from_env, scale);
}

EnvironmentMap::~EnvironmentMap() = default;
EnvironmentMap::EnvironmentMap(EnvironmentMap&&) noexcept = default;
EnvironmentMap& EnvironmentMap::operator=(EnvironmentMap&&) noexcept = default;
EnvironmentMap::EnvironmentMap(const EnvironmentMap& other) : impl_(new Impl(*other.impl_)) {}
EnvironmentMap& EnvironmentMap::operator=(const EnvironmentMap& other) {
    if (this != &other) impl_.reset(new Impl(*other.impl_));
    return *this;
}

bool EnvironmentMap::isConstant() const {
    return impl_->constant;
}

Vec3f EnvironmentMap::eval(const Vec3f& dir) const {
    const Impl& m = *impl_;
    if (m.constant) return m.radiance;
    return m.lookup(directionToUv(m.env_from_world * dir));
}

float EnvironmentMap::pdf(const Vec3f& dir) const {
    const Impl& m = *impl_;
    if (m.constant) return sampling::kInv4Pi;
    const Vec3f d = m.env_from_world * dir;
    const float sin_theta = std::sqrt(std::max(0.f, 1.f - d[2] * d[2]));
    if (sin_theta <= 0.f) return 0.f;
    return m.dist.pdf(directionToUv(d)) / (2.f * kPi * kPi * sin_theta);
}

Vec3f EnvironmentMap::sample(const Vec2f& u, Vec3f& dir, float& pdf) const {
    const Impl& m = *impl_;
    if (m.constant) {
        dir = sampling::squareToUniformSphere(u);
        pdf = sampling::kInv4Pi;
        return m.radiance;
    }
    float pdf_uv;
    const Vec2f uv = m.dist.sampleContinuous(u, pdf_uv);
    const Vec3f d = uvToDirection(uv[0], uv[1]);
    const float sin_theta = std::sin(uv[1] * kPi);
    dir = m.world_from_env * d;
    if (!(pdf_uv > 0.f) || sin_theta <= 0.f) {
        pdf = 0.f;
        return Vec3f(0, 0, 0);
    }
    pdf = pdf_uv / (2.f * kPi * kPi * sin_theta);
    return m.lookup(uv);
}

Point2f EnvironmentMap::directionToPixel(const Vec3f& dir) const {
    const Impl& m = *impl_;
    CV_Assert(!m.constant && "directionToPixel: a constant environment has no image");
    const Vec2f uv = directionToUv(m.env_from_world * dir);
    return Point2f(uv[0] * m.rgb.cols - 0.5f, uv[1] * m.rgb.rows - 0.5f);
}

Vec3f EnvironmentMap::pixelToDirection(const Point2f& px) const {
    const Impl& m = *impl_;
    CV_Assert(!m.constant && "pixelToDirection: a constant environment has no image");
    const Vec3f d = uvToDirection((px.x + 0.5f) / m.rgb.cols, (px.y + 0.5f) / m.rgb.rows);
    return m.world_from_env * d;
}

// Image disk → two hemispheres (see doc/vbme_render_materials.md, "Environment from the
// background"). For the world direction d of an output pixel, c = cam_from_world·d (x right,
// y down, z forward). The hemisphere behind the object (c.z ≥ 0, where the background the
// camera sees lies) is read through the disk by the equidistant mapping θ = ρ·π/2: θ is the
// angle between c and the viewing axis, ψ = atan2(c.y, c.x) its azimuth, and the pixel is
// center + radius·ρ·(cos ψ, sin ψ). The hemisphere facing the camera (c.z < 0) is the mirror
// image of the first through the image plane: c → (c.x, c.y, −c.z).
Mat imageDiskToEnvironment(InputArray background_, Point2f center, float radius,
                           const Matx33f& cam_from_world, Size out_size) {
    const Mat background = background_.getMat();
    CV_Assert(!background.empty() && background.channels() == 3 &&
              "imageDiskToEnvironment: expected a non-empty 3-channel (BGR) background image");
    CV_Assert(radius > 0.f && "imageDiskToEnvironment: the disk radius must be > 0 pixels");
    CV_Assert(out_size.width > 0 && out_size.height > 0 &&
              "imageDiskToEnvironment: the output size must be positive");
    Mat bg;
    background.convertTo(bg, CV_32F);
    // Supersample so that the disk's resolution is not aliased: the disk has radius/(π/2)
    // pixels per radian, the output H/π.
    const int ss = std::min(4, std::max(1, (int)std::ceil(2.f * radius / out_size.height)));
    const int W = out_size.width * ss, H = out_size.height * ss;
    Mat mapx(H, W, CV_32FC1), mapy(H, W, CV_32FC1);
    for (int y = 0; y < H; y++) {
        float* mx = mapx.ptr<float>(y);
        float* my = mapy.ptr<float>(y);
        for (int x = 0; x < W; x++) {
            const Vec3f d = uvToDirection((x + 0.5f) / W, (y + 0.5f) / H);
            Vec3f c = cam_from_world * d;
            c[2] = std::abs(c[2]);  // mirror the front hemisphere onto the back one
            const float theta = std::acos(std::min(std::max(c[2], -1.f), 1.f));
            const float rho = theta / (0.5f * kPi);
            const float psi = std::atan2(c[1], c[0]);
            mx[x] = center.x + radius * rho * std::cos(psi);
            my[x] = center.y + radius * rho * std::sin(psi);
        }
    }
    Mat out;
    remap(bg, out, mapx, mapy, INTER_LINEAR, BORDER_REPLICATE);
    if (ss > 1) resize(out, out, out_size, 0, 0, INTER_AREA);
    return out;
}

}  // namespace vbme
}  // namespace cv
