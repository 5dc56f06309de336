// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef VBME_APP_PIPELINE_PROGRESS_HPP
#define VBME_APP_PIPELINE_PROGRESS_HPP

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include <opencv2/vbme/core/progress.hpp>
#include <opencv2/vbme/pipeline/report.hpp>

namespace vbme_app {

/** @brief A pipeline progress callback that draws one progress bar per stage on stderr
(cv::vbme::Progress, so --quiet turns it off). The stage "waiting" (another process holds the
work folder) prints a line saying so. @p command names the command in that line. */
inline cv::vbme::PipelineProgress progressBars(const std::string& command) {
    struct State {
        std::string stage;
        std::unique_ptr<cv::vbme::Progress> bar;
    };
    auto state = std::make_shared<State>();
    return [state, command](const std::string& stage, int64_t done, int64_t total) {
        if (stage == "waiting") {
            if (cv::vbme::Progress::enabled())
                std::fprintf(stderr,
                             "vbme: another vbme %s holds the work folder: waiting for it\n",
                             command.c_str());
            return;
        }
        if (!state->bar || state->stage != stage) {
            state->bar.reset();  // finishes the previous stage's bar
            state->bar.reset(new cv::vbme::Progress(stage, total));
            state->stage = stage;
        }
        state->bar->set(done);
        if (total > 0 && done >= total) {
            state->bar.reset();
            state->stage.clear();
        }
    };
}

}  // namespace vbme_app

#endif
