// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Shared by the fuzz harnesses (fuzz/fuzz_<target>.cpp). Each harness defines
// LLVMFuzzerTestOneInput; it is linked either with libFuzzer (scripts/fuzz.sh, clang) or with
// replay_main.cpp (every build: CTest replays the seed corpus fuzz/corpus/<target>/).
#ifndef VBME_FUZZ_UTIL_HPP
#define VBME_FUZZ_UTIL_HPP

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include <opencv2/core.hpp>

namespace vbme_fuzz {

/** @brief Writes the input bytes to @p name in this process's scratch folder and returns the
path (the parsers under test read files, as the program does). */
std::string writeInput(const uint8_t* data, size_t size, const std::string& name);

/** @brief This process's scratch folder (created on first use, under $TMPDIR). */
const std::string& scratchDir();

/** @brief A finding: prints @p what with the input's message and aborts, so that libFuzzer
saves the input as a crash and the replay test fails. */
[[noreturn]] inline void finding(const std::string& what) {
    std::fprintf(stderr, "vbme-fuzz: FINDING: %s\n", what.c_str());
    std::fflush(stderr);
    std::abort();
}

/** @brief Runs @p parse, which reads the file @p path. Malformed input must end in a
cv::Exception whose message names the file; any other exception (std::out_of_range from a
number conversion, std::bad_alloc from an unchecked size, …) is a finding, as is a message that
does not say which file was wrong. Crashes, sanitizer reports and hangs are found by the
sanitizers and by libFuzzer's -timeout. */
template <class F>
void expectCleanError(const std::string& path, F&& parse) {
    try {
        parse();
    } catch (const cv::Exception& e) {
        if (e.err.find(path) == std::string::npos)
            finding("the message does not name the file '" + path + "': " + e.err);
    } catch (const std::exception& e) {
        finding(std::string("not a cv::Exception (") + typeid(e).name() + "): " + e.what());
    }
}

}  // namespace vbme_fuzz

#endif
