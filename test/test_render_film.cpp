// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/vbme/render/film.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

TEST(RenderFilm, ExrRoundTripWithChannelsAndAttributes) {
    vbme_test::ScratchDir dir;
    RenderImages img;
    img.color.create(5, 7, CV_32FC3);
    img.albedo.create(5, 7, CV_32FC3);
    img.normal.create(5, 7, CV_32FC3);
    img.object.create(5, 7, CV_32FC1);
    RNG rng(3);
    rng.fill(img.color, RNG::UNIFORM, 0.0, 10.0);
    rng.fill(img.albedo, RNG::UNIFORM, 0.0, 1.0);
    rng.fill(img.normal, RNG::UNIFORM, -1.0, 1.0);
    rng.fill(img.object, RNG::UNIFORM, 0.0, 1.0);
    const std::string path = dir / "r.exr";
    writeExr(path, img, {{"vbme.version", "9.9"}, {"vbme.seed", "42"}});
    std::map<std::string, std::string> attr;
    auto ch = readExrChannels(path, &attr);
    for (const char* n :
         {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z", "object"})
        EXPECT_TRUE(ch.count(n)) << n;
    EXPECT_EQ(attr["vbme.version"], "9.9");
    EXPECT_EQ(attr["vbme.seed"], "42");
    // R is the third channel of the BGR Mat; N.X the first of the normal.
    std::vector<Mat> p;
    split(img.color, p);
    EXPECT_EQ(norm(ch["R"], p[2], NORM_INF), 0.0);
    RenderImages back = readExr(path);
    EXPECT_EQ(norm(back.color, img.color, NORM_INF), 0.0);
    EXPECT_EQ(norm(back.albedo, img.albedo, NORM_INF), 0.0);
    EXPECT_EQ(norm(back.normal, img.normal, NORM_INF), 0.0);
    EXPECT_EQ(norm(back.object, img.object, NORM_INF), 0.0);
    // only the final file is left behind
    int files = 0;
    for (auto& e : std::filesystem::directory_iterator(dir.path()))
        (void)e, ++files;
    EXPECT_EQ(files, 1);
    EXPECT_THROW(readExr(dir / "missing.exr"), cv::Exception);
}

TEST(RenderFilm, FilterOffsets) {
    // box: uniform over [−½, ½)
    EXPECT_EQ(filterOffset(FILTER_BOX, Vec2f(0, 0)), Vec2f(-0.5f, -0.5f));
    EXPECT_EQ(filterOffset(FILTER_BOX, Vec2f(0.75f, 0.25f)), Vec2f(0.25f, -0.25f));
    // Gaussian σ = 0.5 truncated at 2: symmetric, bounded, the right spread
    double m = 0, v = 0;
    const int n = 4096;
    for (int i = 0; i < n; ++i) {
        const float x = filterOffset(FILTER_GAUSSIAN, Vec2f((i + 0.5f) / n, 0.5f))[0];
        EXPECT_LE(std::abs(x), 2.f);
        m += x / n;
        v += x * x / n;
    }
    EXPECT_NEAR(m, 0, 1e-3);
    EXPECT_NEAR(std::sqrt(v), 0.5, 0.01);
    EXPECT_NEAR(filterOffset(FILTER_GAUSSIAN, Vec2f(0.5f, 0.5f))[1], 0.f, 1e-3);
    EXPECT_EQ(parseFilter("gaussian"), FILTER_GAUSSIAN);
    EXPECT_THROW(parseFilter("mitchell"), cv::Exception);
}

TEST(RenderFilm, PreviewExposureFormula) {
    ExposureParams p;  // S 320, N 2.8, t 1, γ 2.2
    const float s = 1.f / (2.8f * 2.8f) * 32.f * 0.65f * std::pow(118.f / 255.f, 2.2f);
    EXPECT_NEAR(p.scale(), s, 1e-6);
    Mat lin(1, 3, CV_32FC3, Scalar(0, 0, 0));
    lin.at<Vec3f>(0, 1) = Vec3f(0.5f / s, 0.5f / s, 0.5f / s);
    lin.at<Vec3f>(0, 2) = Vec3f(10.f / s, 10.f / s, 10.f / s);
    Mat out;
    previewExposure(lin, out, p);
    ASSERT_EQ(out.type(), CV_8UC3);
    EXPECT_EQ(out.at<Vec3b>(0, 0)[0], 0);
    EXPECT_EQ(out.at<Vec3b>(0, 1)[0], saturate_cast<uchar>(std::pow(0.5f, 1 / 2.2f) * 255.f));
    EXPECT_EQ(out.at<Vec3b>(0, 2)[0], 255);
}
