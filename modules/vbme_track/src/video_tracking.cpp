// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/track/video_tracking.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core.hpp"

namespace fs = std::filesystem;

namespace cv {
namespace vbme {

void drawTrackingOverlay(InputOutputArray _frame, const ObjectTracker::Result& r, Rect window,
                         int frame_index) {
    Mat frame = _frame.getMat();
    const int thick = std::max(1, frame.cols / 400);
    if (window.area() > 0 && window.area() < frame.size().area())
        rectangle(frame, window, Scalar(255, 255, 0), 1, LINE_AA);
    if (r.found) {
        const int shift = 4;  // sub-pixel drawing
        const Point c(cvRound(r.disk.center.x * (1 << shift)),
                      cvRound(r.disk.center.y * (1 << shift)));
        circle(frame, c, cvRound(r.disk.radius * (1 << shift)), Scalar(0, 255, 0), thick, LINE_AA,
               shift);
        drawMarker(frame, Point(cvRound(r.disk.center.x), cvRound(r.disk.center.y)),
                   Scalar(0, 255, 0), MARKER_CROSS, 10, thick, LINE_AA);
    }
    const std::string text =
        format("frame %d  confidence %.2f%s", frame_index, r.confidence, r.found ? "" : "  LOST");
    const double scale = std::max(0.4, frame.cols / 1280.0);
    putText(frame, text, Point(10, 10 + cvRound(22 * scale)), FONT_HERSHEY_SIMPLEX, scale,
            Scalar(0, 0, 0), thick + 2, LINE_AA);
    putText(frame, text, Point(10, 10 + cvRound(22 * scale)), FONT_HERSHEY_SIMPLEX, scale,
            r.found ? Scalar(255, 255, 255) : Scalar(0, 0, 255), thick, LINE_AA);
}

namespace {

// A sibling folder for the outputs until the job is complete; removed unless released.
class StagingDir {
public:
    explicit StagingDir(const fs::path& final_dir) {
        const fs::path parent =
            final_dir.has_parent_path() ? final_dir.parent_path() : fs::path(".");
        std::error_code ec;
        fs::create_directories(parent, ec);
        path_ = parent / (final_dir.filename().string() + ".partial-" + std::to_string(::getpid()));
        fs::remove_all(path_, ec);
        if (!fs::create_directories(path_, ec) || ec)
            CV_Error(Error::StsError,
                     "cannot create folder '" + path_.string() + "': " + ec.message());
    }
    ~StagingDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

}  // namespace

TrackVideoSummary trackVideo(const std::string& video, InputArray _first_mask,
                             const std::string& out_dir, const TrackVideoOptions& opt) {
    // Everything is checked before anything is written.
    opt.params.check();
    Mat first_mask = _first_mask.getMat();
    const fs::path dir(out_dir);
    std::error_code ec;
    if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
        CV_Error(Error::StsError, "'" + out_dir + "' exists and is not a folder");
    if (!opt.force) {
        checkOverwrite((dir / "track.csv").string(), false);
        checkOverwrite((dir / maskFileName(0)).string(), false);
        if (!opt.overlay.empty()) checkOverwrite(opt.overlay, false);
    }
    VideoReader reader(video);
    Mat frame;
    if (!reader.read(frame)) CV_Error(Error::StsError, "'" + video + "' holds no frame");
    if (first_mask.empty()) CV_Error(Error::StsBadArg, "the first-frame mask is empty (no image)");
    if (first_mask.size() != frame.size())
        CV_Error(Error::StsBadArg,
                 format("the first-frame mask is %dx%d but the video's frames are %dx%d",
                        first_mask.cols, first_mask.rows, frame.cols, frame.rows));
    Ptr<ObjectTracker> tracker = ObjectTracker::create(opt.params);
    tracker->init(frame, first_mask);

    TrackVideoSummary summary;
    summary.fps = reader.fps();
    summary.init_report = tracker->initReport();
    StagingDir staging(dir);
    std::unique_ptr<VideoSink> overlay;
    if (!opt.overlay.empty()) {
        // full chroma unless a pixel format is asked for: 4:2:0 blurs the one-pixel marks
        VideoSinkOptions so = sinkOptionsFrom(reader, opt.overlay, opt.overlay_encode);
        so.full_chroma = true;
        overlay.reset(new VideoSink(opt.overlay, reader.fps(), frame.size(), so));
    }
    const fs::path csv_tmp = staging.path() / "track.csv";
    std::ofstream csv(csv_tmp);
    if (!csv) CV_Error(Error::StsError, "cannot write '" + csv_tmp.string() + "'");
    csv << "frame,cx,cy,r,confidence\n";

    Progress progress("track", std::max(0, reader.frameCount()));
    ScopedTimer timer;
    Mat mask;
    int i = 0;
    do {
        const ObjectTracker::Result r = tracker->update(frame, mask);
        summary.results.push_back(r);
        if (!r.found) ++summary.lost;
        const std::string name = (staging.path() / maskFileName(i)).string();
        if (!imwrite(name, mask)) CV_Error(Error::StsError, "cannot write '" + name + "'");
        csv << format("%d,%.3f,%.3f,%.3f,%.4f\n", i, r.disk.center.x, r.disk.center.y,
                      r.disk.radius, r.confidence);
        if (overlay) {
            drawTrackingOverlay(frame, r, tracker->lastSearchWindow(), i);
            overlay->write(frame, reader.timestamp());
        }
        progress.tick();
        ++i;
    } while (reader.read(frame));
    summary.seconds = timer.stop();
    progress.finish();
    csv.close();
    if (!csv) CV_Error(Error::StsError, "cannot finish writing '" + csv_tmp.string() + "'");

    // Complete: move the results into place.
    if (overlay) overlay->close();
    fs::create_directories(dir, ec);
    if (ec) CV_Error(Error::StsError, "cannot create folder '" + out_dir + "': " + ec.message());
    if (opt.force) {
        // Masks of an earlier, longer run would otherwise be mistaken for this run's.
        for (const auto& e : fs::directory_iterator(dir, ec)) {
            const std::string n = e.path().filename().string();
            if (n.rfind("mask_", 0) == 0 && e.path().extension() == ".png")
                fs::remove(e.path(), ec);
        }
    }
    for (const auto& e : fs::directory_iterator(staging.path())) {
        fs::rename(e.path(), dir / e.path().filename(), ec);
        if (ec)
            CV_Error(Error::StsError,
                     "cannot move results into '" + out_dir + "': " + ec.message());
    }
    return summary;
}

}  // namespace vbme
}  // namespace cv
