// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Command-line tests of `vbme composite`.
#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::run;
using vbme_test::ScratchDir;

namespace {

std::string exe() {
    return std::string(VBME_EXE) + " composite -q";
}

/** Layers of size @p sz: obj, a difference that darkens the left half, a mask square. */
DifferentialImages layers(Size sz) {
    DifferentialImages im;
    im.obj = Mat(sz, CV_32FC3, Scalar(0.2, 0.4, 0.6));
    im.diff = Mat(sz, CV_32FC3, Scalar(0, 0, 0));
    im.diff(Rect(0, 0, sz.width / 2, sz.height)).setTo(Scalar(-0.1, -0.1, -0.1));
    im.noobj = im.obj - im.diff;
    im.mask = Mat(sz, CV_32FC1, Scalar(0));
    im.mask(Rect(sz.width - 4, 0, 4, 4)).setTo(1);
    return im;
}

}  // namespace

TEST(AppComposite, UsageErrorsExitTwo) {
    ScratchDir dir;
    imwrite(dir / "bg.png", Mat(8, 10, CV_8UC3, Scalar(100, 120, 140)));
    writeDifferentialExr(dir / "l.exr", layers(Size(10, 8)));
    const std::string base =
        exe() + " --background " + dir / "bg.png" + " --layers " + dir / "l.exr";
    EXPECT_EQ(run(exe() + " --layers " + dir / "l.exr --out " + dir / "o.png").code, 2);
    EXPECT_EQ(run(base).code, 2);                              // no --out
    EXPECT_EQ(run(base + " --out " + dir / "o.exr").code, 2);  // not PNG
    EXPECT_EQ(run(base + " --out " + dir / "o.png --response log").code, 2);
    EXPECT_EQ(run(base + " --out " + dir / "o.png --alpha x").code, 2);
    EXPECT_FALSE(std::filesystem::exists(dir / "o.png"));
}

TEST(AppComposite, BadInputExitsOneAndWritesNothing) {
    ScratchDir dir;
    imwrite(dir / "bg.png", Mat(8, 10, CV_8UC3, Scalar(100, 120, 140)));
    imwrite(dir / "small.png", Mat(7, 10, CV_8UC3, Scalar(100, 120, 140)));
    writeDifferentialExr(dir / "l.exr", layers(Size(10, 8)));
    writeExrChannels(dir / "plain.exr", {{"R", Mat(8, 10, CV_32F, Scalar(1))}});
    const std::string out = " --out " + dir / "o.png";
    auto r = run(exe() + " --background " + dir / "small.png --layers " + dir / "l.exr" + out);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("10x7"), std::string::npos) << r.output;
    r = run(exe() + " --background " + dir / "bg.png --layers " + dir / "plain.exr" + out);
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("diff.R"), std::string::npos) << r.output;
    r = run(exe() + " --background " + dir / "bg.png --layers " + dir / "none.exr" + out);
    EXPECT_EQ(r.code, 1) << r.output;
    r = run(exe() + " --background " + dir / "none.png --layers " + dir / "l.exr" + out);
    EXPECT_EQ(r.code, 1) << r.output;
    int n = 0;
    for (auto& e : std::filesystem::directory_iterator(dir.path()))
        (void)e, ++n;
    EXPECT_EQ(n, 4);  // the inputs only: nothing (half-)written
}

// The output is Eq. 5.2 through the response: the object where M = 1, the frame darkened where
// the difference is negative, the frame itself elsewhere; existing output needs --force.
TEST(AppComposite, ComposesAndEncodes) {
    ScratchDir dir;
    const Size sz(10, 8);
    const Mat bg(sz, CV_8UC3, Scalar(100, 120, 140));
    imwrite(dir / "bg.png", bg);
    writeDifferentialExr(dir / "l.exr", layers(sz));
    const std::string cmd =
        exe() + " --background " + dir / "bg.png --layers " + dir / "l.exr --out " + dir / "o.png";
    auto r = run(cmd + " --alpha 2 --response gamma2.2 --shadows additive");
    ASSERT_EQ(r.code, 0) << r.output;
    Mat o = imread(dir / "o.png", IMREAD_UNCHANGED);
    ASSERT_EQ(o.size(), sz);
    auto enc = [](float lin) {
        return saturate_cast<uchar>(std::round(encode(lin, Response::GAMMA22) * 255.f));
    };
    for (int c = 0; c < 3; ++c) {
        const float I = linearize(bg.at<Vec3b>(0, 0)[c] / 255.f, Response::GAMMA22);
        EXPECT_EQ(o.at<Vec3b>(7, 0)[c], enc(std::max(0.f, I - 0.2f)));          // α·diff = −0.2
        EXPECT_EQ(o.at<Vec3b>(7, 9)[c], bg.at<Vec3b>(0, 0)[c]);                 // untouched
        EXPECT_EQ(o.at<Vec3b>(0, 9)[c], enc(float(Scalar(0.2, 0.4, 0.6)[c])));  // object
    }
    // the default, ratio shadows: the frame keeps 1 + α·diff / noobj of its light
    r = run(cmd + " --alpha 2 --response gamma2.2 --force");
    ASSERT_EQ(r.code, 0) << r.output;
    o = imread(dir / "o.png", IMREAD_UNCHANGED);
    const DifferentialImages l = layers(sz);
    for (int c = 0; c < 3; ++c) {
        const float I = linearize(bg.at<Vec3b>(0, 0)[c] / 255.f, Response::GAMMA22);
        const float n = l.noobj.at<Vec3f>(7, 0)[c];
        EXPECT_EQ(o.at<Vec3b>(7, 0)[c], enc(I * (1.f - 0.2f / n)));
        EXPECT_EQ(o.at<Vec3b>(7, 9)[c], bg.at<Vec3b>(0, 0)[c]);
    }
    EXPECT_EQ(run(cmd + " --shadows darker --force").code, 2);
    EXPECT_EQ(run(cmd).code, 1);  // exists
    EXPECT_EQ(run(cmd + " --force").code, 0);
}
