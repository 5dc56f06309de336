// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/render/texture.hpp"

#include <cmath>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/render/film.hpp"

namespace cv {
namespace vbme {

Texture::~Texture() = default;

Vec3f Texture::evalFiltered(const Vec2f& uv, float) const {
    return eval(uv);
}

namespace {

class ConstantTexture : public Texture {
public:
    explicit ConstantTexture(const Vec3f& c) : c_(c) {}
    Vec3f eval(const Vec2f&) const override { return c_; }
    Vec3f mean() const override { return c_; }

private:
    Vec3f c_;
};

class ImageTexture : public Texture {
public:
    ImageTexture(const Mat& bgr, Wrap wrap) : wrap_(wrap) {
        CV_Assert(!bgr.empty());
        Mat f;
        if (bgr.channels() == 1)
            cvtColor(bgr, f, COLOR_GRAY2RGB);
        else if (bgr.channels() == 3)
            cvtColor(bgr, f, COLOR_BGR2RGB);
        else if (bgr.channels() == 4)
            cvtColor(bgr, f, COLOR_BGRA2RGB);
        else
            CV_Error(Error::StsBadArg, "texture: expected 1, 3 or 4 channels");
        if (f.depth() != CV_32F) f.convertTo(f, CV_32F);
        w_ = f.cols;
        h_ = f.rows;
        px_.resize(size_t(w_) * h_);
        for (int y = 0; y < h_; ++y)
            for (int x = 0; x < w_; ++x)
                px_[size_t(y) * w_ + x] = f.at<Vec3f>(y, x);
        Scalar m = cv::mean(f);
        mean_ = Vec3f(float(m[0]), float(m[1]), float(m[2]));
        buildMipmap(f);
    }
    Vec3f eval(const Vec2f& uv) const override {
        const float x = uv[0] * w_ - 0.5f, y = (1.f - uv[1]) * h_ - 0.5f;
        if (!(std::isfinite(x) && std::isfinite(y))) return mean_;
        const float fx = std::floor(x), fy = std::floor(y);
        const float ax = x - fx, ay = y - fy;
        const int x0 = int(fx), y0 = int(fy);
        const int X0 = wrapIndex(x0, w_), X1 = wrapIndex(x0 + 1, w_);
        const int Y0 = wrapIndex(y0, h_), Y1 = wrapIndex(y0 + 1, h_);
        const Vec3f& a = px_[size_t(Y0) * w_ + X0];
        const Vec3f& b = px_[size_t(Y0) * w_ + X1];
        const Vec3f& c = px_[size_t(Y1) * w_ + X0];
        const Vec3f& d = px_[size_t(Y1) * w_ + X1];
        return (a * (1.f - ax) + b * ax) * (1.f - ay) + (c * (1.f - ax) + d * ax) * ay;
    }
    Vec3f mean() const override { return mean_; }

    Vec3f evalFiltered(const Vec2f& uv, float width) const override {
        const float texels = width * float(std::max(w_, h_));
        if (!(texels >= 2.f) || levels_.empty()) return eval(uv);  // also NaN width
        const int k = std::min((int)levels_.size(), ilogb2(texels));
        const Level& L = levels_[k - 1];
        const float x = uv[0] * L.w - 0.5f, y = (1.f - uv[1]) * L.h - 0.5f;
        if (!(std::isfinite(x) && std::isfinite(y))) return mean_;
        const float fx = std::floor(x), fy = std::floor(y);
        const float ax = x - fx, ay = y - fy;
        const int x0 = int(fx), y0 = int(fy);
        const int X0 = wrapIndex(x0, L.w), X1 = wrapIndex(x0 + 1, L.w);
        const int Y0 = wrapIndex(y0, L.h), Y1 = wrapIndex(y0 + 1, L.h);
        const size_t i00 = size_t(Y0) * L.w + X0, i01 = size_t(Y0) * L.w + X1,
                     i10 = size_t(Y1) * L.w + X0, i11 = size_t(Y1) * L.w + X1;
        const float w00 = (1.f - ax) * (1.f - ay), w01 = ax * (1.f - ay), w10 = (1.f - ax) * ay,
                    w11 = ax * ay;
        if (!L.f.empty()) return L.f[i00] * w00 + L.f[i01] * w01 + L.f[i10] * w10 + L.f[i11] * w11;
        return unpack(L.c[i00]) * w00 + unpack(L.c[i01]) * w01 + unpack(L.c[i10]) * w10 +
               unpack(L.c[i11]) * w11;
    }

private:
    /** One reduced level: float texels, or 8-bit sRGB packed as 0x00BBGGRR. */
    struct Level {
        int w = 0, h = 0;
        std::vector<Vec3f> f;
        std::vector<uint32_t> c;
    };
    static int ilogb2(float v) { return std::ilogb(v); }  // ⌊log2 v⌋ for v ≥ 1
    Vec3f unpack(uint32_t p) const {
        return Vec3f(lut_[p & 0xffu], lut_[(p >> 8) & 0xffu], lut_[(p >> 16) & 0xffu]);
    }
    void buildMipmap(const Mat& rgb) {
        double lo, hi;
        minMaxLoc(rgb.reshape(1), &lo, &hi);
        const bool compact = lo >= 0.0 && hi <= 1.0;
        for (int i = 0; i < 256; ++i)
            lut_[i] = linearize(i / 255.f, Response::SRGB);
        Mat cur = rgb;
        while (cur.cols > 1 || cur.rows > 1) {
            Mat next;
            resize(cur, next, Size(std::max(1, cur.cols / 2), std::max(1, cur.rows / 2)), 0, 0,
                   INTER_AREA);
            Level L;
            L.w = next.cols;
            L.h = next.rows;
            if (compact) {
                L.c.resize(size_t(L.w) * L.h);
                for (int y = 0; y < L.h; ++y)
                    for (int x = 0; x < L.w; ++x) {
                        const Vec3f& v = next.at<Vec3f>(y, x);
                        uint32_t p = 0;
                        for (int c = 0; c < 3; ++c) {
                            const float e =
                                encode(std::min(1.f, std::max(0.f, v[c])), Response::SRGB);
                            p |= uint32_t(std::lround(e * 255.f)) << (8 * c);
                        }
                        L.c[size_t(y) * L.w + x] = p;
                    }
            } else {
                L.f.resize(size_t(L.w) * L.h);
                for (int y = 0; y < L.h; ++y)
                    for (int x = 0; x < L.w; ++x)
                        L.f[size_t(y) * L.w + x] = next.at<Vec3f>(y, x);
            }
            levels_.push_back(std::move(L));
            cur = next;
        }
    }
    int wrapIndex(int i, int n) const {
        if (wrap_ == WRAP_CLAMP) return i < 0 ? 0 : (i >= n ? n - 1 : i);
        i %= n;
        return i < 0 ? i + n : i;
    }
    Wrap wrap_;
    int w_ = 0, h_ = 0;
    std::vector<Vec3f> px_;
    Vec3f mean_;
    std::vector<Level> levels_;  // levels 1, 2, … of the mip-map
    float lut_[256];             // 8-bit sRGB → linear
};

}  // namespace

Ptr<Texture> Texture::createConstant(const Vec3f& rgb) {
    return makePtr<ConstantTexture>(rgb);
}

Ptr<Texture> Texture::createImage(InputArray image_bgr_, Wrap wrap) {
    const Mat image_bgr = image_bgr_.getMat();
    if (image_bgr.empty()) CV_Error(Error::StsBadArg, "Texture::createImage: empty image");
    return makePtr<ImageTexture>(image_bgr, wrap);
}

Ptr<Texture> Texture::load(const std::string& path, Response response, Wrap wrap,
                           const std::string& field) {
    if (!std::filesystem::exists(path))
        CV_Error(Error::StsObjectNotFound, field + ": texture file '" + path + "' does not exist");
    std::string ext = std::filesystem::path(path).extension().string();
    for (auto& ch : ext)
        ch = char(std::tolower((unsigned char)ch));
    Mat img;
    try {
        if (ext == ".exr") {
            img = readExr(path).color;
        } else {
            img = imreadChecked(path, IMREAD_ANYDEPTH | IMREAD_ANYCOLOR);
            if (img.depth() == CV_8U || img.depth() == CV_16U) {
                if (img.channels() == 4) cvtColor(img, img, COLOR_BGRA2BGR);
                Mat lin;
                linearize(img, lin, response);
                img = lin;
            } else if (img.depth() != CV_32F) {
                img.convertTo(img, CV_32F);
            }
        }
    } catch (const cv::Exception& e) {
        CV_Error(Error::StsError, field + ": cannot read texture '" + path + "': " + e.err);
    }
    return createImage(img, wrap);
}

}  // namespace vbme
}  // namespace cv
