// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_INPAINT_CONSENSUS_HPP
#define OPENCV_VBME_INPAINT_CONSENSUS_HPP

#include <string>

#include "opencv2/vbme/inpaint/exemplar.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_inpaint
//! @{

/** @brief How neighbouring frames are aligned to the frame being filled. */
enum ConsensusAlignment {
    /** No alignment: the camera stands still (the fastest; material editing's default). */
    CONSENSUS_ALIGN_NONE = 0,
    /** One homography per frame pair, chained from consecutive frames: fitted (RANSAC) to
    corners around the hole tracked by pyramidal Lucas-Kanade @cite Bouguet2001 with a
    forward-backward check, so that it maps the background plane next to the object (the
    floor it rolls on) even when the view as a whole has parallax; frames without a hole, or
    too few corners, use ORB features over the whole frame. Each link is then refined by
    direct alignment (ECC @cite Evangelidis2008) on the same ring, and each neighbour's
    chained map is refined again around the hole of the frame being filled (every second
    neighbour; the others are one refined link from one), since the links far along the
    chain were fitted where the object was then: corner tracks fix the plane to about a
    pixel, which fine repeated texture turns into seams. */
    CONSENSUS_ALIGN_HOMOGRAPHY = 1,
    /** The homography, then a dense residual flow (DIS @cite Kroeger2016) around the hole,
    completed into the holes by normalised convolution @cite Knutsson1993; used for a
    neighbour only where it agrees better with the frame on a ring around the hole than the
    homography alone (parallax). The default. */
    CONSENSUS_ALIGN_FLOW = 2
};

/** @brief What is done with the removed object's cast shadow. */
enum ShadowMode {
    SHADOWS_KEEP = 0,   //!< leave the frame's own pixels outside the hole untouched
    SHADOWS_REMOVE = 1  //!< detect the object's shadow near the hole and remove it
};

/** @brief Parses "keep" or "remove" (case-insensitive); throws cv::Exception otherwise. */
CV_EXPORTS ShadowMode parseShadowMode(const std::string& name);
/** @brief "keep" or "remove". */
CV_EXPORTS std::string toString(ShadowMode m);

/** @brief Streaming video object removal by a robust consensus of aligned frames, with the
removal of the object's cast shadow.

For every hole pixel of frame t, each frame s within ±K frames (K = Params::temporal_radius,
or chosen from how fast the hole moves against the background) that sees the pixel gives a
candidate colour, after aligning s to t (ConsensusAlignment). Candidates are weighted by the
alignment's agreement with frame t on a ring around the hole and by their temporal distance.
Candidates that lie in their own frame's object shadow are left out: a candidate within
Params::shadow_reach object radii of its frame's hole ("the object's zone") whose luminance
falls below (1 − Params::shadow_threshold) times the weighted median of the candidates outside
their zones is shadowed. The remaining candidates vote: the weighted medoid in CIE Lab (the
candidate with the least weighted sum of Lab distances to the others) is found, and the
weighted mean of the candidates within Params::inlier_distance of it is the fill. This is a
weighted mode in a perceptual colour space: the ball's own colour, its shadow and misaligned
samples are outvoted, and noise is averaged. Pixels no frame sees take the previous output's
fill (aligned) where it had one, so that they do not flicker, and the rest are filled by
ExemplarInpainter, whose patches continue the consensus-filled surroundings.

With SHADOWS_REMOVE, the same consensus is formed for the frame's own known pixels in the
object's zone. Where the frame is darker than its consensus by more than the threshold, in
connected regions of at least Params::shadow_min_area of the hole's area, grown to take in the
faint penumbra, the shadow is replaced by the consensus, feathered into the frame; or, with
Params::shadow_relight, the per-channel attenuation (frame / consensus) is smoothed and
divided out, so that the frame's own texture is kept, re-lit.

Frames go in with push() and come out in order with pop() once K later frames have arrived
(or after finish()). At most 2K + 2 frames are kept, whatever the video's length.

Example:
@code
    using namespace cv::vbme;
    ConsensusInpainter::Params p;
    p.shadows = SHADOWS_REMOVE;
    Ptr<ConsensusInpainter> ci = ConsensusInpainter::create(p);
    Mat frame, out;
    while (reader.read(frame)) {
        ci->push(frame, maskOf(frame));
        while (ci->pop(out)) sink.write(out);
    }
    ci->finish();
    while (ci->pop(out)) sink.write(out);
@endcode
*/
class CV_EXPORTS ConsensusInpainter {
public:
    /** @brief Settings of the consensus fill. */
    struct CV_EXPORTS Params {
        /** @brief The defaults listed with each field. */
        Params();
        /** Settings of the exemplar fill of what no frame sees. */
        ExemplarInpainter::Params exemplar;
        /** Frames on each side of a frame that give candidates; 0 = chosen from the object's
        motion (see @p motion_factor) between @p min_radius and @p max_radius. */
        int temporal_radius = 0;
        /** Automatic radius: K = ⌈motion_factor · (object diameter) / (object speed)⌉ frames,
        the speed measured against the aligned background over the first frames. */
        double motion_factor = 3.0;
        int min_radius = 4;   //!< smallest automatic radius
        int max_radius = 12;  //!< largest automatic radius (bounds memory and time)
        /** The alignment (a ConsensusAlignment). */
        int alignment = CONSENSUS_ALIGN_FLOW;
        /** ORB features per frame for the whole-frame homographies. */
        int features = 1000;
        /** The local homography uses corners within this many object radii of the hole
        (at least 40 px). */
        double local_reach = 5.0;
        /** A homography moving no image corner by more than this (pixels) is the identity. */
        double identity_tolerance = 0.3;
        /** Largest robust (median) absolute difference, 8-bit levels, between an aligned
        neighbour and the frame on the ring around the hole; worse neighbours are not used. */
        double max_ring_error = 12.0;
        /** Neighbour weight exp(−(e / ring_sigma)²) for its ring error e. */
        double ring_sigma = 6.0;
        /** Neighbour weight 1 / (1 + |s − t| / temporal_sigma) for its distance in frames. */
        double temporal_sigma = 6.0;
        /** Pixels of a neighbour within this distance of its own hole give no candidate
        (the mask may miss the object's soft edge or motion blur). */
        int hole_margin = 2;
        /** The object's zone: within this many object radii (√(area/π) of the hole) of the
        hole; shadow candidates are searched for there, and a frame's own shadow too. */
        double shadow_reach = 3.0;
        /** A pixel in the zone is shadowed if its luminance (8-bit sRGB values) is below
        (1 − shadow_threshold) times the unshadowed consensus. */
        double shadow_threshold = 0.08;
        /** Candidates in their frame's zone that are not shadowed still weigh less: ×this. */
        double zone_weight = 0.5;
        /** Lab distance (L1 over 8-bit L*a*b*) within which candidates join the medoid's mean. */
        double inlier_distance = 12.0;
        /** What is done with the frame's own shadow of the object (a ShadowMode). */
        int shadows = SHADOWS_REMOVE;
        /** A shadow region smaller than this fraction of the hole's area is noise. */
        double shadow_min_area = 0.05;
        /** Gaussian σ (pixels): of the attenuation map divided out of the shadow when
        re-lighting; half of it feathers the consensus fill; the shadow mask is grown by
        2⌈σ⌉ + 1 pixels to take in the faint penumbra. */
        double shadow_smooth = 2.0;
        /** Remove the shadow by re-lighting (divide the frame by its smoothed attenuation,
        keeping its own texture) instead of the default consensus fill (the vote of the other
        frames, feathered into the frame). Re-lighting leaves halos at sharp shadow edges
        (contact shadows), which is why the consensus fill is the default (figures in
        doc/vbme_inpaint.md, "Measured"). */
        bool shadow_relight = false;
        /** Reuse the previous output's fill where no frame sees the background. */
        bool reuse_previous = true;

        /** @brief Reads the fields present in @p node (others keep their values); an
        unknown key or a value check() refuses is an error. */
        void read(const FileNode& node);
        /** @brief Writes all fields into the open map of @p fs. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range
        (create() calls it). */
        void check() const;
    };

    /** @brief What happened to one output frame. */
    struct CV_EXPORTS FrameStats {
        int index = -1;        //!< frame index (from 0)
        int radius = 0;        //!< the temporal radius K in use
        int hole = 0;          //!< hole pixels
        int temporal = 0;      //!< filled by the consensus of other frames
        int previous = 0;      //!< filled from the previous output frame
        int exemplar = 0;      //!< filled by exemplars
        int neighbours = 0;    //!< neighbours that passed the ring check
        int flow_aligned = 0;  //!< of which aligned by the dense flow
        int shadow = 0;        //!< pixels of the frame's own shadow found (and re-lit)
        int excluded = 0;      //!< candidates left out as shadowed
    };

    /** @brief Creates an inpainter. Throws cv::Exception for invalid parameters. */
    static Ptr<ConsensusInpainter> create(const Params& params = Params());
    /** @brief Destructor. */
    virtual ~ConsensusInpainter();

    /** @brief Adds the next frame and its hole.
    @param frame CV_8UC3 BGR frame; all frames must have one size.
    @param mask CV_8UC1 of the frame's size, non-zero = hole (the object), or empty. */
    virtual void push(InputArray frame, InputArray mask) = 0;
    /** @brief Says that no more frames follow. */
    virtual void finish() = 0;
    /** @brief Takes the next finished frame, in input order; false if none is ready.
    @param frame the CV_8UC3 result.
    @param stats optional: what was done.
    @param shadow optional: CV_8UC1 map of the frame's shadow pixels that were re-lit. */
    virtual bool pop(OutputArray frame, FrameStats* stats = nullptr,
                     OutputArray shadow = noArray()) = 0;

    /** @brief The parameters in use. */
    virtual const Params& params() const = 0;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
