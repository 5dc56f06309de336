// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/datasets/rendered_ball_clip.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/render.hpp>
#include <opencv2/vbme/track/disk.hpp>

#ifdef _WIN32
#include <process.h>
#define VBME_GETPID _getpid
#else
#include <unistd.h>
#define VBME_GETPID getpid
#endif

namespace cv {
namespace vbme {

namespace {

namespace fs = std::filesystem;

// Scene layout (see the class documentation).
const double kBallRadius = 0.18;
const Vec3d kCameraPos(-2.4, 0, 1.2);
const double kPitchDeg = 25;
const double kHfovDeg = 60;
const Vec2d kPathStart(-0.35, 0.55), kPathEnd(0.15, -0.55);
const double kWallX = 1.6;
const double kFloorY = 6, kFloorXMin = -4.5;  // floor: x in [-4.5, wall], y in [-6, 6]
const double kWallTop = 3.0;
const double kTexMetres = 1.6;  // one texture repeat covers 1.6 m × 1.6 m
const double kSunIrradiance = 2.8, kSunHalfAngleDeg = 2;
const Vec3d kSunColour(1.0, 0.96, 0.9), kSky(0.2, 0.23, 0.28);
const int kMaxDepth = 5;

// Multi-scale value noise in [-1, 1] (roughly), deterministic in rng.
Mat valueNoise(RNG& rng, int size, int coarsest, int finest) {
    Mat acc(size, size, CV_32F, Scalar(0));
    double total = 0;
    for (int cells = coarsest; cells <= finest; cells *= 2) {
        Mat small(cells + 1, cells + 1, CV_32F), up;
        rng.fill(small, RNG::UNIFORM, -1, 1);
        resize(small, up, Size(size, size), 0, 0, INTER_CUBIC);
        const double w = 1.0 / std::sqrt((double)cells);
        acc += up * w;
        total += w;
    }
    return acc / total;
}

// Floor: 4 × 4 tiles per texture, warm grey and slate in a checkerboard with per-tile
// lightness jitter, grime, dark grout and a few grey scuffs. Low saturation (HSV S < 0.25).
Mat floorTexture(int size, uint64 seed) {
    RNG rng(seed * 7919 + 11);
    const int tiles = 4, tile = size / tiles, grout = std::max(2, size / 170);
    const Vec3f light(160, 166, 172), slate(118, 104, 96);  // BGR
    Mat tex(size, size, CV_32FC3);
    const Mat grime = valueNoise(rng, size, 4, 128);
    std::vector<float> jitter(tiles * tiles);
    for (float& j : jitter)
        j = (float)rng.uniform(-14.0, 14.0);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const int tx = x / tile, ty = y / tile;
            Vec3f c = ((tx + ty) % 2 == 0) ? light : slate;
            const float g = jitter[ty * tiles + tx] + 22.f * grime.at<float>(y, x);
            c += Vec3f(g, g, g);
            if (x % tile < grout || y % tile < grout) c = Vec3f(62, 64, 66) + Vec3f(g, g, g) * 0.3f;
            tex.at<Vec3f>(y, x) = c;
        }
    Mat img;
    tex.convertTo(img, CV_8UC3);
    for (int i = 0; i < 60; ++i) {  // scuffs
        const int v = rng.uniform(40, 220);
        const Point a(rng.uniform(0, size), rng.uniform(0, size));
        const Point b =
            a + Point(rng.uniform(-size / 12, size / 12), rng.uniform(-size / 12, size / 12));
        line(img, a, b, Scalar(v, v, v + 4), rng.uniform(1, 4), LINE_AA);
    }
    GaussianBlur(img, img, Size(0, 0), 0.7);
    return img;
}

// Wall: staggered blocks (8 rows of 4), pale grey-green with lightness jitter and noise,
// light mortar, a few darker stains. Low saturation.
Mat wallTexture(int size, uint64 seed) {
    RNG rng(seed * 104729 + 5);
    const int rows = 8, cols = 4, bh = size / rows, bw = size / cols,
              mortar = std::max(2, size / 200);
    const Mat grime = valueNoise(rng, size, 4, 256);
    std::vector<float> jitter(rows * (cols + 1));
    std::vector<Vec3f> tint(rows * (cols + 1));
    for (size_t i = 0; i < jitter.size(); ++i) {
        jitter[i] = (float)rng.uniform(-22.0, 22.0);
        tint[i] = Vec3f((float)rng.uniform(-6.0, 6.0), (float)rng.uniform(-6.0, 6.0),
                        (float)rng.uniform(-6.0, 6.0));
    }
    Mat tex(size, size, CV_32FC3);
    for (int y = 0; y < size; ++y) {
        const int r = y / bh, off = (r % 2) * bw / 2;
        for (int x = 0; x < size; ++x) {
            const int xs = (x + off) % size, c = xs / bw;
            const int id = r * (cols + 1) + c;
            const float g = jitter[id] + 18.f * grime.at<float>(y, x);
            Vec3f v = Vec3f(150, 160, 140) + tint[id] + Vec3f(g, g, g);
            if (y % bh < mortar || xs % bw < mortar)
                v = Vec3f(196, 198, 200) + Vec3f(g, g, g) * 0.3f;
            tex.at<Vec3f>(y, x) = v;
        }
    }
    Mat img;
    tex.convertTo(img, CV_8UC3);
    for (int i = 0; i < 25; ++i) {  // stains
        const int v = rng.uniform(70, 130);
        circle(img, Point(rng.uniform(0, size), rng.uniform(0, size)),
               rng.uniform(size / 100, size / 30), Scalar(v, v + 6, v), FILLED, LINE_AA);
    }
    GaussianBlur(img, img, Size(0, 0), 0.7);
    return img;
}

// A textured quad as OBJ + MTL: corners p0..p3 (counter-clockwise seen from the front), uv in
// metres / kTexMetres.
void writeQuad(const fs::path& obj, const std::string& tex_name, const Vec3d p[4],
               const Vec2d uv[4]) {
    const std::string mtl = obj.stem().string() + ".mtl";
    {
        AtomicFile f((obj.parent_path() / mtl).string());
        std::ofstream o(f.tempPath());
        o << "newmtl m\nKd 1 1 1\nKs 0 0 0\nmap_Kd " << tex_name << "\n";
        o.close();
        if (!o) CV_Error(Error::StsError, "RenderedBallClip: cannot write " + f.finalPath());
        f.commit();
    }
    AtomicFile f(obj.string());
    std::ofstream o(f.tempPath());
    o.precision(9);
    o << "mtllib " << mtl << "\nusemtl m\n";
    for (int i = 0; i < 4; ++i)
        o << "v " << p[i][0] << ' ' << p[i][1] << ' ' << p[i][2] << '\n';
    for (int i = 0; i < 4; ++i)
        o << "vt " << uv[i][0] << ' ' << uv[i][1] << '\n';
    o << "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    o.close();
    if (!o) CV_Error(Error::StsError, "RenderedBallClip: cannot write " + f.finalPath());
    f.commit();
}

// A unit UV sphere with smooth vertex normals, z the pole axis.
void writeSphere(const fs::path& obj, int stacks, int slices) {
    AtomicFile f(obj.string());
    std::ofstream o(f.tempPath());
    o.precision(9);
    // Vertices: north pole, (stacks − 1) rings of `slices`, south pole.
    o << "v 0 0 1\nvn 0 0 1\n";
    for (int i = 1; i < stacks; ++i) {
        const double th = CV_PI * i / stacks;
        for (int j = 0; j < slices; ++j) {
            const double ph = 2 * CV_PI * j / slices;
            const double x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph),
                         z = std::cos(th);
            o << "v " << x << ' ' << y << ' ' << z << "\nvn " << x << ' ' << y << ' ' << z << '\n';
        }
    }
    o << "v 0 0 -1\nvn 0 0 -1\n";
    auto ring = [&](int i, int j) { return 2 + (i - 1) * slices + (j % slices); };  // 1-based
    const int south = 2 + (stacks - 1) * slices;
    auto face = [&](int a, int b, int c) {
        o << "f " << a << "//" << a << ' ' << b << "//" << b << ' ' << c << "//" << c << '\n';
    };
    for (int j = 0; j < slices; ++j)
        face(1, ring(1, j), ring(1, j + 1));
    for (int i = 1; i + 1 < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            face(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
            face(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
        }
    for (int j = 0; j < slices; ++j)
        face(south, ring(stacks - 1, j + 1), ring(stacks - 1, j));
    o.close();
    if (!o) CV_Error(Error::StsError, "RenderedBallClip: cannot write " + f.finalPath());
    f.commit();
}

Matx33d rodrigues(const Vec3d& axis_angle) {
    Mat R;
    Rodrigues(Mat(axis_angle), R);
    return Matx33d(R);
}

}  // namespace

struct RenderedBallClip::Impl {
    Params p;
    fs::path dir;
    Camera camera;
    Scene base;  // everything but the ball's placement

    ~Impl() {
        std::error_code ec;
        if (!dir.empty()) fs::remove_all(dir, ec);
    }
};

RenderedBallClip::Params::Params() {}

RenderedBallClip::RenderedBallClip(const Params& p) : impl_(std::make_shared<Impl>()) {
    if (p.size.width < 16 || p.size.height < 16)
        CV_Error(Error::StsBadArg,
                 format("RenderedBallClip: size %dx%d is too small (expected at least 16x16)",
                        p.size.width, p.size.height));
    if (p.frames < 1)
        CV_Error(Error::StsBadArg,
                 format("RenderedBallClip: frames = %d (expected >= 1)", p.frames));
    if (p.spp < 1)
        CV_Error(Error::StsBadArg, format("RenderedBallClip: spp = %d (expected >= 1)", p.spp));
    if (!(p.fps > 0)) CV_Error(Error::StsBadArg, "RenderedBallClip: fps must be positive");
    for (int c = 0; c < 3; ++c)
        if (!(p.albedo[c] >= 0 && p.albedo[c] <= 1))
            CV_Error(Error::StsBadArg, "RenderedBallClip: albedo components must lie in [0, 1]");
    if (p.has_material && p.material.type == Material::EMISSIVE)
        CV_Error(Error::StsBadArg,
                 "RenderedBallClip: the ball cannot be emissive (expected a reflecting or "
                 "refracting material)");
    if (!(norm(p.to_light) > 0) || !(p.to_light[2] > 0.1 * norm(p.to_light)))
        CV_Error(Error::StsBadArg,
                 "RenderedBallClip: to_light must point above the floor (z > 0.1·|to_light|)");
    Impl& m = *impl_;
    m.p = p;

    // Private folder for the meshes and textures.
    static std::atomic<unsigned> counter{0};
    const auto stamp =
        (unsigned long long)std::chrono::steady_clock::now().time_since_epoch().count();
    m.dir = fs::temp_directory_path() /
            format("vbme-ballclip-%d-%u-%llx", (int)VBME_GETPID(), counter.fetch_add(1), stamp);
    fs::create_directories(m.dir);
    // Texture resolution follows the frame width (1024 at 640 pixels: a texel is smaller than a
    // pixel everywhere on the floor), so that small test clips are quick to prepare.
    const int tex_size = std::min(1024, std::max(256, (p.size.width * 8 / 5 + 63) / 64 * 64));
    imwriteAtomic((m.dir / "floor.png").string(), floorTexture(tex_size, p.seed),
                  {IMWRITE_PNG_COMPRESSION, 1});
    imwriteAtomic((m.dir / "wall.png").string(), wallTexture(tex_size, p.seed),
                  {IMWRITE_PNG_COMPRESSION, 1});
    {
        const Vec3d f[4] = {Vec3d(kFloorXMin, -kFloorY, 0), Vec3d(kWallX, -kFloorY, 0),
                            Vec3d(kWallX, kFloorY, 0), Vec3d(kFloorXMin, kFloorY, 0)};
        Vec2d uv[4];
        for (int i = 0; i < 4; ++i)
            uv[i] = Vec2d(f[i][0] / kTexMetres, f[i][1] / kTexMetres);
        writeQuad(m.dir / "floor.obj", "floor.png", f, uv);
        // The wall faces −x (towards the camera): counter-clockwise seen from −x, where image
        // right is −y and image up is +z.
        const Vec3d w[4] = {Vec3d(kWallX, kFloorY, 0), Vec3d(kWallX, -kFloorY, 0),
                            Vec3d(kWallX, -kFloorY, kWallTop), Vec3d(kWallX, kFloorY, kWallTop)};
        for (int i = 0; i < 4; ++i)
            uv[i] = Vec2d(-w[i][1] / kTexMetres, w[i][2] / kTexMetres);
        writeQuad(m.dir / "wall.obj", "wall.png", w, uv);
    }
    writeSphere(m.dir / "ball.obj", 48, 96);

    // Camera: looking along +x, pitched down, 60° horizontal field of view.
    const double f = 0.5 * p.size.width / std::tan(kHfovDeg * CV_PI / 360);
    m.camera = Camera::fromFocal(f, p.size);
    m.camera.response = Response::SRGB;
    // Level camera looking along +x: x_cam = −y_world (right), y_cam = −z_world (down),
    // z_cam = x_world (forward); then pitch down about the camera's x axis.
    const Matx33d level(0, -1, 0, 0, 0, -1, 1, 0, 0);
    m.camera.R = rodrigues(Vec3d(kPitchDeg * CV_PI / 180, 0, 0)) * level;
    m.camera.t = -(m.camera.R * kCameraPos);

    Scene& s = m.base;
    s.image_size = p.size;
    s.camera = m.camera;
    s.has_room = false;
    SceneObject floor, wall;
    floor.mesh = (m.dir / "floor.obj").string();
    wall.mesh = (m.dir / "wall.obj").string();
    s.proxies = {floor, wall};
    Light sun;
    sun.type = Light::DISTANT;
    sun.to_light = p.to_light / norm(p.to_light);
    sun.half_angle_deg = kSunHalfAngleDeg;
    const double s2 = std::sin(kSunHalfAngleDeg * CV_PI / 180);
    sun.radiance = kSunColour * (kSunIrradiance / (CV_PI * s2 * s2));  // E = L·π·sin²(half angle)
    Light sky;
    sky.type = Light::ENVIRONMENT;
    sky.radiance = kSky;
    s.lights = {sun, sky};
    s.render.spp = p.spp;
    s.render.max_depth = kMaxDepth;
    s.render.seed = p.seed;
}

const RenderedBallClip::Params& RenderedBallClip::params() const {
    return impl_->p;
}

double RenderedBallClip::ballRadius() const {
    return kBallRadius;
}

Vec3d RenderedBallClip::ballCenter(int i) const {
    const Params& p = impl_->p;
    CV_Assert(i >= 0 && i < p.frames);
    const double a = p.frames > 1 ? double(i) / (p.frames - 1) : 0.0;
    const Vec2d xy = kPathStart + (kPathEnd - kPathStart) * a;
    return Vec3d(xy[0], xy[1], kBallRadius);
}

Scene RenderedBallClip::scene(int frame) const {
    const Params& p = impl_->p;
    if (frame < 0 || frame >= p.frames)
        CV_Error(Error::StsOutOfRange,
                 format("RenderedBallClip: frame %d out of range (the clip has %d frames)", frame,
                        p.frames));
    Scene s = impl_->base;
    s.render.seed = p.seed + (uint64)frame;
    // Rolling without slipping: rotation by distance / radius about z × direction.
    const Vec3d c = ballCenter(frame), c0 = ballCenter(0);
    const Vec3d travel = c - c0;
    const Vec3d dir = kPathEnd[0] == kPathStart[0] && kPathEnd[1] == kPathStart[1]
                          ? Vec3d(1, 0, 0)
                          : Vec3d(kPathEnd[0] - kPathStart[0], kPathEnd[1] - kPathStart[1], 0) /
                                norm(kPathEnd - kPathStart);
    const Vec3d axis = Vec3d(0, 0, 1).cross(dir);
    const Matx33d R = rodrigues(axis * (norm(travel) / kBallRadius));
    SceneObject ball;
    ball.mesh = (impl_->dir / "ball.obj").string();
    ball.has_material = true;
    if (p.has_material) {
        ball.material = p.material;
    } else {
        ball.material.type = Material::LAMBERTIAN;
        ball.material.albedo = p.albedo;
    }
    Matx44d W = Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k)
            W(r, k) = R(r, k) * kBallRadius;
        W(r, 3) = c[r];
    }
    ball.world_from_object = W;
    s.objects = {ball};
    return s;
}

Mat RenderedBallClip::frameLinear(int i) const {
    const Scene s = scene(i);
    const Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params rp = Renderer::Params::fromScene(s.render);
    rp.aovs = false;
    const Ptr<Renderer> r = Renderer::create(rp);
    RenderImages out;
    r->render(*rs, s.camera, out);
    return out.color;
}

Mat RenderedBallClip::frame(int i) const {
    Mat bgr;
    encode(frameLinear(i), bgr, impl_->camera.response, CV_8U);
    return bgr;
}

namespace {
// The sphere's perspective silhouette in frame i, as image points.
std::vector<Point2d> silhouette(const Camera& cam, const Vec3d& centre_world, double radius,
                                int n) {
    const Vec3d s = cam.camFromWorld(centre_world);
    const double D = norm(s);
    CV_Assert(D > radius);
    const Vec3d a = s / D;
    Vec3d e1 = std::abs(a[0]) < 0.9 ? Vec3d(1, 0, 0).cross(a) : Vec3d(0, 1, 0).cross(a);
    e1 /= norm(e1);
    const Vec3d e2 = a.cross(e1);
    const double sa = radius / D, ca = std::sqrt(1 - sa * sa);
    std::vector<Point2d> pts(n);
    for (int k = 0; k < n; ++k) {
        const double ph = 2 * CV_PI * k / n;
        const Vec3d d = a * ca + (e1 * std::cos(ph) + e2 * std::sin(ph)) * sa;
        const Vec3d q = cam.K * d;
        pts[k] = Point2d(q[0] / q[2], q[1] / q[2]);
    }
    return pts;
}

Disk equalAreaDisk(const std::vector<Point2d>& pts) {
    double A = 0, cx = 0, cy = 0;
    const size_t n = pts.size();
    for (size_t k = 0; k < n; ++k) {
        const Point2d& p = pts[k];
        const Point2d& q = pts[(k + 1) % n];
        const double c = p.x * q.y - q.x * p.y;
        A += c;
        cx += (p.x + q.x) * c;
        cy += (p.y + q.y) * c;
    }
    A *= 0.5;
    cx /= 6 * A;
    cy /= 6 * A;
    return Disk(Point2f((float)cx, (float)cy), (float)std::sqrt(std::abs(A) / CV_PI));
}
}  // namespace

Disk RenderedBallClip::truthDisk(int i) const {
    return equalAreaDisk(silhouette(impl_->camera, ballCenter(i), kBallRadius, 720));
}

double RenderedBallClip::truthDiskError(int i) const {
    const std::vector<Point2d> pts = silhouette(impl_->camera, ballCenter(i), kBallRadius, 720);
    const Disk d = equalAreaDisk(pts);
    double e = 0;
    for (const Point2d& p : pts)
        e = std::max(e, std::abs(norm(p - Point2d(d.center.x, d.center.y)) - d.radius));
    return e;
}

Vec3d RenderedBallClip::truthLightDirCamera() const {
    const Vec3d l = impl_->camera.R * impl_->p.to_light;
    return l / norm(l);
}

double RenderedBallClip::focal() const {
    return impl_->camera.K(0, 0);
}

void RenderedBallClip::write(const std::string& video, const std::string& first_mask) const {
    const Params& p = impl_->p;
    if (!first_mask.empty()) {
        Mat mask;
        diskMask(p.size, truthDisk(0), mask);
        imwriteAtomic(first_mask, mask);
    }
    VideoSink sink(video, p.fps, p.size);
    Progress progress("render clip", p.frames);
    for (int i = 0; i < p.frames; ++i) {
        sink.write(frame(i));
        progress.tick();
    }
    progress.finish();
    sink.close();
}

void RenderedBallClip::writeTruth(const std::string& csv) const {
    AtomicFile f(csv);
    {
        std::ofstream o(f.tempPath());
        o << "frame,cx,cy,r\n";
        for (int i = 0; i < impl_->p.frames; ++i) {
            const Disk d = truthDisk(i);
            o << format("%d,%.4f,%.4f,%.4f\n", i, d.center.x, d.center.y, d.radius);
        }
        o.close();
        if (!o) CV_Error(Error::StsError, "RenderedBallClip: cannot write " + csv);
    }
    f.commit();
}

}  // namespace vbme
}  // namespace cv
