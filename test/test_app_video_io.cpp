// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// What the commands' videos keep of their input: audio (same packets), timestamps, and HDR
// input converted or refused with a clear message.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>

#include "vbme_test_util.hpp"

namespace fs = std::filesystem;
using namespace cv;

namespace {

bool haveFfmpeg() {
    static const bool ok = vbme_test::run("ffmpeg -version").code == 0;
    return ok;
}

// An orange shaded ball moving over a grey gradient, PNG frames in dir/clip, and its frame-0
// mask in dir/first.png (as test_app_material_edit.cpp draws it).
void writeBallFrames(const vbme_test::ScratchDir& dir, int frames) {
    fs::create_directories(dir / "clip");
    const Size size(120, 90);
    for (int i = 0; i < frames; i++) {
        Mat img(size, CV_8UC3);
        for (int y = 0; y < size.height; y++)
            for (int x = 0; x < size.width; x++)
                img.at<Vec3b>(y, x) =
                    Vec3b(90 + x / 4, 100 + y / 4, 95 + ((x / 10 + y / 10) % 2) * 20);
        const Point2f c(30.f + 8.f * i, 50.f);
        for (int y = 0; y < size.height; y++)
            for (int x = 0; x < size.width; x++) {
                const float dx = (x - c.x) / 14.f, dy = (y - c.y) / 14.f;
                if (dx * dx + dy * dy > 1) continue;
                const float s =
                    0.35f + 0.65f * std::max(0.f, -0.5f * dx - 0.5f * dy +
                                                      0.7f * std::sqrt(1 - dx * dx - dy * dy));
                img.at<Vec3b>(y, x) =
                    Vec3b(saturate_cast<uchar>(20 * s), saturate_cast<uchar>(110 * s),
                          saturate_cast<uchar>(240 * s));
            }
        imwrite(dir / format("clip/%05d.png", i), img);
    }
    Mat mask = Mat::zeros(size, CV_8U);
    circle(mask, Point(30, 50), 13, Scalar(255), FILLED);
    imwrite(dir / "first.png", mask);
}

// The frames as an MP4 with a 440 Hz AAC tone as long as the video.
std::string makeClipWithTone(const vbme_test::ScratchDir& dir, int frames, int fps) {
    const std::string out = dir / "clip.mp4";
    const double secs = (double)frames / fps;
    auto r = vbme_test::run(
        "ffmpeg -v error -y -framerate " + std::to_string(fps) + " -i " + (dir / "clip/%05d.png") +
        " -f lavfi -i sine=frequency=440:duration=" + std::to_string(secs) + " -t " +
        std::to_string(secs) + " -c:v libx264 -crf 10 -pix_fmt yuv420p -c:a aac " + out);
    EXPECT_EQ(r.code, 0) << r.output;
    return out;
}

std::string md5Of(const std::string& cmd) {
    auto r = vbme_test::run(cmd);
    const auto p = r.output.find("MD5=");
    return r.code == 0 && p != std::string::npos ? r.output.substr(p + 4, 32)
                                                 : "failed: " + r.output;
}

std::string audioPackets(const std::string& file) {
    return md5Of("ffmpeg -v error -i " + file + " -map 0:a -c copy -f md5 -");
}

std::vector<double> timestampsOf(const std::string& file) {
    cv::vbme::VideoReader r(file);
    while (r.read(noArray())) {
    }
    return r.timestamps();
}

void expectSameTimes(const std::string& in, const std::string& out) {
    const auto a = timestampsOf(in), b = timestampsOf(out);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i)
        EXPECT_NEAR(a[i], b[i], 1.0 / 90000 + 1e-9) << "frame " << i;
}

const std::string kExe = VBME_EXE;

}  // namespace

TEST(AppVideoIo, MaterialEditKeepsAudioAndTimestamps) {
    if (!haveFfmpeg()) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir dir;
    writeBallFrames(dir, 6);
    const std::string clip = makeClipWithTone(dir, 6, 10);
    const std::string out = dir / "out.mp4";
    auto r = vbme_test::run(kExe + " material-edit --quiet --video " + clip + " --mask " +
                            (dir / "first.png") + " --material chrome --out " + out);
    ASSERT_EQ(r.code, 0) << r.output;
    cv::vbme::VideoReader v(out);
    EXPECT_EQ(v.audioStreams(), 1);
    EXPECT_EQ(audioPackets(out), audioPackets(clip));  // codec-copied
    expectSameTimes(clip, out);
}

TEST(AppVideoIo, InpaintVideoKeepsAudio) {
    if (!haveFfmpeg()) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir dir;
    writeBallFrames(dir, 5);
    const std::string clip = makeClipWithTone(dir, 5, 10);
    fs::create_directories(dir / "masks");
    for (int i = 0; i < 5; ++i) {
        Mat m = Mat::zeros(90, 120, CV_8U);
        circle(m, Point(30 + 8 * i, 50), 16, Scalar(255), FILLED);
        imwrite(dir / ("masks/" + cv::vbme::maskFileName(i)), m);
    }
    const std::string out = dir / "out.mp4";
    auto r = vbme_test::run(kExe + " inpaint --quiet --video " + clip + " --masks " +
                            (dir / "masks") + " --radius 2 --crf 18 --out " + out);
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(audioPackets(out), audioPackets(clip));
    expectSameTimes(clip, out);
    // --crf is recorded in the encoder settings
    auto p = vbme_test::run(
        "ffprobe -v error -show_entries format_tags=encoder_settings -of "
        "default=nw=1:nk=1 " +
        out);
    EXPECT_NE(p.output.find("crf 18"), std::string::npos) << p.output;
}

TEST(AppVideoIo, HdrInputIsConvertedOrRefused) {
    if (!haveFfmpeg()) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir dir;
    writeBallFrames(dir, 4);
    // the frames tagged as 10-bit HLG BT.2020 (values as if HLG-encoded)
    const std::string hlg = dir / "hlg.mp4";
    auto r = vbme_test::run("ffmpeg -v error -y -framerate 10 -i " + (dir / "clip/%05d.png") +
                            " -vf scale=out_color_matrix=bt2020:out_range=tv,format=yuv420p10le "
                            "-c:v libx264 -crf 10 -color_primaries bt2020 -color_trc arib-std-b67 "
                            "-colorspace bt2020nc -color_range tv " +
                            hlg);
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string base = kExe + " material-edit --quiet --video " + hlg + " --mask " +
                             (dir / "first.png") + " --material chrome ";
    // a response other than srgb cannot describe the converted frames: refused, exit 1
    r = vbme_test::run(base + "--response gamma2.2 --out " + (dir / "no.mp4"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("HDR"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("HLG"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("--response srgb"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "no.mp4"));
    // with srgb: converted, said in the log and in the output's metadata
    r = vbme_test::run(base + "--max-lost 3 --out " + (dir / "yes.mp4"));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("HLG bt2020 10-bit converted to BT.709"), std::string::npos)
        << r.output;
    auto p = vbme_test::run(
        "ffprobe -v error -show_entries format_tags=comment -of "
        "default=nw=1:nk=1 " +
        (dir / "yes.mp4"));
    EXPECT_NE(p.output.find("converted to BT.709"), std::string::npos) << p.output;
    cv::vbme::VideoReader v(dir / "yes.mp4");
    EXPECT_FALSE(v.colorInfo().isHdr());
    EXPECT_EQ(v.colorInfo().primaries, 1);
}
