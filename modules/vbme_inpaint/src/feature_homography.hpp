// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Shared by the video inpainters: a homography between two frames from their ORB features.
#pragma once

#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

namespace cv {
namespace vbme {
namespace detail {

/** Homography mapping the pixels of frame `a` to frame `b` from their binary features (ratio
test 0.8, RANSAC at 2 px, at least 12 inliers); empty if it cannot be estimated. */
inline Mat featureHomography(const std::vector<KeyPoint>& kp_a, const Mat& desc_a,
                             const std::vector<KeyPoint>& kp_b, const Mat& desc_b) {
    Mat H;
    if (desc_a.rows < 8 || desc_b.rows < 8) return H;
    BFMatcher matcher(NORM_HAMMING);
    std::vector<std::vector<DMatch>> knn;
    matcher.knnMatch(desc_a, desc_b, knn, 2);
    std::vector<Point2f> pa, pb;
    for (const auto& m : knn)
        if (m.size() == 2 && m[0].distance < 0.8f * m[1].distance) {
            pa.push_back(kp_a[m[0].queryIdx].pt);
            pb.push_back(kp_b[m[0].trainIdx].pt);
        }
    if (pa.size() >= 12) {
        std::vector<uchar> inl;
        H = findHomography(pa, pb, RANSAC, 2.0, inl, 2000, 0.999);
        if (!H.empty() && countNonZero(inl) < 12) H.release();
    }
    return H;
}

}  // namespace detail
}  // namespace vbme
}  // namespace cv
