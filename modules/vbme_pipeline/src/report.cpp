// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/pipeline/report.hpp"

#include <iomanip>
#include <ostream>
#include <unordered_map>

#include "opencv2/vbme/core/fileio.hpp"

namespace cv {
namespace vbme {

namespace {

using Named = std::vector<std::pair<std::string, double>>;

double* find(Named& v, const std::string& name) {
    for (auto& kv : v)
        if (kv.first == name) return &kv.second;
    return nullptr;
}

double lookup(const Named& v, const std::string& name, double fallback) {
    for (const auto& kv : v)
        if (kv.first == name) return kv.second;
    return fallback;
}

void writeNamed(FileStorage& fs, const char* key, const Named& v) {
    fs << key << "{";
    for (const auto& kv : v)
        fs << kv.first << kv.second;
    fs << "}";
}

Named readNamed(const FileNode& n) {
    Named v;
    if (!n.isMap()) return v;
    for (const FileNode& c : n)
        v.emplace_back(c.name(), (double)c);
    return v;
}

}  // namespace

void PipelineReport::addSeconds(const std::string& stage, double s) {
    if (double* x = find(seconds, stage))
        *x += s;
    else
        seconds.emplace_back(stage, s);
}

double PipelineReport::stageSeconds(const std::string& stage) const {
    return lookup(seconds, stage, 0.0);
}

void PipelineReport::setFigure(const std::string& name, double value) {
    if (double* x = find(figures, name))
        *x = value;
    else
        figures.emplace_back(name, value);
}

void PipelineReport::setFigures(const std::vector<std::pair<std::string, double>>& values) {
    std::unordered_map<std::string, size_t> at;
    at.reserve(figures.size() + values.size());
    for (size_t i = 0; i < figures.size(); ++i)
        at.emplace(figures[i].first, i);  // the first of equal names, as find() would
    for (const auto& kv : values) {
        const auto [it, added] = at.emplace(kv.first, figures.size());
        if (added)
            figures.push_back(kv);
        else
            figures[it->second].second = kv.second;
    }
}

double PipelineReport::figure(const std::string& name, double default_value) const {
    return lookup(figures, name, default_value);
}

void PipelineReport::print(std::ostream& out) const {
    const int frames = frames_processed;
    const auto flags = out.flags();
    out << std::left << std::setw(14) << "stage" << std::right << std::setw(10) << "seconds"
        << std::setw(10) << "frames/s"
        << "\n";
    out << std::fixed;
    auto row = [&](const std::string& name, double s) {
        out << std::left << std::setw(14) << name << std::right << std::setw(10)
            << std::setprecision(3) << s << std::setw(10) << std::setprecision(1)
            << (s > 0 ? frames / s : 0.0) << "\n";
    };
    for (const auto& s : seconds)
        row(s.first, s.second);
    row("total", total_seconds);
    out << "frames: " << frames_total << " in the video, " << frames_processed << " made, "
        << frames_skipped << " already done, " << frames_busy << " busy elsewhere";
    if (frames_lost) out << ", " << frames_lost << " lost";
    out << "\n";
    if (!missing.empty()) out << "frames still missing: " << missing.size() << "\n";
    for (const auto& f : figures)
        out << f.first << ": " << std::defaultfloat << std::setprecision(6) << f.second << "\n";
    out.flags(flags);
}

void PipelineReport::write(FileStorage& fs) const {
    fs << "pipeline" << pipeline << "frames_total" << frames_total << "frames_processed"
       << frames_processed << "frames_skipped" << frames_skipped << "frames_busy" << frames_busy
       << "frames_lost" << frames_lost << "video_written" << (int)video_written << "work" << work;
    fs << "missing_frames"
       << "[:";
    for (int m : missing)
        fs << m;
    fs << "]";
    writeNamed(fs, "seconds", seconds);
    fs << "total_seconds" << total_seconds;
    writeNamed(fs, "figures", figures);
}

void PipelineReport::read(const FileNode& n) {
    *this = PipelineReport();
    if (!n["pipeline"].empty()) n["pipeline"] >> pipeline;
    auto readInt = [&](const char* k, int& v) {
        if (!n[k].empty()) v = (int)n[k];
    };
    readInt("frames_total", frames_total);
    readInt("frames_processed", frames_processed);
    readInt("frames_skipped", frames_skipped);
    readInt("frames_busy", frames_busy);
    readInt("frames_lost", frames_lost);
    video_written = !n["video_written"].empty() && (int)n["video_written"] != 0;
    if (!n["work"].empty()) n["work"] >> work;
    for (const FileNode& m : n["missing_frames"])
        missing.push_back((int)m);
    seconds = readNamed(n["seconds"]);
    if (!n["total_seconds"].empty()) total_seconds = (double)n["total_seconds"];
    figures = readNamed(n["figures"]);
}

void PipelineReport::save(const std::string& path) const {
    AtomicFile out(path);
    {
        FileStorage fs(out.tempPath(), FileStorage::WRITE);
        if (!fs.isOpened()) CV_Error(Error::StsError, "cannot write the report '" + path + "'");
        write(fs);
    }
    out.commit();
}

}  // namespace vbme
}  // namespace cv
