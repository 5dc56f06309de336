// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Shared by the insertion tests on the Blender clip (test/data/insertion_blender, made by
// scripts/blender/insertion_clip.py): its folder, reading a whole video, and the object's
// neighbourhood where the composites are scored.
#ifndef VBME_TEST_INSERTION_BLENDER_UTIL_HPP
#define VBME_TEST_INSERTION_BLENDER_UTIL_HPP

#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core/video.hpp>
#include <opencv2/vbme/pipeline/insertion.hpp>

namespace vbme_test {

/** The Blender insertion clip's folder. */
inline std::string insertionBlenderData() {
    return std::string(VBME_TEST_DATA_DIR) + "/insertion_blender";
}

/** Insertion options for the clip as it is: its input, its frame-0 scene with the sphere, its
true cameras; the output and the work folder under @p dir. */
inline cv::vbme::InsertionParams insertionBlenderParams(const std::string& dir) {
    const std::string data = insertionBlenderData();
    cv::vbme::InsertionParams ip;
    ip.video = data + "/plate.mkv";
    ip.scene = data + "/scene.yml";
    ip.cameras = data + "/cameras.yml";
    ip.out = dir + "/inserted.mkv";
    ip.work = dir + "/work";
    return ip;
}

/** Every frame of @p video (8-bit BGR). */
/** The object's neighbourhood in one frame: where the truth differs from the input by more
than the renders' noise (8 code values in some channel: the sphere, its shadow, the light it
reflects), dilated by 3 px. */
inline cv::Mat insertionInfluence(const cv::Mat& input, const cv::Mat& truth) {
    cv::Mat d;
    cv::absdiff(input, truth, d);
    std::vector<cv::Mat> ch;
    cv::split(d, ch);
    cv::Mat m = cv::max(cv::max(ch[0], ch[1]), ch[2]) > 8;
    cv::dilate(m, m, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7)));
    return m;
}

}  // namespace vbme_test

#endif
