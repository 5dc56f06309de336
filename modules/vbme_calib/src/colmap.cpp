// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE).
#include "opencv2/vbme/calib/colmap.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <sys/resource.h>

#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/core/utility.hpp"

namespace fs = std::filesystem;

namespace cv {
namespace vbme {

Matx33d rotationFromQuaternion(const Vec4d& q_in) {
    const double n = norm(q_in);
    CV_Assert(n > 0);
    const Vec4d q = q_in * (1.0 / n);
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    return Matx33d(1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                   2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y));
}

Vec4d quaternionFromRotation(const Matx33d& R) {
    // Shepperd's method: the largest of the four candidates keeps the division
    // well conditioned.
    const double tr = R(0, 0) + R(1, 1) + R(2, 2);
    Vec4d q;
    if (tr > 0) {
        const double s = std::sqrt(tr + 1.0) * 2;
        q = Vec4d(0.25 * s, (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s,
                  (R(1, 0) - R(0, 1)) / s);
    } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
        const double s = std::sqrt(1.0 + R(0, 0) - R(1, 1) - R(2, 2)) * 2;
        q = Vec4d((R(2, 1) - R(1, 2)) / s, 0.25 * s, (R(0, 1) + R(1, 0)) / s,
                  (R(0, 2) + R(2, 0)) / s);
    } else if (R(1, 1) > R(2, 2)) {
        const double s = std::sqrt(1.0 + R(1, 1) - R(0, 0) - R(2, 2)) * 2;
        q = Vec4d((R(0, 2) - R(2, 0)) / s, (R(0, 1) + R(1, 0)) / s, 0.25 * s,
                  (R(1, 2) + R(2, 1)) / s);
    } else {
        const double s = std::sqrt(1.0 + R(2, 2) - R(0, 0) - R(1, 1)) * 2;
        q = Vec4d((R(1, 0) - R(0, 1)) / s, (R(0, 2) + R(2, 0)) / s, (R(1, 2) + R(2, 1)) / s,
                  0.25 * s);
    }
    q *= 1.0 / norm(q);
    if (q[0] < 0) q = -q;
    return q;
}

namespace {

// Lines of a COLMAP text file without comments and blank lines, with their line
// numbers.
// Next line of a COLMAP text file that is neither blank nor a comment; @p n counts the lines
// read.
bool nextDataLine(std::istream& f, std::string& line, int& n) {
    while (std::getline(f, line)) {
        ++n;
        const size_t p = line.find_first_not_of(" \t\r");
        if (p != std::string::npos && line[p] != '#') return true;
    }
    return false;
}

std::ifstream openColmapFile(const std::string& path) {
    std::ifstream f(path);
    if (!f) CV_Error(Error::StsError, "cannot read COLMAP file '" + path + "'");
    return f;
}

std::vector<std::pair<int, std::string>> dataLines(const std::string& path) {
    std::ifstream f = openColmapFile(path);
    std::vector<std::pair<int, std::string>> out;
    std::string line;
    int n = 0;
    while (nextDataLine(f, line, n))
        out.emplace_back(n, line);
    return out;
}

[[noreturn]] void parseError(const std::string& path, int line, const std::string& what) {
    CV_Error(Error::StsParseError, format("%s:%d: %s", path.c_str(), line, what.c_str()));
}

}  // namespace

std::vector<ColmapModel> ColmapModel::readTextModels(const std::string& root) {
    std::error_code ec;
    std::vector<fs::path> dirs;
    for (const auto& e : fs::directory_iterator(root, ec))
        if (e.is_directory()) dirs.push_back(e.path());
    std::sort(dirs.begin(), dirs.end());
    std::vector<ColmapModel> models;
    for (const auto& d : dirs)
        models.push_back(readText(d.string()));
    std::stable_sort(models.begin(), models.end(), [](const ColmapModel& a, const ColmapModel& b) {
        return a.images.size() > b.images.size();
    });
    return models;
}

ColmapModel ColmapModel::readText(const std::string& dir) {
    ColmapModel m;
    const std::string cam_path = (fs::path(dir) / "cameras.txt").string();
    for (const auto& [n, line] : dataLines(cam_path)) {
        std::istringstream s(line);
        ColmapCamera c;
        if (!(s >> c.id >> c.model >> c.size.width >> c.size.height))
            parseError(cam_path, n, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
        double v;
        while (s >> v)
            c.params.push_back(v);
        m.cameras[c.id] = c;
    }
    const std::string img_path = (fs::path(dir) / "images.txt").string();
    // Two lines per image; the second (keypoints) may be empty, which dataLines()
    // would drop, so the raw file is read to keep the pairing right.
    std::ifstream f = openColmapFile(img_path);
    std::string line;
    int n = 0;
    while (nextDataLine(f, line, n)) {
        std::istringstream s(line);
        ColmapImage im;
        Vec4d q;
        if (!(s >> im.id >> q[0] >> q[1] >> q[2] >> q[3] >> im.t[0] >> im.t[1] >> im.t[2] >>
              im.camera_id >> im.name))
            parseError(img_path, n, "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
        if (!(norm(q) > 0) || !std::isfinite(norm(q)))
            parseError(img_path, n, "the quaternion QW QX QY QZ is zero or not finite");
        im.R = rotationFromQuaternion(q);
        std::string pts;
        if (std::getline(f, pts)) {
            ++n;
            std::istringstream ps(pts);
            double x, y;
            long long id;
            while (ps >> x >> y >> id) {
                im.xys.emplace_back(x, y);
                im.point3d_ids.push_back(id);
            }
        }
        m.images[im.id] = im;
    }
    const std::string pt_path = (fs::path(dir) / "points3D.txt").string();
    for (const auto& [ln, l] : dataLines(pt_path)) {
        std::istringstream s(l);
        ColmapPoint pt;
        int r, g, b;
        if (!(s >> pt.id >> pt.xyz[0] >> pt.xyz[1] >> pt.xyz[2] >> r >> g >> b >> pt.error))
            parseError(pt_path, ln, "expected POINT3D_ID X Y Z R G B ERROR TRACK[]");
        pt.rgb = Vec3b((uchar)r, (uchar)g, (uchar)b);
        int image_id, idx;
        while (s >> image_id >> idx)
            pt.track.emplace_back(image_id, idx);
        m.points[pt.id] = pt;
    }
    return m;
}

void ColmapModel::writeText(const std::string& dir) const {
    std::error_code ec;
    fs::create_directories(dir, ec);
    auto writeFile = [&](const std::string& name, const std::string& text) {
        const std::string path = (fs::path(dir) / name).string();
        AtomicFile out(path);
        {
            std::ofstream f(out.tempPath());
            f << text;
            if (!f) CV_Error(Error::StsError, "cannot write '" + path + "'");
        }
        out.commit();
    };
    std::ostringstream c, i, p;
    c.precision(17);
    i.precision(17);
    p.precision(17);
    c << "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, "
         "WIDTH, HEIGHT, PARAMS[]\n";
    for (const auto& [id, cam] : cameras) {
        c << id << " " << cam.model << " " << cam.size.width << " " << cam.size.height;
        for (double v : cam.params)
            c << " " << v;
        c << "\n";
    }
    i << "# Image list with two lines of data per image:\n"
         "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
         "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
    for (const auto& [id, im] : images) {
        const Vec4d q = quaternionFromRotation(im.R);
        i << id << " " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << " " << im.t[0] << " "
          << im.t[1] << " " << im.t[2] << " " << im.camera_id << " " << im.name << "\n";
        for (size_t k = 0; k < im.xys.size(); ++k)
            i << (k ? " " : "") << im.xys[k].x << " " << im.xys[k].y << " " << im.point3d_ids[k];
        i << "\n";
    }
    p << "# 3D point list with one line of data per point:\n"
         "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, "
         "POINT2D_IDX)\n";
    for (const auto& [id, pt] : points) {
        p << id << " " << pt.xyz[0] << " " << pt.xyz[1] << " " << pt.xyz[2] << " " << (int)pt.rgb[0]
          << " " << (int)pt.rgb[1] << " " << (int)pt.rgb[2] << " " << pt.error;
        for (const auto& t : pt.track)
            p << " " << t.first << " " << t.second;
        p << "\n";
    }
    writeFile("cameras.txt", c.str());
    writeFile("images.txt", i.str());
    writeFile("points3D.txt", p.str());
}

const ColmapImage* ColmapModel::imageByName(const std::string& name) const {
    for (const auto& kv : images)
        if (kv.second.name == name) return &kv.second;
    return nullptr;
}

namespace {

using Args = std::vector<std::string>;

// CPU seconds (user + system) of this process's finished, waited-for children.
double childCpuSeconds() {
    rusage u{};
    getrusage(RUSAGE_CHILDREN, &u);
    return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Runs one colmap step (no shell), appending its output to the log; throws in plain words
// on failure.
void runStep(const ColmapOptions& o, const std::string& step, const Args& args,
             const std::string& log) {
    {
        std::ofstream l(log, std::ios::app);
        l << "\n==== colmap " << step;
        for (const std::string& a : args)
            l << " " << a;
        l << "\n";
    }
    Args argv = {o.executable, step};
    argv.insert(argv.end(), args.begin(), args.end());
    ProcessOptions po;
    po.env = {"QT_QPA_PLATFORM=offscreen"};
    po.log_file = log;
    // a hung step is stopped: SIGTERM, then SIGKILL 5 s later
    po.timeout = std::max(0, o.timeout);
    po.kill_after = 5;
    const ProcessResult r = runProcess(argv, po);
    if (!r.error.empty())
        CV_Error(Error::StsError, "the colmap program ('" + o.executable +
                                      "') was not found: install Debian's colmap "
                                      "package or give its path (" +
                                      r.error + ")");
    if (r.timed_out)
        CV_Error(Error::StsError,
                 format("COLMAP %s did not finish within %d s (hung?) and was stopped; its output "
                        "is in %s",
                        step.c_str(), o.timeout, log.c_str()));
    if (r.status != 0)
        CV_Error(Error::StsError, format("COLMAP %s failed (exit code %d); its output is in %s",
                                         step.c_str(), r.status, log.c_str()));
}

}  // namespace

namespace {

// Runs a colmap step and records its wall and CPU time.
void timedStep(const ColmapOptions& o, const std::string& step, const Args& args,
               const std::string& log, std::vector<std::pair<std::string, double>>* step_seconds,
               std::vector<std::pair<std::string, double>>* step_cpu_seconds) {
    const double cpu0 = childCpuSeconds();
    ScopedTimer timer([&](double s) {
        if (step_seconds) step_seconds->emplace_back(step, s);
    });
    runStep(o, step, args, log);
    timer.stop();
    if (step_cpu_seconds) step_cpu_seconds->emplace_back(step, childCpuSeconds() - cpu0);
}

// COLMAP's mapper on the database of @p work_dir into work_dir/<sparse_name>, converted to text
// in work_dir/<text_name> (both emptied first); the models read back.
std::vector<ColmapModel> mapAndConvert(const std::string& image_dir, const std::string& work_dir,
                                       const std::string& sparse_name, const std::string& text_name,
                                       const ColmapOptions& o,
                                       std::vector<std::pair<std::string, double>>* step_seconds,
                                       std::vector<std::pair<std::string, double>>* step_cpu) {
    const fs::path work(work_dir);
    const std::string log = (work / "colmap.log").string(), db = (work / "database.db").string();
    const fs::path sparse = work / sparse_name, text = work / text_name;
    std::error_code ec;
    fs::remove_all(sparse, ec);
    fs::remove_all(text, ec);
    fs::create_directories(sparse, ec);
    timedStep(o, "mapper",
              {"--random_seed",
               std::to_string(o.random_seed),
               "--database_path",
               db,
               "--image_path",
               image_dir,
               "--output_path",
               sparse.string(),
               "--Mapper.num_threads",
               std::to_string(o.mapper_threads),
               "--Mapper.ba_refine_focal_length",
               "0",
               "--Mapper.ba_refine_principal_point",
               "0",
               "--Mapper.ba_refine_extra_params",
               "0",
               "--Mapper.min_model_size",
               std::to_string(o.min_model_size),
               "--Mapper.abs_pose_min_num_inliers",
               std::to_string(o.abs_pose_min_num_inliers)},
              log, step_seconds, step_cpu);
    for (const auto& e : fs::directory_iterator(sparse, ec)) {
        if (!e.is_directory()) continue;
        const fs::path out = text / e.path().filename();
        fs::create_directories(out, ec);
        runStep(o, "model_converter",
                {"--input_path", e.path().string(), "--output_path", out.string(), "--output_type",
                 "TXT"},
                log);
    }
    return ColmapModel::readTextModels(text.string());
}

}  // namespace

std::vector<ColmapModel> rerunColmapMapper(
    const std::string& image_dir, const std::string& work_dir, const std::string& output_name,
    const ColmapOptions& o, std::vector<std::pair<std::string, double>>* step_seconds,
    std::vector<std::pair<std::string, double>>* step_cpu_seconds) {
    const fs::path work(work_dir);
    std::error_code ec;
    if (!fs::exists(work / "database.db", ec))
        CV_Error(Error::StsError, "no COLMAP database in '" + work_dir + "' to map again");
    if (output_name.empty() || output_name == "sparse" || output_name == "sparse_txt")
        CV_Error(Error::StsBadArg, "rerunColmapMapper: output_name '" + output_name +
                                       "' would overwrite runColmapSfM's models");
    return mapAndConvert(image_dir, work_dir, output_name, output_name + "_txt", o, step_seconds,
                         step_cpu_seconds);
}

std::vector<ColmapModel> runColmapSfM(
    const std::string& image_dir, const std::string& work_dir, const Matx33d& K, Size size,
    const ColmapOptions& o, std::vector<std::pair<std::string, double>>* step_seconds,
    std::vector<std::pair<std::string, double>>* step_cpu_seconds) {
    auto timed = [&](const std::string& step, const Args& args, const std::string& log) {
        timedStep(o, step, args, log, step_seconds, step_cpu_seconds);
    };
    std::error_code ec;
    if (!fs::is_directory(image_dir, ec))
        CV_Error(Error::StsError, "'" + image_dir + "' is not a folder of images");
    fs::create_directories(work_dir, ec);
    if (ec) CV_Error(Error::StsError, "cannot create '" + work_dir + "': " + ec.message());
    const fs::path work(work_dir);
    const std::string log = (work / "colmap.log").string(), db = (work / "database.db").string();
    fs::remove(db, ec);

    // PINHOLE with COLMAP's +0.5 pixel-centre convention.
    const std::string params =
        format("%.10g,%.10g,%.10g,%.10g", K(0, 0), K(1, 1), K(0, 2) + 0.5, K(1, 2) + 0.5);
    const Args common = {"--random_seed", std::to_string(o.random_seed)};
    auto with = [&](Args extra) {
        Args a = common;
        a.insert(a.end(), extra.begin(), extra.end());
        return a;
    };
    if (!o.database.empty()) {
        // An earlier run's features and matches, mapped again (replays that run's model).
        fs::copy_file(o.database, db, fs::copy_options::overwrite_existing, ec);
        if (ec)
            CV_Error(Error::StsError,
                     "cannot copy the COLMAP database '" + o.database + "': " + ec.message());
        std::vector<ColmapModel> models = mapAndConvert(image_dir, work_dir, "sparse", "sparse_txt",
                                                        o, step_seconds, step_cpu_seconds);
        if (models.empty())
            CV_Error(Error::StsError, "COLMAP reconstructed nothing from the database '" +
                                          o.database + "'; its output is in " + log);
        return models;
    }
    timed("feature_extractor",
          with({"--database_path", db, "--image_path", image_dir, "--ImageReader.camera_model",
                "PINHOLE", "--ImageReader.single_camera", "1", "--ImageReader.camera_params",
                params, "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads",
                std::to_string(o.threads), "--SiftExtraction.max_num_features",
                std::to_string(o.max_num_features)}),
          log);
    Args match = with({"--database_path", db, "--SiftMatching.use_gpu", "0",
                       "--SiftMatching.num_threads", std::to_string(o.threads),
                       "--SequentialMatching.overlap", std::to_string(o.overlap)});
    if (!o.vocab_tree.empty())
        match.insert(match.end(), {"--SequentialMatching.loop_detection", "1",
                                   "--SequentialMatching.vocab_tree_path", o.vocab_tree});
    timed("sequential_matcher", match, log);
    std::vector<ColmapModel> models = mapAndConvert(image_dir, work_dir, "sparse", "sparse_txt", o,
                                                    step_seconds, step_cpu_seconds);
    if (models.empty())
        CV_Error(Error::StsError, "COLMAP reconstructed nothing from '" + image_dir +
                                      "' (too little texture or motion?); its output is in " + log);
    return models;
}

}  // namespace vbme
}  // namespace cv
