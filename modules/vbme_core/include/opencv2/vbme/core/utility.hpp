// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_UTILITY_HPP
#define OPENCV_VBME_CORE_UTILITY_HPP

#include <algorithm>
#include <chrono>
#include <functional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @name Timing
@{ */

/** @brief Measures the wall time of a scope (std::chrono::steady_clock) and hands it over once.

On destruction (or at stop(), whichever comes first) the elapsed seconds are added to a double
or passed to a callback, e.g. to add them to a stage of a report:
@code
double decode_s = 0;
{ ScopedTimer t(decode_s); ... }                                   // decode_s += elapsed
{ ScopedTimer t([&](double s) { report.seconds["render"] += s; }); ... }
@endcode
*/
class CV_EXPORTS ScopedTimer {
public:
    /** @brief Measures only: read the figure with seconds() or stop(). */
    ScopedTimer();
    /** @brief Adds the elapsed seconds to @p accumulator. */
    explicit ScopedTimer(double& accumulator);
    /** @brief Calls @p sink with the elapsed seconds (an empty function: nothing is called). */
    explicit ScopedTimer(std::function<void(double)> sink);
    /** @brief Stops the timer if stop() was not called. */
    ~ScopedTimer();
    ScopedTimer(const ScopedTimer&) = delete;
    ScopedTimer& operator=(const ScopedTimer&) = delete;
    /** @brief Seconds since construction (the final figure once stopped). */
    double seconds() const;
    /** @brief Stops the timer, hands the elapsed seconds over (only the first call does) and
    returns them. */
    double stop();

private:
    std::chrono::steady_clock::time_point start_;
    std::function<void(double)> sink_;
    double elapsed_ = 0;
    bool stopped_ = false;
};

/** @} */

/** @name Running programs
@{ */

/** @brief How runProcess() runs a program. */
struct CV_EXPORTS ProcessOptions {
    /** @brief Variables added to (or replacing in) the child's environment, "NAME=value". */
    std::vector<std::string> env;
    /** @brief Working folder of the child (empty: the caller's). */
    std::string working_dir;
    /** @brief Wall-time limit in seconds (0: none). When it is exceeded the child gets SIGTERM,
    then SIGKILL @p kill_after seconds later if it is still running. */
    double timeout = 0;
    /** @brief Grace period between SIGTERM and SIGKILL once the timeout expired, seconds. */
    double kill_after = 5;
    /** @brief When non-empty, the child's stdout and stderr are appended to this file (created
    if missing) instead of being captured in ProcessResult::out and ProcessResult::err. */
    std::string log_file;
    /** @brief Bytes written to the child's standard input (then closed). Empty: the child
    reads /dev/null. */
    std::string input;

    /** @brief Reads the fields present in the map @p fn (others keep their value); an unknown
    key or a value check() refuses is an error. */
    void read(const FileNode& fn);
    /** @brief Writes every field as `name: value` into the open map of @p fs. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief What became of a program run by runProcess(). */
struct CV_EXPORTS ProcessResult {
    /** @brief Exit status: the program's exit code when it exited; 128 + signal number when a
    signal ended it; 127 when the program could not be started (then @p error says why). */
    int status = -1;
    /** @brief The signal that ended the program, 0 if it exited. */
    int signal = 0;
    /** @brief Whether the timeout expired and the program was stopped. */
    bool timed_out = false;
    /** @brief Why the program could not be started (e.g. "No such file or directory"), empty
    when it started. */
    std::string error;
    /** @brief Captured standard output (empty when ProcessOptions::log_file is set). */
    std::string out;
    /** @brief Captured standard error (empty when ProcessOptions::log_file is set). */
    std::string err;
    /** @brief Wall seconds from start to exit. */
    double seconds = 0;
    /** @brief True when the program started, ran to the end and exited with code 0. */
    bool ok() const { return status == 0 && signal == 0 && !timed_out && error.empty(); }
};

/** @brief Runs the program @p argv[0] (looked up in PATH when it has no '/') with the
arguments @p argv[1..], without a shell, and waits for it.

Arguments are passed as they are: spaces, quotes, `$` or `;` in them mean nothing special.
Standard output and error are captured (or appended to ProcessOptions::log_file); a program
that cannot be started gives status 127 and ProcessResult::error, it does not throw. Throws
cv::Exception only when @p argv is empty or the system cannot create a process.
Thread-safe; the child inherits no file descriptors other than stdin/stdout/stderr that the
caller opened with O_CLOEXEC.
*/
CV_EXPORTS ProcessResult runProcess(const std::vector<std::string>& argv,
                                    const ProcessOptions& options = ProcessOptions());

/** @brief @p s quoted for a POSIX shell ('…', with each ' written as '\''), for writing shell
scripts that other tools run. Programs run by vbme go through runProcess() instead. */
CV_EXPORTS std::string shellQuote(const std::string& s);

/** @} */

/** @name Hashing
@{ */

/** @brief The splitmix64 finaliser (Stafford's variant 13 @cite Steele2014splittable): a
bijection of 64-bit integers in which every input bit flips each output bit with probability
about ½. */
inline uint64 mix64(uint64 x) {
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

/** @brief Combines a hash @p a with a value @p b: mix64(a ^ (mix64(b) + golden ratio)).
Order matters (hashCombine(a, b) ≠ hashCombine(b, a) in general). */
inline uint64 hashCombine(uint64 a, uint64 b) {
    return mix64(a ^ (mix64(b) + 0x9e3779b97f4a7c15ULL));
}

/** @} */

/** @name Sampling
@{ */

/** @brief Bilinear look-up of pixel type @p T (float, Vec3f, …) in @p img at the continuous
pixel position (@p x, @p y), pixel centres at integers (DESIGN convention).

Positions outside the image are clamped to the edge (clamp-to-edge); an image of one row or
column is handled. @p img must have elements of type @p T (not checked, for speed). The
coordinate type @p C (float or double) is the precision in which the position is clamped; the
weights are float.
*/
template <typename T, typename C>
inline T bilinear(const Mat& img, C x, C y) {
    const C xc = std::min(std::max(x, C(0)), C(img.cols - 1));
    const C yc = std::min(std::max(y, C(0)), C(img.rows - 1));
    const int x0 = std::min((int)xc, std::max(img.cols - 2, 0));
    const int y0 = std::min((int)yc, std::max(img.rows - 2, 0));
    const int x1 = std::min(x0 + 1, img.cols - 1), y1 = std::min(y0 + 1, img.rows - 1);
    const float ax = float(xc - x0), ay = float(yc - y0);
    const T* r0 = img.ptr<T>(y0);
    const T* r1 = img.ptr<T>(y1);
    return (r0[x0] * (1.f - ax) + r0[x1] * ax) * (1.f - ay) +
           (r1[x0] * (1.f - ax) + r1[x1] * ax) * ay;
}

/** @} */

/** @name Threads
@{ */

/** @brief Runs @p fn with at most @p threads worker threads for the TBB parallel work it starts,
without changing the process-wide cv::setNumThreads() (so other callers are not affected).

@p fn runs inside a `tbb::task_arena` of @p threads slots; @p threads ≤ 0 runs @p fn as is
(no limit). What is limited: TBB loops started inside @p fn that run in the current arena
(`tbb::parallel_for` and the like). What is NOT limited: cv::parallel_for_ (OpenCV functions such
as cv::resize or cv::remap): Debian's OpenCV 4.6 runs its loops in an arena of its own whose
size only the process-wide cv::setNumThreads() changes (measured on a 2-core machine: 2 threads
inside runLimited(1); test_core_utility.cpp, RunLimited.OpenCvLoops). Exceptions thrown by @p fn
are passed on.
*/
CV_EXPORTS void runLimited(int threads, const std::function<void()>& fn);

/** @brief The number of worker threads TBB work started here may use: the current arena's
concurrency (the machine's core count outside runLimited()). */
CV_EXPORTS int currentConcurrency();

/** @} */

/** @name Reading parameters
@{ */

/** @brief Reads the keys of a FileStorage map and refuses unknown ones.

@code
void Foo::Params::read(const FileNode& fn) {
    ParamsReader r(fn, "foo");
    r("radius", radius);            // read when present, else left as is
    r("method", method_name);
    inner.read(r.node("inner"));    // a nested map
    r.finish();                     // throws if fn has keys not asked for
}
@endcode
Each value is read as `(T)fn[key]` would read it (bool through an int, uint64 through a
double, exact to 2⁵³). finish() throws cv::Exception (StsBadArg) naming the unknown keys and
the valid ones, so a typo such as `radus: 3` is an error instead of being ignored. A node that is
neither a map nor empty is refused by the constructor.
*/
class CV_EXPORTS ParamsReader {
public:
    /** @brief Reader of the map @p node; @p what names it in messages (e.g. "render"). */
    ParamsReader(const FileNode& node, const std::string& what);
    /** @brief Reads @p key into @p value when present (else leaves @p value unchanged); returns
    whether it was present. */
    template <typename T>
    bool operator()(const char* key, T& value) {
        const FileNode n = node(key);
        if (n.empty()) return false;
        readValue(n, value);
        return true;
    }
    /** @brief The node of @p key (possibly empty), now counted as a valid key. */
    FileNode node(const char* key);
    /** @brief Counts @p key as valid without reading it (it is read elsewhere). */
    void accept(const char* key);
    /** @brief Whether @p key is present (and counts it as valid). */
    bool has(const char* key) { return !node(key).empty(); }
    /** @brief The keys of the map that were not asked for, in file order. */
    std::vector<std::string> unknownKeys() const;
    /** @brief Throws cv::Exception (StsBadArg) when the map has keys that were not asked for,
    naming them and the valid keys. */
    void finish() const;
    /** @brief The name given to the constructor. */
    const std::string& what() const { return what_; }

private:
    template <typename T>
    static void readValue(const FileNode& n, T& v) {
        n >> v;
    }
    static void readValue(const FileNode& n, bool& v) { v = (int)n != 0; }
    static void readValue(const FileNode& n, uint64& v) { v = (uint64)(double)n; }
    static void readValue(const FileNode& n, float& v) { v = (float)n; }
    static void readValue(const FileNode& n, double& v) { v = (double)n; }
    static void readValue(const FileNode& n, int& v) { v = (int)n; }
    static void readValue(const FileNode& n, std::string& v) { v = (std::string)n; }

    FileNode node_;
    std::string what_;
    std::vector<std::string> asked_;
};

/** @} */

//! @}

}  // namespace vbme
}  // namespace cv

#endif
