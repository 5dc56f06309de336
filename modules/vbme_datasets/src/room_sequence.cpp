// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE).
#include "opencv2/vbme/datasets/room_sequence.hpp"

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/render/scene.hpp>
#include <opencv2/vbme/render/texture.hpp>

namespace cv {
namespace vbme {

std::map<std::string, Mat> makeRoomTextures(int seed, int size) {
    std::map<std::string, Mat> out;
    int k = 0;
    for (const auto& face : Room::faceNames()) {
        RNG rng((uint64)seed * 1000003u + (uint64)(++k) * 7919u);
        Mat tex(size, size, CV_32FC3, Scalar::all(0));
        // Multi-scale colour noise: blotches at several sizes.
        for (int scale = size / 8; scale >= 4; scale /= 2) {
            Mat small(std::max(2, size / scale), std::max(2, size / scale), CV_32FC3), up;
            rng.fill(small, RNG::UNIFORM, -1, 1);
            resize(small, up, tex.size(), 0, 0, INTER_CUBIC);
            tex += up * (0.12 * std::sqrt(scale / 4.0) / std::sqrt(size / 32.0));
        }
        tex += Scalar(0.45, 0.45, 0.45) +
               Scalar(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1));
        Mat img;
        tex.convertTo(img, CV_8UC3, 255);
        // Shapes: corners and blobs for the feature detector.
        const int shapes = size * size / 2500;
        for (int i = 0; i < shapes; ++i) {
            const Scalar c(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256));
            const Point p(rng.uniform(0, size), rng.uniform(0, size));
            const int r = rng.uniform(size / 200 + 2, size / 25 + 3);
            switch (rng.uniform(0, 3)) {
                case 0:
                    circle(img, p, r, c, FILLED, LINE_AA);
                    break;
                case 1:
                    rectangle(img, Rect(p.x, p.y, r, rng.uniform(2, 2 * r)), c, FILLED);
                    break;
                default:
                    line(img, p, p + Point(rng.uniform(-3 * r, 3 * r), rng.uniform(-3 * r, 3 * r)),
                         c, rng.uniform(1, 4), LINE_AA);
            }
        }
        GaussianBlur(img, img, Size(0, 0), 0.8);  // no aliasing when sampled
        out[face] = img;
    }
    return out;
}

Mat renderTexturedRoom(const Camera& cam, const Room& room,
                       const std::map<std::string, Mat>& textures, int supersample) {
    CV_Assert(cam.image_size.area() > 0 && supersample >= 1);
    const Vec3d c = cam.center();
    for (int a = 0; a < 3; ++a)
        if (!(c[a] > room.min[a] && c[a] < room.max[a]))
            CV_Error(Error::StsBadArg, "renderTexturedRoom: the camera is outside the room");
    // vbme_render's room (its box geometry and face texture coordinates) without texture
    // files: rays are cast into it and each face's texture is looked up at the hit's (u, v).
    Scene scene;
    scene.image_size = cam.image_size;
    scene.camera = cam;
    scene.has_room = true;
    scene.room.min = room.min;
    scene.room.max = room.max;
    const Ptr<RenderScene> rs = RenderScene::create(scene);
    const std::vector<std::string>& faces = Room::faceNames();
    std::vector<Ptr<Texture>> tex(faces.size());
    for (size_t f = 0; f < faces.size(); ++f) {
        auto it = textures.find(faces[f]);
        if (it == textures.end() || it->second.empty()) continue;
        Mat t;
        it->second.convertTo(t, CV_32F);  // 8-bit levels, looked up as they are
        tex[f] = Texture::createImage(t, Texture::WRAP_CLAMP);
    }
    const Vec3f o(c);
    const Matx33d Kinv = cam.K.inv(), Rt = cam.R.t();
    Mat out(cam.image_size, CV_8UC3);
    parallel_for_(Range(0, out.rows), [&](const Range& rows) {
        SurfaceHit hit;
        for (int y = rows.start; y < rows.end; ++y)
            for (int x = 0; x < out.cols; ++x) {
                Vec3d sum(0, 0, 0);
                for (int sy = 0; sy < supersample; ++sy)
                    for (int sx = 0; sx < supersample; ++sx) {
                        const double px = x - 0.5 + (sx + 0.5) / supersample,
                                     py = y - 0.5 + (sy + 0.5) / supersample;
                        const Vec3f d(normalize(Rt * (Kinv * Vec3d(px, py, 1))));
                        // The room's face f is triangles 2f, 2f + 1 (Room::faceNames() order).
                        const int f =
                            rs->intersect(o, d, 0.f, std::numeric_limits<float>::max(), hit)
                                ? hit.prim_id / 2
                                : -1;
                        if (f < 0 || !tex[f]) {
                            sum += Vec3d(128, 128, 128);
                            continue;
                        }
                        const Vec3f rgb = tex[f]->eval(hit.uv);
                        sum += Vec3d(rgb[2], rgb[1], rgb[0]);  // BGR
                    }
                sum *= 1.0 / (supersample * supersample);
                out.at<Vec3b>(y, x) =
                    Vec3b(saturate_cast<uchar>(sum[0]), saturate_cast<uchar>(sum[1]),
                          saturate_cast<uchar>(sum[2]));
            }
    });
    return out;
}

Scene syntheticRoomScene(Size size, double focal, double pitch_rad, double height) {
    Scene s;
    s.image_size = size;
    s.has_room = true;
    s.room.min = Vec3d(-2, -1, 0);
    s.room.max = Vec3d(2, 4, 2.6);
    s.camera = Camera::fromFocal(focal, size);
    Mat pitch;
    Rodrigues(Vec3d(pitch_rad, 0, 0), pitch);  // about the camera's x axis: positive looks down
    s.camera.R = Matx33d(pitch) * Matx33d(1, 0, 0, 0, 0, -1, 0, 1, 0);
    s.camera.t = -(s.camera.R * Vec3d(0, 0, height));
    return s;
}

std::vector<Camera> handheldCameraPath(const Camera& first, int frames, double travel,
                                       double shake_m, double shake_deg, int seed) {
    CV_Assert(frames >= 1);
    RNG rng(seed);
    // Band-limited shake: a few random sinusoids per axis.
    struct Wave {
        double amp, freq, phase;
    };
    auto waves = [&](double amp) {
        std::vector<Wave> w;
        for (int i = 0; i < 3; ++i)
            w.push_back({amp * rng.uniform(0.3, 1.0), rng.uniform(0.05, 0.25),
                         rng.uniform(0.0, 2 * CV_PI)});
        return w;
    };
    std::vector<std::vector<Wave>> pos(3), rot(3);
    for (int a = 0; a < 3; ++a) {
        pos[a] = waves(shake_m);
        rot[a] = waves(shake_deg * CV_PI / 180);
    }
    auto eval = [](const std::vector<Wave>& w, double i) {
        double s = 0;
        for (const auto& x : w)
            s += x.amp * std::sin(2 * CV_PI * x.freq * i + x.phase);
        return s;
    };
    // The walk in the camera's horizontal frame: sideways (camera x) and forwards
    // (camera z projected on the floor), with a slow pan about world z.
    const Vec3d c0 = first.center();
    Vec3d right = first.R.t() * Vec3d(1, 0, 0), fwd = first.R.t() * Vec3d(0, 0, 1);
    right[2] = 0;
    fwd[2] = 0;
    right = normalize(right);
    fwd = normalize(fwd);
    std::vector<Camera> path;
    for (int i = 0; i < frames; ++i) {
        const double t = frames > 1 ? double(i) / (frames - 1) : 0;
        const Vec3d centre = c0 + right * (0.8 * travel * std::sin(CV_PI * t)) +
                             fwd * (0.6 * travel * t) +
                             Vec3d(eval(pos[0], i), eval(pos[1], i), eval(pos[2], i)) -
                             Vec3d(eval(pos[0], 0), eval(pos[1], 0), eval(pos[2], 0));
        const double pan = -0.35 * std::sin(CV_PI * t);  // radians about world z
        Mat Rpan;
        Rodrigues(Vec3d(0, 0, pan), Rpan);
        Mat Rshake;
        Rodrigues(Vec3d(eval(rot[0], i) - eval(rot[0], 0), eval(rot[1], i) - eval(rot[1], 0),
                        eval(rot[2], i) - eval(rot[2], 0)),
                  Rshake);
        Camera c = first;
        c.R = Matx33d(Rshake) * first.R * Matx33d(Rpan).t();
        c.t = -(c.R * centre);
        path.push_back(c);
    }
    return path;
}

}  // namespace vbme
}  // namespace cv
