// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Tracks a coloured ball and recovers its shape, with the vbme_track C++ API.
//
//   vbme_sample_track_ball VIDEO FIRST_MASK.png OUT_DIR
//   vbme_sample_track_ball OUT_DIR            (makes a synthetic clip with known truth)
//
// Writes OUT_DIR/overlay_%05d.png (disk drawn on the frame), OUT_DIR/fg_%05d.png (the cleaned
// object pixels), and OUT_DIR/normals.png (the recovered sphere's normals in the first frame).
#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/datasets/ball_clip.hpp>
#include <opencv2/vbme/track.hpp>

using namespace cv;
using namespace cv::vbme;

int main(int argc, char** argv) {
    if (argc != 2 && argc != 4) {
        std::fprintf(stderr, "usage: %s VIDEO FIRST_MASK.png OUT_DIR | %s OUT_DIR\n", argv[0],
                     argv[0]);
        return 2;
    }
    try {
        const std::string out = argv[argc - 1];
        std::filesystem::create_directories(out);

        // Frames come from a video, or from a synthetic clip whose truth we print alongside.
        std::unique_ptr<VideoReader> video;
        std::unique_ptr<SyntheticBallClip> clip;
        Mat frame, first_mask;
        if (argc == 4) {
            video.reset(new VideoReader(argv[1]));
            first_mask = imreadChecked(argv[2], IMREAD_GRAYSCALE);
        } else {
            SyntheticBallClip::Params p;
            p.frames = 30;
            clip.reset(new SyntheticBallClip(p));
            diskMask(p.size, clip->truth(0), first_mask);
        }
        auto next = [&](int i) {
            if (video) return video->read(frame);
            if (i >= clip->params().frames) return false;
            frame = clip->frame(i);
            return true;
        };

        Ptr<ObjectTracker> tracker = ObjectTracker::create();
        for (int i = 0; next(i); ++i) {
            if (i == 0) tracker->init(frame, first_mask);
            Mat mask;
            const ObjectTracker::Result r = tracker->update(frame, mask);
            std::printf("frame %d: centre (%.2f, %.2f) radius %.2f confidence %.3f%s", i,
                        r.disk.center.x, r.disk.center.y, r.disk.radius, r.confidence,
                        r.found ? "" : " LOST");
            if (clip) {
                const Disk t = clip->truth(i);
                std::printf("  truth (%.2f, %.2f) %.2f", t.center.x, t.center.y, t.radius);
            }
            std::printf("\n");

            Mat overlay = frame.clone();
            rectangle(overlay, tracker->lastSearchWindow(), Scalar(255, 255, 0), 1);
            if (r.found)
                circle(overlay, Point(cvRound(r.disk.center.x * 16), cvRound(r.disk.center.y * 16)),
                       cvRound(r.disk.radius * 16), Scalar(0, 255, 0), 1, LINE_AA, 4);
            imwrite(out + format("/overlay_%05d.png", i), overlay);
            imwrite(out + format("/fg_%05d.png", i), tracker->lastForeground());

            if (i == 0 && r.found) {
                // Shape recovery: the sphere's height map and its normals.
                Mat height, normals, picture;
                sphereHeightMap(frame.size(), r.disk, height);
                heightToNormals(height, mask, normals, NORMALS_CENTRAL);
                normalMapImage(normals, picture);
                imwrite(out + "/normals.png", picture);
            }
        }
    } catch (const cv::Exception& e) {
        std::fprintf(stderr, "error: %s\n", e.err.c_str());
        return 1;
    }
    return 0;
}
