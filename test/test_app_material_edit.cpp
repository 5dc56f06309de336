// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// `vbme material-edit`: exit codes, messages, outputs.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vbme_test_util.hpp"

namespace fs = std::filesystem;

namespace {

/** A small clip: a uniformly orange, shaded ball moving over a grey gradient (PNG frames). */
void writeClip(const vbme_test::ScratchDir& dir, int frames, int vanish_at = -1) {
    fs::create_directories(dir / "clip");
    const cv::Size size(120, 90);
    for (int i = 0; i < frames; i++) {
        cv::Mat img(size, CV_8UC3);
        for (int y = 0; y < size.height; y++)
            for (int x = 0; x < size.width; x++)
                img.at<cv::Vec3b>(y, x) =
                    cv::Vec3b(90 + x / 4, 100 + y / 4, 95 + ((x / 10 + y / 10) % 2) * 20);
        if (vanish_at < 0 || i < vanish_at) {
            const cv::Point2f c(30.f + 8.f * i, 50.f);
            for (int y = 0; y < size.height; y++)
                for (int x = 0; x < size.width; x++) {
                    const float dx = (x - c.x) / 14.f, dy = (y - c.y) / 14.f;
                    if (dx * dx + dy * dy > 1) continue;
                    const float s =
                        0.35f + 0.65f * std::max(0.f, -0.5f * dx - 0.5f * dy +
                                                          0.7f * std::sqrt(1 - dx * dx - dy * dy));
                    img.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(20 * s),
                                                        cv::saturate_cast<uchar>(110 * s),
                                                        cv::saturate_cast<uchar>(240 * s));
                }
        }
        cv::imwrite(dir / cv::format("clip/%05d.png", i), img);
    }
    cv::Mat mask = cv::Mat::zeros(size, CV_8U);
    cv::circle(mask, cv::Point(30, 50), 13, cv::Scalar(255), cv::FILLED);
    cv::imwrite(dir / "first.png", mask);
}

std::string cmd(const vbme_test::ScratchDir& dir, const std::string& extra) {
    return std::string(VBME_EXE) + " material-edit --quiet --video " + (dir / "clip") + " --mask " +
           (dir / "first.png") + " " + extra;
}

}  // namespace

TEST(AppMaterialEdit, EditsAndRefusesOverwrite) {
    vbme_test::ScratchDir dir;
    writeClip(dir, 6);
    const std::string out = dir / "out.mkv";
    auto r = vbme_test::run(
        cmd(dir, "--material glass --out " + out + " --save-intermediates " + (dir / "inter")));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(fs::exists(out));
    EXPECT_TRUE(fs::exists(dir / "inter/mask_00005.png"));
    EXPECT_TRUE(fs::exists(dir / "inter/background.mkv"));
    EXPECT_TRUE(fs::exists(dir / "inter/env_00000.exr"));
    r = vbme_test::run(cmd(dir, "--material glass --out " + out));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("--force"), std::string::npos) << r.output;
    r = vbme_test::run(
        cmd(dir, "--material chrome --light fixed:0,-1,-1 --out " + out + " --force"));
    EXPECT_EQ(r.code, 0) << r.output;
}

TEST(AppMaterialEdit, UsageErrors) {
    vbme_test::ScratchDir dir;
    writeClip(dir, 2);
    auto r = vbme_test::run(std::string(VBME_EXE) + " material-edit --video " + (dir / "clip") +
                            " --out " + (dir / "o.mkv"));
    EXPECT_EQ(r.code, 2) << r.output;
    r = vbme_test::run(cmd(dir, "--material glass --out " + (dir / "o.mkv") + " --inpaint magic"));
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_FALSE(fs::exists(dir / "o.mkv"));
}

TEST(AppMaterialEdit, BadInput) {
    vbme_test::ScratchDir dir;
    writeClip(dir, 6, 3);
    const std::string out = dir / "out.mkv";
    // Unknown material: the message lists the presets.
    auto r = vbme_test::run(cmd(dir, "--material unobtainium --out " + out));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("chrome"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("glass"), std::string::npos) << r.output;
    // A material file that does not exist.
    r = vbme_test::run(cmd(dir, "--material " + (dir / "missing.yml") + " --out " + out));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;
    // Bad lights: not a light, a direction of two components, a zero direction.
    for (const char* light : {"sideways", "fixed:1,2", "fixed:0,0,0", "fixed:1,2,3x"}) {
        r = vbme_test::run(
            cmd(dir, std::string("--material blue --light ") + light + " --out " + out));
        EXPECT_EQ(r.code, 1) << light << ": " << r.output;
        EXPECT_NE(r.output.find("fixed:x,y,z"), std::string::npos) << r.output;
    }
    // The ball leaves at frame 3: lost track, named frame, nothing written.
    r = vbme_test::run(
        cmd(dir, "--material blue --out " + out + " --save-intermediates " + (dir / "inter")));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("lost at frame 3"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(dir / "inter/mask_00000.png"));
    // Empty first mask.
    cv::imwrite(dir / "first.png", cv::Mat::zeros(90, 120, CV_8U));
    r = vbme_test::run(cmd(dir, "--material blue --out " + out));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("empty"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out));
}

// --material takes a YAML file with a top-level material: map, and --light fixed:x,y,z a
// direction: the edit runs, and the ball's region differs from the preset edit's.
TEST(AppMaterialEdit, MaterialFileAndFixedLight) {
    vbme_test::ScratchDir dir;
    writeClip(dir, 4);
    {
        std::FILE* f = std::fopen((dir / "red.yml").c_str(), "w");
        ASSERT_NE(f, nullptr);
        std::fputs("%YAML:1.0\nmaterial:\n  type: lambertian\n  albedo: [0.8, 0.05, 0.05]\n", f);
        std::fclose(f);
    }
    auto r = vbme_test::run(cmd(dir, "--material " + (dir / "red.yml") +
                                         " --light fixed:0,-1,-1 --out " + (dir / "red/%05d.png")));
    ASSERT_EQ(r.code, 0) << r.output;
    r = vbme_test::run(cmd(dir, "--material blue --light fixed:0,-1,-1 --out " +
                                    (dir / "blue/%05d.png") + " --report " + (dir / "r.yml")));
    ASSERT_EQ(r.code, 0) << r.output;
    // --report: the run's PipelineReport.
    cv::FileStorage rep(dir / "r.yml", cv::FileStorage::READ);
    ASSERT_TRUE(rep.isOpened());
    EXPECT_EQ((std::string)rep["pipeline"], "material-edit");
    EXPECT_EQ((int)rep["frames_processed"], 4);
    EXPECT_EQ((int)rep["frames_total"], 4);
    EXPECT_FALSE(rep["seconds"]["rendering"].empty());
    EXPECT_GT((double)rep["figures"]["pixels_temporal"], 0);
    // In the ball of frame 0 (centre (30, 50), radius 14): red dominates in the file's edit,
    // blue in the preset's.
    const cv::Mat red = cv::imread(dir / "red/00000.png"),
                  blue = cv::imread(dir / "blue/00000.png");
    ASSERT_FALSE(red.empty());
    ASSERT_FALSE(blue.empty());
    cv::Mat mask = cv::Mat::zeros(red.size(), CV_8U);
    cv::circle(mask, cv::Point(30, 50), 10, cv::Scalar(255), cv::FILLED);
    const cv::Scalar mr = cv::mean(red, mask), mb = cv::mean(blue, mask);  // BGR
    std::printf(
        "[ measured ] ball mean BGR: file (red) %.0f %.0f %.0f, preset blue %.0f %.0f %.0f\n",
        mr[0], mr[1], mr[2], mb[0], mb[1], mb[2]);
    EXPECT_GT(mr[2], 2 * mr[0]);
    EXPECT_GT(mb[0], mb[2]);
}

TEST(AppMaterialEdit, ShadowsAutoFollowsTheMaterial) {
    // --shadows auto (the default) removes the original shadow for a material that transmits
    // light and keeps it for the others; an explicit choice wins. The report says which ran.
    vbme_test::ScratchDir dir;
    writeClip(dir, 4);
    const auto removed = [&](const std::string& extra, const std::string& name) {
        const auto r = vbme_test::run(cmd(dir, extra + " --light fixed:0,-1,-1 --out " +
                                                   (dir / (name + ".mkv")) + " --report " +
                                                   (dir / (name + ".yml"))));
        EXPECT_EQ(r.code, 0) << r.output;
        cv::FileStorage rep(dir / (name + ".yml"), cv::FileStorage::READ);
        EXPECT_TRUE(rep.isOpened()) << name;
        return rep.isOpened() ? (int)rep["figures"]["shadows_removed"] : -1;
    };
    EXPECT_EQ(removed("--material glass", "glass"), 1);
    EXPECT_EQ(removed("--material blue", "blue"), 0);
    EXPECT_EQ(removed("--material chrome --shadows auto", "chrome"), 0);
    EXPECT_EQ(removed("--material glass --shadows keep", "glass_keep"), 0);
    EXPECT_EQ(removed("--material blue --shadows remove", "blue_remove"), 1);
}
