// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The sub-command table of the vbme program. Each cmd_<name>.cpp registers itself with
// VBME_REGISTER_COMMAND; main.cpp builds the CLI11 application from the table.
#ifndef VBME_APP_COMMAND_HPP
#define VBME_APP_COMMAND_HPP

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/vbme/core/video.hpp>

namespace vbme_app {

/** @brief One sub-command: its name, one-line summary, and a function that adds its options
to a CLI11 sub-app and sets the callback that runs it. The callback throws cv::Exception for
bad input or failures (exit 1) and CLI::ValidationError for usage errors (exit 2). */
struct Command {
    std::string name;
    std::string summary;
    std::function<void(CLI::App&)> setup;
};

/** @brief All registered commands, in DESIGN order. */
std::vector<Command>& commands();

/** @brief Registers a command at static-initialisation time. */
struct CommandRegistrar {
    CommandRegistrar(const char* name, const char* summary, std::function<void(CLI::App&)> setup) {
        commands().push_back({name, summary, std::move(setup)});
    }
};

/** @brief Options every command has. */
struct CommonOptions {
    bool force = false;  //!< overwrite existing outputs
    bool quiet = false;  //!< no progress output
};

/** @brief Adds --force and --quiet to @p app, writing into @p opts. */
void addCommonOptions(CLI::App& app, CommonOptions& opts, bool with_force = true);

/** @brief Adds the video output options --codec, --crf, --pix-fmt and --bitrate to @p app,
writing into @p opts (see cv::vbme::VideoSinkOptions). */
void addVideoOutputOptions(CLI::App& app, cv::vbme::VideoSinkOptions& opts);

/** @brief Applies the common options (turns progress off when quiet). */
void applyCommonOptions(const CommonOptions& opts);

/** @brief The whole program: parses @p argv, runs the command, returns the exit code (0, 1 bad
input or failure, 2 usage). With @p parse_only the commands' options are parsed and checked
(CLI11 validators) but no command runs (the CLI fuzz target). */
int vbmeMain(int argc, char** argv, bool parse_only = false);

/** @brief The command line as one string (for provenance headers). */
const std::string& commandLine();

}  // namespace vbme_app

#define VBME_CONCAT_INNER(a, b) a##b
#define VBME_CONCAT(a, b) VBME_CONCAT_INNER(a, b)
/** Registers a command: VBME_REGISTER_COMMAND("track", "Track a ball", setupFunction); */
#define VBME_REGISTER_COMMAND(name, summary, setup) \
    static ::vbme_app::CommandRegistrar VBME_CONCAT(vbme_command_, __LINE__)(name, summary, setup)

#endif
