// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The prepared scene's record in the work folder: prepared_scene.yml is the prepared scene
// (Scene::write) followed by a `vbme_prepared` map (fingerprint, inputs, options, light
// estimate), written with FileStorage in append mode, all through one AtomicFile. A record
// whose fingerprint matches the inputs is reused by the next run.
#include <filesystem>

#include "insertion/stages.hpp"
#include "opencv2/vbme/core/fileio.hpp"

namespace cv {
namespace vbme {
namespace insertion {

namespace fs = std::filesystem;

namespace {

std::string absolute(const std::string& p) {
    return fs::absolute(p).lexically_normal().string();
}

void writeEstimate(FileStorage& fs, const LightEstimate& e) {
    fs << "scale"
       << "[";
    for (const Vec3d& s : e.scale)
        fs << "[:" << s[0] << s[1] << s[2] << "]";
    fs << "]";
    fs << "gains"
       << "[:";
    for (double g : e.gains)
        fs << g;
    fs << "]";
    fs << "error_before" << e.error_before << "error_after" << e.error_after << "iterations"
       << e.iterations << "pixels_used" << e.pixels_used;
}

LightEstimate readEstimate(const FileNode& n) {
    LightEstimate e;
    for (const FileNode& s : n["scale"])
        e.scale.push_back(readVec3(s, "vbme_prepared.lights.scale"));
    for (const FileNode& g : n["gains"])
        e.gains.push_back((double)g);
    e.error_before = (double)n["error_before"];
    e.error_after = (double)n["error_after"];
    e.iterations = (int)n["iterations"];
    e.pixels_used = (int)n["pixels_used"];
    return e;
}

}  // namespace

std::string fingerprint(const InsertionParams& p, const Inputs& in, const CameraPath& path) {
    Hasher h;
    h.str("vbme-insert-prepared-v1");
    h.str(VBME_VERSION);
    h.file(p.scene);
    for (const auto* list : {&in.scene.objects, &in.scene.proxies})
        for (const SceneObject& o : *list)
            h.file(o.mesh);
    for (const CameraPath::Frame& fr : path.frames) {
        h.bytes(fr.R.val, sizeof fr.R.val);
        h.bytes(fr.t.val, sizeof fr.t.val);
    }
    h.bytes(path.K.val, sizeof path.K.val);
    h.num((int64)in.video.pixels_hash);
    h.num((int64)in.video.frames);
    h.str(toString(p.texture_mode));
    h.str(toString(p.albedo));
    h.str(toString(p.lights));
    h.num((int64)p.per_frame_gain);
    h.num(p.white);
    if (p.exposure != InsertionParams::EXPOSURE_OFF) {  // off: the fingerprint of before
        h.str("exposure " + toString(p.exposure));
        h.num((int64)p.exposure_smooth);
    }
    h.num((int64)p.has_place);
    if (p.has_place) {
        h.num(p.place.x);
        h.num(p.place.y);
    }
    return h.hex();
}

void writePrepared(const std::string& path, const Scene& scene, const InsertionParams& p,
                   const PreparedRecord& r) {
    AtomicFile out(path);
    scene.write(out.tempPath());
    {
        FileStorage rec(out.tempPath(), FileStorage::APPEND);
        if (!rec.isOpened()) CV_Error(Error::StsError, "cannot write '" + path + "'");
        rec << "vbme_prepared"
            << "{";
        rec << "hash" << r.fingerprint << "vbme_version" << VBME_VERSION;
        rec << "scene" << absolute(r.scene) << "video" << absolute(r.video) << "cameras"
            << absolute(r.cameras);
        rec << "frames" << r.frames << "texture_mode" << toString(p.texture_mode)
            << "texture_frames" << r.texture_frames << "albedo" << toString(p.albedo)
            << "lights_method" << toString(p.lights) << "per_frame_gain" << (int)p.per_frame_gain
            << "white" << p.white << "white_scale" << r.white_scale;
        rec << "exposure" << toString(p.exposure) << "exposure_smooth" << p.exposure_smooth;
        rec << "gains"
            << "[:";
        for (const Vec3d& g : r.gains)
            rec << g[0] << g[1] << g[2];
        rec << "]";
        rec << "exposure_texels_min" << r.exposure_texels_min;
        if (p.has_place)
            rec << "place"
                << "[:" << p.place.x << p.place.y << "]";
        rec << "lights"
            << "{";
        writeEstimate(rec, r.lights);
        rec << "}";
        // motion blur: the estimated shutter
        rec << "shutter_estimate" << r.shutter_estimate << "shutter_frame" << r.shutter_frame
            << "shutter_motion_px" << r.shutter_motion_px;
        rec << "}";
    }
    out.commit();
}

int readPrepared(const std::string& path, const std::string& fp, Scene& scene, PreparedRecord& out,
                 std::string& found) {
    found.clear();
    if (!fs::exists(path)) return 0;
    FileStorage f;
    try {
        f.open(path, FileStorage::READ);
    } catch (const cv::Exception&) {
        return -1;
    }
    if (!f.isOpened()) return -1;
    const FileNode rec = f["vbme_prepared"];
    if (rec.empty() || !rec["hash"].isString()) return -1;
    found = (std::string)rec["hash"];
    if (found != fp) return -1;
    Scene s = Scene::read(path);
    for (const auto& kv : s.room.textures)
        if (!fs::exists(kv.second)) return 0;  // incomplete: prepare again
    scene = s;
    out.fingerprint = found;
    out.frames = (int)rec["frames"];
    out.texture_frames = (int)rec["texture_frames"];
    out.white_scale = rec["white_scale"].empty() ? 1.0 : (double)rec["white_scale"];
    out.lights = readEstimate(rec["lights"]);
    out.gains.clear();
    std::vector<double> g;
    for (const FileNode& v : rec["gains"])
        g.push_back((double)v);
    if (g.size() % 3 != 0) return 0;  // damaged: prepare again
    for (size_t k = 0; k + 2 < g.size(); k += 3)
        out.gains.emplace_back(g[k], g[k + 1], g[k + 2]);
    out.exposure_texels_min = (int)rec["exposure_texels_min"];
    // motion blur: the estimated shutter (absent from older records: estimated again)
    if (!rec["shutter_estimate"].empty()) {
        out.shutter_estimate = (double)rec["shutter_estimate"];
        out.shutter_frame = (int)rec["shutter_frame"];
        out.shutter_motion_px = (double)rec["shutter_motion_px"];
    }
    return 1;
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
