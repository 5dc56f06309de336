// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_PIPELINE_MATERIAL_EDIT_HPP
#define OPENCV_VBME_PIPELINE_MATERIAL_EDIT_HPP

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/core/video.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_pipeline
//! @{

/** @brief Material from a preset name (chrome, gold, glass, blue, ... as Material::preset) or
a material file (YAML/JSON with a top-level material: map); clear error naming the valid
presets. */
CV_EXPORTS Material parseMaterialSpec(const std::string& spec);

/** @brief Parses a light specification: "auto" (fitted to the original object's shading) or
"fixed:x,y,z" (direction towards the light in camera coordinates; its strength is still
fitted). Throws cv::Exception saying what is expected otherwise.
@param spec the text. @param fixed set to true for "fixed:…".
@param to_light receives the unit direction for "fixed:…". */
CV_EXPORTS void parseLightSpec(const std::string& spec, bool& fixed, Vec3d& to_light);

/** @brief Settings of runMaterialEdit() (`vbme material-edit`). */
struct CV_EXPORTS MaterialEditParams {
    std::string video;           //!< input video (file, folder or pattern)
    std::string first_mask;      //!< 8-bit mask of the object in frame 0 (255 = object)
    std::string out;             //!< edited video
    Material material;           //!< the new material
    std::string light = "auto";  //!< "auto" (fit to the original object's shading) or "fixed:x,y,z"
                                 //!< (camera coordinates)
    double focal = 0;            //!< focal length in pixels (0: 60° horizontal field of view)
    std::string env;  //!< optional user HDR environment (equirectangular); empty: from the frames
    std::string
        intermediates;  //!< optional folder: masks, inpainted background video, environment maps
    bool force = false;
    int threads = 0;  //!< 0: all cores

    // Additions beyond the agreed interface (defaults suit 640×480 footage).
    /** Consecutive frames the tracker may lose the object; the last disk is kept meanwhile.
    More consecutive lost frames stop the run with an error naming the frame (default 0:
    any lost frame is an error, since a kept disk would leave the real object visible). */
    int max_lost = 0;
    /** Background filling, both by ConsensusInpainter (a robust vote of the frames within
    ±`lookahead` that see each hole pixel, leaving out those in the object's shadow; the rest
    by exemplars): "background" (static camera, no alignment) or "video" (frames aligned by
    homography and dense flow, for moving cameras; slower). */
    std::string inpaint = "background";
    int lookahead = 8;  //!< frames on each side that vote for the background fill
    /** The original object's cast shadow: "keep" (default: the new object is rendered
    without a shadow of its own, so the original one stays) or "remove" (detected near the
    object and re-lit, ConsensusInpainter::Params::shadows). */
    std::string shadows = "keep";
    int env_every = 10;               //!< intermediates: write every N-th environment map
    Size env_size = Size(256, 128);   //!< size of the per-frame environment maps
    std::string response = "srgb";    //!< camera response of the video (srgb, gamma2.2, linear)
    int samples = 4;                  //!< BSDF / light samples per pixel for rough lobes
    double light_half_angle_deg = 3;  //!< angular radius of the key light (highlights)
    double background_depth = 5;      //!< background plane behind the ball (ball radii), glass
    double hole_margin = 3;           //!< pixels added to the disk's radius for the hole
    /** Refine the tracked disk to sub-pixel accuracy against the inpainted background (the
    edge where the coverage falls through ½ along 64 rays, circle fit; changes ≤ 1.5 px). */
    bool refine_disk = true;
    /** Encoding of the output video (codec, quality, pixel format). The input's timestamps,
    colour tags and audio are carried to it (cv::vbme::sinkOptionsFrom). HDR input (PQ, HLG) is
    converted to sRGB-encoded BT.709 (cv::vbme::VideoReader), which only `response` "srgb"
    describes: with another response it is refused. */
    VideoSinkOptions encode;
};

/** @brief What runMaterialEdit() did, with the time spent per stage. */
struct CV_EXPORTS MaterialEditReport {
    int frames = 0;
    int frames_lost = 0;
    std::vector<std::pair<std::string, double>>
        seconds;  //!< per stage in pipeline order: decode, tracking, shape, inpainting,
                  //!< environment, lighting, rendering, compositing, encode
    double total_seconds = 0;
    void print(FILE* f) const;  //!< the timing table (seconds and frames/s per stage)

    // Additions beyond the agreed interface.
    std::vector<Vec3f> disks;     //!< per frame: tracked disk (cx, cy, r), pixels
    std::vector<Vec3d> to_light;  //!< per frame: key light direction used (camera coords)
    std::vector<double> fit_rms;  //!< per frame: RMS residual of the lighting fit (linear)
    std::vector<Vec3d> albedo;    //!< per frame: estimated albedo of the original (RGB)
    int pixels_exemplar = 0;      //!< hole pixels filled by exemplars (never seen)
    int pixels_temporal = 0;      //!< hole pixels filled from other frames
};

/** @brief The material-editing pipeline (thesis chapter 4, @cite Khan2006): the object
marked in frame 0 is tracked (ObjectTracker), its shape recovered (sphere normals), removed
(background fill), and re-rendered in @p p.material under lighting fitted to its own shading
(fitLighting()) and the environment built from the inpainted frame
(imageDiskToEnvironment()) or a user HDR, then composited with anti-aliased edges.

Frames are streamed: memory holds `2·lookahead + 2` frames whatever the video's length. All
inputs are checked before any output is written; outputs go to temporary names renamed when
the whole video is done, so a failure leaves nothing half-written. Throws cv::Exception on bad
input (empty first mask, object lost mid-video, unreadable files, existing outputs without
force). See doc/vbme_pipeline_material_edit.md. */
CV_EXPORTS MaterialEditReport runMaterialEdit(const MaterialEditParams& p);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
