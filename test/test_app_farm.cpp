// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme farm slurm (doc/cluster.md): the batch scripts split the frames exactly, and on a real
// single-node Slurm cluster (scripts/slurm-local.sh, when slurm-wlm and munge are installed
// and we may start it) the job chain makes the same video as one machine.
#include <stdlib.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <thread>

#include <gtest/gtest.h>

#include "app_insert_inputs.hpp"
#include "vbme_test_util.hpp"
#include "video_test_util.hpp"

namespace {

using namespace vbme_test;
namespace fs = std::filesystem;

// Samples per pixel that make a 64x48 frame of the requeue test take a fraction of a second.
constexpr int kRequeueSpp = 128;

std::string farmCmd(const FaultInputs& in, const std::string& out, const std::string& extra) {
    return std::string(VBME_EXE) + " farm slurm --video '" + in.video + "' --scene '" + in.scene +
           "' --cameras '" + in.cameras + "' --out '" + out +
           "' --insert-args '--lights none --albedo retinex' " + extra;
}

TEST(AppFarm, ScriptsSplitEveryFrameOnceAndRequestMoreForLargerFrames) {
    ScratchDir dir;
    const FaultInputs in = makeFaultInputs(dir, Size(48, 36), 7);
    // --vbme echo: the scripts print the command each job would run
    const std::string out = dir / "out.mkv";
    auto r = run(farmCmd(in, out, "--tasks 3 --vbme echo"));
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string sd = dir / "out_work/slurm";
    for (const char* f : {"prepare.sbatch", "render.sbatch", "assemble.sbatch", "submit.sh"})
        EXPECT_TRUE(fs::exists(sd + "/" + f)) << f;
    std::ifstream rs(sd + "/render.sbatch");
    const std::string render((std::istreambuf_iterator<char>(rs)),
                             std::istreambuf_iterator<char>());
    EXPECT_NE(render.find("#SBATCH --array=0-2"), std::string::npos) << render;
    EXPECT_NE(render.find("#SBATCH --requeue"), std::string::npos) << render;
    std::set<int> covered;
    int total = 0;
    for (int task = 0; task < 3; ++task) {
        r = run("SLURM_ARRAY_TASK_ID=" + std::to_string(task) + " bash " + sd + "/render.sbatch");
        ASSERT_EQ(r.code, 0) << r.output;
        std::smatch m;
        ASSERT_TRUE(std::regex_search(r.output, m, std::regex("--frames (\\d+):(\\d+)")))
            << r.output;
        for (int i = std::stoi(m[1]); i < std::stoi(m[2]); ++i) {
            covered.insert(i);
            ++total;
        }
    }
    EXPECT_EQ(total, 7);  // no frame twice
    EXPECT_EQ(covered.size(), 7u);
    // a rerun (requeue) of a task after the video was written: nothing to do, success
    std::ofstream(out) << "written by the task that finished last";
    r = run("SLURM_ARRAY_TASK_ID=1 bash " + sd + "/render.sbatch");
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("already written"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("--frames"), std::string::npos) << r.output;  // vbme not run
    fs::remove(out);
    r = run("bash " + sd + "/prepare.sbatch");
    EXPECT_NE(r.output.find("--prepare-only"), std::string::npos) << r.output;
    // refuses to overwrite the scripts without --force
    r = run(farmCmd(in, out, "--tasks 3 --vbme echo"));
    EXPECT_EQ(r.code, 1) << r.output;
    // the requests grow with the frame size and the spp
    auto requests = [&](const std::string& extra, int& minutes, int& mem) {
        const auto rr = run(farmCmd(in, dir / "o2.mkv", "--tasks 3 --force --vbme echo " + extra));
        EXPECT_EQ(rr.code, 0) << rr.output;
        std::smatch m;
        EXPECT_TRUE(std::regex_search(rr.output, m, std::regex("(\\d+) min, (\\d+) MB")))
            << rr.output;
        minutes = std::stoi(m[1]);
        mem = std::stoi(m[2]);
    };
    int m1, mem1, m2, mem2;
    requests("--spp 16", m1, mem1);
    requests("--spp 4096", m2, mem2);
    EXPECT_GT(m2, m1);
    EXPECT_EQ(mem2, mem1);
    // with --force the old video is to be replaced: a task renders even when one exists
    std::ofstream(dir / "o2.mkv") << "an earlier video";
    r = run("SLURM_ARRAY_TASK_ID=0 bash " + std::string(dir / "o2_work/slurm/render.sbatch"));
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("--frames"), std::string::npos) << r.output;
    // a missing scene is a usage error, a bad one names the file
    EXPECT_EQ(run(std::string(VBME_EXE) + " farm slurm --video v --scene /nonexistent --out o "
                                          "--tasks 2")
                  .code,
              2);
}

// Stops the cluster the test started, whatever happens. Its folder is a short one under /tmp:
// munge's socket path must fit a Unix socket address (108 bytes).
struct LocalSlurm {
    std::string dir;
    bool started = false;
    LocalSlurm() {
        char tmpl[] = "/tmp/vbme-slurm-XXXXXX";
        if (::mkdtemp(tmpl)) dir = tmpl;
    }
    /** Starts the cluster (scripts/slurm-local.sh start): exit 3 when Slurm is not installed;
    otherwise the cluster, even half started, is stopped at the end. */
    vbme_test::RunResult start() {
        const auto r = run(std::string("bash ") + VBME_SOURCE_DIR +
                           "/scripts/slurm-local.sh start '" + dir + "'");
        started = r.code != 3;
        return r;
    }
    ~LocalSlurm() {
        if (started)
            run(std::string("bash ") + VBME_SOURCE_DIR + "/scripts/slurm-local.sh stop '" + dir +
                "'");
        std::error_code ec;
        if (!dir.empty()) fs::remove_all(dir, ec);
    }
};

TEST(AppFarm, SlurmClusterMakesTheSameVideoAsOneMachine) {
    ScratchDir dir;
    LocalSlurm slurm;
    ASSERT_FALSE(slurm.dir.empty());
    const std::string sdir = slurm.dir;
    auto r = slurm.start();
    if (r.code == 3) GTEST_SKIP() << "no Slurm cluster here: " << r.output;
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string conf = sdir + "/slurm.conf";
    const FaultInputs in = makeFaultInputs(dir, Size(48, 36), 6);
    // one machine
    const std::string ref = dir / "ref.mkv";
    const double t_one = secondsOf([&] { r = run(insertCmd(in, ref, dir / "ref_work")); });
    ASSERT_EQ(r.code, 0) << r.output;
    // the cluster: prepare, 3 array tasks, assemble
    const std::string out = dir / "farm.mkv";
    const auto t0 = std::chrono::steady_clock::now();
    r = run("SLURM_CONF='" + conf + "' " + farmCmd(in, out, "--tasks 3 --cpus 1 --submit"));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("submitted: prepare"), std::string::npos) << r.output;
    // wait for the queue to empty (at most two minutes)
    double t_farm = 0;
    for (int i = 0; i < 600; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        const auto q = run("SLURM_CONF='" + conf + "' squeue -h -o '%i %r'");
        if (q.code == 0 && q.output.find_first_not_of(" \n") == std::string::npos) break;
        if (q.output.find("DependencyNeverSatisfied") != std::string::npos) break;  // failed
    }
    t_farm = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "one machine: %.2f s; Slurm (prepare + 3 tasks + assemble, submit to done): "
        "%.2f s\n",
        t_one, t_farm);
    ASSERT_TRUE(fs::exists(out)) << "no video; job logs in " << dir / "farm_work/slurm";
    const std::vector<Mat> got = vbme_test::readVideoFrames(out),
                           want = vbme_test::readVideoFrames(ref);
    ASSERT_EQ(got.size(), want.size());
    for (size_t i = 0; i < got.size(); ++i)
        EXPECT_TRUE(sameImage(got[i], want[i])) << "frame " << i;
    // every task rendered its share (its log says so), none rendered a frame twice
    int rendered = 0;
    for (const auto& e : fs::directory_iterator(dir / "farm_work/slurm")) {
        if (e.path().filename().string().rfind("render_", 0) != 0) continue;
        std::ifstream f(e.path());
        const std::string s((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
        std::smatch m;
        if (std::regex_search(s, m, std::regex("(\\d+) rendered"))) rendered += std::stoi(m[1]);
    }
    EXPECT_EQ(rendered, 6);
}

// Preemption: while the second render task of the array runs (its first frame written, its
// last not yet), it is suspended and Slurm requeues it (`scontrol requeue`, what preemption with
// PreemptMode=REQUEUE does); the task runs again, resumes its frames (its log says some were
// already done), and the video is identical to one machine's.
TEST(AppFarm, SlurmRequeuedTaskResumesToTheSameVideo) {
    ScratchDir dir;
    LocalSlurm slurm;
    ASSERT_FALSE(slurm.dir.empty());
    const std::string sdir = slurm.dir;
    auto r = slurm.start();
    if (r.code == 3) GTEST_SKIP() << "no Slurm cluster here: " << r.output;
    ASSERT_EQ(r.code, 0) << r.output;
    const std::string env = "SLURM_CONF='" + sdir + "/slurm.conf' ";
    // frames slow enough (more samples) for the requeue to land while a task renders
    const int n = 6, spp = kRequeueSpp;
    const FaultInputs in = makeFaultInputs(dir, Size(64, 48), n);
    const std::string ref = dir / "ref.mkv", spp_arg = " --spp " + std::to_string(spp);
    const double t_one = secondsOf([&] { r = run(insertCmd(in, ref, dir / "ref_work", spp_arg)); });
    ASSERT_EQ(r.code, 0) << r.output;
    // Each attempt submits the farm afresh; a new attempt only when task 1 finished its frames
    // before it could be stopped mid-way (see below).
    std::smatch m;
    std::string out, work, task;
    auto t0 = std::chrono::steady_clock::now();
    bool requeued = false;
    const auto waitForEmptyQueue = [&](std::string* last_queue) {
        for (int i = 0; i < 1200; ++i) {
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
            const auto q = run(env + "squeue -h -o '%i %T %r'");
            if (last_queue) *last_queue = q.output;
            if (q.code == 0 && q.output.find_first_not_of(" \n") == std::string::npos) break;
            if (q.output.find("DependencyNeverSatisfied") != std::string::npos) break;  // failed
        }
    };
    for (int attempt = 0; attempt < 4 && !requeued; ++attempt) {
        out = dir / cv::format("farm%d.mkv", attempt);
        work = dir / cv::format("farm%d_work", attempt);
        const std::string frames = work + "/frames";
        t0 = std::chrono::steady_clock::now();
        r = run(env + farmCmd(in, out, "--tasks 2 --cpus 1 --submit" + spp_arg));
        ASSERT_EQ(r.code, 0) << r.output;
        ASSERT_TRUE(std::regex_search(r.output, m, std::regex("render (\\d+) \\(array\\)")))
            << r.output;
        task = m[1].str() + "_1";  // frames 3, 4, 5
        // wait for task 1 to be running with frame 3 written and frame 5 not, then requeue it
        for (int i = 0; i < 1200 && !requeued; ++i) {
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            if (fs::exists(out)) break;
            if (!fs::exists(frames + "/frame_00003.png") || fs::exists(frames + "/frame_00005.png"))
                continue;
            const auto q = run(env + "squeue -h -t R -j " + task + " -o %i");
            if (q.output.find(task) == std::string::npos) continue;
            // Stop the task where it is (SIGSTOP) before requeueing it; a suspended job is
            // requeued all the same.
            const auto sus = run(env + "scontrol suspend " + task);
            if (sus.code != 0) continue;  // it left the running state meanwhile: look again
            // SIGSTOP is sent: look at its frames again now that the task cannot move on. Frames
            // take a fraction of a second, so it may have finished them (and written the video,
            // being the last task) between the checks above and the stop: then there is nothing
            // left to resume, so let it end and submit the farm again.
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
            if (fs::exists(frames + "/frame_00005.png") || fs::exists(out)) {
                run(env + "scontrol resume " + task);
                std::printf("attempt %d: task %s finished its frames before it stopped\n", attempt,
                            task.c_str());
                break;
            }
            const double t_rq =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const auto rq = run(env + "scontrol requeue " + task);
            ASSERT_EQ(rq.code, 0) << rq.output;
            // The killed run's slurmstepd removes the job's spool folder when it has finished; a
            // rerun launched before that (same job id, same folder) loses its script to that
            // clean-up, fails to launch and is held again (reason launch_failed_requeued_held,
            // seen once on CI under ASan). So let the rerun start only once that folder is gone.
            std::string job_id = task;
            {
                const auto sj = run(env + "scontrol show job " + task);
                std::smatch jm;
                if (std::regex_search(sj.output, jm, std::regex("JobId=(\\d+)"))) job_id = jm[1];
            }
            const std::string spool =
                sdir + "/spool/d/" + cv::format("job%05d", std::atoi(job_id.c_str()));
            // Slurm holds a requeued job back (pending, reason BeginTime: two minutes measured
            // here; or held, JobHeldAdmin, when it was suspended; or launch_failed_requeued_held
            // after a failed launch) once the killed run has completed; let it start again at once
            bool restarted = false;
            std::string seen, last;  // the states seen while waiting, for the failure message
            for (int k = 0; k < 600 && !restarted; ++k) {
                const auto st = run(env + "squeue -h -j " + task + " -o '%T %r'");
                // (after 10 s the folder is not waited for any longer)
                const bool spool_there = fs::exists(spool), old_run_gone = !spool_there || k > 100;
                const std::string state =
                    st.output.substr(0, st.output.find('\n')) + (spool_there ? " (spool)" : "");
                if (state != last && seen.size() < 2000)
                    seen += cv::format("%.1f s: ", k * 0.1) + state + "\n";
                last = state;
                if (old_run_gone && st.output.find("BeginTime") != std::string::npos)
                    run(env + "scontrol update JobId=" + task + " StartTime=now");
                if (old_run_gone && (st.output.find("held") != std::string::npos ||
                                     st.output.find("Held") != std::string::npos))
                    run(env + "scontrol release " + task);
                restarted = st.output.find("RUNNING") != std::string::npos ||
                            st.output.find_first_not_of(" \n") == std::string::npos;
                std::this_thread::sleep_for(std::chrono::milliseconds(100));
            }
            EXPECT_TRUE(restarted) << "the requeued task did not start again within 60 s; seen:\n"
                                   << seen;
            requeued = true;
            std::printf("requeued task %s %.2f s after the submission\n", task.c_str(), t_rq);
        }
        if (!requeued) waitForEmptyQueue(nullptr);  // the missed attempt's jobs end first
    }
    ASSERT_TRUE(requeued) << "task " << task << " was never seen running mid-way";
    std::string last_queue;
    waitForEmptyQueue(&last_queue);
    const double t_farm =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto show = run(env + "scontrol show job " + task);
    std::printf(
        "one machine: %.2f s; Slurm with task %s requeued: %.2f s (%s)\n", t_one, task.c_str(),
        t_farm,
        std::regex_search(show.output, m, std::regex("Restarts=\\d+")) ? m[0].str().c_str() : "?");
    // requeued once by the test (more only if a launch failed and Slurm requeued it again)
    EXPECT_TRUE(std::regex_search(show.output, m, std::regex("Restarts=[1-9]"))) << show.output;
    if (!fs::exists(out)) {
        std::string logs;
        for (const auto& e : fs::directory_iterator(work + "/slurm"))
            if (e.path().extension() == ".log") {
                std::ifstream f(e.path());
                logs += e.path().filename().string() + ":\n" +
                        std::string((std::istreambuf_iterator<char>(f)),
                                    std::istreambuf_iterator<char>());
            }
        FAIL() << "no video; the queue: " << last_queue << "\njob logs:\n" << logs;
    }
    const std::vector<Mat> got = vbme_test::readVideoFrames(out),
                           want = vbme_test::readVideoFrames(ref);
    ASSERT_EQ(got.size(), want.size());
    for (size_t i = 0; i < got.size(); ++i)
        EXPECT_TRUE(sameImage(got[i], want[i])) << "frame " << i;
    // the requeued task's second run resumed: its log (rewritten by the rerun) counts frames
    // already done
    std::ifstream f(work + "/slurm/render_" + task + ".log");
    const std::string log((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    ASSERT_TRUE(std::regex_search(log, m,
                                  std::regex("frames 3:6 of 6: (\\d+) rendered, (\\d+) "
                                             "already done")))
        << log;
    std::printf("the requeued task's rerun: %s rendered, %s already done\n", m[1].str().c_str(),
                m[2].str().c_str());
    EXPECT_GE(std::stoi(m[2]), 1) << log;
    EXPECT_EQ(std::stoi(m[1]) + std::stoi(m[2]), 3) << log;
}

}  // namespace
