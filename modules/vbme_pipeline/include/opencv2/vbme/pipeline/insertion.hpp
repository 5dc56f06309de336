// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_PIPELINE_INSERTION_HPP
#define OPENCV_VBME_PIPELINE_INSERTION_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera_path.hpp"
#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/core/video.hpp"
#include "opencv2/vbme/pipeline/camera_match.hpp"
#include "opencv2/vbme/pipeline/report.hpp"
#include "opencv2/vbme/render/differential.hpp"
#include "opencv2/vbme/render/integrator.hpp"
#include "opencv2/vbme/render/light_estimation.hpp"
#include "opencv2/vbme/render/placement.hpp"
#include "opencv2/vbme/render/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_pipeline
//! @{

/** @brief Options of the insertion pipeline (prepareInsertion(), runInsertion(); the
`vbme insert` command's options).

The stages and their files: the inputs and the camera path (`src/insertion/inputs.cpp`,
`camera_path.cpp`), the room textures (`room_textures.cpp`), the albedo (`albedo.cpp`), the
lights (`lights.cpp`), the prepared scene (`prepare.cpp`, `prepared_record.cpp`), one frame
(`render_frame.cpp`) and the resumable file-to-file driver (`driver.cpp`). */
struct CV_EXPORTS InsertionParams {
    /** @brief Which frames give the room's radiance textures. */
    enum TextureMode {
        TEXTURE_ACCUMULATE = 0,  //!< frames over the whole video (every k-th, at most ~24)
        TEXTURE_PER_FRAME = 1    //!< frame 0 only (the thesis's textures)
    };
    /** @brief How the room's albedo is taken from its radiance textures. */
    enum AlbedoMethod {
        ALBEDO_IRRADIANCE = 0,  //!< texture / irradiance of the room's lights (irradianceAlbedo())
        ALBEDO_RETINEX = 1      //!< Retinex shading removal (retinexAlbedo())
    };
    /** @brief How the lights' powers are estimated (estimateLights()). */
    enum LightsMethod {
        LIGHTS_NNLS = 0,        //!< non-negative least squares
        LIGHTS_HILL_CLIMB = 1,  //!< the thesis's hill climbing (Eq. 5.1)
        LIGHTS_NONE = 2         //!< keep the scene's powers
    };

    std::string video;    //!< input video (file, image folder or pattern)
    std::string scene;    //!< frame-0 scene file (vbme calibrate's output + objects:)
    std::string cameras;  //!< camera path YAML; empty: camera tracking is run into the work folder
    std::string out;      //!< composited video (.mp4, .mkv, .avi or %05d image pattern)
    std::string work;     //!< work folder (empty: <out without extension>_work)
    bool has_place = false;  //!< whether @p place is given (--place u,v)
    Point2d place;           //!< objects[0] on the floor under this frame-0 pixel
    int spp = 0;             //!< samples per pixel (0: the scene's render.spp)
    /** @brief Adaptive sampling's minimum per pixel (Renderer::Params::adaptive_min_spp; 0:
    off, every pixel takes `spp`). When on (the default, 2), a pixel takes at most 4 × `spp`;
    pixels where no path met the object stop at the minimum, so the mean is usually below
    `spp` (doc/vbme_pipeline_insert.md, "Sampling": better composites than uniform `spp` at
    0.66–0.73× its samples on the synthetic and the Blender clips). */
    int adaptive_min_spp = 2;
    /** @brief Adaptive sampling's target: 95 % half-width of the composite in 8-bit display
    values (Renderer::Params::adaptive_error). */
    double adaptive_error = 0.5;
    /** @brief Probability that a pixel whose minimum met no object goes on
    (Renderer::Params::adaptive_roulette; 0: such pixels keep a difference of exactly 0). */
    double adaptive_roulette = 0.0;
    /** @brief Texture filtering after diffuse bounces: the ray cone's spread in radians
    (Renderer::Params::texture_cone; 0: off). */
    double texture_cone = 0.1;
    /** @brief Radius in pixels of the joint bilateral filter applied to each frame's difference
    layer outside the objects (denoiseDifference(); 0: off). The default, 1, lowered the
    composite's error and did not add flicker where measured (doc/vbme_pipeline_insert.md,
    "Denoising the difference layer"). */
    int denoise = 1;
    int first = 0;              //!< first frame to render (frames [first, end))
    int end = -1;               //!< one past the last frame to render (−1: to the last frame)
    bool prepare_only = false;  //!< stop after preparing the work folder (tracking, textures,
                                //!< albedo, lights): render farms prepare once, then split frames
    bool keep_exr = false;      //!< keep per-frame multi-layer EXRs in <work>/exr
    TextureMode texture_mode = TEXTURE_ACCUMULATE;  //!< frames of the room textures
    AlbedoMethod albedo = ALBEDO_IRRADIANCE;        //!< albedo method
    LightsMethod lights = LIGHTS_NNLS;              //!< light estimation method
    bool per_frame_gain = false;  //!< light estimation fits one exposure gain per frame
    /** @brief Largest albedo of the room's surfaces: the lights are raised (never lowered)
    until the whitest surfaces reach it, which fixes the scale that image = albedo × light power
    leaves open when the annotated powers are a lower bound (irradianceAlbedoWhitePoint()); 0
    keeps the annotated powers. Used by ALBEDO_IRRADIANCE only (Retinex has its own
    RetinexParams::white). */
    double white = 0.9;
    /** @brief How the objects' shadows go onto the footage (CompositeParams::Shadows): ratio
    (default; the footage loses the fraction of light the model loses, which is never negative
    and follows the footage's exposure) or additive (Eq. 5.2). */
    CompositeParams::Shadows shadows = CompositeParams::SHADOWS_RATIO;

    // ---- exposure and white balance per frame (issue 21; doc/vbme_pipeline_insert.md) ----
    /** @brief Whether the frames' exposure and white balance are followed. */
    enum ExposureMode {
        /** per-frame per-channel gains estimated against the room model, applied to the
        rendered object and its differential; the room textures, albedo and lights are built
        from frames brought to frame 0's exposure (the default) */
        EXPOSURE_AUTO = 0,
        EXPOSURE_OFF = 1  //!< every frame is taken at one exposure (all gains 1)
    };
    ExposureMode exposure = EXPOSURE_AUTO;  //!< exposure and white balance per frame
    /** @brief Half-width in frames of the gains' smoothing over time (a robust local
    quadratic fit over 2·n + 1 frames; 0: the per-frame estimates as they are). */
    int exposure_smooth = 2;
    // ---- end of exposure ----

    // --- grain and motion blur (issue 21: the camera's noise and blur on the object) ---
    /** @brief Whether the footage's noise is added to the objects' pixels. */
    enum GrainMode {
        GRAIN_AUTO = 0,  //!< measured (measureGrain()); added when the measure is reliable
        GRAIN_OFF = 1    //!< not measured, not added
    };
    GrainMode grain = GRAIN_AUTO;  //!< grain matching (`--grain auto|off`)
    /** @brief The exposure as a fraction of the frame interval, over which the objects and
    their differential are rendered (motion blur from the camera path); −1 (the default,
    `--shutter auto`): estimated from the blur of the room's edges on the frame of the fastest
    camera motion; 0 (`--shutter off`): no motion blur. */
    double shutter = -1;
    // --- end of grain and motion blur ---
    int threads = 0;           //!< renderer worker threads (0: all cores)
    bool force = false;        //!< overwrite an existing --out; redo a foreign work folder
    std::string command_line;  //!< recorded in the EXR provenance attributes (optional)
    /** Encoding of the output video (codec, quality, pixel format); the input's timestamps,
    colour tags and audio are carried to it (cv::vbme::sinkOptionsFrom). */
    VideoSinkOptions encode;

    /** @brief Reads the fields present in @p fn (names as write() writes them; the enums as
    the command line's words, e.g. `texture_mode: per-frame`). Throws cv::Exception naming
    any key it does not know, and the valid ones. `encode` is not read. */
    void read(const FileNode& fn);
    /** @brief Writes the fields (not `encode`, `command_line`) at the current level. */
    void write(FileStorage& fs) const;
    /** @brief Throws cv::Exception naming the first field out of its valid range (and the
    range). File names are not checked for existence here. */
    void check() const;
    /** @brief The work folder: @p work, or `<out without extension>_work` when empty. */
    std::string workFolder() const;
};

/** @brief The command line's word for a texture mode ("accumulate", "per-frame"). */
CV_EXPORTS std::string toString(InsertionParams::TextureMode m);
/** @brief The command line's word for an albedo method ("irradiance", "retinex"). */
CV_EXPORTS std::string toString(InsertionParams::AlbedoMethod m);
/** @brief The command line's word for a light estimation ("nnls", "hill-climb", "none"). */
CV_EXPORTS std::string toString(InsertionParams::LightsMethod m);
/** @brief The command line's word for an exposure mode ("auto", "off"). */
CV_EXPORTS std::string toString(InsertionParams::ExposureMode m);
/** @brief The command line's word for a grain mode ("auto", "off"). */
CV_EXPORTS std::string toString(InsertionParams::GrainMode m);

/** @brief The result of the preparation stages: everything a frame's render needs.

Made by prepareInsertion(); frames are then rendered in any order, by renderInsertionFrame(),
in this process or (through the work folder's `prepared_scene.yml`) in others. The render
scene is built on the first renderInsertionFrame() call and shared by copies of this object;
renderInsertionFrame() is not to be called concurrently on one PreparedInsertion. */
struct CV_EXPORTS PreparedInsertion {
    /** @brief The prepared scene: the room with albedo textures, the lights scaled by the
    white point and the light estimate, the objects placed. */
    Scene scene;
    CameraPath path;         //!< one camera per frame of the video
    LightEstimate lights;    //!< the light estimate (applied to @p scene's lights)
    double white_scale = 1;  //!< factor (≥ 1) applied to all lights before @p lights
    /** @brief Per frame, the linear gains (B, G, R) of the video against the room model (whose
    exposure is frame 0's), smoothed over time; renderInsertionFrame() multiplies the rendered
    layers by them. All 1 with InsertionParams::EXPOSURE_OFF. */
    std::vector<Vec3d> gains;
    int frames = 0;                  //!< frames of the input video
    std::vector<double> timestamps;  //!< presentation time of each input frame (seconds)
    std::string fingerprint;         //!< hash of everything the preparation depends on
    std::string work;                //!< the work folder holding textures, albedo and the record
    bool reused = false;             //!< the work folder's prepared scene was reused
    /** @brief Path tracer settings of every frame (spp, seed, adaptive sampling). */
    Renderer::Params render;
    /** @brief Compositing of every frame (the response is the scene camera's; the shadow
    mode InsertionParams::shadows). */
    CompositeParams composite;
    /** @brief InsertionParams::denoise: radius of the difference layer's denoising (0: off). */
    int denoise = 0;
    // --- grain and motion blur ---
    GrainModel grain;       //!< the footage's noise (measured unless InsertionParams::grain off)
    bool grain_on = false;  //!< whether @ref grain is added to the objects' pixels
    /** @brief Exposure as a fraction of the frame interval over which each frame is rendered
    (0: no motion blur); InsertionParams::shutter or its estimate. */
    double shutter = 0;
    // --- end of grain and motion blur ---
    /** @brief The camera of frame @p i (the path's pose, the scene's response and size). */
    Camera camera(int i) const;

    /** @brief Built on first use by renderInsertionFrame(). */
    Ptr<RenderScene> render_scene;
    /** @brief Built on first use by renderInsertionFrame(). */
    Ptr<DifferentialRenderer> renderer;
};

/** @brief Prepares an insertion: reads the inputs, finds the camera path (tracking it into
`<work>/tracking` when InsertionParams::cameras is empty), builds the room's radiance textures
from the video (unseen texels filled by fillUnseenTexels()), its albedo
(irradianceAlbedoWhitePoint() or retinexAlbedo()) and the light estimate (estimateLights()), and
records the prepared scene in the work folder (`textures/`, `albedo/`, `prepared_scene.yml`). A
prepared scene already in the work folder that was made from the same inputs and options is reused;
one made from others is an error unless InsertionParams::force (then it and its frames are removed).

The input video is decoded once here (counting, fingerprinting and keeping the texture frames),
twice when its container's frame count was wrong; camera tracking decodes it on its own.
@param p options (checked with InsertionParams::check()).
@param progress stage progress ("video", "tracking", "textures", "albedo", "lights").
@param report if not null, receives frames_total, work, the stages' seconds and the figures
`white_scale`, `prepared_reused`, `light<i>_scale_{r,g,b}`, the gains `gain_<i>_{b,g,r}` of
every frame i (PreparedInsertion::gains) and `exposure_texels_min` (the fewest room texels a
frame's gain was estimated from; below 30 that frame took its neighbours' fit; 0 when off).;
the grain model (`grain_on`, `grain_reliable`, `grain_sigma` (mean, code values), `grain_blur`
(px), `grain_correlation`, `grain_pixels`, and per intensity bin b `grain_<b>_level`,
`grain_<b>_sigma_{b,g,r}`) and the shutter (`shutter`, `shutter_estimated` (1 when estimated),
`shutter_frame` and `shutter_motion_px`: the frame it was estimated on and its image motion). */
CV_EXPORTS PreparedInsertion prepareInsertion(const InsertionParams& p,
                                              const PipelineProgress& progress = PipelineProgress(),
                                              PipelineReport* report = nullptr);

/** @brief Renders frame @p i of a prepared insertion and composites it onto the input frame
(DifferentialRenderer with shared samples and a fixed seed; the layers × the frame's gain
PreparedInsertion::gains[i]; compositeDifferential() with PreparedInsertion::composite,
encodeComposite()). With PreparedInsertion::shutter > 0 the layers are rendered over the
shutter interval (renderOverShutter(), the camera from cameraAtTime()); with
PreparedInsertion::grain_on the footage's noise is added to the objects' pixels after the
composite (addGrain(), weighted by the coverage, seeded by the frame index).
@param prepared the preparation (its render scene is built on the first call).
@param i frame index in [0, prepared.frames).
@param frame the input video's frame @p i (8- or 16-bit BGR, the scene's image size).
@param composite receives the composited frame, of @p frame's type.
@param layers if not null, receives the differential render's layers (at the frame's exposure:
multiplied by its gain).
@param composite_linear if not null, receives the linear CV_32FC3 composite. */
CV_EXPORTS void renderInsertionFrame(PreparedInsertion& prepared, int i, InputArray frame,
                                     OutputArray composite, DifferentialImages* layers = nullptr,
                                     Mat* composite_linear = nullptr);

/** @brief Inserts the scene's `objects:` into a hand-held video of a room (thesis chapter 5),
file to file: the driver of `vbme insert`.

Takes the work folder's lock, runs prepareInsertion(), then renders the frames of
[first, end) missing from `<work>/frames/frame_%05d.png` (renderInsertionFrame(); one lock per
frame, so several processes can split a video over a shared work folder; frames already there
are skipped, so an interrupted run resumes), and when every frame exists assembles the output
video with the input's timestamps, colour tags and audio (VideoSink). The input is decoded
once more for the frames rendered. Writes `<work>/report.yml` (PipelineReport) and returns the
report. See doc/vbme_pipeline_insert.md. Throws cv::Exception for bad input.
@param p options.
@param progress stage progress (prepareInsertion()'s stages, "render", "encode"; "waiting"
with 0, 0 when another process holds the work folder). */
CV_EXPORTS PipelineReport runInsertion(const InsertionParams& p,
                                       const PipelineProgress& progress = PipelineProgress());

//! @}

}  // namespace vbme
}  // namespace cv

#endif
