// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Fuzz target: the vbme program's option parsing (CLI11, every command's options and checks).
// The input is the argument list, one argument per line (or NUL-separated); the commands'
// callbacks are replaced by no-ops, so nothing runs and nothing is written. The exit code
// must be 0, 1 or 2 and nothing may crash.
#include <string>
#include <vector>

#include "command.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::vector<std::string> args = {"vbme"};
    std::string cur;
    for (size_t i = 0; i < size && args.size() < 64; ++i) {
        const char c = (char)data[i];
        if (c == '\n' || c == '\0') {
            args.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    if (!cur.empty() && args.size() < 64) args.push_back(cur);
    std::vector<char*> argv;
    for (auto& a : args)
        argv.push_back(a.data());
    argv.push_back(nullptr);
    const int code = vbme_app::vbmeMain((int)args.size(), argv.data(), true);
    if (code != 0 && code != 1 && code != 2)
        vbme_fuzz::finding("exit code " + std::to_string(code) + " (expected 0, 1 or 2)");
    return 0;
}
