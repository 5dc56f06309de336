// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// A synthetic hand-held room video with the user's annotation and a known answer, for object
// insertion (vbme demo, end-to-end tests).
#include "opencv2/vbme/datasets/insertion_sequence.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core/utility.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>
#include <opencv2/vbme/render/differential.hpp>
#include <opencv2/vbme/render/integrator.hpp>
#include <opencv2/vbme/render/placement.hpp>
#include <opencv2/vbme/render/scene.hpp>

namespace cv {
namespace vbme {

namespace fs = std::filesystem;

void writeTorusKnotObj(const std::string& path, double width, int segments, int sides) {
    CV_Assert(width > 0 && segments >= 16 && sides >= 6);
    // (p, q) = (2, 3) torus knot: radius R + r·cos(qφ) about z, height r·sin(qφ); tube radius a.
    const int p = 2, q = 3;
    const double a = 0.078 * width, r = 0.17 * width, R = width / 2 - r - a;
    auto curve = [&](double phi) {
        const double rho = R + r * std::cos(q * phi);
        return Vec3d(rho * std::cos(p * phi), rho * std::sin(p * phi), r * std::sin(q * phi));
    };
    auto tangent = [&](double phi) {
        const double rho = R + r * std::cos(q * phi), drho = -q * r * std::sin(q * phi);
        return normalize(Vec3d(drho * std::cos(p * phi) - p * rho * std::sin(p * phi),
                               drho * std::sin(p * phi) + p * rho * std::cos(p * phi),
                               q * r * std::cos(q * phi)));
    };
    // The tube's frame: b1 horizontal (T × z; T is never vertical on this knot), b2 = b1 × T
    // (mostly up). The frame is a function of φ, so the tube closes without a seam.
    std::vector<Vec3d> v, n;
    for (int i = 0; i < segments; ++i) {
        const double phi = 2 * CV_PI * i / segments;
        const Vec3d c = curve(phi), T = tangent(phi);
        const Vec3d b1 = normalize(T.cross(Vec3d(0, 0, 1))), b2 = b1.cross(T);
        for (int j = 0; j < sides; ++j) {
            const double th = 2 * CV_PI * j / sides;
            const Vec3d d = std::cos(th) * b1 + std::sin(th) * b2;
            v.push_back(c + a * d);
            n.push_back(d);
        }
    }
    // The bounding box's bottom centre becomes the origin.
    Vec3d lo(1e9, 1e9, 1e9), hi(-1e9, -1e9, -1e9);
    for (const Vec3d& x : v)
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], x[k]);
            hi[k] = std::max(hi[k], x[k]);
        }
    // Scaled to the exact width (the trefoil's extent depends on its turn about z).
    const double k = width / std::max(hi[0] - lo[0], hi[1] - lo[1]);
    for (Vec3d& x : v)
        x *= k;
    lo *= k;
    hi *= k;
    const Vec3d shift(-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]);
    AtomicFile file(path);
    {
        std::ofstream out(file.tempPath());
        out << "# vbme: a (2, 3) torus knot tube, " << width << " m wide, z up, base at z = 0\n";
        out.setf(std::ios::fixed);
        out.precision(6);
        for (const Vec3d& x : v)
            out << "v " << x[0] + shift[0] << ' ' << x[1] + shift[1] << ' ' << x[2] + shift[2]
                << '\n';
        for (const Vec3d& d : n)
            out << "vn " << d[0] << ' ' << d[1] << ' ' << d[2] << '\n';
        // Quads (i, j) → (i+1, j) → (i+1, j+1) → (i, j+1), wound counter-clockwise seen from
        // outside: (T, d_θ) is right-handed with the outward normal d.
        auto id = [&](int i, int j) { return (i % segments) * sides + (j % sides) + 1; };
        for (int i = 0; i < segments; ++i)
            for (int j = 0; j < sides; ++j) {
                const int A = id(i, j), B = id(i + 1, j), C = id(i + 1, j + 1), D = id(i, j + 1);
                out << "f " << A << "//" << A << ' ' << B << "//" << B << ' ' << C << "//" << C
                    << '\n';
                out << "f " << A << "//" << A << ' ' << C << "//" << C << ' ' << D << "//" << D
                    << '\n';
            }
        if (!out) CV_Error(Error::StsError, "writeTorusKnotObj: could not write '" + path + "'");
    }
    file.commit();
}

Matx44d floorPlacement(const Camera& camera, const Room& room, Point2d px, double yaw_rad) {
    Vec3d p;
    if (!floorPointUnderPixel(camera, room.min[2], px, p))
        CV_Error(Error::StsBadArg,
                 format("floorPlacement: the ray through pixel (%.1f, %.1f) does not go down to "
                        "the floor; choose a pixel below the horizon",
                        px.x, px.y));
    const double cs = std::cos(yaw_rad), sn = std::sin(yaw_rad);
    return Matx44d(cs, -sn, 0, p[0], sn, cs, 0, p[1], 0, 0, 1, room.min[2], 0, 0, 0, 1);
}

namespace {

// The visible part of a world segment in a camera: the longest run of samples in front of it
// and inside the image (2 px margin). Returns false when shorter than min_px.
bool visibleSegment(const Camera& cam, const Vec3d& A, const Vec3d& B, Vec4d& seg,
                    double min_px = 40) {
    const int n = 400;
    const Rect2d inside(2, 2, cam.image_size.width - 5, cam.image_size.height - 5);
    int best_a = -1, best_b = -1, cur = -1;
    for (int i = 0; i <= n; ++i) {
        double depth = 0;
        const Point2d p = cam.project(A + (B - A) * (double(i) / n), &depth);
        const bool ok = depth > 0.05 && inside.contains(p);
        if (ok && cur < 0) cur = i;
        if (cur >= 0 && (!ok || i == n)) {
            const int end = ok ? i : i - 1;
            if (end - cur > best_b - best_a) {
                best_a = cur;
                best_b = end;
            }
            cur = -1;
        }
    }
    if (best_a < 0) return false;
    const Point2d p = cam.project(A + (B - A) * (double(best_a) / n)),
                  q = cam.project(A + (B - A) * (double(best_b) / n));
    if (norm(p - q) < min_px) return false;
    seg = Vec4d(p.x, p.y, q.x, q.y);
    return true;
}

bool visiblePoint(const Camera& cam, const Vec3d& X, Point2d& p) {
    double depth = 0;
    p = cam.project(X, &depth);
    return depth > 0.05 &&
           Rect2d(5, 5, cam.image_size.width - 11, cam.image_size.height - 11).contains(p);
}

Light polygonLight(const std::vector<Vec3d>& corners, const Vec3d& radiance) {
    Light l;
    l.type = Light::POLYGON;
    l.corners = corners;
    l.radiance = radiance;
    return l;
}

}  // namespace

SyntheticInsertionSequence::Params::Params() = default;

struct SyntheticInsertionSequence::Impl {
    Params params_;
    std::string dir_;
    Scene scene_;
    std::vector<Camera> cameras_;
    FrameAnnotation annotation_;
    Ptr<RenderScene> render_scene_;  // built on the first renderFrame()
};

SyntheticInsertionSequence::SyntheticInsertionSequence(const std::string& dir, const Params& params)
    : impl_(std::make_shared<Impl>()) {
    impl_->params_ = params;
    impl_->dir_ = dir;
    Params& p = impl_->params_;
    CV_Assert(p.size.width >= 32 && p.size.height >= 32 && p.frames >= 1 && p.spp >= 1);
    if (p.focal <= 0) p.focal = 0.6 * p.size.width;
    if (p.place.x < 0 || p.place.y < 0) p.place = Point2d(0.6 * p.size.width, 0.78 * p.size.height);
    fs::create_directories(impl_->dir_);

    // The room (4 × 5 × 2.6 m) and the first camera, from the calibration tests' sequence.
    impl_->scene_ = syntheticRoomScene(p.size, p.focal, p.pitch_deg * CV_PI / 180, p.camera_height);
    Room& room = impl_->scene_.room;
    const auto textures = makeRoomTextures(p.seed, p.texture_size);
    for (const auto& kv : textures) {
        const std::string file = (fs::path(impl_->dir_) / ("tex_" + kv.first + ".png")).string();
        imwriteAtomic(file, kv.second);
        room.textures[kv.first] = fs::absolute(file).string();
    }
    // Lights in the room: a ceiling panel that the first frame sees near its top, and a
    // window-like panel on the back wall, right of centre.
    const double zc = room.max[2], yb = room.max[1];
    impl_->scene_.lights.push_back(
        polygonLight({{-0.45, 2.75, zc}, {-0.45, 3.45, zc}, {0.45, 3.45, zc}, {0.45, 2.75, zc}},
                     p.ceiling_radiance));
    if (p.wall_light)
        impl_->scene_.lights.push_back(
            polygonLight({{0.55, yb, 0.65}, {1.55, yb, 0.65}, {1.55, yb, 1.6}, {0.55, yb, 1.6}},
                         p.wall_radiance));
    for (const Light& l : impl_->scene_.lights)
        CV_Assert(l.polygonNormal().dot(Vec3d(0, 1, 1.5) - l.corners[0]) > 0);  // lit side in

    // The object on the floor under the first frame's pixel `place`.
    const std::string mesh = (fs::path(impl_->dir_) / "object.obj").string();
    writeTorusKnotObj(mesh, p.object_width);
    SceneObject obj;
    obj.mesh = fs::absolute(mesh).string();
    obj.has_material = true;
    obj.material.type = Material::PLASTIC;
    obj.material.albedo = p.object_albedo;
    obj.material.roughness = p.object_roughness;
    obj.material.ior = 1.5;
    obj.world_from_object =
        floorPlacement(impl_->scene_.camera, room, p.place, p.object_yaw_deg * CV_PI / 180);
    impl_->scene_.objects.push_back(obj);
    impl_->scene_.render.spp = p.spp;
    impl_->scene_.render.max_depth = p.max_depth;
    impl_->scene_.render.seed = (uint64)p.seed;
    impl_->scene_.write((fs::path(impl_->dir_) / "true_scene.yml").string());

    impl_->cameras_ = handheldCameraPath(impl_->scene_.camera, p.frames, p.travel, p.shake_m,
                                         p.shake_deg, p.seed + 4);
    truePath().write(trueCamerasPath());

    // What a person clicks on frame 0: room edges, wall/floor/ceiling points, light polygons.
    const Camera& cam = impl_->scene_.camera;
    RNG rng((uint64)p.seed * 7717u + 13u);
    auto noisy = [&](Point2d q) {
        return Point2d(q.x + rng.gaussian(p.click_noise_px), q.y + rng.gaussian(p.click_noise_px));
    };
    const Vec3d lo = room.min, hi = room.max;
    FrameAnnotation& ann = impl_->annotation_;
    ann.image_size = p.size;
    ann.camera_height = p.camera_height;
    ann.has_response = true;
    ann.response = Response::SRGB;
    struct Group {
        const char* name;
        AxisHint axis;
        std::vector<std::pair<Vec3d, Vec3d>> edges;
    };
    const std::vector<Group> groups = {{"along_back_wall",
                                        AxisHint::HORIZONTAL,
                                        {{{lo[0], hi[1], lo[2]}, {hi[0], hi[1], lo[2]}},
                                         {{lo[0], hi[1], hi[2]}, {hi[0], hi[1], hi[2]}}}},
                                       {"along_side_walls",
                                        AxisHint::HORIZONTAL,
                                        {{{lo[0], lo[1], lo[2]}, {lo[0], hi[1], lo[2]}},
                                         {{hi[0], lo[1], lo[2]}, {hi[0], hi[1], lo[2]}},
                                         {{lo[0], lo[1], hi[2]}, {lo[0], hi[1], hi[2]}},
                                         {{hi[0], lo[1], hi[2]}, {hi[0], hi[1], hi[2]}}}},
                                       {"room_corners",
                                        AxisHint::VERTICAL,
                                        {{{lo[0], hi[1], lo[2]}, {lo[0], hi[1], hi[2]}},
                                         {{hi[0], hi[1], lo[2]}, {hi[0], hi[1], hi[2]}}}}};
    for (const Group& g : groups) {
        LineGroup lg;
        lg.name = g.name;
        lg.axis = g.axis;
        for (const auto& e : g.edges) {
            Vec4d s;
            if (!visibleSegment(cam, e.first, e.second, s)) continue;
            const Point2d a = noisy(Point2d(s[0], s[1])), b = noisy(Point2d(s[2], s[3]));
            lg.segments.push_back(Vec4d(a.x, a.y, b.x, b.y));
        }
        if (lg.segments.size() >= 2) ann.lines.push_back(lg);
    }
    if (ann.lines.size() < 2)
        CV_Error(Error::StsError,
                 "SyntheticInsertionSequence: fewer than two line groups are in view of frame 0 "
                 "(change focal or pitch)");
    auto addPoint = [&](std::vector<Point2d>& pts, const Vec3d& X) {
        Point2d q;
        if (visiblePoint(cam, X, q)) pts.push_back(noisy(q));
    };
    for (double x : {0.5 * lo[0], 0.5 * hi[0]})
        addPoint(ann.room.floor_edges["back"], Vec3d(x, hi[1], lo[2]));
    addPoint(ann.room.floor_edges["left"], Vec3d(lo[0], hi[1] - 0.4, lo[2]));
    addPoint(ann.room.floor_edges["right"], Vec3d(hi[0], hi[1] - 0.4, lo[2]));
    addPoint(ann.room.ceiling_edges["back"], Vec3d(-0.3, hi[1], hi[2]));
    for (auto* m : {&ann.room.floor_edges, &ann.room.ceiling_edges})
        for (auto it = m->begin(); it != m->end();)
            it = it->second.empty() ? m->erase(it) : std::next(it);
    // Faces out of view or not clicked are given as measured numbers.
    ann.room.faces["front"] = lo[1];
    if (!ann.room.floor_edges.count("left")) ann.room.faces["left"] = lo[0];
    if (!ann.room.floor_edges.count("right")) ann.room.faces["right"] = hi[0];
    if (!ann.room.ceiling_edges.count("back")) ann.room.faces["ceiling"] = hi[2];
    for (const Light& l : impl_->scene_.lights) {
        LightAnnotation la;
        for (const Vec3d& X : l.corners) {
            double depth = 0;
            const Point2d q = cam.project(X, &depth);
            if (depth <= 0)
                CV_Error(Error::StsError, "SyntheticInsertionSequence: a light is behind frame 0");
            la.polygon.push_back(noisy(q));
        }
        la.face = std::abs(l.corners[0][2] - hi[2]) < 1e-9 ? "ceiling" : "back";
        ann.lights.push_back(la);
    }
    ann.write(annotationPath());
}

SyntheticInsertionSequence::~SyntheticInsertionSequence() = default;

const SyntheticInsertionSequence::Params& SyntheticInsertionSequence::params() const {
    return impl_->params_;
}
const std::string& SyntheticInsertionSequence::dir() const {
    return impl_->dir_;
}
const Scene& SyntheticInsertionSequence::trueScene() const {
    return impl_->scene_;
}
const std::vector<Camera>& SyntheticInsertionSequence::cameras() const {
    return impl_->cameras_;
}
const FrameAnnotation& SyntheticInsertionSequence::annotation() const {
    return impl_->annotation_;
}
const SceneObject& SyntheticInsertionSequence::object() const {
    return impl_->scene_.objects.front();
}

CameraPath SyntheticInsertionSequence::truePath() const {
    CameraPath path;
    path.K = impl_->scene_.camera.K;
    path.image_size = impl_->params_.size;
    for (size_t i = 0; i < impl_->cameras_.size(); ++i) {
        CameraPath::Frame f;
        f.index = (int)i;
        f.R = impl_->cameras_[i].R;
        f.t = impl_->cameras_[i].t;
        f.source = CameraPath::SFM;
        path.frames.push_back(f);
    }
    return path;
}

void SyntheticInsertionSequence::addObject(Scene& scene) const {
    CV_Assert(scene.has_room);
    SceneObject obj = object();
    obj.world_from_object = floorPlacement(scene.camera, scene.room, impl_->params_.place,
                                           impl_->params_.object_yaw_deg * CV_PI / 180);
    scene.objects.push_back(obj);
    scene.render.spp = impl_->params_.spp;
    scene.render.max_depth = impl_->params_.max_depth;
    scene.render.seed = (uint64)impl_->params_.seed;
}

std::string SyntheticInsertionSequence::annotationPath() const {
    return (fs::path(impl_->dir_) / "annotation.yml").string();
}
std::string SyntheticInsertionSequence::trueScenePath() const {
    return (fs::path(impl_->dir_) / "true_scene.yml").string();
}
std::string SyntheticInsertionSequence::trueCamerasPath() const {
    return (fs::path(impl_->dir_) / "true_cameras.yml").string();
}
std::string SyntheticInsertionSequence::inputVideoPath() const {
    return (fs::path(impl_->dir_) / "input.mkv").string();
}
std::string SyntheticInsertionSequence::truthVideoPath() const {
    return (fs::path(impl_->dir_) / "truth.mkv").string();
}
std::string SyntheticInsertionSequence::regionPath(int i) const {
    return (fs::path(impl_->dir_) / "region" / maskFileName(i)).string();
}

void SyntheticInsertionSequence::renderFrame(int i, Mat& input, Mat& truth, Mat& region,
                                             int seed) const {
    CV_Assert(i >= 0 && i < (int)impl_->cameras_.size());
    if (!impl_->render_scene_) impl_->render_scene_ = RenderScene::create(impl_->scene_);
    Renderer::Params rp;
    rp.spp = impl_->params_.spp;
    rp.max_depth = impl_->params_.max_depth;
    rp.seed = (uint64)(seed >= 0 ? seed : impl_->params_.seed);
    rp.threads = impl_->params_.threads;
    const Ptr<Renderer> renderer = Renderer::create(rp);
    RenderImages with, without;
    renderer->renderDifferential(*impl_->render_scene_, impl_->cameras_[i], with, without);
    encode(without.color, input, Response::SRGB, CV_8U);
    encode(with.color, truth, Response::SRGB, CV_8U);
    // Where the object changes the picture: its silhouette (dilated), and its shadow and
    // reflections: the smoothed luminance change above 2 % of the frame's mean luminance.
    Mat d = with.color - without.color, lum, lum0;
    cvtColor(d, lum, COLOR_BGR2GRAY);
    lum = abs(lum);
    GaussianBlur(lum, lum, Size(0, 0), 2.0);
    cvtColor(without.color, lum0, COLOR_BGR2GRAY);
    const double thr = 0.02 * mean(lum0)[0];
    Mat sil = with.mask > 0.f, shadow = lum > thr;
    dilate(sil, sil, getStructuringElement(MORPH_ELLIPSE, Size(13, 13)));
    region = sil | shadow;
}

void SyntheticInsertionSequence::renderDifferentialTruth(int i, InputArray input_in, int spp,
                                                         int seed, Mat& truth, Mat* half_difference,
                                                         Rect roi) const {
    CV_Assert(i >= 0 && i < (int)impl_->cameras_.size());
    CV_Assert(spp >= 2 && seed >= 0);
    const Mat input = input_in.getMat();
    CV_Assert(input.type() == CV_8UC3 && input.size() == impl_->params_.size);
    const Rect frame(Point(0, 0), input.size());
    roi = roi.area() > 0 ? (roi & frame) : frame;
    CV_Assert(roi.area() > 0);
    if (!impl_->render_scene_) impl_->render_scene_ = RenderScene::create(impl_->scene_);
    // the frame's camera, cropped to roi: pixel (x, y) of the crop is pixel roi.tl() + (x, y)
    Camera cam = impl_->cameras_[i];
    cam.K(0, 2) -= roi.x;
    cam.K(1, 2) -= roi.y;
    cam.image_size = roi.size();
    const Mat bg = input(roi);
    CompositeParams cp;
    cp.response = Response::SRGB;
    cp.shadows = CompositeParams::SHADOWS_ADDITIVE;
    DifferentialImages half[2];
    for (int h = 0; h < 2; ++h) {
        DifferentialRenderer::Params dp;
        dp.render.spp = (spp + 1) / 2;
        dp.render.max_depth = impl_->params_.max_depth;
        dp.render.seed = (uint64)seed + (uint64)h;
        dp.render.threads = impl_->params_.threads;
        DifferentialRenderer::create(dp)->render(*impl_->render_scene_, cam, half[h]);
    }
    auto display = [&](const DifferentialImages& im) {
        Mat d;
        compositeDifferentialDisplay(bg, im, d, cp);
        return d;
    };
    DifferentialImages mean_layers;
    mean_layers.obj = (half[0].obj + half[1].obj) * 0.5;
    mean_layers.noobj = (half[0].noobj + half[1].noobj) * 0.5;
    mean_layers.diff = (half[0].diff + half[1].diff) * 0.5;
    mean_layers.mask = (half[0].mask + half[1].mask) * 0.5;
    truth = input.clone();
    Mat truth_roi = truth(roi);  // a view: converted in place
    display(mean_layers).convertTo(truth_roi, CV_8U);
    if (half_difference) {
        half_difference->create(input.size(), CV_32FC3);
        half_difference->setTo(Scalar::all(0));
        Mat half_roi = (*half_difference)(roi);
        Mat((display(half[0]) - display(half[1])) * 0.5).copyTo(half_roi);
    }
}

double SyntheticInsertionSequence::writeVideos(bool force) const {
    const int n = (int)impl_->cameras_.size();
    auto complete = [&](const std::string& video) {
        if (!fs::exists(video)) return false;
        VideoReader r(video);
        return r.frameCount() == n && r.frameSize() == impl_->params_.size;
    };
    if (!force && complete(inputVideoPath()) && complete(truthVideoPath()) &&
        fs::exists(regionPath(n - 1)) && !fs::exists(regionPath(n)))
        return 0;
    fs::remove_all(fs::path(impl_->dir_) / "region");
    fs::create_directories(fs::path(impl_->dir_) / "region");
    VideoSink in(inputVideoPath(), impl_->params_.fps, impl_->params_.size),
        tr(truthVideoPath(), impl_->params_.fps, impl_->params_.size);
    Progress progress("render synthetic room", n);
    double seconds = 0;
    {
        ScopedTimer timer(seconds);
        for (int i = 0; i < n; ++i) {
            Mat input, truth, region;
            renderFrame(i, input, truth, region);
            in.write(input);
            tr.write(truth);
            imwriteAtomic(regionPath(i), region);
            progress.tick();
        }
        progress.finish();
        in.close();
        tr.close();
    }
    return seconds / n;
}

}  // namespace vbme
}  // namespace cv
