// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_TRACK_VIDEO_TRACKING_HPP
#define OPENCV_VBME_TRACK_VIDEO_TRACKING_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/video.hpp"

#include "opencv2/vbme/track/object_tracker.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_track
//! @{

/** @brief Draws a tracking result on a frame: the search window (cyan), the disk (green),
its centre, and a caption with the frame index and confidence ("LOST" in red when lost). */
CV_EXPORTS void drawTrackingOverlay(InputOutputArray frame, const ObjectTracker::Result& r,
                                    Rect search_window, int frame_index);

/** @brief Options of trackVideo(). */
struct CV_EXPORTS TrackVideoOptions {
    ObjectTracker::Params params;  //!< tracker settings
    std::string overlay;           //!< if set, an overlay video (or image pattern) written here
    /** Encoding of the overlay video (codec, quality); the input's timestamps, colour tags and
    audio are added (cv::vbme::sinkOptionsFrom), and H.264/H.265 get full chroma
    (VideoSinkOptions::full_chroma) unless a pixel format is given. */
    VideoSinkOptions overlay_encode;
    bool force = false;  //!< replace existing outputs

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief What trackVideo() did. */
struct CV_EXPORTS TrackVideoSummary {
    std::vector<ObjectTracker::Result> results;  //!< one per frame
    int lost = 0;                                //!< frames where the object was lost
    double seconds = 0;       //!< wall time of the tracking loop (decoding included)
    double fps = 0;           //!< the input's frame rate
    std::string init_report;  //!< the colour models tried on frame 0 (ObjectTracker::initReport())
};

/** @brief Tracks the object of @p first_mask through a whole video: the job of `vbme track`.

Writes `out_dir/mask_%05d.png` (255 = object, empty when lost) and `out_dir/track.csv` with the
header `frame,cx,cy,r,confidence` (one row per frame; a lost frame keeps its row with the last
known disk and its low confidence). Frames are streamed (memory does not grow with the video).
All inputs are checked before anything is written; outputs are written under temporary names
and moved into place when the whole video is done, so an error leaves no partial result.
@param video video file, image folder or pattern (cv::vbme::VideoReader).
@param first_mask CV_8U mask of the object in frame 0 (non-zero = object), the frame's size.
@param out_dir output folder (created; existing masks/track.csv need options.force).
@param options settings. Throws cv::Exception on bad input. */
CV_EXPORTS TrackVideoSummary trackVideo(const std::string& video, InputArray first_mask,
                                        const std::string& out_dir,
                                        const TrackVideoOptions& options = TrackVideoOptions());

//! @}

}  // namespace vbme
}  // namespace cv

#endif
