// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, lighting stage: the original object as a light probe (fitLighting()).
#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

LightingFit fitObjectLighting(const Mat& object_linear, const Mat& normals, const Mat& fit_mask,
                              const MaterialEditParams& p) {
    LightFitParams lp;
    lp.fixed_direction = p.light == MATERIAL_EDIT_LIGHT_FIXED;
    if (lp.fixed_direction) {
        const Vec3d d = p.to_light / norm(p.to_light);
        lp.fixed_to_light = Vec3f((float)d[0], (float)d[1], (float)d[2]);
    }
    return fitLighting(object_linear, normals, fit_mask, lp);
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
