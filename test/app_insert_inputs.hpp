// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Tiny `vbme insert` inputs shared by the fault-injection and cluster tests: a room scene with
// a ceiling light and a cube, its camera path and a folder of frames (a second or so a run).
#ifndef VBME_TEST_APP_INSERT_INPUTS_HPP
#define VBME_TEST_APP_INSERT_INPUTS_HPP

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/room.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

namespace vbme_test {

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

// A room scene with a ceiling light and a cube, its camera path, and a folder of frames.
struct FaultInputs {
    std::string scene, cameras, video;
};

inline FaultInputs makeFaultInputs(const vbme_test::ScratchDir& dir, Size size, int frames) {
    FaultInputs in;
    Scene s = syntheticRoomScene(size, 0.8 * size.width, 0.35, 1.5);
    Light l;
    l.type = Light::POLYGON;
    const double z = s.room.max[2];
    l.corners = {Vec3d(-0.5, 1.5, z), Vec3d(0.5, 1.5, z), Vec3d(0.5, 2.5, z), Vec3d(-0.5, 2.5, z)};
    if (l.polygonNormal()[2] > 0) std::reverse(l.corners.begin(), l.corners.end());
    l.radiance = Vec3d(12, 12, 12);
    s.lights = {l};
    SceneObject o;
    o.mesh = dir / "cube.obj";
    vbme_test::writeCubeObj(o.mesh, "", "", 0.3, true);
    o.world_from_object = Matx44d(1, 0, 0, 0.1, 0, 1, 0, 2.0, 0, 0, 1, 0, 0, 0, 0, 1);
    o.has_material = true;
    s.objects = {o};
    s.render.spp = 2;
    s.render.max_depth = 2;
    in.scene = dir / "scene.yml";
    s.write(in.scene);
    const std::vector<Camera> cams = handheldCameraPath(s.camera, frames, 0.1, 0.002, 0.1, 3);
    CameraPath path;
    path.K = s.camera.K;
    for (int i = 0; i < frames; ++i) {
        CameraPath::Frame f;
        f.index = i;
        f.R = cams[i].R;
        f.t = cams[i].t;
        path.frames.push_back(f);
    }
    in.cameras = dir / "cameras.yml";
    path.write(in.cameras);
    in.video = dir / "video";
    fs::create_directories(in.video);
    for (int i = 0; i < frames; ++i)
        imwrite(in.video + format("/%05d.png", i), drawSyntheticRoom(cams[i], s.room));
    return in;
}

inline std::string insertCmd(const FaultInputs& in, const std::string& out, const std::string& work,
                             const std::string& extra = "") {
    return std::string(VBME_EXE) + " insert --quiet --video '" + in.video + "' --scene '" +
           in.scene + "' --cameras '" + in.cameras + "' --out '" + out + "' --work '" + work +
           "' --lights none --albedo retinex --threads 1 " + extra;
}

inline double secondsOf(const std::function<void()>& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

inline bool sameImage(const Mat& a, const Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && norm(a, b, NORM_INF) == 0;
}

}  // namespace vbme_test

#endif
