// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, rendering stage: the object in the new material under the fitted key light and
// the image-based environment with the fitted ambient.
#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

void renderObject(const MaterialEditParams& p, const Mat& bg_lin, Point2f c, float r, double focal,
                  const LightingFit& fit, const EnvironmentMap& env, Mat& rendered) {
    SphereRefraction refr;
    refr.background = bg_lin;
    refr.center = c;
    refr.radius = r;
    refr.focal = focal;
    refr.background_depth = (float)p.background_depth;
    ImageShader::Params ip;
    ip.samples = p.samples;
    ip.world_from_camera = cameraFromWorld().t();
    CombinationShader shader;
    if (fit.irradiance.dot(fit.irradiance) > 0)
        shader.add(makePtr<AreaLightShader>(p.material, fit.to_light, fit.irradiance,
                                            (float)(p.light_half_angle_deg * CV_PI / 180),
                                            p.samples));
    shader.add(makePtr<ImageShader>(p.material, &env, &fit.ambient, &refr, ip));
    // Into its own image: glass refraction reads the background while others are written.
    renderSphere(bg_lin, c, r, focal, shader, rendered);
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
