// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The parts of `vbme demo`, one file each (demo_<part>.cpp): each makes its own input with
// known truth, runs one pipeline on it exactly as its command would, and writes what a person
// should watch.
#ifndef VBME_APP_DEMO_HPP
#define VBME_APP_DEMO_HPP

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/vbme/core/video.hpp>

namespace vbme_app {

/** @brief What the demo's parts share: where to write, how big, whether to overwrite. */
struct DemoContext {
    std::filesystem::path dir;          //!< the part's own output folder (created by the caller)
    int width = 640;                    //!< frame width of the generated clip
    int height = 480;                   //!< frame height
    int frames = 0;                     //!< number of frames (0: the part's default)
    int spp = 0;                        //!< render samples per pixel (0: the part's default)
    bool force = false;                 //!< overwrite existing outputs
    cv::vbme::VideoSinkOptions encode;  //!< encoding of the videos written (--codec, --crf, ...)
};

/** @brief What a part reports at the end: the files to watch and one-line figures. */
struct DemoResult {
    std::vector<std::string> watch;    //!< videos / images a person should open
    std::vector<std::string> figures;  //!< measured figures, one line each
};

/** @brief Wall seconds since @p t0 (the parts' timing figures). */
inline double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/** @brief Material editing (issue: `vbme material-edit`): a rendered clip of a coloured ball
rolling in a textured scene, edited to chrome and to glass. */
DemoResult runMaterialDemo(const DemoContext& ctx);

/** @brief Object insertion (`vbme insert`): a rendered hand-held video of a textured room plus
the annotation a user would give; calibrate → track-camera → insert a procedural object. */
DemoResult runInsertionDemo(const DemoContext& ctx);

}  // namespace vbme_app

#endif
