// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// runInsertion: the resumable file-to-file driver of `vbme insert`. Locks the work folder,
// prepares (prepareInsertion), renders the missing frames of [first, end) into
// <work>/frames (renderInsertionFrame), and assembles the output video once every frame is
// there. Several processes may share one work folder (split runs, render farms).
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>

#include "insertion/stages.hpp"
#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/render/film.hpp"

namespace cv {
namespace vbme {

namespace fs = std::filesystem;
using namespace insertion;

namespace {

// The frames folder records the settings its frames were made with; other settings need
// --force (the old frames go) or another work folder.
void checkFrameSettings(const PreparedInsertion& prep, int spp, bool force) {
    const Renderer::Params& rp = prep.render;
    const std::string settings = (fs::path(prep.work) / "frames" / "settings.yml").string();
    std::string want = format("%s spp=%d max_depth=%d seed=%llu", prep.fingerprint.c_str(), spp,
                              rp.max_depth, (unsigned long long)rp.seed);
    // ratio shadows (the default since they exist): frames made before them lack the word
    if (prep.composite.shadows == CompositeParams::SHADOWS_RATIO) want += " shadows=ratio";
    if (rp.adaptive_min_spp > 0 || rp.texture_cone > 0)
        want += format(" adaptive=%d,%g,%g texture_cone=%g", rp.adaptive_min_spp, rp.adaptive_error,
                       rp.adaptive_roulette, rp.texture_cone);
    if (prep.denoise > 0) want += format(" denoise=%d", prep.denoise);
    if (fs::exists(settings)) {
        FileStorage f(settings, FileStorage::READ);
        const std::string have = f.isOpened() ? (std::string)f["made_with"] : std::string();
        if (have != want) {
            if (!force)
                CV_Error(Error::StsBadArg,
                         "the frames in '" + (fs::path(prep.work) / "frames").string() +
                             "' were made with other settings (" + have + "; now " + want +
                             "): use another --work, or --force to render them again");
            fs::remove_all(fs::path(prep.work) / "frames");
            fs::remove_all(fs::path(prep.work) / "exr");
        }
    }
    if (!fs::exists(settings)) {
        AtomicFile af(settings);
        {
            FileStorage f(af.tempPath(), FileStorage::WRITE);
            f << "made_with" << want;
        }
        af.commit();
    }
}

// Renders the missing frames of [first, end): one pass over the video.
void renderFrames(const InsertionParams& p, PreparedInsertion& prep, int first, int end, int spp,
                  const PipelineProgress& progress, PipelineReport& rep) {
    const std::string& work = prep.work;
    int todo = 0;
    for (int i = first; i < end; ++i)
        if (!fs::exists(frameFile(work, i))) ++todo;
    VideoReader reader(p.video);
    Mat f, enc, linear;
    double render_seconds = 0, sample_sum = 0;
    int done = 0;
    for (int i = 0; i < end && reader.read(f); ++i) {
        if (i < first) continue;
        const std::string out_file = frameFile(work, i);
        if (fs::exists(out_file)) {
            ++rep.frames_skipped;
            continue;
        }
        // claim the frame: another process rendering it holds its lock (skip it); a frame
        // finished while we looked is there once we hold the lock
        FileLock frame_lock;
        const std::string lock_file = out_file + ".lock";
        if (!frame_lock.acquire(lock_file, false)) {
            ++rep.frames_busy;
            continue;
        }
        if (fs::exists(out_file)) {
            ++rep.frames_skipped;
            continue;
        }
        ScopedTimer timer(render_seconds);  // render, composite, write
        DifferentialImages im;
        renderInsertionFrame(prep, i, f, enc, &im, p.keep_exr ? &linear : nullptr);
        // the render's cost: camera paths per pixel (adaptive sampling varies it per pixel)
        sample_sum += im.samples.empty() ? (double)prep.render.spp : mean(im.samples)[0];
        if (p.keep_exr) {
            const Renderer::Params& rp = prep.render;
            const std::map<std::string, std::string> attr = {
                {"vbme.version", VBME_VERSION},
                {"vbme.commandLine", p.command_line},
                {"vbme.seed", std::to_string(rp.seed)},
                {"vbme.spp", std::to_string(spp)},
                {"vbme.maxDepth", std::to_string(rp.max_depth)},
                {"vbme.frame", std::to_string(i)},
                {"vbme.scene", p.scene},
                {"vbme.video", p.video},
                {"vbme.prepared", prep.fingerprint},
                {"vbme.response", toString(prep.scene.camera.response)},
                {"vbme.sampling",
                 rp.adaptive_min_spp > 0
                     ? format("correlated, adaptive %d..%d spp, error %g, roulette %g",
                              rp.adaptive_min_spp, rp.spp, rp.adaptive_error, rp.adaptive_roulette)
                     : std::string("correlated")},
                {"vbme.textureCone", format("%g", rp.texture_cone)},
                {"vbme.denoise", std::to_string(prep.denoise)},
                {"vbme.shadows", toString(prep.composite.shadows)}};
            writeDifferentialExr(exrFile(work, i), im, linear, attr);
        }
        imwriteAtomic(out_file, enc);  // last: its presence means the frame is done
        std::error_code ec;
        fs::remove(lock_file, ec);
        frame_lock.release();
        timer.stop();
        ++rep.frames_processed;
        if (progress) progress("render", ++done, todo);
    }
    rep.addSeconds("render", render_seconds);
    rep.setFigure("seconds_per_frame",
                  rep.frames_processed ? render_seconds / rep.frames_processed : 0);
    rep.setFigure("samples_per_pixel",
                  rep.frames_processed ? sample_sum / rep.frames_processed : 0);
}

// Assembles the output video from the frames folder. The input's timestamps (from the
// preparation's scan), colour tags and audio are carried by the sink; the input is opened
// for them but not decoded. A video file is written under a temporary name of ours, read back,
// then renamed: a short write (a full disk) the encoder did not report leaves no partial
// video under the output name.
void writeVideo(const InsertionParams& p, const PreparedInsertion& prep,
                const PipelineProgress& progress) {
    const int n = prep.frames;
    const bool pattern = p.out.find('%') != std::string::npos;
    std::unique_ptr<AtomicFile> vout;
    if (!pattern) vout.reset(new AtomicFile(p.out));
    const std::string target = vout ? vout->tempPath() : p.out;
    VideoReader reader(p.video);
    VideoSink sink(target, reader.fps(), prep.scene.image_size,
                   sinkOptionsFrom(reader, p.out, p.encode));
    double t = -1;
    for (int i = 0; i < n; ++i) {
        t = i < (int)prep.timestamps.size() ? prep.timestamps[i] : t + 1.0 / reader.fps();
        sink.write(imreadChecked(frameFile(prep.work, i), IMREAD_COLOR), t);
        if (progress) progress("encode", i + 1, n);
    }
    sink.close();
    if (vout) {
        int readable = 0;
        try {
            VideoReader check(target);
            while (check.read(noArray()))
                ++readable;
        } catch (const cv::Exception&) {
        }
        if (readable < n) {
            std::error_code ec;
            fs::remove(target, ec);
            CV_Error(Error::StsError,
                     format("the video '%s' came out incomplete (%d of %d frames readable; "
                            "disk full?): not written; the frames are kept in '%s', run the "
                            "command again to write it",
                            p.out.c_str(), readable, n, (fs::path(prep.work) / "frames").c_str()));
        }
        vout->commit();
    }
}

// runInsertion() inside runLimited(p.threads).
PipelineReport runInsertionLimited(const InsertionParams& p, const PipelineProgress& progress) {
    const int64 t_start = getTickCount();
    PipelineReport rep;
    rep.pipeline = "insert";
    for (const char* k :
         {"video", "tracking", "textures", "exposure", "albedo", "lights", "render", "encode"})
        rep.addSeconds(k, 0);
    p.check();
    checkOverwrite(p.out, p.force);
    const std::string work = p.workFolder();
    auto finish = [&] {
        rep.total_seconds = (double)(getTickCount() - t_start) / getTickFrequency();
        rep.save((fs::path(work) / "report.yml").string());
    };

    // from here to the first frame, one process at a time per work folder
    fs::create_directories(work);
    FileLock work_lock;
    lockWork(work_lock, work, progress);
    PreparedInsertion prep = prepareInsertion(p, progress, &rep);
    const int n = prep.frames;
    const int first = p.first, end = p.end < 0 ? n : p.end;
    const int spp = p.adaptive_min_spp > 0 ? prep.render.spp / 4 : prep.render.spp;
    rep.setFigure("spp", spp);
    // a preparation renders no frame: the render runs that follow choose the sampling (the
    // first one records it for the others)
    if (p.prepare_only) {
        finish();
        return rep;
    }
    checkFrameSettings(prep, spp, p.force);
    work_lock.release();

    renderFrames(p, prep, first, end, spp, progress, rep);

    // the output video, when every frame is there (one process assembles it)
    lockWork(work_lock, work, progress);
    for (int i = 0; i < n; ++i)
        if (!fs::exists(frameFile(work, i))) rep.missing.push_back(i);
    if (rep.missing.empty() && !p.force && fs::exists(p.out)) {
        rep.video_written = true;  // made meanwhile by another process on this work folder
    } else if (rep.missing.empty()) {
        ScopedTimer timer(stageSeconds(&rep, "encode"));
        writeVideo(p, prep, progress);
        rep.video_written = true;
    }
    finish();
    return rep;
}

}  // namespace

PipelineReport runInsertion(const InsertionParams& p, const PipelineProgress& progress) {
    // TBB work (the path tracer, irradiance albedo) limited to p.threads; OpenCV's own loops
    // are not (runLimited()); the process-wide cv::setNumThreads is left alone
    PipelineReport rep;
    runLimited(p.threads, [&] { rep = runInsertionLimited(p, progress); });
    return rep;
}

}  // namespace vbme
}  // namespace cv
