// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Shared by the video inpainters: a homography between two frames from their ORB features,
// refined by tracking corners with pyramidal Lucas-Kanade.
#pragma once

#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

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

/** Whether @p H moves none of the four corners of a @p size frame by more than @p tol pixels
(false for an empty H). */
inline bool nearIdentity(const Mat& H, Size size, double tol) {
    if (H.empty()) return false;
    std::vector<Point2f> c = {Point2f(0, 0), Point2f(float(size.width - 1), 0),
                              Point2f(float(size.width - 1), float(size.height - 1)),
                              Point2f(0, float(size.height - 1))};
    std::vector<Point2f> d;
    perspectiveTransform(c, d, H);
    for (size_t i = 0; i < c.size(); ++i)
        if (norm(c[i] - d[i]) > tol) return false;
    return true;
}

/** Sub-pixel refinement of the homography @p H from frame a to frame b: up to @p max_corners
corners of a (in @p usable_a) are tracked into b by pyramidal Lucas-Kanade from the positions H
predicts; those landing on a usable pixel of b (@p usable_b, frame size @p size) give a
homography by RANSAC at @p ransac_px, taken when it has at least 20 inliers. Otherwise H is
returned unchanged. */
inline Mat refineHomographyByFlow(const Mat& gray_a, const Mat& gray_b, const Mat& usable_a,
                                  const Mat& usable_b, Size size, const Mat& H, int max_corners,
                                  double ransac_px) {
    std::vector<Point2f> ca, cb, ra, rb;
    goodFeaturesToTrack(gray_a, ca, max_corners, 0.01, 6, usable_a, 5);
    if (ca.size() < 20) return H;
    perspectiveTransform(ca, cb, H);
    std::vector<uchar> ok;
    std::vector<float> err;
    calcOpticalFlowPyrLK(gray_a, gray_b, ca, cb, ok, err, Size(21, 21), 2,
                         TermCriteria(TermCriteria::COUNT | TermCriteria::EPS, 30, 0.005),
                         OPTFLOW_USE_INITIAL_FLOW);
    for (size_t k = 0; k < ca.size(); ++k) {
        const Point p(cvRound(cb[k].x), cvRound(cb[k].y));
        if (ok[k] && Rect(Point(), size).contains(p) && usable_b.at<uchar>(p)) {
            ra.push_back(ca[k]);
            rb.push_back(cb[k]);
        }
    }
    if (ra.size() < 20) return H;
    std::vector<uchar> inl;
    Mat R = findHomography(ra, rb, RANSAC, ransac_px, inl, 2000, 0.999);
    if (!R.empty() && countNonZero(inl) >= 20) return R;
    return H;
}

}  // namespace detail
}  // namespace vbme
}  // namespace cv
