// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// MaterialEditParams: validation and FileStorage reading/writing.
#include <algorithm>
#include <cmath>
#include <initializer_list>

#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/core/utility.hpp"
#include "stages.hpp"

namespace cv {
namespace vbme {

std::string toString(MaterialEditLight m) {
    return m == MATERIAL_EDIT_LIGHT_FIXED ? "fixed" : "auto";
}

ShadowMode shadowModeFor(const Material& material) {
    return material.type == Material::DIELECTRIC ? SHADOWS_REMOVE : SHADOWS_KEEP;
}

std::string toString(MaterialEditInpaint m) {
    return m == MATERIAL_EDIT_INPAINT_VIDEO ? "video" : "background";
}

namespace {

[[noreturn]] void bad(const std::string& field, const std::string& expected) {
    CV_Error(Error::StsBadArg, "MaterialEditParams." + field + ": expected " + expected);
}

std::string readWord(const FileNode& n, const std::string& field) {
    if (!n.isString()) CV_Error(Error::StsParseError, field + ": expected a string");
    return (std::string)n;
}

/** Reads @p key as one of the words toString() gives for @p values. */
template <class E>
void readChoice(ParamsReader& r, const char* key, E& v, std::initializer_list<E> values) {
    const FileNode n = r.node(key);
    if (n.empty()) return;
    const std::string w = readWord(n, key);
    std::string list;
    for (E e : values) {
        if (toString(e) == w) {
            v = e;
            return;
        }
        list += (list.empty() ? "'" : ", '") + toString(e) + "'";
    }
    CV_Error(Error::StsParseError,
             std::string(key) + ": unknown '" + w + "' (expected " + list + ")");
}

}  // namespace

void MaterialEditParams::check() const {
    if (light != MATERIAL_EDIT_LIGHT_AUTO && light != MATERIAL_EDIT_LIGHT_FIXED)
        bad("light", "MATERIAL_EDIT_LIGHT_AUTO or MATERIAL_EDIT_LIGHT_FIXED");
    if (light == MATERIAL_EDIT_LIGHT_FIXED) {
        const double n = norm(to_light);
        if (!(n > 0) || !std::isfinite(n))
            bad("to_light",
                "a finite non-zero direction towards the light (camera "
                "coordinates: x right, y down, z forward)");
    }
    if (!(focal >= 0) || !std::isfinite(focal))
        bad("focal", "a focal length > 0 pixels, or 0 for a 60° horizontal field of view");
    if (max_lost < 0) bad("max_lost", "≥ 0");
    if (inpaint != MATERIAL_EDIT_INPAINT_BACKGROUND && inpaint != MATERIAL_EDIT_INPAINT_VIDEO)
        bad("inpaint", "MATERIAL_EDIT_INPAINT_BACKGROUND or MATERIAL_EDIT_INPAINT_VIDEO");
    if (lookahead < 0) bad("lookahead", "≥ 0");
    if (shadows != SHADOWS_KEEP && shadows != SHADOWS_REMOVE)
        bad("shadows", "SHADOWS_KEEP or SHADOWS_REMOVE");
    if (env_every < 1) bad("env_every", "≥ 1");
    if (env_size.width < 8 || env_size.height < 4) bad("env_size", "at least 8×4");
    if (samples < 1) bad("samples", "≥ 1");
    if (!(light_half_angle_deg > 0 && light_half_angle_deg < 80))
        bad("light_half_angle_deg", "in (0, 80) degrees");
    if (!(background_depth > 0) || !std::isfinite(background_depth))
        bad("background_depth", "> 0 (ball radii)");
    if (!(hole_margin >= 0) || !std::isfinite(hole_margin)) bad("hole_margin", "≥ 0 pixels");
    if (threads < 0) bad("threads", "≥ 0 (0: all cores)");
}

void MaterialEditParams::read(const FileNode& node) {
    ParamsReader r(node, "material-edit params");
    r("video", video);
    r("first_mask", first_mask);
    r("out", out);
    r("env", env);
    r("intermediates", intermediates);
    r("env_every", env_every);
    r("force", force);
    r("threads", threads);
    {
        const FileNode e = r.node("encode");
        if (!e.empty()) {
            ParamsReader er(e, "material-edit params.encode");
            er("codec", encode.codec);
            er("crf", encode.crf);
            er("preset", encode.preset);
            double bitrate = (double)encode.bitrate;
            er("bitrate", bitrate);
            encode.bitrate = (int64)bitrate;
            er("pix_fmt", encode.pix_fmt);
            er.finish();
        }
    }
    {
        const FileNode m = r.node("material");
        if (!m.empty()) material.read(m, "material");
    }
    readChoice(r, "light", light, {MATERIAL_EDIT_LIGHT_AUTO, MATERIAL_EDIT_LIGHT_FIXED});
    {
        const FileNode n = r.node("to_light");
        if (!n.empty()) to_light = readVec3(n, "to_light");
    }
    r("focal", focal);
    r("max_lost", max_lost);
    readChoice(r, "inpaint", inpaint,
               {MATERIAL_EDIT_INPAINT_BACKGROUND, MATERIAL_EDIT_INPAINT_VIDEO});
    r("lookahead", lookahead);
    readChoice(r, "shadows", shadows, {SHADOWS_KEEP, SHADOWS_REMOVE});
    {
        const FileNode n = r.node("env_size");
        if (!n.empty()) env_size = readImageSize(n, "env_size");
    }
    readChoice(r, "response", response, {Response::SRGB, Response::GAMMA22, Response::LINEAR});
    r("samples", samples);
    r("light_half_angle_deg", light_half_angle_deg);
    r("background_depth", background_depth);
    r("hole_margin", hole_margin);
    r("refine_disk", refine_disk);
    r.finish();
}

void MaterialEditParams::write(FileStorage& fs) const {
    fs << "video" << video << "first_mask" << first_mask << "out" << out << "env" << env
       << "intermediates" << intermediates << "env_every" << env_every << "force" << (int)force
       << "threads" << threads;
    fs << "encode"
       << "{"
       << "codec" << encode.codec << "crf" << encode.crf << "preset" << encode.preset << "bitrate"
       << (double)encode.bitrate << "pix_fmt" << encode.pix_fmt << "}";
    fs << "material"
       << "{";
    material.write(fs);
    fs << "}";
    fs << "light" << toString(light);
    writeVec3(fs, "to_light", to_light);
    fs << "focal" << focal << "max_lost" << max_lost << "inpaint" << toString(inpaint)
       << "lookahead" << lookahead << "shadows" << toString(shadows);
    fs << "env_size"
       << "[:" << env_size.width << env_size.height << "]";
    fs << "response" << toString(response) << "samples" << samples << "light_half_angle_deg"
       << light_half_angle_deg << "background_depth" << background_depth << "hole_margin"
       << hole_margin << "refine_disk" << (int)refine_disk;
}

}  // namespace vbme
}  // namespace cv
