// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Motion blur: the camera's motion during the exposure from the camera path (the neighbouring
// poses), the exposure time given (--shutter) or estimated from the blur of the room's edges,
// and the frame's layers rendered over the shutter interval (renderOverShutter).
#include <algorithm>
#include <cmath>

#include <filesystem>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "insertion/stages.hpp"
#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/pipeline/camera_match.hpp"

namespace cv {
namespace vbme {

namespace fs = std::filesystem;

Camera cameraAtTime(const CameraPath& path, double time, const Camera& base) {
    CV_Assert(!path.frames.empty());
    Camera cam = base;
    const int n = (int)path.frames.size();
    if (n == 1) {
        cam.R = path.frames[0].R;
        cam.t = path.frames[0].t;
        return cam;
    }
    const int a = std::min(n - 2, std::max(0, (int)std::floor(time)));
    const double f = time - a;  // < 0 or > 1 extrapolates the interval's motion
    const CameraPath::Frame& A = path.frames[a];
    const CameraPath::Frame& B = path.frames[a + 1];
    const Matx33d dR = B.R * A.R.t();  // R_b = dR · R_a
    Vec3d w;
    Rodrigues(dR, w);
    Matx33d Rf;
    Rodrigues(w * f, Rf);
    cam.R = Rf * A.R;
    const Vec3d Ca = -(A.R.t() * A.t), Cb = -(B.R.t() * B.t);
    const Vec3d C = Ca + f * (Cb - Ca);
    cam.t = -(cam.R * C);
    return cam;
}

double projectedMotion(const CameraPath& path, double t0, double t1, const Camera& base,
                       const std::vector<Vec3d>& points) {
    const Camera c0 = cameraAtTime(path, t0, base), c1 = cameraAtTime(path, t1, base);
    double best = 0;
    for (const Vec3d& X : points) {
        double z0 = 0, z1 = 0;
        const Point2d p0 = c0.project(X, &z0), p1 = c1.project(X, &z1);
        if (z0 <= 0 || z1 <= 0) continue;
        best = std::max(best, norm(p1 - p0));
    }
    return best;
}

void renderOverShutter(const DifferentialRenderer::Params& params, const RenderScene& scene,
                       const std::function<Camera(double)>& camera_at, double time, double shutter,
                       int subframes, DifferentialImages& out) {
    CV_Assert(subframes >= 1 && shutter >= 0);
    if (shutter <= 0 || subframes == 1) {
        DifferentialRenderer::create(params)->render(scene, camera_at(time), out);
        return;
    }
    const int K = subframes;
    DifferentialRenderer::Params sp = params;
    sp.render.spp = std::max(1, (params.render.spp + K - 1) / K);
    if (sp.render.adaptive_min_spp > 0) {
        // adaptive sampling: each render may be √K times noisier (K of them are averaged), and
        // takes at least 2 samples a pixel (its error estimate needs two)
        sp.render.spp = std::max(2, sp.render.spp);
        sp.render.adaptive_min_spp =
            std::min(sp.render.spp, std::max(2, (params.render.adaptive_min_spp + K - 1) / K));
        sp.render.adaptive_error = params.render.adaptive_error * std::sqrt((float)K);
    }
    Mat m_sum, mo_sum, md_sum, obj_sum, diff_sum, noobj_sum, object_sum, samples_sum;
    for (int k = 0; k < K; ++k) {
        const double tk = time + shutter * ((k + 0.5) / K - 0.5);
        sp.render.seed = params.render.seed + 0x9e3779b97f4a7c15ull * (uint64)k;
        DifferentialImages im;
        DifferentialRenderer::create(sp)->render(scene, camera_at(tk), im);
        Mat m3;
        cvtColor(im.mask, m3, COLOR_GRAY2BGR);
        Mat mo = m3.mul(im.obj), md = (Scalar::all(1) - m3).mul(im.diff);
        if (k == 0) {
            m_sum = im.mask.clone();
            mo_sum = mo;
            md_sum = md;
            obj_sum = im.obj.clone();
            diff_sum = im.diff.clone();
            noobj_sum = im.noobj.clone();
            object_sum = im.object.clone();
            if (!im.samples.empty()) samples_sum = im.samples.clone();
        } else {
            m_sum += im.mask;
            mo_sum += mo;
            md_sum += md;
            obj_sum += im.obj;
            diff_sum += im.diff;
            noobj_sum += im.noobj;
            object_sum += im.object;
            if (!samples_sum.empty() && !im.samples.empty()) samples_sum += im.samples;
        }
    }
    const float inv = 1.f / K;
    out.mask = m_sum * inv;
    out.noobj = noobj_sum * inv;
    out.object = object_sum * inv;
    out.samples = samples_sum;
    out.obj.create(out.mask.size(), CV_32FC3);
    out.diff.create(out.mask.size(), CV_32FC3);
    for (int y = 0; y < out.mask.rows; ++y) {
        const float* M = out.mask.ptr<float>(y);
        const Vec3f *MO = mo_sum.ptr<Vec3f>(y), *MD = md_sum.ptr<Vec3f>(y);
        const Vec3f *O = obj_sum.ptr<Vec3f>(y), *D = diff_sum.ptr<Vec3f>(y);
        Vec3f *Oo = out.obj.ptr<Vec3f>(y), *Do = out.diff.ptr<Vec3f>(y);
        for (int x = 0; x < out.mask.cols; ++x) {
            const float m = M[x];
            Oo[x] = m > 1e-6f ? MO[x] * (inv / m) : O[x] * inv;
            Do[x] = m < 1 - 1e-6f ? MD[x] * (inv / (1 - m)) : D[x] * inv;
        }
    }
}

namespace insertion {

namespace {

// The objects' origins: where the image motion that matters is measured.
std::vector<Vec3d> objectPoints(const Scene& scene) {
    std::vector<Vec3d> pts;
    for (const SceneObject& o : scene.objects)
        pts.emplace_back(o.world_from_object(0, 3), o.world_from_object(1, 3),
                         o.world_from_object(2, 3));
    return pts;
}

// Renders over a shutter interval: one per 2 px of the objects' motion, 2 … 12.
int shutterSubframes(const PreparedInsertion& prep, int i, double shutter) {
    if (shutter <= 0) return 1;
    const double px = projectedMotion(prep.path, i - shutter / 2, i + shutter / 2, prep.camera(i),
                                      objectPoints(prep.scene));
    if (px < 1) return 1;
    return std::min(12, std::max(2, (int)std::ceil(px / 2)));
}

}  // namespace

void renderFrameLayers(PreparedInsertion& prepared, int i, DifferentialImages& im) {
    // With a barrel lens (k1 < 0) the pinhole camera over the whole region the frame shows
    // (enlarged; the frame's own camera otherwise): renderInsertionFrame() warps it to the lens.
    const Camera base = lensCoverCamera(prepared.camera(i));
    const int K = shutterSubframes(prepared, i, prepared.shutter);
    if (K <= 1) {  // no blur: the one render (as without motion blur)
        prepared.renderer->render(*prepared.render_scene, base, im);
        return;
    }
    renderOverShutter(
        prepared.renderer->getParams(), *prepared.render_scene,
        [&](double t) { return cameraAtTime(prepared.path, t, base); }, i, prepared.shutter, K, im);
}

namespace {

// The room's radiance textures (<work>/textures/<face>.png, linear) and where they were seen.
struct RoomView {
    Room room;
    std::vector<RoomFace> faces;
    std::vector<Mat> tex, seen;  // per face (faceNames() order); empty when missing
};

RoomView loadRoomView(const Scene& scene, const std::string& work) {
    RoomView v;
    v.room = scene.room;
    const auto& names = Room::faceNames();
    for (int f = 0; f < (int)names.size(); ++f) {
        v.faces.push_back(v.room.face(f));
        const std::string base = (fs::path(work) / "textures" / names[f]).string();
        Mat enc = imread(base + ".png", IMREAD_COLOR), lin, sn;
        if (!enc.empty()) {
            linearize(enc, lin, scene.camera.response);
            sn = imread(base + "_seen.png", IMREAD_GRAYSCALE);
        }
        v.tex.push_back(lin);
        v.seen.push_back(sn.size() == lin.size() ? sn : Mat());
    }
    return v;
}

// The face and texel coordinates where the ray through pixel px of cam leaves the room box
// (the nearest face hit from inside); false when none.
bool roomHit(const RoomView& v, const Camera& cam, const Point2d& px, int& face, Point2d& tx,
             Vec3d* X_out = nullptr) {
    const Vec3d C = cam.center(), d = cam.rayDirection(px);
    double best = 1e300;
    face = -1;
    for (int f = 0; f < (int)v.faces.size(); ++f) {
        const RoomFace& F = v.faces[f];
        const Vec3d n = F.right.cross(F.up);
        const double dn = n.dot(d);
        if (std::abs(dn) < 1e-12) continue;
        const double s = n.dot(F.bl - C) / dn;
        if (s <= 0 || s >= best) continue;
        const Vec3d X = C + s * d;
        const double u = (X - F.bl).dot(F.right) / F.right.dot(F.right);
        const double w = (X - F.bl).dot(F.up) / F.up.dot(F.up);
        if (u < 0 || u > 1 || w < 0 || w > 1) continue;
        best = s;
        face = f;
        if (X_out) *X_out = X;
        if (!v.tex[f].empty()) tx = Point2d(u * v.tex[f].cols - 0.5, (1 - w) * v.tex[f].rows - 0.5);
    }
    return face >= 0;
}

// The room as its radiance textures show it through cam (linear BGR), and where every pixel
// looked at a texel some frame saw (valid, CV_8U 0/1).
void viewRoom(const RoomView& v, const Camera& cam, Mat& out, Mat& valid) {
    out.create(cam.image_size, CV_32FC3);
    valid.create(cam.image_size, CV_8U);
    for (int y = 0; y < out.rows; ++y)
        for (int x = 0; x < out.cols; ++x) {
            int f;
            Point2d t;
            Vec3f c(0, 0, 0);
            uchar ok = 0;
            if (roomHit(v, cam, Point2d(x, y), f, t) && !v.tex[f].empty()) {
                const Mat& T = v.tex[f];
                c = bilinear<Vec3f>(T, t.x, t.y);
                const int x0 = std::min(T.cols - 2, std::max(0, (int)std::floor(t.x)));
                const int y0 = std::min(T.rows - 2, std::max(0, (int)std::floor(t.y)));
                ok = v.seen[f].empty() || v.seen[f].at<uchar>(y0, x0) ? 1 : 0;
            }
            out.at<Vec3f>(y, x) = c;
            valid.at<uchar>(y, x) = ok;
        }
}

}  // namespace

double estimateShutter(const Scene& scene, const CameraPath& path, int frames,
                       const std::string& work, const std::string& video, int* frame,
                       double* motion_px) {
    if (frame) *frame = -1;
    if (motion_px) *motion_px = 0;
    const RoomView view = loadRoomView(scene, work);
    // the frame of the largest image motion over one frame interval, at the room points a 5×5
    // grid of its pixels sees
    int best = -1;
    double best_px = 0;
    for (int i = 0; i < frames && i < (int)path.frames.size(); ++i) {
        const Camera cam = pathCamera(path, i, scene);
        std::vector<Vec3d> pts;
        for (int gy = 1; gy <= 5; ++gy)
            for (int gx = 1; gx <= 5; ++gx) {
                int f;
                Point2d t;
                Vec3d X;
                if (roomHit(
                        view, cam,
                        Point2d(gx * cam.image_size.width / 6.0, gy * cam.image_size.height / 6.0),
                        f, t, &X))
                    pts.push_back(X);
            }
        const double px = projectedMotion(path, i - 0.5, i + 0.5, cam, pts);
        if (px > best_px) best_px = px, best = i;
    }
    if (frame) *frame = best;
    if (motion_px) *motion_px = best_px;
    if (best < 0 || best_px < 3) return -1;  // too little motion to see its blur
    Mat plate;
    {
        VideoReader reader(video);
        Mat f;
        for (int i = 0; i <= best && reader.read(f); ++i)
            if (i == best) plate = f.clone();
    }
    if (plate.empty()) return -1;
    undistortImageK1(plate, plate, scene.camera);  // compared with pinhole views of the room
    Mat P;
    // at most 480 px wide (the textures' lookups stay cheap; blur widths stay measurable)
    Camera base = pathCamera(path, best, scene);
    const double scale = std::min(1.0, 480.0 / plate.cols);
    if (scale < 1) {
        base.image_size =
            Size((int)std::lround(plate.cols * scale), (int)std::lround(plate.rows * scale));
        base.K(0, 0) *= scale;
        base.K(0, 1) *= scale;
        base.K(1, 1) *= scale;
        base.K(0, 2) = (base.K(0, 2) + 0.5) * scale - 0.5;
        base.K(1, 2) = (base.K(1, 2) + 0.5) * scale - 0.5;
        resize(plate, plate, base.image_size, 0, 0, INTER_AREA);
    }
    linearize(plate, P, scene.camera.response);
    // the room through 32 cameras spread over one frame interval centred on the frame (and
    // one at its time): a shutter of j/16 averages the 2j central ones
    const int N = 32;
    std::vector<Mat> sub(N);
    Mat valid_all, v;
    for (int k = 0; k < N; ++k) {
        viewRoom(view, cameraAtTime(path, best + (k + 0.5) / N - 0.5, base), sub[k], v);
        valid_all = valid_all.empty() ? v : (valid_all & v);
    }
    Mat sharp;
    viewRoom(view, base, sharp, v);
    valid_all &= v;
    erode(valid_all, valid_all, getStructuringElement(MORPH_RECT, Size(5, 5)));
    auto gradients = [&](const Mat& img) {
        Mat g, gx, gy;
        cvtColor(img, g, COLOR_BGR2GRAY);
        Sobel(g, gx, CV_32F, 1, 0, 3);
        Sobel(g, gy, CV_32F, 0, 1, 3);
        gx.setTo(0, valid_all == 0);
        gy.setTo(0, valid_all == 0);
        std::vector<Mat> c = {gx, gy};
        Mat out;
        merge(c, out);
        return out;
    };
    const Mat gP = gradients(P);
    std::vector<double> shutters, errors;
    for (int j = 0; j <= N / 2; ++j) {
        Mat acc;
        if (j == 0) {
            acc = sharp;
        } else {
            acc = Mat::zeros(sharp.size(), CV_32FC3);
            for (int k = N / 2 - j; k < N / 2 + j; ++k)
                acc += sub[k];
            acc *= 1.0 / (2 * j);
        }
        // the textures' scale against the frame's (exposure), then the edges' difference
        const Mat gB = gradients(acc);
        const double ab = gP.dot(gB), bb = gB.dot(gB);
        const double a = bb > 0 ? ab / bb : 1;
        const Mat d = gP - a * gB;
        shutters.push_back(2.0 * j / N);
        errors.push_back(d.dot(d));
    }
    const size_t m = std::min_element(errors.begin(), errors.end()) - errors.begin();
    double S = shutters[m];
    if (m > 0 && m + 1 < errors.size()) {  // parabola through the minimum and its neighbours
        const double e0 = errors[m - 1], e1 = errors[m], e2 = errors[m + 1];
        const double den = e0 - 2 * e1 + e2;
        if (den > 0) S += 0.5 * (e0 - e2) / den * (2.0 / N);
    }
    return std::min(1.0, std::max(0.0, S));
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
