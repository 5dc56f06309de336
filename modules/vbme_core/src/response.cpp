// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/response.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace cv {
namespace vbme {

Response parseResponse(const std::string& name) {
    std::string n = name;
    std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return std::tolower(c); });
    if (n == "srgb") return Response::SRGB;
    if (n == "gamma2.2" || n == "gamma22" || n == "gamma") return Response::GAMMA22;
    if (n == "linear") return Response::LINEAR;
    CV_Error(Error::StsBadArg,
             "camera response '" + name + "' is unknown (expected srgb, gamma2.2 or linear)");
}

std::string toString(Response r) {
    switch (r) {
        case Response::SRGB:
            return "srgb";
        case Response::GAMMA22:
            return "gamma2.2";
        case Response::LINEAR:
            return "linear";
    }
    return "srgb";
}

float linearize(float v, Response r) {
    switch (r) {
        case Response::SRGB:
            return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
        case Response::GAMMA22:
            return v <= 0.f ? 0.f : std::pow(v, 2.2f);
        case Response::LINEAR:
            return v;
    }
    return v;
}

float encode(float v, Response r) {
    switch (r) {
        case Response::SRGB:
            return v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
        case Response::GAMMA22:
            return v <= 0.f ? 0.f : std::pow(v, 1.f / 2.2f);
        case Response::LINEAR:
            return v;
    }
    return v;
}

void linearize(InputArray _src, OutputArray _dst, Response r) {
    Mat src = _src.getMat();
    CV_Assert(!src.empty());
    const int cn = src.channels();
    if (src.depth() == CV_8U) {
        Mat lut(1, 256, CV_32F);
        for (int i = 0; i < 256; ++i)
            lut.at<float>(i) = linearize(i / 255.f, r);
        LUT(src, lut, _dst);  // a one-channel table applies to every channel
        return;
    }
    Mat f;
    if (src.depth() == CV_16U)
        src.convertTo(f, CV_32F, 1.0 / 65535.0);
    else if (src.depth() == CV_32F)
        f = src.clone();
    else
        src.convertTo(f, CV_32F);
    if (r != Response::LINEAR) {
        f = f.reshape(1);
        for (int y = 0; y < f.rows; ++y) {
            float* p = f.ptr<float>(y);
            for (int x = 0; x < f.cols; ++x)
                p[x] = linearize(p[x], r);
        }
        f = f.reshape(cn);
    }
    f.copyTo(_dst);
}

void encode(InputArray _src, OutputArray _dst, Response r, int ddepth) {
    Mat src = _src.getMat();
    CV_Assert(src.depth() == CV_32F);
    CV_Assert(ddepth == CV_8U || ddepth == CV_32F);
    const int cn = src.channels();
    Mat f = src.clone().reshape(1);
    if (r != Response::LINEAR) {
        for (int y = 0; y < f.rows; ++y) {
            float* p = f.ptr<float>(y);
            for (int x = 0; x < f.cols; ++x)
                p[x] = encode(p[x], r);
        }
    }
    f = f.reshape(cn);
    if (ddepth == CV_8U)
        f.convertTo(_dst, CV_8U, 255.0);
    else
        f.copyTo(_dst);
}

}  // namespace vbme
}  // namespace cv
