// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <algorithm>
#include <cstdio>
#include <iostream>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/vbme/core.hpp>

#include "command.hpp"

namespace vbme_app {

std::vector<Command>& commands() {
    static std::vector<Command> table;
    return table;
}

static std::string g_command_line;
const std::string& commandLine() {
    return g_command_line;
}

void addCommonOptions(CLI::App& app, CommonOptions& opts, bool with_force) {
    if (with_force) app.add_flag("--force", opts.force, "Overwrite existing outputs");
    app.add_flag("-q,--quiet", opts.quiet, "Print no progress");
}

void addVideoOutputOptions(CLI::App& app, cv::vbme::VideoSinkOptions& opts) {
    app.add_option("--codec", opts.codec,
                   "Output codec: h264 (default for .mp4/.mov), h265, prores, ffv1 (default for "
                   ".mkv/.avi); png (16-bit) or exr (linear half float) for an image pattern such "
                   "as out/%05d.png")
        ->check(CLI::IsMember({"h264", "h265", "prores", "ffv1", "png", "exr"}));
    app.add_option("--crf", opts.crf,
                   "Quality of h264/h265 (constant rate factor, lower is better); h264 output "
                   "from a lossy input keeps at least the input's bit rate")
        ->check(CLI::Range(0, 51))
        ->capture_default_str();
    app.add_option("--min-psnr", opts.min_psnr,
                   "h264/h265: the lowest PSNR (dB) of the coding error, decoded frames against "
                   "the frames written; trial encodes of the first frames lower the CRF until it "
                   "is reached (0: off, the CRF as given; default: 48 for the overlays of track "
                   "and track-camera, off for the other outputs, which lose at most 0.3 dB at "
                   "CRF 14)")
        ->check(CLI::Range(0.0, 100.0));
    app.add_option("--preset", opts.preset,
                   "Speed preset of h264/h265 (x264/x265): slower presets give smaller files at "
                   "about the same quality, for more time")
        ->check(CLI::IsMember({"ultrafast", "superfast", "veryfast", "faster", "fast", "medium",
                               "slow", "slower", "veryslow", "placebo"}))
        ->capture_default_str();
    app.add_option("--pix-fmt", opts.pix_fmt,
                   "Pixel format of the encoded video, e.g. yuv444p, yuv420p10le (default: "
                   "yuv420p for h264/h265, yuv444p for the overlays of track and track-camera, "
                   "yuv422p10le for prores, bgr0 for ffv1)");
    app.add_option("--bitrate", opts.bitrate,
                   "h264/h265: encode at this average bit rate (bit/s) instead of the CRF")
        ->check(CLI::PositiveNumber);
}

void applyCommonOptions(const CommonOptions& opts) {
    cv::vbme::Progress::setEnabled(!opts.quiet);
}

}  // namespace vbme_app

int vbme_app::vbmeMain(int argc, char** argv, bool parse_only) {
    using namespace vbme_app;
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
    g_command_line.clear();
    for (int i = 0; i < argc; ++i)
        g_command_line += (i ? " " : "") + std::string(argv[i]);

    CLI::App app{
        "vbme: physically based editing of ordinary video.\n"
        "Re-renders a filmed object with a new material, or inserts synthetic objects into\n"
        "hand-held footage of a room. Run 'vbme <command> --help' for a command's options."};
    app.name("vbme");
    app.set_version_flag("--version", std::string("vbme ") + VBME_VERSION);
    app.require_subcommand(1);
    app.fallthrough(false);

    // DESIGN order; commands not in the list follow, by name.
    static const std::vector<std::string> order = {
        "track",     "inpaint",       "calibrate", "annotate", "track-camera", "render",
        "composite", "material-edit", "insert",    "demo",     "bench"};
    auto rank = [](const std::string& n) {
        auto it = std::find(order.begin(), order.end(), n);
        return it == order.end() ? order.size() : size_t(it - order.begin());
    };
    auto& table = commands();
    std::sort(table.begin(), table.end(), [&](const Command& a, const Command& b) {
        return rank(a.name) != rank(b.name) ? rank(a.name) < rank(b.name) : a.name < b.name;
    });
    for (const auto& c : table) {
        CLI::App* sub = app.add_subcommand(c.name, c.summary);
        c.setup(*sub);
    }

    if (argc > 1 && argv[1][0] != '-') {
        bool known = false;
        for (const auto& c : table)
            known = known || c.name == argv[1];
        if (!known) {
            std::string names;
            for (const auto& c : table)
                names += (names.empty() ? "" : ", ") + c.name;
            std::fprintf(stderr, "vbme: unknown command '%s' (commands: %s; see vbme --help)\n",
                         argv[1], names.c_str());
            return 2;
        }
    }
    // parse only: the root's parse-complete callback runs after every option is parsed and
    // checked and before any command's callback (replacing the commands' callbacks would free
    // the option structures they own)
    struct ParseOnlyDone {};
    if (parse_only) app.parse_complete_callback([] { throw ParseOnlyDone{}; });
    try {
        app.parse(argc, argv);
    } catch (const ParseOnlyDone&) {
        return 0;
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return 2;
    } catch (const cv::Exception& e) {
        std::fprintf(stderr, "vbme: error: %s\n", e.err.c_str());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "vbme: error: %s\n", e.what());
        return 1;
    }
    return 0;
}

#ifndef VBME_APP_NO_MAIN
int main(int argc, char** argv) {
    return vbme_app::vbmeMain(argc, argv);
}
#endif
