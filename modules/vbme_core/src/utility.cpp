// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/utility.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>

#include <tbb/task_arena.h>

extern char** environ;

namespace cv {
namespace vbme {

// ---------------------------------------------------------------- ScopedTimer

ScopedTimer::ScopedTimer() : start_(std::chrono::steady_clock::now()) {}

ScopedTimer::ScopedTimer(double& accumulator)
    : start_(std::chrono::steady_clock::now()),
      sink_([&accumulator](double s) { accumulator += s; }) {}

ScopedTimer::ScopedTimer(std::function<void(double)> sink)
    : start_(std::chrono::steady_clock::now()), sink_(std::move(sink)) {}

ScopedTimer::~ScopedTimer() {
    if (!stopped_) stop();
}

double ScopedTimer::seconds() const {
    if (stopped_) return elapsed_;
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

double ScopedTimer::stop() {
    if (stopped_) return elapsed_;
    elapsed_ = seconds();
    stopped_ = true;
    if (sink_) sink_(elapsed_);
    return elapsed_;
}

// ---------------------------------------------------------------- runProcess

namespace {

struct Fd {
    int fd = -1;
    Fd() = default;
    explicit Fd(int f) : fd(f) {}
    Fd(const Fd&) = delete;
    Fd& operator=(const Fd&) = delete;
    ~Fd() { close(); }
    void close() {
        if (fd >= 0) ::close(fd);
        fd = -1;
    }
};

void makePipe(Fd& r, Fd& w) {
    int p[2];
    if (::pipe2(p, O_CLOEXEC) != 0)
        CV_Error(Error::StsError, std::string("runProcess: pipe: ") + std::strerror(errno));
    r.fd = p[0];
    w.fd = p[1];
}

// The child's environment: the caller's, with the NAME=value entries of `extra` added or
// replacing the same names.
std::vector<std::string> childEnvironment(const std::vector<std::string>& extra) {
    std::vector<std::string> env;
    std::map<std::string, size_t> index;
    for (char** e = environ; e && *e; ++e) {
        const std::string s(*e);
        index[s.substr(0, s.find('='))] = env.size();
        env.push_back(s);
    }
    for (const std::string& s : extra) {
        const size_t eq = s.find('=');
        if (eq == std::string::npos || eq == 0)
            CV_Error(Error::StsBadArg,
                     "runProcess: environment entry '" + s + "' is not NAME=value");
        const std::string name = s.substr(0, eq);
        auto it = index.find(name);
        if (it != index.end())
            env[it->second] = s;
        else {
            index[name] = env.size();
            env.push_back(s);
        }
    }
    return env;
}

// Writes all of `buf` to `fd`, in the child (async-signal-safe calls only).
void childWriteAll(int fd, const void* buf, size_t n) {
    const char* p = static_cast<const char*>(buf);
    while (n > 0) {
        const ssize_t k = ::write(fd, p, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return;
        p += k;
        n -= (size_t)k;
    }
}

}  // namespace

ProcessResult runProcess(const std::vector<std::string>& argv, const ProcessOptions& o) {
    if (argv.empty() || argv[0].empty())
        CV_Error(Error::StsBadArg, "runProcess: empty argument list (expected the program first)");
    if (o.timeout < 0 || o.kill_after < 0)
        CV_Error(Error::StsBadArg, "runProcess: timeout and kill_after must be >= 0");

    // Everything the child needs is prepared before fork(): after it, only async-signal-safe
    // calls are allowed (the parent may have other threads holding locks).
    std::vector<std::string> env = childEnvironment(o.env);
    std::vector<char*> cargv, cenv;
    for (const std::string& a : argv)
        cargv.push_back(const_cast<char*>(a.c_str()));
    cargv.push_back(nullptr);
    for (std::string& e : env)
        cenv.push_back(&e[0]);
    cenv.push_back(nullptr);
    // execvpe's PATH search, done here so that the child does not allocate.
    std::vector<std::string> candidates;
    if (argv[0].find('/') != std::string::npos)
        candidates.push_back(argv[0]);
    else {
        const char* path = std::getenv("PATH");
        std::string p = path ? path : "/usr/local/bin:/usr/bin:/bin";
        size_t s = 0;
        while (true) {
            const size_t e = p.find(':', s);
            std::string dir = p.substr(s, e == std::string::npos ? std::string::npos : e - s);
            candidates.push_back((dir.empty() ? std::string(".") : dir) + "/" + argv[0]);
            if (e == std::string::npos) break;
            s = e + 1;
        }
    }

    Fd in_r, in_w, out_r, out_w, err_r, err_w, exec_r, exec_w, log;
    makePipe(exec_r, exec_w);  // carries errno of a failed exec; closed by a successful one
    if (!o.input.empty()) makePipe(in_r, in_w);
    if (o.log_file.empty()) {
        makePipe(out_r, out_w);
        makePipe(err_r, err_w);
    } else {
        log.fd = ::open(o.log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
        if (log.fd < 0)
            CV_Error(Error::StsError, "runProcess: cannot open the log file '" + o.log_file +
                                          "': " + std::strerror(errno));
    }
    const char* wd = o.working_dir.empty() ? nullptr : o.working_dir.c_str();

    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = ::fork();
    if (pid < 0)
        CV_Error(Error::StsError, std::string("runProcess: fork: ") + std::strerror(errno));
    if (pid == 0) {
        // Child. dup2 clears O_CLOEXEC on the copies.
        int in = in_r.fd >= 0 ? in_r.fd : ::open("/dev/null", O_RDONLY | O_CLOEXEC);
        const int out = log.fd >= 0 ? log.fd : out_w.fd;
        const int err = log.fd >= 0 ? log.fd : err_w.fd;
        if (in < 0 || ::dup2(in, 0) < 0 || ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0) {
            const int e = errno;
            childWriteAll(exec_w.fd, &e, sizeof e);
            ::_exit(127);
        }
        // default signal dispositions and mask for the program
        sigset_t none;
        sigemptyset(&none);
        ::sigprocmask(SIG_SETMASK, &none, nullptr);
        ::signal(SIGPIPE, SIG_DFL);
        if (wd && ::chdir(wd) != 0) {
            const int e = errno;
            childWriteAll(exec_w.fd, &e, sizeof e);
            ::_exit(127);
        }
        int e = ENOENT;
        for (const std::string& c : candidates) {
            ::execve(c.c_str(), cargv.data(), cenv.data());
            // keep the most telling error, as execvp does (EACCES over ENOENT)
            if (errno != ENOENT && errno != ENOTDIR) e = errno;
        }
        childWriteAll(exec_w.fd, &e, sizeof e);
        ::_exit(127);
    }

    // Parent.
    exec_w.close();
    in_r.close();
    out_w.close();
    err_w.close();
    ProcessResult res;
    {
        int e = 0;
        ssize_t k;
        do
            k = ::read(exec_r.fd, &e, sizeof e);
        while (k < 0 && errno == EINTR);
        if (k == (ssize_t)sizeof e) res.error = std::strerror(e);
    }
    if (!res.error.empty()) in_w.close();

    // Feed stdin, drain stdout/stderr, and watch the clock until all pipes are closed.
    size_t in_off = 0;
    if (in_w.fd >= 0) ::fcntl(in_w.fd, F_SETFL, O_NONBLOCK);
    using clock = std::chrono::steady_clock;
    const auto deadline =
        t0 + std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(o.timeout));
    auto kill_at = clock::time_point::max();
    bool termed = false, killed = false;
    auto checkClock = [&] {
        if (o.timeout <= 0) return;
        const auto now = clock::now();
        if (!termed && now >= deadline) {
            ::kill(pid, SIGTERM);
            termed = true;
            res.timed_out = true;
            kill_at = now + std::chrono::duration_cast<clock::duration>(
                                std::chrono::duration<double>(o.kill_after));
        } else if (termed && !killed && now >= kill_at) {
            ::kill(pid, SIGKILL);
            killed = true;
        }
    };
    char buf[65536];
    while (in_w.fd >= 0 || out_r.fd >= 0 || err_r.fd >= 0) {
        pollfd p[3];
        int n = 0, idx_in = -1, idx_out = -1, idx_err = -1;
        if (in_w.fd >= 0) {
            idx_in = n;
            p[n++] = {in_w.fd, POLLOUT, 0};
        }
        if (out_r.fd >= 0) {
            idx_out = n;
            p[n++] = {out_r.fd, POLLIN, 0};
        }
        if (err_r.fd >= 0) {
            idx_err = n;
            p[n++] = {err_r.fd, POLLIN, 0};
        }
        const int r = ::poll(p, (nfds_t)n, o.timeout > 0 ? 50 : -1);
        checkClock();
        // a killed program's own children may keep the pipes open: stop reading a second later
        if (killed && clock::now() > kill_at + std::chrono::seconds(1)) break;
        if (r < 0) {
            if (errno == EINTR) continue;
            break;
        }
        auto drain = [&](int idx, Fd& fd, std::string& dst) {
            if (idx < 0 || !(p[idx].revents & (POLLIN | POLLHUP | POLLERR))) return;
            const ssize_t k = ::read(fd.fd, buf, sizeof buf);
            if (k > 0)
                dst.append(buf, (size_t)k);
            else if (k == 0 || errno != EINTR)
                fd.close();
        };
        drain(idx_out, out_r, res.out);
        drain(idx_err, err_r, res.err);
        if (idx_in >= 0 && (p[idx_in].revents & (POLLOUT | POLLERR | POLLHUP))) {
            const ssize_t k = ::write(in_w.fd, o.input.data() + in_off, o.input.size() - in_off);
            if (k > 0) in_off += (size_t)k;
            if ((k < 0 && errno != EINTR && errno != EAGAIN) || in_off >= o.input.size())
                in_w.close();
        }
    }
    // With output going to a log file there is nothing to poll: wait, watching the clock.
    int status = 0;
    while (true) {
        const pid_t w = ::waitpid(pid, &status, o.timeout > 0 ? WNOHANG : 0);
        if (w == pid) break;
        if (w < 0) {
            if (errno == EINTR) continue;
            CV_Error(Error::StsError, std::string("runProcess: waitpid: ") + std::strerror(errno));
        }
        checkClock();
        ::usleep(20000);
    }
    res.seconds = std::chrono::duration<double>(clock::now() - t0).count();
    if (!res.error.empty())
        res.status = 127;
    else if (WIFEXITED(status))
        res.status = WEXITSTATUS(status);
    else if (WIFSIGNALED(status)) {
        res.signal = WTERMSIG(status);
        res.status = 128 + res.signal;
    }
    return res;
}

std::string shellQuote(const std::string& s) {
    std::string q = "'";
    for (char c : s)
        q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

// ---------------------------------------------------------------- threads

void runLimited(int threads, const std::function<void()>& fn) {
    if (!fn) return;
    if (threads <= 0) {
        fn();
        return;
    }
    tbb::task_arena arena(threads);
    arena.execute([&] { fn(); });
}

int currentConcurrency() {
    return tbb::this_task_arena::max_concurrency();
}

// ---------------------------------------------------------------- ParamsReader

ParamsReader::ParamsReader(const FileNode& node, const std::string& what)
    : node_(node), what_(what) {
    if (!node.empty() && !node.isMap() && !node.isNone())
        CV_Error(Error::StsBadArg, what + ": expected a map of parameters");
}

FileNode ParamsReader::node(const char* key) {
    if (std::find(asked_.begin(), asked_.end(), key) == asked_.end()) asked_.push_back(key);
    if (!node_.isMap()) return FileNode();
    return node_[key];
}

void ParamsReader::accept(const char* key) {
    node(key);
}

std::vector<std::string> ParamsReader::unknownKeys() const {
    std::vector<std::string> unknown;
    if (!node_.isMap()) return unknown;
    for (FileNodeIterator it = node_.begin(); it != node_.end(); ++it) {
        const std::string k = (*it).name();
        if (std::find(asked_.begin(), asked_.end(), k) == asked_.end()) unknown.push_back(k);
    }
    return unknown;
}

void ParamsReader::finish() const {
    const std::vector<std::string> unknown = unknownKeys();
    if (unknown.empty()) return;
    auto join = [](const std::vector<std::string>& v) {
        std::string s;
        for (const auto& k : v)
            s += (s.empty() ? "" : ", ") + k;
        return s;
    };
    CV_Error(Error::StsBadArg, what_ +
                                   (unknown.size() == 1 ? ": unknown key " : ": unknown keys ") +
                                   join(unknown) + " (valid: " + join(asked_) + ")");
}

}  // namespace vbme
}  // namespace cv
