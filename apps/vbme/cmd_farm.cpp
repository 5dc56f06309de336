// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// vbme farm slurm: batch scripts that run `vbme insert` on a Slurm cluster: one preparation
// job (--prepare-only), an array job whose tasks render --frames A:B on the shared work folder,
// and an assembly job that writes the video once the array is done (doc/cluster.md).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/vbme/core.hpp>

#include "command.hpp"

namespace vbme_app {

namespace {

namespace fs = std::filesystem;

struct FarmOptions {
    std::string video, scene, cameras, out, work, partition, insert_args, vbme;
    int tasks = 0, spp = 0, cpus = 2, mem_mb = 0, minutes = 0;
    bool submit = false;
    CommonOptions common;
};

// The job scripts are shell scripts: paths in them are quoted for the shell.
std::string quote(const std::string& s) {
    return cv::vbme::shellQuote(s);
}

std::string absolute(const std::string& p) {
    return fs::absolute(p).lexically_normal().string();
}

// Core-seconds per camera sample of a differential render (both passes and the composite),
// from `vbme bench insert` on the development machine (doc/vbme_pipeline_insert.md: 7.67 s per
// 640x480 frame at 32 spp on 2 cores). The requests below take four times this.
constexpr double kCoreSecondsPerSample = 7.67 * 2 / (640.0 * 480.0 * 32.0);

std::string header(const FarmOptions& o, const std::string& name, int minutes, int mem_mb, int cpus,
                   const std::string& log, const std::string& more = "") {
    std::string h = "#!/bin/bash\n";
    h += "#SBATCH --job-name=" + name + "\n";
    h += cv::format("#SBATCH --time=%d\n#SBATCH --mem=%dM\n#SBATCH --cpus-per-task=%d\n", minutes,
                    mem_mb, cpus);
    h += "#SBATCH --output=" + log + "\n";
    if (!o.partition.empty()) h += "#SBATCH --partition=" + o.partition + "\n";
    h += more;  // (sbatch reads #SBATCH lines only before the first command)
    h += "set -euo pipefail\n";
    return h;
}

void writeScript(const std::string& path, const std::string& text) {
    cv::vbme::AtomicFile f(path);
    {
        std::ofstream s(f.tempPath());
        s << text;
        if (!s) CV_Error(cv::Error::StsError, "cannot write '" + path + "'");
    }
    fs::permissions(f.tempPath(), fs::perms::owner_all | fs::perms::group_read |
                                      fs::perms::group_exec | fs::perms::others_read |
                                      fs::perms::others_exec);
    f.commit();
}

void runFarmSlurm(FarmOptions& o) {
    using namespace cv::vbme;
    checkOverwrite(o.out, o.common.force);
    const cv::vbme::Scene scene = cv::vbme::Scene::read(o.scene);
    int frames = 0;
    {
        VideoReader reader(o.video);
        cv::Mat f;
        while (reader.read(f))
            ++frames;
    }
    if (frames == 0) CV_Error(cv::Error::StsBadArg, "video '" + o.video + "' has no frames");
    const int tasks = std::min(o.tasks, frames);
    const int spp = o.spp > 0 ? o.spp : scene.render.spp;
    const std::string work =
        absolute(!o.work.empty()
                     ? o.work
                     : (fs::path(o.out).parent_path() / (fs::path(o.out).stem().string() + "_work"))
                           .string());
    const std::string dir = (fs::path(work) / "slurm").string();
    for (const char* name : {"prepare.sbatch", "render.sbatch", "assemble.sbatch", "submit.sh"})
        checkOverwrite((fs::path(dir) / name).string(), o.common.force);
    fs::create_directories(dir);

    // requests: time from the frame size and spp, memory from the frame size
    const double pixels = (double)scene.image_size.area();
    const double frame_seconds = kCoreSecondsPerSample * pixels * spp / o.cpus;
    const int per_task = (frames + tasks - 1) / tasks;
    const int minutes =
        o.minutes > 0 ? o.minutes : 10 + (int)std::ceil(4 * frame_seconds * per_task / 60);
    // ~40 float layers per pixel (two passes, film, composite) plus the scene and textures
    const int mem_mb = o.mem_mb > 0 ? o.mem_mb : 1024 + (int)std::ceil(pixels * 160 / 1048576.0);
    const int prep_minutes = o.minutes > 0 ? o.minutes : 60 + frames / 10;
    const int prep_mem = std::max(mem_mb, 4096);

    std::error_code ec;
    const std::string vbme =
        !o.vbme.empty() ? o.vbme : fs::read_symlink("/proc/self/exe", ec).string();
    std::string common = quote(vbme) + " insert --quiet --video " + quote(absolute(o.video)) +
                         " --scene " + quote(absolute(o.scene)) + " --out " +
                         quote(absolute(o.out)) + " --work " + quote(work);
    if (!o.cameras.empty()) common += " --cameras " + quote(absolute(o.cameras));
    if (o.spp > 0) common += " --spp " + std::to_string(o.spp);
    if (o.common.force) common += " --force";
    if (!o.insert_args.empty()) common += " " + o.insert_args;
    const std::string threads =
        " --threads \"${SLURM_CPUS_PER_TASK:-" + std::to_string(o.cpus) + "}\"";

    const std::string prep = (fs::path(dir) / "prepare.sbatch").string();
    writeScript(prep,
                header(o, "vbme-prepare", prep_minutes, prep_mem, o.cpus, dir + "/prepare_%j.log") +
                    "# tracking, room textures, albedo, lights: once, into the work "
                    "folder\n" +
                    common + threads + " --prepare-only\n");
    const std::string render = (fs::path(dir) / "render.sbatch").string();
    writeScript(render,
                header(o, "vbme-render", minutes, mem_mb, o.cpus, dir + "/render_%A_%a.log",
                       cv::format("#SBATCH --array=0-%d\n#SBATCH --requeue\n", tasks - 1)) +
                    cv::format("# task i renders frames [i*%d/%d, (i+1)*%d/%d); a rerun (requeue, "
                               "preemption) resumes its frames\n",
                               frames, tasks, frames, tasks) +
                    cv::format("i=${SLURM_ARRAY_TASK_ID:?run this as a Slurm array task}\n"
                               "A=$(( i * %d / %d ))\nB=$(( (i + 1) * %d / %d ))\n",
                               frames, tasks, frames, tasks) +
                    // without --force the video did not exist when the scripts were written:
                    // if it exists now, the task that finished last wrote it (atomically), and
                    // a rerun of this task (requeue, preemption) has nothing left to do
                    (o.common.force ? std::string()
                                    : "if [ -e " + quote(absolute(o.out)) +
                                          " ]; then\n  echo \"vbme farm: the video is already "
                                          "written; nothing to do\"\n  exit 0\nfi\n") +
                    common + threads + " --frames \"$A:$B\"\n");
    const std::string assemble = (fs::path(dir) / "assemble.sbatch").string();
    writeScript(
        assemble,
        header(o, "vbme-assemble", 30 + frames / 60, 2048, 1, dir + "/assemble_%j.log") +
            "# the render task that finished last has usually written the video; else every\n"
            "# frame exists now and this run renders nothing and writes it\n"
            "if [ ! -e " +
            quote(absolute(o.out)) + " ]; then\n  " + common + " --threads 1 --frames 0:1\nfi\n" +
            "test -e " + quote(absolute(o.out)) +
            " || { echo 'vbme farm: frames are missing, the video was not written' >&2; "
            "exit 1; }\n");
    const std::string submit = (fs::path(dir) / "submit.sh").string();
    writeScript(submit,
                "#!/bin/bash\n# Submits the three jobs, each depending on the one before.\n"
                "set -euo pipefail\ncd " +
                    quote(dir) +
                    "\nprep=$(sbatch --parsable prepare.sbatch)\n"
                    "render=$(sbatch --parsable --dependency=afterok:${prep%%;*} render.sbatch)\n"
                    "# afterany: a requeued or preempted render task can leave an afterok\n"
                    "# dependency never satisfied (Slurm judges the killed run), while its rerun\n"
                    "# finishes the frames; assemble checks them itself\n"
                    "assemble=$(sbatch --parsable --dependency=afterany:${render%%;*} "
                    "assemble.sbatch)\n"
                    "echo \"submitted: prepare ${prep%%;*}, render ${render%%;*} (array), "
                    "assemble ${assemble%%;*}\"\n");

    std::printf(
        "%d frames of %dx%d at %d spp in %d tasks (%d frames each at most): "
        "%d min, %d MB, %d CPUs per task (estimated %.1f s per frame)\n",
        frames, scene.image_size.width, scene.image_size.height, spp, tasks, per_task, minutes,
        mem_mb, o.cpus, frame_seconds);
    std::printf("written: %s/{prepare.sbatch,render.sbatch,assemble.sbatch,submit.sh}\n",
                dir.c_str());
    if (o.submit) {
        const cv::vbme::ProcessResult r = cv::vbme::runProcess({"bash", submit});
        std::fputs(r.out.c_str(), stdout);
        std::fputs(r.err.c_str(), stderr);
        if (!r.ok())
            CV_Error(cv::Error::StsError,
                     cv::format("submitting with sbatch failed (exit %d): is Slurm's sbatch on "
                                "PATH and the controller up? The scripts are in %s",
                                r.status, dir.c_str()));
    } else {
        std::printf("submit with: bash %s\n", quote(submit).c_str());
    }
}

void setupFarm(CLI::App& app) {
    app.require_subcommand(1);
    CLI::App* slurm = app.add_subcommand(
        "slurm", "Write (and with --submit, submit) Slurm batch scripts for vbme insert");
    auto o = std::make_shared<FarmOptions>();
    slurm->footer(
        "Three jobs on a shared work folder: prepare (vbme insert --prepare-only), an array of\n"
        "--tasks render tasks (vbme insert --frames A:B; a requeued or preempted task resumes\n"
        "its frames), and assemble (writes the video once every frame exists), each depending\n"
        "on the one before. Time and memory requests are estimated from the frame size and spp\n"
        "(override with --time, --mem). See doc/cluster.md.");
    slurm->add_option("--video", o->video, "Input video (on the shared file system)")->required();
    slurm->add_option("--scene", o->scene, "Frame-0 scene file with objects:")
        ->required()
        ->check(CLI::ExistingFile);
    slurm->add_option("--out", o->out, "Output video")->required();
    slurm->add_option("--tasks", o->tasks, "Array tasks (frames are split evenly)")
        ->required()
        ->check(CLI::Range(1, 100000));
    slurm->add_option("--cameras", o->cameras, "Camera-path YAML (else tracked in the prepare job)")
        ->check(CLI::ExistingFile);
    slurm->add_option("--work", o->work, "Shared work folder (default: <out>_work)");
    slurm->add_option("--spp", o->spp, "Samples per pixel (default: the scene's)")
        ->check(CLI::PositiveNumber);
    slurm->add_option("--partition", o->partition, "Slurm partition");
    slurm->add_option("--cpus", o->cpus, "CPUs per task")
        ->check(CLI::Range(1, 4096))
        ->capture_default_str();
    slurm->add_option("--mem", o->mem_mb, "Memory per task in MB (default: estimated)")
        ->check(CLI::PositiveNumber);
    slurm->add_option("--time", o->minutes, "Minutes per task (default: estimated)")
        ->check(CLI::PositiveNumber);
    slurm->add_option("--insert-args", o->insert_args,
                      "More vbme insert options for every job, e.g. \"--lights none\"");
    slurm->add_option("--vbme", o->vbme, "The vbme program on the nodes (default: this one)");
    slurm->add_flag("--submit", o->submit, "Submit the jobs with sbatch");
    addCommonOptions(*slurm, o->common);
    slurm->callback([o] {
        applyCommonOptions(o->common);
        runFarmSlurm(*o);
    });
}

}  // namespace

VBME_REGISTER_COMMAND("farm", "Run vbme insert on a cluster: write Slurm batch scripts", setupFarm);

}  // namespace vbme_app
