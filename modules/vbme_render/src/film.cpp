// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/render/film.hpp"
#include "opencv2/vbme/core/params.hpp"

#include <cmath>
#include <filesystem>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include "opencv2/vbme/core/fileio.hpp"

namespace cv {
namespace vbme {

namespace {

// Inverse CDF of the Gaussian (σ = 0.5) truncated to [−2, 2], tabulated once.
struct TruncatedGaussian {
    static constexpr int kN = 1024;
    float inv[kN + 1];
    TruncatedGaussian() {
        const double sigma = 0.5, r = 2.0;
        const int M = 1 << 14;
        std::vector<double> cdf(M + 1, 0.0);
        const double g0 = std::exp(-r * r / (2 * sigma * sigma));
        for (int i = 0; i < M; ++i) {
            const double x = -r + (i + 0.5) * (2 * r / M);
            cdf[i + 1] = cdf[i] + std::max(0.0, std::exp(-x * x / (2 * sigma * sigma)) - g0);
        }
        for (auto& c : cdf)
            c /= cdf[M];
        int j = 0;
        for (int k = 0; k <= kN; ++k) {
            const double u = double(k) / kN;
            while (j < M && cdf[j + 1] < u)
                ++j;
            const double c0 = cdf[j], c1 = cdf[std::min(j + 1, M)];
            const double a = c1 > c0 ? (u - c0) / (c1 - c0) : 0.0;
            inv[k] = float(-r + (j + std::min(std::max(a, 0.0), 1.0)) * (2 * r / M));
        }
    }
    float sample(float u) const {
        const float x = u * kN;
        const int i = std::min(int(x), kN - 1);
        const float a = x - i;
        return inv[i] * (1.f - a) + inv[i + 1] * a;
    }
};

const TruncatedGaussian& gaussian() {
    static const TruncatedGaussian g;
    return g;
}

}  // namespace

Vec2f filterOffsetGaussian(const Vec2f& u) {
    return Vec2f(gaussian().sample(u[0]), gaussian().sample(u[1]));
}

FilterType parseFilter(const std::string& name) {
    if (name == "box") return FILTER_BOX;
    if (name == "gaussian") return FILTER_GAUSSIAN;
    CV_Error(Error::StsBadArg, "filter: unknown '" + name + "' (expected box or gaussian)");
}

void writeExrChannels(const std::string& path,
                      const std::vector<std::pair<std::string, Mat>>& channels,
                      const std::map<std::string, std::string>& attributes) {
    if (channels.empty()) CV_Error(Error::StsBadArg, "writeExrChannels: no channels");
    const Size sz = channels[0].second.size();
    std::vector<Mat> planes;
    for (const auto& c : channels) {
        if (c.second.size() != sz || c.second.type() != CV_32FC1)
            CV_Error(Error::StsBadArg, "writeExrChannels: channel '" + c.first +
                                           "' must be CV_32FC1 of the first channel's size");
        planes.push_back(c.second.isContinuous() ? c.second : c.second.clone());
    }
    AtomicFile out(path);
    try {
        Imf::Header header(sz.width, sz.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        for (const auto& c : channels)
            header.channels().insert(c.first, Imf::Channel(Imf::FLOAT));
        for (const auto& a : attributes)
            header.insert(a.first, Imf::StringAttribute(a.second));
        Imf::FrameBuffer fb;
        for (size_t i = 0; i < channels.size(); ++i)
            fb.insert(channels[i].first, Imf::Slice(Imf::FLOAT, (char*)planes[i].ptr<float>(),
                                                    sizeof(float), sizeof(float) * sz.width));
        Imf::OutputFile file(out.tempPath().c_str(), header);
        file.setFrameBuffer(fb);
        file.writePixels(sz.height);
    } catch (const std::exception& e) {
        CV_Error(Error::StsError, "cannot write '" + path + "': " + e.what());
    }
    out.commit();
}

std::map<std::string, Mat> readExrChannels(const std::string& path,
                                           std::map<std::string, std::string>* attributes) {
    if (!std::filesystem::exists(path))
        CV_Error(Error::StsObjectNotFound, "'" + path + "' does not exist");
    std::map<std::string, Mat> out;
    try {
        Imf::InputFile file(path.c_str());
        const Imath::Box2i dw = file.header().dataWindow();
        const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        Imf::FrameBuffer fb;
        for (auto it = file.header().channels().begin(); it != file.header().channels().end();
             ++it) {
            Mat m(h, w, CV_32FC1, Scalar(0));
            out[it.name()] = m;
            char* base = (char*)m.ptr<float>() - (dw.min.x + size_t(dw.min.y) * w) * sizeof(float);
            fb.insert(it.name(), Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * w));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        if (attributes) {
            for (auto it = file.header().begin(); it != file.header().end(); ++it) {
                const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute());
                if (s) (*attributes)[it.name()] = s->value();
            }
        }
    } catch (const std::exception& e) {
        CV_Error(Error::StsError, "cannot read EXR '" + path + "': " + e.what());
    }
    return out;
}

void writeExr(const std::string& path, const RenderImages& images,
              const std::map<std::string, std::string>& attributes) {
    CV_Assert(images.color.type() == CV_32FC3);
    std::vector<std::pair<std::string, Mat>> ch;
    std::vector<Mat> p;
    split(images.color, p);
    ch.emplace_back("R", p[2]);
    ch.emplace_back("G", p[1]);
    ch.emplace_back("B", p[0]);
    if (!images.albedo.empty()) {
        std::vector<Mat> a;
        split(images.albedo, a);
        ch.emplace_back("albedo.R", a[2]);
        ch.emplace_back("albedo.G", a[1]);
        ch.emplace_back("albedo.B", a[0]);
    }
    if (!images.normal.empty()) {
        std::vector<Mat> n;
        split(images.normal, n);
        ch.emplace_back("N.X", n[0]);
        ch.emplace_back("N.Y", n[1]);
        ch.emplace_back("N.Z", n[2]);
    }
    if (!images.object.empty()) ch.emplace_back("object", images.object);
    if (!images.mask.empty()) ch.emplace_back("mask", images.mask);
    writeExrChannels(path, ch, attributes);
}

RenderImages readExr(const std::string& path, std::map<std::string, std::string>* attributes) {
    auto ch = readExrChannels(path, attributes);
    auto get3 = [&](const char* a, const char* b, const char* c) -> Mat {
        if (!ch.count(a) || !ch.count(b) || !ch.count(c)) return Mat();
        Mat m;
        merge(std::vector<Mat>{ch[a], ch[b], ch[c]}, m);
        return m;
    };
    RenderImages r;
    r.color = get3("B", "G", "R");
    if (r.color.empty() && ch.count("Y"))
        merge(std::vector<Mat>{ch["Y"], ch["Y"], ch["Y"]}, r.color);
    if (r.color.empty()) CV_Error(Error::StsBadArg, "'" + path + "': no R, G, B channels");
    r.albedo = get3("albedo.B", "albedo.G", "albedo.R");
    r.normal = get3("N.X", "N.Y", "N.Z");
    if (ch.count("object")) r.object = ch["object"];
    if (ch.count("mask")) r.mask = ch["mask"];
    return r;
}

float ExposureParams::scale() const {
    return exposure / (fstop * fstop) * (sensitivity / 10.f) * 0.65f *
           std::pow(118.f / 255.f, gamma);
}

void ExposureParams::read(const FileNode& fn) {
    ParamsIn in(fn, "exposure parameters");
    in("sensitivity", sensitivity);
    in("fstop", fstop);
    in("exposure", exposure);
    in("gamma", gamma);
    in.finish();
    check();
}

void ExposureParams::check() const {
    const char* w = "exposure parameters";
    checkParam(sensitivity > 0, w, "sensitivity", sensitivity, "> 0 (ISO)");
    checkParam(fstop > 0, w, "fstop", fstop, "> 0");
    checkParam(exposure > 0, w, "exposure", exposure, "> 0 seconds");
    checkParam(gamma > 0, w, "gamma", gamma, "> 0");
}

void ExposureParams::write(FileStorage& fs) const {
    fs << "sensitivity" << sensitivity << "fstop" << fstop << "exposure" << exposure << "gamma"
       << gamma;
}

void previewExposure(InputArray linear_bgr, OutputArray bgr8, const ExposureParams& params) {
    Mat src = linear_bgr.getMat();
    CV_Assert(src.depth() == CV_32F);
    const float s = params.scale(), inv_g = 1.f / params.gamma;
    Mat dst(src.size(), CV_MAKETYPE(CV_8U, src.channels()));
    const int n = src.cols * src.channels();
    for (int y = 0; y < src.rows; ++y) {
        const float* a = src.ptr<float>(y);
        uchar* b = dst.ptr<uchar>(y);
        for (int i = 0; i < n; ++i) {
            const float v = std::min(std::max(a[i] * s, 0.f), 1.f);
            b[i] = saturate_cast<uchar>(std::pow(v, inv_g) * 255.f);
        }
    }
    dst.copyTo(bgr8);
}

}  // namespace vbme
}  // namespace cv
