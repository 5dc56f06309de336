// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Each stage of the colour tracker against a reference: histograms, ratio, back-projection,
// morphology, hole filling, disk fitting.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/track.hpp>

using namespace cv;
using namespace cv::vbme;

TEST(TrackStages, HistogramCountsAndScalesToOne) {
    // 3 pixels in bin (1, 2), 1 pixel in bin (0, 0), one masked-out pixel.
    Mat hsv(1, 5, CV_8UC3);
    hsv.at<Vec3b>(0) = Vec3b(10, 20, 100);  // h bin 10*18/180 = 1, s bin 20*32/256 = 2
    hsv.at<Vec3b>(1) = Vec3b(11, 23, 50);
    hsv.at<Vec3b>(2) = Vec3b(19, 16, 0);
    hsv.at<Vec3b>(3) = Vec3b(0, 0, 255);
    hsv.at<Vec3b>(4) = Vec3b(179, 255, 255);
    Mat mask = (Mat_<uchar>(1, 5) << 1, 1, 1, 1, 0);
    Mat hist;
    hueSatHistogram(hsv, mask, hist, 18, 32);
    ASSERT_EQ(hist.size(), Size(32, 18));
    EXPECT_FLOAT_EQ(hist.at<float>(1, 2), 1.f);
    EXPECT_FLOAT_EQ(hist.at<float>(0, 0), 1.f / 3);
    EXPECT_FLOAT_EQ(hist.at<float>(17, 31), 0.f);
    EXPECT_NEAR(sum(hist)[0], 4.f / 3, 1e-6);
}

TEST(TrackStages, HistogramMatchesCalcHist) {
    Mat bgr(60, 80, CV_8UC3), hsv;
    RNG(3).fill(bgr, RNG::UNIFORM, 0, 256);
    cvtColor(bgr, hsv, COLOR_BGR2HSV);
    Mat mask(hsv.size(), CV_8UC1);
    RNG(4).fill(mask, RNG::UNIFORM, 0, 2);
    Mat ours, ref;
    hueSatHistogram(hsv, mask, ours, 30, 32);
    const int channels[] = {0, 1}, sizes[] = {30, 32};
    const float hr[] = {0, 180}, sr[] = {0, 256};
    const float* ranges[] = {hr, sr};
    calcHist(&hsv, 1, channels, mask, ref, 2, sizes, ranges);
    double mx;
    minMaxLoc(ref, nullptr, &mx);
    ref /= mx;
    EXPECT_LT(norm(ours, ref, NORM_INF), 1e-6);
}

TEST(TrackStages, RatioIsFgOverSumAndZeroWhereEmpty) {
    Mat fg = (Mat_<float>(1, 4) << 1.f, 0.5f, 0.f, 0.f);
    Mat bg = (Mat_<float>(1, 4) << 0.f, 0.5f, 0.25f, 0.f);
    Mat r;
    foregroundRatio(fg, bg, r);
    EXPECT_FLOAT_EQ(r.at<float>(0), 1.f);
    EXPECT_FLOAT_EQ(r.at<float>(1), 0.5f);
    EXPECT_FLOAT_EQ(r.at<float>(2), 0.f);
    EXPECT_FLOAT_EQ(r.at<float>(3), 0.f);
}

TEST(TrackStages, BackProjectionLooksUpEveryPixel) {
    Mat ratio(30, 32, CV_32F);
    for (int h = 0; h < 30; ++h)
        for (int s = 0; s < 32; ++s)
            ratio.at<float>(h, s) = h * 100.f + s;
    Mat bgr(20, 20, CV_8UC3), hsv, prob;
    RNG(5).fill(bgr, RNG::UNIFORM, 0, 256);
    cvtColor(bgr, hsv, COLOR_BGR2HSV);
    backProjectRatio(hsv, ratio, prob);
    for (int y = 0; y < hsv.rows; ++y)
        for (int x = 0; x < hsv.cols; ++x) {
            const Vec3b p = hsv.at<Vec3b>(y, x);
            EXPECT_EQ(prob.at<float>(y, x), (p[0] * 30 / 180) * 100.f + p[1] * 32 / 256);
        }
}

// Reference morphology: min/max over the structuring element, pixels outside the image
// neutral (they never win).
static Mat naiveMorph(const Mat& m, const Mat& el, bool dilate) {
    Mat out(m.size(), CV_8UC1);
    const int ax = el.cols / 2, ay = el.rows / 2;
    for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x) {
            int v = dilate ? 0 : 255;
            for (int j = 0; j < el.rows; ++j)
                for (int i = 0; i < el.cols; ++i) {
                    if (!el.at<uchar>(j, i)) continue;
                    const int yy = y + j - ay, xx = x + i - ax;
                    if (yy < 0 || xx < 0 || yy >= m.rows || xx >= m.cols) continue;
                    const int p = m.at<uchar>(yy, xx);
                    v = dilate ? std::max(v, p) : std::min(v, p);
                }
            out.at<uchar>(y, x) = (uchar)v;
        }
    return out;
}

TEST(TrackStages, CleanMaskMatchesNaiveOpeningThenClosing) {
    Mat m(64, 72, CV_8UC1);
    RNG(6).fill(m, RNG::UNIFORM, 0, 2);
    m *= 255;
    circle(m, Point(36, 30), 18, Scalar(255), FILLED);
    const Mat e9 = getStructuringElement(MORPH_ELLIPSE, Size(9, 9));
    const Mat e13 = getStructuringElement(MORPH_ELLIPSE, Size(13, 13));
    Mat ref = naiveMorph(naiveMorph(m, e9, false), e9, true);  // opening
    ref = naiveMorph(naiveMorph(ref, e13, true), e13, false);  // closing
    Mat ours;
    cleanMask(m, ours, 9, 13, false);
    EXPECT_EQ(countNonZero(ours != ref), 0);
}

TEST(TrackStages, OpeningRemovesSpecksAndKeepsTheBall) {
    Mat m(100, 100, CV_8UC1, Scalar(0));
    circle(m, Point(50, 50), 25, Scalar(255), FILLED);
    Mat ball = m.clone();
    rectangle(m, Rect(5, 5, 4, 4), Scalar(255), FILLED);    // a 4x4 speck: gone
    line(m, Point(50, 80), Point(50, 95), Scalar(255), 2);  // a thin tail: gone
    Mat crack = m.clone();
    line(m, Point(30, 50), Point(70, 50), Scalar(0), 2);  // a thin crack through the ball: closed
    Mat cleaned;
    cleanMask(m, cleaned, 9, 13, true);
    EXPECT_GT(maskIoU(cleaned, ball), 0.98);
    EXPECT_EQ(cleaned.at<uchar>(6, 6), 0);
    EXPECT_EQ(cleaned.at<uchar>(90, 50), 0);
    EXPECT_EQ(cleaned.at<uchar>(50, 50), 255);
}

TEST(TrackStages, FillHolesFillsEnclosedOnly) {
    Mat m(50, 60, CV_8UC1, Scalar(0));
    circle(m, Point(20, 25), 15, Scalar(255), FILLED);
    circle(m, Point(20, 25), 5, Scalar(0), FILLED);  // enclosed hole → filled
    rectangle(m, Rect(40, 0, 20, 20), Scalar(255), FILLED);
    rectangle(m, Rect(45, 0, 5, 10), Scalar(0), FILLED);  // notch open to the border → kept
    Mat f;
    fillHoles(m, f);
    // Reference: background components not touching the border are holes.
    Mat bg = (m == 0), labels;
    const int n = connectedComponents(bg, labels, 4);
    std::vector<bool> touches(n, false);
    for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x)
            if (y == 0 || x == 0 || y == m.rows - 1 || x == m.cols - 1)
                touches[labels.at<int>(y, x)] = true;
    Mat ref = m.clone();
    for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x)
            if (bg.at<uchar>(y, x) && !touches[labels.at<int>(y, x)]) ref.at<uchar>(y, x) = 255;
    EXPECT_EQ(countNonZero(f != ref), 0);
    EXPECT_EQ(f.at<uchar>(25, 20), 255);
    EXPECT_EQ(f.at<uchar>(2, 47), 0);
}

TEST(TrackStages, InitialDiskIsMedianAndMeanExtent) {
    Mat m(100, 120, CV_8UC1, Scalar(0));
    rectangle(m, Rect(20, 30, 41, 21), Scalar(255), FILLED);  // x 20..60, y 30..50
    const Disk d = initialDisk(m);
    EXPECT_FLOAT_EQ(d.center.x, 40);
    EXPECT_FLOAT_EQ(d.center.y, 40);
    EXPECT_FLOAT_EQ(d.radius, 0.25f * (41 + 21));
    EXPECT_EQ(initialDisk(Mat(10, 10, CV_8UC1, Scalar(0))).radius, 0);
}

TEST(TrackStages, DiskFitRecoversNoisyDiskWithTailAndDent) {
    const Disk truth(Point2f(83.3f, 71.6f), 31.4f);
    Mat m;
    diskMask(Size(180, 150), truth, m);
    // A "tail" (a blob stuck to the disk), a "dent" (a bite out of it), and salt-and-pepper.
    ellipse(m, Point(120, 75), Size(18, 5), 0, 0, 360, Scalar(255), FILLED);
    circle(m, Point(70, 45), 9, Scalar(0), FILLED);
    RNG rng(7);
    for (int i = 0; i < 600; ++i) {
        const int x = rng.uniform(0, m.cols), y = rng.uniform(0, m.rows);
        m.at<uchar>(y, x) = 255 - m.at<uchar>(y, x);
    }
    const Disk d = fitDisk(m);
    EXPECT_LT(norm(d.center - truth.center), 1.0) << d.center << " r " << d.radius;
    EXPECT_LT(std::abs(d.radius - truth.radius), 1.0);
}

TEST(TrackStages, DiskFitIsALocalMaximumOfTheReferenceQuality) {
    Mat m;
    diskMask(Size(90, 80), Disk(Point2f(40.2f, 37.9f), 20.3f), m);
    rectangle(m, Rect(55, 30, 25, 8), Scalar(255), FILLED);
    DiskFitParams p;
    p.min_step = 1;
    const Disk init(Point2f(30, 30), 10);
    const Disk d = fitDisk(m, &init, p);
    const double q = diskQuality(m, d);
    const float dx[] = {1, -1, 0, 0, 0, 0}, dy[] = {0, 0, 1, -1, 0, 0}, dr[] = {0, 0, 0, 0, 1, -1};
    for (int k = 0; k < 6; ++k)
        EXPECT_LE(diskQuality(m, Disk(d.center + Point2f(dx[k], dy[k]), d.radius + dr[k])), q);
    // Unknown votes (0) do not count either way.
    Mat votes(m.size(), CV_8SC1);
    for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x)
            votes.at<schar>(y, x) = m.at<uchar>(y, x) ? 1 : -1;
    votes(Rect(0, 0, 10, 10)).setTo(0);
    EXPECT_EQ(diskQuality(votes, d), diskQuality(m, d) - 100);  // those pixels agreed before
}

TEST(TrackStages, DiskMaskAndIoU) {
    Mat a, b;
    diskMask(Size(200, 200), Disk(Point2f(100, 100), 50), a);
    EXPECT_NEAR(countNonZero(a), CV_PI * 2500, 60);
    diskMask(Size(200, 200), Disk(Point2f(100, 100), 50), b);
    EXPECT_DOUBLE_EQ(maskIoU(a, b), 1.0);
    diskMask(Size(200, 200), Disk(Point2f(300, 300), 10), b);
    EXPECT_DOUBLE_EQ(maskIoU(a, b), 0.0);
}
