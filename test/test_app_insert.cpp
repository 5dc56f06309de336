// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme insert: help, usage errors (exit 2), bad input (exit 1, clear message, nothing written
// to --out), and a small run through the command.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/room.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;
using vbme_test::run;

// Inputs for the command: a scene (room, ceiling light, cube), a camera path, and a folder
// of frames drawn with drawSyntheticRoom (the content does not matter for the input checks).
struct Inputs {
    std::string scene, cameras, video;
};

Inputs makeInputs(const vbme_test::ScratchDir& dir, const std::string& tag, Size scene_size,
                  Size video_size, int frames, int path_frames,
                  const Vec3d& object_at = Vec3d(0.1, 2.0, 0)) {
    Inputs in;
    Scene s = syntheticRoomScene(scene_size, 0.8 * scene_size.width, 0.35, 1.5);
    Light l;
    l.type = Light::POLYGON;
    const double z = s.room.max[2];
    l.corners = {Vec3d(-0.5, 1.5, z), Vec3d(0.5, 1.5, z), Vec3d(0.5, 2.5, z), Vec3d(-0.5, 2.5, z)};
    if (l.polygonNormal()[2] > 0) std::reverse(l.corners.begin(), l.corners.end());
    l.radiance = Vec3d(12, 12, 12);
    s.lights = {l};
    SceneObject o;
    o.mesh = dir / "cube.obj";
    if (!fs::exists(o.mesh)) vbme_test::writeCubeObj(o.mesh, "", "", 0.3, true);
    o.world_from_object =
        Matx44d(1, 0, 0, object_at[0], 0, 1, 0, object_at[1], 0, 0, 1, object_at[2], 0, 0, 0, 1);
    o.has_material = true;
    s.objects = {o};
    s.render.spp = 2;
    s.render.max_depth = 2;
    in.scene = dir / (tag + "_scene.yml");
    s.write(in.scene);
    const std::vector<Camera> cams =
        handheldCameraPath(s.camera, std::max(frames, path_frames), 0.1, 0.002, 0.1, 3);
    CameraPath path;
    path.K = s.camera.K;
    for (int i = 0; i < path_frames; ++i) {
        CameraPath::Frame f;
        f.index = i;
        f.R = cams[i].R;
        f.t = cams[i].t;
        path.frames.push_back(f);
    }
    in.cameras = dir / (tag + "_cameras.yml");
    path.write(in.cameras);
    in.video = dir / (tag + "_video");
    fs::create_directories(in.video);
    for (int i = 0; i < frames; ++i) {
        Camera c = cams[i];
        c.image_size = video_size;
        c.K = s.camera.scaled(video_size).K;
        imwrite(in.video + format("/%05d.png", i), drawSyntheticRoom(c, s.room));
    }
    return in;
}

std::string cmd(const Inputs& in, const std::string& out, const std::string& extra = "") {
    return std::string(VBME_EXE) + " insert --quiet --video '" + in.video + "' --scene '" +
           in.scene + "' --cameras '" + in.cameras + "' --out '" + out + "' " + extra;
}

TEST(AppInsert, HelpListsEveryOption) {
    const auto r = run(std::string(VBME_EXE) + " insert --help");
    EXPECT_EQ(r.code, 0) << r.output;
    for (const char* opt :
         {"--video", "--scene", "--cameras", "--out", "--place", "--spp", "--frames", "--work",
          "--keep-exr", "--texture-mode", "--albedo", "--lights", "--per-frame-gain", "--exposure",
          "--exposure-smooth", "--threads", "--force", "--quiet"})
        EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
}

TEST(AppInsert, UsageErrorsExitTwo) {
    vbme_test::ScratchDir dir;
    const Inputs in = makeInputs(dir, "ok", Size(64, 48), Size(64, 48), 2, 2);
    const std::string out = dir / "out.mkv";
    for (const char* bad :
         {"--frames 2-3", "--frames a:b", "--frames 3:1", "--place 12", "--place abc,4",
          "--lights magic", "--spp 0", "--exposure manual", "--exposure-smooth -1"}) {
        const auto r = run(cmd(in, out, bad));
        EXPECT_EQ(r.code, 2) << bad << ": " << r.output;
        EXPECT_FALSE(fs::exists(out)) << bad;
    }
    const auto r = run(cmd(in, out, "--place 12"));
    EXPECT_NE(r.output.find("u,v"), std::string::npos) << r.output;
}

TEST(AppInsert, BadInputExitsOneWithClearMessage) {
    vbme_test::ScratchDir dir;
    const std::string out = dir / "out.mkv";
    struct Case {
        Inputs in;
        std::string extra, expect;
    };
    std::vector<Case> cases;
    // the scene was annotated on 64x48 frames, the video is 80x60
    cases.push_back({makeInputs(dir, "size", Size(64, 48), Size(80, 60), 2, 2), "", "80x60"});
    // the camera path ends before the video
    cases.push_back({makeInputs(dir, "short", Size(64, 48), Size(64, 48), 3, 2), "",
                     "has 2 frames but the video"});
    // the object floats above the ceiling
    cases.push_back(
        {makeInputs(dir, "outside", Size(64, 48), Size(64, 48), 2, 2, Vec3d(0.1, 2.0, 3.0)), "",
         "outside the room"});
    // --place on a pixel that sees the ceiling (top row, camera pitched 0.35 rad down with a
    // half field of view of ~0.56 rad)
    cases.push_back({makeInputs(dir, "ceiling", Size(64, 48), Size(64, 48), 2, 2), "--place 32,0",
                     "does not meet the floor"});
    // frames beyond the video
    cases.push_back(
        {makeInputs(dir, "range", Size(64, 48), Size(64, 48), 2, 2), "--frames 1:5", "has 2"});
    for (const Case& c : cases) {
        const auto r = run(cmd(c.in, out, c.extra + " --work '" + (dir / "work") + "'"));
        EXPECT_EQ(r.code, 1) << c.expect << ": " << r.output;
        EXPECT_NE(r.output.find(c.expect), std::string::npos) << r.output;
        EXPECT_FALSE(fs::exists(out)) << c.expect;
    }
    Inputs missing = cases[0].in;
    missing.scene = dir / "missing.yml";
    const auto r = run(cmd(missing, out));
    EXPECT_EQ(r.code, 1) << r.output;
}

TEST(AppInsert, SmallRunWritesVideoAndRefusesOverwrite) {
    vbme_test::ScratchDir dir;
    const Inputs in = makeInputs(dir, "run", Size(64, 48), Size(64, 48), 2, 2);
    const std::string out = dir / "out.mkv";
    auto r = run(cmd(in, out, "--lights none --albedo retinex --spp 2 --frames 0:1"));
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("still missing"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out));
    r = run(cmd(in, out, "--lights none --albedo retinex --spp 2 --frames=1:"));
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("exposure: frame gains"), std::string::npos) << r.output;
    ASSERT_TRUE(fs::exists(out));
    EXPECT_TRUE(fs::exists(dir / "out_work/report.yml"));
    VideoReader v(out);
    EXPECT_EQ(v.frameSize(), Size(64, 48));
    int n = 0;
    Mat f;
    while (v.read(f))
        ++n;
    EXPECT_EQ(n, 2);
    // an existing --out is not overwritten without --force
    r = run(cmd(in, out, "--lights none --albedo retinex --spp 2"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
}

// A preparation (--prepare-only, as a render farm's first job) renders nothing, so it fixes no
// sampling: the render runs choose --spp, and the first of them records it for the others.
TEST(AppInsert, PrepareOnlyLeavesTheSamplingToTheRenderRuns) {
    vbme_test::ScratchDir dir;
    const Inputs in = makeInputs(dir, "prep", Size(64, 48), Size(64, 48), 2, 2);
    const std::string out = dir / "out.mkv", opts = "--lights none --albedo retinex ";
    auto r = run(cmd(in, out, opts + "--prepare-only"));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_FALSE(fs::exists(dir / "out_work/frames/settings.yml"));
    r = run(cmd(in, out, opts + "--spp 3 --frames 0:1"));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("prepared scene reused"), std::string::npos) << r.output;
    // another sampling for the same frames folder is refused, naming both
    r = run(cmd(in, out, opts + "--spp 2 --frames 1:2"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("spp=3"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "out_work/frames/frame_00001.png"));
    r = run(cmd(in, out, opts + "--spp 3 --frames 1:2"));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(fs::exists(out));
}

TEST(AppInsert, KeepsAudioAndTimestamps) {
    // An MP4 input with a tone: the output carries the same audio packets and the input's
    // frame times; its frames are those rendered into the work folder, up to the encoder.
    if (run("ffmpeg -version").code != 0) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir dir;
    const Inputs in = makeInputs(dir, "av", Size(64, 48), Size(64, 48), 3, 3);
    const std::string clip = dir / "clip.mp4";
    auto r = run("ffmpeg -v error -y -framerate 10 -i '" + in.video +
                 "/%05d.png' -f lavfi -i sine=frequency=440:duration=0.3 -t 0.3 -c:v libx264 "
                 "-crf 10 -pix_fmt yuv420p -c:a aac " +
                 clip);
    ASSERT_EQ(r.code, 0) << r.output;
    Inputs av = in;
    av.video = clip;
    const std::string out = dir / "out.mp4";
    r = run(cmd(av, out, "--lights none --albedo retinex --spp 2"));
    ASSERT_EQ(r.code, 0) << r.output;
    auto packets = [&](const std::string& f) {
        return run("ffmpeg -v error -i " + f + " -map 0:a -c copy -f md5 -").output;
    };
    EXPECT_NE(packets(clip).find("MD5="), std::string::npos);
    EXPECT_EQ(packets(out), packets(clip));
    VideoReader a(clip), b(out);
    Mat fa, fb;
    double se = 0, cnt = 0;
    for (int i = 0; a.read(fa); ++i) {
        ASSERT_TRUE(b.read(fb));
        EXPECT_NEAR(b.timestamp(), a.timestamp(), 1.0 / 90000 + 1e-9) << "frame " << i;
        const Mat rendered = imread(dir / format("out_work/frames/frame_%05d.png", i));
        ASSERT_FALSE(rendered.empty());
        const double e = norm(fb, rendered, NORM_L2);
        se += e * e;
        cnt += (double)rendered.total() * 3;
    }
    EXPECT_FALSE(b.read(fb));
    const double psnr = 10 * std::log10(255.0 * 255.0 / (se / cnt));
    std::printf("insert: output video vs the frames it rendered: %.2f dB\n", psnr);
    EXPECT_GT(psnr, 37.0);  // measured 39.4 dB (64x48 frames, 4:2:0 chroma at CRF 14)
}

}  // namespace
