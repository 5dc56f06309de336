// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_INPAINT_EXEMPLAR_HPP
#define OPENCV_VBME_INPAINT_EXEMPLAR_HPP

#include <string>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_inpaint
//! @{

/** @brief How the best source patch for a target patch is searched. */
enum PatchSearchMethod {
    /** Global randomised search in the spirit of PatchMatch @cite Barnes2009: candidates
    propagated from the sources of already-filled neighbours, uniform random samples over the
    whole image, and a random search around the best with shrinking radius. The default. */
    PATCH_SEARCH_PATCHMATCH = 0,
    /** Global search with a vantage-point tree @cite Yianilos1993 as in the thesis: the
    query's unknown pixels are auto-completed from a smooth pre-fill, its nearest source
    patches are taken from the tree, and re-ranked against the true masked distance. The
    slowest. */
    PATCH_SEARCH_VPTREE = 1,
    /** Exhaustive search in a square window around the target patch, as in
    @cite Criminisi2004. */
    PATCH_SEARCH_LOCAL = 2
};

/** @brief Colour space in which patch distances are measured. */
enum PatchColorSpace {
    PATCH_COLOR_RGB = 0,  //!< the image's own 8-bit BGR values
    PATCH_COLOR_LAB = 1   //!< 8-bit CIE L*a*b* (cv::COLOR_BGR2Lab), closer to perception
};

/** @brief Parses "patchmatch", "vptree" or "local" (case-insensitive). Throws cv::Exception
listing the accepted names otherwise. */
CV_EXPORTS PatchSearchMethod parsePatchSearchMethod(const std::string& name);
/** @brief The name of a search method: "patchmatch", "vptree" or "local". */
CV_EXPORTS std::string toString(PatchSearchMethod m);

/** @brief Exemplar-based image inpainting in the fill order of Criminisi et al.
@cite Criminisi2004.

The hole is filled patch by patch. Every pixel p on the fill front (hole pixels next to known
ones) has the priority P(p) = C(p)·D(p): the confidence C(p) is the mean confidence of the
known pixels of the patch centred at p (known pixels start at 1, hole pixels at 0; the pixels
filled from a patch take its C); the data term D(p) = |∇I⊥(p)·n(p)| / 255 measures how
strongly an isophote flows into the hole. ∇I⊥ is the dominant (largest) image gradient among
the known pixels of the patch rotated by 90°, and n(p) the unit fill-front normal, the mean
direction from p to the unfilled pixels around it. The patch with the highest priority is
filled by copying, into its hole pixels, the source patch that is entirely known (in the
original image) and has the least sum of squared differences over the target's known pixels,
in RGB or CIE Lab; exact ties go to the source whose pixels over the target's unknown part are
closest to a smooth pre-fill of the hole. To avoid an all-zero order in flat regions,
P = C·(D + 0.001).

Example:
@code
    using namespace cv::vbme;
    ExemplarInpainter::Params p;
    p.patch_size = 9;
    p.method = PATCH_SEARCH_PATCHMATCH;
    Ptr<ExemplarInpainter> inp = ExemplarInpainter::create(p);
    cv::Mat filled;
    inp->inpaint(image, hole, filled);   // hole: CV_8UC1, non-zero = fill
@endcode
*/
class CV_EXPORTS ExemplarInpainter {
public:
    /** @brief Settings of the exemplar fill. */
    struct CV_EXPORTS Params {
        /** @brief The defaults listed with each field. */
        Params();
        /** Side of the square patch in pixels (odd, ≥ 3). Larger patches keep larger
        structures; 9 suits 640×480 footage. */
        int patch_size = 9;
        /** The search (a PatchSearchMethod). */
        int method = PATCH_SEARCH_PATCHMATCH;
        /** Colour space of the patch distance (a PatchColorSpace). */
        int color_space = PATCH_COLOR_LAB;
        /** PATCH_SEARCH_LOCAL: half side of the search window around the target patch
        centre, in pixels (doubled for a target whose window holds no whole source patch). */
        int local_radius = 40;
        /** PATCH_SEARCH_PATCHMATCH: uniform random candidates per query. */
        int pm_random_samples = 64;
        /** PATCH_SEARCH_PATCHMATCH: rounds of random search with halving radius around the
        best candidate. */
        int pm_search_rounds = 4;
        /** PATCH_SEARCH_PATCHMATCH: PatchMatch iterations over the known pixels around the
        hole before the fill; their nearest-neighbour field gives every query coherent
        candidates (0 = off). */
        int pm_band_iterations = 4;
        /** PATCH_SEARCH_VPTREE: number of nearest neighbours taken from the tree and re-ranked
        by the true masked distance (the thesis used 100). */
        int vp_candidates = 100;
        /** PATCH_SEARCH_VPTREE: dimensions the patches are projected to by PCA before they
        go into the tree (0 = no projection, the full patch vector). Projection makes the tree
        search much faster; the re-ranking still uses full patches. */
        int vp_dims = 64;
        /** PATCH_SEARCH_VPTREE: source patches are taken at every @p vp_stride -th pixel in x
        and y (1 = all). */
        int vp_stride = 1;
        /** PATCH_SEARCH_VPTREE: extra queries per patch in which the unknown pixels are
        completed from the best match so far instead of the smooth pre-fill (0 = the thesis's
        single query). Textures need this: a smoothly completed query lies nearer to smooth
        patches than to the texture it should continue. */
        int vp_refine = 2;
        /** PATCH_SEARCH_VPTREE: at most this many distance evaluations per tree query (0 =
        exact search). Nearest-neighbour search in a metric tree degrades towards a linear
        scan for high-dimensional, noise-like patches; the budget bounds it. */
        int vp_max_checks = 20000;
        /** Seed of the randomised search: results are a pure function of the input and the
        seed. */
        uint64 seed = 0;

        /** @brief Reads the fields present in @p node (others keep their values); an
        unknown key or a value check() refuses is an error. */
        void read(const FileNode& node);
        /** @brief Writes all fields into the open map of @p fs. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range
        (create() calls it). */
        void check() const;
    };

    /** @brief Creates an inpainter. Throws cv::Exception for invalid parameters. */
    static Ptr<ExemplarInpainter> create(const Params& params = Params());
    /** @brief Destructor. */
    virtual ~ExemplarInpainter();

    /** @brief Fills the hole of an image.
    @param image CV_8UC3 (BGR) or CV_8UC1 image.
    @param mask CV_8UC1 of the image's size: non-zero = hole to fill (so an anti-aliased mask
    fills its soft edge too), 0 = known. An empty mask (no non-zero pixel) returns a copy of
    @p image.
    @param result the filled image, same size and type as @p image; pixels outside the hole
    are copied unchanged.
    @param source optional CV_8UC1 of the image's size: non-zero = pixels that may be copied
    from (default: all known pixels). Source patches lie entirely inside the image, in the
    known region and in @p source.
    Throws cv::Exception if the types or sizes are wrong or no patch-sized source region
    remains (for example a mask covering the whole image). */
    virtual void inpaint(InputArray image, InputArray mask, OutputArray result,
                         InputArray source = noArray()) = 0;

    /** @brief The parameters in use. */
    virtual const Params& params() const = 0;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
