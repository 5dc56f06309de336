// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read / write / check of LightFitParams and ImageShader::Params (the other render params
// structs: next to their algorithms).
#include <cmath>

#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/render/relighting.hpp"

namespace cv {
namespace vbme {

void LightFitParams::read(const FileNode& fn) {
    ParamsIn in(fn, "light fit parameters");
    in("albedo_max", albedo_max);
    in("min_facing", min_facing);
    in("max_value", max_value);
    in("max_pixels", max_pixels);
    in("ridge", ridge);
    in("fixed_direction", fixed_direction);
    in("fixed_to_light", fixed_to_light);
    in.finish();
    check();
}

void LightFitParams::write(FileStorage& fs) const {
    fs << "albedo_max" << albedo_max << "min_facing" << min_facing << "max_value" << max_value
       << "max_pixels" << max_pixels << "ridge" << ridge << "fixed_direction"
       << (int)fixed_direction;
    fs << "fixed_to_light"
       << "[:" << fixed_to_light[0] << fixed_to_light[1] << fixed_to_light[2] << "]";
}

void LightFitParams::check() const {
    const char* w = "light fit parameters";
    checkParam(albedo_max > 0 && albedo_max <= 1, w, "albedo_max", albedo_max, "(0, 1]");
    checkParam(min_facing >= 0 && min_facing < 1, w, "min_facing", min_facing, "[0, 1)");
    checkParam(max_value > 0, w, "max_value", max_value, "> 0 (linear)");
    checkParam(max_pixels > 0, w, "max_pixels", max_pixels, "> 0");
    checkParam(ridge >= 0, w, "ridge", ridge, ">= 0");
    const double len = norm(fixed_to_light);
    checkParam(!fixed_direction || (len > 0 && std::isfinite(len)), w, "fixed_to_light", len,
               "a non-zero direction (its length is shown)");
}

void ImageShader::Params::read(const FileNode& fn) {
    ParamsIn in(fn, "image shader parameters");
    in("samples", samples);
    in("mirror_roughness", mirror_roughness);
    in("sharp_pdf", sharp_pdf);
    in("world_from_camera", world_from_camera);
    in.finish();
    check();
}

void ImageShader::Params::write(FileStorage& fs) const {
    fs << "samples" << samples << "mirror_roughness" << mirror_roughness << "sharp_pdf"
       << sharp_pdf;
    fs << "world_from_camera"
       << "[:";
    for (int i = 0; i < 9; i++)
        fs << world_from_camera.val[i];
    fs << "]";
}

void ImageShader::Params::check() const {
    const char* w = "image shader parameters";
    checkParam(samples > 0, w, "samples", samples, "> 0");
    checkParam(mirror_roughness >= 0, w, "mirror_roughness", mirror_roughness, ">= 0");
    checkParam(sharp_pdf > 0, w, "sharp_pdf", sharp_pdf, "> 0 (1/sr)");
    // a rotation: R·Rᵀ = I and det R = 1 (to float precision)
    const Matx33d R = world_from_camera;
    const double err = norm(R * R.t() - Matx33d::eye(), NORM_INF);
    checkParam(err < 1e-3 && determinant(R) > 0, w, "world_from_camera", err,
               "a rotation matrix (max |R·Rᵀ − I| is shown)");
}

}  // namespace vbme
}  // namespace cv
