// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme composite: differential compositing of a differential render onto a frame.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct CompositeOptions {
    std::string background, layers, out, response = "srgb", scene;
    std::string shadows = "ratio";
    float alpha = 1.f;
    bool response_from_scene = false;  // --scene given, --response not
    CommonOptions common;
};

void runComposite(const CompositeOptions& o) {
    using namespace cv::vbme;
    checkOverwrite(o.out, o.common.force);
    const cv::Mat frame = imreadChecked(o.background, cv::IMREAD_ANYDEPTH | cv::IMREAD_COLOR);
    if (frame.depth() != CV_8U && frame.depth() != CV_16U)
        CV_Error(cv::Error::StsBadArg,
                 "--background '" + o.background + "': expected an 8- or 16-bit image");
    std::map<std::string, std::string> attr;
    DifferentialImages im = readDifferentialExr(o.layers, cv::noArray(), &attr);
    if (im.obj.size() != frame.size())
        CV_Error(cv::Error::StsBadSize,
                 cv::format("--background '%s' is %dx%d but the layers in '%s' are %dx%d",
                            o.background.c_str(), frame.cols, frame.rows, o.layers.c_str(),
                            im.obj.cols, im.obj.rows));
    // The lens: layers rendered through it (`vbme render` with camera.k1) say so in their header;
    // pinhole layers are warped to the --scene's lens here.
    const double layers_k1 = attr.count("vbme.k1") ? std::stod(attr.at("vbme.k1")) : 0.0;
    std::string lens = layers_k1 != 0 ? cv::format(", rendered through the lens k1 = %g", layers_k1)
                                      : std::string();
    Response response = parseResponse(o.response);
    if (!o.scene.empty()) {
        const Scene scene = Scene::read(o.scene);
        Camera cam = scene.camera;
        if (cam.image_size.area() <= 0) cam.image_size = scene.image_size;
        cam = cam.scaled(frame.size());
        if (layers_k1 != 0 && std::abs(layers_k1 - cam.k1) > 1e-9)
            CV_Error(cv::Error::StsBadArg,
                     cv::format("the layers in '%s' were rendered through the lens k1 = %g, the "
                                "scene '%s' has k1 = %g",
                                o.layers.c_str(), layers_k1, o.scene.c_str(), cam.k1));
        if (layers_k1 == 0 && cam.k1 != 0) {
            distortLayersK1(im, cam, cam);
            lens = cv::format(", warped to the lens k1 = %g", cam.k1);
        }
        if (o.response_from_scene) response = cam.response;
    }
    CompositeParams cp;
    cp.alpha = o.alpha;
    cp.response = response;
    cp.shadows = parseShadows(o.shadows, "--shadows");
    cv::Mat linear, enc;
    compositeDifferential(frame, im, linear, cp);
    encodeComposite(linear, enc, cp.response, frame.depth());
    imwriteAtomic(o.out, enc);
    std::printf("composited %dx%d (alpha %g, response %s, %s shadows%s)\n", frame.cols, frame.rows,
                o.alpha, toString(cp.response).c_str(), o.shadows.c_str(), lens.c_str());
}

void setupComposite(CLI::App& app) {
    auto o = std::make_shared<CompositeOptions>();
    app.footer(
        "Differential compositing (Debevec 1998):\n"
        "  result = M*obj + (1-M)*back\n"
        "  back = max(0, input + alpha*diff)            where diff = obj - noobj >= 0, or always\n"
        "                                               with --shadows additive\n"
        "  back = input*max(0, 1 + alpha*max(-1, diff/noobj))  where diff < 0 (ratio shadows)\n"
        "in linear space: the frame is linearised with --response, the layers (obj.*, diff.*,\n"
        "mask of an EXR written by `vbme render --differential`) are linear, and the result\n"
        "is re-encoded with the same response (16-bit output for a 16-bit frame).");
    app.add_option("--background", o->background, "The input frame (PNG/JPEG, display-encoded)")
        ->required();
    app.add_option("--layers", o->layers, "EXR with the obj.*, diff.* and mask layers")->required();
    app.add_option("--out", o->out, "Output image (.png)")->required();
    app.add_option("--alpha", o->alpha, "Scale of the difference term (default 1)");
    app.add_option("--shadows", o->shadows,
                   "Shadows (diff < 0): ratio (the frame loses the fraction of light the "
                   "render loses) or additive")
        ->check(CLI::IsMember({"ratio", "additive"}))
        ->capture_default_str();
    auto* resp = app.add_option("--response", o->response,
                                "Camera response of the frame (default: the --scene camera's, "
                                "else srgb)")
                     ->check(CLI::IsMember({"srgb", "gamma2.2", "linear"}));
    app.add_option("--scene", o->scene,
                   "Scene file whose camera filmed the frame: with a lens (camera.k1), layers "
                   "rendered without it (no vbme.k1 in their header, e.g. `vbme render "
                   "--no-lens`) are warped to it first (the frame's edges a barrel lens adds stay "
                   "without layers: render through the lens to fill them); layers rendered "
                   "through another lens are refused");
    addCommonOptions(app, o->common);
    app.callback([o, resp] {
        std::string e = std::filesystem::path(o->out).extension().string();
        for (auto& c : e)
            c = char(std::tolower((unsigned char)c));
        if (e != ".png") throw CLI::ValidationError("--out", "must be a .png file");
        o->response_from_scene = !o->scene.empty() && resp->count() == 0;
        applyCommonOptions(o->common);
        runComposite(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("composite",
                      "Composite a differential render onto a frame (Eq. 5.2 with ratio shadows, "
                      "linear space)",
                      setupComposite);

}  // namespace vbme_app
