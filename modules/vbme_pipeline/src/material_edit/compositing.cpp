// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, compositing stage: the rendered box (whose rim pixels already blend the
// object's coverage with the background) encoded into the filled frame.
#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

void compositeObject(const Mat& filled, const Mat& rendered, Rect box, Response response,
                     Mat& out8) {
    out8 = filled.clone();
    if (!box.empty()) {
        Mat comp;
        encode(rendered(box), comp, response, CV_8U);
        comp.copyTo(out8(box));
    }
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
