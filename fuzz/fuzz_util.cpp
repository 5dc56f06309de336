// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "fuzz_util.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;

namespace vbme_fuzz {

const std::string& scratchDir() {
    static const std::string dir = [] {
        const char* tmp = std::getenv("TMPDIR");
        const fs::path base = tmp && *tmp ? fs::path(tmp) : fs::path("/tmp");
        const fs::path d = base / ("vbme_fuzz_" + std::to_string(::getpid()));
        fs::create_directories(d);
        return d.string();
    }();
    return dir;
}

namespace {
// Removes the scratch folder when the process ends normally.
struct Cleanup {
    ~Cleanup() {
        std::error_code ec;
        if (!dir.empty()) fs::remove_all(dir, ec);
    }
    std::string dir;
} cleanup;
}  // namespace

std::string writeInput(const uint8_t* data, size_t size, const std::string& name) {
    if (cleanup.dir.empty()) cleanup.dir = scratchDir();
    const std::string path = (fs::path(scratchDir()) / name).string();
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), (std::streamsize)size);
    f.close();
    if (!f) finding("cannot write the scratch file " + path);
    return path;
}

}  // namespace vbme_fuzz
