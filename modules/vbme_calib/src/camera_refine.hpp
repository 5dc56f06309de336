// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Ceres refinement of an aligned camera track (private to vbme_calib).
#ifndef VBME_CALIB_CAMERA_REFINE_HPP
#define VBME_CALIB_CAMERA_REFINE_HPP

#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "opencv2/vbme/calib/camera_tracking.hpp"
#include "opencv2/vbme/core/fileio.hpp"

namespace cv {
namespace vbme {
namespace detail {

/** Writes a one-line resume marker of the work folder (a finished stage and its settings)
through AtomicFile: a run killed while writing it leaves no marker rather than a partial one. */
inline void writeMarker(const std::string& path, const std::string& line) {
    AtomicFile out(path);
    {
        std::ofstream f(out.tempPath());
        f << line << "\n";
        if (!f.flush()) CV_Error(Error::StsError, "cannot write '" + path + "'");
    }
    out.commit();
}

/** What refineTrack() did. */
struct RefineSummary {
    double rms_before = 0, rms_after = 0;  // reprojection RMS (pixels) over all observations
    int points = 0, plane_points = 0, observations = 0, iterations = 0;
};

/** Bundle adjustment of the registered frames of @p path (intrinsics fixed, frame 0 held at
the annotated camera) with the model's points moved into the world frame by the similarity
(M, c, s) of the alignment. Points lying within @p plane_tolerance of a face of the room box are
tied to that face (σ = 1 cm), which fixes the scale and the floor height from every frame, not
from frame 0 alone. With @p smooth_sigma > 0, a prior on the second difference of camera centres
and rotations (σ = 2 mm and 0.0005 rad divided by smooth_sigma², smooth_sigma in frames) damps
jitter. @p world_points, if given, receives the refined points in the world frame by
POINT3D_ID (those observed by a registered frame). */
RefineSummary refineTrack(const ColmapModel& model, const std::vector<std::string>& names,
                          const Scene& frame0, const Matx33d& M, const Vec3d& c, double s,
                          double plane_tolerance, double smooth_sigma, CameraPath& path,
                          std::map<long long, Vec3d>* world_points = nullptr);

/** Gives every frame without @p have a pose interpolated between the nearest frames with
one (slerp of rotations, linear centres), or held at the nearest one beyond the ends, marked
CameraPath::INTERPOLATED. @return how many frames were interpolated. */
int interpolateMissing(CameraPath& path, const std::vector<bool>& have);

/** alignToRoom() that also returns the model's points in the world frame (refined when
options.refine), by POINT3D_ID. */
CameraPath alignToRoomWithPoints(const ColmapModel& model, const std::vector<std::string>& names,
                                 const Scene& frame0, const CameraTrackingOptions& options,
                                 CameraTrackingReport* report,
                                 std::map<long long, Vec3d>* world_points);

}  // namespace detail
}  // namespace vbme
}  // namespace cv

#endif
