// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Room face textures: per-texel rectification of frames onto the room box, accumulated over
// frames with sharpness weights (thesis §5.1.2).
#include "opencv2/vbme/render/room_texture.hpp"
#include "opencv2/vbme/core/params.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "room_faces.hpp"

namespace cv {
namespace vbme {

void RoomTextureParams::read(const FileNode& fn) {
    ParamsIn in(fn, "room texture parameters");
    in("texel_scale", texel_scale);
    in("min_size", min_size);
    in("max_size", max_size);
    in("accumulate", accumulate);
    in.finish();
    check();
}

void RoomTextureParams::check() const {
    const char* w = "room texture parameters";
    checkParam(texel_scale > 0, w, "texel_scale", texel_scale, "> 0");
    checkParam(min_size >= 1, w, "min_size", min_size, ">= 1");
    checkParam(max_size >= min_size, w, "max_size", max_size, ">= min_size");
}

void RoomTextureParams::write(FileStorage& fs) const {
    fs << "texel_scale" << texel_scale << "min_size" << min_size << "max_size" << max_size
       << "accumulate" << (int)accumulate;
}

namespace {

void checkRoom(const Room& room) {
    for (int a = 0; a < 3; ++a)
        if (!(room.max[a] > room.min[a]))
            CV_Error(Error::StsBadArg, "room: max must exceed min on every axis");
}

void checkCamera(const Camera& cam, const char* who) {
    if (cam.image_size.width < 2 || cam.image_size.height < 2)
        CV_Error(Error::StsBadArg, std::string(who) + ": the camera's image_size is not set");
}

/** Per-face projection set-up: p(u, v) = p0 + u·pu + v·pv in homogeneous pixels (K (R P + t)). */
struct FaceProjector {
    Vec3d p0, pu, pv;  // homogeneous image point of bl, and its derivatives along u and v
    Vec3d bl, right, up, n, c;
    double near_z;
    FaceProjector(const Room& room, int face, const Camera& cam) {
        const RoomFace F = room.face(face);
        const Matx33d M = cam.K * cam.R;
        const Vec3d m = cam.K * cam.t;
        p0 = M * F.bl + m;
        pu = M * F.right;
        pv = M * F.up;
        bl = F.bl;
        right = F.right;
        up = F.up;
        n = F.n;
        c = cam.center();
        near_z = 1e-6 * norm(room.max - room.min);
    }
    /** Pixel position and footprint of the point (u, v); false if behind the camera or
    on the back side of the face. The Jacobian columns are per texel (du = 1/W, dv = −1/H). */
    bool project(double u, double v, double du, double dv, Point2d& px, double& smin,
                 double& smax) const {
        const Vec3d p = p0 + pu * u + pv * v;
        if (p[2] <= near_z) return false;
        const Vec3d P = bl + right * u + up * v;
        if ((c - P).dot(n) <= 0) return false;
        const double iz = 1.0 / p[2];
        px = Point2d(p[0] * iz, p[1] * iz);
        const Vec3d a = pu * du, b = pv * dv;
        const double ax = (a[0] - px.x * a[2]) * iz, ay = (a[1] - px.y * a[2]) * iz;
        const double bx = (b[0] - px.x * b[2]) * iz, by = (b[1] - px.y * b[2]) * iz;
        const double T = ax * ax + ay * ay + bx * bx + by * by;
        const double D = std::abs(ax * by - ay * bx);
        smax = std::sqrt(0.5 * (T + std::sqrt(std::max(0.0, T * T - 4 * D * D))));
        smin = smax > 0 ? D / smax : 0;
        return true;
    }
};

/** A Gaussian pyramid of a CV_32FC3 frame (and optionally of a float mask). */
struct Pyramid {
    std::vector<Mat> img, mask;
    void build(const Mat& frame32, const Mat& mask32) {
        img.assign(1, frame32);
        mask.clear();
        if (!mask32.empty()) mask.push_back(mask32);
        while ((int)img.size() < 8 && std::min(img.back().cols, img.back().rows) >= 16) {
            Mat d;
            pyrDown(img.back(), d);
            img.push_back(d);
            if (!mask.empty()) {
                Mat md;
                pyrDown(mask.back(), md);
                mask.push_back(md);
            }
        }
    }
    /** Colour at pixel (x, y) of level 0 filtered for a footprint of @p smax pixels; @p masked
    receives whether an ignored pixel contributes. */
    Vec3f sample(const Point2d& px, double smax, bool& masked) const {
        const double lev =
            std::min(std::max(std::log2(std::max(smax, 1e-9)), 0.0), double(img.size() - 1));
        const int l0 = (int)lev, l1 = std::min(l0 + 1, (int)img.size() - 1);
        const float f = float(lev - l0);
        auto at = [&](int l, Vec3f& c, float& mk) {
            // pyrDown centres pixel i of level l on pixel 2^l·i of level 0
            const double s = 1.0 / (1 << l);
            const double x = px.x * s, y = px.y * s;
            c = bilinear<Vec3f>(img[l], x, y);
            mk = mask.empty() ? 0.f : bilinear<float>(mask[l], x, y);
        };
        Vec3f c0, c1;
        float m0, m1 = 0.f;
        at(l0, c0, m0);
        if (f > 0 && l1 != l0) {
            at(l1, c1, m1);
            c0 = c0 * (1.f - f) + c1 * f;
        }
        masked = m0 > 1e-3f || m1 > 1e-3f;
        return c0;
    }
};

/** Projects every texel of face @p face and calls fn(row, col, colour, smin, border_dist). */
template <typename Fn>
void forEachSeenTexel(const Pyramid& pyr, const Camera& cam, const Room& room, int face, Size tex,
                      double margin, Fn fn) {
    const FaceProjector fp(room, face, cam);
    const double W = tex.width, H = tex.height;
    const double w = cam.image_size.width, h = cam.image_size.height;
    parallel_for_(Range(0, tex.height), [&](const Range& rows) {
        for (int r = rows.start; r < rows.end; ++r) {
            const double v = 1.0 - (r + 0.5) / H;
            for (int col = 0; col < tex.width; ++col) {
                const double u = (col + 0.5) / W;
                Point2d px;
                double smin, smax;
                if (!fp.project(u, v, 1.0 / W, -1.0 / H, px, smin, smax)) continue;
                const double dist =
                    std::min(std::min(px.x, w - 1 - px.x), std::min(px.y, h - 1 - px.y));
                if (!(dist >= margin)) continue;
                bool masked;
                const Vec3f c = pyr.sample(px, smax, masked);
                if (masked) continue;
                fn(r, col, c, smin, dist);
            }
        }
    });
}

Mat toFloat3(InputArray frame, const char* who) {
    Mat f = frame.getMat();
    if (f.empty() || f.channels() != 3)
        CV_Error(Error::StsBadArg,
                 std::string(who) + ": the frame must be a non-empty 3-channel image");
    Mat out;
    if (f.depth() == CV_32F)
        out = f;
    else
        f.convertTo(out, CV_32FC3);
    return out;
}

}  // namespace

namespace {

/** Largest magnification (pixels per metre) at the points of face @p fi that @p camera sees,
or 0 if it sees none. */
double seenMagnification(const Room& room, int fi, const Camera& camera) {
    const RoomFace F = room.face(fi);
    const double fw = norm(F.right), fh = norm(F.up);
    const FaceProjector fp(room, fi, camera);
    const double w = camera.image_size.width, h = camera.image_size.height;
    double m = 0;
    const int N = 32;
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) {
            const double u = (j + 0.5) / N, v = (i + 0.5) / N;
            Point2d px;
            double smin, smax;
            if (!fp.project(u, v, 1.0 / fw, 1.0 / fh, px, smin, smax)) continue;
            if (px.x < 0 || px.y < 0 || px.x > w - 1 || px.y > h - 1) continue;
            m = std::max(m, std::sqrt(smin * smax));
        }
    return m;
}

}  // namespace

Size chooseFaceTextureSize(const Room& room, const std::string& face, const Camera& camera,
                           const RoomTextureParams& p) {
    checkRoom(room);
    checkCamera(camera, "chooseFaceTextureSize");
    CV_Assert(p.min_size >= 2 && p.max_size >= p.min_size && p.texel_scale > 0);
    const int fi = Room::faceIndex(face);
    const RoomFace F = room.face(fi);
    const double fw = norm(F.right), fh = norm(F.up);
    double m = seenMagnification(room, fi, camera);  // pixels per metre, sharpest seen point
    if (m <= 0)  // not seen: the largest magnification of the faces that are seen
        for (int k = 0; k < 6; ++k)
            if (k != fi) m = std::max(m, seenMagnification(room, k, camera));
    if (m <= 0) {
        // Nothing seen: the magnification of a square view from the camera's distance.
        const Vec3d c = camera.center();
        Vec3d q = c - F.bl;
        const double a = std::min(std::max(q.dot(F.right) / (fw * fw), 0.0), 1.0);
        const double b = std::min(std::max(q.dot(F.up) / (fh * fh), 0.0), 1.0);
        const double d = std::max(norm(c - (F.bl + F.right * a + F.up * b)), 1e-3);
        m = 0.5 * (camera.K(0, 0) + camera.K(1, 1)) / d;
    }
    double sw = fw * m * p.texel_scale, sh = fh * m * p.texel_scale;
    const double big = std::max(sw, sh);
    if (big > p.max_size) {
        sw *= p.max_size / big;
        sh *= p.max_size / big;
    }
    auto clampSide = [&](double s) {
        return std::min(std::max((int)std::lround(s), p.min_size), p.max_size);
    };
    return Size(clampSide(sw), clampSide(sh));
}

void rectifyFace(InputArray frame, const Camera& camera, const Room& room, const std::string& face,
                 Size tex_size, OutputArray texture, OutputArray valid) {
    checkRoom(room);
    checkCamera(camera, "rectifyFace");
    const int fi = Room::faceIndex(face);
    if (tex_size.width < 1 || tex_size.height < 1)
        CV_Error(Error::StsBadArg, "rectifyFace: tex_size must be positive");
    Mat f = toFloat3(frame, "rectifyFace");
    if (f.size() != camera.image_size)
        CV_Error(Error::StsBadArg, "rectifyFace: the frame size differs from camera.image_size");
    Pyramid pyr;
    pyr.build(f, Mat());
    texture.create(tex_size, CV_32FC3);
    valid.create(tex_size, CV_8U);
    Mat T = texture.getMat(), V = valid.getMat();
    T.setTo(Scalar::all(0));
    V.setTo(Scalar::all(0));
    forEachSeenTexel(pyr, camera, room, fi, tex_size, 0.0,
                     [&](int r, int c, const Vec3f& col, double, double) {
                         T.at<Vec3f>(r, c) = col;
                         V.at<uchar>(r, c) = 255;
                     });
}

RoomTextureAccumulator::~RoomTextureAccumulator() {}

namespace {

class RoomTextureAccumulatorImpl : public RoomTextureAccumulator {
public:
    RoomTextureAccumulatorImpl(const Room& room, const Camera& cam, const RoomTextureParams& p)
        : room_(room), p_(p) {
        checkRoom(room);
        checkCamera(cam, "RoomTextureAccumulator::create");
        const auto& names = Room::faceNames();
        for (int f = 0; f < 6; ++f) {
            size_[f] = chooseFaceTextureSize(room, names[f], cam, p);
            sum_[f] = Mat::zeros(size_[f], CV_32FC3);
            wsum_[f] = Mat::zeros(size_[f], CV_32F);
        }
    }

    void add(InputArray frame_linear, const Camera& camera, InputArray ignore) override {
        checkCamera(camera, "RoomTextureAccumulator::add");
        Mat f = toFloat3(frame_linear, "RoomTextureAccumulator::add");
        if (f.size() != camera.image_size)
            CV_Error(Error::StsBadArg,
                     "RoomTextureAccumulator::add: the frame size differs from camera.image_size");
        Mat m32;
        if (!ignore.empty()) {
            Mat m = ignore.getMat();
            if (m.size() != f.size() || m.type() != CV_8U)
                CV_Error(Error::StsBadArg,
                         "RoomTextureAccumulator::add: ignore must be CV_8U of the frame's size");
            Mat md;
            dilate(m, md, Mat());
            md.convertTo(m32, CV_32F, 1.0 / 255);
            threshold(m32, m32, 0, 1, THRESH_BINARY);
        }
        pyr_.build(f, m32);
        if (!p_.accumulate)
            for (int k = 0; k < 6; ++k) {
                sum_[k].setTo(Scalar::all(0));
                wsum_[k].setTo(Scalar::all(0));
            }
        const double band = std::max(2.0, 0.01 * std::min(f.cols, f.rows));
        for (int k = 0; k < 6; ++k) {
            Mat& S = sum_[k];
            Mat& Wt = wsum_[k];
            forEachSeenTexel(pyr_, camera, room_, k, size_[k], band,
                             [&](int r, int c, const Vec3f& col, double smin, double dist) {
                                 const double b = std::min(1.0, (dist - band) / band);
                                 const float w = float(smin * smin * b);
                                 if (!(w > 0)) return;
                                 S.at<Vec3f>(r, c) += col * w;
                                 Wt.at<float>(r, c) += w;
                             });
        }
        ++frames_;
    }

    void textures(std::map<std::string, Mat>& linear,
                  std::map<std::string, Mat>& seen) const override {
        const auto& names = Room::faceNames();
        linear.clear();
        seen.clear();
        for (int k = 0; k < 6; ++k) {
            Mat T(size_[k], CV_32FC3), V(size_[k], CV_8U);
            for (int r = 0; r < T.rows; ++r) {
                const Vec3f* s = sum_[k].ptr<Vec3f>(r);
                const float* w = wsum_[k].ptr<float>(r);
                Vec3f* t = T.ptr<Vec3f>(r);
                uchar* v = V.ptr<uchar>(r);
                for (int c = 0; c < T.cols; ++c) {
                    const bool ok = w[c] > 0;
                    t[c] = ok ? s[c] * (1.f / w[c]) : Vec3f(0, 0, 0);
                    v[c] = ok ? 255 : 0;
                }
            }
            linear[names[k]] = T;
            seen[names[k]] = V;
        }
    }

    int framesAdded() const override { return frames_; }

    std::map<std::string, Size> textureSizes() const override {
        std::map<std::string, Size> m;
        for (int k = 0; k < 6; ++k)
            m[Room::faceNames()[k]] = size_[k];
        return m;
    }

private:
    Room room_;
    RoomTextureParams p_;
    Size size_[6];
    Mat sum_[6], wsum_[6];
    Pyramid pyr_;
    int frames_ = 0;
};

}  // namespace

Ptr<RoomTextureAccumulator> RoomTextureAccumulator::create(const Room& room,
                                                           const Camera& first_camera,
                                                           const RoomTextureParams& p) {
    return makePtr<RoomTextureAccumulatorImpl>(room, first_camera, p);
}

}  // namespace vbme
}  // namespace cv
