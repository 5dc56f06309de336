// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_INPAINT_VIDEO_HPP
#define OPENCV_VBME_INPAINT_VIDEO_HPP

#include <string>

#include "opencv2/vbme/inpaint/exemplar.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_inpaint
//! @{

/** @brief Streaming video inpainting: removes a moving object from a video frame by frame
with bounded memory.

A moving object hides different background in different frames. Each frame's hole is
filled, in this order:
1. from the neighbouring frames within Params::temporal_radius, nearest first: each neighbour
   is aligned to the frame by a homography (ORB features outside both holes, RANSAC, refined
   with corners tracked by pyramidal Lucas-Kanade @cite Bouguet2001; taken as
   the identity when it moves no image corner by more than Params::identity_tolerance pixels,
   so a static camera copies pixels exactly). A neighbour is used only if, on a ring of known
   pixels around the hole, it agrees with the frame (mean absolute difference at most
   Params::max_ring_error); its pixels are used only where they were not hidden in it;
2. from the previous output frame (aligned the same way), so that background never seen keeps
   the fill it got before instead of flickering (Params::reuse_previous);
3. the rest by ExemplarInpainter.

Frames go in with push() and come out, in order, with pop() once enough later frames have
arrived (temporal_radius of them) or after finish(). At most 2·temporal_radius + 2 frames are
kept in memory.

Example:
@code
    Ptr<VideoInpainter> vi = VideoInpainter::create();
    Mat frame, mask, out;
    while (reader.read(frame)) {
        vi->push(frame, maskOf(frame));
        while (vi->pop(out)) sink.write(out);
    }
    vi->finish();
    while (vi->pop(out)) sink.write(out);
@endcode
*/
class CV_EXPORTS VideoInpainter {
public:
    /** @brief Settings of the video fill. */
    struct CV_EXPORTS Params {
        /** @brief The defaults listed with each field. */
        Params();
        /** Settings of the exemplar fill of what no neighbour sees. */
        ExemplarInpainter::Params exemplar;
        /** Neighbouring frames on each side used to fill a frame's hole. */
        int temporal_radius = 6;
        /** Largest mean absolute difference (8-bit levels, averaged over channels) between
        an aligned neighbour and the frame on the ring of known pixels around the hole. */
        double max_ring_error = 10.0;
        /** Width of that ring in pixels. */
        int ring_width = 4;
        /** A homography moving no image corner by more than this (pixels) is taken as the
        identity, so that pixels are copied without resampling. */
        double identity_tolerance = 0.5;
        /** Pixels of a neighbour within this distance of its own hole are not used (the mask
        may miss the object's soft edge or shadow). */
        int hole_margin = 1;
        /** Reuse the previous output frame's fill where no neighbour sees the background. */
        bool reuse_previous = true;
        /** ORB features per frame for the alignment. */
        int features = 1500;
        /** Refine each feature-based homography to sub-pixel accuracy: corners tracked by
        pyramidal Lucas-Kanade from the predicted positions, and a homography fitted to them. */
        bool refine_alignment = true;

        /** @brief Reads the fields present in @p node (others keep their values); an
        unknown key or a value check() refuses is an error. */
        void read(const FileNode& node);
        /** @brief Writes all fields into the open map of @p fs. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range
        (create() calls it). */
        void check() const;
    };

    /** @brief What happened to the hole of one output frame. */
    struct CV_EXPORTS FrameStats {
        int index = -1;      //!< frame index (from 0)
        int hole = 0;        //!< hole pixels
        int temporal = 0;    //!< filled from neighbouring frames
        int previous = 0;    //!< filled from the previous output frame
        int exemplar = 0;    //!< filled by exemplars
        int neighbours = 0;  //!< neighbours that passed the consistency check
    };

    /** @brief Creates a video inpainter. Throws cv::Exception for invalid parameters. */
    static Ptr<VideoInpainter> create(const Params& params = Params());
    /** @brief Destructor. */
    virtual ~VideoInpainter();

    /** @brief Adds the next frame and its hole.
    @param frame CV_8UC3 BGR frame; all frames must have one size.
    @param mask CV_8UC1 of the frame's size, non-zero = hole (the object), or empty for no
    hole. */
    virtual void push(InputArray frame, InputArray mask) = 0;
    /** @brief Says that no more frames follow, so the last ones can be finished. */
    virtual void finish() = 0;
    /** @brief Takes the next finished frame, in input order. Returns false if none is ready.
    @param frame the filled CV_8UC3 frame.
    @param stats optional: what filled its hole. */
    virtual bool pop(OutputArray frame, FrameStats* stats = nullptr) = 0;

    /** @brief The parameters in use. */
    virtual const Params& params() const = 0;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
