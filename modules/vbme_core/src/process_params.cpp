// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read / write / check of ProcessOptions (runProcess() itself: utility.cpp).
#include <cmath>

#include "opencv2/vbme/core/params.hpp"
#include "opencv2/vbme/core/utility.hpp"

namespace cv {
namespace vbme {

void ProcessOptions::read(const FileNode& fn) {
    ParamsIn in(fn, "process options");
    if (const FileNode n = in.take("env"); !n.empty()) {
        if (!n.isSeq())
            CV_Error(Error::StsParseError,
                     "process options.env: expected a list of \"NAME=value\" strings");
        env.clear();
        for (const FileNode& e : n) {
            if (!e.isString())
                CV_Error(Error::StsParseError,
                         "process options.env: expected a list of \"NAME=value\" strings");
            env.push_back((std::string)e);
        }
    }
    in("working_dir", working_dir);
    in("timeout", timeout);
    in("kill_after", kill_after);
    in("log_file", log_file);
    in("input", input);
    in.finish();
    check();
}

void ProcessOptions::write(FileStorage& fs) const {
    fs << "env"
       << "[";
    for (const std::string& e : env)
        fs << e;
    fs << "]";
    fs << "working_dir" << working_dir << "timeout" << timeout << "kill_after" << kill_after
       << "log_file" << log_file << "input" << input;
}

void ProcessOptions::check() const {
    const char* w = "process options";
    for (const std::string& e : env)
        if (e.find('=') == std::string::npos || e.front() == '=')
            CV_Error(Error::StsBadArg, "process options.env = '" + e + "': expected NAME=value");
    checkParam(timeout >= 0 && std::isfinite(timeout), w, "timeout", timeout,
               ">= 0 seconds (0: none)");
    checkParam(kill_after >= 0 && std::isfinite(kill_after), w, "kill_after", kill_after,
               ">= 0 seconds");
}

}  // namespace vbme
}  // namespace cv
