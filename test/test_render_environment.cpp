// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Environment maps: Blender orientation, pixel ↔ direction, importance sampling (pdf, mean,
// variance), loading .hdr/.exr, and the image-disk → two-hemispheres environment.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render/environment.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

const float kPi = 3.14159265358979323846f;

Vec3f uniformSphere(float u0, float u1) {
    const float z = 1 - 2 * u0, r = std::sqrt(std::max(0.f, 1 - z * z)), phi = 2 * kPi * u1;
    return Vec3f(r * std::cos(phi), r * std::sin(phi), z);
}
float lum(const Vec3f& c) {
    return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
}

// A smooth sky (BGR) with a small bright "sun" of a few pixels.
Mat skyWithSun(int w, int h) {
    Mat img(h, w, CV_32FC3);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float v = (y + 0.5f) / h;
            img.at<Vec3f>(y, x) = Vec3f(0.8f - 0.5f * v, 0.5f, 0.2f + 0.3f * v);  // B, G, R
        }
    img(Rect(w / 3, h / 5, 3, 2)).setTo(Scalar(500, 800, 1000));
    return img;
}

// ∫ luminance dω of an environment by a fine midpoint rule in (θ, φ).
double integrateLuminance(const EnvironmentMap& env, int nt = 720, int np = 1440) {
    double s = 0;
    for (int i = 0; i < nt; i++) {
        const float t = (i + 0.5f) * kPi / nt;
        for (int j = 0; j < np; j++) {
            const float p = (j + 0.5f) * 2 * kPi / np;
            const Vec3f d(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
            s += lum(env.eval(d)) * std::sin(t);
        }
    }
    return s * (kPi / nt) * (2 * kPi / np);
}

Matx33f rotZ(float a) {
    return Matx33f(std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1);
}
Matx33f rotX(float a) {
    return Matx33f(1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a));
}

}  // namespace

TEST(RenderEnvironment, BlenderOrientation) {
    const int w = 64, h = 32;
    EnvironmentMap env(Mat(h, w, CV_32FC3, Scalar(1, 1, 1)));
    // Pixel centres at integers: the image centre ((w−1)/2, (h−1)/2) looks along +x.
    const Point2f c = env.directionToPixel(Vec3f(1, 0, 0));
    EXPECT_NEAR(c.x, (w - 1) / 2.f, 1e-4);
    EXPECT_NEAR(c.y, (h - 1) / 2.f, 1e-4);
    // Top edge is straight up, bottom edge straight down.
    EXPECT_NEAR(env.directionToPixel(Vec3f(0, 0, 1)).y, -0.5f, 1e-4);
    EXPECT_NEAR(env.directionToPixel(Vec3f(0, 0, -1)).y, h - 0.5f, 1e-4);
    // +y is a quarter width to the left of the centre, −y a quarter to the right, −x at the seam.
    EXPECT_NEAR(env.directionToPixel(Vec3f(0, 1, 0)).x, w / 4.f - 0.5f, 1e-4);
    EXPECT_NEAR(env.directionToPixel(Vec3f(0, -1, 0)).x, 3 * w / 4.f - 0.5f, 1e-4);
    const float seam = env.directionToPixel(Vec3f(-1, 1e-6f, 0)).x;
    EXPECT_TRUE(std::abs(seam + 0.5f) < 1e-3 || std::abs(seam - (w - 0.5f)) < 1e-3) << seam;
    // Looking at the pixel: a marked pixel is seen in its direction, RGB order.
    Mat img(h, w, CV_32FC3, Scalar(0, 0, 0));
    img.at<Vec3f>(10, 20) = Vec3f(0.25f, 0.5f, 1.f);  // BGR
    EnvironmentMap marked(img);
    const Vec3f v = marked.eval(marked.pixelToDirection(Point2f(20, 10)));
    EXPECT_NEAR(v[0], 1.f, 1e-5);
    EXPECT_NEAR(v[2], 0.25f, 1e-5);
    EXPECT_FALSE(marked.isConstant());
}

TEST(RenderEnvironment, PixelDirectionRoundTripWithRotation) {
    const int w = 200, h = 100;
    const Matx33f R = rotZ(0.7f) * rotX(0.3f);
    EnvironmentMap env(Mat(h, w, CV_32FC3, Scalar(1, 1, 1)), R);
    RNG rng(1);
    for (int i = 0; i < 2000; i++) {
        const Vec3f d = uniformSphere(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f));
        const Point2f p = env.directionToPixel(d);
        EXPECT_NEAR(norm(env.pixelToDirection(p) - d), 0, 2e-4) << d;
        const Point2f q(rng.uniform(-0.5f, w - 0.5f), rng.uniform(-0.5f, h - 0.5f));
        const Point2f q2 = env.directionToPixel(env.pixelToDirection(q));
        EXPECT_NEAR(q2.y, q.y, 2e-2);
        if (q.y > 1 && q.y < h - 2) {
            EXPECT_NEAR(q2.x, q.x, 2e-2);
        }
    }
    // world_from_env rotates the map: the map's +x (image centre) appears at world R·x.
    const Vec3f centre = env.pixelToDirection(Point2f((w - 1) / 2.f, (h - 1) / 2.f));
    EXPECT_NEAR(norm(centre - R * Vec3f(1, 0, 0)), 0, 1e-5);
}

TEST(RenderEnvironment, PdfIntegratesToOneAndMatchesSample) {
    const Matx33f R = rotZ(0.4f) * rotX(-0.2f);
    EnvironmentMap env(skyWithSun(128, 64), R, 2.f);
    // ∫ pdf dω over the sphere (midpoint rule).
    double s = 0;
    const int nt = 512, np = 1024;
    for (int i = 0; i < nt; i++) {
        const float t = (i + 0.5f) * kPi / nt;
        for (int j = 0; j < np; j++) {
            const float p = (j + 0.5f) * 2 * kPi / np;
            const Vec3f d(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
            s += env.pdf(d) * std::sin(t);
        }
    }
    EXPECT_NEAR(s * (kPi / nt) * (2 * kPi / np), 1.0, 5e-3);
    RNG rng(2);
    for (int i = 0; i < 5000; i++) {
        Vec3f d;
        float pdf;
        const Vec3f L = env.sample(Vec2f(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f)), d, pdf);
        ASSERT_NEAR(norm(d), 1, 1e-5);
        ASSERT_GT(pdf, 0.f);
        ASSERT_NEAR(pdf, env.pdf(d), 2e-3 * pdf);
        for (int c = 0; c < 3; c++)
            ASSERT_NEAR(L[c], env.eval(d)[c], 1e-3 * (1 + L[c]));
    }
}

TEST(RenderEnvironment, ImportanceSamplingIsUnbiasedAndReducesVariance) {
    EnvironmentMap env(skyWithSun(128, 64), rotZ(1.f));
    const double exact = integrateLuminance(env);
    const int n = 100000;
    RNG rng(3);
    double su = 0, su2 = 0, si = 0, si2 = 0;
    for (int i = 0; i < n; i++) {
        const Vec3f d = uniformSphere(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f));
        const double e = lum(env.eval(d)) * 4 * CV_PI;
        su += e;
        su2 += e * e;
        Vec3f di;
        float pdf;
        const Vec3f L = env.sample(Vec2f(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f)), di, pdf);
        const double ei = pdf > 0 ? lum(L) / pdf : 0.0;
        si += ei;
        si2 += ei * ei;
    }
    const double mu = su / n, mi = si / n;
    const double vu = su2 / n - mu * mu, vi = si2 / n - mi * mi;
    const double sem_u = std::sqrt(vu / n), sem_i = std::sqrt(vi / n);
    EXPECT_NEAR(mu, exact, 4 * sem_u) << "uniform";
    EXPECT_NEAR(mi, exact, 4 * sem_i + 1e-3 * exact) << "importance";
    EXPECT_LT(vi, 0.05 * vu) << "importance sampling should cut the variance by far";
}

TEST(RenderEnvironment, ConstantEnvironment) {
    EnvironmentMap env(Vec3f(0.5f, 1.f, 2.f));
    EXPECT_TRUE(env.isConstant());
    EXPECT_EQ(env.eval(Vec3f(0, 0, 1)), Vec3f(0.5f, 1.f, 2.f));
    EXPECT_NEAR(env.pdf(Vec3f(1, 0, 0)), 1 / (4 * CV_PI), 1e-7);
    Vec3f d;
    float pdf;
    EXPECT_EQ(env.sample(Vec2f(0.2f, 0.9f), d, pdf), Vec3f(0.5f, 1.f, 2.f));
    EXPECT_NEAR(norm(d), 1, 1e-6);
    EXPECT_NEAR(pdf, 1 / (4 * CV_PI), 1e-7);
    // Copy and move keep the content.
    EnvironmentMap copy(env);
    EnvironmentMap moved(std::move(env));
    EXPECT_EQ(copy.eval(Vec3f(1, 0, 0)), moved.eval(Vec3f(1, 0, 0)));
}

TEST(RenderEnvironment, LoadsHdrAndExr) {
    vbme_test::ScratchDir dir;
    Mat img = skyWithSun(64, 32);
    ASSERT_TRUE(imwrite(dir / "sky.hdr", img));
    ASSERT_TRUE(imwrite(dir / "sky.exr", img));
    for (const std::string name : {"sky.hdr", "sky.exr"}) {
        EnvironmentMap env = EnvironmentMap::load(dir / name, Matx33f::eye(), 0.5f);
        for (Point p : {Point(3, 4), Point(22, 7), Point(40, 30)}) {
            const Vec3f v = env.eval(env.pixelToDirection(Point2f((float)p.x, (float)p.y)));
            const Vec3f bgr = img.at<Vec3f>(p);
            // RGBE (.hdr) keeps ~1 % precision; EXR float exactly.
            for (int c = 0; c < 3; c++)
                EXPECT_NEAR(v[c], 0.5f * bgr[2 - c], 0.01f * bgr[2 - c]) << name;
        }
    }
    // A single-channel EXR (luminance) is grey.
    Mat grey(16, 32, CV_32FC1, Scalar(3.f));
    ASSERT_TRUE(imwrite(dir / "grey.exr", grey));
    const Vec3f g = EnvironmentMap::load(dir / "grey.exr").eval(Vec3f(0, 0, 1));
    EXPECT_NEAR(g[0], 3.f, 1e-5);
    EXPECT_NEAR(g[2], 3.f, 1e-5);
    EXPECT_THROW(EnvironmentMap::load(dir / "missing.hdr"), cv::Exception);
    EXPECT_THROW(EnvironmentMap::load(dir / "missing.exr"), cv::Exception);
    // An 8-bit image is not an HDR environment.
    ASSERT_TRUE(imwrite(dir / "ldr.png", Mat(8, 16, CV_8UC3, Scalar(10, 20, 30))));
    EXPECT_THROW(EnvironmentMap::load(dir / "ldr.png"), cv::Exception);
}

// ------------------------------------------------------------------------------------------
// Image disk → two hemispheres

namespace {

// A smooth background whose colour encodes the pixel: B = x/100, G = y/100, R = 1.
Mat codedBackground(int w, int h) {
    Mat img(h, w, CV_32FC3);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            img.at<Vec3f>(y, x) = Vec3f(x / 100.f, y / 100.f, 1.f);
    return img;
}
// Pixel coordinates read back from an environment value (RGB) of codedBackground.
Point2f decode(const Vec3f& rgb) {
    return Point2f(rgb[2] * 100.f, rgb[1] * 100.f);
}

// Camera looking along world +y, upright: x_cam = x_world, y_cam = −z_world, z_cam = y_world.
const Matx33f kCamFromWorld(1, 0, 0, 0, 0, -1, 0, 1, 0);

}  // namespace

TEST(RenderEnvironment, ImageDiskForwardDirectionIsTheDiskCentre) {
    const Mat bg = codedBackground(400, 300);
    const Point2f centre(210, 140);
    const float radius = 100;
    const Mat eq = imageDiskToEnvironment(bg, centre, radius, kCamFromWorld, Size(512, 256));
    ASSERT_EQ(eq.type(), CV_32FC3);
    ASSERT_EQ(eq.size(), Size(512, 256));
    EnvironmentMap env(eq);
    // Straight ahead of the camera (world +y) → disk centre.
    const Point2f p = decode(env.eval(Vec3f(0, 1, 0)));
    EXPECT_NEAR(p.x, centre.x, 1.0);
    EXPECT_NEAR(p.y, centre.y, 1.0);
    // θ off the axis → radius·θ/(π/2) from the centre in the matching image direction:
    // camera-right (world +x), camera-up (world +z, image −y).
    for (float th : {0.3f, 0.8f, 1.2f}) {
        const float r = radius * th / (kPi / 2);
        const Point2f right = decode(env.eval(Vec3f(std::sin(th), std::cos(th), 0)));
        EXPECT_NEAR(right.x, centre.x + r, 1.5) << th;
        EXPECT_NEAR(right.y, centre.y, 1.5) << th;
        const Point2f up = decode(env.eval(Vec3f(0, std::cos(th), std::sin(th))));
        EXPECT_NEAR(up.x, centre.x, 1.5) << th;
        EXPECT_NEAR(up.y, centre.y - r, 1.5) << th;
    }
    // Straight up (90° from the axis) is the top of the disk.
    const Point2f top = decode(env.eval(Vec3f(0, 0, 1)));
    EXPECT_NEAR(top.x, centre.x, 2.0);
    EXPECT_NEAR(top.y, centre.y - radius, 2.0);
}

TEST(RenderEnvironment, ImageDiskBackHemisphereIsTheMirrorImage) {
    const Mat bg = codedBackground(400, 300);
    const Mat eq =
        imageDiskToEnvironment(bg, Point2f(200, 150), 120, kCamFromWorld, Size(512, 256));
    EnvironmentMap env(eq);
    RNG rng(7);
    int n = 0;
    for (int i = 0; i < 500; i++) {
        const Vec3f d = uniformSphere(rng.uniform(0.f, 1.f), rng.uniform(0.f, 1.f));
        // Reflection through the camera's image plane (flip the camera-z component).
        Vec3f c = kCamFromWorld * d;
        if (std::abs(c[2]) < 0.05f || std::abs(c[1]) > 0.95f) continue;  // seam / poles
        c[2] = -c[2];
        const Vec3f dm = kCamFromWorld.t() * c;
        const Point2f a = decode(env.eval(d)), b = decode(env.eval(dm));
        EXPECT_NEAR(a.x, b.x, 1.5) << d;
        EXPECT_NEAR(a.y, b.y, 1.5) << d;
        n++;
    }
    EXPECT_GT(n, 300);
    // The direction towards the camera (world −y) shows the disk centre too.
    const Point2f back = decode(env.eval(Vec3f(0, -1, 0)));
    EXPECT_NEAR(back.x, 200, 1.0);
    EXPECT_NEAR(back.y, 150, 1.0);
    EXPECT_THROW(imageDiskToEnvironment(bg, Point2f(200, 150), 0, kCamFromWorld, Size(64, 32)),
                 cv::Exception);
}
