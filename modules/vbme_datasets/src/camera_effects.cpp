// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Camera effects for tests: exposure and white-balance drift in linear light, sensor noise.
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/video.hpp"
#include "opencv2/vbme/datasets/camera_effects.hpp"

namespace cv {
namespace vbme {

Vec3d cameraEffectGains(const CameraEffects& fx, int t) {
    CV_Assert(fx.period > 0);
    const double a = 2 * CV_PI * (t + fx.phase) / fx.period;
    const double g = 1 + fx.exposure_amplitude * std::sin(a);
    const double s = std::sin(a + fx.wb_phase);
    return Vec3d(g * (1 - fx.wb_amplitude * s), g, g * (1 + fx.wb_amplitude * s));
}

Mat applyLinearGains(const Mat& frame_bgr8, const Vec3d& gains_bgr, Response r) {
    CV_Assert(frame_bgr8.type() == CV_8UC3);
    Mat lin, out;
    linearize(frame_bgr8, lin, r);
    multiply(lin, Scalar(gains_bgr[0], gains_bgr[1], gains_bgr[2]), lin);
    encode(lin, out, r, CV_8U);
    return out;
}

Mat addSensorNoise(const Mat& frame_bgr8, double sigma, double blur_px, uint64 seed) {
    CV_Assert(frame_bgr8.type() == CV_8UC3 && sigma >= 0 && blur_px >= 0);
    Mat noise(frame_bgr8.size(), CV_32FC3);
    RNG rng(seed);
    rng.fill(noise, RNG::NORMAL, 0, 1);
    if (blur_px > 0) {
        // rescale to unit per-pixel variance: white noise blurred by a separable kernel k has
        // variance (Σ k²)² (away from the border)
        const int ks = 2 * (int)std::ceil(3 * blur_px) + 1;
        GaussianBlur(noise, noise, Size(ks, ks), blur_px, blur_px, BORDER_REFLECT101);
        const Mat k = getGaussianKernel(ks, blur_px, CV_64F);
        const double s1 = k.dot(k);
        noise *= 1.0 / std::sqrt(s1 * s1);
    }
    Mat f, out;
    frame_bgr8.convertTo(f, CV_32FC3);
    f += noise * sigma;
    f.convertTo(out, CV_8UC3);  // rounds and saturates
    return out;
}

Mat applyCameraEffects(const Mat& frame_bgr8, int t, const CameraEffects& fx) {
    Mat out = frame_bgr8.clone();
    if (fx.exposure_amplitude != 0 || fx.wb_amplitude != 0)
        out = applyLinearGains(out, cameraEffectGains(fx, t), fx.response);
    if (fx.noise_sigma > 0) {
        const uint64 seed =
            fx.seed * 0x9e3779b97f4a7c15ull + (uint64)(t + 1) * 0xbf58476d1ce4e5b9ull;
        out = addSensorNoise(out, fx.noise_sigma, fx.noise_blur, seed);
    }
    return out;
}

// --- grain's effects ---

std::vector<Mat> compressH264(const std::vector<Mat>& frames, double fps, int64 bitrate,
                              const std::string& path) {
    CV_Assert(!frames.empty() && fps > 0 && bitrate > 0);
    VideoSinkOptions o;
    o.codec = "h264";
    o.bitrate = bitrate;
    o.pix_fmt = "yuv420p";
    {
        VideoSink sink(path, fps, frames[0].size(), o);
        for (const Mat& f : frames)
            sink.write(f);
        sink.close();
    }
    std::vector<Mat> out;
    VideoReader reader(path);
    Mat f;
    while (reader.read(f))
        out.push_back(f.clone());
    return out;
}

}  // namespace vbme
}  // namespace cv
