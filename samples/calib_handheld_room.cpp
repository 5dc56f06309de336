// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Makes a hand-held video of a textured box room with known cameras, and the frame-0 scene a
// user would get from `vbme calibrate`, to try `vbme track-camera` on:
//
//   vbme_sample_calib_handheld_room OUT_DIR [FRAMES]
//   vbme track-camera --video OUT_DIR/walk.mkv --scene OUT_DIR/frame0.yml
//        --out OUT_DIR/cameras.yml --overlay OUT_DIR/overlay.mp4
//
// OUT_DIR/true_cameras.yml holds the true camera path to compare with.
#include <cstdio>
#include <cstdlib>

#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

using namespace cv;
using namespace cv::vbme;

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s OUT_DIR [FRAMES]\n", argv[0]);
        return 2;
    }
    try {
        const std::string out = argv[1];
        const int frames = argc > 2 ? std::atoi(argv[2]) : 40;
        const Scene s0 = syntheticRoomScene();  // 4 x 5 x 2.6 m room, camera 1.5 m up
        const Camera first = s0.camera;
        const std::vector<Camera> path = handheldCameraPath(first, frames, 1.5, 0.01, 0.4, 5);
        const auto textures = makeRoomTextures(3, 1024);
        VideoSink video(out + "/walk.mkv", 30, s0.image_size);
        CameraPath truth;
        truth.K = first.K;
        truth.image_size = s0.image_size;
        for (int i = 0; i < frames; ++i) {
            video.write(renderTexturedRoom(path[i], s0.room, textures, 2));
            CameraPath::Frame f;
            f.index = i;
            f.R = path[i].R;
            f.t = path[i].t;
            truth.frames.push_back(f);
        }
        video.close();
        s0.write(out + "/frame0.yml");
        truth.write(out + "/true_cameras.yml");
        std::printf("wrote %s/walk.mkv (%d frames), %s/frame0.yml, %s/true_cameras.yml\n",
                    out.c_str(), frames, out.c_str(), out.c_str());
    } catch (const cv::Exception& e) {
        std::fprintf(stderr, "error: %s\n", e.err.c_str());
        return 1;
    }
    return 0;
}
