// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Command-line tests of `vbme bench insert`'s cached reference: rendered in chunks, each
// cached once under a key of the scene and settings, reused by later runs, and its own noise
// estimated from two halves. Times are not asserted (benchmarks report them).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "vbme_test_util.hpp"

using vbme_test::run;
using vbme_test::ScratchDir;

namespace {

int count(const std::string& text, const std::string& what) {
    int n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
        ++n;
    return n;
}

// The chunk EXRs (and any other file) in the one key folder under @p cache.
std::vector<std::string> cachedFiles(const std::filesystem::path& cache) {
    std::vector<std::string> out;
    for (const auto& e : std::filesystem::recursive_directory_iterator(cache))
        if (e.is_regular_file()) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
}

double figure(const std::string& text, const std::string& pattern) {
    std::smatch m;
    EXPECT_TRUE(std::regex_search(text, m, std::regex(pattern))) << pattern << "\n" << text;
    return m.size() > 1 ? std::stod(m[1]) : -1;
}

}  // namespace

// 128x96 (the smallest size whose synthetic room shows its vanishing lines), 2-spp chunks.
TEST(AppBenchInsert, ReferenceChunksAreCachedOnceAndReused) {
    ScratchDir dir;
    const std::filesystem::path cache = dir / "cache";
    const std::string bench = "TMPDIR=" + dir.path().string() + " " + VBME_EXE +
                              " bench insert --width 128 --height 96 --spp 2 --ref-chunk-spp 2 "
                              "--repeat 1 --cache " +
                              cache.string();
    // two chunks rendered
    const auto a = run(bench + " --ref-spp 4 --ref-only");
    ASSERT_EQ(a.code, 0) << a.output;
    EXPECT_EQ(count(a.output, "  reference chunk "), 2) << a.output;
    const std::vector<std::string> two = {"chunk-0000.exr", "chunk-0001.exr"};
    EXPECT_EQ(cachedFiles(cache), two);
    // asked for three: only the third is rendered, then the whole bench runs against the
    // 6-spp reference; the halves (2 + 1 chunks of 2 spp) differ, every variant has an RMSE
    const auto b = run(bench + " --ref-spp 6");
    ASSERT_EQ(b.code, 0) << b.output;
    EXPECT_EQ(count(b.output, "  reference chunk "), 1) << b.output;
    EXPECT_NE(b.output.find("  reference chunk 3/3"), std::string::npos) << b.output;
    EXPECT_NE(b.output.find("reference: 6 spp (3 of 3 chunks)"), std::string::npos) << b.output;
    const double noise = figure(b.output, "so its own noise is ([0-9.]+)");
    EXPECT_GT(noise, 0);
    const double uniform = figure(b.output, "uniform 2 spp +[^\n]*RMSE ([0-9.]+)");
    const double defaults = figure(b.output, "vbme insert's defaults +[^\n]*RMSE ([0-9.]+)");
    EXPECT_GT(defaults, 0);
    // a 6-spp average is less noisy than a 2-spp render (its noise ~0.6x, the RMSE ~1.15x)
    EXPECT_LT(noise, 0.8 * uniform);
    EXPECT_NE(b.output.find("equal quality"), std::string::npos) << b.output;
    // no temporary file is left
    const std::vector<std::string> three = {"chunk-0000.exr", "chunk-0001.exr", "chunk-0002.exr"};
    EXPECT_EQ(cachedFiles(cache), three);
}
