// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_TRACK_OBJECT_TRACKER_HPP
#define OPENCV_VBME_TRACK_OBJECT_TRACKER_HPP

#include <string>

#include <opencv2/core.hpp>

#include "opencv2/vbme/track/disk.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_track
//! @{

/** @name Stages of the colour tracker (thesis §4.1), usable on their own
@{ */

/** @brief 2-D hue–saturation histogram of the pixels of @p hsv under @p mask, scaled so that
its maximum is 1 (all zeros if no pixel counts).
@param hsv CV_8UC3 image in OpenCV's 8-bit HSV (H in [0,180), S, V in [0,255]).
@param mask CV_8U, non-zero = counted; empty = every pixel.
@param hist output CV_32F, @p h_bins rows × @p s_bins columns.
@param h_bins hue bins over [0,180).
@param s_bins saturation bins over [0,256). */
CV_EXPORTS void hueSatHistogram(InputArray hsv, InputArray mask, OutputArray hist, int h_bins,
                                int s_bins);

/** @brief Per-bin foreground ratio `f = h_fg / (h_fg + h_bg)`, 0 where both are 0.
@param hist_fg, hist_bg CV_32F histograms of equal size.
@param ratio output CV_32F of the same size. */
CV_EXPORTS void foregroundRatio(InputArray hist_fg, InputArray hist_bg, OutputArray ratio);

/** @brief Looks up every pixel's ratio: `prob(x) = ratio(bin(h(x)), bin(s(x)))`.
@param hsv CV_8UC3 HSV image. @param ratio table from foregroundRatio().
@param prob output CV_32F. */
CV_EXPORTS void backProjectRatio(InputArray hsv, InputArray ratio, OutputArray prob);

/** @brief Fills the holes of a binary mask: pixels not connected (4-connectivity) to the
image border through background become object (flood fill from the border, invert, union). */
CV_EXPORTS void fillHoles(InputArray mask, OutputArray filled);

/** @brief The thesis's clean-up: opening with an @p open_size, then closing with a
@p close_size elliptic structuring element, then (optionally) fillHoles(). A size ≤ 1 skips
that step. */
CV_EXPORTS void cleanMask(InputArray mask, OutputArray cleaned, int open_size = 9,
                          int close_size = 13, bool fill_holes = true);
/** @} */

/** @brief Colour models of ObjectTracker (Params::colour_model). */
enum TrackColourModel {
    TRACK_COLOUR_HS = 0,     //!< the thesis: hue–saturation histograms (exact HSV per pixel)
    TRACK_COLOUR_AUTO = 1,   //!< chosen on frame 0 among the models below by self-check
    TRACK_COLOUR_LAB8 = 2,   //!< Lab joint histogram, 8×8×8 bins
    TRACK_COLOUR_LAB16 = 3,  //!< Lab joint histogram, 16×16×16 bins
    TRACK_COLOUR_HSV = 4,    //!< HSV joint histogram, 12×8×8 bins (keeps the value V)
    TRACK_COLOUR_AB = 5,     //!< Lab chroma only (a, b), 16×16 bins
    TRACK_COLOUR_GMM = 6     //!< Gaussian mixtures in Lab: 3 object, 6 background components
};

/** @brief Tracks a uniformly coloured ball through a video (thesis §4.1).

The first frame and a mask of the ball train hue–saturation histograms of the object and of
the background; in every later frame each pixel is object where `f = h_fg/(h_fg + h_bg) > T`,
the binary image is cleaned (cleanMask()) and a disk is fitted (fitDisk()). The disk, a
confidence in [0,1] and the disk's mask are returned per frame.

Beyond the thesis, each switchable in Params: a search window around the previous disk (rejects
distractors of the same hue elsewhere and makes a frame cheaper), neutral votes for specular
highlights and clipped pixels (they keep the object's colour from being learnt and from
denting the disk), a lost-track signal (confidence below a threshold gives an empty mask
instead of a wrong disk, and widens the search), and a slow update of the colour model.

@code
Ptr<ObjectTracker> tracker = ObjectTracker::create();
tracker->init(first_frame, first_mask);
Mat frame, mask;
while (video.read(frame)) {
    ObjectTracker::Result r = tracker->update(frame, mask);
    if (!r.found) { ... }  // lost: mask is empty
}
@endcode
*/
class CV_EXPORTS ObjectTracker {
public:
    /** @brief Settings; every field is read and written by read()/write(). */
    struct CV_EXPORTS Params {
        Params();                        //!< the defaults below
        int h_bins = 30;                 //!< hue bins
        int s_bins = 32;                 //!< saturation bins
        float threshold = 0.5f;          //!< T: object where f > T
        int open_size = 9;               //!< opening element size (thesis: 9×9)
        int close_size = 13;             //!< closing element size (thesis: 13×13)
        bool fill_holes = true;          //!< fill interior holes after closing
        bool use_search_window = true;   //!< search only near the previous disk
        float window_scale = 2.0f;       //!< window half-size = window_scale·r + window_margin
        int window_margin = 24;          //!< extra window half-size (pixels)
        bool neutral_highlights = true;  //!< specular / clipped pixels vote neither way
        int highlight_min_value = 235;   //!< V ≥ this and S ≤ highlight_max_saturation, or any
        int highlight_max_saturation = 80;    //!< channel ≥ 254: unreliable colour
        float lost_threshold = 0.5f;          //!< confidence below this: lost (empty mask)
        float model_update_rate = 0.f;        //!< 0: fixed model; else blend weight per frame
        float min_update_confidence = 0.85f;  //!< update the model only above this confidence
        float min_step = 0.25f;               //!< finest hill-climbing step (pixels)
        /** Colour model (TrackColourModel). TRACK_COLOUR_AUTO learns joint colour histograms
        that keep lightness and chroma from frame 0 and picks the one whose segmentation of
        frame 0 agrees best with the mask; TRACK_COLOUR_HS is the thesis's model. */
        int colour_model = TRACK_COLOUR_AUTO;
        /** init() refuses (throws) when the chosen model segments frame 0 with an IoU against
        the mask below this: the ball cannot be told from its surroundings by colour. 0 = never
        refuse. */
        float min_init_iou = 0.5f;
        /** A joint model whose object and background histograms overlap more than this
        (Bhattacharyya coefficient, 1 = identical) is not used; 1 = no bound. */
        float max_init_overlap = 0.9f;
        bool predict_motion = true;       //!< constant-velocity prediction places the window
        float max_radius_change = 0.15f;  //!< bound on |Δr|/r per frame (0 = no bound)
        /** Confidence from colour and shape evidence (fill, surroundings, rim edges, motion);
        false: the thesis's IoU of the disk with the cleaned object pixels. */
        bool evidence_confidence = true;
        /** Move the colour-fitted disk onto the ball's silhouette: along rays from its centre,
        a few colour-edge candidates each; the circle most rays agree with (RANSAC-style
        consensus @cite Fischler1981), then a strength-weighted least-squares circle
        @cite Kasa1976 through each ray's strongest edge near it (kept when most rays agree).
        Used on a clip only when it improves frame 0's disk. */
        bool edge_refine = true;
        bool redetect = true;             //!< when lost, search the whole frame and resume
        float redetect_threshold = 0.6f;  //!< confidence needed to resume after a loss

        /** @brief Reads the fields present in @p fn (others keep their value), then
        check()s; an unknown key is an error. */
        void read(const FileNode& fn);
        /** @brief Throws cv::Exception naming the first field out of its range. */
        void check() const;
        /** @deprecated Use check(). */
        void validate() const { check(); }
        /** @brief Writes every field. */
        void write(FileStorage& fs) const;
    };

    /** @brief One frame's result. */
    struct Result {
        Disk disk;  //!< the fitted disk (the last good one when lost)
        /** In [0,1]. With Params::evidence_confidence: `cbrt(fill · surround · rim) ·
        (0.5 + 0.5 · motion)`; else the IoU of the disk with the cleaned object pixels. */
        float confidence = 0;
        bool found = false;       //!< confidence ≥ Params::lost_threshold
        float fill = 0;           //!< fraction of the disk's pixels classified object
        float surround = 0;       //!< fraction of a ring around the disk classified background
        float rim = 0;            //!< fraction of rim directions with a colour edge
        float motion = 0;         //!< agreement with the predicted disk (1 = as predicted)
        bool redetected = false;  //!< found by a whole-frame search after a loss
    };

    virtual ~ObjectTracker();

    /** @brief Learns the colour model from the first frame and the object's mask.
    Throws cv::Exception if the mask is empty, covers the whole frame, or differs in size. */
    virtual void init(InputArray frame, InputArray mask) = 0;

    /** @brief Tracks the object in the next frame.
    @param frame 8-bit BGR frame of the size given to init().
    @param mask if given, receives the disk's mask (CV_8U, 255 inside), empty (all 0) when lost.
    @return the disk and confidence. */
    virtual Result update(InputArray frame, OutputArray mask = noArray()) = 0;

    /** @brief The cleaned object pixels of the last update() (CV_8U, full frame), for
    inspection. */
    virtual Mat lastForeground() const = 0;
    /** @brief The region searched by the last update(). */
    virtual Rect lastSearchWindow() const = 0;
    /** @brief The current ratio table f (h_bins × s_bins, CV_32F). */
    virtual Mat ratioTable() const = 0;
    /** @brief The settings. */
    virtual const Params& params() const = 0;
    /** @brief The colour model in use after init() (a TrackColourModel, never AUTO). */
    virtual int colourModel() const = 0;
    /** @brief IoU of frame 0's segmentation by the chosen model with the init() mask. */
    virtual double initSelfCheckIoU() const = 0;
    /** @brief A line describing the models tried at init() and their frame-0 IoU. */
    virtual std::string initReport() const = 0;

    /** @brief Creates a tracker. */
    static Ptr<ObjectTracker> create(const Params& params = Params());
};

/** @brief Reads tracker parameters from a YAML/JSON file (`vbme track --params`): the fields
of ObjectTracker::Params at top level or under `tracker:`; others keep their defaults. Throws
cv::Exception naming the file and the field when the file is unreadable or a value is out of
range. */
CV_EXPORTS ObjectTracker::Params readTrackerParamsFile(const std::string& path);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
