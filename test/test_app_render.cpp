// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Command-line tests of `vbme render`.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::run;
using vbme_test::ScratchDir;

namespace {

// A small room with a ceiling light and a cube, written as a scene file.
std::string writeScene(const ScratchDir& dir, bool broken_mesh = false) {
    vbme_test::writeCubeObj(dir / "cube.obj");
    Scene s;
    s.image_size = Size(16, 12);
    s.camera = vbme_test::lookAt(Vec3d(0, -1.4, 1.2), Vec3d(0, 0.3, 0.5), 14, s.image_size);
    s.has_room = true;
    s.room.min = Vec3d(-1.5, -1.5, 0);
    s.room.max = Vec3d(1.5, 1.5, 2.5);
    Light l;
    l.type = Light::POLYGON;
    l.corners = {Vec3d(-0.5, 0.5, 2.5), Vec3d(0.5, 0.5, 2.5), Vec3d(0.5, -0.5, 2.5),
                 Vec3d(-0.5, -0.5, 2.5)};
    l.radiance = Vec3d(5, 5, 5);
    s.lights = {l};
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
