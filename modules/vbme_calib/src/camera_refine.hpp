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

/** CPU seconds (user + system) of this process (all threads) and its finished children. */
double processCpuSeconds();

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

/** A corner followed through consecutive frames: the frames it was seen in (increasing) and its
position in each (vbme pixel convention). */
struct CornerTrack {
    std::vector<int> frames;
    std::vector<Point2f> px;
    float sigma = 1;  // standard deviation of its positions (pixels): its weight is 1 / sigma²
};

/** What refineAllFrames() did. */
struct GlobalRefineSummary {
    double rms = 0;                   // inlier reprojection RMS at the end (pixels)
    int points = 0;                   // tracks triangulated and adjusted
    int observations = 0;             // inlier observations at the end
    int total_observations = 0;       // observations of the triangulated tracks before rejection
    double worst_frame_rms = 0;       // worst per-frame inlier RMS (pixels)
    int plane_points = 0;             // points tied to a face of the room box
    double on_face_fraction = 0;      // points within plane_tolerance of a face at the end
    double median_face_distance = 0;  // median distance (m) of the points to the nearest face
};

/** Joint bundle adjustment of every frame with @p posed set (intrinsics fixed, frame 0 held when
posed) with points triangulated from @p tracks at the current poses of @p path: by the linear
(DLT) method where the rays of a track subtend at least 1 degree, else on the room box along the
ray of its first observation; a track whose median reprojection error at the start exceeds 3 px
is left out. Reprojection residuals have a Huber loss (1 px); points within @p plane_tolerance of
a face of the room box are tied to it (σ = 1 cm) as in refineTrack(). Observations farther than
2 px from their projection after a solve are removed and the problem solved again (twice).
Writes the adjusted poses of the posed frames back into @p path. */
GlobalRefineSummary refineAllFrames(const std::vector<CornerTrack>& tracks, const Scene& frame0,
                                    double plane_tolerance, const std::vector<bool>& posed,
                                    CameraPath& path);

/** Gives every frame without @p have a pose interpolated between the nearest frames with
one (slerp of rotations, linear centres), or held at the nearest one beyond the ends, marked
CameraPath::INTERPOLATED. @return how many frames were interpolated. */
int interpolateMissing(CameraPath& path, const std::vector<bool>& have);

/** Median distance (metres) of @p points to the nearest face of @p room (0 when empty). */
double medianFaceDistance(const std::vector<Vec3d>& points, const Room& room);

/** Sets report.confident and report.doubt from report.scale.spread and report.face_distance
against the limits of @p options, and (when @p joint_adjustment ran) report.ba_applied. */
void judgeConfidence(const CameraTrackingOptions& options, bool joint_adjustment,
                     CameraTrackingReport& report);

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
