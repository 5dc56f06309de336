// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/params.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace cv {
namespace vbme {

ParamsIn::ParamsIn(const FileNode& node, const char* what) : keys_(node, what) {}

FileNode ParamsIn::take(const char* key) {
    return keys_.node(key);
}

bool ParamsIn::readBool(const char* key, const FileNode& n) const {
    if (n.isString()) {
        const std::string s = (std::string)n;
        if (s == "true" || s == "True" || s == "TRUE") return true;
        if (s == "false" || s == "False" || s == "FALSE") return false;
    } else if (n.isInt() || n.isReal()) {
        const double d = (double)n;
        if (d == 0 || d == 1) return d != 0;
    }
    CV_Error(Error::StsParseError,
             what() + "." + key + ": expected a boolean (0, 1, true or false)");
}

size_t ParamsIn::pickName(const char* key, const FileNode& n,
                          const std::vector<std::string>& valid) const {
    std::string name = n.isString() ? (std::string)n : std::string();
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return (char)std::tolower(c); });
    for (size_t i = 0; i < valid.size(); i++)
        if (name == valid[i]) return i;
    std::string list;
    for (size_t i = 0; i < valid.size(); i++)
        list += (i == 0 ? "" : i + 1 == valid.size() ? " or " : ", ") + valid[i];
    CV_Error(Error::StsBadArg, what() + "." + key + ": unknown '" +
                                   (n.isString() ? (std::string)n : std::string("(not a name)")) +
                                   "' (expected " + list + ")");
}

double ParamsIn::readNumber(const char* key, const FileNode& n, bool whole, double lo,
                            double hi) const {
    if (!n.isInt() && !n.isReal())
        CV_Error(Error::StsParseError, what() + "." + key + ": expected a number");
    const double d = (double)n;
    if (std::isnan(d) || (whole && (d != std::floor(d) || d < lo || d > hi)))
        CV_Error(
            Error::StsParseError,
            format("%s.%s: %g is not %s", what().c_str(), key, d,
                   whole ? format("a whole number in [%.0f, %.0f]", lo, hi).c_str() : "a number"));
    return d;
}

std::string ParamsIn::readString(const char* key, const FileNode& n) const {
    if (!n.isString()) CV_Error(Error::StsParseError, what() + "." + key + ": expected a string");
    return (std::string)n;
}

std::vector<double> ParamsIn::readNumbers(const char* key, const FileNode& n, int count,
                                          bool whole) const {
    const bool ok_shape = n.isSeq() && (int)n.size() == count;
    std::vector<double> v;
    if (ok_shape)
        for (const FileNode& e : n) {
            if (!e.isInt() && !e.isReal()) break;
            const double d = (double)e;
            if (std::isnan(d) || (whole && (d != std::floor(d) || std::abs(d) > 2147483647.0)))
                break;
            v.push_back(d);
        }
    if ((int)v.size() != count)
        CV_Error(Error::StsParseError, format("%s.%s: expected a list of %d %s", what().c_str(),
                                              key, count, whole ? "integers" : "numbers"));
    return v;
}

void checkParam(bool ok, const char* what, const char* field, double value, const char* expected) {
    if (!ok)
        CV_Error(Error::StsBadArg, format("%s.%s = %g: expected %s", what, field, value, expected));
}

}  // namespace vbme
}  // namespace cv
