// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/core/yaml_guard.hpp"

#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include <opencv2/imgcodecs.hpp>

namespace fs = std::filesystem;

namespace cv {
namespace vbme {

AtomicFile::AtomicFile(const std::string& final_path) : final_(final_path) {
    static std::atomic<int> counter{0};
    fs::path p(final_path);
    if (p.filename().empty()) CV_Error(Error::StsBadArg, "'" + final_path + "' is not a file name");
    std::error_code ec;
    if (p.has_parent_path()) {
        fs::create_directories(p.parent_path(), ec);
        if (ec)
            CV_Error(Error::StsError,
                     "cannot create folder '" + p.parent_path().string() + "': " + ec.message());
    }
    const std::string tag =
        ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
    fs::path tmp = p.parent_path() / (p.stem().string() + tag + p.extension().string());
    temp_ = tmp.string();
}

AtomicFile::~AtomicFile() {
    if (!committed_) {
        std::error_code ec;
        fs::remove(temp_, ec);
    }
}

void AtomicFile::commit() {
    std::error_code ec;
    if (!fs::exists(temp_, ec))
        CV_Error(Error::StsError, "'" + final_ + "' was not written (no temporary file)");
    fs::rename(temp_, final_, ec);
    if (ec) CV_Error(Error::StsError, "cannot rename into '" + final_ + "': " + ec.message());
    committed_ = true;
}

void checkOverwrite(const std::string& path, bool force) {
    std::error_code ec;
    if (!force && fs::exists(path, ec))
        CV_Error(Error::StsError, "'" + path + "' exists; use --force to overwrite it");
}

void imwriteAtomic(const std::string& path, InputArray img, const std::vector<int>& params) {
    AtomicFile out(path);
    // encoded in memory and written here, so that a short write (a full disk, a file-size
    // limit) is an error instead of a truncated image renamed into place
    std::vector<uchar> bytes;
    std::string ext = fs::path(path).extension().string();
    for (auto& c : ext)
        c = (char)std::tolower((unsigned char)c);
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg" && ext != ".ppm" && ext != ".pgm" &&
        ext != ".bmp") {
        // encoders that write only to files (OpenEXR, TIFF): through cv::imwrite
        bool ok = false;
        try {
            ok = imwrite(out.tempPath(), img, params);
        } catch (const cv::Exception& e) {
            CV_Error(Error::StsError, "cannot write '" + path + "': " + e.err);
        }
        if (!ok)
            CV_Error(Error::StsError, "cannot write '" + path + "' (no encoder for this type?)");
        out.commit();
        return;
    }
    bool ok = false;
    try {
        ok = imencode(ext, img, bytes, params);
    } catch (const cv::Exception& e) {
        CV_Error(Error::StsError, "cannot write '" + path + "': " + e.err);
    }
    if (!ok) CV_Error(Error::StsError, "cannot write '" + path + "' (no encoder for this type?)");
    FILE* f = std::fopen(out.tempPath().c_str(), "wb");
    if (!f) CV_Error(Error::StsError, "cannot write '" + path + "': " + std::strerror(errno));
    const size_t n = std::fwrite(bytes.data(), 1, bytes.size(), f);
    const int write_errno = errno;
    const bool flushed = std::fflush(f) == 0;
    const int flush_errno = errno;
    const bool closed = std::fclose(f) == 0;
    if (n != bytes.size() || !flushed || !closed)
        CV_Error(Error::StsError,
                 format("cannot write '%s': %s (disk full?)", path.c_str(),
                        std::strerror(n != bytes.size() ? write_errno : flush_errno)));

    out.commit();
}

void checkYamlTopLevel(const std::string& text, const std::string& path) {
    const size_t first = text.find_first_not_of(" \t\r\n");
    if (first == std::string::npos || text[first] == '{') return;
    size_t pos = 0;
    for (int line = 1; pos < text.size(); ++line) {
        size_t end = text.find('\n', pos);
        if (end == std::string::npos) end = text.size();
        const std::string l = text.substr(pos, end - pos);
        pos = end + 1;
        const size_t c = l.find_first_not_of(" \t\r");
        // a document start is "---" alone (OpenCV 4.6 also loops on "---L:0\n----\n---")
        const bool doc_start =
            l.compare(0, 3, "---") == 0 &&
            (l.size() == 3 || l.find_first_not_of(" \t\r", 3) == std::string::npos);
        if (c == std::string::npos || l[c] == '#' || (c == 0 && l[0] == '%') || doc_start) continue;
        if (c > 0)
            CV_Error(Error::StsParseError,
                     format("%s: line %d: the top level is indented; expected 'key: value' "
                            "lines starting at column 0",
                            path.c_str(), line));
        if (l[0] == '-' || l[0] == '[')
            CV_Error(Error::StsParseError,
                     format("%s: line %d: the top level is a list; expected 'key: value' lines",
                            path.c_str(), line));
        return;
    }
}

FileStorage openForReading(const std::string& path, const std::string& what) {
    FileStorage fs;
    {
        std::ifstream in(path, std::ios::binary);
        if (in) {
            std::stringstream ss;
            ss << in.rdbuf();
            checkYamlTopLevel(ss.str(), path);
        }
    }
    try {
        fs.open(path, FileStorage::READ);
    } catch (const cv::Exception& e) {
        CV_Error(Error::StsParseError, path + ": not a readable YAML/JSON file: " + e.err);
    } catch (const std::exception& e) {  // OpenCV's parsers may throw std::length_error
        CV_Error(Error::StsParseError,
                 path + ": not a readable YAML/JSON file: " + std::string(e.what()));
    }
    if (!fs.isOpened()) CV_Error(Error::StsError, path + ": cannot open " + what);
    return fs;
}

FileStorage openForWriting(const AtomicFile& out) {
    FileStorage fs(out.tempPath(), FileStorage::WRITE);
    if (!fs.isOpened()) CV_Error(Error::StsError, out.finalPath() + ": cannot open for writing");
    return fs;
}

Mat imreadChecked(const std::string& path, int flags) {
    std::error_code ec;
    if (!fs::exists(path, ec)) CV_Error(Error::StsError, "'" + path + "' does not exist");
    if (fs::is_directory(path, ec))
        CV_Error(Error::StsError, "'" + path + "' is a folder, expected an image file");
    Mat m = imread(path, flags);
    if (m.empty()) CV_Error(Error::StsError, "'" + path + "' is not a readable image");
    return m;
}

Mat readObjectMask(const std::string& path, Size expected_size) {
    Mat m = imreadChecked(path, IMREAD_GRAYSCALE);
    if (expected_size.area() > 0 && m.size() != expected_size)
        CV_Error(Error::StsBadArg,
                 format("mask '%s' is %dx%d but the video's frames are %dx%d", path.c_str(), m.cols,
                        m.rows, expected_size.width, expected_size.height));
    const int n = countNonZero(m);
    if (n == 0)
        CV_Error(Error::StsBadArg,
                 "mask '" + path + "' is empty: expected the object's pixels set to 255");
    if (n == (int)m.total())
        CV_Error(Error::StsBadArg,
                 "mask '" + path + "' covers the whole frame: expected only the object");
    Mat out = m != 0;
    return out;
}

std::string resolvePath(const std::string& base, const std::string& p) {
    fs::path q(p);
    if (q.is_absolute()) return q.lexically_normal().string();
    return (fs::absolute(fs::path(base)) / q).lexically_normal().string();
}

std::string relativePath(const std::string& base, const std::string& p) {
    fs::path b = fs::absolute(fs::path(base)).lexically_normal();
    fs::path q = fs::absolute(fs::path(p)).lexically_normal();
    fs::path rel = q.lexically_relative(b);
    if (rel.empty() || *rel.begin() == "..") return p;
    return rel.string();
}

std::string parentFolder(const std::string& path) {
    fs::path p(path);
    return p.has_parent_path() ? p.parent_path().string() : std::string(".");
}

std::string maskFileName(int frame) {
    return format("mask_%05d.png", frame);
}

}  // namespace vbme
}  // namespace cv
