// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The insertion's work folder: fingerprints, locks, file names.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "insertion/stages.hpp"

namespace cv {
namespace vbme {
namespace insertion {

namespace fs = std::filesystem;

void Hasher::bytes(const void* data, size_t n) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 1099511628211ull;
    }
}

void Hasher::str(const std::string& s) {
    const uint64 n = s.size();
    bytes(&n, sizeof n);
    bytes(s.data(), s.size());
}

void Hasher::file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        str("<missing " + path + ">");
        return;
    }
    std::vector<char> buf(1 << 16);
    while (in) {
        in.read(buf.data(), (std::streamsize)buf.size());
        bytes(buf.data(), (size_t)in.gcount());
    }
}

void Hasher::mat(const Mat& m) {
    num((int64)m.rows);
    num((int64)m.cols);
    num((int64)m.type());
    for (int y = 0; y < m.rows; ++y)
        bytes(m.ptr(y), m.cols * m.elemSize());
}

std::string Hasher::hex() const {
    return format("%016llx", (unsigned long long)h);
}

bool FileLock::acquire(const std::string& path, bool wait) {
    release();
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0)
        CV_Error(Error::StsError,
                 "cannot create the lock file '" + path + "': " + std::strerror(errno));
    int r;
    do {
        r = ::flock(fd_, LOCK_EX | (wait ? 0 : LOCK_NB));
    } while (r != 0 && errno == EINTR);
    if (r != 0) {
        const int err = errno;
        ::close(fd_);
        fd_ = -1;
        if (!wait && err == EWOULDBLOCK) return false;
        CV_Error(Error::StsError, "cannot lock '" + path + "': " + std::strerror(err));
    }
    return true;
}

void FileLock::release() {
    if (fd_ < 0) return;
    ::flock(fd_, LOCK_UN);
    ::close(fd_);
    fd_ = -1;
}

void lockWork(FileLock& lock, const std::string& work, const PipelineProgress& progress) {
    const std::string path = (fs::path(work) / "work.lock").string();
    if (lock.acquire(path, false)) return;
    if (progress) progress("waiting", 0, 0);
    lock.acquire(path, true);
}

std::string frameFile(const std::string& work, int i) {
    return (fs::path(work) / "frames" / format("frame_%05d.png", i)).string();
}

std::string exrFile(const std::string& work, int i) {
    return (fs::path(work) / "exr" / format("frame_%05d.exr", i)).string();
}

}  // namespace insertion
}  // namespace vbme
}  // namespace cv
