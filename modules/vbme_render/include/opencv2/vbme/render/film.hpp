// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_FILM_HPP
#define OPENCV_VBME_RENDER_FILM_HPP

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/response.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief The images a render produces (all CV_32F, the render's size). */
struct CV_EXPORTS RenderImages {
    Mat color;    //!< CV_32FC3, linear scene-referred radiance, BGR order
    Mat albedo;   //!< CV_32FC3, diffuse colour at the first hit (BGR), black where nothing was hit
    Mat normal;   //!< CV_32FC3, world shading normal at the first hit, channels (X, Y, Z)
    Mat object;   //!< CV_32FC1, fraction of the pixel's paths that interacted with an `objects:`
                  //!< mesh (a path vertex on it, or a shadow ray it blocked)
    Mat mask;     //!< CV_32FC1, fraction of the pixel's camera rays whose first hit is an
                  //!< `objects:` mesh (the compositing mask M of differential rendering)
    Mat samples;  //!< CV_32FC1, samples taken per pixel (adaptive sampling only, else empty)
};

/** @brief Reconstruction filter of the film.

Both filters are applied by *filter importance sampling* @cite Ernst2006: a pixel's sample positions
are drawn from the filter's density around the pixel centre and every sample has weight 1, so each
pixel is the plain mean of its own samples — no splatting between pixels, no order-dependent sums,
bitwise identical for any thread count. */
enum FilterType {
    FILTER_BOX,      //!< uniform over the pixel, [−½, ½)² (the default)
    FILTER_GAUSSIAN  //!< separable Gaussian, σ = 0.5 pixel, each axis truncated at ±2 pixels
};

/** @brief Offset of a FILTER_GAUSSIAN film sample from its pixel centre for uniform numbers
@p u (filterOffset()'s Gaussian case). */
CV_EXPORTS Vec2f filterOffsetGaussian(const Vec2f& u);

/** @brief Offset of a film sample from its pixel centre for uniform numbers @p u. Inline: the
box filter's offset is two subtractions, taken once per camera ray. */
inline Vec2f filterOffset(FilterType filter, const Vec2f& u) {
    if (filter == FILTER_GAUSSIAN) return filterOffsetGaussian(u);
    return Vec2f(u[0] - 0.5f, u[1] - 0.5f);
}

/** @brief Parses "box" or "gaussian". */
CV_EXPORTS FilterType parseFilter(const std::string& name);

/** @brief Writes float channels to an OpenEXR file (32-bit float, ZIP compression) under a
temporary name renamed when complete (cv::vbme::AtomicFile).
@param path the .exr file.
@param channels (name, CV_32FC1 image) pairs, all the same size.
@param attributes string header attributes (provenance). */
CV_EXPORTS void writeExrChannels(
    const std::string& path, const std::vector<std::pair<std::string, Mat>>& channels,
    const std::map<std::string, std::string>& attributes = std::map<std::string, std::string>());

/** @brief Reads every channel of an OpenEXR file as CV_32FC1 images; @p attributes (if not
null) receives the string header attributes. Throws cv::Exception if the file is unreadable. */
CV_EXPORTS std::map<std::string, Mat> readExrChannels(
    const std::string& path, std::map<std::string, std::string>* attributes = nullptr);

/** @brief Writes a render as OpenEXR: channels R, G, B, then (when present) albedo.R/G/B,
N.X/Y/Z, `object` and `mask`; @p attributes become string header attributes. Atomic. */
CV_EXPORTS void writeExr(
    const std::string& path, const RenderImages& images,
    const std::map<std::string, std::string>& attributes = std::map<std::string, std::string>());

/** @brief Reads an EXR written by writeExr() (color from R,G,B, and the AOVs if present). */
CV_EXPORTS RenderImages readExr(const std::string& path,
                                std::map<std::string, std::string>* attributes = nullptr);

/** @brief Preview exposure in the style of LuxRender's linear tone map.

`v = L · (t / N²) · (S / 10) · 0.65 · (118/255)^γ`, then `display = clamp(v, 0, 1)^(1/γ)`,
with sensitivity S (ISO), f-number N, exposure time t (seconds) and gamma γ. With the defaults
(S = 320, N = 2.8, t = 1 s, γ = 2.2) a radiance of about 2.05 maps to white. */
struct CV_EXPORTS ExposureParams {
    float sensitivity = 320.f;  //!< film sensitivity (ISO)
    float fstop = 2.8f;         //!< f-number
    float exposure = 1.f;       //!< exposure time (seconds)
    float gamma = 2.2f;         //!< display gamma
    /** @brief The linear scale factor applied to radiance before the gamma. */
    float scale() const;
    /** @brief Reads the fields present in @p fn. */
    void read(const FileNode& fn);
    /** @brief Writes the fields. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief An 8-bit BGR preview of a linear BGR render with ExposureParams. */
CV_EXPORTS void previewExposure(InputArray linear_bgr, OutputArray bgr8,
                                const ExposureParams& params = ExposureParams());

//! @}

}  // namespace vbme
}  // namespace cv

#endif
