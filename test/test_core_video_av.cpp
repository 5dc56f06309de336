// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Video IO on FFmpeg's libraries: quality of the default encode against OpenCV's path, variable
// frame rate, HDR (HLG, PQ) detection and conversion, audio carried, damaged input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/videoio.hpp>

#include "vbme_test_util.hpp"
#include "video_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

bool haveFfmpeg() {
    static const bool ok = vbme_test::run("ffmpeg -version").code == 0;
    return ok;
}

// A clean synthetic frame: a fine texture panning by 2 pixels a frame (the detail a renderer
// computes and a starved encoder smears), smooth gradients, a moving coloured disc, text.
Mat truthFrame(int i, Size size) {
    static Mat texture;
    if (texture.empty()) {
        Mat t(512, 512, CV_8UC1);
        RNG rng(7);
        rng.fill(t, RNG::UNIFORM, 0, 256);
        GaussianBlur(t, t, Size(0, 0), 1.2);
        normalize(t, t, 0, 255, NORM_MINMAX);
        cvtColor(t, texture, COLOR_GRAY2BGR);
    }
    Mat f(size, CV_8UC3);
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x)
            f.at<Vec3b>(y, x) =
                Vec3b((uchar)(40 + 150 * x / size.width), (uchar)(60 + 120 * y / size.height),
                      (uchar)(100 + 60 * std::sin(0.05 * (x + y + 3 * i))));
    if (size.width + 2 * i <= texture.cols && size.height <= texture.rows)
        addWeighted(f, 0.5, texture(Rect(2 * i, 0, size.width, size.height)), 0.5, 0, f);
    circle(f, Point(40 + 6 * i, size.height / 2), size.height / 5, Scalar(30, 60, 220), FILLED,
           LINE_AA);
    rectangle(f, Rect(size.width - 70, 20, 40, 30), Scalar(200, 230, 240), FILLED);
    putText(f, "vbme " + std::to_string(i), Point(10, size.height - 12), FONT_HERSHEY_SIMPLEX, 0.6,
            Scalar(250, 250, 250), 1, LINE_AA);
    return f;
}

// The truth plus rendering noise (as a path tracer leaves it), seeded per frame.
Mat renderedFrame(const Mat& truth, int i) {
    Mat noise(truth.size(), CV_32FC3);
    RNG rng(1000 + i);
    rng.fill(noise, RNG::NORMAL, 0, 3.0);
    Mat f;
    truth.convertTo(f, CV_32FC3);
    f += noise;
    f.convertTo(f, CV_8UC3);
    return f;
}

double psnrOf(const std::vector<Mat>& a, const std::vector<Mat>& b) {
    double se = 0, n = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        const double e = norm(a[i], b[i], NORM_L2);
        se += e * e;
        n += (double)a[i].total() * a[i].channels();
    }
    return 10 * std::log10(255.0 * 255.0 / (se / n));
}

}  // namespace

TEST(CoreVideoAv, DefaultEncodeKeepsWhatWasRendered) {
    // The measure: PSNR against the truth of the frames as rendered, and of the same
    // frames after the video round trip. vbme's default (libx264 CRF 17) must lose <= 0.5 dB;
    // OpenCV's VideoWriter (today's path before FFmpeg's libraries) is measured beside it.
    vbme_test::ScratchDir tmp;
    const Size size(320, 240);
    const int n = 12, fps = 24;
    std::vector<Mat> truth, rendered;
    for (int i = 0; i < n; ++i) {
        truth.push_back(truthFrame(i, size));
        rendered.push_back(renderedFrame(truth.back(), i));
    }
    {
        VideoSink sink(tmp / "vbme.mp4", fps, size);
        for (const Mat& f : rendered)
            sink.write(f);
        sink.close();
    }
    std::vector<Mat> ours;
    {
        VideoReader r(tmp / "vbme.mp4");
        Mat f;
        while (r.read(f))
            ours.push_back(f.clone());
        EXPECT_EQ(r.codecName(), "h264");
        EXPECT_EQ(r.colorInfo().primaries, 1);
        EXPECT_EQ(r.colorInfo().matrix, 1);
    }
    ASSERT_EQ((int)ours.size(), n);
    std::vector<Mat> theirs;
    {
        VideoWriter w(tmp / "opencv.mp4", CAP_FFMPEG, VideoWriter::fourcc('a', 'v', 'c', '1'), fps,
                      size);
        ASSERT_TRUE(w.isOpened());
        for (const Mat& f : rendered)
            w.write(f);
        w.release();
        VideoCapture c(tmp / "opencv.mp4", CAP_FFMPEG);
        Mat f;
        while (c.read(f))
            theirs.push_back(f.clone());
    }
    ASSERT_EQ((int)theirs.size(), n);
    const double p_rendered = psnrOf(rendered, truth);
    const double p_ours = psnrOf(ours, truth), p_theirs = psnrOf(theirs, truth);
    const auto bytes = [&](const std::string& p) { return (double)std::filesystem::file_size(p); };
    const double secs = (double)n / fps;
    // the alternatives, for the record: CRF 17 in 4:2:0 and 4:4:4; CRF 14 with x264's preset
    // medium (the default before superfast)
    std::vector<double> alt;
    for (const char* pf : {"yuv420p", "yuv444p", "medium"}) {
        VideoSinkOptions so;
        so.crf = 17;
        so.min_psnr = 0;  // the CRF as given, without the quality floor's trials
        so.pix_fmt = pf;
        if (std::string(pf) == "medium") {
            so.crf = 14;
            so.pix_fmt = "yuv420p";
            so.preset = "medium";
        }
        {
            VideoSink sink(tmp / "alt.mp4", fps, size, so);
            for (const Mat& f : rendered)
                sink.write(f);
            sink.close();
        }
        VideoReader r(tmp / "alt.mp4");
        std::vector<Mat> got;
        Mat f;
        while (r.read(f))
            got.push_back(f.clone());
        alt.push_back(psnrOf(got, truth));
        std::printf(
            "  h264 crf %d %s %s: %.2f dB (%.0f kbit/s)\n", so.crf, so.preset.c_str(),
            so.pix_fmt.c_str(), alt.back(),
            (double)std::filesystem::file_size(tmp / "alt.mp4") * 8 / ((double)n / fps) / 1000);
        std::filesystem::remove(tmp / "alt.mp4");
    }
    std::printf(
        "PSNR vs truth: rendered frames %.2f dB; vbme default (h264 crf 14 superfast yuv420p) "
        "%.2f dB (%.0f "
        "kbit/s); "
        "OpenCV VideoWriter avc1 %.2f dB (%.0f kbit/s)\n",
        p_rendered, p_ours, bytes(tmp / "vbme.mp4") * 8 / secs / 1000, p_theirs,
        bytes(tmp / "opencv.mp4") * 8 / secs / 1000);
    std::printf("PSNR vs frames written: vbme %.2f dB, OpenCV %.2f dB\n", psnrOf(ours, rendered),
                psnrOf(theirs, rendered));
    EXPECT_GE(p_ours, p_rendered - 0.5);
    EXPECT_GT(p_ours, p_theirs);  // the old path is the baseline this replaces
}

TEST(CoreVideoAv, VariableFrameRateTimestampsAreKept) {
    if (!haveFfmpeg()) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir tmp;
    // made by ffmpeg itself: frame N shown at N/30 + 0.004 N^2 seconds (irregular intervals)
    const int n = 10;
    auto r =
        vbme_test::run("ffmpeg -v error -y -f lavfi -i testsrc2=size=96x64:rate=30 -frames:v " +
                       std::to_string(n) +
                       " -vf \"settb=1/90000,setpts='(N/30+0.004*N*N)/TB'\" -fps_mode passthrough "
                       "-enc_time_base 1/90000 -video_track_timescale 90000 -c:v libx264 -crf 18 " +
                       (tmp / "vfr.mp4"));
    ASSERT_EQ(r.code, 0) << r.output;
    auto expected = [](int i) { return i / 30.0 + 0.004 * i * i; };
    std::vector<double> times;
    Vec2i tb;
    {
        VideoReader in(tmp / "vfr.mp4");
        tb = in.timeBase();
        Mat f;
        while (in.read(f))
            times.push_back(in.timestamp());
        ASSERT_EQ((int)times.size(), n);
        VideoSinkOptions o;
        o.time_base = tb;
        VideoReader again(tmp / "vfr.mp4");
        VideoSink sink(tmp / "out.mp4", again.fps(), again.frameSize(), o);
        VideoSink sink2(tmp / "out.mkv", again.fps(), again.frameSize());
        while (again.read(f)) {
            sink.write(f, again.timestamp());
            sink2.write(f, again.timestamp());
        }
        sink.close();
        sink2.close();
    }
    const double tick = (double)tb[0] / tb[1];
    // ffmpeg's own rounding of the formula: up to two ticks
    for (int i = 0; i < n; ++i)
        EXPECT_NEAR(times[i], expected(i), tick * 2.01) << "input frame " << i;
    for (const char* name : {"out.mp4", "out.mkv"}) {
        VideoReader out(tmp / name);
        Mat f;
        int i = 0;
        const double out_tick =
            std::string(name) == "out.mkv" ? 1e-3 : (double)out.timeBase()[0] / out.timeBase()[1];
        while (out.read(f)) {
            ASSERT_LT(i, n);
            EXPECT_NEAR(out.timestamp(), times[i], out_tick * 1.01) << name << " frame " << i;
            ++i;
        }
        EXPECT_EQ(i, n) << name;
    }
}

namespace {

// ITU-R BT.2100 inverse EOTF (PQ) and OETF (HLG), written here independently of vbme_core.
double pqInverse(double nits) {
    const double m1 = 0.1593017578125, m2 = 78.84375, c1 = 0.8359375, c2 = 18.8515625, c3 = 18.6875;
    const double y = std::pow(std::max(nits, 0.0) / 10000.0, m1);
    return std::pow((c1 + c2 * y) / (1 + c3 * y), m2);
}
double hlgOetf(double e) {
    const double a = 0.17883277, b = 0.28466892, c = 0.55991073;
    return e <= 1.0 / 12 ? std::sqrt(3 * e) : a * std::log(12 * e - b) + c;
}
double srgb(double x) {
    x = std::min(std::max(x, 0.0), 1.0);
    return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055;
}

// Linear BT.709 patch colours (RGB, relative to HDR reference white) and where they lie.
const std::vector<Vec3d> kPatches = {{0.02, 0.02, 0.02}, {0.18, 0.18, 0.18}, {0.5, 0.5, 0.5},
                                     {0.75, 0.75, 0.75}, {0.5, 0.2, 0.1},    {0.1, 0.3, 0.6},
                                     {1.0, 1.0, 1.0},    {3.0, 3.0, 3.0}};
const int kPatch = 32;

// Makes a 10-bit HDR clip with ffmpeg from the patches: the test encodes linear → R'G'B'
// (BT.2020) itself, ffmpeg converts to Y'CbCr 4:2:0 10-bit (BT.2020 matrix, limited range) and
// encodes it losslessly with libx264, tagged as HDR.
std::string makeHdrClip(const vbme_test::ScratchDir& tmp, bool pq) {
    const Matx33d to2020(0.6274, 0.3293, 0.0433, 0.0691, 0.9195, 0.0114, 0.0164, 0.0880, 0.8956);
    Mat img(2 * kPatch, 4 * kPatch, CV_16UC3);
    for (size_t k = 0; k < kPatches.size(); ++k) {
        const Vec3d lin = to2020 * kPatches[k];
        Vec3w code;
        for (int c = 0; c < 3; ++c) {
            const double e = pq ? pqInverse(lin[c] * 203.0)
                                : hlgOetf(lin[c] * 0.26496256);  // 75 % HLG = reference white
            code[2 - c] = (ushort)std::lround(std::min(1.0, e) * 65535);
        }
        img(Rect((int)(k % 4) * kPatch, (int)(k / 4) * kPatch, kPatch, kPatch)).setTo(code);
    }
    const std::string png = tmp / (pq ? "pq.png" : "hlg.png");
    const std::string out = tmp / (pq ? "pq.mp4" : "hlg.mp4");
    imwrite(png, img);
    const std::string trc = pq ? "smpte2084" : "arib-std-b67";
    auto r = vbme_test::run(
        "ffmpeg -v error -y -loop 1 -i " + png +
        " -frames:v 3 -vf scale=out_color_matrix=bt2020:out_range=tv,format=yuv420p10le "
        "-c:v libx264 -qp 0 -color_primaries bt2020 -color_trc " +
        trc + " -colorspace bt2020nc -color_range tv " + out);
    EXPECT_EQ(r.code, 0) << r.output;
    return out;
}

}  // namespace

TEST(CoreVideoAv, HdrInputIsDetectedAndConverted) {
    if (!haveFfmpeg()) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir tmp;
    for (bool pq : {false, true}) {
        const std::string clip = makeHdrClip(tmp, pq);
        VideoReadOptions o;
        o.log = false;
        o.depth = CV_16U;
        VideoReader r(clip, o);
        EXPECT_TRUE(r.colorInfo().isHdr());
        EXPECT_EQ(r.colorInfo().transfer, pq ? 16 : 18);
        EXPECT_EQ(r.colorInfo().primaries, 9);
        EXPECT_EQ(r.bitDepth(), 10);
        EXPECT_NE(r.conversion().find(pq ? "PQ" : "HLG"), std::string::npos);
        Mat f;
        ASSERT_TRUE(r.read(f));
        ASSERT_EQ(f.type(), CV_16UC3);
        double worst = 0;
        for (size_t k = 0; k < kPatches.size(); ++k) {
            const Vec3d lin = kPatches[k];
            const double m = std::max(lin[0], std::max(lin[1], lin[2]));
            const double s = m > 0.8 ? (0.8 + 0.2 * (1 - std::exp(-(m - 0.8) / 0.2))) / m : 1.0;
            const Vec3w got =
                f.at<Vec3w>((int)(k / 4) * kPatch + kPatch / 2, (int)(k % 4) * kPatch + kPatch / 2);
            for (int c = 0; c < 3; ++c) {
                const double want = srgb(lin[c] * s) * 255;
                const double have = got[2 - c] / 257.0;
                worst = std::max(worst, std::abs(want - have));
                EXPECT_NEAR(have, want, 2.0)
                    << (pq ? "PQ" : "HLG") << " patch " << k << " channel " << c;
            }
        }
        std::printf("%s: largest error of the converted patches %.2f (of 255)\n", pq ? "PQ" : "HLG",
                    worst);
        // a reader that cannot use HDR says so
        VideoReadOptions refuse;
        refuse.hdr = HdrPolicy::Refuse;
        refuse.purpose = "this test";
        try {
            VideoReader no(clip, refuse);
            ADD_FAILURE() << "HDR input was not refused";
        } catch (const cv::Exception& e) {
            EXPECT_NE(e.err.find("HDR"), std::string::npos) << e.err;
            EXPECT_NE(e.err.find(pq ? "PQ" : "HLG"), std::string::npos) << e.err;
            EXPECT_NE(e.err.find("this test"), std::string::npos) << e.err;
        }
    }
}

namespace {

std::string md5Of(const std::string& cmd) {
    auto r = vbme_test::run(cmd);
    const auto p = r.output.find("MD5=");
    return r.code == 0 && p != std::string::npos ? r.output.substr(p + 4, 32)
                                                 : "failed: " + r.output;
}

// Seconds of audio as decoded (mono 44.1 kHz samples counted).
double audioSeconds(const std::string& file) {
    auto r = vbme_test::run("ffmpeg -v error -i " + file +
                            " -map 0:a:0 -f s16le -ac 1 -ar 44100 pipe:1 | wc -c");
    return r.code == 0 ? std::atof(r.output.c_str()) / 2 / 44100 : -1;
}

}  // namespace

TEST(CoreVideoAv, AudioIsCarried) {
    if (!haveFfmpeg()) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir tmp;
    // a 1 s clip with a 440 Hz tone, AAC in MP4 and PCM in MKV; carried into MP4 (AAC:
    // copied, same decoded samples; PCM: re-encoded to AAC, same length) and MKV (AAC copied)
    struct Case {
        std::string in, out;
        bool copied;
    };
    const std::vector<Case> cases = {{"tone.mp4", "out.mp4", true},
                                     {"tone.mp4", "out.mkv", true},
                                     {"tone.mkv", "out.mp4", false}};
    for (const std::string in : {"tone.mp4", "tone.mkv"}) {
        auto r = vbme_test::run(
            "ffmpeg -v error -y -f lavfi -i testsrc2=size=64x48:rate=10 "
            "-f lavfi -i sine=frequency=440:duration=1 -t 1 "
            "-c:v libx264 -crf 20 -c:a " +
            std::string(in == "tone.mp4" ? "aac " : "pcm_s16le ") + (tmp / in));
        ASSERT_EQ(r.code, 0) << r.output;
    }
    for (const Case& c : cases) {
        const std::string in = tmp / c.in, o = tmp / ("from_" + c.in + "_" + c.out);
        {
            VideoReader rd(in);
            EXPECT_EQ(rd.audioStreams(), 1);
            VideoSinkOptions so;
            so.audio_from = in;
            VideoSink sink(o, rd.fps(), rd.frameSize(), so);
            Mat f;
            while (rd.read(f))
                sink.write(f, rd.timestamp());
            sink.close();
        }
        VideoReader back(o);
        EXPECT_EQ(back.audioStreams(), 1);
        if (c.copied) {
            EXPECT_EQ(md5Of("ffmpeg -v error -i " + in + " -map 0:a -c copy -f md5 -"),
                      md5Of("ffmpeg -v error -i " + o + " -map 0:a -c copy -f md5 -"))
                << c.in << " -> " << c.out;
            if (c.out == "out.mp4") {
                EXPECT_EQ(md5Of("ffmpeg -v error -i " + in + " -map 0:a -f md5 -"),
                          md5Of("ffmpeg -v error -i " + o + " -map 0:a -f md5 -"));
            }
            std::printf("%s -> %s: audio packets copied\n", c.in.c_str(), c.out.c_str());
        } else {
            const double d_in = audioSeconds(in), d_out = audioSeconds(o);
            std::printf("%s -> %s: audio re-encoded to AAC, %.4f s -> %.4f s\n", c.in.c_str(),
                        c.out.c_str(), d_in, d_out);
            EXPECT_NEAR(d_out, d_in, 0.05);  // AAC frames are 23 ms
        }
    }
}

TEST(CoreVideoAv, DamagedPacketsAreNamedNotShifted) {
    // An intra-only H.264 clip (made by ffmpeg) whose middle is overwritten with junk: every
    // frame delivered keeps its index (content and time); the damaged or lost ones are named.
    if (!haveFfmpeg()) GTEST_SKIP() << "ffmpeg program not installed";
    vbme_test::ScratchDir tmp;
    const Size size(96, 64);
    const int n = 12;
    std::vector<Mat> frames;
    for (int i = 0; i < n; ++i) {
        frames.push_back(truthFrame(i, size));
        putText(frames.back(), std::to_string(i), Point(30, 40), FONT_HERSHEY_SIMPLEX, 1.2,
                Scalar(0, 0, 0), 3);
        imwrite(tmp / format("f%02d.png", i), frames.back());
    }
    auto run = vbme_test::run("ffmpeg -v error -y -framerate 10 -i " + (tmp / "f%02d.png") +
                              " -c:v libx264 -g 1 -crf 12 -pix_fmt yuv444p " + (tmp / "clip.mp4"));
    ASSERT_EQ(run.code, 0) << run.output;
    {
        std::fstream f(tmp / "clip.mp4", std::ios::in | std::ios::out | std::ios::binary);
        f.seekg(0, std::ios::end);
        const auto len = (long long)f.tellg();
        f.seekp(len / 2);
        std::string junk(200, '\xA5');
        f.write(junk.data(), (std::streamsize)junk.size());
    }
    VideoReadOptions o;
    o.log = false;
    VideoReader r(tmp / "clip.mp4", o);
    Mat f;
    int i = 0;
    while (r.read(f)) {
        ASSERT_LT(i, n);
        EXPECT_NEAR(r.timestamp(), i / 10.0, 1e-3) << "frame " << i;
        const bool damaged = std::count(r.damagedFrames().begin(), r.damagedFrames().end(), i) > 0;
        if (!damaged) {
            // its own frame, not a neighbour's
            const double own = norm(f, frames[i], NORM_L1);
            for (int j : {i - 1, i + 1}) {
                if (j >= 0 && j < n) {
                    EXPECT_LT(own, norm(f, frames[j], NORM_L1)) << "frame " << i << " vs " << j;
                }
            }
            EXPECT_LT(own / f.total() / 3, 4.0) << "undamaged frame " << i;
        }
        ++i;
    }
    EXPECT_EQ(i, n);
    ASSERT_FALSE(r.damagedFrames().empty()) << "damage not reported";
    ASSERT_FALSE(r.notes().empty());
    std::printf("damaged frames named:");
    for (int d : r.damagedFrames())
        std::printf(" %d", d);
    std::printf("; first note: %s\n", r.notes().front().c_str());
    EXPECT_NE(r.notes().front().find("frame " + std::to_string(r.damagedFrames().front())),
              std::string::npos);
    // strict mode: an error with the frame index
    VideoReadOptions s = o;
    s.strict = true;
    try {
        VideoReader rs(tmp / "clip.mp4", s);
        while (rs.read(f)) {
        }
        ADD_FAILURE() << "strict reader did not throw";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("frame " + std::to_string(r.damagedFrames().front())),
                  std::string::npos)
            << e.err;
    }
}

TEST(CoreVideoAv, TruncatedFileIsReported) {
    vbme_test::ScratchDir tmp;
    const Size size(64, 48);
    {
        VideoSink sink(tmp / "clip.mp4", 10, size);
        for (int i = 0; i < 20; ++i)
            sink.write(truthFrame(i, size));
        sink.close();
    }
    const auto len = std::filesystem::file_size(tmp / "clip.mp4");
    std::filesystem::resize_file(tmp / "clip.mp4", len * 6 / 10);
    VideoReadOptions o;
    o.log = false;
    VideoReader r(tmp / "clip.mp4", o);
    EXPECT_EQ(r.frameCount(), 20);
    Mat f;
    int n = 0;
    while (r.read(f))
        ++n;
    EXPECT_LT(n, 20);
    ASSERT_FALSE(r.notes().empty());
    EXPECT_NE(r.notes().back().find("truncated"), std::string::npos) << r.notes().back();
    EXPECT_NE(r.notes().back().find(std::to_string(n)), std::string::npos) << r.notes().back();
}

TEST(CoreVideoAv, CodecsAndSixteenBitSequences) {
    vbme_test::ScratchDir tmp;
    const Size size(64, 48);
    Mat f8 = truthFrame(3, size), f16;
    GaussianBlur(f8, f8, Size(0, 0), 1.5);  // content a lossy codec keeps within a few levels
    f8.convertTo(f16, CV_16U, 257.0);
    f16 += Scalar(100, 50, 0);  // values an 8-bit path cannot hold
    for (const std::string c : {"h265", "prores", "ffv1"}) {
        VideoSinkOptions o;
        o.codec = c;
        const std::string p = tmp / ("c_" + c + (c == "ffv1" ? ".mkv" : ".mov"));
        {
            VideoSink s(p, 10, size, o);
            for (int i = 0; i < 3; ++i)
                s.write(f16);
            s.close();
        }
        VideoReadOptions ro;
        ro.depth = CV_16U;
        VideoReader r(p, ro);
        EXPECT_EQ(r.codecName(), c == "h265" ? "hevc" : c);
        Mat g;
        ASSERT_TRUE(r.read(g));
        ASSERT_EQ(g.type(), CV_16UC3);
        const double err = norm(g, f16, NORM_L1) / (double)g.total() / 3 / 257.0;
        std::printf("%s: mean error %.3f (of 255)\n", c.c_str(), err);
        if (c == "ffv1")
            EXPECT_EQ(norm(g, f16, NORM_INF), 0);
        else
            EXPECT_LT(err, 3.5);  // lossy (measured 2.5 for h265 4:2:0, 1.6 for prores)
        EXPECT_GE(r.bitDepth(), 10);
    }
    {
        VideoSinkOptions o;
        o.codec = "png";
        VideoSink s(tmp / "png/%04d.png", 10, size, o);
        s.write(f16);
        s.close();
        Mat back = imread(tmp / "png/0000.png", IMREAD_UNCHANGED);
        ASSERT_EQ(back.type(), CV_16UC3);
        EXPECT_EQ(norm(back, f16, NORM_INF), 0);
    }
    {
        VideoSinkOptions o;
        o.codec = "exr";
        VideoSink s(tmp / "exr/%04d.exr", 10, size, o);
        s.write(f8);
        s.close();
        ASSERT_TRUE(std::filesystem::exists(tmp / "exr/0000.exr"));
        // read back through FFmpeg: half floats, linear (sRGB curve undone)
        auto r = vbme_test::run("ffmpeg -v error -y -i " + (tmp / "exr/0000.exr") +
                                " -vf zscale=t=iec61966-2-1:tin=linear:p=bt709:pin=bt709,format="
                                "rgb24 " +
                                (tmp / "exr_back.png"));
        ASSERT_EQ(r.code, 0) << r.output;
        Mat back = imread(tmp / "exr_back.png");
        ASSERT_FALSE(back.empty());
        EXPECT_LT(norm(back, f8, NORM_L1) / (double)back.total() / 3, 1.0);
    }
    EXPECT_THROW(
        {
            VideoSinkOptions o;
            o.codec = "exr";
            VideoSink s(tmp / "x.mp4", 10, size, o);
        },
        cv::Exception);
}

TEST(CoreVideoAv, AviCountsFrames) {
    // AVI has one tick per frame: five frames stay five frames at their times
    vbme_test::ScratchDir tmp;
    const Size size(32, 24);
    {
        VideoSink s(tmp / "c.avi", 12.5, size);
        for (int i = 0; i < 5; ++i)
            s.write(Mat(size, CV_8UC3, Scalar(10 * i, 20, 30)));
        s.close();
    }
    VideoReader r(tmp / "c.avi");
    Mat f;
    int n = 0;
    while (r.read(f)) {
        EXPECT_NEAR(r.timestamp(), n / 12.5, 1e-6);
        EXPECT_EQ(f.at<Vec3b>(0, 0), Vec3b(10 * n, 20, 30));
        ++n;
    }
    EXPECT_EQ(n, 5);
}

TEST(CoreVideoAv, InputBitRateIsAFloorForTheDefaultQuality) {
    // "CRF 14 or the input's bit rate, whichever is higher": a lossy input coded at a higher
    // rate than CRF 14 needs (x264 CRF 6) is re-encoded at about its rate and keeps more of it
    // than CRF 14 does; a lossy input at a lower rate (CRF 30) is re-encoded as at CRF 14; a
    // lossless input (FFV1) sets no floor.
    vbme_test::ScratchDir tmp;
    const Size size(192, 144);
    // 4 s: the floor acts once x264's first packets are out, after its 40-frame look-ahead
    const int n = 100, fps = 25;
    auto write = [&](const std::string& path, const VideoSinkOptions& so) {
        VideoSink s(path, fps, size, so);
        for (int i = 0; i < n; ++i)
            s.write(renderedFrame(truthFrame(i % 50, size), i));
        s.close();
    };
    auto rateOf = [&](const std::string& path) {
        return (double)std::filesystem::file_size(path) * 8 / ((double)n / fps);
    };
    // @p input re-encoded at the default quality, with the floor sinkOptionsFrom sets (as every
    // command does) or without it; returns the floor
    auto reencode = [&](const std::string& input, const std::string& out, bool with_floor) {
        VideoReader r(input);
        VideoSinkOptions so = sinkOptionsFrom(r, out);
        const int64 floor = so.min_bitrate;
        if (!with_floor) so.min_bitrate = 0;
        so.min_psnr = 0;  // the bit-rate floor alone, from plain CRF 14 (no quality trials)
        VideoSink s(out, r.fps(), r.frameSize(), so);
        Mat f;
        while (r.read(f))
            s.write(f, r.timestamp());
        s.close();
        return floor;
    };
    VideoSinkOptions hi, lo, lossless;
    hi.crf = 6;
    lo.crf = 30;
    hi.min_psnr = lo.min_psnr = 0;  // inputs at exactly these CRFs
    lossless.codec = "ffv1";
    write(tmp / "hi.mp4", hi);
    write(tmp / "lo.mp4", lo);
    write(tmp / "lossless.mkv", lossless);

    const int64 floor_hi = reencode(tmp / "hi.mp4", tmp / "hi_out.mp4", true);
    reencode(tmp / "hi.mp4", tmp / "hi_crf14.mp4", false);
    const int64 floor_lo = reencode(tmp / "lo.mp4", tmp / "lo_out.mp4", true);
    reencode(tmp / "lo.mp4", tmp / "lo_crf14.mp4", false);
    const int64 floor_ll = reencode(tmp / "lossless.mkv", tmp / "ll_out.mp4", true);

    const auto in_hi = vbme_test::readVideoFrames(tmp / "hi.mp4"),
               out_hi = vbme_test::readVideoFrames(tmp / "hi_out.mp4"),
               crf14_hi = vbme_test::readVideoFrames(tmp / "hi_crf14.mp4");
    ASSERT_EQ((int)in_hi.size(), n);
    ASSERT_EQ((int)out_hi.size(), n);
    ASSERT_EQ((int)crf14_hi.size(), n);
    const double r_in = rateOf(tmp / "hi.mp4"), r_out = rateOf(tmp / "hi_out.mp4"),
                 r_crf14 = rateOf(tmp / "hi_crf14.mp4");
    const double p_out = psnrOf(out_hi, in_hi), p_crf14 = psnrOf(crf14_hi, in_hi);
    std::printf(
        "bit-rate floor: input (x264 CRF 6) %.2f Mbit/s, reader's rate %.2f; re-encoded with the "
        "floor %.2f Mbit/s, %.2f dB against the input's frames; at plain CRF 14 %.2f Mbit/s, "
        "%.2f dB\n",
        r_in / 1e6, floor_hi / 1e6, r_out / 1e6, p_out, r_crf14 / 1e6, p_crf14);
    std::printf(
        "low-rate input (CRF 30) %.2f Mbit/s: re-encoded with the floor %.3f Mbit/s, at plain "
        "CRF 14 %.3f Mbit/s; lossless input: floor %lld\n",
        rateOf(tmp / "lo.mp4") / 1e6, rateOf(tmp / "lo_out.mp4") / 1e6,
        rateOf(tmp / "lo_crf14.mp4") / 1e6, (long long)floor_ll);
    EXPECT_GT(floor_hi, 0.8 * r_in);    // the video stream's rate, as the reader gives it
    EXPECT_GT(r_in, 1.5 * r_crf14);     // above what CRF 14 spends: the floor must act
    EXPECT_GT(r_out, 0.75 * floor_hi);  // the first ~2 s are encoded at CRF 14
    EXPECT_GT(p_out, p_crf14 + 0.5);
    // below the CRF's rate the floor changes nothing (the same packets; the file differs only
    // by the encoder-settings tag); a lossless input sets none
    EXPECT_GT(floor_lo, 0);
    EXPECT_NEAR(rateOf(tmp / "lo_out.mp4"), rateOf(tmp / "lo_crf14.mp4"), 2000.0);
    EXPECT_EQ(floor_ll, 0);
}

// The quality floor (VideoSinkOptions::min_psnr): on noisy textured frames, where x264's CRF 14
// keeps well under 48 dB of the frames written, the default video keeps at least the floor
// (4:4:4, so that the conversion's own loss stays far above it); the same frames with the floor
// off (the CRF as given) are the control that shows the trials acted. A video shorter than
// the trial (2 frames) is chosen for at close().
TEST(CoreVideoAv, QualityFloorLowersTheCrfUntilTheFramesAreKept) {
    vbme_test::ScratchDir tmp;
    const Size size(128, 96);
    const int n = 8;
    std::vector<Mat> frames;
    for (int i = 0; i < n; ++i)
        frames.push_back(renderedFrame(truthFrame(i, size), i));
    auto roundTrip = [&](const std::string& name, double min_psnr, int count) {
        VideoSinkOptions so;
        so.full_chroma = true;
        so.min_psnr = min_psnr;
        {
            VideoSink s(tmp / name, 24, size, so);
            for (int i = 0; i < count; ++i)
                s.write(frames[i]);
            s.close();
        }
        const std::vector<Mat> back = vbme_test::readVideoFrames(tmp / name);
        EXPECT_EQ((int)back.size(), count) << name;
        if ((int)back.size() != count) return 0.0;
        return psnrOf(back, std::vector<Mat>(frames.begin(), frames.begin() + count));
    };
    const double p_floor = roundTrip("floor.mp4", 48, n), p_plain = roundTrip("plain.mp4", 0, n),
                 p_short = roundTrip("short.mp4", 48, 2);
    std::printf(
        "[ measured ] PSNR of the video against the frames written: quality floor 48 dB "
        "%.2f dB (2-frame video %.2f dB), CRF 14 as given %.2f dB\n",
        p_floor, p_short, p_plain);
    EXPECT_LT(p_plain, 45.0);  // the floor has work to do
    EXPECT_GE(p_floor, 47.5);  // kept: 0.5 dB for the frames after the trial
    EXPECT_GE(p_short, 47.5);
}
