// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_TEXTURE_HPP
#define OPENCV_VBME_RENDER_TEXTURE_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/response.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief A colour over (u, v) texture coordinates: linear RGB, thread-safe, allocation-free
lookups.

Texture coordinates: u runs left → right across the image, v runs bottom → top (the OBJ
convention), so (u, v) = (0, 0) is the bottom-left corner of the image and (1, 1) the top
right. Image point x = u·W − ½, y = (1 − v)·H − ½ (pixel centres at integers), filtered
bilinearly.
*/
class CV_EXPORTS Texture {
public:
    /** @brief How coordinates outside [0,1] are treated. */
    enum Wrap {
        WRAP_REPEAT,  //!< tile the image (mesh textures)
        WRAP_CLAMP    //!< clamp to the edge pixels (room faces)
    };
    virtual ~Texture();
    /** @brief Linear RGB colour at (u, v). */
    virtual Vec3f eval(const Vec2f& uv) const = 0;
    /** @brief The mean colour (linear RGB). */
    virtual Vec3f mean() const = 0;
    /** @brief Linear RGB colour at (u, v) averaged over a footprint @p width wide in texture
    coordinates (a fraction of the image width), for lookups whose ray cone is wide (hits after
    a diffuse bounce) @cite Williams1983.

    An image texture keeps a mip-map: level k is the image box-filtered to 1/2^k of its size
    (levels above 0 as 8-bit sRGB through a look-up table when every value lies in [0, 1],
    else as float); the lookup is bilinear in level ⌊log2(width · max(W, H))⌋, clamped to the
    pyramid, and in the full image (eval()) when that level is ≤ 0. Constant textures and
    the default implementation return eval(). */
    virtual Vec3f evalFiltered(const Vec2f& uv, float width) const;

    /** @brief A constant colour (linear RGB). */
    static Ptr<Texture> createConstant(const Vec3f& rgb);
    /** @brief An image texture.
    @param image_bgr linear CV_32FC3 (or CV_32FC1, grey) image in BGR order.
    @param wrap how coordinates outside [0,1] are treated. */
    static Ptr<Texture> createImage(InputArray image_bgr, Wrap wrap = WRAP_REPEAT);
    /** @brief Loads an image file: 8- or 16-bit images are linearised with @p response, float
    images (.exr, .hdr, .pfm) are taken as linear. Throws cv::Exception naming @p field and the
    file if it is missing or unreadable. */
    static Ptr<Texture> load(const std::string& path, Response response, Wrap wrap,
                             const std::string& field = "texture");
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
