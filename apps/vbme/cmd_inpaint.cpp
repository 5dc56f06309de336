// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme inpaint: remove an object from an image or a video by exemplar-based inpainting.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/inpaint.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

struct InpaintOptions {
    std::string image, mask, video, masks, out;
    std::string method = "patchmatch";
    std::string fill = "consensus", shadows = "remove", align = "flow";
    int patch = 9;
    int radius = 0;
    bool rgb = false;
    unsigned long long seed = 0;
    cv::vbme::VideoSinkOptions encode;
    CommonOptions common;
};

/** Reads a hole mask: 8-bit single channel, non-zero = hole. Says so if it is not binary. */
cv::Mat readMask(const std::string& path, bool quiet) {
    cv::Mat m = cv::vbme::imreadChecked(path, cv::IMREAD_GRAYSCALE);
    const int soft = cv::countNonZero((m > 0) & (m < 255));
    if (soft > 0 && !quiet)
        std::fprintf(stderr,
                     "vbme: note: %d pixels of '%s' are neither 0 nor 255; every non-zero pixel is "
                     "filled\n",
                     soft, path.c_str());
    return m;
}

cv::vbme::ExemplarInpainter::Params exemplarParams(const InpaintOptions& o) {
    cv::vbme::ExemplarInpainter::Params p;
    p.method = cv::vbme::parsePatchSearchMethod(o.method);
    p.patch_size = o.patch;
    p.color_space = o.rgb ? cv::vbme::PATCH_COLOR_RGB : cv::vbme::PATCH_COLOR_LAB;
    p.seed = o.seed;
    return p;
}

void runImage(const InpaintOptions& o) {
    cv::vbme::checkOverwrite(o.out, o.common.force);
    const cv::Mat img = cv::vbme::imreadChecked(o.image, cv::IMREAD_COLOR);
    const cv::Mat mask = readMask(o.mask, o.common.quiet);
    if (mask.size() != img.size())
        CV_Error(
            cv::Error::StsBadSize,
            cv::format("mask '%s' is %dx%d but image '%s' is %dx%d; they must match",
                       o.mask.c_str(), mask.cols, mask.rows, o.image.c_str(), img.cols, img.rows));
    cv::Mat out;
    cv::vbme::ExemplarInpainter::create(exemplarParams(o))->inpaint(img, mask, out);
    cv::vbme::imwriteAtomic(o.out, out);
}

void runVideo(const InpaintOptions& o) {
    namespace fs = std::filesystem;
    cv::vbme::checkOverwrite(o.out, o.common.force);
    std::error_code ec;
    if (!fs::is_directory(o.masks, ec))
        CV_Error(cv::Error::StsError,
                 "mask folder '" + o.masks + "' does not exist or is not a folder");
    cv::vbme::VideoReader reader(o.video);
    const int count = reader.frameCount();
    auto maskPath = [&](int i) { return (fs::path(o.masks) / cv::vbme::maskFileName(i)).string(); };
    // Check the masks before any work when the frame count is exact.
    if (reader.isImageSequence())
        for (int i = 0; i < count; ++i)
            if (!fs::exists(maskPath(i), ec))
                CV_Error(cv::Error::StsError,
                         cv::format("mask of frame %d is missing: expected '%s'", i,
                                    maskPath(i).c_str()));

    // Both fills stream: push a frame, pop what is finished.
    cv::Ptr<cv::vbme::VideoInpainter> vi;
    cv::Ptr<cv::vbme::ConsensusInpainter> ci;
    if (o.fill == "nearest") {
        cv::vbme::VideoInpainter::Params vp;
        vp.exemplar = exemplarParams(o);
        vp.temporal_radius = o.radius > 0 ? o.radius : 6;
        vi = cv::vbme::VideoInpainter::create(vp);
    } else {
        cv::vbme::ConsensusInpainter::Params cp;
        cp.exemplar = exemplarParams(o);
        cp.temporal_radius = o.radius;
        cp.shadows = cv::vbme::parseShadowMode(o.shadows);
        cp.alignment = o.align == "none"         ? cv::vbme::CONSENSUS_ALIGN_NONE
                       : o.align == "homography" ? cv::vbme::CONSENSUS_ALIGN_HOMOGRAPHY
                                                 : cv::vbme::CONSENSUS_ALIGN_FLOW;
        ci = cv::vbme::ConsensusInpainter::create(cp);
    }
    auto push = [&](const cv::Mat& f, const cv::Mat& m) {
        if (vi)
            vi->push(f, m);
        else
            ci->push(f, m);
    };
    auto pop = [&](cv::Mat& f) { return vi ? vi->pop(f) : ci->pop(f); };
    // the input's timestamps, colour tags and audio go to the output
    cv::vbme::VideoSink sink(o.out, reader.fps(), reader.frameSize(),
                             cv::vbme::sinkOptionsFrom(reader, o.out, o.encode));
    int written = 0;
    auto put = [&](const cv::Mat& f) { sink.write(f, reader.timestamps()[written++]); };
    cv::vbme::Progress progress("inpaint", count > 0 ? count : 0);
    cv::Mat frame, filled;
    int i = 0;
    while (reader.read(frame)) {
        const std::string mp = maskPath(i);
        if (!fs::exists(mp, ec))
            CV_Error(cv::Error::StsError,
                     cv::format("mask of frame %d is missing: expected '%s'", i, mp.c_str()));
        const cv::Mat mask = readMask(mp, o.common.quiet || i > 0);
        if (mask.size() != frame.size())
            CV_Error(cv::Error::StsBadSize,
                     cv::format("mask '%s' is %dx%d but the video frames are %dx%d", mp.c_str(),
                                mask.cols, mask.rows, frame.cols, frame.rows));
        push(frame, mask);
        ++i;
        while (pop(filled)) {
            put(filled);
            progress.tick();
        }
    }
    if (i == 0) CV_Error(cv::Error::StsError, "video '" + o.video + "' has no frames");
    if (vi)
        vi->finish();
    else
        ci->finish();
    while (pop(filled)) {
        put(filled);
        progress.tick();
    }
    sink.close();
    progress.finish();
}

void setupInpaint(CLI::App& app) {
    auto opt = std::make_shared<InpaintOptions>();
    app.footer(
        "Remove an object by exemplar-based inpainting (image) or by the consensus of aligned "
        "frames, with its cast shadow (video).\n"
        "  image: vbme inpaint --image IN.png --mask HOLE.png --out OUT.png\n"
        "  video: vbme inpaint --video IN.mp4 --masks DIR --out OUT.mp4 [--shadows keep|remove]\n"
        "Masks are 8-bit, non-zero = hole (255 = object); a video's are DIR/mask_%05d.png from "
        "frame 0, as 'vbme track' writes them.");
    auto* image = app.add_option("--image", opt->image, "Input image");
    auto* mask = app.add_option("--mask", opt->mask, "Hole mask of the image (non-zero = fill)");
    auto* video = app.add_option("--video", opt->video, "Input video file or image folder");
    auto* masks = app.add_option("--masks", opt->masks, "Folder of per-frame masks mask_%05d.png");
    app.add_option("--out", opt->out, "Output image or video")->required();
    app.add_option("--method", opt->method,
                   "Patch search: patchmatch (fast, default), vptree, local")
        ->check(CLI::IsMember({"patchmatch", "vptree", "local"}));
    app.add_option("--patch", opt->patch, "Patch side in pixels (odd, >= 3)")
        ->check(CLI::Range(3, 99))
        ->check(CLI::Validator(
            [](std::string& s) { return std::stoi(s) % 2 == 1 ? std::string() : "must be odd"; },
            "ODD"));
    app.add_option("--radius", opt->radius,
                   "Video: neighbouring frames on each side used to fill a frame (0 = from the "
                   "object's motion for the consensus fill, 6 for the nearest fill)")
        ->check(CLI::Range(0, 100));
    app.add_option("--fill", opt->fill,
                   "Video: consensus (default: a robust vote of aligned frames) or nearest (each "
                   "pixel from the nearest frame that sees it, the earlier method)")
        ->check(CLI::IsMember({"consensus", "nearest"}));
    app.add_option("--shadows", opt->shadows,
                   "Video, consensus fill: remove (default) or keep the object's cast shadow")
        ->check(CLI::IsMember({"keep", "remove"}));
    app.add_option("--align", opt->align,
                   "Video, consensus fill: flow (default: homography + dense flow where there is "
                   "parallax), homography, or none (static camera, fastest)")
        ->check(CLI::IsMember({"flow", "homography", "none"}));
    app.add_flag("--rgb", opt->rgb, "Measure patch distances in RGB instead of CIE Lab");
    app.add_option("--seed", opt->seed, "Seed of the randomised search");
    image->excludes(video)->excludes(masks)->needs(mask);
    mask->needs(image);
    video->excludes(mask)->needs(masks);
    masks->needs(video);
    addVideoOutputOptions(app, opt->encode);
    addCommonOptions(app, opt->common);
    app.callback([opt] {
        applyCommonOptions(opt->common);
        if (opt->image.empty() && opt->video.empty())
            throw CLI::ValidationError("give --image IN --mask HOLE or --video IN --masks DIR");
        if (!opt->image.empty())
            runImage(*opt);
        else
            runVideo(*opt);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("inpaint", "Remove an object (and its shadow) from an image or a video",
                      setupInpaint);

}  // namespace vbme_app
