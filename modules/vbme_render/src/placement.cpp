// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Placing an object in the room: its world bounds and standing it on the floor under a pixel.
#include "opencv2/vbme/render/placement.hpp"

#include "opencv2/vbme/render/scene.hpp"

namespace cv {
namespace vbme {

void objectWorldBounds(const SceneObject& object, Vec3d& lo, Vec3d& hi) {
    Scene s;
    s.image_size = Size(1, 1);
    s.objects.push_back(object);
    Ptr<RenderScene> rs = RenderScene::create(s);
    Vec3f l, h;
    rs->bounds(l, h);
    lo = Vec3d(l[0], l[1], l[2]);
    hi = Vec3d(h[0], h[1], h[2]);
}

bool floorPointUnderPixel(const Camera& camera, double floor_z, Point2d px, Vec3d& point) {
    const Vec3d o = camera.center(), d = camera.rayDirection(px);
    const double tt = d[2] < -1e-12 ? (floor_z - o[2]) / d[2] : -1;
    if (!(tt > 0)) return false;
    point = o + tt * d;
    return true;
}

Matx44d placeOnFloor(const Scene& scene, const SceneObject& object, Point2d px) {
    if (!scene.has_room) CV_Error(Error::StsBadArg, "--place: the scene has no room (no floor)");
    const Camera& cam = scene.camera;
    const Size sz = scene.image_size;
    if (px.x < -0.5 || px.y < -0.5 || px.x > sz.width - 0.5 || px.y > sz.height - 0.5)
        CV_Error(Error::StsOutOfRange,
                 format("--place %g,%g: the pixel lies outside the %dx%d frame", px.x, px.y,
                        sz.width, sz.height));
    Vec3d P;
    if (!floorPointUnderPixel(cam, scene.room.min[2], px, P))
        CV_Error(
            Error::StsBadArg,
            format("--place %g,%g: the frame-0 ray through this pixel does not meet the "
                   "floor (it looks %s); pick a pixel that shows the floor",
                   px.x, px.y, cam.rayDirection(px)[2] >= 0 ? "level or upwards" : "away from it"));
    const Room& r = scene.room;
    if (P[0] < r.min[0] || P[0] > r.max[0] || P[1] < r.min[1] || P[1] > r.max[1])
        CV_Error(Error::StsBadArg,
                 format("--place %g,%g: the ray meets the floor plane at (%.3f, %.3f), outside "
                        "the room's floor [%.3f, %.3f] x [%.3f, %.3f]; pick a pixel that shows "
                        "the floor",
                        px.x, px.y, P[0], P[1], r.min[0], r.max[0], r.min[1], r.max[1]));
    // Bounds of the object with its rotation / scale but no translation.
    SceneObject tmp = object;
    tmp.world_from_object(0, 3) = tmp.world_from_object(1, 3) = tmp.world_from_object(2, 3) = 0;
    Vec3d lo, hi;
    objectWorldBounds(tmp, lo, hi);
    const Vec3d bottom((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]);
    const Vec3d T = P - bottom;
    Matx44d M = tmp.world_from_object;
    M(0, 3) = T[0];
    M(1, 3) = T[1];
    M(2, 3) = T[2];
    const Vec3d nlo = lo + T, nhi = hi + T;
    const double eps = 1e-6 * norm(r.max - r.min);
    for (int a = 0; a < 3; ++a)
        if (nlo[a] < r.min[a] - eps || nhi[a] > r.max[a] + eps)
            CV_Error(Error::StsBadArg,
                     format("--place %g,%g: the object placed at (%.3f, %.3f, %.3f) would reach "
                            "[%.3f, %.3f, %.3f] … [%.3f, %.3f, %.3f], outside the room "
                            "[%.3f, %.3f, %.3f] … [%.3f, %.3f, %.3f]; pick a pixel further "
                            "from the walls",
                            px.x, px.y, P[0], P[1], P[2], nlo[0], nlo[1], nlo[2], nhi[0], nhi[1],
                            nhi[2], r.min[0], r.min[1], r.min[2], r.max[0], r.max[1], r.max[2]));
    return M;
}

}  // namespace vbme
}  // namespace cv
