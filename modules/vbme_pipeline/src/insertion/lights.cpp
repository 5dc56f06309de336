// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion stage 5: the lights' powers, estimated so that the rendered room matches the
// light frames (estimateLights), or kept as annotated.
#include "insertion/stages.hpp"

namespace cv {
namespace vbme {
namespace insertion {

LightEstimate roomLights(const InsertionParams& p, const RoomRadiance& radiance,
                         Scene& room_scene) {
    LightEstimate est;
    if (p.lights != InsertionParams::LIGHTS_NONE) {
        LightEstimationParams lp;
        lp.method = p.lights == InsertionParams::LIGHTS_NNLS ? LightEstimationParams::NNLS
                                                             : LightEstimationParams::HILL_CLIMB;
        lp.per_frame_gain = p.per_frame_gain;
        est = estimateLights(room_scene, radiance.light_frames, radiance.light_cameras, lp);
        applyLightEstimate(room_scene, est);
    } else {
        est.scale.assign(room_scene.lights.size(), Vec3d(1, 1, 1));
        est.gains.assign(radiance.light_frames.size(), 1.0);
    }
    return est;
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
