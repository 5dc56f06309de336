// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_RESPONSE_HPP
#define OPENCV_VBME_CORE_RESPONSE_HPP

#include <string>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief Camera response: how scene-linear values were display-encoded.

Input video is linearised with the inverse response before any lighting arithmetic, and
composites are re-encoded with the same response (DESIGN, "Colour").
*/
enum class Response {
    SRGB,     //!< IEC 61966-2-1 sRGB transfer curve (the default)
    GAMMA22,  //!< pure power law, exponent 2.2
    LINEAR    //!< no encoding
};

/** @brief Parses "srgb", "gamma2.2" or "linear" (case-insensitive). Throws cv::Exception
listing the accepted names otherwise. */
CV_EXPORTS Response parseResponse(const std::string& name);
/** @brief The file name of a response: "srgb", "gamma2.2" or "linear". */
CV_EXPORTS std::string toString(Response r);

/** @brief Display-encoded value in [0,1] → scene-linear value. */
CV_EXPORTS float linearize(float encoded, Response r);
/** @brief Scene-linear value → display-encoded value (not clamped). */
CV_EXPORTS float encode(float linear, Response r);

/** @brief Linearises an image.
@param src CV_8U (divided by 255), CV_16U (divided by 65535) or CV_32F (taken as encoded
values in [0,1]) with any number of channels.
@param dst CV_32F image of the same size and channels, scene-linear.
@param r the camera response. 8-bit input uses a 256-entry look-up table. */
CV_EXPORTS void linearize(InputArray src, OutputArray dst, Response r);

/** @brief Encodes a scene-linear CV_32F image for display.
@param src CV_32F, any number of channels.
@param dst output; its depth is @p ddepth: CV_8U (rounded, saturated to [0,255]) or CV_32F
(encoded, not clamped).
@param r the camera response.
@param ddepth CV_8U or CV_32F. */
CV_EXPORTS void encode(InputArray src, OutputArray dst, Response r, int ddepth = CV_8U);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
