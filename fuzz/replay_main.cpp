// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// A main() for the fuzz harnesses when libFuzzer is not used (gcc, the Release and ASan
// builds): feeds every file named on the command line (folders: every file inside, in name
// order) to LLVMFuzzerTestOneInput once. CTest runs it over fuzz/corpus/<target>/, so the
// seed inputs and every minimised crash stay fixed.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace fs = std::filesystem;

int main(int argc, char** argv) {
    std::vector<std::string> files;
    for (int i = 1; i < argc; ++i) {
        const fs::path p(argv[i]);
        if (fs::is_directory(p)) {
            std::vector<std::string> in;
            for (const auto& e : fs::recursive_directory_iterator(p))
                if (e.is_regular_file()) in.push_back(e.path().string());
            std::sort(in.begin(), in.end());
            files.insert(files.end(), in.begin(), in.end());
        } else if (fs::is_regular_file(p)) {
            files.push_back(p.string());
        } else {
            std::fprintf(stderr, "replay: '%s' is neither a file nor a folder\n", argv[i]);
            return 2;
        }
    }
    if (files.empty()) {
        std::fprintf(stderr, "replay: no input files (usage: %s FILE|DIR...)\n", argv[0]);
        return 2;
    }
    for (const auto& f : files) {
        std::ifstream in(f, std::ios::binary);
        const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                      std::istreambuf_iterator<char>());
        std::fprintf(stderr, "replay: %s (%zu bytes)\n", f.c_str(), bytes.size());
        LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    }
    std::printf("replay: %zu inputs, no finding\n", files.size());
    return 0;
}
