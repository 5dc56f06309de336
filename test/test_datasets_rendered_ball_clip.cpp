// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// RenderedBallClip: the rendered clip of the material-editing demo is deterministic, its
// ground truth agrees with the pixels (renderer's coverage mask, colour threshold) and the
// colour tracker follows the ball through it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/datasets/rendered_ball_clip.hpp>
#include <opencv2/vbme/render.hpp>
#include <opencv2/vbme/track.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

RenderedBallClip::Params smallClip(Size size, int frames, int spp) {
    RenderedBallClip::Params p;
    p.size = size;
    p.frames = frames;
    p.spp = spp;
    return p;
}

// The ball by colour alone: saturated orange (OpenCV hue ≤ 25 or ≥ 170, S > 0.45, V > 0.1).
Mat colourMask(const Mat& bgr) {
    Mat hsv, a, b, m;
    cvtColor(bgr, hsv, COLOR_BGR2HSV);
    inRange(hsv, Scalar(0, 115, 25), Scalar(25, 255, 255), a);
    inRange(hsv, Scalar(170, 115, 25), Scalar(180, 255, 255), b);
    bitwise_or(a, b, m);
    return m;
}

}  // namespace

TEST(DatasetsRenderedBallClip, RendersAreDeterministic) {
    const RenderedBallClip::Params p = smallClip(Size(160, 120), 3, 4);
    const RenderedBallClip a(p), b(p);
    const Mat fa = a.frame(1), fb = b.frame(1);
    ASSERT_EQ(fa.type(), CV_8UC3);
    ASSERT_EQ(fa.size(), p.size);
    EXPECT_EQ(norm(fa, fb, NORM_INF), 0.0) << "two renders of one frame differ";
    // The ball moves: another frame differs.
    EXPECT_GT(norm(a.frame(2), fa, NORM_L1), 0.0);
    // A different seed gives different noise.
    RenderedBallClip::Params q = p;
    q.seed = 7;
    EXPECT_GT(norm(RenderedBallClip(q).frame(1), fa, NORM_L1), 0.0);
}

TEST(DatasetsRenderedBallClip, TruthDiskMatchesRenderedSilhouette) {
    // Oracle: the renderer's coverage mask (fraction of camera rays whose first hit is the ball),
    // an exact silhouette; the disk differs from it by the ellipse's flattening (< 0.5 px).
    const RenderedBallClip clip(smallClip(Size(320, 240), 9, 1));
    for (int i : {0, 8}) {
        const Scene s = clip.scene(i);
        const Ptr<RenderScene> rs = RenderScene::create(s);
        Renderer::Params rp = Renderer::Params::fromScene(s.render);
        rp.spp = 8;
        rp.max_depth = 1;
        RenderImages out;
        Renderer::create(rp)->render(*rs, s.camera, out);
        const Mat rendered = out.mask >= 0.5f;
        Mat truth;
        diskMask(s.image_size, clip.truthDisk(i), truth);
        const double iou = maskIoU(rendered, truth);
        std::printf("frame %d: disk (%.1f, %.1f) r %.2f, silhouette vs disk %.3f px, IoU %.4f\n", i,
                    clip.truthDisk(i).center.x, clip.truthDisk(i).center.y,
                    clip.truthDisk(i).radius, clip.truthDiskError(i), iou);
        EXPECT_GT(iou, 0.98) << "frame " << i;
        EXPECT_LT(clip.truthDiskError(i), 0.5) << "frame " << i;
    }
    // The light in camera coordinates is the world direction rotated by cam_from_world.
    const Vec3d l = clip.scene(0).camera.R * clip.params().to_light;
    EXPECT_LT(norm(clip.truthLightDirCamera() - l / norm(l)), 1e-12);
    EXPECT_NEAR(clip.focal(), 0.5 * 320 / std::tan(CV_PI / 6), 1e-9);  // 60° horizontal field
}

TEST(DatasetsRenderedBallClip, BallShadingPointsToTheKeyLight) {
    // Oracle: the rendered shading of the ball. On its lit part, radiance / albedo is
    // E/π · (n · l) plus a slowly varying sky term; a least-squares fit of a·n + b over the
    // brightly lit pixels (normals from the renderer's AOV) recovers the light direction.
    const RenderedBallClip clip(smallClip(Size(160, 120), 1, 16));
    const Scene s = clip.scene(0);
    const Ptr<RenderScene> rs = RenderScene::create(s);
    RenderImages out;
    Renderer::create(Renderer::Params::fromScene(s.render))->render(*rs, s.camera, out);
    std::vector<float> shade;
    std::vector<Vec3f> normal;
    for (int y = 0; y < out.color.rows; ++y)
        for (int x = 0; x < out.color.cols; ++x) {
            if (out.mask.at<float>(y, x) < 1.f) continue;  // whole pixels of the ball only
            const float a = out.albedo.at<Vec3f>(y, x)[2];
            if (a <= 0) continue;
            shade.push_back(out.color.at<Vec3f>(y, x)[2] / a);  // red channel
            normal.push_back(out.normal.at<Vec3f>(y, x));
        }
    ASSERT_GT(shade.size(), 100u);
    const float top = *std::max_element(shade.begin(), shade.end());
    Mat A(0, 4, CV_64F), rhs(0, 1, CV_64F);
    for (size_t k = 0; k < shade.size(); ++k)
        if (shade[k] > 0.5f * top) {
            const Vec3f& n = normal[k];
            A.push_back(Mat(Matx14d(n[0], n[1], n[2], 1)));
            rhs.push_back(double(shade[k]));
        }
    Mat sol;
    ASSERT_TRUE(solve(A, rhs, sol, DECOMP_SVD));
    const Vec3d l(sol.at<double>(0), sol.at<double>(1), sol.at<double>(2));
    const Vec3d truth = clip.params().to_light / norm(clip.params().to_light);
    const double angle = std::acos(std::min(1.0, l.dot(truth) / norm(l))) * 180 / CV_PI;
    // E/π from the fit against the scene's key light (irradiance 2.8, warm white: red 1.0).
    std::printf(
        "shading fit over %d pixels: light (%.3f, %.3f, %.3f), %.2f deg from to_light, "
        "E/pi %.3f (key light %.3f)\n",
        A.rows, l[0] / norm(l), l[1] / norm(l), l[2] / norm(l), angle, norm(l), 2.8 / CV_PI);
    EXPECT_LT(angle, 5.0);
    EXPECT_NEAR(norm(l), 2.8 / CV_PI, 0.15 * 2.8 / CV_PI);
}

TEST(DatasetsRenderedBallClip, BallSeparableByColourWhereTheTruthSays) {
    const RenderedBallClip clip(smallClip(Size(320, 240), 9, 4));
    for (int i : {0, 4, 8}) {
        const Mat f = clip.frame(i);
        Mat truth;
        diskMask(f.size(), clip.truthDisk(i), truth);
        const Mat colour = colourMask(f);
        const double iou = maskIoU(colour, truth);
        // Nothing of that colour away from the ball (the floor under it is tinted by light
        // bounced off it: a margin of half the radius).
        Disk wide = clip.truthDisk(i);
        wide.radius = wide.radius * 1.5f + 2;
        Mat near;
        diskMask(f.size(), wide, near);
        const int outside = countNonZero(colour & ~near);
        std::printf("frame %d: colour-threshold IoU vs truth disk %.4f, %d stray pixels\n", i, iou,
                    outside);
        EXPECT_GE(iou, 0.95) << "frame " << i;
        EXPECT_LE(outside, 2) << "frame " << i;
    }
}

TEST(DatasetsRenderedBallClip, TrackerFollowsTheBall) {
    const RenderedBallClip::Params p = smallClip(Size(160, 120), 8, 4);
    const RenderedBallClip clip(p);
    Mat mask;
    diskMask(p.size, clip.truthDisk(0), mask);
    Ptr<ObjectTracker> tracker = ObjectTracker::create();
    tracker->init(clip.frame(0), mask);
    double worst = 1, sum = 0, err = 0;
    for (int i = 1; i < p.frames; ++i) {
        Mat got, truth;
        const ObjectTracker::Result r = tracker->update(clip.frame(i), got);
        diskMask(p.size, clip.truthDisk(i), truth);
        const double iou = maskIoU(got, truth);
        worst = std::min(worst, iou);
        sum += iou;
        err = std::max(err, (double)norm(r.disk.center - clip.truthDisk(i).center));
        EXPECT_TRUE(r.found) << "frame " << i;
    }
    std::printf("tracker vs truth: mean IoU %.3f, worst %.3f, worst centre error %.2f px\n",
                sum / (p.frames - 1), worst, err);
    EXPECT_GT(worst, 0.85);
    EXPECT_LT(err, 1.5);
}

TEST(DatasetsRenderedBallClip, WritesLosslessVideoAndMask) {
    vbme_test::ScratchDir dir;
    const RenderedBallClip::Params p = smallClip(Size(96, 72), 3, 2);
    const RenderedBallClip clip(p);
    const std::string video = dir / "clip.mkv", mask = dir / "first_mask.png";
    clip.write(video, mask);
    VideoReader in(video);
    EXPECT_EQ(in.frameSize(), p.size);
    Mat f;
    int n = 0;
    while (in.read(f)) {
        ASSERT_LT(n, p.frames);
        EXPECT_EQ(norm(f, clip.frame(n), NORM_INF), 0.0) << "frame " << n << " not lossless";
        ++n;
    }
    EXPECT_EQ(n, p.frames);
    Mat m = imread(mask, IMREAD_UNCHANGED), truth;
    ASSERT_FALSE(m.empty());
    diskMask(p.size, clip.truthDisk(0), truth);
    EXPECT_EQ(norm(m, truth, NORM_INF), 0.0);
}

TEST(DatasetsRenderedBallClip, RejectsBadParams) {
    RenderedBallClip::Params p;
    p.frames = 0;
    EXPECT_THROW(RenderedBallClip{p}, cv::Exception);
    p = RenderedBallClip::Params();
    p.to_light = Vec3d(0, 1, -0.2);  // below the floor
    EXPECT_THROW(RenderedBallClip{p}, cv::Exception);
    const RenderedBallClip clip(smallClip(Size(64, 48), 2, 1));
    EXPECT_THROW(clip.scene(2), cv::Exception);
}
