// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Shared by the video inpainters: the checks of a pushed frame and its hole mask.
#pragma once

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {
namespace detail {

/** Copies pushed frame @p index of an inpainter called @p who into @p image (non-empty CV_8UC3
of the size of the earlier frames, @p size; set by the first frame) and its mask into @p hole
(255 where @p mask is non-zero; all 0 when @p mask is empty; CV_8UC1 of the frame's size).
Throws with a message naming the frame and what was expected. */
inline void checkPushedFrame(const char* who, int index, InputArray frame, InputArray mask,
                             Size& size, Mat& image, Mat& hole) {
    image = frame.getMat().clone();
    if (image.empty() || image.type() != CV_8UC3)
        CV_Error(Error::StsBadArg,
                 format("%s: frame %d is %s, expected a non-empty CV_8UC3 image", who, index,
                        image.empty() ? "empty" : typeToString(image.type()).c_str()));
    if (size.area() == 0) size = image.size();
    if (image.size() != size)
        CV_Error(Error::StsBadSize, format("%s: frame %d is %dx%d, earlier frames %dx%d", who,
                                           index, image.cols, image.rows, size.width, size.height));
    Mat m = mask.getMat();
    if (m.empty()) {
        hole = Mat::zeros(size, CV_8U);
        return;
    }
    if (m.type() != CV_8UC1)
        CV_Error(Error::StsBadArg, format("%s: mask %d is %s, expected CV_8UC1", who, index,
                                          typeToString(m.type()).c_str()));
    if (m.size() != size)
        CV_Error(Error::StsBadSize, format("%s: mask %d is %dx%d but the frame is %dx%d", who,
                                           index, m.cols, m.rows, size.width, size.height));
    compare(m, 0, hole, CMP_NE);
}

}  // namespace detail
}  // namespace vbme
}  // namespace cv
