// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme demo: the README's main job. Makes its own input (nothing is downloaded) and runs the
// pipelines on it, writing results a person can watch. The parts live in demo_<part>.cpp.
#include <chrono>
#include <cstdio>
#include <filesystem>

#include <opencv2/core.hpp>

#include "command.hpp"
#include "demo.hpp"

namespace vbme_app {

namespace {

struct DemoOptions {
    std::string out = "vbme-demo";
    std::string part = "all";
    cv::vbme::VideoSinkOptions encode;
    int width = 640, height = 480;
    int frames = 0, spp = 0;
    CommonOptions common;
};

void runDemo(const DemoOptions& o) {
    namespace fs = std::filesystem;
    struct Part {
        const char* name;
        DemoResult (*run)(const DemoContext&);
    };
    const Part parts[] = {{"insert", runInsertionDemo}, {"material", runMaterialDemo}};
    std::vector<std::pair<std::string, DemoResult>> results;
    for (const Part& p : parts) {
        if (o.part != "all" && o.part != p.name) continue;
        DemoContext ctx;
        ctx.dir = fs::path(o.out) / p.name;
        ctx.width = o.width;
        ctx.height = o.height;
        ctx.frames = o.frames;
        ctx.spp = o.spp;
        ctx.force = o.common.force;
        ctx.encode = o.encode;
        fs::create_directories(ctx.dir);
        std::printf("demo: --- %s ---\n", p.name);
        const auto t0 = std::chrono::steady_clock::now();
        DemoResult r = p.run(ctx);
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        r.figures.push_back(cv::format("%s demo took %.1f s", p.name, s));
        results.emplace_back(p.name, std::move(r));
    }
    std::printf("\ndemo: summary\n");
    for (const auto& [name, r] : results) {
        for (const std::string& f : r.figures)
            std::printf("  %s: %s\n", name.c_str(), f.c_str());
        for (const std::string& w : r.watch)
            std::printf("  %s: watch %s\n", name.c_str(), w.c_str());
    }
}

void setupDemo(CLI::App& app) {
    auto o = std::make_shared<DemoOptions>();
    app.footer(
        "Run vbme on input it makes itself (nothing is downloaded), writing under OUT/<part>/:\n"
        "  insert    a hand-held video of a textured room is rendered with vbme_render, with the\n"
        "            annotation a user would give; vbme runs calibrate -> track-camera -> insert\n"
        "            and writes the composited video (and the true one to compare).\n"
        "  material  a clip of a coloured ball rolling in a textured scene is rendered, tracked,\n"
        "            removed and re-rendered in chrome and in glass.\n"
        "The summary at the end names the videos to watch and the figures measured.");
    app.add_option("--out", o->out, "Output folder")->capture_default_str();
    app.add_option("--part", o->part, "Which part to run")
        ->check(CLI::IsMember({"all", "insert", "material"}))
        ->capture_default_str();
    app.add_option("--frames", o->frames, "Number of frames of each clip (0: each part's default)")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    app.add_option("--spp", o->spp, "Render samples per pixel (0: each part's default)")
        ->check(CLI::Range(0, 65536))
        ->capture_default_str();
    app.add_option("--width", o->width, "Frame width")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    app.add_option("--height", o->height, "Frame height")
        ->check(CLI::Range(64, 8192))
        ->capture_default_str();
    addVideoOutputOptions(app, o->encode);
    addCommonOptions(app, o->common);
    app.callback([o] {
        applyCommonOptions(o->common);
        runDemo(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("demo",
                      "Run the pipelines on clips vbme makes itself and write videos to watch",
                      setupDemo);

}  // namespace vbme_app
