// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, driver: runMaterialEdit from file to file. Decoding of the next frame and
// encoding of the last one run in their own threads, overlapping MaterialEditor's work.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <future>
#include <memory>
#include <vector>

#include <opencv2/core/utils/logger.hpp>

#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "stages.hpp"

namespace cv {
namespace vbme {

namespace fs = std::filesystem;

namespace {

/** Removes a staging folder on scope exit. */
struct Staging {
    fs::path dir;
    ~Staging() {
        if (!dir.empty()) {
            std::error_code ec;
            fs::remove_all(dir, ec);
        }
    }
};

PipelineReport runEdit(const MaterialEditParams& p, const PipelineProgress& progress,
                       std::vector<MaterialEditor::FrameResult>* results) {
    const auto t_start = std::chrono::steady_clock::now();
    double decode_s = 0, encode_s = 0;

    // ---- Check every input before any output is written.
    if (p.video.empty()) CV_Error(Error::StsBadArg, "material-edit: no input video given");
    if (p.first_mask.empty())
        CV_Error(Error::StsBadArg, "material-edit: no first-frame mask given");
    if (p.out.empty()) CV_Error(Error::StsBadArg, "material-edit: no output video given");
    p.check();
    checkOverwrite(p.out, p.force);
    const fs::path inter = p.intermediates;
    if (!inter.empty()) {
        std::error_code ec;
        if (fs::exists(inter, ec) && !fs::is_directory(inter, ec))
            CV_Error(Error::StsBadArg,
                     "intermediates folder '" + p.intermediates + "' exists and is not a folder");
        checkOverwrite((inter / maskFileName(0)).string(), p.force);
        checkOverwrite((inter / "background.mkv").string(), p.force);
        checkOverwrite((inter / "env_00000.exr").string(), p.force);
    }
    Ptr<EnvironmentMap> user_env;
    if (!p.env.empty()) user_env = makePtr<EnvironmentMap>(EnvironmentMap::load(p.env));

    VideoReadOptions read_opt;
    if (p.response != Response::SRGB) {
        read_opt.hdr = HdrPolicy::Refuse;
        read_opt.purpose = "material-edit with --response " + toString(p.response) +
                           " (HDR input is converted to sRGB-encoded frames; use --response srgb)";
    }
    VideoReader reader(p.video, read_opt);
    Mat frame;
    {
        ScopedTimer t(decode_s);
        if (!reader.read(frame))
            CV_Error(Error::StsBadArg, "video '" + p.video + "' holds no frame");
    }
    // The frames' times, kept by this thread: the reader's own list grows in the decoding
    // thread while the frames already decoded are being encoded.
    std::vector<double> times(1, reader.timestamp());
    const Size size = frame.size();
    // the first-frame mask: readable, of the video's size, marking some but not all pixels
    const Mat first_mask = readObjectMask(p.first_mask, size);
    Ptr<MaterialEditor> editor = MaterialEditor::create(p, first_mask, user_env);

    // ---- Outputs (temporary names until the end).
    VideoSink sink(p.out, reader.fps(), size, sinkOptionsFrom(reader, p.out, p.encode));
    Staging staging;
    std::unique_ptr<VideoSink> bg_sink;
    if (!inter.empty()) {
        fs::create_directories(inter);
        staging.dir = inter / format(".material-edit-%d", (int)::getpid());
        fs::remove_all(staging.dir);
        fs::create_directories(staging.dir);
        bg_sink.reset(new VideoSink((staging.dir / "background.mkv").string(), reader.fps(), size));
    }

    const int64 total = std::max(0, reader.frameCount());
    int64 done = 0;
    std::future<void> encoding;
    auto drain = [&] {
        Mat out, filled, hole, env;
        while (editor->pop(out, filled, hole, env)) {
            const int index = editor->results().back().index;
            // Encoding runs in its own thread, overlapping the next frame's work.
            if (encoding.valid()) encoding.get();
            encoding = std::async(
                std::launch::async, [&, out, filled, hole, env, index, time = times[index]] {
                    ScopedTimer t(encode_s);
                    sink.write(out, time);
                    if (bg_sink) bg_sink->write(filled);
                    if (!inter.empty()) {
                        imwriteAtomic((staging.dir / maskFileName(index)).string(), hole);
                        if (!env.empty() && index % p.env_every == 0) {
                            Mat ch[3];
                            split(env, ch);
                            writeExrChannels((staging.dir / format("env_%05d.exr", index)).string(),
                                             {{"R", ch[2]}, {"G", ch[1]}, {"B", ch[0]}});
                        }
                    }
                });
            ++done;
            if (progress) progress("material-edit", done, total);
        }
    };
    try {
        for (;;) {
            editor->push(frame);
            // Decode the next frame in its own thread while this one is processed.
            Mat next_frame;
            std::future<bool> decoding = std::async(std::launch::async, [&] {
                ScopedTimer t(decode_s);
                return reader.read(next_frame);
            });
            try {
                drain();
            } catch (...) {
                decoding.wait();
                throw;
            }
            if (!decoding.get()) break;
            times.push_back(reader.timestamp());
            frame = next_frame;  // the editor keeps its own reference to the previous frame
        }
        editor->finish();
        drain();
    } catch (...) {
        if (encoding.valid()) encoding.wait();
        throw;
    }

    if (encoding.valid()) encoding.get();
    {
        ScopedTimer t(encode_s);
        sink.close();
        if (bg_sink) bg_sink->close();
        if (!inter.empty()) {
            for (const auto& e : fs::directory_iterator(staging.dir)) {
                const fs::path dst = inter / e.path().filename();
                std::error_code ec;
                fs::remove(dst, ec);
                fs::rename(e.path(), dst);
            }
        }
    }

    if (results) *results = editor->results();
    PipelineReport report = editor->report();
    report.frames_total = (int)done;
    report.video_written = true;
    report.work = p.intermediates;
    report.seconds.insert(report.seconds.begin(), {"decode", decode_s});
    report.seconds.emplace_back("encode", encode_s);
    report.total_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    CV_LOG_INFO(NULL, "material-edit: " << report.frames_processed << " frames of '" << p.video
                                        << "' edited into '" << p.out << "' in "
                                        << report.total_seconds << " s");
    return report;
}

}  // namespace

PipelineReport runMaterialEdit(const MaterialEditParams& p, const PipelineProgress& progress,
                               std::vector<MaterialEditor::FrameResult>* results) {
    PipelineReport report;
    runLimited(p.threads, [&] { report = runEdit(p, progress, results); });
    return report;
}

}  // namespace vbme
}  // namespace cv
