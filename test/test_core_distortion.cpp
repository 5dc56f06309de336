// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Camera::k1, one-coefficient radial lens distortion: the point maps against OpenCV's own
// projectPoints / undistortPoints, the image warps, and k1 in the scene and camera-path files.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>

#include "vbme_test_util.hpp"

namespace {

using namespace cv;
using namespace cv::vbme;

Camera lens(double k1, Size size = Size(160, 120), double f = 96) {
    Camera c = Camera::fromFocal(f, size);
    c.K(1, 1) = 1.02 * f;  // fx ≠ fy: the normalised coordinates are K⁻¹ p, not (p − c) / f
    c.k1 = k1;
    return c;
}

// distortPixel is OpenCV's model with distCoeffs (k1, 0, 0, 0) (an independent implementation)
// and undistortPixel inverts it; barrel distortion beyond its fold has no undistorted point.
TEST(CoreDistortion, PixelMapsMatchOpenCVAndInvert) {
    for (double k1 : {-0.25, 0.15}) {
        const Camera c = lens(k1);
        const std::vector<double> dist = {k1, 0, 0, 0};
        double worst_cv = 0, worst_inv = 0;
        for (int y = -20; y <= 140; y += 10)
            for (int x = -20; x <= 180; x += 10) {
                const Vec3d xn = c.K.inv() * Vec3d(x, y, 1);
                std::vector<Point3d> X = {Point3d(xn[0], xn[1], 1)};
                std::vector<Point2d> p;
                projectPoints(X, Vec3d(0, 0, 0), Vec3d(0, 0, 0), Mat(c.K), dist, p);
                const Point2d d = c.distortPixel(Point2d(x, y));
                worst_cv = std::max(worst_cv, norm(d - p[0]));
                // invertible up to the fold of barrel distortion (r² < 1 / (3 |k1|))
                if (k1 > 0 || xn[0] * xn[0] + xn[1] * xn[1] < 0.99 / (3 * -k1))
                    worst_inv = std::max(worst_inv, norm(c.undistortPixel(d) - Point2d(x, y)));
            }
        EXPECT_LT(worst_cv, 1e-9) << "k1 " << k1;
        EXPECT_LT(worst_inv, 1e-9) << "k1 " << k1;
    }
    // barrel: x_d = r (1 − 0.25 r²) reaches at most (2/3) / sqrt(0.75) = 0.7698 at r = 1.1547
    const Camera c = lens(-0.25);
    const Point2d inside = c.distortPixel(Point2d(79.5 + 1.1 * 96, 59.5));
    EXPECT_TRUE(std::isfinite(c.undistortPixel(inside).x));
    const Point2d beyond(79.5 + 0.78 * 96, 59.5);
    EXPECT_TRUE(std::isnan(c.undistortPixel(beyond).x));
    // k1 = 0 is the identity
    const Camera pin = lens(0);
    EXPECT_EQ(pin.distortPixel(Point2d(3.25, 7.5)), Point2d(3.25, 7.5));
    EXPECT_EQ(pin.undistortPixel(Point2d(3.25, 7.5)), Point2d(3.25, 7.5));
    // projectDistorted = distortPixel ∘ project
    Camera posed = lens(-0.2);
    posed.t = Vec3d(0.1, -0.2, 0.3);
    const Vec3d X(0.4, 0.3, 2.0);
    EXPECT_LT(norm(posed.projectDistorted(X) - posed.distortPixel(posed.project(X))), 1e-12);
}

// The image warps against OpenCV's initUndistortRectifyMap + remap (which undistorts with the
// same model): equal up to interpolation; distorting back restores the frame where both warps
// stay inside it.
TEST(CoreDistortion, ImageWarpsMatchOpenCVAndRoundTrip) {
    const Camera c = lens(-0.22);
    Mat img(c.image_size, CV_32FC3);
    for (int y = 0; y < img.rows; ++y)
        for (int x = 0; x < img.cols; ++x)
            img.at<Vec3f>(y, x) = Vec3f(std::sin(x * 0.11f) + 1, std::cos(y * 0.13f) + 1,
                                        std::sin((x + y) * 0.07f) + 1);
    Mat und, mx, my, ref;
    undistortImageK1(img, und, c);
    initUndistortRectifyMap(Mat(c.K), std::vector<double>{c.k1, 0, 0, 0}, Mat(), Mat(c.K),
                            img.size(), CV_32FC1, mx, my);
    remap(img, ref, mx, my, INTER_LINEAR, BORDER_REPLICATE);
    const Rect inner(8, 8, img.cols - 16, img.rows - 16);
    EXPECT_LT(norm(und(inner), ref(inner), NORM_INF), 1e-3);
    Mat back;
    distortImageK1(und, back, c);
    // barrel: the undistorted frame holds the centre; the distorted frame's edge (r beyond the
    // pinhole image) comes back black
    Mat err;
    absdiff(back, img, err);
    double centre_err = 0;
    minMaxLoc(err(Rect(40, 30, 80, 60)).reshape(1), nullptr, &centre_err);
    EXPECT_LT(centre_err, 0.02);
    EXPECT_EQ(back.at<Vec3f>(0, 0), Vec3f(0, 0, 0));
    // in place, and k1 = 0 copies
    Mat same = img.clone();
    undistortImageK1(same, same, lens(0));
    EXPECT_EQ(norm(same, img, NORM_INF), 0);
    Mat w = img.clone();
    undistortImageK1(w, w, c);
    EXPECT_EQ(norm(w, und, NORM_INF), 0);
}

// A barrel lens shows more near the frame's edges than the pinhole image of the same size and
// K: rendered over lensCoverCamera (enlarged) and warped, a picture fills the whole frame,
// where the same-size warp leaves its edges black. Oracle: an analytic picture of the viewing
// direction, evaluated at OpenCV's undistortPoints of each frame pixel.
TEST(CoreDistortion, CoverCameraFillsTheBarrelFrame) {
    const Camera c = lens(-0.22);
    const Camera cover = lensCoverCamera(c);
    auto f = [](double x, double y) {  // of the normalised undistorted coordinates
        return Vec3f((float)(1.5 + std::sin(7 * x)), (float)(1.5 + std::cos(5 * y)),
                     (float)(1.5 + std::sin(4 * (x + y))));
    };
    auto picture = [&](const Camera& cam) {
        Mat img(cam.image_size, CV_32FC3);
        const Matx33d Ki = cam.K.inv();
        for (int y = 0; y < img.rows; ++y)
            for (int x = 0; x < img.cols; ++x) {
                const Vec3d n = Ki * Vec3d(x, y, 1);
                img.at<Vec3f>(y, x) = f(n[0], n[1]);
            }
        return img;
    };
    std::vector<Point2d> pd, pu;
    for (int y = 0; y < c.image_size.height; ++y)
        for (int x = 0; x < c.image_size.width; ++x)
            pd.emplace_back(x, y);
    undistortPoints(pd, pu, Mat(c.K), std::vector<double>{c.k1, 0, 0, 0}, noArray(), noArray(),
                    TermCriteria(TermCriteria::COUNT + TermCriteria::EPS, 100, 1e-12));
    Mat warped, same_size;
    distortImageK1(picture(cover), warped, c, cover);
    distortImageK1(picture(c), same_size, c);
    ASSERT_EQ(warped.size(), c.image_size);
    int black = 0, black_same = 0, n = 0;
    double worst = 0;
    for (size_t i = 0; i < pd.size(); ++i) {
        const int x = (int)pd[i].x, y = (int)pd[i].y;
        if (!std::isfinite(c.undistortPixel(pd[i]).x)) continue;  // beyond the fold
        ++n;
        const Vec3f w = warped.at<Vec3f>(y, x);
        black += w == Vec3f(0, 0, 0);
        black_same += same_size.at<Vec3f>(y, x) == Vec3f(0, 0, 0);
        worst = std::max(worst, norm(Vec3d(w) - Vec3d(f(pu[i].x, pu[i].y)), NORM_INF));
    }
    std::printf(
        "barrel k1 %.2f, %dx%d frame: cover %dx%d; black pixels %d (same-size render %d) "
        "of %d; worst error %.4f\n",
        c.k1, c.image_size.width, c.image_size.height, cover.image_size.width,
        cover.image_size.height, black, black_same, n, worst);
    EXPECT_EQ(black, 0);
    EXPECT_GT(black_same, 100);
    EXPECT_LT(worst, 0.02);
    // the same pose and focal lengths; the principal point moved by whole pixels
    EXPECT_EQ(cover.R, c.R);
    EXPECT_EQ(cover.K(0, 0), c.K(0, 0));
    EXPECT_EQ(cover.K(1, 1), c.K(1, 1));
    const double dx = cover.K(0, 2) - c.K(0, 2), dy = cover.K(1, 2) - c.K(1, 2);
    EXPECT_EQ(dx, std::round(dx));
    EXPECT_EQ(dy, std::round(dy));
    // undistorting the frame into the cover camera puts each ray where the cover renders it
    Mat frame(c.image_size, CV_32FC3), und;
    for (size_t i = 0; i < pd.size(); ++i)
        frame.at<Vec3f>((int)pd[i].y, (int)pd[i].x) = f(pu[i].x, pu[i].y);
    undistortImageK1(frame, und, c, cover);
    ASSERT_EQ(und.size(), cover.image_size);
    const Mat truth = picture(cover);
    const Rect centre((int)dx + 8, (int)dy + 8, c.image_size.width - 16, c.image_size.height - 16);
    EXPECT_LT(norm(und(centre), truth(centre), NORM_INF), 0.02);
    // no lens, or pincushion: the camera itself (k1 > 0 sees less than the pinhole image)
    EXPECT_EQ(lensCoverCamera(lens(0)).image_size, lens(0).image_size);
    EXPECT_EQ(lensCoverCamera(lens(0.15)).K, lens(0.15).K);
}

// k1 is written to the scene file's camera and the camera path, only when not 0 (so files of
// undistorted footage stay as they were), and read back.
TEST(CoreDistortion, SceneAndCameraPathCarryK1) {
    vbme_test::ScratchDir dir;
    Scene s;
    s.image_size = Size(160, 120);
    s.camera = lens(-0.1834);
    s.camera.K(1, 1) = s.camera.K(0, 0);
    s.write(dir / "k1.yml");
    EXPECT_DOUBLE_EQ(Scene::read(dir / "k1.yml").camera.k1, -0.1834);
    s.camera.k1 = 0;
    s.write(dir / "pin.yml");
    std::ifstream in(dir / "pin.yml");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text.find("k1"), std::string::npos);
    EXPECT_EQ(Scene::read(dir / "pin.yml").camera.k1, 0);

    CameraPath p;
    p.K = s.camera.K;
    p.k1 = 0.07;
    p.image_size = s.image_size;
    p.frames.resize(2);
    p.frames[1].index = 1;
    p.write(dir / "path.yml");
    const CameraPath q = CameraPath::read(dir / "path.yml");
    EXPECT_DOUBLE_EQ(q.k1, 0.07);
    EXPECT_DOUBLE_EQ(q.camera(1).k1, 0.07);
    // an implausible value is refused with the field's name
    {
        std::ofstream f(dir / "bad.yml");
        f << "%YAML:1.0\nimage_size: [160, 120]\ncamera: { K: [[96, 0, 79.5], [0, 96, 59.5], "
             "[0, 0, 1]], k1: 40 }\n";
    }
    try {
        Scene::read(dir / "bad.yml");
        ADD_FAILURE() << "k1 40 accepted";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("camera.k1"), std::string::npos) << e.err;
    }
}

}  // namespace
