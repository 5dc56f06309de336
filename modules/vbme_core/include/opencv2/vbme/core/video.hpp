// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_VIDEO_HPP
#define OPENCV_VBME_CORE_VIDEO_HPP

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief Reads a video file, a folder of numbered images, or a printf pattern
(`frames/%05d.png`), frame by frame.

Frames are delivered as 8-bit BGR in the orientation a player shows them (rotation metadata
is honoured). Image folders are ordered by the number in the file name, then by name; all
images must have one size. A folder's frame rate is read from an optional `fps.txt` in it,
else taken as 30.
*/
class CV_EXPORTS VideoReader {
public:
    /** @brief Opens @p source; throws cv::Exception saying what is wrong (missing, not a
    video, empty folder, …). */
    explicit VideoReader(const std::string& source);
    ~VideoReader();
    VideoReader(const VideoReader&) = delete;
    VideoReader& operator=(const VideoReader&) = delete;

    /** @brief Reads the next frame; returns false at the end. Throws if a frame in an image
    folder cannot be decoded or differs in size. */
    bool read(OutputArray frame);
    /** @brief Frame rate (frames per second). */
    double fps() const;
    /** @brief Frame size as shown (after rotation). */
    Size frameSize() const;
    /** @brief Number of frames: exact for image folders, the container's count for videos
    (may be approximate; −1 if unknown). */
    int frameCount() const;
    /** @brief Index of the frame the next read() returns. */
    int position() const;
    /** @brief Whether the source is a folder or pattern of images. */
    bool isImageSequence() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/** @brief Writes frames to a video file or to numbered images, completed atomically.

The kind follows the path: a path containing `%` (e.g. `out/%05d.png`) writes numbered images,
each under a temporary name renamed when written; a video file (`.mp4` → H.264 when available,
else MPEG-4 part 2; `.mkv`/`.avi` → lossless FFV1) is written under a temporary name and renamed
by close(). If the writer is destroyed without close(), the partial video is deleted.
*/
class CV_EXPORTS VideoSink {
public:
    /** @brief Opens @p path for frames of @p size at @p fps (8-bit BGR, or 8-bit gray when
    @p color is false). Throws cv::Exception if no encoder can write it. */
    VideoSink(const std::string& path, double fps, Size size, bool color = true);
    ~VideoSink();
    VideoSink(const VideoSink&) = delete;
    VideoSink& operator=(const VideoSink&) = delete;

    /** @brief Appends a frame (must have the size and type given at opening). */
    void write(InputArray frame);
    /** @brief Finishes the file and renames it into place. */
    void close();
    /** @brief Frames written so far. */
    int count() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
