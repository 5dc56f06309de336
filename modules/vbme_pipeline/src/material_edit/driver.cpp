// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, driver: runMaterialEdit from file to file. Decoding and encoding run in their
// own threads, joined to MaterialEditor's work by bounded queues: the decoder reads ahead and
// the encoder writes behind by at most kQueued frames each, so the three overlap while memory
// stays bounded whatever the video's length; frames are encoded in their order by one thread.
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <opencv2/core/utils/logger.hpp>

#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "stages.hpp"

namespace cv {
namespace vbme {

namespace fs = std::filesystem;

namespace {

/** Frames each queue between the threads holds at most. */
const size_t kQueued = 4;

/** A queue of at most @p capacity items between a producing and a consuming thread. close()
ends it: push() then refuses (returns false), pop() returns what is left, then false. */
template <class T>
class BoundedQueue {
public:
    explicit BoundedQueue(size_t capacity) : capacity_(capacity) {}
    bool push(T v) {
        std::unique_lock<std::mutex> l(m_);
        not_full_.wait(l, [&] { return q_.size() < capacity_ || closed_; });
        if (closed_) return false;
        q_.push_back(std::move(v));
        not_empty_.notify_one();
        return true;
    }
    bool pop(T& v) {
        std::unique_lock<std::mutex> l(m_);
        not_empty_.wait(l, [&] { return !q_.empty() || closed_; });
        if (q_.empty()) return false;
        v = std::move(q_.front());
        q_.pop_front();
        not_full_.notify_one();
        return true;
    }
    void close() {
        std::lock_guard<std::mutex> l(m_);
        closed_ = true;
        not_full_.notify_all();
        not_empty_.notify_all();
    }

private:
    std::mutex m_;
    std::condition_variable not_full_, not_empty_;
    std::deque<T> q_;
    size_t capacity_;
    bool closed_ = false;
};

/** A decoded frame and its time. */
struct Decoded {
    Mat frame;
    double time = 0;
};

/** An edited frame on its way to the encoder, with what is written beside it. */
struct Edited {
    Mat out, filled, hole, env;
    int index = 0;
    double time = 0;
};

/** On scope exit (an error included): closes the queue feeding or fed by a thread, so that
the thread stops, then joins it. */
template <class Q>
struct StopAndJoin {
    Q& queue;
    std::thread& thread;
    ~StopAndJoin() {
        queue.close();
        if (thread.joinable()) thread.join();
    }
};

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

    // ---- Decoding thread: reads ahead into `decoded`.
    BoundedQueue<Decoded> decoded(kQueued);
    std::exception_ptr decode_error;
    std::thread decoder([&] {
        try {
            for (;;) {
                Decoded d;  // a new buffer each frame: the queued ones stay untouched
                bool ok;
                {
                    ScopedTimer t(decode_s);
                    ok = reader.read(d.frame);
                }
                if (!ok) break;
                d.time = reader.timestamp();
                if (!decoded.push(std::move(d))) break;  // the run stopped
            }
        } catch (...) {
            decode_error = std::current_exception();
        }
        decoded.close();
    });
    StopAndJoin<BoundedQueue<Decoded>> stop_decoder{decoded, decoder};

    // ---- Encoding thread: writes `edited` in order (the only thread using the sinks).
    BoundedQueue<Edited> edited(kQueued);
    std::exception_ptr encode_error;
    std::thread encoder([&] {
        try {
            Edited e;
            while (edited.pop(e)) {
                ScopedTimer t(encode_s);
                sink.write(e.out, e.time);
                if (bg_sink) bg_sink->write(e.filled);
                if (!inter.empty()) {
                    imwriteAtomic((staging.dir / maskFileName(e.index)).string(), e.hole);
                    if (!e.env.empty() && e.index % p.env_every == 0) {
                        Mat ch[3];
                        split(e.env, ch);
                        writeExrChannels((staging.dir / format("env_%05d.exr", e.index)).string(),
                                         {{"R", ch[2]}, {"G", ch[1]}, {"B", ch[0]}});
                    }
                }
            }
        } catch (...) {
            encode_error = std::current_exception();
        }
        edited.close();  // a failed encoder refuses further frames
    });
    StopAndJoin<BoundedQueue<Edited>> stop_encoder{edited, encoder};
    // Hands the frames the editor has finished to the encoder; false when the encoder failed.
    auto drain = [&] {
        Edited e;
        while (editor->pop(e.out, e.filled, e.hole, e.env)) {
            e.index = editor->results().back().index;
            e.time = times[e.index];
            if (!edited.push(std::move(e))) return false;
            e = Edited();
            ++done;
            if (progress) progress("material-edit", done, total);
        }
        return true;
    };
    bool encoding = true, decoding = true;
    for (;;) {
        editor->push(frame);
        if (!(encoding = drain())) break;
        Decoded d;
        if (!decoded.pop(d)) break;
        times.push_back(d.time);
        frame = d.frame;  // the editor keeps its own reference to the previous frame
    }
    // the decoder's error is set before it closes its queue, which pop() saw (under its lock)
    if (encoding && decode_error) decoding = false;
    if (encoding && decoding) {
        editor->finish();
        encoding = drain();
    }
    edited.close();  // no more frames: the encoder finishes the queued ones and stops
    encoder.join();
    if (encode_error) std::rethrow_exception(encode_error);
    decoded.close();
    decoder.join();
    if (decode_error) std::rethrow_exception(decode_error);

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
    // which shadow handling ran (`--shadows auto` resolves it from the material)
    report.setFigure("shadows_removed", p.shadows == SHADOWS_REMOVE ? 1 : 0);
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
