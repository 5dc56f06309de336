// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Chrome and glass material edits against a path-traced truth: RenderedBallClip renders the
// same clip (scene, light, path, sampler seeds) with the filmed Lambertian ball and with the
// new material; runMaterialEdit (the file API of `vbme material-edit`) turns the first into
// the second. The edit must be closer to the truth of its material than the unedited video is
// (the baseline), and closer to it than to the truth of the other material (so the comparison
// can tell a wrong material).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/core.hpp>
#include <opencv2/vbme/core/metrics.hpp>
#include <opencv2/vbme/datasets/rendered_ball_clip.hpp>
#include <opencv2/vbme/pipeline/material_edit.hpp>
#include <opencv2/vbme/track/disk.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

RenderedBallClip::Params clipParams() {
    RenderedBallClip::Params p;
    p.size = Size(200, 150);
    p.frames = 4;
    p.spp = 8;
    return p;
}

RenderedBallClip::Params withMaterial(const std::string& preset) {
    RenderedBallClip::Params p = clipParams();
    p.has_material = true;
    p.material = Material::preset(preset);
    return p;
}

// PSNR pooled over the clip inside the ball (the truth disk shrunk by 1.5 px, so that the
// comparison is about the ball's shading, not about its anti-aliased edge).
struct Pooled {
    double sse = 0, count = 0;
    void add(const Mat& a, const Mat& b, const Mat& region) {
        double s = 0, c = 0;
        regionPsnr(a, b, region, &s, &c);
        sse += s;
        count += c;
    }
    double psnr() const { return 10 * std::log10(255.0 * 255.0 * count / sse); }
};

Mat ballRegion(const RenderedBallClip& clip, int i) {
    Disk d = clip.truthDisk(i);
    d.radius -= 1.5f;
    Mat m;
    diskMask(clip.params().size, d, m);
    return m;
}

}  // namespace

TEST(DatasetsMaterialTruth, ChromeAndGlassEditsAgainstPathTracedTruth) {
    vbme_test::ScratchDir dir;
    const RenderedBallClip input(clipParams());
    const std::string video = dir / "input.mkv", mask = dir / "first_mask.png";
    input.write(video, mask);
    std::vector<Mat> filmed;  // the unedited frames (lossless), rendered once
    {
        VideoReader in(video);
        Mat f;
        while (in.read(f))
            filmed.push_back(f.clone());
    }
    ASSERT_EQ((int)filmed.size(), clipParams().frames);

    const std::vector<std::string> materials = {"chrome", "glass"};
    std::vector<std::vector<Mat>> truth(materials.size()), edit(materials.size());
    for (size_t m = 0; m < materials.size(); ++m) {
        const RenderedBallClip t(withMaterial(materials[m]));
        MaterialEditParams p;
        p.video = video;
        p.first_mask = mask;
        p.out = dir / (materials[m] + "/%05d.png");
        p.material = Material::preset(materials[m]);
        p.focal = input.focal();
        p.lookahead = 2;
        p.threads = 2;
        runMaterialEdit(p);
        for (int i = 0; i < clipParams().frames; ++i) {
            truth[m].push_back(t.frame(i));
            edit[m].push_back(imread(format(p.out.c_str(), i)));
            ASSERT_FALSE(edit[m].back().empty()) << materials[m] << " frame " << i;
            if (i == 0 && std::getenv("VBME_KEEP_TEST_FILES"))  // to look at
                imwrite(dir / (materials[m] + "_truth_00000.png"), truth[m].back());
        }
    }

    for (size_t m = 0; m < materials.size(); ++m) {
        const size_t other = 1 - m;
        Pooled edited, unedited, crossed, truths;
        for (int i = 0; i < clipParams().frames; ++i) {
            const Mat region = ballRegion(input, i);
            edited.add(edit[m][i], truth[m][i], region);
            unedited.add(filmed[i], truth[m][i], region);
            crossed.add(edit[m][i], truth[other][i], region);
            truths.add(truth[other][i], truth[m][i], region);
        }
        std::printf(
            "[ measured ] %s ball, PSNR inside the ball over %d frames: edit vs %s truth %.2f dB, "
            "unedited (baseline) %.2f dB, edit vs %s truth %.2f dB (the two truths: %.2f dB)\n",
            materials[m].c_str(), clipParams().frames, materials[m].c_str(), edited.psnr(),
            unedited.psnr(), materials[other].c_str(), crossed.psnr(), truths.psnr());
        EXPECT_GT(edited.psnr(), unedited.psnr()) << materials[m] << ": no better than no edit";
        EXPECT_GT(edited.psnr(), crossed.psnr())
            << materials[m] << ": the edit is closer to the other material's truth";
    }
}
