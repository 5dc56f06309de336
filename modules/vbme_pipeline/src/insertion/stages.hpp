// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The insertion pipeline's stages, one source file each (see insertion.hpp), and the work
// folder's helpers they share. Private to vbme_pipeline.
#ifndef VBME_PIPELINE_INSERTION_STAGES_HPP
#define VBME_PIPELINE_INSERTION_STAGES_HPP

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/pipeline/insertion.hpp"
#include "opencv2/vbme/render/differential.hpp"
#include "opencv2/vbme/version.hpp"

namespace cv {
namespace vbme {
namespace insertion {

// ------------------------------------------------------------------ work folder (work_folder.cpp)

/** FNV-1a, 64 bit: the fingerprint of a preparation's inputs (persisted in prepared_scene.yml,
so it must not change between versions that share a work folder format). */
struct Hasher {
    uint64 h = 1469598103934665603ull;
    void bytes(const void* data, size_t n);
    void str(const std::string& s);
    void num(double v) { bytes(&v, sizeof v); }
    void num(int64 v) { bytes(&v, sizeof v); }
    void file(const std::string& path);
    void mat(const Mat& m);
    std::string hex() const;
};

/** An advisory lock (flock) on a file of the work folder, released by the kernel when the
process ends, even by kill -9. Several `vbme insert` on one work folder (a render farm's
tasks, or the same command started twice by mistake) take the folder's lock to prepare and to
assemble the video, and one lock per frame while rendering it. (On NFS, Linux emulates flock
with POSIX locks, which the lock daemon shares between machines.) */
class FileLock {
public:
    FileLock() = default;
    FileLock(const FileLock&) = delete;
    FileLock& operator=(const FileLock&) = delete;
    ~FileLock() { release(); }
    /** Takes the lock; with @p wait false returns false at once when another process holds it. */
    bool acquire(const std::string& path, bool wait);
    void release();

private:
    int fd_ = -1;
};

/** Takes the work folder's lock, calling progress("waiting", 0, 0) when another process holds
it. */
void lockWork(FileLock& lock, const std::string& work, const PipelineProgress& progress);

std::string frameFile(const std::string& work, int i);  //!< <work>/frames/frame_%05d.png
std::string exrFile(const std::string& work, int i);    //!< <work>/exr/frame_%05d.exr

/** A ScopedTimer that adds its seconds to stage @p stage of @p report (if not null). */
inline std::function<void(double)> stageSeconds(PipelineReport* report, const char* stage) {
    return [report, stage](double s) {
        if (report) report->addSeconds(stage, s);
    };
}

// ------------------------------------------------------------------ inputs (inputs.cpp)

/** What one decoding pass over the input video gives. */
struct VideoScan {
    int frames = 0;                  //!< frames decoded
    double fps = 0;                  //!< frame rate
    uint64 pixels_hash = 0;          //!< FNV-1a of every frame's pixels, then the fps
    std::vector<double> timestamps;  //!< presentation time of each frame
    std::map<int, Mat> kept;         //!< frames kept for the textures and lights (8-bit BGR)
};

/** The inputs of a preparation: the scene (objects placed and checked against the room) and
the video's scan. */
struct Inputs {
    Scene scene;
    VideoScan video;
    int first = 0, end = 0;  //!< frames to render, [first, end)
};

/** The frames whose radiance builds the room textures (every stride-th, at most ~24, or frame 0
only) for a video of @p n frames. */
std::vector<int> textureFrames(InsertionParams::TextureMode mode, int n);
/** Up to four of @p texture_frames, spread over the video: the frames of light estimation. */
std::vector<int> lightFrames(const std::vector<int>& texture_frames);

/** Reads the scene, checks it against the video, places the objects, scans the video. */
Inputs readInputs(const InsertionParams& p, const PipelineProgress& progress,
                  PipelineReport* report);

// ------------------------------------------------------------------ camera path (camera_path.cpp)

/** The camera path: read from InsertionParams::cameras, or from <work>/cameras.yml, or tracked
into <work>/tracking. @p path_file receives the file it is stored in. */
CameraPath cameraPath(const InsertionParams& p, const Inputs& in, const std::string& work,
                      std::string& path_file, PipelineReport* report);

/** The camera of frame @p i: the path's pose, @p scene's response and image size. */
Camera pathCamera(const CameraPath& path, int i, const Scene& scene);

// ------------------------------------------------------------------ exposure (exposure.cpp)

/** A frame compared with the room: per face it sees, the logarithm of the frame's linear
radiance rectified onto the face at the estimation size, and the texels usable for comparison
(seen, not clipped, within the reliable range, away from the objects' influence and the
proxies). */
struct FaceObservation {
    std::map<std::string, Mat> log;  //!< CV_32FC3, log of the linear radiance
    std::map<std::string, Mat> ok;   //!< CV_8U, 255 where usable
};

/** CV_8U mask, 255 where the inserted objects (their box grown by its size, down to the floor:
the shadow and the light they reflect) or the proxies project in @p cam's image. */
Mat influenceMask(const Scene& scene, const Camera& cam);

/** Per-frame per-channel gains of the video against the room model (see exposure.cpp). */
class ExposureEstimator {
public:
    /** Estimation sizes for @p scene's room as @p first_camera sees it. */
    ExposureEstimator(const Scene& scene, const Camera& first_camera);
    /** Rectifies a display-encoded frame (8-, 16-bit or float BGR) seen by @p cam. */
    FaceObservation observe(const Mat& frame, const Camera& cam) const;
    /** The gains (B, G, R) of @p obs (the texture frames, the first one the reference: gain 1)
    from their pairwise robust log-ratios; builds the model from the normalised frames. */
    std::vector<Vec3d> alignFrames(const std::vector<FaceObservation>& obs);
    /** A frame's gain against the model (alignFrames() first); @p texels receives the texels
    compared (fewer than 30: gain 1 and no estimate). */
    Vec3d frameGain(const FaceObservation& o, int* texels) const;

private:
    Scene scene_;
    Size small_;
    std::map<std::string, Size> sizes_;
    float lo_ = 0, hi_ = 1;
    FaceObservation model_;
};

/** Robust local quadratic smoothing of log gains over ±@p half_window frames; frames with fewer
than 30 texels compared take the fit of their neighbours. */
std::vector<Vec3d> smoothGains(const std::vector<Vec3d>& raw, const std::vector<int>& texels,
                               int half_window);

/** Every frame's gain against the model (one decoding pass), smoothed (InsertionParams::
exposure_smooth). @p raw and @p texels (if not null) receive the unsmoothed gains and the
texels each frame was compared over. */
std::vector<Vec3d> exposureGains(const InsertionParams& p, const Scene& scene,
                                 const CameraPath& path, const ExposureEstimator& est, int frames,
                                 const PipelineProgress& progress, std::vector<Vec3d>* raw,
                                 std::vector<int>* texels);

/** Brings a differential render to a frame's exposure: obj, noobj and diff × @p g (B, G, R). */
void applyFrameGain(DifferentialImages& im, const Vec3d& g);

// ------------------------------------------------------------------ room textures
// (room_textures.cpp)

/** The room's radiance as the video shows it. */
struct RoomRadiance {
    std::map<std::string, Mat> observed;  //!< linear radiance, 0 where unseen
    std::map<std::string, Mat> filled;    //!< the same with unseen texels inpainted
    std::map<std::string, Mat> seen;      //!< CV_8U, 255 where some frame saw the texel
    std::vector<Mat> light_frames;        //!< input frames of light estimation
    std::vector<Camera> light_cameras;    //!< their cameras
    int texture_frames = 0;               //!< frames added to the textures
    /** The frames' exposure against the room model (EXPOSURE_AUTO; null when off): the texture
    and light frames above were divided by their gains, so the radiance is at frame 0's
    exposure. */
    std::shared_ptr<ExposureEstimator> exposure;
};

/** Projects the texture frames onto the room's faces (RoomTextureAccumulator), fills the
unseen texels (fillUnseenTexels()) and writes <work>/textures/<face>.png and _seen.png. Frames
missing from @p in.video.kept are decoded again. */
RoomRadiance roomTextures(const InsertionParams& p, const Inputs& in, const CameraPath& path,
                          const std::string& work, const PipelineProgress& progress);

// ------------------------------------------------------------------ albedo (albedo.cpp)

/** The room's albedo into <work>/albedo/<face>.exr, set as @p room_scene's textures; with
ALBEDO_IRRADIANCE the lights of @p room_scene are scaled to the white point. Returns the white
scale (1 when not used). */
double roomAlbedo(const InsertionParams& p, const RoomRadiance& radiance, Scene& room_scene,
                  const std::string& work, const std::string& fingerprint);

// ------------------------------------------------------------------ lights (lights.cpp)

/** Estimates the lights' powers from the light frames (or keeps them: LIGHTS_NONE) and applies
the estimate to @p room_scene. */
LightEstimate roomLights(const InsertionParams& p, const RoomRadiance& radiance, Scene& room_scene);

// ------------------------------------------------------------------ grain (grain.cpp)

/** The footage's noise measured on (up to 8 of) the kept frames; an empty model when
InsertionParams::grain is off. */
GrainModel footageGrain(const InsertionParams& p, const std::map<int, Mat>& kept);

/** Frame @p i's step "grain": adds the footage's noise to the objects' pixels of the linear
composite (weighted by the coverage) when PreparedInsertion::grain_on. */
void addFrameGrain(const PreparedInsertion& prepared, int i, const DifferentialImages& layers,
                   Mat& linear);

// ------------------------------------------------------------------ motion blur
// (motion_blur.cpp)

/** Frame @p i's step "render (with motion blur)": the layers rendered over the shutter interval
(one render per 1.5 px of the objects' motion over it, at most 16), or the one render at the
frame's time when PreparedInsertion::shutter is 0 or the objects barely move. */
void renderFrameLayers(PreparedInsertion& prepared, int i, DifferentialImages& layers);

/** The shutter (fraction of the frame interval) that best explains the blur of the room's
edges on the frame of the fastest camera motion (the largest image motion over a frame interval
of the room points a 5×5 pixel grid sees): the room's radiance textures (<work>/textures)
seen through 32 cameras spread over one frame interval centred on that frame, averaged over the
central 2j of them (shutter j/16), the frame's gradients compared with the average's (scaled
by least squares, on texels some frame saw), the minimum refined by a parabola. At most 480 px
wide. −1 when the camera never moves more than 3 px in a frame interval. @p frame and
@p motion_px receive that frame and its motion. */
double estimateShutter(const Scene& scene, const CameraPath& path, int frames,
                       const std::string& work, const std::string& video, int* frame,
                       double* motion_px);

// ------------------------------------------------------------------ the record
// (prepared_record.cpp)

/** The fingerprint of everything the prepared scene depends on. */
std::string fingerprint(const InsertionParams& p, const Inputs& in, const CameraPath& path);

/** Fields of prepared_scene.yml's `vbme_prepared` map besides the scene. */
struct PreparedRecord {
    std::string fingerprint;
    std::string scene, video, cameras;  //!< absolute input paths
    int frames = 0, texture_frames = 0;
    double white_scale = 1;
    LightEstimate lights;
    std::vector<Vec3d> gains;     //!< per frame (B, G, R); empty when exposure is off
    int exposure_texels_min = 0;  //!< the fewest texels a frame's gain came from
    // --- motion blur: the estimated shutter (estimateShutter()) ---
    double shutter_estimate = -2;  //!< −2: not estimated, −1: too little motion to measure
    int shutter_frame = -1;        //!< the frame it was measured on
    double shutter_motion_px = 0;  //!< that frame's image motion over a frame interval
};

/** Writes the prepared scene and its record to @p path atomically (FileStorage, AtomicFile). */
void writePrepared(const std::string& path, const Scene& scene, const InsertionParams& p,
                   const PreparedRecord& rec);

/** Reads @p path if it exists, is complete and was made from @p fingerprint. Returns 0 if
absent or incomplete, 1 if reusable (fills @p scene and @p rec), −1 if made from something
else (@p found receives its fingerprint, "" if unreadable). */
int readPrepared(const std::string& path, const std::string& fingerprint, Scene& scene,
                 PreparedRecord& rec, std::string& found);

}  // namespace insertion
}  // namespace vbme
}  // namespace cv

#endif
