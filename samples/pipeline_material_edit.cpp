// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Edits the material of a filmed ball with the material-editing C++ API (MaterialEditor):
// frames go in one by one and come back edited after the editor's lookahead.
//
//   vbme_sample_pipeline_material_edit VIDEO FIRST_MASK.png MATERIAL OUT.mp4
//   vbme_sample_pipeline_material_edit OUT_DIR     (draws a small clip of a shaded ball)
//
// MATERIAL is a preset name (chrome, gold, glass, blue, ...). Prints, per frame, the disk used
// and the key light fitted to the ball's own shading, then the time spent per stage.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/pipeline/material_edit.hpp>

using namespace cv;
using namespace cv::vbme;

namespace {

/** Frame @p i of a small clip: a Lambertian orange ball lit from the upper left, moving over a
checkered floor (sRGB 8-bit). */
Mat drawnFrame(int i, Mat* first_mask) {
    const Size size(160, 120);
    Mat lin(size, CV_32FC3);
    const Point2f c(40.f + 6.f * i, 62.f);
    const float r = 18.f;
    const Vec3f to_light = normalize(Vec3f(-0.5f, -0.6f, -0.62f));
    for (int y = 0; y < size.height; y++)
        for (int x = 0; x < size.width; x++) {
            const float chk = ((x / 16 + y / 16) % 2) ? 0.3f : 0.18f;
            Vec3f v(chk, chk, chk * 1.1f);
            const float dx = (x - c.x) / r, dy = (y - c.y) / r;
            if (dx * dx + dy * dy <= 1) {
                const Vec3f n(dx, dy, -std::sqrt(1 - dx * dx - dy * dy));
                const float s = 0.7f * std::max(0.f, n.dot(to_light)) + 0.1f;
                v = Vec3f(0.05f, 0.25f, 0.8f) * s;  // BGR
            }
            lin.at<Vec3f>(y, x) = v;
        }
    if (first_mask) {
        *first_mask = Mat::zeros(size, CV_8U);
        circle(*first_mask, Point(cvRound(c.x), cvRound(c.y)), cvRound(r - 1), Scalar(255), FILLED);
    }
    Mat out;
    encode(lin, out, Response::SRGB, CV_8U);
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2 && argc != 5) {
        std::fprintf(stderr, "usage: %s VIDEO FIRST_MASK.png MATERIAL OUT.mp4 | %s OUT_DIR\n",
                     argv[0], argv[0]);
        return 2;
    }
    try {
        MaterialEditParams params;
        params.lookahead = 4;
        std::unique_ptr<VideoReader> video;
        std::unique_ptr<VideoSink> sink;
        Mat first_mask, frame;
        const int drawn_frames = 16;
        if (argc == 5) {
            video.reset(new VideoReader(argv[1]));
            if (!video->read(frame)) CV_Error(Error::StsBadArg, "the video holds no frame");
            first_mask = readObjectMask(argv[2], frame.size());
            params.material = Material::preset(argv[3]);
            // The edited video keeps the input's timestamps, colour tags and audio.
            sink.reset(new VideoSink(argv[4], video->fps(), frame.size(),
                                     sinkOptionsFrom(*video, argv[4], VideoSinkOptions())));
        } else {
            std::filesystem::create_directories(argv[1]);
            frame = drawnFrame(0, &first_mask);
            params.material = Material::preset("chrome");
        }

        Ptr<MaterialEditor> editor = MaterialEditor::create(params, first_mask);
        int written = 0;
        Mat edited;
        auto takeReady = [&] {
            while (editor->pop(edited)) {
                if (sink)
                    sink->write(edited);
                else
                    imwrite(std::string(argv[1]) + format("/edited_%05d.png", written), edited);
                const MaterialEditor::FrameResult& r = editor->results().back();
                std::printf(
                    "frame %d: disk (%.2f, %.2f) r %.2f%s, light towards (%.2f, %.2f, "
                    "%.2f), fit RMS %.4f\n",
                    r.index, r.disk[0], r.disk[1], r.disk[2], r.lost ? " (lost)" : "",
                    r.to_light[0], r.to_light[1], r.to_light[2], r.fit_rms);
                ++written;
            }
        };
        for (int i = 0;; ++i) {
            editor->push(frame);
            takeReady();  // nothing comes out until `lookahead` later frames went in
            if (video ? !video->read(frame) : i + 1 >= drawn_frames) break;
            if (!video) frame = drawnFrame(i + 1, nullptr);
        }
        editor->finish();
        takeReady();
        if (sink) sink->close();  // renames the finished file into place
        editor->report().print(std::cout);
    } catch (const cv::Exception& e) {
        std::fprintf(stderr, "error: %s\n", e.err.c_str());
        return 1;
    }
    return 0;
}
