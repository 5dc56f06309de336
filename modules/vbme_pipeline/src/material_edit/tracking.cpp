// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, tracking stage: the object's disk in each frame (thesis §4.1).
#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

ObjectTrack::ObjectTrack(const Mat& first_mask, int max_lost)
    : tracker_(ObjectTracker::create()), first_mask_(first_mask), max_lost_(max_lost) {}

Disk ObjectTrack::update(const Mat& frame, int index, bool& lost) {
    if (!started_) {
        tracker_->init(frame, first_mask_);
        started_ = true;
    }
    const ObjectTracker::Result res = tracker_->update(frame);
    lost = !res.found;
    if (res.found) {
        last_good_ = res.disk;
        consecutive_lost_ = 0;
    } else {
        ++consecutive_lost_;
        if (index == 0) last_good_ = fitDisk(first_mask_);
        if (consecutive_lost_ > max_lost_)
            CV_Error(Error::StsError,
                     format("material-edit: the object was lost at frame %d (tracking "
                            "confidence %.2f below %.2f); nothing was written. Check "
                            "that the object stays in view and keeps its colour, or "
                            "allow short losses with max_lost (--max-lost N lets up to "
                            "N lost frames in a row pass through unedited)",
                            index, res.confidence, tracker_->params().lost_threshold));
    }
    return last_good_;
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
