// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Command-line tests of `vbme render`.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::run;
using vbme_test::ScratchDir;

namespace {

// A box room [lo, hi] lit by a 1 m² ceiling panel at z = 2.5, seen by `cam`.
Scene litRoom(const Camera& cam, const Vec3d& lo, const Vec3d& hi) {
    Scene s;
    s.image_size = cam.image_size;
    s.camera = cam;
    s.has_room = true;
    s.room.min = lo;
    s.room.max = hi;
    Light l;
    l.type = Light::POLYGON;
    l.corners = {Vec3d(-0.5, 0.5, 2.5), Vec3d(0.5, 0.5, 2.5), Vec3d(0.5, -0.5, 2.5),
                 Vec3d(-0.5, -0.5, 2.5)};
    l.radiance = Vec3d(5, 5, 5);
    s.lights = {l};
    return s;
}

// A small room with a ceiling light and a cube, written as a scene file.
std::string writeScene(const ScratchDir& dir, bool broken_mesh = false) {
    vbme_test::writeCubeObj(dir / "cube.obj");
    Scene s = litRoom(vbme_test::lookAt(Vec3d(0, -1.4, 1.2), Vec3d(0, 0.3, 0.5), 14, Size(16, 12)),
                      Vec3d(-1.5, -1.5, 0), Vec3d(1.5, 1.5, 2.5));
    SceneObject o;
    o.mesh = broken_mesh ? dir / "nothere.obj" : dir / "cube.obj";
    o.world_from_object = vbme_test::placement(0.4, Vec3d(0, 0.3, 0.2));
    o.has_material = true;
    o.material = vbme_test::lambertian(Vec3d(0.7, 0.4, 0.2));
    s.objects = {o};
    s.render.spp = 2;
    s.render.max_depth = 3;
    s.render.seed = 5;
    const std::string path = dir / (broken_mesh ? "broken.yml" : "scene.yml");
    s.write(path);
    return path;
}

std::string exe() {
    return std::string(VBME_EXE) + " render -q";
}

int countFiles(const ScratchDir& dir) {
    int n = 0;
    for (auto& e : std::filesystem::directory_iterator(dir.path()))
        (void)e, ++n;
    return n;
}

}  // namespace

TEST(AppRender, UsageErrorsExitTwo) {
    ScratchDir dir;
    const std::string scene = writeScene(dir);
    EXPECT_EQ(run(exe() + " --out " + dir / "a.exr").code, 2);                        // no --scene
    EXPECT_EQ(run(exe() + " --scene " + scene + " --out " + dir / "a.png").code, 2);  // not EXR
    EXPECT_EQ(run(exe() + " --scene " + scene + " --out " + dir / "a.exr --width 8").code, 2);
    EXPECT_EQ(run(exe() + " --scene " + scene + " --out " + dir / "a.exr --spp 0").code, 2);
    EXPECT_EQ(run(exe() + " --scene " + scene + " --out " + dir / "a.exr --frame 0").code, 2);
    EXPECT_EQ(run(exe() + " --scene " + scene + " --out " + dir / "a.exr --bogus").code, 2);
    EXPECT_FALSE(std::filesystem::exists(dir / "a.exr"));
}

TEST(AppRender, BadInputExitsOneAndWritesNothing) {
    ScratchDir dir;
    const std::string broken = writeScene(dir, true);
    const int before = countFiles(dir);
    auto r = run(exe() + " --scene " + broken + " --out " + dir / "a.exr --png " + dir / "a.png");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("objects[0].mesh"), std::string::npos) << r.output;
    EXPECT_EQ(countFiles(dir), before);  // no output, no temporary left behind
    r = run(exe() + " --scene " + dir / "missing.yml --out " + dir / "a.exr");
    EXPECT_EQ(r.code, 1) << r.output;
    const std::string scene = writeScene(dir);
    r = run(exe() + " --scene " + scene + " --out " + dir / "a.exr --cameras " +
            dir / "nope.yml --frame 0");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir / "a.exr"));
}

TEST(AppRender, WritesExrWithChannelsAndProvenance) {
    ScratchDir dir;
    const std::string scene = writeScene(dir);
    const std::string out = dir / "r.exr", png = dir / "r.png";
    auto r = run(exe() + " --scene " + scene + " --out " + out + " --png " + png + " --threads 2");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("samples/pixel"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("paths/s"), std::string::npos) << r.output;
    std::map<std::string, std::string> attr;
    auto ch = readExrChannels(out, &attr);
    for (const char* n : {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z",
                          "object", "mask"}) {
        ASSERT_TRUE(ch.count(n)) << n;
        EXPECT_EQ(ch[n].size(), Size(16, 12));
    }
    EXPECT_GT(mean(ch["G"])[0], 0.01);  // lit
    EXPECT_EQ(attr["vbme.version"], VBME_VERSION);
    EXPECT_EQ(attr["vbme.seed"], "5");
    EXPECT_NE(attr["vbme.commandLine"].find("render"), std::string::npos);
    EXPECT_TRUE(std::filesystem::exists(png));

    // Existing outputs are refused without --force, and left as they were.
    const auto size = std::filesystem::file_size(out);
    r = run(exe() + " --scene " + scene + " --out " + out + " --spp 1");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
    EXPECT_EQ(std::filesystem::file_size(out), size);

    // --threads 1 renders the same bits; --width/--height scale the camera.
    r = run(exe() + " --scene " + scene + " --out " + out + " --threads 1 --force");
    ASSERT_EQ(r.code, 0) << r.output;
    auto ch1 = readExrChannels(out);
    EXPECT_EQ(norm(ch1["R"], ch["R"], NORM_INF), 0.0);
    r = run(exe() + " --scene " + scene + " --out " + dir / "small.exr --width 8 --height 6");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(readExr(dir / "small.exr").color.size(), Size(8, 6));
}

// A camera-path frame replaces the scene's camera: the frame holding the scene's own pose
// renders the same image; a frame index past the end is bad input.
TEST(AppRender, CameraPathFrame) {
    ScratchDir dir;
    const std::string scene = writeScene(dir);
    const Scene s = Scene::read(scene);
    CameraPath path;
    path.K = s.camera.K;
    path.image_size = s.image_size;
    CameraPath::Frame f0, f1;
    f0.index = 0;
    f0.R = Matx33d::eye();
    f0.t = Vec3d(0, 0, 5);
    f1.index = 1;
    f1.R = s.camera.R;
    f1.t = s.camera.t;
    path.frames = {f0, f1};
    path.write(dir / "cams.yml");
    auto r = run(exe() + " --scene " + scene + " --out " + dir / "a.exr");
    ASSERT_EQ(r.code, 0) << r.output;
    r = run(exe() + " --scene " + scene + " --out " + dir / "b.exr --cameras " +
            dir / "cams.yml --frame 1");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(norm(readExr(dir / "a.exr").color, readExr(dir / "b.exr").color, NORM_INF), 0.0);
    r = run(exe() + " --scene " + scene + " --out " + dir / "c.exr --cameras " +
            dir / "cams.yml --frame 0");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_GT(norm(readExr(dir / "a.exr").color, readExr(dir / "c.exr").color, NORM_INF), 0.0);
    r = run(exe() + " --scene " + scene + " --out " + dir / "d.exr --cameras " +
            dir / "cams.yml --frame 2");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir / "d.exr"));
}

// --- differential rendering (--differential) ---

TEST(AppRender, DifferentialUsageAndBadInput) {
    ScratchDir dir;
    const std::string scene = writeScene(dir);
    imwrite(dir / "bg.png", Mat(12, 16, CV_8UC3, Scalar(90, 100, 110)));
    imwrite(dir / "wrong.png", Mat(12, 15, CV_8UC3, Scalar(90, 100, 110)));
    const std::string base = exe() + " --scene " + scene + " --out " + dir / "d.exr";
    EXPECT_EQ(run(base + " --differential").code, 2);                  // no --background
    EXPECT_EQ(run(base + " --background " + dir / "bg.png").code, 2);  // no --differential
    EXPECT_EQ(
        run(base + " --differential --background " + dir / "bg.png --composite " + dir / "c.jpg")
            .code,
        2);
    EXPECT_EQ(run(base + " --differential --no-objects --background " + dir / "bg.png").code, 2);
    EXPECT_EQ(run(base + " --differential --mask exact --background " + dir / "bg.png").code, 2);
    EXPECT_EQ(run(base + " --frame-seeds per-frame").code, 2);  // needs --cameras
    const int before = countFiles(dir);
    auto r = run(base + " --differential --background " + dir / "wrong.png --composite " +
                 dir / "c.png");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("15x12"), std::string::npos) << r.output;
    r = run(base + " --differential --background " + dir / "none.png");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_EQ(countFiles(dir), before);  // nothing (half-)written
}

// The EXR carries every layer; the composite PNG is what `vbme composite` makes from them; with
// no object in the scene the composite is the frame, bit for bit.
TEST(AppRender, DifferentialWritesLayersAndComposite) {
    ScratchDir dir;
    const std::string scene = writeScene(dir);
    Mat bg(12, 16, CV_8UC3);
    randu(bg, 0, 256);
    imwrite(dir / "bg.png", bg);
    auto r = run(exe() + " --scene " + scene + " --out " + dir / "d.exr --differential " +
                 "--background " + dir / "bg.png --composite " + dir / "c.png");
    ASSERT_EQ(r.code, 0) << r.output;
    std::map<std::string, std::string> attr;
    const auto ch = readExrChannels(dir / "d.exr", &attr);
    for (const char* n : {"R", "G", "B", "obj.R", "obj.G", "obj.B", "noobj.R", "noobj.G", "noobj.B",
                          "diff.R", "diff.G", "diff.B", "mask"})
        EXPECT_EQ(ch.count(n), 1u) << n;
    EXPECT_EQ(attr["vbme.seed"], "5");
    EXPECT_GT(countNonZero(ch.at("mask")), 0);
    // adaptive sampling by default (as vbme insert), recorded with its mean cost; 0 turns it off
    EXPECT_EQ(attr["vbme.sampling"].rfind("correlated, adaptive 2..", 0), 0u)
        << attr["vbme.sampling"];
    EXPECT_GT(std::stod(attr["vbme.samplesPerPixel"]), 0.0);
    {
        auto r0 = run(exe() + " --scene " + scene + " --out " + dir / "u.exr --differential " +
                      "--adaptive-min-spp 0 --background " + dir / "bg.png");
        ASSERT_EQ(r0.code, 0) << r0.output;
        std::map<std::string, std::string> a0;
        readExrChannels(dir / "u.exr", &a0);
        EXPECT_EQ(a0["vbme.sampling"], "correlated");
    }
    EXPECT_EQ(
        run(exe() + " --scene " + scene + " --out " + dir / "v.exr --adaptive-min-spp 4").code,
        2);  // needs --differential
    r = run(std::string(VBME_EXE) + " composite -q --background " + dir / "bg.png --layers " +
            dir / "d.exr --out " + dir / "c2.png");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(norm(imread(dir / "c.png"), imread(dir / "c2.png"), NORM_INF), 0.0);
    EXPECT_GT(norm(imread(dir / "c.png"), bg, NORM_INF), 0.0);

    Scene s = Scene::read(scene);
    s.objects.clear();
    s.write(dir / "empty.yml");
    r = run(exe() + " --scene " + dir / "empty.yml --out " + dir / "e.exr --differential " +
            "--background " + dir / "bg.png --composite " + dir / "e.png");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(norm(imread(dir / "e.png"), bg, NORM_INF), 0.0);
}

namespace {

// A 64×48 room seen through a barrel lens (k1 = −0.2, f = 48 px; corners r = 0.83, before the
// fold at 0.86) with two small cubes: one whose pinhole projection lies beyond the frame's right
// edge but which the lens shows inside it, one inside where the lens moves it by ~2.7 px.
struct LensScene {
    Scene s;
    std::vector<Vec3d> centres;
    const double side = 0.2;
    LensScene(const ScratchDir& dir) {
        vbme_test::writeCubeObj(dir / "cube.obj");
        s = litRoom(vbme_test::lookAt(Vec3d(0, -1.5, 1.0), Vec3d(0, 1, 1.0), 48, Size(64, 48)),
                    Vec3d(-2.5, -2.5, 0), Vec3d(2.5, 3, 2.5));
        s.camera.k1 = -0.2;
        // camera axes: image right +x, down −z, forward +y; 2 m in front
        for (const Point2d& xn : {Point2d(0.73, 0.2), Point2d(0.55, 0.35)}) {
            centres.push_back(Vec3d(2 * xn.x, -1.5 + 2, 1.0 - 2 * xn.y));
            SceneObject o;
            o.mesh = dir / "cube.obj";
            o.world_from_object = vbme_test::placement(side, centres.back());
            o.has_material = true;
            o.material = vbme_test::lambertian(Vec3d(0.8, 0.35, 0.1));
            s.objects.push_back(o);
        }
        s.render.spp = 16;
        s.render.max_depth = 2;
        s.render.seed = 3;
    }
    // The true coverage of cube `c` (all: −1) through the lens, 4×4 points a pixel: each point's
    // ray from OpenCV's undistortPoints, tested against the cube's box.
    Mat coverage(int c = -1) const {
        const Camera& cam = s.camera;
        std::vector<Point2d> pd, pu;
        for (int y = 0; y < s.image_size.height; ++y)
            for (int x = 0; x < s.image_size.width; ++x)
                for (int k = 0; k < 16; ++k)
                    pd.emplace_back(x - 0.375 + 0.25 * (k % 4), y - 0.375 + 0.25 * (k / 4));
        undistortPoints(pd, pu, Mat(cam.K), std::vector<double>{cam.k1, 0, 0, 0}, noArray(),
                        noArray(),
                        TermCriteria(TermCriteria::COUNT + TermCriteria::EPS, 100, 1e-12));
        Mat cov = Mat::zeros(s.image_size, CV_32F);
        const Vec3d C = cam.center();
        for (size_t i = 0; i < pd.size(); ++i) {
            const Vec3d d = cam.R.t() * Vec3d(pu[i].x, pu[i].y, 1);
            for (int j = 0; j < (int)centres.size(); ++j) {
                if (c >= 0 && j != c) continue;
                double t0 = 0, t1 = 1e9;
                for (int a = 0; a < 3; ++a) {
                    const double lo = (centres[j][a] - side / 2 - C[a]) / d[a];
                    const double hi = (centres[j][a] + side / 2 - C[a]) / d[a];
                    t0 = std::max(t0, std::min(lo, hi));
                    t1 = std::min(t1, std::max(lo, hi));
                }
                if (t0 <= t1)
                    cov.at<float>((int)(i / 16) / s.image_size.width,
                                  (int)(i / 16) % s.image_size.width) += 1.f / 16;
            }
        }
        return cov;
    }
};

Point2d weightedCentroid(const Mat& w) {
    const Moments m = moments(w, false);
    return m.m00 > 0 ? Point2d(m.m10 / m.m00, m.m01 / m.m00) : Point2d(-1e3, -1e3);
}

// Relative L1 difference of a rendered coverage against the true one.
double coverageError(const Mat& mask, const Mat& truth) {
    return norm(mask, truth, NORM_L1) / std::max(1e-9, sum(truth)[0]);
}

}  // namespace

// vbme render with camera.k1: the images are as the lens shows them, over the whole frame
// (rendered over lensCoverCamera, then warped): the mask against the true coverage (rays from
// OpenCV's undistortPoints), with the pinhole render (--no-lens) as the baseline; the
// differential layers alike, and vbme composite --scene warps pinhole layers to the lens.
TEST(AppRender, LensK1RendersThroughTheLens) {
    ScratchDir dir;
    const LensScene ls(dir);
    ls.s.write(dir / "k1.yml");
    const Mat truth = ls.coverage();
    auto r = run(exe() + " --scene " + dir / "k1.yml --out " + dir / "lens.exr");
    ASSERT_EQ(r.code, 0) << r.output;
    r = run(exe() + " --scene " + dir / "k1.yml --no-lens --out " + dir / "pin.exr");
    ASSERT_EQ(r.code, 0) << r.output;
    std::map<std::string, std::string> attr, attr_pin;
    const Mat lens = readExrChannels(dir / "lens.exr", &attr).at("mask");
    const Mat pin = readExrChannels(dir / "pin.exr", &attr_pin).at("mask");
    EXPECT_EQ(std::stod(attr["vbme.k1"]), -0.2);
    EXPECT_EQ(attr_pin.count("vbme.k1"), 0u);
    if (std::getenv("VBME_KEEP_TEST_FILES")) {
        Mat row;
        hconcat(std::vector<Mat>{truth, lens, pin}, row);
        resize(row, row, Size(), 4, 4, INTER_NEAREST);
        imwrite(dir / "masks.png", row * 255);
    }
    // the band beyond the pinhole frame's right edge (where the edge cube is): rendered there
    const Camera& cam = ls.s.camera;
    Mat band = Mat::zeros(ls.s.image_size, CV_32F);
    for (int y = 0; y < band.rows; ++y)
        for (int x = 0; x < band.cols; ++x)
            band.at<float>(y, x) = cam.undistortPixel(Point2d(x, y)).x > band.cols - 1 ? 1.f : 0.f;
    const double err = coverageError(lens, truth), err_pin = coverageError(pin, truth);
    const double shift = norm(weightedCentroid(lens) - weightedCentroid(truth));
    auto inBand = [&](const Mat& m) { return sum(m.mul(band))[0]; };
    const double in_band = inBand(truth);
    std::printf(
        "render through the lens k1 -0.2: coverage error %.3f (pinhole render %.3f); "
        "true coverage in the band beyond the pinhole frame %.2f px, rendered %.2f "
        "(pinhole %.2f); centroid %.2f px off; rendered over %dx%d\n",
        err, err_pin, in_band, inBand(lens), inBand(pin), shift,
        lensCoverCamera(cam).image_size.width, lensCoverCamera(cam).image_size.height);
    ASSERT_GT(in_band, 4);  // the setting: the lens shows the edge cube there
    EXPECT_NEAR(inBand(lens), in_band, 0.2 * in_band);
    EXPECT_LT(err, 0.2);
    EXPECT_GT(err_pin, 4 * err);
    EXPECT_LT(shift, 0.3);

    // differential: the layers through the lens; composite warps pinhole layers with --scene
    Mat bg(48, 64, CV_8UC3, Scalar::all(128));
    imwrite(dir / "bg.png", bg);
    const std::string diff = exe() + " --differential --background " + dir / "bg.png";
    r = run(diff + " --scene " + dir / "k1.yml --out " + dir / "dl.exr");
    ASSERT_EQ(r.code, 0) << r.output;
    r = run(diff + " --scene " + dir / "k1.yml --no-lens --out " + dir / "dp.exr");
    ASSERT_EQ(r.code, 0) << r.output;
    std::map<std::string, std::string> a;
    const DifferentialImages dl = readDifferentialExr(dir / "dl.exr", noArray(), &a);
    EXPECT_EQ(std::stod(a["vbme.k1"]), -0.2);
    EXPECT_LT(coverageError(dl.mask, truth), 0.2);
    const std::string comp = std::string(VBME_EXE) + " composite -q --background " + dir / "bg.png";
    r = run(comp + " --layers " + dir / "dp.exr --scene " + dir / "k1.yml --out " + dir / "cs.png");
    ASSERT_EQ(r.code, 0) << r.output;
    r = run(comp + " --layers " + dir / "dp.exr --out " + dir / "cp.png");
    ASSERT_EQ(r.code, 0) << r.output;
    // the inner cube (orange on the grey frame: red well above blue) against its true coverage
    const Rect inner(48, 35, 16, 13);
    auto changed = [&](const std::string& f) {
        std::vector<Mat> bgr;
        split(imread(dir / f), bgr);
        Mat m = bgr[2] > bgr[0] + 40;
        m.convertTo(m, CV_32F, 1 / 255.0);
        return Mat(m(inner));
    };
    const Point2d ct = weightedCentroid(ls.coverage(1)(inner));
    const double off_scene = norm(weightedCentroid(changed("cs.png")) - ct);
    const double off_pin = norm(weightedCentroid(changed("cp.png")) - ct);
    std::printf(
        "vbme composite of pinhole layers: inner cube's centroid %.2f px off with --scene "
        "(the lens), %.2f px without\n",
        off_scene, off_pin);
    EXPECT_LT(off_scene, 0.6);
    EXPECT_GT(off_pin, 2.0);
    // layers through one lens, a scene with another: refused
    Scene other = ls.s;
    other.camera.k1 = -0.1;
    other.write(dir / "other.yml");
    r = run(comp + " --layers " + dir / "dl.exr --scene " + dir / "other.yml --out " +
            dir / "x.png");
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("k1 = -0.2"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
}
