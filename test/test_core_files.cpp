// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Scene, material and camera-path files: FileStorage round trips and errors that name the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/core.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

static Scene fullScene(const std::string& dir) {
    Scene s;
    s.image_size = Size(640, 480);
    s.camera = Camera::fromFocal(612.5, s.image_size);
    Mat R;
    Rodrigues(Vec3d(1.2, 0.1, -0.05), R);
    s.camera.R = Matx33d(R);
    s.camera.t = Vec3d(0.2, 1.1, 2.3);
    s.camera.response = Response::GAMMA22;
    s.has_room = true;
    s.room.min = Vec3d(-2, -1, 0);
    s.room.max = Vec3d(2, 4, 2.6);
    s.room.textures["floor"] = dir + "/tex/floor.png";
    s.room.textures["back"] = "/abs/back.png";
    Light poly;
    poly.type = Light::POLYGON;
    poly.corners = {Vec3d(0, 0, 2.6), Vec3d(0, 1, 2.6), Vec3d(1, 1, 2.6), Vec3d(1, 0, 2.6)};
    poly.radiance = Vec3d(5, 4.5, 4);
    Light point;
    point.type = Light::POINT;
    point.position = Vec3d(0.5, 0.5, 2);
    point.intensity = Vec3d(10, 10, 9);
    Light distant;
    distant.type = Light::DISTANT;
    distant.to_light = normalize(Vec3d(1, 1, 2));
    distant.radiance = Vec3d(3, 3, 3);
    distant.half_angle_deg = 3;
    Light env;
    env.type = Light::ENVIRONMENT;
    env.image = dir + "/env.hdr";
    env.scale = 0.5;
    Light sky;
    sky.type = Light::ENVIRONMENT;
    sky.radiance = Vec3d(0.2, 0.3, 0.5);
    s.lights = {poly, point, distant, env, sky};
    SceneObject bunny;
    bunny.mesh = dir + "/bunny.obj";
    bunny.world_from_object = Matx44d(2, 0, 0, 0.5, 0, 0, -2, 1, 0, 2, 0, 0, 0, 0, 0, 1);
    bunny.has_material = true;
    bunny.material = Material::preset("gold");
    SceneObject plain;
    plain.mesh = dir + "/teapot.obj";
    s.objects = {bunny, plain};
    SceneObject table;
    table.mesh = dir + "/table.obj";
    table.has_material = true;
    table.material.type = Material::PHONG;
    table.material.kd = Vec3d(0.4, 0.3, 0.2);
    table.material.ks = Vec3d(0.1, 0.1, 0.1);
    table.material.exponent = 20;
    s.proxies = {table};
    s.render.spp = 64;
    s.render.max_depth = 5;
    s.render.seed = 1234;
    return s;
}

static void expectSameMaterial(const Material& a, const Material& b) {
    EXPECT_EQ(a.type, b.type);
    EXPECT_EQ(a.albedo, b.albedo);
    EXPECT_EQ(a.eta, b.eta);
    EXPECT_EQ(a.k, b.k);
    EXPECT_EQ(a.roughness, b.roughness);
    EXPECT_EQ(a.kd, b.kd);
    EXPECT_EQ(a.exponent, b.exponent);
}

class CoreSceneRoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(CoreSceneRoundTrip, AllFieldsSurvive) {
    vbme_test::ScratchDir tmp;
    const std::string dir = std::filesystem::absolute(tmp.path()).string();
    Scene s = fullScene(dir);
    const std::string path = tmp / ("scene." + GetParam());
    s.write(path);
    Scene r = Scene::read(path);
    EXPECT_EQ(r.image_size, s.image_size);
    EXPECT_LT(norm(Mat(r.camera.K), Mat(s.camera.K)), 1e-12);
    EXPECT_LT(norm(Mat(r.camera.R), Mat(s.camera.R)), 1e-12);
    EXPECT_LT(norm(r.camera.t - s.camera.t), 1e-12);
    EXPECT_EQ(r.camera.response, Response::GAMMA22);
    ASSERT_TRUE(r.has_room);
    EXPECT_EQ(r.room.min, s.room.min);
    EXPECT_EQ(r.room.max, s.room.max);
    EXPECT_EQ(r.room.textures.at("floor"), dir + "/tex/floor.png");
    EXPECT_EQ(r.room.textures.at("back"), "/abs/back.png");
    ASSERT_EQ(r.lights.size(), 5u);
    EXPECT_EQ(r.lights[0].corners.size(), 4u);
    EXPECT_EQ(r.lights[0].radiance, s.lights[0].radiance);
    EXPECT_EQ(r.lights[1].intensity, s.lights[1].intensity);
    EXPECT_LT(norm(r.lights[2].to_light - s.lights[2].to_light), 1e-12);
    EXPECT_EQ(r.lights[2].half_angle_deg, 3);
    EXPECT_EQ(r.lights[3].image, dir + "/env.hdr");
    EXPECT_EQ(r.lights[3].scale, 0.5);
    EXPECT_EQ(r.lights[4].radiance, s.lights[4].radiance);
    EXPECT_TRUE(r.lights[4].image.empty());
    ASSERT_EQ(r.objects.size(), 2u);
    EXPECT_EQ(r.objects[0].mesh, dir + "/bunny.obj");
    EXPECT_LT(norm(Mat(r.objects[0].world_from_object), Mat(s.objects[0].world_from_object)),
              1e-12);
    EXPECT_TRUE(r.objects[0].has_material);
    expectSameMaterial(r.objects[0].material, s.objects[0].material);
    EXPECT_FALSE(r.objects[1].has_material);
    ASSERT_EQ(r.proxies.size(), 1u);
    expectSameMaterial(r.proxies[0].material, s.proxies[0].material);
    EXPECT_EQ(r.render.spp, 64);
    EXPECT_EQ(r.render.max_depth, 5);
    EXPECT_EQ(r.render.seed, 1234u);

    // Paths below the file's folder are written relative to it.
    std::ifstream f(path);
    std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("tex/floor.png"), std::string::npos);
    EXPECT_EQ(text.find(dir + "/tex/floor.png"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Formats, CoreSceneRoundTrip, ::testing::Values("yml", "json"));

TEST(CoreScene, ReadsHandWrittenDesignExample) {
    vbme_test::ScratchDir tmp;
    const std::string path = tmp / "hand.yml";
    std::ofstream(path)
        << "%YAML:1.0\n"
           "image_size: [640, 480]\n"
           "camera:\n"
           "  K: [[500, 0, 319.5], [0, 500, 239.5], [0, 0, 1]]\n"
           "  R: [1, 0, 0, 0, 0, -1, 0, 1, 0]\n"
           "  t: [0, 1.5, 0]\n"
           "room: { min: [-2, -1, 0], max: [2, 3, 2.5], textures: { floor: f.png } }\n"
           "lights:\n"
           "  - { type: polygon, corners: [[0,0,2.5],[0,1,2.5],[1,1,2.5]], radiance: [1,2,3] }\n"
           "objects:\n"
           "  - { mesh: bunny.obj, material: { type: dielectric, ior: 1.33, absorption: "
           "[1,0.5,0.1] } }\n"
           "  - { mesh: ball.obj, material: chrome }\n"
           "render: { spp: 16 }\n";
    Scene s = Scene::read(path);
    EXPECT_EQ(s.camera.K(0, 0), 500);
    EXPECT_EQ(s.camera.R(1, 2), -1);
    EXPECT_EQ(s.camera.t[1], 1.5);
    EXPECT_EQ(s.objects[0].material.type, Material::DIELECTRIC);
    EXPECT_EQ(s.objects[0].material.ior, 1.33);
    EXPECT_EQ(s.objects[1].material.type, Material::CONDUCTOR);
    EXPECT_EQ(s.render.spp, 16);
    EXPECT_EQ(s.render.max_depth, 8);  // default kept
    EXPECT_TRUE(std::filesystem::path(s.room.textures["floor"]).is_absolute());
}

static std::string readError(const std::string& path, const std::string& text) {
    std::ofstream(path) << text;
    try {
        Scene::read(path);
    } catch (const cv::Exception& e) {
        return e.err;
    }
    return "";
}

TEST(CoreScene, ErrorsNameTheField) {
    vbme_test::ScratchDir tmp;
    const std::string head =
        "%YAML:1.0\nimage_size: [64, 48]\ncamera: { K: [50,0,31.5,0,50,23.5,0,0,1] }\n";
    EXPECT_NE(readError(tmp / "a.yml",
                        head + "objects:\n  - { mesh: a.obj, material: { type: velvet } }\n")
                  .find("objects[0].material.type: unknown material type 'velvet'"),
              std::string::npos);
    EXPECT_NE(readError(tmp / "b.yml", head + "objects:\n  - { mesh: a.obj, world_from_object: "
                                              "[0,0,0,0, 0,0,0,0, 0,0,0,0, 0,0,0,1] }\n")
                  .find("objects[0].world_from_object: not invertible"),
              std::string::npos);
    EXPECT_NE(readError(tmp / "c.yml", head + "lights:\n  - { type: point, position: [0,0,1] }\n")
                  .find("lights[0].intensity: missing"),
              std::string::npos);
    EXPECT_NE(readError(tmp / "d.yml", "%YAML:1.0\nimage_size: [64, 48]\n").find("camera"),
              std::string::npos);
    EXPECT_NE(
        readError(tmp / "e.yml", head + "room: { min: [0,0,0], max: [1,0,1] }\n").find("room"),
        std::string::npos);
    EXPECT_NE(
        readError(tmp / "f.yml", head + "lights:\n  - { type: laser }\n").find("lights[0].type"),
        std::string::npos);
    EXPECT_THROW(Scene::read(tmp / "missing.yml"), cv::Exception);
}

TEST(CoreMaterial, FileRoundTripForEveryPreset) {
    vbme_test::ScratchDir tmp;
    for (const auto& name : Material::presetNames()) {
        Material m = Material::preset(name);
        writeMaterialFile(tmp / "m.yml", m);
        expectSameMaterial(readMaterialFile(tmp / "m.yml"), m);
    }
    EXPECT_THROW(Material::preset("unobtainium"), cv::Exception);
}

TEST(CoreMaterial, PresetWithOverride) {
    vbme_test::ScratchDir tmp;
    std::ofstream(tmp / "m.yml") << "%YAML:1.0\nmaterial: { preset: blue, roughness: 0.3 }\n";
    Material m = readMaterialFile(tmp / "m.yml");
    EXPECT_EQ(m.type, Material::PLASTIC);
    EXPECT_EQ(m.roughness, 0.3);
    EXPECT_EQ(m.albedo, Material::preset("blue").albedo);
}

TEST(CoreCameraPath, RoundTripAndOrderCheck) {
    vbme_test::ScratchDir tmp;
    CameraPath p;
    p.K = Camera::fromFocal(800, Size(1280, 720)).K;
    p.image_size = Size(1280, 720);
    for (int i = 0; i < 5; ++i) {
        CameraPath::Frame f;
        f.index = i;
        Mat R;
        Rodrigues(Vec3d(0.1 * i, 0.02, 0), R);
        f.R = Matx33d(R);
        f.t = Vec3d(i * 0.1, 0, 2);
        f.source = i == 2 ? CameraPath::INTERPOLATED : (i == 4 ? CameraPath::PNP : CameraPath::SFM);
        p.frames.push_back(f);
    }
    p.write(tmp / "cameras.yml");
    CameraPath r = CameraPath::read(tmp / "cameras.yml");
    ASSERT_EQ(r.frames.size(), 5u);
    EXPECT_EQ(r.image_size, p.image_size);
    for (int i = 0; i < 5; ++i) {
        EXPECT_LT(norm(Mat(r.frames[i].R), Mat(p.frames[i].R)), 1e-12);
        EXPECT_EQ(r.frames[i].t, p.frames[i].t);
        EXPECT_EQ(r.frames[i].source, p.frames[i].source);
    }
    Camera c = r.camera(3);
    EXPECT_EQ(c.K(0, 0), 800);
    EXPECT_EQ(c.t, p.frames[3].t);

    std::ofstream(tmp / "bad.yml") << "%YAML:1.0\nK: [1,0,0,0,1,0,0,0,1]\nframes:\n"
                                      "  - { index: 1, R: [1,0,0,0,1,0,0,0,1], t: [0,0,0] }\n";
    try {
        CameraPath::read(tmp / "bad.yml");
        FAIL() << "out-of-order frame accepted";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("frames[0].index"), std::string::npos) << e.err;
    }
}

TEST(CoreFileIO, AtomicFileLeavesNothingWithoutCommit) {
    vbme_test::ScratchDir tmp;
    const std::string out = tmp / "sub/out.png";
    {
        AtomicFile f(out);
        imwrite(f.tempPath(), Mat(4, 4, CV_8U, Scalar(7)));
        EXPECT_TRUE(std::filesystem::exists(f.tempPath()));
    }
    EXPECT_FALSE(std::filesystem::exists(out));
    EXPECT_TRUE(std::filesystem::is_empty(tmp / "sub"));
    imwriteAtomic(out, Mat(4, 4, CV_8U, Scalar(7)));
    EXPECT_EQ(imread(out, IMREAD_GRAYSCALE).at<uchar>(0, 0), 7);
    EXPECT_THROW(checkOverwrite(out, false), cv::Exception);
    EXPECT_NO_THROW(checkOverwrite(out, true));
    EXPECT_EQ(maskFileName(12), "mask_00012.png");
}

TEST(CoreFileIO, ImreadCheckedSaysWhatIsWrong) {
    vbme_test::ScratchDir tmp;
    std::ofstream(tmp / "junk.png") << "not a png";
    try {
        imreadChecked(tmp / "junk.png");
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("not a readable image"), std::string::npos);
    }
    try {
        imreadChecked(tmp / "nothing.png");
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("does not exist"), std::string::npos);
    }
}

TEST(CoreScene, WarnsAboutALightFacingOutOfTheRoom) {
    Scene s;
    s.has_room = true;
    s.room.min = Vec3d(-2, -1, 0);
    s.room.max = Vec3d(2, 4, 2.5);
    Light l;
    l.type = Light::POLYGON;
    l.radiance = Vec3d(5, 5, 5);
    // On the ceiling, counter-clockwise seen from below: lights the room.
    l.corners = {Vec3d(-0.5, 2, 2.5), Vec3d(0.5, 2, 2.5), Vec3d(0.5, 1, 2.5), Vec3d(-0.5, 1, 2.5)};
    s.lights = {l};
    EXPECT_TRUE(s.warnings().empty());
    std::reverse(s.lights[0].corners.begin(), s.lights[0].corners.end());
    const auto w = s.warnings();
    ASSERT_EQ(w.size(), 1u);
    EXPECT_NE(w[0].find("lights[0]"), std::string::npos) << w[0];
    s.has_room = false;  // without a room there is no inside to face
    EXPECT_TRUE(s.warnings().empty());
}

// The one room-face table: each face lies on its plane of the box, spans it exactly, faces into
// the room, and shows the walls upright (image up = world +z) as seen from inside.
TEST(CoreRoomFaces, FacesSpanTheBoxFromInside) {
    Room room;
    room.min = Vec3d(-2, -1, 0);
    room.max = Vec3d(2.5, 4, 2.6);
    const Vec3d centre = 0.5 * (room.min + room.max);
    const Vec3d ext = room.max - room.min;
    for (int i = 0; i < 6; ++i) {
        const std::string& name = Room::faceNames()[i];
        EXPECT_EQ(Room::faceIndex(name), i);
        EXPECT_EQ(Room::findFace(name), i);
        const RoomFace f = room.face(i);
        const int ax = Room::faceAxis(i);
        const double plane = (i % 2 == 0) ? room.min[ax] : room.max[ax];
        // all four corners on the face's plane and inside the box's extent
        for (double u : {0.0, 1.0})
            for (double v : {0.0, 1.0}) {
                const Vec3d p = f.bl + u * f.right + v * f.up;
                EXPECT_DOUBLE_EQ(p[ax], plane) << name;
                for (int a = 0; a < 3; ++a) {
                    EXPECT_GE(p[a], room.min[a] - 1e-12) << name;
                    EXPECT_LE(p[a], room.max[a] + 1e-12) << name;
                }
            }
        // the rectangle covers the whole face: area = product of the other two extents
        const double area = norm(f.right.cross(f.up));
        EXPECT_NEAR(area, ext[(ax + 1) % 3] * ext[(ax + 2) % 3], 1e-12) << name;
        // the normal is unit, along the axis, and points to the box's centre
        EXPECT_NEAR(norm(f.n), 1.0, 1e-12);
        EXPECT_NEAR(std::abs(f.n[ax]), 1.0, 1e-12) << name;
        EXPECT_GT(f.n.dot(centre - f.bl), 0) << name;
        if (ax != 2) {  // walls: image up is world up
            EXPECT_GT(f.up[2], 0) << name;
        }
        // float precision: the same table
        const RoomFace_<float> ff = room.face<float>(i);
        EXPECT_LT(
            norm(Vec3d(ff.bl) - f.bl) + norm(Vec3d(ff.right) - f.right) + norm(Vec3d(ff.up) - f.up),
            1e-5);
    }
    EXPECT_EQ(Room::findFace("wall"), -1);
    EXPECT_THROW(Room::faceIndex("wall"), cv::Exception);
    EXPECT_THROW(room.face(6), cv::Exception);
    EXPECT_THROW(Room::faceAxis(-1), cv::Exception);
}

// The shared FileStorage opener and writer: messages name the file and its role; a sequence of
// maps reads back element by element, and an empty one writes no key.
TEST(CoreFiles, OpenForReadingAndWritingAndMapSequences) {
    vbme_test::ScratchDir dir;
    try {
        openForReading(dir / "missing.yml", "camera-path file");
        FAIL() << "a missing file was opened";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("missing.yml: cannot open camera-path file"), std::string::npos)
            << e.err;
    }
    { std::ofstream(dir / "bad.yml") << "%YAML:1.0\n---\nk: [1, 2\n"; }
    try {
        openForReading(dir / "bad.yml", "scene file");
        FAIL() << "a broken file was opened";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("bad.yml: not a readable YAML/JSON file"), std::string::npos) << e.err;
    }
    struct Item {
        int a;
        std::string b;
    };
    const std::vector<Item> items = {{1, "x"}, {2, "y y"}, {3, ""}};
    const std::vector<Item> none;
    for (const char* ext : {".yml", ".json"}) {
        const std::string path = dir / (std::string("seq") + ext);
        AtomicFile out(path);
        {
            FileStorage fs = openForWriting(out);
            writeMapSeq(fs, "items", items,
                        [&](const Item& it) { fs << "a" << it.a << "b" << it.b; });
            writeMapSeq(fs, "none", none, [&](const Item&) { FAIL(); });
            fs << "after" << 7;
        }
        out.commit();
        FileStorage in = openForReading(path, "test file");
        const FileNode seq = in["items"];
        ASSERT_TRUE(seq.isSeq()) << ext;
        ASSERT_EQ(seq.size(), items.size());
        for (size_t i = 0; i < items.size(); ++i) {
            EXPECT_EQ((int)seq[(int)i]["a"], items[i].a);
            EXPECT_EQ((std::string)seq[(int)i]["b"], items[i].b);
        }
        EXPECT_TRUE(in["none"].empty());
        EXPECT_EQ((int)in["after"], 7);
    }
}
