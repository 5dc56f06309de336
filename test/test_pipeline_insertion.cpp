// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// runInsertion and the stage API (prepareInsertion, renderInsertionFrame): resume, split runs,
// prepared-scene reuse, placement, InsertionParams IO, and the composite leaving the footage
// untouched where the object has no influence.
#include <filesystem>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>
#include <opencv2/vbme/pipeline/insertion.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"
#include "video_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

// A small synthetic input: textured room lit by a ceiling panel, a cube on the floor, a
// hand-held path, the frames rendered without the cube as a PNG folder.
struct InsertInput {
    std::string scene, cameras, video, mesh;
    Scene sc;
    std::vector<Camera> cams;
};

InsertInput makeInput(const vbme_test::ScratchDir& dir, Size size = Size(96, 72), int frames = 4,
                      int spp = 4) {
    InsertInput in;
    Scene s = syntheticRoomScene(size, 260.0 * size.width / 320.0, 0.35, 1.5);
    const auto tex = makeRoomTextures(3, 96);
    for (const auto& kv : tex) {
        const std::string f = dir / ("tex_" + kv.first + ".png");
        imwrite(f, kv.second);
        s.room.textures[kv.first] = f;
    }
    Light l;
    l.type = Light::POLYGON;
    const double z = s.room.max[2];
    l.corners = {Vec3d(-0.5, 1.5, z), Vec3d(0.5, 1.5, z), Vec3d(0.5, 2.5, z), Vec3d(-0.5, 2.5, z)};
    if (l.polygonNormal()[2] > 0) std::reverse(l.corners.begin(), l.corners.end());
    l.radiance = Vec3d(12, 12, 12);
    s.lights = {l};
    in.mesh = dir / "cube.obj";
    vbme_test::writeCubeObj(in.mesh, "", "", 0.3, true);
    SceneObject o;
    o.mesh = in.mesh;
    o.world_from_object = Matx44d(1, 0, 0, 0.1, 0, 1, 0, 2.0, 0, 0, 1, 0, 0, 0, 0, 1);
    o.has_material = true;
    o.material.albedo = Vec3d(0.7, 0.2, 0.1);
    s.render.spp = spp;
    s.render.max_depth = 3;
    in.cams = handheldCameraPath(s.camera, frames, 0.2, 0.003, 0.2, 5);
    // the input video: the room without the object
    fs::create_directories(dir / "video");
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params rp = Renderer::Params::fromScene(s.render);
    rp.with_objects = false;
    Ptr<Renderer> r = Renderer::create(rp);
    for (int i = 0; i < frames; ++i) {
        Camera c = in.cams[i];
        c.image_size = size;
        RenderImages img;
        r->render(*rs, c, img);
        Mat enc;
        encode(img.color, enc, Response::SRGB, CV_8U);
        imwrite(dir / format("video/%05d.png", i), enc);
    }
    in.video = dir / "video";
    s.objects = {o};
    in.scene = dir / "scene.yml";
    s.write(in.scene);
    in.sc = Scene::read(in.scene);
    CameraPath path;
    path.K = s.camera.K;
    path.image_size = size;
    for (int i = 0; i < frames; ++i) {
        CameraPath::Frame f;
        f.index = i;
        f.R = in.cams[i].R;
        f.t = in.cams[i].t;
        path.frames.push_back(f);
    }
    in.cameras = dir / "cameras.yml";
    path.write(in.cameras);
    return in;
}

InsertionParams baseParams(const InsertInput& in, const std::string& out, const std::string& work) {
    InsertionParams p;
    p.video = in.video;
    p.scene = in.scene;
    p.cameras = in.cameras;
    p.out = out;
    p.work = work;
    return p;
}

bool identical(const Mat& a, const Mat& b) {
    if (a.size() != b.size() || a.type() != b.type()) return false;
    return norm(a, b, NORM_INF) == 0;
}

class PipelineInsertion : public ::testing::Test {
protected:
    void SetUp() override { Progress::setEnabled(false); }
    void TearDown() override { Progress::setEnabled(true); }
};

// One run over all frames; a second work folder done as a split (0:2, then 2:N) with a frame
// deleted and a stray temporary file (a killed run) in between; both must give the same
// frames bit for bit, finished frames must not be rendered again, and a prepared scene from
// other options must be refused.
TEST_F(PipelineInsertion, ResumeAndSplitGiveIdenticalFrames) {
    vbme_test::ScratchDir dir;
    const int N = 4;
    const InsertInput in = makeInput(dir, Size(96, 72), N, 4);

    InsertionParams pa = baseParams(in, dir / "a.mkv", dir / "work_a");
    const PipelineReport ra = runInsertion(pa);
    EXPECT_EQ(ra.frames_total, N);
    EXPECT_EQ(ra.frames_processed, N);
    EXPECT_EQ(ra.frames_skipped, 0);
    EXPECT_TRUE(ra.video_written);
    EXPECT_EQ(ra.figure("prepared_reused", -1), 0);
    ASSERT_TRUE(fs::exists(dir / "a.mkv"));
    EXPECT_TRUE(fs::exists(dir / "work_a/report.yml"));
    EXPECT_TRUE(fs::exists(dir / "work_a/prepared_scene.yml"));
    EXPECT_GT(ra.figure("light0_scale_r", -1), 0);  // one light, estimated
    EXPECT_EQ(ra.figure("light1_scale_r", -1), -1);

    // split: first share
    InsertionParams pb = baseParams(in, dir / "b.mkv", dir / "work_b");
    pb.first = 0;
    pb.end = 2;
    pb.threads = 1;  // another machine: another thread count, the same frames
    const PipelineReport rb1 = runInsertion(pb);
    EXPECT_EQ(rb1.frames_processed, 2);
    EXPECT_FALSE(rb1.video_written);
    EXPECT_EQ(rb1.missing, std::vector<int>({2, 3}));
    EXPECT_FALSE(fs::exists(dir / "b.mkv"));
    // a killed run: frame 1 gone, a half-written temporary left behind
    fs::remove(dir / "work_b/frames/frame_00001.png");
    {
        std::ofstream junk(dir / "work_b/frames/frame_00001.partial-1234.png");
        junk << "truncated";
    }
    // second share (2:) plus the resume of frame 1: everything from 1 on
    pb.first = 1;
    pb.end = -1;
    const PipelineReport rb2 = runInsertion(pb);
    EXPECT_EQ(rb2.figure("prepared_reused", -1), 1);
    EXPECT_EQ(rb2.frames_processed, 3);  // 1, 2, 3
    EXPECT_EQ(rb2.frames_skipped, 0);
    EXPECT_TRUE(rb2.video_written);
    // a rerun renders nothing
    pb.first = 0;
    pb.force = true;  // --out exists now
    const PipelineReport rb3 = runInsertion(pb);
    EXPECT_EQ(rb3.frames_processed, 0);
    EXPECT_EQ(rb3.frames_skipped, N);

    for (int i = 0; i < N; ++i) {
        const Mat fa = imread(dir / format("work_a/frames/frame_%05d.png", i), IMREAD_UNCHANGED);
        const Mat fb = imread(dir / format("work_b/frames/frame_%05d.png", i), IMREAD_UNCHANGED);
        EXPECT_TRUE(identical(fa, fb)) << "frame " << i;
    }
    const std::vector<Mat> va = vbme_test::readVideoFrames(dir / "a.mkv"),
                           vb = vbme_test::readVideoFrames(dir / "b.mkv");
    ASSERT_EQ(va.size(), (size_t)N);
    ASSERT_EQ(vb.size(), (size_t)N);
    for (int i = 0; i < N; ++i)
        EXPECT_TRUE(identical(va[i], vb[i])) << "video frame " << i;

    // a prepared scene made with other options is refused, not silently reused
    InsertionParams pc = baseParams(in, dir / "c.mkv", dir / "work_a");
    pc.albedo = InsertionParams::ALBEDO_RETINEX;
    try {
        runInsertion(pc);
        ADD_FAILURE() << "expected the mismatched prepared scene to be refused";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("other inputs or options"), std::string::npos) << e.err;
    }
    // and a different spp does not mix with the frames already there
    InsertionParams pd = baseParams(in, dir / "d.mkv", dir / "work_a");
    pd.spp = 8;
    EXPECT_THROW(runInsertion(pd), cv::Exception);
    EXPECT_FALSE(fs::exists(dir / "c.mkv"));
    EXPECT_FALSE(fs::exists(dir / "d.mkv"));
}

// Away from the object and its shadow (no path met the object: diff exactly 0, mask 0) the
// composite equals the input frame bit for bit; where the object is, it does not.
TEST_F(PipelineInsertion, CompositeLeavesUntouchedPixelsBitExact) {
    vbme_test::ScratchDir dir;
    const int N = 2;
    const InsertInput in = makeInput(dir, Size(96, 72), N, 4);
    InsertionParams p = baseParams(in, dir / "out/%05d.png", dir / "work");
    p.keep_exr = true;
    p.lights = InsertionParams::LIGHTS_NONE;
    p.albedo = InsertionParams::ALBEDO_RETINEX;
    p.texture_mode = InsertionParams::TEXTURE_PER_FRAME;  // the thesis's frame-0 textures
    p.has_place = true;                                   // and the object moved by --place
    p.place = Point2d(40, 58);
    const PipelineReport r = runInsertion(p);
    ASSERT_TRUE(r.video_written);
    {
        const Scene prepared = Scene::read(dir / "work/prepared_scene.yml");
        ASSERT_EQ(prepared.objects.size(), 1u);
        const Matx44d want = placeOnFloor(in.sc, in.sc.objects[0], p.place);
        EXPECT_LT(norm(prepared.objects[0].world_from_object - want, NORM_INF), 1e-9);
        EXPECT_GT(norm(prepared.objects[0].world_from_object - in.sc.objects[0].world_from_object,
                       NORM_INF),
                  0.05);
        FileStorage f(dir / "work/prepared_scene.yml", FileStorage::READ);
        EXPECT_EQ((int)f["vbme_prepared"]["texture_frames"], 1);
        EXPECT_EQ((std::string)f["vbme_prepared"]["texture_mode"], "per-frame");
    }
    for (int i = 0; i < N; ++i) {
        const Mat input = imread(dir / format("video/%05d.png", i), IMREAD_COLOR);
        const Mat out = imread(dir / format("work/frames/frame_%05d.png", i), IMREAD_COLOR);
        const DifferentialImages im =
            readDifferentialExr(dir / format("work/exr/frame_%05d.exr", i));
        ASSERT_EQ(out.size(), input.size());
        int untouched = 0, equal = 0, changed = 0;
        for (int y = 0; y < out.rows; ++y)
            for (int x = 0; x < out.cols; ++x) {
                const Vec3f d = im.diff.at<Vec3f>(y, x);
                const bool none = d == Vec3f(0, 0, 0) && im.mask.at<float>(y, x) == 0.f;
                const bool same = out.at<Vec3b>(y, x) == input.at<Vec3b>(y, x);
                untouched += none;
                equal += none && same;
                changed += !same;
            }
        EXPECT_EQ(equal, untouched) << "frame " << i;
        EXPECT_GT(untouched, out.rows * out.cols / 3) << "frame " << i;
        EXPECT_GT(changed, 20) << "frame " << i << ": the object should be visible";
    }
}

// The stage API gives what the driver gives: prepareInsertion() on the driver's work folder
// reuses its preparation, and renderInsertionFrame() on the input frames reproduces the
// driver's frames bit for bit.
TEST_F(PipelineInsertion, StageApiReproducesTheDriversFrames) {
    vbme_test::ScratchDir dir;
    const int N = 2;
    const InsertInput in = makeInput(dir, Size(96, 72), N, 4);
    InsertionParams p = baseParams(in, dir / "a.mkv", dir / "work");
    const PipelineReport r = runInsertion(p);
    ASSERT_TRUE(r.video_written);
    std::vector<std::string> stages;
    const PreparedInsertion prep0 =
        prepareInsertion(p, [&](const std::string& stage, int64, int64) {
            if (stages.empty() || stages.back() != stage) stages.push_back(stage);
        });
    PreparedInsertion prep = prep0;
    EXPECT_TRUE(prep.reused);
    EXPECT_EQ(prep.frames, N);
    ASSERT_EQ((int)prep.timestamps.size(), N);
    EXPECT_EQ(stages, std::vector<std::string>({"video"}));  // nothing prepared again
    EXPECT_EQ(prep.white_scale, r.figure("white_scale"));
    VideoReader reader(in.video);
    Mat f, out, f0, out0;
    for (int i = 0; i < N && reader.read(f); ++i) {
        renderInsertionFrame(prep, i, f, out);
        const Mat want = imread(dir / format("work/frames/frame_%05d.png", i), IMREAD_UNCHANGED);
        EXPECT_TRUE(identical(out, want)) << "frame " << i;
        if (i == 0) f0 = f.clone(), out0 = out.clone();
    }
    EXPECT_THROW(renderInsertionFrame(prep, N, f, out), cv::Exception);
    // --denoise 0 against the default 1: frame 0 changes, and only where the filtered
    // difference layer is not 0 or the object covers the pixel (elsewhere the layer was 0
    // before filtering too).
    ASSERT_EQ(prep.denoise, 1);
    DifferentialImages layers;
    Mat den;
    renderInsertionFrame(prep, 0, f0, den, &layers);
    prep.denoise = 0;
    out0 = Mat();
    renderInsertionFrame(prep, 0, f0, out0);
    int changed = 0, outside = 0;
    for (int y = 0; y < den.rows; ++y)
        for (int x = 0; x < den.cols; ++x) {
            if (den.at<Vec3b>(y, x) == out0.at<Vec3b>(y, x)) continue;
            ++changed;
            if (layers.mask.at<float>(y, x) == 0 && layers.diff.at<Vec3f>(y, x) == Vec3f(0, 0, 0))
                ++outside;
        }
    EXPECT_GT(changed, 0);
    EXPECT_EQ(outside, 0);
}

// InsertionParams: write then read gives the same fields; unknown keys and bad values are
// errors naming the key or field.
TEST(PipelineInsertionParams, ReadWriteCheck) {
    InsertionParams a;
    a.video = "v.mkv";
    a.scene = "s.yml";
    a.out = "o.mkv";
    a.has_place = true;
    a.place = Point2d(12.5, 40);
    a.spp = 7;
    a.texture_mode = InsertionParams::TEXTURE_PER_FRAME;
    a.albedo = InsertionParams::ALBEDO_RETINEX;
    a.lights = InsertionParams::LIGHTS_HILL_CLIMB;
    a.white = 0.7;
    a.shadows = CompositeParams::SHADOWS_ADDITIVE;
    a.exposure = InsertionParams::EXPOSURE_OFF;
    a.exposure_smooth = 5;
    a.first = 3;
    a.end = 9;
    a.denoise = 2;
    FileStorage w(".yml", FileStorage::WRITE | FileStorage::MEMORY);
    a.write(w);
    const std::string text = w.releaseAndGetString();
    EXPECT_NE(text.find("texture_mode: per-frame"), std::string::npos) << text;
    FileStorage r(text, FileStorage::READ | FileStorage::MEMORY);
    InsertionParams b;
    b.read(r.root());
    EXPECT_EQ(b.video, a.video);
    EXPECT_EQ(b.out, a.out);
    EXPECT_TRUE(b.has_place);
    EXPECT_EQ(b.place, a.place);
    EXPECT_EQ(b.spp, 7);
    EXPECT_EQ(b.texture_mode, InsertionParams::TEXTURE_PER_FRAME);
    EXPECT_EQ(b.albedo, InsertionParams::ALBEDO_RETINEX);
    EXPECT_EQ(b.lights, InsertionParams::LIGHTS_HILL_CLIMB);
    EXPECT_EQ(b.white, 0.7);
    EXPECT_EQ(b.shadows, CompositeParams::SHADOWS_ADDITIVE);
    EXPECT_EQ(InsertionParams().shadows, CompositeParams::SHADOWS_RATIO);
    EXPECT_EQ(b.exposure, InsertionParams::EXPOSURE_OFF);
    EXPECT_EQ(b.exposure_smooth, 5);
    EXPECT_NE(text.find("exposure: off"), std::string::npos) << text;
    EXPECT_EQ(b.first, 3);
    EXPECT_EQ(b.end, 9);
    EXPECT_EQ(b.denoise, 2);
    EXPECT_EQ(InsertionParams().denoise, 1);  // the default
    EXPECT_NO_THROW(b.check());
    auto error = [](const std::function<void()>& f) {
        try {
            f();
        } catch (const cv::Exception& e) {
            return e.err;
        }
        return std::string("no error");
    };
    FileStorage u("{\"spp\": 3, \"sppp\": 4}",
                  FileStorage::READ | FileStorage::MEMORY | FileStorage::FORMAT_JSON);
    const std::string e1 = error([&] { InsertionParams().read(u.root()); });
    EXPECT_NE(e1.find("sppp"), std::string::npos) << e1;
    FileStorage m("{\"albedo\": \"shiny\"}",
                  FileStorage::READ | FileStorage::MEMORY | FileStorage::FORMAT_JSON);
    const std::string e2 = error([&] { InsertionParams().read(m.root()); });
    EXPECT_NE(e2.find("irradiance, retinex"), std::string::npos) << e2;
    FileStorage sh("{\"shadows\": \"darker\"}",
                   FileStorage::READ | FileStorage::MEMORY | FileStorage::FORMAT_JSON);
    const std::string e5 = error([&] { InsertionParams().read(sh.root()); });
    EXPECT_NE(e5.find("additive, ratio"), std::string::npos) << e5;
    InsertionParams c = a;
    c.white = 1.5;
    const std::string e3 = error([&] { c.check(); });
    EXPECT_NE(e3.find("white"), std::string::npos) << e3;
    c = a;
    c.adaptive_roulette = -0.1;
    const std::string e4 = error([&] { c.check(); });
    EXPECT_NE(e4.find("adaptive_roulette"), std::string::npos) << e4;
    c = a;
    c.denoise = -1;
    const std::string e9 = error([&] { c.check(); });
    EXPECT_NE(e9.find("denoise"), std::string::npos) << e9;
    c = a;
    c.exposure_smooth = -1;
    const std::string e7 = error([&] { c.check(); });
    EXPECT_NE(e7.find("exposure_smooth"), std::string::npos) << e7;
    FileStorage x("{\"exposure\": \"manual\"}",
                  FileStorage::READ | FileStorage::MEMORY | FileStorage::FORMAT_JSON);
    const std::string e8 = error([&] { InsertionParams().read(x.root()); });
    EXPECT_NE(e8.find("auto, off"), std::string::npos) << e8;
}

}  // namespace
