// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion stage 4: the room's albedo, the textures the renderer uses for the real room.
// Irradiance albedo with the lights scaled to the room's white point, or Retinex.
#include <filesystem>

#include "insertion/stages.hpp"
#include "opencv2/vbme/render/albedo.hpp"
#include "opencv2/vbme/render/film.hpp"

namespace cv {
namespace vbme {
namespace insertion {

namespace fs = std::filesystem;

double roomAlbedo(const InsertionParams& p, const RoomRadiance& radiance, Scene& room_scene,
                  const std::string& work, const std::string& fingerprint) {
    std::map<std::string, Mat> albedo;
    double white_scale = 1;
    if (p.albedo == InsertionParams::ALBEDO_IRRADIANCE) {
        white_scale = irradianceAlbedoWhitePoint(room_scene, radiance.observed, radiance.seen,
                                                 albedo, p.white, IrradianceAlbedoParams());
    } else {
        for (const auto& kv : radiance.filled)
            retinexAlbedo(kv.second, albedo[kv.first]);
    }
    const fs::path alb_dir = fs::path(work) / "albedo";
    for (const auto& kv : albedo) {
        RenderImages img;
        img.color = kv.second;
        const std::string f = (alb_dir / (kv.first + ".exr")).string();
        writeExr(f, img, {{"vbme.version", VBME_VERSION}, {"vbme.prepared", fingerprint}});
        room_scene.room.textures[kv.first] = fs::absolute(f).lexically_normal().string();
    }
    return white_scale;
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
