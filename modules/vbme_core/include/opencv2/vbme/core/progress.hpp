// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_PROGRESS_HPP
#define OPENCV_VBME_CORE_PROGRESS_HPP

#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief Progress of long work, printed to a stream (stderr by default).

On a terminal it redraws one line (bar, count, rate, ETA) at most ten times a second; on a
pipe or file it prints a line at every 10 % so that logs stay short. tick() is thread-safe.
Disabled globally with setEnabled(false) (the command line's `--quiet`).
*/
class CV_EXPORTS Progress {
public:
    /** @brief Starts reporting @p total units of work called @p label. @p total may be 0
    when unknown (then only counts and rate are shown). */
    Progress(const std::string& label, int64 total, FILE* out = stderr);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    /** @brief Adds @p n finished units. */
    void tick(int64 n = 1);
    /** @brief Sets the number of finished units. */
    void set(int64 done);
    /** @brief Prints the final line (also done by the destructor). */
    void finish();
    /** @brief Finished units. */
    int64 done() const { return done_.load(); }
    /** @brief Seconds since construction. */
    double elapsed() const;

    /** @brief Turns all progress output on or off (default on). */
    static void setEnabled(bool on);
    /** @brief Whether progress output is on. */
    static bool enabled();

private:
    void draw(bool final);
    std::string label_;
    int64 total_;
    FILE* out_;
    bool tty_;
    std::atomic<int64> done_{0};
    std::mutex mutex_;
    std::chrono::steady_clock::time_point start_, last_draw_;
    int last_decile_ = -1;
    bool finished_ = false;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
