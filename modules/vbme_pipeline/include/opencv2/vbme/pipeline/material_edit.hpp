// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_PIPELINE_MATERIAL_EDIT_HPP
#define OPENCV_VBME_PIPELINE_MATERIAL_EDIT_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/core/video.hpp"
#include "opencv2/vbme/inpaint/consensus.hpp"
#include "opencv2/vbme/pipeline/report.hpp"

namespace cv {
namespace vbme {

class EnvironmentMap;

//! @addtogroup vbme_pipeline
//! @{

/** @brief Where the key light of the re-rendered object comes from. */
enum MaterialEditLight {
    /** Fitted per frame to the original object's shading (fitLighting()). */
    MATERIAL_EDIT_LIGHT_AUTO = 0,
    /** Along MaterialEditParams::to_light; only its strength and the ambient are fitted. */
    MATERIAL_EDIT_LIGHT_FIXED = 1
};

/** @brief How the object's hole is filled from the neighbouring frames (ConsensusInpainter). */
enum MaterialEditInpaint {
    /** Static camera: the frames vote without alignment (CONSENSUS_ALIGN_NONE). */
    MATERIAL_EDIT_INPAINT_BACKGROUND = 0,
    /** Moving camera: frames aligned by homography and dense flow (CONSENSUS_ALIGN_FLOW). */
    MATERIAL_EDIT_INPAINT_VIDEO = 1
};

/** @brief Settings of the material edit: the per-frame editing (MaterialEditor) and the
file-to-file driver (runMaterialEdit(), `vbme material-edit`).

The fields under "files" are used by runMaterialEdit() only; MaterialEditor reads the others.
read() and write() use the field names as keys and the command line's words for the enums
(light "auto" / "fixed", inpaint "background" / "video", shadows "keep" / "remove",
response "srgb" / "gamma2.2" / "linear"); the material is a map as in a scene file. */
struct CV_EXPORTS MaterialEditParams {
    // ---- files (runMaterialEdit only)
    std::string video;          //!< input video (file, folder or pattern)
    std::string first_mask;     //!< 8-bit mask of the object in frame 0 (255 = object)
    std::string out;            //!< edited video
    std::string env;            //!< optional user HDR environment (equirectangular)
    std::string intermediates;  //!< optional folder: masks, inpainted background, environments
    int env_every = 10;         //!< intermediates: write every N-th environment map
    bool force = false;         //!< overwrite existing outputs
    /** Worker threads of this run (0: all cores), through runLimited(): limits the TBB work
    of the run, not cv::parallel_for_ loops, and never changes the process-wide setting (the
    command line, which owns its process, also sets cv::setNumThreads()). */
    int threads = 0;
    /** Encoding of the output video (codec, quality, pixel format). The input's timestamps,
    colour tags and audio are carried to it (sinkOptionsFrom()). HDR input (PQ, HLG) is
    converted to sRGB-encoded BT.709 (VideoReader), which only Response::SRGB describes: with
    another response it is refused. */
    VideoSinkOptions encode;

    // ---- the edit (MaterialEditor)
    Material material;                                   //!< the new material
    MaterialEditLight light = MATERIAL_EDIT_LIGHT_AUTO;  //!< where the key light comes from
    Vec3d to_light = Vec3d(0, 0, -1);                    //!< MATERIAL_EDIT_LIGHT_FIXED: direction
                                                         //!< towards the light (camera coordinates:
                                                         //!< x right, y down, z forward), non-zero
    double focal = 0;  //!< focal length in pixels (0: 60° horizontal field of view)
    /** Consecutive frames the tracker may lose the object (hidden, or not recognised); those
    frames pass through unedited (MaterialEditor::FrameResult::lost). More consecutive lost
    frames stop the edit with an error naming the frame (default 0: any lost frame is an
    error). */
    int max_lost = 0;
    MaterialEditInpaint inpaint = MATERIAL_EDIT_INPAINT_BACKGROUND;  //!< how the hole is filled
    /** Frames on each side that vote for the background fill (at least 1 is used); also the
    editor's delay: a frame comes out once max(1, lookahead) later frames went in (or at
    finish()). */
    int lookahead = 8;
    /** The original object's cast shadow: SHADOWS_KEEP (the new object is rendered without a
    shadow of its own, so the original one stays) or SHADOWS_REMOVE (detected near the object
    and removed, ConsensusInpainter::Params::shadows; the new object then casts a shadow fitting
    its material, estimated from the original one: the same attenuation for opaque materials
    and chrome, a lighter shadow with a caustic core away from the key light for glass; see
    doc/vbme_pipeline_material_edit.md). */
    ShadowMode shadows = SHADOWS_KEEP;
    Size env_size = Size(256, 128);      //!< size of the per-frame environment maps
    Response response = Response::SRGB;  //!< camera response of the video
    int samples = 4;                     //!< BSDF / light samples per pixel for rough lobes
    double light_half_angle_deg = 3;     //!< angular radius of the key light (highlights)
    double background_depth = 5;         //!< background plane behind the ball (ball radii), glass
    double hole_margin = 3;              //!< pixels added to the disk's radius for the hole
    /** Refine the tracked disk to sub-pixel accuracy against the inpainted background
    (refineDisk(); changes ≤ 1.5 px). */
    bool refine_disk = true;

    /** @brief Throws cv::Exception naming the first invalid field and its valid range
    (file names are checked by runMaterialEdit(), which opens them). */
    void check() const;
    /** @brief Reads the fields present in @p node (a map); absent ones keep their values.
    A key that is not a field is an error naming it and listing the valid keys. */
    void read(const FileNode& node);
    /** @brief Writes every field (at the current level of @p fs, as a map's entries). */
    void write(FileStorage& fs) const;
};

/** @brief The material edit of one video as an object fed frames in order and giving the
edited frames back (thesis chapter 4, @cite Khan2006).

Per frame: the object marked in frame 0 is tracked (ObjectTracker; a frame where it is lost,
up to MaterialEditParams::max_lost in a row, passes through unedited: nothing removed, nothing
drawn), its shape recovered (sphere normals over
the disk), removed (ConsensusInpainter over ±lookahead frames), its disk refined against the
filled background (refineDisk()), the lighting fitted to its own shading (fitLighting()), the
environment built from the filled frame (imageDiskToEnvironment()) unless one is given, and the
object re-rendered in the new material and composited with anti-aliased edges.

A frame comes out of pop() once max(1, `lookahead`) later frames were pushed, or after
finish(); memory holds `2·max(1, lookahead) + 2` frames whatever the video's length. Nothing is
printed and the process-wide thread count is not changed; stage times go to report().
@code
    Ptr<MaterialEditor> ed = MaterialEditor::create(params, first_mask);
    Mat frame, out;
    while (reader.read(frame)) {
        ed->push(frame);
        while (ed->pop(out)) sink.write(out);
    }
    ed->finish();
    while (ed->pop(out)) sink.write(out);
@endcode
*/
class CV_EXPORTS MaterialEditor {
public:
    /** @brief What the editor measured on one frame. */
    struct CV_EXPORTS FrameResult {
        int index = 0;      //!< frame index (0 = first pushed frame)
        bool lost = false;  //!< the tracker lost the object: the frame passed through unedited
        Vec3f disk;      //!< disk used for the edit (cx, cy, r) in pixels, after refinement (when
                         //!< lost: the last disk found, not used)
        Vec3d to_light;  //!< key light direction used (camera coordinates, unit)
        double fit_rms = 0;  //!< RMS residual of the lighting fit (linear)
        Vec3d albedo;        //!< estimated albedo of the original object (RGB)
        /** With shadows "remove": the original shadow's deficit-weighted centroid minus the
        disk's centre (pixels; it points away from the key light in the image), zero when no
        shadow was found or with shadows "keep". */
        Vec2f shadow_offset;
    };

    /** @brief Starts an edit.
    @param params the edit's settings (checked with MaterialEditParams::check(); the "files"
    fields are ignored).
    @param first_mask CV_8U mask of the object in frame 0 (non-zero = object), of the frames'
    size; it must mark some but not all pixels.
    @param environment a user environment lighting every frame; empty: built per frame from
    the filled background. Kept by reference count. */
    static Ptr<MaterialEditor> create(
        const MaterialEditParams& params, InputArray first_mask,
        const Ptr<EnvironmentMap>& environment = Ptr<EnvironmentMap>());
    /** @brief Destructor (frames still queued are dropped). */
    virtual ~MaterialEditor();

    /** @brief Adds the next frame (8-bit BGR, the first mask's size). Throws cv::Exception
    when the object has been lost for more than max_lost frames in a row (naming the frame). */
    virtual void push(InputArray frame) = 0;
    /** @brief Declares that no more frames come; the remaining ones can then be popped. */
    virtual void finish() = 0;
    /** @brief Takes the next edited frame, in input order; false if none is ready.
    @param edited the edited frame (8-bit BGR).
    @param background optional: the frame with the object removed (8-bit BGR).
    @param hole optional: the removed region (CV_8U, 255 = hole).
    @param environment optional: the frame's equirectangular environment map (linear CV_32FC3,
    MaterialEditParams::env_size), empty when a user environment is used. */
    virtual bool pop(OutputArray edited, OutputArray background = noArray(),
                     OutputArray hole = noArray(), OutputArray environment = noArray()) = 0;

    /** @brief Per-frame results of the frames popped so far, in order. */
    virtual const std::vector<FrameResult>& results() const = 0;
    /** @brief Frame counts, seconds per stage (tracking, shape, inpainting, environment,
    lighting, shadow (the new object's shadow, with shadows "remove"), rendering, compositing) and the figures "pixels_temporal" (hole pixels filled
    from other frames) and "pixels_exemplar" (by exemplars, never seen); total_seconds is
    the sum of the stages (the editor's own time). */
    virtual const PipelineReport& report() const = 0;
};

/** @brief The material edit from file to file (`vbme material-edit`): reads @p p.video,
edits it with MaterialEditor and writes @p p.out (and the intermediates when asked).

Frames are streamed (decoding and encoding overlap the editing). All inputs are checked before
any output is written; outputs go to temporary names renamed when the whole video is done, so a
failure leaves nothing half-written. The run is wrapped in runLimited(@p p.threads), which does
not change the process-wide thread setting. Throws cv::Exception on bad input (empty first mask,
object lost mid-video, unreadable files, existing outputs without force).
@param p the settings.
@param progress called with ("material-edit", frames done, frames total) after each frame.
@param results optional: receives MaterialEditor::results() (per frame: disk, light, albedo).
@return the report (pipeline "material-edit"): seconds per stage (decode, tracking, shape,
inpainting, environment, lighting, shadow, rendering, compositing, encode), the figure
"shadows_removed" (1 with SHADOWS_REMOVE, else 0) and the figures of MaterialEditor::report(). See doc/vbme_pipeline_material_edit.md. */
CV_EXPORTS PipelineReport
runMaterialEdit(const MaterialEditParams& p, const PipelineProgress& progress = PipelineProgress(),
                std::vector<MaterialEditor::FrameResult>* results = nullptr);

/** @brief The cast-shadow handling that fits a new material (`vbme material-edit --shadows auto`,
the command's default): SHADOWS_REMOVE for a material that transmits light (Material::DIELECTRIC:
glass, ice), whose shadow must be lighter than the original ball's and carry a caustic core;
SHADOWS_KEEP for every other material, whose shadow is the original ball's own (an opaque or
chrome ball of the same size blocks the same light), kept exactly instead of removed and
re-estimated. */
CV_EXPORTS ShadowMode shadowModeFor(const Material& material);

/** @brief "auto" or "fixed" (MaterialEditLight). */
CV_EXPORTS std::string toString(MaterialEditLight m);
/** @brief "background" or "video" (MaterialEditInpaint). */
CV_EXPORTS std::string toString(MaterialEditInpaint m);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
