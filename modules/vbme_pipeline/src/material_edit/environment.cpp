// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, environment stage: the environment map seen in the filled frame.
#include <opencv2/imgproc.hpp>

#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

Matx33f cameraFromWorld() {
    return Matx33f(1, 0, 0, 0, 0, -1, 0, 1, 0);
}

Mat environmentFromFrame(const Mat& bg_lin, Size env_size) {
    // The map has env_size.height/π pixels per radian; the disk needs no more than
    // radius/(π/2): shrink the frame first so that the mapping stays cheap.
    const float disk_r = 0.5f * std::min(bg_lin.cols, bg_lin.rows);
    const double k = std::min(1.0, 0.5 * env_size.height / disk_r);
    Mat small = bg_lin;
    if (k < 1.0) resize(bg_lin, small, Size(), k, k, INTER_AREA);
    return imageDiskToEnvironment(small, Point2f(0.5f * (small.cols - 1), 0.5f * (small.rows - 1)),
                                  0.5f * std::min(small.cols, small.rows), cameraFromWorld(),
                                  env_size);
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
