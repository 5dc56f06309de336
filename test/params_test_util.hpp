// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Checks shared by the params tests (test_<module>_params.cpp): a params struct survives
// write → read unchanged in every field, an unknown key is refused by name, and check() names
// the field that is out of range.
#ifndef VBME_PARAMS_TEST_UTIL_HPP
#define VBME_PARAMS_TEST_UTIL_HPP

#include <gtest/gtest.h>

#include <map>
#include <string>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/video.hpp"

namespace vbme_test {

/** @brief @p p written as the map "p" of a YAML document, with an optional extra key. */
template <class P>
std::string paramsYaml(const P& p, const char* extra_key = nullptr) {
    cv::FileStorage fs(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
    fs << "p"
       << "{";
    p.write(fs);
    if (extra_key) fs << extra_key << 1;
    fs << "}";
    return fs.releaseAndGetString();
}

/** @brief Reads the map "p" of @p yaml into a default-constructed P. */
template <class P>
P paramsFromYaml(const std::string& yaml) {
    cv::FileStorage fs(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    P p;
    p.read(fs["p"]);
    return p;
}

/** @brief Text of a scalar or a sequence (nested sequences and maps included). */
inline std::string nodeText(const cv::FileNode& n) {
    if (n.isSeq() || n.isMap()) {
        std::string s = n.isSeq() ? "[" : "{";
        for (const cv::FileNode& e : n)
            s += (n.isMap() ? e.name() + ":" : std::string()) + nodeText(e) + ",";
        return s + (n.isSeq() ? "]" : "}");
    }
    return n.isString() ? "'" + (std::string)n + "'" : cv::format("%.17g", (double)n);
}

/** @brief Every field of the map @p n as "path" → text of its value (nested maps give paths
"a/b"; sequences are one value). */
inline void flattenNode(const cv::FileNode& n, const std::string& path,
                        std::map<std::string, std::string>& out) {
    if (n.isMap())
        for (const std::string& k : n.keys())
            flattenNode(n[k], path + "/" + k, out);
    else
        out[path] = nodeText(n);
}

inline std::map<std::string, std::string> flatYaml(const std::string& yaml) {
    cv::FileStorage fs(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    std::map<std::string, std::string> out;
    flattenNode(fs["p"], "", out);
    return out;
}

/** @brief @p changed differs from the defaults in every written field, and write → read →
write gives the same text (so read() takes back every field write() writes). */
template <class P>
void expectRoundTrip(const P& changed) {
    const std::string def = paramsYaml(P()), text = paramsYaml(changed);
    const auto fd = flatYaml(def), fc = flatYaml(text);
    ASSERT_EQ(fd.size(), fc.size()) << text;
    ASSERT_GT(fc.size(), 0u);
    for (const auto& kv : fc) {
        ASSERT_TRUE(fd.count(kv.first)) << kv.first;
        EXPECT_NE(fd.at(kv.first), kv.second)
            << "the test leaves field " << kv.first << " at its default";
    }
    P back;
    ASSERT_NO_THROW(back = paramsFromYaml<P>(text)) << text;
    EXPECT_EQ(paramsYaml(back), text);
}

/** @brief Text of the cv::Exception @p f throws ("" if none). */
template <class F>
std::string thrownBy(F f) {
    try {
        f();
    } catch (const cv::Exception& e) {
        return e.err;
    }
    return "";
}

/** @brief An unknown key is refused with its name and the valid keys (@p a_valid_key among
them) in the message. */
template <class P>
void expectUnknownKeyRefused(const char* a_valid_key) {
    const std::string yaml = paramsYaml(P(), "no_such_setting");
    const std::string err = thrownBy([&] { paramsFromYaml<P>(yaml); });
    EXPECT_NE(err.find("no_such_setting"), std::string::npos) << err;
    EXPECT_NE(err.find(a_valid_key), std::string::npos) << err;
    // the same text without the extra key is accepted
    EXPECT_EQ(thrownBy([&] { paramsFromYaml<P>(paramsYaml(P())); }), "");
}

/** @brief check() of @p bad throws naming @p field, and so does reading it from a file; the
defaults pass check(). */
template <class P>
void expectRejected(const P& bad, const std::string& field) {
    EXPECT_EQ(thrownBy([&] { P().check(); }), "");
    const std::string err = thrownBy([&] { bad.check(); });
    EXPECT_NE(err.find("." + field + " = "), std::string::npos) << "'" << err << "'";
    const std::string err_read = thrownBy([&] { paramsFromYaml<P>(paramsYaml(bad)); });
    EXPECT_NE(err_read.find(field), std::string::npos) << "'" << err_read << "'";
}

/** @brief VideoSinkOptions with every field away from its default. */
inline cv::vbme::VideoSinkOptions changedVideoSinkOptions() {
    cv::vbme::VideoSinkOptions o;
    o.codec = "h265";
    o.crf = 20;
    o.preset = "slow";
    o.bitrate = 4000000;
    o.min_bitrate = 2500000;
    o.min_psnr = 45.5;
    o.quality_trial_frames = 6;
    o.pix_fmt = "yuv444p";
    o.full_chroma = true;
    o.color.primaries = 9;
    o.color.transfer = 14;
    o.color.matrix = 9;
    o.color.range = 2;
    o.audio_from = "in.mp4";
    o.time_base = cv::Vec2i(1, 30);
    o.metadata = {{"comment", "converted"}, {"title", "t"}};
    o.progress = "encode";
    o.expected_frames = 120;
    return o;
}

}  // namespace vbme_test

#endif
