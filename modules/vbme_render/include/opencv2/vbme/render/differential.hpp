// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_DIFFERENTIAL_HPP
#define OPENCV_VBME_RENDER_DIFFERENTIAL_HPP

#include <map>
#include <string>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"
#include "opencv2/vbme/core/progress.hpp"
#include "opencv2/vbme/core/response.hpp"
#include "opencv2/vbme/render/integrator.hpp"
#include "opencv2/vbme/render/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief The layers of a differential render (all CV_32F, the render's size, linear BGR). */
struct CV_EXPORTS DifferentialImages {
    Mat obj;      //!< CV_32FC3, I_obj: the scene with its `objects:`
    Mat noobj;    //!< CV_32FC3, I_noObj: the same scene without them (room, lights, proxies)
    Mat diff;     //!< CV_32FC3, I_obj − I_noObj (exactly 0 where no path met an object)
    Mat mask;     //!< CV_32FC1, the objects' coverage M in [0, 1]
    Mat object;   //!< CV_32FC1, fraction of the pixel's paths that interacted with an object
    Mat samples;  //!< CV_32FC1, samples per pixel of adaptive sampling (empty when off)
};

/** @brief How the coverage mask M of the objects is made. */
enum CoverageMethod {
    COVERAGE_PROJECTED = 0,    //!< the objects' triangles projected into the image and
                               //!< supersampled (8×8 per pixel by default), as in the thesis;
                               //!< sub-samples hidden by the room or proxies dropped
    COVERAGE_PRIMARY_RAYS = 1  //!< fraction of the renderer's camera rays whose first hit is an
                               //!< object (RenderImages::mask; quantised to 1/spp, occlusion-aware)
};

/** @brief Parses "projected" or "rays". */
CV_EXPORTS CoverageMethod parseCoverage(const std::string& name);

/** @brief Renders a scene with and without its `objects:` for additive differential rendering
@cite Debevec1998 @cite Karsch2011, with both renders drawing the same random numbers so that
their noise cancels in the difference.

- **ONE_PASS** (default): Renderer::renderDifferential — every path is traced once with the
  objects and resumed without them only from the vertex where it first interacts with one.
- **TWO_PASS**: two full renders (Params::with_objects true, then false). With the same seed
  the result equals ONE_PASS up to floating-point identity; with Params::independent the second
  render gets an unrelated seed (independent noise, for comparison).
*/
class CV_EXPORTS DifferentialRenderer {
public:
    /** @brief How the two renders are made. */
    enum Method {
        ONE_PASS = 0,  //!< one path tracing pass, resumed without the objects where needed
        TWO_PASS = 1   //!< two full renders
    };
    /** @brief Options. */
    struct CV_EXPORTS Params {
        Params();                           //!< Defaults as below.
        Renderer::Params render;            //!< the path tracer's options (with_objects ignored)
        int method = ONE_PASS;              //!< Method
        bool independent = false;           //!< unrelated samples in the two renders (implies
                                            //!< TWO_PASS); for comparison only
        int coverage = COVERAGE_PROJECTED;  //!< CoverageMethod
        int coverage_supersampling = 8;     //!< COVERAGE_PROJECTED: n×n samples a pixel (1…8)
        bool coverage_occlusion = true;     //!< COVERAGE_PROJECTED: drop hidden sub-samples
        /** @brief Reads the fields present in @p fn (`render` is a nested map); an unknown
        key or a value check() refuses is an error. */
        void read(const FileNode& fn);
        /** @brief Writes the fields. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range. */
        void check() const;
    };

    virtual ~DifferentialRenderer();
    /** @brief A differential renderer with the given options. */
    static Ptr<DifferentialRenderer> create(const Params& params = Params());
    /** @brief The options. */
    virtual const Params& getParams() const = 0;
    /** @brief Changes the options. */
    virtual void setParams(const Params& params) = 0;
    /** @brief Renders all layers of @p out through @p camera (at camera.image_size).
    @return timing and counts of the rendering (both passes). */
    virtual RenderStats render(const RenderScene& scene, const Camera& camera,
                               DifferentialImages& out, Progress* progress = nullptr) const = 0;
};

/** @brief Anti-aliased coverage of the scene's `objects:` by projecting their triangles.

Each pixel [x−½, x+½)×[y−½, y+½) is sampled at n×n regularly spaced points; a sub-sample counts
if it falls in any object triangle (clipped at the camera's near plane, either winding) and,
with @p occlusion, if its camera ray meets an object before the room, a proxy or a light (so
that an object behind a proxy or wall is not composited over it).
@param scene the render scene (its OBJECT geometry).
@param camera the camera (K, cam_from_world, image size).
@param mask receives a CV_32FC1 image in [0, 1] (multiples of 1/n²).
@param supersampling n, 1 … 8.
@param occlusion drop sub-samples hidden by other geometry (one ray per covered sub-sample). */
CV_EXPORTS void projectObjectCoverage(const RenderScene& scene, const Camera& camera,
                                      OutputArray mask, int supersampling = 8,
                                      bool occlusion = true);

/** @brief How the sampler seed varies across the frames of a video. Within a frame the two
renders of differential rendering always share their samples. */
enum FrameSeeding {
    SEEDS_FIXED = 0,  //!< every frame uses the same seed: the same sample pattern per pixel
                      //!< (the thesis's choice; the default, see doc/vbme_render_differential.md)
    SEEDS_PER_FRAME = 1  //!< each frame's seed is hashed from (seed, frame index)
};

/** @brief Parses "fixed" or "per-frame". */
CV_EXPORTS FrameSeeding parseFrameSeeding(const std::string& name);

/** @brief The sampler seed of frame @p frame (≥ 0) for a base @p seed: @p seed itself for
SEEDS_FIXED, a hash of both for SEEDS_PER_FRAME. */
CV_EXPORTS uint64 frameSeed(uint64 seed, int frame, FrameSeeding mode);

/** @brief Options of the differential compositor. */
struct CV_EXPORTS CompositeParams {
    /** @brief How the light the objects take away (a negative difference: shadows) is put on
    the footage. */
    enum Shadows {
        /** `input + α·diff` everywhere (Eq. 5.2, @cite Debevec1998): exact where the model's
        radiance I_noObj equals the footage's; where the model is brighter than the footage
        (noise at low spp, texture or albedo error), a deep shadow goes below zero and is
        clamped black, channel by channel. */
        SHADOWS_ADDITIVE = 0,
        /** where diff < 0, the footage loses the fraction of its light that the model loses:
        `input · (1 + α·max(−1, diff / I_noObj))` (per channel; the same as additive where
        I_noObj equals the footage, never negative, and it follows the footage's exposure);
        where diff ≥ 0 (light the objects add) additive. Needs the `noobj` layer. */
        SHADOWS_RATIO = 1
    };
    float alpha = 1.f;                   //!< scale α of the difference term (Karsch et al.)
    Response response = Response::SRGB;  //!< camera response of the background frame
    Shadows shadows = SHADOWS_ADDITIVE;  //!< additive or ratio shadows
    /** @brief Reads the fields present in @p fn; an unknown key or a value check() refuses is
    an error. */
    void read(const FileNode& fn);
    /** @brief Writes the fields. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief The command line's word for a shadow mode ("additive", "ratio"). */
CV_EXPORTS std::string toString(CompositeParams::Shadows s);
/** @brief Parses "additive" or "ratio" (throws cv::Exception naming @p field otherwise). */
CV_EXPORTS CompositeParams::Shadows parseShadows(const std::string& name,
                                                 const std::string& field = "shadows");

/** @brief Additive differential compositing (Eq. 5.2 of the thesis, @cite Debevec1998) in
linear space:

`result = M·I_obj + (1 − M)·max(0, I_input + α·(I_obj − I_noObj))`

where I_input is @p background linearised with CompositeParams::response. The clamp is per
channel and applies to the background term only: where the difference would darken the
footage below zero (a shadow deeper than the modelled light explains), the pixel becomes black
rather than negative.
@param background the input frame, display-encoded BGR: CV_8UC3, CV_16UC3 or CV_32FC3
(encoded values in [0, 1]).
@param obj I_obj, CV_32FC3 linear BGR, the size of @p background.
@param diff I_obj − I_noObj, CV_32FC3.
@param mask M, CV_32FC1 in [0, 1].
@param linear receives the composite, CV_32FC3 linear BGR.
@param params α and the response; CompositeParams::SHADOWS_RATIO needs the `noobj` layer, so
it is refused here (use the DifferentialImages overload). */
CV_EXPORTS void compositeDifferential(InputArray background, InputArray obj, InputArray diff,
                                      InputArray mask, OutputArray linear,
                                      const CompositeParams& params = CompositeParams());

/** @brief Differential compositing of a differential render's layers (`obj`, `noobj`, `diff`,
`mask`) in linear space, additive or with ratio shadows (CompositeParams::shadows):

`result = M·I_obj + (1 − M)·back`, with `back = max(0, I_input + α·diff)` where the difference is
positive or shadows are additive, and `back = I_input · max(0, 1 + α·max(−1, diff / I_noObj))`
(per channel; I_noObj ≤ 0 counts as a full loss) for ratio shadows where it is negative.

Ratio shadows are what `vbme insert` uses: on the Blender insertion clip they took the region
PSNR from 31.2 to 32.8 dB and removed the black, coloured speckle that additive compositing
leaves where the ground meets the object (see doc/vbme_render_differential.md).
@param background the input frame, display-encoded BGR (CV_8UC3, CV_16UC3 or CV_32FC3).
@param layers the render's layers (CV_32FC3 `obj`, `diff` and, for ratio shadows, `noobj`;
CV_32FC1 `mask`), of @p background's size.
@param linear receives the composite, CV_32FC3 linear BGR.
@param params α, the response and the shadow mode. */
CV_EXPORTS void compositeDifferential(InputArray background, const DifferentialImages& layers,
                                      OutputArray linear,
                                      const CompositeParams& params = CompositeParams());

/** @brief The composite in the footage's display values, for error measures in 8-bit display
units (adaptive sampling's target, benchmarks and truths against references):
compositeDifferential() of @p layers over @p background, encoded with `params.response`,
clamped to [0, 1] and scaled by 255, unquantised.
@param background as for compositeDifferential().
@param layers as for compositeDifferential().
@param display receives CV_32FC3 values in [0, 255].
@param params α, the response and the shadow mode. */
CV_EXPORTS void compositeDifferentialDisplay(InputArray background,
                                             const DifferentialImages& layers,
                                             OutputArray display,
                                             const CompositeParams& params = CompositeParams());

/** @brief Denoises the difference layer `layers.diff` with a joint bilateral filter
@cite Petschnigg2004 guided by the input frame, outside the objects' coverage.

Each pixel with coverage `layers.mask` = 0 becomes the weighted mean of the differences of its
(2r+1)² neighbours that are also outside the coverage, with weights
exp(−d²/(2σs²) − ‖g − g₀‖²/(2σr²)), σs = r/2 pixels, σr = 0.1 of the display range, g the
guide's display values (so that a shadow does not bleed across an edge of the footage). A pixel
whose window holds no non-zero difference keeps exactly 0, so the footage outside the objects'
reach stays bit-exact. Covered pixels are left alone. Deterministic (no randomness; any thread
count gives the same result).
@param layers the render's layers; `diff` is filtered in place (`mask` is read).
@param guide the input frame (CV_8UC3, CV_16UC3 or CV_32FC3 in [0, 1]), the layers' size.
@param radius r in pixels (≥ 1). */
CV_EXPORTS void denoiseDifference(DifferentialImages& layers, InputArray guide, int radius);

/** @brief Warps the layers of a differential render made with the pinhole camera @p source to
where the lens of @p cam (Camera::k1) shows them, in place (distortImageK1(): bilinear, the
sample counts nearest; 0 where the source holds nothing). With @p source =
lensCoverCamera(cam) the layers fill @p cam's whole frame. Nothing changes when cam.k1 = 0 and
@p source is @p cam. `vbme insert` and `vbme render --differential` composite so. */
CV_EXPORTS void distortLayersK1(DifferentialImages& layers, const Camera& cam,
                                const Camera& source);

/** @brief Encodes a linear composite with the response, to the depth of the input frame
(CV_8U or CV_16U; CV_32F input gives CV_16U). Where the composite equals the linearised input,
the result equals the input bit for bit (8-bit input). */
CV_EXPORTS void encodeComposite(InputArray linear, OutputArray encoded, Response response,
                                int ddepth = CV_8U);

/** @brief Writes a differential render as one multi-layer OpenEXR (32-bit float, atomic):
`R,G,B` = @p composite (linear; the `obj` layer when empty), `obj.R/G/B`, `noobj.R/G/B`,
`diff.R/G/B`, `mask`, and `object` when present. */
CV_EXPORTS void writeDifferentialExr(
    const std::string& path, const DifferentialImages& images, InputArray composite = noArray(),
    const std::map<std::string, std::string>& attributes = std::map<std::string, std::string>());

/** @brief Reads the layers of an EXR written by writeDifferentialExr(). Throws cv::Exception
naming the missing channels if `obj.*`, `diff.*` or `mask` are absent (`noobj` is then
obj − diff when absent). @p composite (if given) receives R,G,B when present, else is
released. */
CV_EXPORTS DifferentialImages
readDifferentialExr(const std::string& path, OutputArray composite = noArray(),
                    std::map<std::string, std::string>* attributes = nullptr);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
