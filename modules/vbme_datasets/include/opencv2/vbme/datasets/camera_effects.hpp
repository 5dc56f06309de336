// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_DATASETS_CAMERA_EFFECTS_HPP
#define OPENCV_VBME_DATASETS_CAMERA_EFFECTS_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/core/response.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_datasets
//! @{

/** @brief What a phone camera does to a clip, applied in test code to frames rendered without
it (the same effects to an input clip and to its truth, so that both stay comparable).

Gains act in linear light: a frame is linearised with @p response, multiplied per channel by
cameraEffectGains(), encoded again, rounded and saturated; then Gaussian noise is added to the
encoded 8-bit values. With the defaults every effect is off and applyCameraEffects() returns
its input unchanged. */
struct CV_EXPORTS CameraEffects {
    /** @brief Exposure drift: the linear gain of frame t is
    g(t) = 1 + exposure_amplitude · sin(2π (t + phase) / period) (auto-exposure hunting). */
    double exposure_amplitude = 0;
    /** @brief White-balance drift: the red gain is 1 + wb_amplitude · s(t), the blue gain
    1 − wb_amplitude · s(t), green 1, with s(t) = sin(2π (t + phase) / period + wb_phase). */
    double wb_amplitude = 0;
    double wb_phase = CV_PI / 2;  //!< radians: a white balance that does not follow the exposure
    double period = 48;           //!< frames of one cycle of both drifts
    double phase = 0;             //!< frames added to t in both drifts
    /** @brief Gaussian noise's standard deviation in 8-bit code values of the encoded frame,
    independent per channel. */
    double noise_sigma = 0;
    /** @brief Spatial correlation of the noise: the standard deviation (pixels) of a Gaussian
    blur of the noise field, which is then rescaled so that its per-pixel standard deviation
    stays noise_sigma (0: white noise). */
    double noise_blur = 0;
    uint64 seed = 0;                     //!< the noise depends on (seed, frame index) only
    Response response = Response::SRGB;  //!< how the frames are encoded
};

/** @brief The per-channel linear gains (B, G, R) of frame @p t: the exposure drift times the
white-balance drift of @p fx. */
CV_EXPORTS Vec3d cameraEffectGains(const CameraEffects& fx, int t);

/** @brief Multiplies a frame by per-channel gains in linear light.
@param frame_bgr8 CV_8UC3 display-encoded frame.
@param gains_bgr linear gains (B, G, R).
@param r the frame's response (linearise, multiply, encode).
@return CV_8UC3, rounded and saturated (values the gain pushes above 255 clip, as a camera's
do). */
CV_EXPORTS Mat applyLinearGains(const Mat& frame_bgr8, const Vec3d& gains_bgr,
                                Response r = Response::SRGB);

/** @brief Adds Gaussian noise to a frame's encoded values.
@param frame_bgr8 CV_8UC3 frame.
@param sigma standard deviation in code values (per channel, independent between channels).
@param blur_px spatial correlation (CameraEffects::noise_blur; 0: white noise).
@param seed the noise is a function of @p seed only (cv::RNG).
@return CV_8UC3, rounded and saturated. */
CV_EXPORTS Mat addSensorNoise(const Mat& frame_bgr8, double sigma, double blur_px, uint64 seed);

/** @brief All effects of @p fx on frame index @p t: the gains (applyLinearGains() with
cameraEffectGains()), then the noise (addSensorNoise() with a seed mixed from fx.seed and
@p t). Returns a copy of @p frame_bgr8 when no effect is on. */
CV_EXPORTS Mat applyCameraEffects(const Mat& frame_bgr8, int t, const CameraEffects& fx);

// --- grain's effects ---

/** @brief Phone-like compression: encodes @p frames as H.264 (yuv420p) at an average bit rate
through VideoSink into @p path (e.g. a file in the test's temporary folder, `.mp4`), decodes it
back with VideoReader and returns the decoded frames (8-bit BGR, as many as were written).
@param frames 8-bit BGR frames of one size.
@param fps frame rate written.
@param bitrate average bit rate in bit/s (e.g. 400000 for 320×180 at 30 fps, about the bits
per pixel of a phone's 1080p30 video at 17 Mbit/s).
@param path the video file written (overwritten). */
CV_EXPORTS std::vector<Mat> compressH264(const std::vector<Mat>& frames, double fps, int64 bitrate,
                                         const std::string& path);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
