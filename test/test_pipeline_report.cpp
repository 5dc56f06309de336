// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// PipelineReport: figures set in bulk are the figures set one by one.
#include <gtest/gtest.h>

#include <opencv2/vbme/pipeline/report.hpp>

using namespace cv;
using namespace cv::vbme;

TEST(PipelineReport, SetFiguresIsSetFigureInTurn) {
    RNG rng(7);
    for (int trial = 0; trial < 20; ++trial) {
        PipelineReport one, bulk;
        for (int i = 0, n = rng.uniform(0, 6); i < n; ++i) {  // figures held before
            const std::string name = format("f%d", rng.uniform(0, 8));
            const double v = rng.uniform(-1.0, 1.0);
            one.setFigure(name, v);
            bulk.setFigure(name, v);
        }
        std::vector<std::pair<std::string, double>> values;
        for (int i = 0, n = rng.uniform(0, 30); i < n; ++i)  // repeats, old and new names
            values.emplace_back(format("f%d", rng.uniform(0, 16)), rng.uniform(-1.0, 1.0));
        for (const auto& kv : values)
            one.setFigure(kv.first, kv.second);
        bulk.setFigures(values);
        EXPECT_EQ(bulk.figures, one.figures) << "trial " << trial;
    }
}
