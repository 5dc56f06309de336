// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/progress.hpp"

#include <unistd.h>

namespace cv {
namespace vbme {

static std::atomic<bool> g_progress_enabled{true};

void Progress::setEnabled(bool on) {
    g_progress_enabled = on;
}
bool Progress::enabled() {
    return g_progress_enabled;
}

Progress::Progress(const std::string& label, int64 total, FILE* out)
    : label_(label), total_(total), out_(out), tty_(out && isatty(fileno(out))) {
    start_ = last_draw_ = std::chrono::steady_clock::now();
}

Progress::~Progress() {
    finish();
}

double Progress::elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::tick(int64 n) {
    done_ += n;
    draw(false);
}

void Progress::set(int64 done) {
    done_ = done;
    draw(false);
}

void Progress::finish() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (finished_) return;
    finished_ = true;
    if (!enabled() || !out_) return;
    const double t = elapsed();
    const int64 d = done_.load();
    std::fprintf(out_, "%s%s: %lld%s in %.1f s (%.1f/s)\n", tty_ ? "\r\033[K" : "", label_.c_str(),
                 (long long)d, total_ > 0 ? format("/%lld", (long long)total_).c_str() : "", t,
                 t > 0 ? d / t : 0.0);
    std::fflush(out_);
}

void Progress::draw(bool) {
    if (!enabled() || !out_) return;
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock() || finished_) return;  // another thread is drawing: skip
    const auto now = std::chrono::steady_clock::now();
    const int64 d = done_.load();
    const double t = std::chrono::duration<double>(now - start_).count();
    const double rate = t > 0 ? d / t : 0.0;
    if (tty_) {
        if (now - last_draw_ < std::chrono::milliseconds(100)) return;
        last_draw_ = now;
        std::string line = "\r\033[K" + label_ + " ";
        if (total_ > 0) {
            const int width = 30;
            const double f = std::min(1.0, double(d) / total_);
            const int fill = int(f * width);
            line += "[" + std::string(fill, '#') + std::string(width - fill, '.') + "] ";
            line += format("%lld/%lld %.1f/s", (long long)d, (long long)total_, rate);
            if (rate > 0 && d < total_) line += format(" ETA %.0f s", (total_ - d) / rate);
        } else {
            line += format("%lld %.1f/s", (long long)d, rate);
        }
        std::fputs(line.c_str(), out_);
        std::fflush(out_);
    } else if (total_ > 0) {
        const int decile = int(10.0 * d / total_);
        if (decile <= last_decile_ || decile >= 10) return;
        last_decile_ = decile;
        if (decile == 0) return;
        std::fprintf(out_, "%s: %d%% (%lld/%lld, %.1f/s, ETA %.0f s)\n", label_.c_str(),
                     decile * 10, (long long)d, (long long)total_, rate,
                     rate > 0 ? (total_ - d) / rate : 0.0);
        std::fflush(out_);
    }
}

}  // namespace vbme
}  // namespace cv
