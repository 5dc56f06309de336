// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Reading a whole (small) test video into memory, shared by the tests.
#pragma once

#include <climits>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/core/video.hpp>

namespace vbme_test {

/** The frames of @p video (a file or an image pattern), at most @p max_frames, each its own
copy, read through vbme's VideoReader as the commands read them. */
inline std::vector<cv::Mat> readVideoFrames(const std::string& video, int max_frames = INT_MAX) {
    std::vector<cv::Mat> frames;
    cv::vbme::VideoReader reader(video);
    cv::Mat f;
    while ((int)frames.size() < max_frames && reader.read(f))
        frames.push_back(f.clone());
    return frames;
}

}  // namespace vbme_test
