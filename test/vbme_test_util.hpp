// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Helpers shared by the test programs: scratch folders and running the vbme program.
#ifndef VBME_TEST_UTIL_HPP
#define VBME_TEST_UTIL_HPP

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

namespace vbme_test {

/** @brief A fresh empty folder for the current test (removed when the object dies unless
VBME_KEEP_TEST_FILES is set, so that the pictures can be inspected). */
class ScratchDir {
public:
    ScratchDir() {
        const char* base = std::getenv("VBME_TEST_TMP");
        std::filesystem::path root =
            base ? base : std::filesystem::temp_directory_path() / "vbme-test";
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        std::string name =
            info ? std::string(info->test_suite_name()) + "." + info->name() : "test";
        path_ = root / (name + "-" + std::to_string(::getpid()));
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~ScratchDir() {
        if (!std::getenv("VBME_KEEP_TEST_FILES")) {
            std::error_code ec;
            std::filesystem::remove_all(path_, ec);
        }
    }
    std::string operator/(const std::string& name) const { return (path_ / name).string(); }
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

/** @brief The comma-separated fields of one line of a CSV file without quoting (the test
data's truth.csv and labels.csv). */
inline std::vector<std::string> csvFields(const std::string& line) {
    std::vector<std::string> t;
    std::stringstream ss(line);
    std::string x;
    while (std::getline(ss, x, ','))
        t.push_back(x);
    return t;
}

/** @brief Result of running a command: exit code and combined stdout+stderr. */
struct RunResult {
    int code = -1;
    std::string output;
};

/** @brief Runs a shell command line, capturing its output and exit code. */
inline RunResult run(const std::string& cmd) {
    RunResult r;
    FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
    if (!p) return r;
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0)
        r.output.append(buf, n);
    const int status = ::pclose(p);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

}  // namespace vbme_test

#endif
