// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Removes a region from an image with each of the three patch searches and writes the results
// side by side.
//
//   vbme_sample_inpaint_image IMAGE MASK OUT.png     (mask: non-zero = remove)
//   vbme_sample_inpaint_image                        (the thesis's three disks → three_disks.png)
#include <cstdio>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/inpaint.hpp>

int main(int argc, char** argv) {
    using namespace cv;
    using namespace cv::vbme;
    try {
        Mat image, mask;
        std::string out = "three_disks.png";
        if (argc == 4) {
            image = imreadChecked(argv[1], IMREAD_COLOR);
            mask = imreadChecked(argv[2], IMREAD_GRAYSCALE);
            out = argv[3];
        } else if (argc == 1) {
            // Three dark disks, a triangle over their centres hides a wedge of each.
            const int S = 160;
            image = Mat(S, S, CV_8UC3, Scalar(200, 200, 200));
            mask = Mat::zeros(S, S, CV_8U);
            const std::vector<Point> c = {{80, 32}, {32, 120}, {128, 120}};
            for (const Point& p : c)
                circle(image, p, 22, Scalar(40, 40, 40), FILLED);
            fillConvexPoly(mask, c, Scalar(255));
        } else {
            std::fprintf(stderr, "usage: %s [IMAGE MASK OUT.png]\n", argv[0]);
            return 2;
        }

        std::vector<Mat> panels;
        Mat shown = image.clone();
        shown.setTo(Scalar(255, 255, 255), mask);
        panels.push_back(shown);
        for (PatchSearchMethod m :
             {PATCH_SEARCH_LOCAL, PATCH_SEARCH_VPTREE, PATCH_SEARCH_PATCHMATCH}) {
            ExemplarInpainter::Params p;
            p.method = m;
            p.patch_size = 9;
            Ptr<ExemplarInpainter> inpainter = ExemplarInpainter::create(p);
            const int64 t0 = getTickCount();
            Mat filled;
            inpainter->inpaint(image, mask, filled);
            std::printf("%-10s %8.1f ms\n", toString(m).c_str(),
                        (getTickCount() - t0) * 1000.0 / getTickFrequency());
            panels.push_back(filled);
        }
        Mat strip;
        hconcat(panels, strip);
        imwriteAtomic(out, strip);
        std::printf("wrote %s (hole, local, vptree, patchmatch)\n", out.c_str());
    } catch (const cv::Exception& e) {
        std::fprintf(stderr, "error: %s\n", e.err.c_str());
        return 1;
    }
    return 0;
}
