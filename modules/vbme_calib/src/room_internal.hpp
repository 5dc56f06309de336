// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Internals of the room fitting shared by room.cpp and frame.cpp.
#ifndef VBME_CALIB_ROOM_INTERNAL_HPP
#define VBME_CALIB_ROOM_INTERNAL_HPP

#include <string>

#include "opencv2/vbme/calib/frame_calibration.hpp"

namespace cv {
namespace vbme {
namespace detail {

/** Index of a face name in Room::faceNames() (floor, ceiling, left, right, front, back). */
int faceIndex(const std::string& name, const std::string& field);
/** Determines as many face coordinates as the annotation allows (value/known per face, in
Room::faceNames() order); @p use_numbers: take RoomAnnotation::faces into account. */
void solveFaces(const Camera& camera, const RoomAnnotation& ann, bool use_numbers, double value[6],
                bool known[6]);

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
