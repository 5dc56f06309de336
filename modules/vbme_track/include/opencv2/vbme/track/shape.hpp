// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_TRACK_SHAPE_HPP
#define OPENCV_VBME_TRACK_SHAPE_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/track/disk.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_track
//! @{

/** @brief Height map of the sphere seen as disk @p d (thesis §4.2):
`h(x, y) = sqrt(r² − (x − cx)² − (y − cy)²)` towards the viewer inside the disk, 0 outside.
@param size image size. @param d the disk. @param height output CV_32F. */
CV_EXPORTS void sphereHeightMap(Size size, const Disk& d, OutputArray height);

/** @brief Finite differences used to turn a height map into normals. */
enum NormalDifferences {
    NORMALS_FORWARD = 0,  //!< h(x+1) − h(x) (the thesis); biased by half a pixel
    NORMALS_CENTRAL = 1   //!< (h(x+1) − h(x−1)) / 2
};

/** @brief Surface normals of a height map, in the OpenCV camera frame.

The surface is `z = −h(x, y)` (h grows towards the viewer, camera z points away), so the
normal is `normalize(−∂h/∂x, −∂h/∂y, −1)`: visible normals have n_z < 0. Where a difference
would use a pixel outside @p mask (or outside the image), the one-sided difference on the other
side is used; pixels outside the mask get (0, 0, 0).
@param height CV_32F height map (pixels).
@param mask CV_8U, non-zero where the surface exists; empty = height > 0.
@param normals output CV_32FC3 (x, y, z) per pixel.
@param method forward or central differences. */
CV_EXPORTS void heightToNormals(InputArray height, InputArray mask, OutputArray normals,
                                int method = NORMALS_CENTRAL);

/** @brief Exact normals of the sphere seen as disk @p d, `(x − cx, y − cy, −h) / r`
(CV_32FC3, zero outside), the reference for heightToNormals(). */
CV_EXPORTS void sphereNormals(Size size, const Disk& d, OutputArray normals);

/** @brief An 8-bit picture of a normal map: the usual blue-ish normal-map colours, with
R = (n_x + 1)/2, G = (−n_y + 1)/2 (up is green), B = (−n_z + 1)/2 (facing the viewer is
blue); zero normals are black. Output is BGR CV_8UC3. */
CV_EXPORTS void normalMapImage(InputArray normals, OutputArray image);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
