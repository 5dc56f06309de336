// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Inserts a scene's objects into a video of a room with the insertion pipeline's C++ API:
// prepareInsertion() once (camera path, room textures, albedo, lights), then
// renderInsertionFrame() per frame, written with VideoSink. The work folder keeps the prepared
// scene, so a second run reuses it. (`vbme insert` adds locks, resume and split runs.)
//
//   vbme_sample_pipeline_insert video scene.yml cameras.yml out.mkv [spp]
#include <cstdio>
#include <iostream>
#include <string>

#include <opencv2/vbme/pipeline/insertion.hpp>

int main(int argc, char** argv) {
    if (argc < 5) {
        std::fprintf(stderr, "usage: %s video scene.yml cameras.yml out.mkv [spp]\n", argv[0]);
        return 2;
    }
    using namespace cv::vbme;
    try {
        InsertionParams p;
        p.video = argv[1];
        p.scene = argv[2];
        p.cameras = argv[3];
        p.out = argv[4];
        if (argc > 5) p.spp = std::stoi(argv[5]);
        p.force = true;
        // stages and their progress
        PipelineReport report;
        PreparedInsertion prepared = prepareInsertion(
            p,
            [](const std::string& stage, int64 done, int64 total) {
                if (done == total) std::printf("%s: %lld done\n", stage.c_str(), (long long)done);
            },
            &report);
        std::printf("prepared in %s (%s), white scale %.3f\n", prepared.work.c_str(),
                    prepared.reused ? "reused" : "made now", prepared.white_scale);
        // frames
        VideoReader in(p.video);
        // the input's timestamps, colour tags and audio carried over
        VideoSink out(p.out, in.fps(), prepared.scene.image_size, sinkOptionsFrom(in, p.out));
        cv::Mat frame, composite;
        for (int i = 0; i < prepared.frames && in.read(frame); ++i) {
            const int64 t0 = cv::getTickCount();
            renderInsertionFrame(prepared, i, frame, composite);
            out.write(composite, prepared.timestamps[i]);
            const double seconds = (double)(cv::getTickCount() - t0) / cv::getTickFrequency();
            report.addSeconds("render", seconds);
            ++report.frames_processed;
            std::printf("frame %d: %.2f s\n", i, seconds);
        }
        out.close();
        report.print(std::cout);
    } catch (const cv::Exception& e) {
        std::fprintf(stderr, "error: %s\n", e.err.c_str());
        return 1;
    }
    return 0;
}
