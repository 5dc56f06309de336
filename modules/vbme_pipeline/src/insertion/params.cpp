// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// InsertionParams: the enums' words, read / write / check.
#include <filesystem>

#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/pipeline/insertion.hpp"

namespace cv {
namespace vbme {

namespace {

const char* const kTextureWords[] = {"accumulate", "per-frame"};
const char* const kAlbedoWords[] = {"irradiance", "retinex"};
const char* const kLightsWords[] = {"nnls", "hill-climb", "none"};
const char* const kExposureWords[] = {"auto", "off"};
const char* const kGrainWords[] = {"auto", "off"};

template <size_t N>
int parseWord(const FileNode& n, const char* key, const char* const (&words)[N]) {
    const std::string s = (std::string)n;
    std::string valid;
    for (size_t i = 0; i < N; ++i) {
        if (s == words[i]) return (int)i;
        valid += std::string(i ? ", " : "") + words[i];
    }
    CV_Error(Error::StsBadArg,
             format("InsertionParams.%s: '%s' is not one of %s", key, s.c_str(), valid.c_str()));
}

}  // namespace

std::string toString(InsertionParams::TextureMode m) {
    CV_Assert(m >= 0 && m < 2);
    return kTextureWords[m];
}
std::string toString(InsertionParams::AlbedoMethod m) {
    CV_Assert(m >= 0 && m < 2);
    return kAlbedoWords[m];
}
std::string toString(InsertionParams::LightsMethod m) {
    CV_Assert(m >= 0 && m < 3);
    return kLightsWords[m];
}

std::string toString(InsertionParams::ExposureMode m) {
    CV_Assert(m >= 0 && m < 2);
    return kExposureWords[m];
}

std::string toString(InsertionParams::GrainMode m) {
    CV_Assert(m >= 0 && m < 2);
    return kGrainWords[m];
}

std::string InsertionParams::workFolder() const {
    namespace fs = std::filesystem;
    if (!work.empty()) return work;
    return (fs::path(out).parent_path() / (fs::path(out).stem().string() + "_work")).string();
}

void InsertionParams::read(const FileNode& fn) {
    ParamsReader r(fn, "InsertionParams");
    r("video", video);
    r("scene", scene);
    r("cameras", cameras);
    r("out", out);
    r("work", work);
    const FileNode pl = r.node("place");
    if (!pl.empty()) {
        if (!pl.isSeq() || pl.size() != 2)
            CV_Error(Error::StsBadArg, "InsertionParams.place: expected [u, v]");
        has_place = true;
        place = Point2d((double)pl[0], (double)pl[1]);
    }
    r("spp", spp);
    r("adaptive_min_spp", adaptive_min_spp);
    r("adaptive_error", adaptive_error);
    r("adaptive_roulette", adaptive_roulette);
    r("texture_cone", texture_cone);
    r("denoise", denoise);
    r("first", first);
    r("end", end);
    r("prepare_only", prepare_only);
    r("keep_exr", keep_exr);
    if (r.has("texture_mode"))
        texture_mode =
            (TextureMode)parseWord(r.node("texture_mode"), "texture_mode", kTextureWords);
    if (r.has("albedo")) albedo = (AlbedoMethod)parseWord(r.node("albedo"), "albedo", kAlbedoWords);
    if (r.has("lights")) lights = (LightsMethod)parseWord(r.node("lights"), "lights", kLightsWords);
    r("per_frame_gain", per_frame_gain);
    r("white", white);
    if (r.has("shadows"))
        shadows = parseShadows((std::string)r.node("shadows"), "InsertionParams.shadows");
    // exposure and white balance per frame
    if (r.has("exposure"))
        exposure = (ExposureMode)parseWord(r.node("exposure"), "exposure", kExposureWords);
    r("exposure_smooth", exposure_smooth);
    // grain and motion blur
    if (r.has("grain")) grain = (GrainMode)parseWord(r.node("grain"), "grain", kGrainWords);
    r("shutter", shutter);
    r("threads", threads);
    r("force", force);
    r("command_line", command_line);
    r.finish();
}

void InsertionParams::write(FileStorage& fs) const {
    fs << "video" << video << "scene" << scene << "cameras" << cameras << "out" << out << "work"
       << work;
    if (has_place)
        fs << "place"
           << "[:" << place.x << place.y << "]";
    fs << "spp" << spp << "adaptive_min_spp" << adaptive_min_spp << "adaptive_error"
       << adaptive_error << "adaptive_roulette" << adaptive_roulette << "texture_cone"
       << texture_cone << "denoise" << denoise << "first" << first << "end" << end << "prepare_only"
       << (int)prepare_only << "keep_exr" << (int)keep_exr << "texture_mode"
       << toString(texture_mode) << "albedo" << toString(albedo) << "lights" << toString(lights)
       << "per_frame_gain" << (int)per_frame_gain << "white" << white << "shadows"
       << toString(shadows) << "grain" << toString(grain) << "shutter" << shutter << "threads"
       << threads << "force" << (int)force;
    fs << "exposure" << toString(exposure) << "exposure_smooth" << exposure_smooth;
}

void InsertionParams::check() const {
    auto bad = [](const std::string& what) {
        CV_Error(Error::StsOutOfRange, "InsertionParams." + what);
    };
    if (video.empty()) bad("video: no input video given");
    if (scene.empty()) bad("scene: no scene file given");
    if (out.empty()) bad("out: no output video given");
    if (spp < 0) bad(format("spp = %d: expected >= 0 (0: the scene's render.spp)", spp));
    if (adaptive_min_spp < 0)
        bad(format("adaptive_min_spp = %d: expected >= 0 (0: off)", adaptive_min_spp));
    if (!(adaptive_error >= 1e-3 && adaptive_error <= 255))
        bad(format("adaptive_error = %g: expected in [0.001, 255]", adaptive_error));
    if (!(adaptive_roulette >= 0 && adaptive_roulette <= 1))
        bad(format("adaptive_roulette = %g: expected in [0, 1]", adaptive_roulette));
    if (!(denoise >= 0 && denoise <= 16))
        bad(format("denoise = %d: expected in [0, 16] pixels", denoise));
    if (!(texture_cone >= 0 && texture_cone <= 3.2))
        bad(format("texture_cone = %g: expected in [0, 3.2] radians", texture_cone));
    if (first < 0) bad(format("first = %d: expected >= 0", first));
    if (end >= 0 && end <= first)
        bad(format("end = %d: expected > first (%d), or -1 for the last frame", end, first));
    if (texture_mode < 0 || texture_mode > TEXTURE_PER_FRAME)
        bad(format("texture_mode = %d: expected TEXTURE_ACCUMULATE or TEXTURE_PER_FRAME",
                   (int)texture_mode));
    if (albedo < 0 || albedo > ALBEDO_RETINEX)
        bad(format("albedo = %d: expected ALBEDO_IRRADIANCE or ALBEDO_RETINEX", (int)albedo));
    if (lights < 0 || lights > LIGHTS_NONE)
        bad(format("lights = %d: expected LIGHTS_NNLS, LIGHTS_HILL_CLIMB or LIGHTS_NONE",
                   (int)lights));
    if (!(white >= 0 && white <= 1)) bad(format("white = %g: expected in [0, 1]", white));
    if (shadows != CompositeParams::SHADOWS_ADDITIVE && shadows != CompositeParams::SHADOWS_RATIO)
        bad(format("shadows = %d: expected SHADOWS_ADDITIVE or SHADOWS_RATIO", (int)shadows));
    if (exposure < 0 || exposure > EXPOSURE_OFF)
        bad(format("exposure = %d: expected EXPOSURE_AUTO or EXPOSURE_OFF", (int)exposure));
    if (exposure_smooth < 0 || exposure_smooth > 1000)
        bad(format("exposure_smooth = %d: expected in [0, 1000] frames", exposure_smooth));
    if (grain < 0 || grain > GRAIN_OFF)
        bad(format("grain = %d: expected GRAIN_AUTO or GRAIN_OFF", (int)grain));
    if (!(shutter == -1 || (shutter >= 0 && shutter <= 1)))
        bad(format("shutter = %g: expected in [0, 1] (of the frame interval) or -1 (estimated)",
                   shutter));
    if (threads < 0) bad(format("threads = %d: expected >= 0 (0: all cores)", threads));
}

}  // namespace vbme
}  // namespace cv
