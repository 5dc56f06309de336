// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_PLACEMENT_HPP
#define OPENCV_VBME_RENDER_PLACEMENT_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief World-space axis-aligned bounds of an object's mesh under its world_from_object.

Loads the mesh (as RenderScene does, so the bounds are those of the triangles the renderer
traces). Throws cv::Exception if the mesh cannot be read.
@param object the object (mesh file and world_from_object).
@param lo receives the smallest world coordinates.
@param hi receives the largest world coordinates. */
CV_EXPORTS void objectWorldBounds(const SceneObject& object, Vec3d& lo, Vec3d& hi);

/** @brief Where the ray of @p camera through pixel @p px meets the horizontal plane
z = @p floor_z (the room's floor), the one ray–floor intersection of placeOnFloor() and the
datasets' floorPlacement().
@param camera the camera the pixel belongs to.
@param floor_z height of the floor plane (room.min.z).
@param px pixel (x right, y down, pixel centres at integers).
@param point receives the world point on the floor plane.
@return false when the ray does not go down to the plane (it looks level or upwards, or the
camera is not above the floor); @p point is then left unchanged. */
CV_EXPORTS bool floorPointUnderPixel(const Camera& camera, double floor_z, Point2d px,
                                     Vec3d& point);

/** @brief world_from_object that stands @p object on the room's floor where the scene camera's
pixel @p px looks.

The bottom centre of the object's world bounding box goes to the point where the ray through
@p px meets the floor plane z = room.min.z; the rotation and scale of the object's current
world_from_object are kept, its translation is replaced. Throws cv::Exception (naming the
pixel) if the scene has no room, the pixel lies outside the image, the ray does not meet the
floor inside the room, or the placed object would leave the room.
@param scene scene with a room; its camera is the frame the pixel belongs to.
@param object the object to place.
@param px pixel (x right, y down, pixel centres at integers). */
CV_EXPORTS Matx44d placeOnFloor(const Scene& scene, const SceneObject& object, Point2d px);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
