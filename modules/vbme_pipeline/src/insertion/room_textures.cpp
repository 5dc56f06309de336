// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion stage 3: the room's radiance textures. The texture frames (every stride-th, at most
// ~24, or frame 0) linearised with the camera response and projected onto the room's faces
// (RoomTextureAccumulator); unseen texels filled (fillUnseenTexels). The light estimation's
// frames are collected on the way.
#include <algorithm>
#include <filesystem>

#include "insertion/stages.hpp"
#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/render/room_texture.hpp"

namespace cv {
namespace vbme {
namespace insertion {

namespace fs = std::filesystem;

RoomRadiance roomTextures(const InsertionParams& p, const Inputs& in, const CameraPath& path,
                          const std::string& work, const PipelineProgress& progress) {
    const Scene& scene = in.scene;
    RoomRadiance out;
    RoomTextureParams tp;
    tp.accumulate = p.texture_mode == InsertionParams::TEXTURE_ACCUMULATE;
    Ptr<RoomTextureAccumulator> acc =
        RoomTextureAccumulator::create(scene.room, pathCamera(path, 0, scene), tp);
    const std::vector<int> tex_frames = textureFrames(p.texture_mode, in.video.frames);
    const std::vector<int> light_frames = lightFrames(tex_frames);
    out.texture_frames = (int)tex_frames.size();

    // the frames, in order: kept by the scan, else decoded again (the container's frame
    // count was wrong)
    std::vector<int> wanted = tex_frames;
    wanted.insert(wanted.end(), light_frames.begin(), light_frames.end());
    std::sort(wanted.begin(), wanted.end());
    wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
    std::map<int, Mat> frames;
    bool all_kept = true;
    for (int i : wanted) {
        const auto it = in.video.kept.find(i);
        if (it == in.video.kept.end()) {
            all_kept = false;
            break;
        }
        frames[i] = it->second;
    }
    if (!all_kept) {
        frames.clear();
        VideoReader reader(p.video);
        Mat f;
        for (int i = 0; i <= wanted.back() && reader.read(f); ++i)
            if (std::binary_search(wanted.begin(), wanted.end(), i)) frames[i] = f.clone();
    }
    // the room model is built in the undistorted (pinhole) frame of the scene's camera
    // (Camera::k1); the kept frames themselves stay as filmed (the grain is measured on them)
    if (scene.camera.k1 != 0)
        for (auto& kv : frames) {
            Mat u;
            undistortImageK1(kv.second, u, scene.camera);
            kv.second = u;
        }

    // exposure and white balance: the texture frames' gains against frame 0's (exposure.cpp);
    // every frame below is divided by its gain, so that the textures, the albedo and the
    // lights are at frame 0's exposure
    std::map<int, Vec3d> gain;
    if (p.exposure == InsertionParams::EXPOSURE_AUTO) {
        out.exposure = std::make_shared<ExposureEstimator>(scene, pathCamera(path, 0, scene));
        std::vector<FaceObservation> obs;
        for (int i : tex_frames)
            obs.push_back(out.exposure->observe(frames.at(i), pathCamera(path, i, scene)));
        const std::vector<Vec3d> g = out.exposure->alignFrames(obs);
        for (size_t k = 0; k < tex_frames.size(); ++k)
            gain[tex_frames[k]] = g[k];
    }

    int done = 0;
    Mat lin;
    for (const auto& kv : frames) {
        const int i = kv.first;
        const auto git = gain.find(i);
        const bool scaled = git != gain.end() && git->second != Vec3d(1, 1, 1);
        const Scalar inv = scaled
                               ? Scalar(1 / git->second[0], 1 / git->second[1], 1 / git->second[2])
                               : Scalar::all(1);
        if (std::binary_search(tex_frames.begin(), tex_frames.end(), i)) {
            linearize(kv.second, lin, scene.camera.response);
            if (scaled) multiply(lin, inv, lin);
            acc->add(lin, pathCamera(path, i, scene));
            if (progress) progress("textures", ++done, (int64)tex_frames.size());
        }
        if (std::find(light_frames.begin(), light_frames.end(), i) != light_frames.end()) {
            Mat f = kv.second;
            if (scaled) {
                // encoded floats at frame 0's exposure; clipped pixels keep their values, so
                // that light estimation still leaves them out (LightEstimationParams::clip_level)
                Mat enc, orig;
                linearize(kv.second, lin, scene.camera.response);
                multiply(lin, inv, lin);
                encode(lin, enc, scene.camera.response, CV_32F);
                kv.second.convertTo(orig, CV_32FC3,
                                    kv.second.depth() == CV_16U ? 1.0 / 65535 : 1.0 / 255);
                std::vector<Mat> ch;
                split(orig, ch);
                orig.copyTo(enc, max(max(ch[0], ch[1]), ch[2]) >= 0.98f);
                f = enc;
            }
            out.light_frames.push_back(f);
            out.light_cameras.push_back(pathCamera(path, i, scene));
        }
    }
    acc->textures(out.filled, out.seen);
    const fs::path tex_dir = fs::path(work) / "textures";
    for (auto& kv : out.filled) {
        // before filling: the albedo stage wants L unknown where unseen
        out.observed[kv.first] = kv.second.clone();
        fillUnseenTexels(kv.second, out.seen[kv.first]);
        Mat enc;
        encode(kv.second, enc, scene.camera.response, CV_8U);
        imwriteAtomic((tex_dir / (kv.first + ".png")).string(), enc);
        imwriteAtomic((tex_dir / (kv.first + "_seen.png")).string(), out.seen[kv.first]);
    }
    return out;
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
