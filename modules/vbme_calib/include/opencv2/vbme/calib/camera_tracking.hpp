// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE).
#ifndef OPENCV_VBME_CALIB_CAMERA_TRACKING_HPP
#define OPENCV_VBME_CALIB_CAMERA_TRACKING_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/core.hpp>

#include "opencv2/vbme/calib/colmap.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_calib
//! @{

/** @brief Depth (camera z, metres) of the room-box surface seen at pixel @p px
by @p camera (which must be inside the box); @p face receives the face's index
in Room::faceNames(). */
CV_EXPORTS double boxDepthAt(const Camera& camera, const Room& room, const Point2d& px,
                             int* face = nullptr);

/** @brief Result of a scale estimate: metres per unit of the SfM model. */
struct CV_EXPORTS ScaleEstimate {
    double scale = 0;   //!< metres per SfM unit
    double spread = 0;  //!< relative spread of the per-point ratios used (std / scale)
    int used = 0;       //!< points used
    int total = 0;      //!< points offered
};

/** @brief Eq. 5.3 of the thesis: the mean over the points of box_depth /
 * sfm_depth. */
CV_EXPORTS ScaleEstimate scaleEq53(const std::vector<double>& box_depths,
                                   const std::vector<double>& sfm_depths);

/** @brief A robust Eq. 5.3: the median ratio, then the points whose ratio lies
within
@p tolerance (relative) of it — points that really lie on the box, not on
furniture or seen through a window — averaged with weights 1 / (reprojection
error + 0.5 px).
@param errors per-point reprojection errors (pixels), or empty for equal
weights. */
CV_EXPORTS ScaleEstimate scaleRobust(const std::vector<double>& box_depths,
                                     const std::vector<double>& sfm_depths,
                                     const std::vector<double>& errors = std::vector<double>(),
                                     double tolerance = 0.05);

/** @brief How trackCameraVideo() chooses the frames COLMAP reconstructs and registers the
others. */
struct CV_EXPORTS KeyframeOptions {
    int features = 500;        //!< KLT corners tracked through the video to choose keyframes
    double max_motion = 0.08;  //!< new keyframe when the median image motion of the tracked
                               //!< corners since the last keyframe exceeds this fraction of the
                               //!< image width (parallax for translation, overlap loss for pans)
    double min_overlap = 0.6;  //!< new keyframe when fewer than this fraction of the last
                               //!< keyframe's corners are still tracked
    int max_gap = 15;          //!< never more than this many frames between keyframes
    int stride = 0;            //!< > 0: keyframes every stride-th frame instead (no selection)
    int sift_features = 2048;  //!< COLMAP SIFT features per keyframe (replaces
                               //!< ColmapOptions::max_num_features for keyframe runs)
    int overlap = 6;           //!< COLMAP sequential matching overlap between keyframes

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief Options of alignment and tracking. */
struct CV_EXPORTS CameraTrackingOptions {
    /** @brief Which frames structure-from-motion sees. */
    enum Method {
        KEYFRAMES,  //!< COLMAP on keyframes only, every other frame registered by PnP
        FULL        //!< COLMAP on every stride-th frame, the others interpolated
    };
    Method method = KEYFRAMES;      //!< what trackCameraVideo() does
    KeyframeOptions keyframes;      //!< keyframe choice and COLMAP settings of the KEYFRAMES method
    bool pnp = true;                //!< KEYFRAMES: register non-keyframes by PnP (else interpolate)
    int pnp_min_inliers = 25;       //!< a PnP pose needs at least this many inlier points...
    double pnp_max_rms = 1.5;       //!< ...and an inlier reprojection RMS (pixels) at most this
    bool global_refine = true;      //!< KEYFRAMES: after PnP, bundle adjustment of every registered
                                    //!< frame's pose with points triangulated from corner tracks
                                    //!< through the whole video (trackCameraKeyframes())
    bool robust_scale = true;       //!< robust Eq. 5.3 (else the thesis's mean)
    double scale_tolerance = 0.05;  //!< relative tolerance of the robust scale's inliers
    int stride = 1;  //!< FULL: reconstruct every k-th frame (the rest interpolated); KEYFRAMES:
                     //!< when > 1, keyframes every k-th frame (sets keyframes.stride)
    bool refine =
        true;  //!< Ceres bundle adjustment in the room frame, points tied to the box faces
    double plane_tolerance = 0.05;  //!< points this close (m) to a face are tied to it
    double smooth_sigma = 0;        //!< > 0: smoothness prior on the trajectory, width in frames
    /** The track is reported as doubtful (CameraTrackingReport::confident) when the relative
    spread of the frame-0 depth ratios of the robust scale exceeds this: the COLMAP model's shape
    does not fit the annotated room. Blender clip, keyframe models: 0.0160-0.0176 where the track
    was 0.31-0.40 cm off, 0.0207-0.0244 where it was 0.48 cm to 58 cm off. */
    double max_scale_spread = 0.019;
    /** The track is reported as doubtful when its points' median distance to the nearest face of
    the room box (CameraTrackingReport::face_distance) exceeds this (metres). */
    double max_face_distance = 0.0015;
    /** KEYFRAMES: when a fresh COLMAP model is doubtful by max_scale_spread, COLMAP's mapper is
    run again on the same features and matches with another random seed, up to this many times,
    and the model with the smallest scale spread is kept; if it is still doubtful, COLMAP runs
    once more from new features and matches (0: none of this). */
    int mapper_retries = 2;
    /** KEYFRAMES with global_refine: at most this many passes of the joint adjustment, each set up
    again (points triangulated, tied to the box's faces, gated) at the poses the last one left:
    a second pass when the first moved a frame by more than 15 mm, further ones while a pass moves
    one by more than 5 mm. 1: one pass (before issue 22's fix of
    the poor runs: from a distorted COLMAP model it stayed in that model's basin). */
    int joint_passes = 3;
    ColmapOptions colmap;  //!< how COLMAP runs

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief What the tracking did. */
struct CV_EXPORTS CameraTrackingReport {
    int frames = 0;               //!< video frames
    int registered = 0;           //!< frames with a pose from SfM
    int interpolated = 0;         //!< frames whose pose was interpolated
    int models = 0;               //!< models COLMAP produced (only the one holding frame 0 is used)
    double reprojection_rms = 0;  //!< RMS reprojection error of the used model's points (pixels)
    double refined_rms = 0;       //!< RMS reprojection error after the refinement (pixels)
    int plane_points = 0;         //!< points tied to a face of the box in the refinement
    ScaleEstimate scale;          //!< the scale of Eq. 5.3 (robust or mean)
    double seconds = 0;           //!< wall time
    int keyframes = 0;            //!< KEYFRAMES: frames given to COLMAP
    int pnp = 0;                  //!< frames registered by PnP
    double pnp_rms = 0;           //!< RMS reprojection error of the PnP frames' inliers (pixels)
    double pnp_inliers = 0;       //!< mean inlier points per PnP frame
    /** KEYFRAMES with global_refine: RMS reprojection error (pixels) of the corner tracks'
    inlier observations after the joint adjustment of all frames (0: not run). */
    double ba_rms = 0;
    int ba_points = 0;              //!< corner tracks triangulated into the joint adjustment
    int ba_observations = 0;        //!< their inlier observations (within 2 px at the end)
    double ba_worst_frame_rms = 0;  //!< worst per-frame RMS of those observations (pixels)
    /** Fraction of the joint adjustment's points within plane_tolerance of a face of the room
    box at the end (measured on the Blender clip: 0.78-0.79 with the true focal length, 0.64-0.71
    with one 5 % too long); a room with much furniture has it lower. */
    double ba_on_face = 0;
    /** Median distance (metres) of the joint adjustment's points to the nearest face of the room
    box after its first pass (later passes fit a wrong room better too): a confidence of the track
    in the annotated room, which rises when the track does not fit the room (Blender clip: 0.43-0.44
    mm with the true focal length, 2.72-4.22 mm with one 5 % too long, whose track is 5.2-5.4 cm
    off). */
    double ba_face_distance = 0;
    /** Whether the joint adjustment's poses were used: not when it moved a frame more than
    0.25 m or 5 degrees from its SfM/PnP pose (the adjustment came apart). */
    bool ba_applied = false;
    /** How far (metres) each pass of the joint adjustment moved the frame it moved most: the
    adjustment is set up again at its own poses and repeated when its first pass moved a frame by
    more than 15 mm, then while a pass moves one by more than 5 mm, at most
    CameraTrackingOptions::joint_passes passes (one entry per pass run). */
    std::vector<double> ba_pass_moves;
    /** Median distance (metres) of the track's 3D points to the nearest face of the room box:
    the joint adjustment's points (KEYFRAMES, when applied), else the aligned and refined COLMAP
    points. A track that does not fit the annotated room has it larger. */
    double face_distance = 0;
    /** Whether nothing the pipeline can see without ground truth speaks against the track: false
    when the scale spread exceeds CameraTrackingOptions::max_scale_spread, face_distance exceeds
    CameraTrackingOptions::max_face_distance, or the joint adjustment came apart; doubt then
    says why. */
    bool confident = true;
    std::string doubt;  //!< why the track is not confident (empty when it is)
    /** KEYFRAMES: the scale spread of every COLMAP mapper run on the keyframes, in order (the
    first, then the retries with other seeds; empty when a finished run was reused). */
    std::vector<double> mapper_scale_spreads;
    /** Wall time of each stage (name, seconds) in order, e.g. decode, keyframes, COLMAP's
    feature_extractor, sequential_matcher, mapper, align, pnp. */
    std::vector<std::pair<std::string, double>> stage_seconds;
    /** CPU time (user + system, seconds) of each stage, in the order of stage_seconds: vbme's
    threads for its own stages, COLMAP's process for COLMAP's steps. */
    std::vector<std::pair<std::string, double>> stage_cpu_seconds;
};

/** @brief Aligns a COLMAP model to the annotated room: rotates and translates
it so that frame 0's camera coincides with @p frame0's camera, and scales it by
Eq. 5.3 (frame-0 features with a 3D point: depth of the feature's ray on the box
/ depth of its SfM point).
@param model the SfM model (cam_from_model poses).
@param frame_names the image name of every video frame, in order (frame_names[0]
is frame 0).
@param frame0 the annotated scene of frame 0 (camera and room).
@param options robust or mean scale.
@param report receives counts, the scale, the points' median distance to the room's faces
(face_distance) and whether the track is confident (CameraTrackingReport::confident: false with
the reason in doubt when the scale spread or the face distance exceeds the limits of @p options).
@return one pose per video frame; frames absent from the model are interpolated
(slerp of rotations, linear centres) between their registered neighbours, or
held at the nearest one beyond the ends, and flagged CameraPath::INTERPOLATED.
*/
CV_EXPORTS CameraPath alignToRoom(const ColmapModel& model,
                                  const std::vector<std::string>& frame_names, const Scene& frame0,
                                  const CameraTrackingOptions& options = CameraTrackingOptions(),
                                  CameraTrackingReport* report = nullptr);

/** @brief Camera tracking of a video given as a folder of frames named in time
order: COLMAP (runColmapSfM) then alignToRoom(). @p work_dir receives COLMAP's
files and log. */
CV_EXPORTS CameraPath trackCameraFrames(
    const std::string& frames_dir, const std::vector<std::string>& frame_names, const Scene& frame0,
    const std::string& work_dir, const CameraTrackingOptions& options = CameraTrackingOptions(),
    CameraTrackingReport* report = nullptr);

/** @brief Camera tracking of a video file (or image folder). With options.method KEYFRAMES
(the default) the frames are decoded to grey in memory and trackCameraKeyframes() runs. With
FULL, frames are extracted to `work_dir/frames` (every @p options.stride-th one; the others are
interpolated), COLMAP runs in `work_dir`, and the model is aligned to the annotated room. Resumable:
extracted frames and a finished COLMAP run found in
@p work_dir (marked complete) are reused, not redone. Throws cv::Exception if
the video's frame size differs from the scene's image size. */
CV_EXPORTS CameraPath
trackCameraVideo(const std::string& video, const Scene& frame0, const std::string& work_dir,
                 const CameraTrackingOptions& options = CameraTrackingOptions(),
                 CameraTrackingReport* report = nullptr);

/** @brief Chooses keyframes of a video by tracking corners (pyramidal Lucas-Kanade
@cite Bouguet2001, forward-backward checked) from frame to frame: a frame becomes a keyframe when
the median motion of the last keyframe's corners exceeds options.max_motion × width, when fewer
than options.min_overlap of them survive, or options.max_gap frames after the last keyframe.
Frame 0 and the last frame are keyframes. With options.stride > 0: every stride-th frame.
@param gray the video's frames, 8-bit single channel, all of one size.
@return keyframe indices, increasing. */
CV_EXPORTS std::vector<int> selectKeyframes(InputArrayOfArrays gray,
                                            const KeyframeOptions& options = KeyframeOptions());

/** @brief Camera tracking of a video held in memory by keyframes: selectKeyframes(), COLMAP
(runColmapSfM) on the keyframes alone (written to `work_dir/keyframes`), alignToRoom() of the
model, then every frame COLMAP did not register gets its pose by PnP: the 2D features of the
nearest registered frame on each side that have a 3D point are tracked into it (Lucas-Kanade,
frame to frame, forward-backward checked), its pose solved by RANSAC PnP and refined by
Levenberg-Marquardt on the inliers with the points fixed (solvePnPRefineLM), in the room frame
(CameraPath::PNP). A frame with too few inliers or too large an error keeps the interpolated
pose (CameraPath::INTERPOLATED). Then, with options.global_refine, every SfM and PnP frame is
adjusted jointly (Ceres, intrinsics fixed, frame 0 held): the corners the keyframe choice tracked
through the whole video and COLMAP's own keyframe observations are triangulated at the current
poses (or placed on the room box where their rays are nearly parallel), points near a face of the
box are tied to it, observations more than 2 px off are dropped, and this is set up again at the
adjusted poses and repeated when the first pass moved a frame by more than 15 mm, then while a
pass moves one by more than 5 mm (at most options.joint_passes passes, report.ba_pass_moves); the
adjusted poses replace the SfM and PnP ones unless a frame moved more than 0.25 m or 5 degrees
(report.ba_applied). This makes the track depend far less on COLMAP's keyframe model, which varies
between runs. A fresh COLMAP model whose frame-0 depth ratios spread more than
options.max_scale_spread is mapped again (rerunColmapMapper(), other seeds, up to
options.mapper_retries times) and the model with the smallest spread kept; if it stays doubtful,
COLMAP runs once more on the same keyframes (new features and matches) and its model is kept if its
spread is smaller; report.confident and report.doubt say whether the final track is doubtful
(CameraTrackingOptions::max_scale_spread, max_face_distance, the adjustment coming apart).
Resumable: a finished COLMAP run on the same keyframes, settings and intrinsics found in @p work_dir
is reused.
@param gray the video's frames, 8-bit single channel, of frame0.image_size. */
CV_EXPORTS CameraPath
trackCameraKeyframes(InputArrayOfArrays gray, const Scene& frame0, const std::string& work_dir,
                     const CameraTrackingOptions& options = CameraTrackingOptions(),
                     CameraTrackingReport* report = nullptr);

/** @brief Draws the room box's edges as @p camera sees them (clipped to the
part in front of the camera), with a caption; the quickest check of a camera
track. With lens distortion (Camera::k1 ≠ 0) the edges are bent as the lens shows them
(Camera::distortPixel), for drawing on the video's own frames. */
CV_EXPORTS void drawRoomBox(InputOutputArray image, const Camera& camera, const Room& room,
                            const Scalar& colour = Scalar(0, 255, 255),
                            const std::string& caption = std::string());

/** @brief Writes a Python script that, run in Blender (`blender --python FILE`, or from its
Text Editor), creates a camera keyframed on every frame of @p path (OpenCV camera axes turned
into Blender's, focal length and principal point as lens and shift, frame rate @p fps) and the
room box as a wireframe cube, so the track can be checked where users check tracks. Written
atomically. */
CV_EXPORTS void writeBlenderScript(const std::string& script_path, const CameraPath& path,
                                   const Room& room, double fps);

/** @brief The aligned track as a COLMAP text model (one PINHOLE camera, one
image per video frame named frame_%05d.png, no points), for tools that read
COLMAP models. With lens distortion (CameraPath::k1 ≠ 0) the camera describes the video's
own distorted frames: SIMPLE_RADIAL (f, cx, cy, k) with k = k1 — COLMAP's radial coefficient
acts on the same normalised coordinates as vbme's — or OPENCV (k1, 0, 0, 0) when fx ≠ fy. */
CV_EXPORTS ColmapModel toColmapModel(const CameraPath& path);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
