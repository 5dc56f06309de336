// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, shape stage: the hole to remove and the sphere normals over the disk
// (thesis §4.2).
#include <opencv2/imgproc.hpp>

#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

void objectHole(Size size, Point2f center, float radius, double margin, Mat& hole) {
    const float rh = radius + (float)margin;
    hole = Mat::zeros(size, CV_8U);
    circle(hole, Point(cvRound(center.x * 16), cvRound(center.y * 16)), cvRound(rh * 16),
           Scalar(255), FILLED, LINE_8, 4);
}

Rect renderBox(Size size, Point2f c, float r) {
    return Rect(Point(cvFloor(c.x - r - 1), cvFloor(c.y - r - 1)),
                Point(cvCeil(c.x + r + 2), cvCeil(c.y + r + 2))) &
           Rect(Point(0, 0), size);
}

void sphereNormalsInBox(Rect box, Point2f c, float r, Mat& normals, Mat& fit_mask) {
    normals.create(box.size(), CV_32FC3);
    fit_mask.create(box.size(), CV_8U);
    for (int y = 0; y < box.height; y++)
        for (int x = 0; x < box.width; x++) {
            const float px = (float)(x + box.x), py = (float)(y + box.y);
            const float dx = px - c.x, dy = py - c.y;
            const bool in = dx * dx + dy * dy <= (r - 1.5f) * (r - 1.5f);
            normals.at<Vec3f>(y, x) = in ? sphereNormalAt(px, py, c, r) : Vec3f(0, 0, 0);
            fit_mask.at<uchar>(y, x) = in ? 255 : 0;
        }
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
