// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_INTEGRATOR_HPP
#define OPENCV_VBME_RENDER_INTEGRATOR_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"
#include "opencv2/vbme/core/progress.hpp"
#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "opencv2/vbme/render/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief Figures of one render. */
struct CV_EXPORTS RenderStats {
    double seconds = 0;  //!< wall-clock time of the render
    int64 paths = 0;     //!< camera paths traced (pixels × spp)
    int64 rays = 0;      //!< rays traced (closest-hit and shadow)
    /** @brief Pixels that stopped at the minimum of adaptive sampling because no path met an
    object (0 without adaptive sampling). */
    int64 pixels_untouched = 0;
};

/** @brief The path tracer: renders a RenderScene through a camera.

Integrators:
- **PATH** (default): unidirectional path tracing @cite Kajiya1986 with next-event estimation
  and multiple importance sampling (power heuristic) between light sampling and BSDF sampling
  @cite Veach1995, Russian roulette from depth `rr_depth` (survival max(βmax, 0.05)), at most
  `max_depth` bounces (`max_depth` = 1 is direct lighting: the camera ray's hit, one shadow
  ray and one BSDF ray whose emitter hit is weighted by MIS). One light per vertex is chosen
  uniformly among the scene's lights, or mostly by power (Params::light_selection).
- **REFERENCE**: BSDF sampling only, emission collected where paths hit it (no NEE, no MIS);
  cannot see point lights or zero-angle distant lights. Used by the tests as a cross-check.

Light inside dielectrics is attenuated by Beer–Lambert absorption over the distance travelled
inside (Bsdf::absorption() of the surface through which the path leaves).

Determinism: each pixel is the mean of its own samples, and every random number is
SobolSampler(seed).get(pixel, sample, dimension) with dimensions fixed per path vertex
(PathDims), so a render is bitwise identical for any number of threads, and a render without
the `objects:` (Params::with_objects = false) draws the same numbers for the same
(pixel, sample, dimension) as the render with them. Tiles are rendered in parallel with TBB.
*/
class CV_EXPORTS Renderer {
public:
    /** @brief Light transport algorithm. */
    enum Integrator {
        PATH = 0,      //!< path tracing with NEE and MIS
        REFERENCE = 1  //!< BSDF sampling only
    };
    /** @brief How next-event estimation picks the light of a vertex. */
    enum LightSelection {
        LIGHTS_UNIFORM = 0,  //!< every light equally likely (default)
        LIGHTS_POWER = 1     //!< 90 % by Emitter::power() (lights at infinity through a disk of
                             //!< the scene's radius), 10 % uniform so that none is starved
    };
    /** @brief Parses "uniform" or "power". */
    static int parseLightSelection(const std::string& name);
    /** @brief Render options. */
    struct CV_EXPORTS Params {
        Params();           //!< Defaults as below.
        int spp = 32;       //!< samples per pixel
        int max_depth = 8;  //!< maximum number of bounces (≥ 1)
        uint64 seed = 0;    //!< sampler seed
        int threads = 0;    //!< worker threads (0: those of the calling arena: all cores, or the
                            //!< limit of cv::vbme::runLimited())
        int integrator = PATH;           //!< Integrator
        bool with_objects = true;        //!< false: render without the `objects:` meshes
        FilterType filter = FILTER_BOX;  //!< pixel reconstruction filter
        float clamp = 0.f;               //!< firefly clamp on a sample's largest channel (0: off)
        int rr_depth = 3;                //!< first bounce at which Russian roulette may end a path
        int tile_size = 16;              //!< tile edge in pixels (parallel work unit)
        bool aovs = true;                //!< also produce albedo, normal and object images
        int light_selection = LIGHTS_UNIFORM;  //!< LightSelection
        /** @brief Adaptive sampling of differential renders (renderDifferential() only; 0:
        off, every pixel gets `spp`). When > 0, every pixel first takes this many samples
        (the minimum); a pixel none of whose paths met an object (its difference is exactly 0)
        stops there, unless a pixel within `adaptive_radius` had one that did, or with
        probability `adaptive_roulette`; the others take batches of
        this many more samples until the estimated error of the composite (see
        `adaptive_error`) is below the target or `spp` (then the maximum) is reached. The
        without-objects image is the mean of all samples taken; the difference is
        α·(mean of the minimum) + (1 − α)·w·(mean of the later samples), α = minimum / spp,
        w = 1 / `adaptive_roulette` for a pixel that went on by the roulette, else 1: the later
        samples are independent of the decision to take them, so the estimate is unbiased
        up to the error-driven stopping. The with-objects image is the without-objects one
        plus the difference. The schedule depends only on the pixel's own samples: bitwise
        identical for any number of threads. */
        int adaptive_min_spp = 0;
        /** @brief Target of adaptive sampling: the half-width of the 95 % confidence interval
        of a pixel's composite value, in display code values of 8 bits (0 … 255) through
        the camera's response. The composite's per-sample value is the render with the
        objects where the camera ray meets an object, and the difference (with − without)
        elsewhere; its standard error is mapped to display values at the render's level. */
        float adaptive_error = 0.5f;
        /** @brief Texture filtering after non-specular bounces (0: off, every lookup is
        bilinear in the full image). When > 0, each path carries a ray cone
        @cite Amanatides1984 that starts one pixel wide at the camera; at the first
        non-specular (diffuse or glossy) bounce its spread angle becomes at least this many
        radians, and diffuse textures hit after that are looked up with
        Texture::evalFiltered() over the cone's width there. Camera-ray hits are unchanged. */
        float texture_cone = 0.f;
        /** @brief Probability that a pixel whose minimum samples met no object still goes on
        (adaptive sampling; its later differences then weigh 1 / this). 0: such pixels always
        stop with a difference of exactly 0, which misses rare indirect effects of the
        objects (shadowed light that reaches the pixel over a bounce) and biases them. */
        float adaptive_roulette = 0.25f;
        /** @brief Adaptive sampling: a pixel whose minimum met no object still goes on (with
        weight 1) when a pixel within this many pixels (square window) had a path that met
        one, so that soft shadows and penumbrae, where only some paths meet the object, are
        not cut off. The decision uses the whole image's minimum samples (a first pass before
        the rest): still independent of the thread count. */
        int adaptive_radius = 2;
        /** @brief Trace each pixel's camera rays in packets of up to 8 (rtcIntersect8, coherent)
        ahead of their paths, instead of one at a time. The image is the same bit for bit
        (tested), so this speed switch is not part of read()/write(). */
        bool camera_packets = true;
        /** @brief Paths of one pixel advanced together, stage by stage (0 or 1: one path at a
        time). When > 1, up to this many samples of a pixel are traced as a batch: all live
        paths are intersected, then all are shaded (BSDF and light sample, shadow ray built),
        then all shadow rays are traced, then all are continued — independent work that the
        processor overlaps, where one path at a time is a chain of dependent operations. Each
        path does the same floating-point operations on the same random numbers as alone, so
        the image is the same bit for bit (tested). Applies to render() (PATH and REFERENCE);
        renderDifferential(), whose paths fork, traces one path at a time. Shadow rays go to
        Embree in packets, except when they must tell which object blocks them (AOVs of a
        scene with objects: closest-hit rays one at a time, as without batches). */
        int path_batch = 16;
        /** @brief In path batches (path_batch > 1), draw the lanes' random numbers and the
        Lambertian lanes' cosine-weighted directions with vector code, eight lanes at a time,
        where the processor has AVX2 (checked at run time; elsewhere, or when false, one lane at
        a time). The same operations in the same order: the image is the same bit for bit
        (tested), so this speed switch is not part of read()/write(). */
        bool batch_simd = true;

        /** @brief spp, max_depth and seed from a scene's render settings. */
        static Params fromScene(const RenderSettings& s);
        /** @brief Reads the fields present in @p fn; an unknown key or a value check()
        refuses is an error. */
        void read(const FileNode& fn);
        /** @brief Writes the fields. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range. */
        void check() const;
    };

    virtual ~Renderer();
    /** @brief A renderer with the given options. */
    static Ptr<Renderer> create(const Params& params = Params());
    /** @brief The options. */
    virtual const Params& getParams() const = 0;
    /** @brief Changes the options. */
    virtual void setParams(const Params& params) = 0;

    /** @brief Renders @p scene through @p camera at camera.image_size (scale it with
    Camera::scaled() to render at another size).
    @param scene the scene.
    @param camera the camera (K, cam_from_world, image size).
    @param out receives the colour image and, if Params::aovs, the AOVs.
    @param progress if not null, ticked once per finished pixel row of a tile.
    @return timing and counts. */
    virtual RenderStats render(const RenderScene& scene, const Camera& camera, RenderImages& out,
                               Progress* progress = nullptr) const = 0;

    /** @brief Renders the scene with and without its `objects:` in one pass (differential
    rendering @cite Debevec1998).

    Each path is traced in the scene with the objects. As long as it does not interact with one
    (no vertex on an object, no shadow ray blocked by one) its radiance is, sample for sample,
    the one the render without the objects would compute, and it is used for both. At the first
    vertex where it interacts, the path is resumed from that vertex's state without the objects
    with the same (pixel, sample, dimension) numbers. The two images are therefore those of two
    separate renders with Params::with_objects true and false and the same seed (up to the
    floating-point identity of Embree's hits in its two BVHs), bit for bit equal wherever no
    path met an object, at the cost of one render plus the interacting path suffixes.
    Params::with_objects is ignored.
    @param scene the scene.
    @param camera the camera.
    @param with_objects receives the render with the objects (colour and, if Params::aovs, the
    AOVs; `object` then marks the pixels where the two renders may differ).
    @param without_objects receives the colour of the render without the objects (no AOVs).
    @param progress if not null, ticked once per finished pixel row of a tile.
    @return timing and counts (rays of both passes). */
    virtual RenderStats renderDifferential(const RenderScene& scene, const Camera& camera,
                                           RenderImages& with_objects,
                                           RenderImages& without_objects,
                                           Progress* progress = nullptr) const = 0;

    /** @brief The radiance estimate of one path: sample @p index of pixel @p pixel along the
    ray (o, d) (for tests and tools that trace their own rays). */
    virtual Vec3f radiance(const RenderScene& scene, const Vec3f& o, const Vec3f& d,
                           const Point& pixel, uint32_t index) const = 0;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
