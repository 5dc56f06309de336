// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_PIPELINE_INSERTION_HPP
#define OPENCV_VBME_PIPELINE_INSERTION_HPP

#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/core/video.hpp"
#include "opencv2/vbme/render/light_estimation.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_pipeline
//! @{

/** @brief Options of runInsertion() (the `vbme insert` command's options). */
struct CV_EXPORTS InsertionParams {
    std::string video;    //!< input video (file, image folder or pattern)
    std::string scene;    //!< frame-0 scene file (vbme calibrate's output + objects:)
    std::string cameras;  //!< camera path YAML; empty: camera tracking is run into the work folder
    std::string out;      //!< composited video (.mp4, .mkv, .avi or %05d image pattern)
    std::string work;     //!< work folder (empty: <out without extension>_work)
    bool has_place = false;     //!< whether @p place is given (--place u,v)
    Point2d place;              //!< objects[0] on the floor under this frame-0 pixel
    int spp = 0;                //!< samples per pixel (0: the scene's render.spp)
    /** @brief Adaptive sampling's minimum per pixel (Renderer::Params::adaptive_min_spp; 0,
    the default: every pixel takes `spp`). When on, a pixel takes at most 4 × `spp`. Off by
    default: in PipelineInsertE2E (spp 4) it lowered the region PSNR from 30 to 25.3 dB. */
    int adaptive_min_spp = 0;
    /** @brief Adaptive sampling's target: 95 % half-width of the composite in 8-bit display
    values (Renderer::Params::adaptive_error). */
    double adaptive_error = 0.5;
    /** @brief Probability that a pixel whose minimum met no object goes on
    (Renderer::Params::adaptive_roulette; 0: such pixels keep a difference of exactly 0). */
    double adaptive_roulette = 0.0;
    /** @brief Texture filtering after diffuse bounces: the ray cone's spread in radians
    (Renderer::Params::texture_cone; 0: off). */
    double texture_cone = 0.1;
    int first = 0;              //!< first frame to render (frames [first, end))
    int end = -1;               //!< one past the last frame to render (−1: to the last frame)
    bool prepare_only = false;  //!< stop after preparing the work folder (tracking, textures,
                                //!< albedo, lights): render farms prepare once, then split frames
    bool keep_exr = false;      //!< keep per-frame multi-layer EXRs in <work>/exr
    std::string texture_mode = "accumulate";  //!< or "per-frame"
    std::string albedo = "irradiance";        //!< or "retinex"
    std::string lights = "nnls";              //!< or "hill-climb", "none"
    bool per_frame_gain = false;              //!< light estimation fits one exposure gain per frame
    /** @brief Albedo of the room's whitest surfaces (99th percentile of the irradiance albedo's
    largest channel), which fixes the scale that image = albedo × light power leaves open: the
    lights' annotated radiance comes from clipped LDR pixels and is only a lower bound. 0 keeps
    the annotated powers. Retinex albedo uses its own white point (RetinexParams::white). */
    double white = 0.9;
    int threads = 0;           //!< 0: all cores
    bool force = false;        //!< overwrite an existing --out
    bool quiet = false;        //!< no scene warnings on stderr (progress: Progress::setEnabled)
    std::string command_line;  //!< recorded in the EXR provenance attributes (optional)
    /** Encoding of the output video (codec, quality, pixel format); the input's timestamps,
    colour tags and audio are carried to it (cv::vbme::sinkOptionsFrom). */
    VideoSinkOptions encode;
};

/** @brief What runInsertion() did. */
struct CV_EXPORTS InsertionReport {
    int frames_total = 0;        //!< frames of the video
    int frames_rendered = 0;     //!< frames rendered by this run
    int frames_busy = 0;         //!< frames of [first, end) another process was rendering
    int frames_skipped = 0;      //!< frames of [first, end) already in the work folder
    bool video_written = false;  //!< false when frames of the video are still missing (split runs)
    /** @brief Per stage wall seconds: tracking, textures, albedo, lights, render, encode. */
    std::map<std::string, double> seconds;
    double seconds_per_frame = 0;  //!< render + composite per rendered frame
    LightEstimate lights;          //!< the light estimate (stored in the prepared scene)
    /** @brief Factor applied to all annotated light powers to bring the room's white point to
    InsertionParams::white (before `lights`; 1 when not used). */
    double white_scale = 1;
    int spp = 0;                   //!< samples per pixel used
    bool prepared_reused = false;  //!< the prepared scene of the work folder was reused
    std::string work;              //!< the work folder used
    std::vector<int> missing;      //!< frames of the video without a composited file
    /** @brief Writes the report as YAML (atomically). */
    void write(const std::string& path) const;
};

/** @brief Inserts the scene's `objects:` into a hand-held video of a room (thesis chapter 5).

A thin driver over the modules: camera path (read, or vbme_calib's trackCameraVideo into
`<work>/tracking`), room textures accumulated over the video (RoomTextureAccumulator, unseen
texels filled by ExemplarInpainter), albedo (irradianceAlbedo or retinexAlbedo), light
estimation (estimateLights, applyLightEstimate), then per frame a DifferentialRenderer render
with shared samples and a fixed seed, composited onto the input frame (compositeDifferential,
encodeComposite) and written as `<work>/frames/frame_%05d.png`. Frames already there are
skipped, so an interrupted run resumes and several machines can split one video with
@p first / @p end. When every frame exists the output video is assembled (with the input's
audio, if any). See doc/vbme_pipeline_insert.md. Throws cv::Exception for bad input. */
CV_EXPORTS InsertionReport runInsertion(const InsertionParams& p);

/** @brief world_from_object that puts the object's bounding-box bottom centre on the floor
(z = room.min.z) where frame-0 pixel @p px looks (the rotation of the object's current
world_from_object is kept); throws if the ray misses the floor or the object would leave the
room. */
CV_EXPORTS Matx44d placeOnFloor(const Scene& scene, const SceneObject& object, Point2d px);

/** @brief World-space axis-aligned bounds of an object's mesh under its world_from_object
(loads the mesh). */
CV_EXPORTS void objectWorldBounds(const SceneObject& object, Vec3d& lo, Vec3d& hi);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
