// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read / write / check of DiskFitParams and TrackVideoOptions (ObjectTracker::Params: in
// object_tracker.cpp).
#include <cmath>

#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/track/disk.hpp"
#include "opencv2/vbme/track/video_tracking.hpp"

namespace cv {
namespace vbme {

void DiskFitParams::read(const FileNode& fn) {
    ParamsIn in(fn, "disk fit parameters");
    in("min_step", min_step);
    in("max_iterations", max_iterations);
    in("min_radius", min_radius);
    in("max_radius", max_radius);
    in.finish();
    check();
}

void DiskFitParams::write(FileStorage& fs) const {
    fs << "min_step" << min_step << "max_iterations" << max_iterations << "min_radius" << min_radius
       << "max_radius" << max_radius;
}

void DiskFitParams::check() const {
    const char* w = "disk fit parameters";
    checkParam(min_step > 0 && min_step <= 1, w, "min_step", min_step, "(0, 1] pixels");
    checkParam(max_iterations >= 0, w, "max_iterations", max_iterations, ">= 0");
    checkParam(min_radius >= 0 && std::isfinite(min_radius), w, "min_radius", min_radius,
               ">= 0 pixels");
    checkParam(max_radius == 0 || (max_radius >= min_radius && std::isfinite(max_radius)), w,
               "max_radius", max_radius, "0 (no bound) or >= min_radius");
}

void TrackVideoOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "track video options");
    in("params", params);
    in("overlay", overlay);
    in("overlay_encode", overlay_encode);
    in("force", force);
    in.finish();
    check();
}

void TrackVideoOptions::write(FileStorage& fs) const {
    fs << "params"
       << "{";
    params.write(fs);
    fs << "}";
    fs << "overlay" << overlay;
    fs << "overlay_encode"
       << "{";
    overlay_encode.write(fs);
    fs << "}";
    fs << "force" << (int)force;
}

void TrackVideoOptions::check() const {
    params.check();
    overlay_encode.check();
}

}  // namespace vbme
}  // namespace cv
