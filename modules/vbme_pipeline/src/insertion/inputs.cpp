// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion stage 1: the inputs. The scene (objects placed, checked against the room) and one
// decoding pass over the video that counts and fingerprints its frames, records their
// timestamps and keeps the frames the room textures and the light estimation will need.
#include <algorithm>

#include <opencv2/core/utils/logger.hpp>

#include "insertion/stages.hpp"
#include "opencv2/vbme/core/response.hpp"

namespace cv {
namespace vbme {
namespace insertion {

std::vector<int> textureFrames(InsertionParams::TextureMode mode, int n) {
    const int stride =
        mode == InsertionParams::TEXTURE_ACCUMULATE ? std::max(1, (n + 23) / 24) : std::max(1, n);
    std::vector<int> f;
    for (int i = 0; i < n; i += stride)
        f.push_back(i);
    return f;
}

std::vector<int> lightFrames(const std::vector<int>& tex) {
    std::vector<int> f;
    const int nl = std::min<int>(4, (int)tex.size());
    for (int k = 0; k < nl; ++k)
        f.push_back(tex[(size_t)k * tex.size() / nl]);
    return f;
}

namespace {

void checkObjectsInRoom(const Scene& scene) {
    const Room& r = scene.room;
    const double eps = 1e-6 * norm(r.max - r.min);
    for (size_t i = 0; i < scene.objects.size(); ++i) {
        Vec3d lo, hi;
        objectWorldBounds(scene.objects[i], lo, hi);
        for (int a = 0; a < 3; ++a)
            if (lo[a] < r.min[a] - eps || hi[a] > r.max[a] + eps)
                CV_Error(
                    Error::StsBadArg,
                    format("objects[%d] ('%s') spans [%.3f, %.3f, %.3f] … [%.3f, %.3f, "
                           "%.3f], outside the room [%.3f, %.3f, %.3f] … [%.3f, %.3f, "
                           "%.3f] (check world_from_object, or use --place)",
                           (int)i, scene.objects[i].mesh.c_str(), lo[0], lo[1], lo[2], hi[0], hi[1],
                           hi[2], r.min[0], r.min[1], r.min[2], r.max[0], r.max[1], r.max[2]));
    }
}

}  // namespace

Inputs readInputs(const InsertionParams& p, const PipelineProgress& progress,
                  PipelineReport* report) {
    Inputs in;
    Scene& scene = in.scene;
    scene = Scene::read(p.scene);
    if (!scene.has_room)
        CV_Error(Error::StsBadArg,
                 "scene '" + p.scene + "': no room (insertion needs the room box)");
    for (const std::string& w : scene.warnings())
        CV_LOG_WARNING(NULL, "vbme insert: " << p.scene << ": " << w);
    if (scene.objects.empty())
        CV_Error(Error::StsBadArg,
                 "scene '" + p.scene + "': no objects: to insert (add an `objects:` entry)");

    // One pass over the video. The frames to keep depend on the frame count, known for image
    // folders and (approximately) from the container otherwise: keep those of the expected
    // count; if the count turns out different the texture stage decodes the missing ones.
    {
        ScopedTimer timer(stageSeconds(report, "video"));
        // HDR input is converted to sRGB-encoded BT.709, which only the `srgb` response describes
        VideoReadOptions ro;
        if (scene.camera.response != Response::SRGB) {
            ro.hdr = HdrPolicy::Refuse;
            ro.purpose = "insert with camera.response " + toString(scene.camera.response) +
                         " (HDR input is converted to sRGB-encoded frames; use response srgb)";
        }
        VideoReader reader(p.video, ro);
        if (reader.frameSize() != scene.image_size)
            CV_Error(Error::StsBadSize,
                     format("the scene '%s' is for %dx%d images but the video '%s' has %dx%d "
                            "frames (annotate a frame of this video)",
                            p.scene.c_str(), scene.image_size.width, scene.image_size.height,
                            p.video.c_str(), reader.frameSize().width, reader.frameSize().height));
        const int expected = reader.frameCount();
        std::vector<int> want;
        if (expected > 0) {
            want = textureFrames(p.texture_mode, expected);
            for (int i : lightFrames(want))
                want.push_back(i);
        } else {
            want = {0};
        }
        std::sort(want.begin(), want.end());
        Hasher h;
        Mat f;
        int n = 0;
        while (reader.read(f)) {
            h.mat(f);
            if (std::binary_search(want.begin(), want.end(), n)) in.video.kept[n] = f.clone();
            ++n;
            if (progress) progress("video", n, std::max(expected, n));
        }
        h.num(reader.fps());
        in.video.frames = n;
        in.video.fps = reader.fps();
        in.video.pixels_hash = h.h;
        in.video.timestamps = reader.timestamps();
    }
    const int n = in.video.frames;
    if (n == 0) CV_Error(Error::StsBadArg, "video '" + p.video + "' has no frames");
    in.first = p.first;
    in.end = p.end < 0 ? n : p.end;
    if (in.first < 0 || in.first >= in.end || in.end > n)
        CV_Error(Error::StsOutOfRange,
                 format("frames %d:%d: the video '%s' has %d frames (expected 0 <= A < B <= %d)",
                        in.first, in.end, p.video.c_str(), n, n));

    // placement and the room check
    if (p.has_place)
        scene.objects[0].world_from_object = placeOnFloor(scene, scene.objects[0], p.place);
    checkObjectsInRoom(scene);
    return in;
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
