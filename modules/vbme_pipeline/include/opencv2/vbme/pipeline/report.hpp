// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_PIPELINE_REPORT_HPP
#define OPENCV_VBME_PIPELINE_REPORT_HPP

#include <functional>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_pipeline
//! @{

/** @brief Progress of a pipeline: called with the stage's name (as in PipelineReport::seconds),
the units of it that are finished and its total (0 when not known). Calls come from the thread
that runs the pipeline, never from worker threads. The command line draws them with Progress;
a library caller may log them, update a GUI, or ignore them (an empty function). */
using PipelineProgress = std::function<void(const std::string& stage, int64 done, int64 total)>;

/** @brief What a run of either pipeline (insertion, material editing) did: one shape for both,
written by `vbme insert --report` and `vbme material-edit --report` alike.

Frame counts refer to the frames the run was asked to process; a resumed or split run counts
the frames it found finished as skipped, and those another process was working on as busy.
Stage times are wall seconds in pipeline order. Results that only one pipeline has (the
insertion's white-point scale, the material edit's hole pixels filled by exemplars) are named
figures, so that the report's shape does not depend on the pipeline. */
struct CV_EXPORTS PipelineReport {
    std::string pipeline;        //!< "insert" or "material-edit"
    int frames_total = 0;        //!< frames of the input video
    int frames_processed = 0;    //!< frames this run made
    int frames_skipped = 0;      //!< frames found already finished (resume, split runs)
    int frames_busy = 0;         //!< frames another process was making
    int frames_lost = 0;         //!< frames where the object was lost (material edit)
    std::vector<int> missing;    //!< frames of the video still without an output frame
    bool video_written = false;  //!< whether the output video was written by this run
    std::string work;            //!< work folder used ("" when none)
    /** @brief Wall seconds per stage, in pipeline order. */
    std::vector<std::pair<std::string, double>> seconds;
    double total_seconds = 0;  //!< wall seconds of the whole run
    /** @brief Named results of the run (e.g. "spp", "white_scale", "pixels_exemplar"). */
    std::vector<std::pair<std::string, double>> figures;

    /** @brief Adds @p s seconds to stage @p stage (appended at the end when new). */
    void addSeconds(const std::string& stage, double s);
    /** @brief Seconds of stage @p stage (0 when absent). */
    double stageSeconds(const std::string& stage) const;
    /** @brief Sets figure @p name (appended at the end when new). */
    void setFigure(const std::string& name, double value);
    /** @brief Sets every figure of @p values as setFigure() would, in one pass over the
    figures already held (setFigure() looks each name up in turn: per-frame figures of a
    long video would make that quadratic). */
    void setFigures(const std::vector<std::pair<std::string, double>>& values);
    /** @brief Figure @p name, or @p default_value when absent. */
    double figure(const std::string& name, double default_value = 0) const;

    /** @brief The timing table (seconds and frames/s per stage), the frame counts and the
    figures, as text for a terminal or a log. */
    void print(std::ostream& out) const;
    /** @brief Writes the report's fields into an open FileStorage (at the current level). */
    void write(FileStorage& fs) const;
    /** @brief Reads what write() wrote; absent fields keep their defaults. */
    void read(const FileNode& node);
    /** @brief Writes the report as a YAML or JSON file (by extension), atomically. */
    void save(const std::string& path) const;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
