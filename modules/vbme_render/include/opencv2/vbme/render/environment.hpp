// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_ENVIRONMENT_HPP
#define OPENCV_VBME_RENDER_ENVIRONMENT_HPP

#include <memory>
#include <string>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief An equirectangular environment (radiance arriving from every direction), world z up,
mapped the way Blender maps it, with importance sampling.

Mapping of a world direction d (after world_from_env⁻¹): u = 0.5 − atan2(d.y, d.x)/2π,
v = acos(d.z)/π, column = u·W, row = v·H in continuous coordinates where pixel i covers
[i, i+1) (row 0 is straight up), so the image centre looks along +x and +y lies a quarter width
left of it, as in Blender. Radiance is looked up bilinearly. Sampling draws a pixel from the
piecewise-constant distribution of luminance·sin θ (marginal rows, conditional columns) and a
point inside it; the solid-angle pdf is pdf_uv/(2π² sin θ). See doc/vbme_render_materials.md.
Methods are const and thread-safe.
*/
class CV_EXPORTS EnvironmentMap {
public:
    /** @brief From a linear CV_32FC3 BGR equirectangular image (W = 2H is usual, not needed).
    @param world_from_env rotation from the map's frame to the world.
    @param scale multiplies the radiance. */
    EnvironmentMap(const Mat& equirect, const Matx33f& world_from_env = Matx33f::eye(),
                   float scale = 1.f);
    /** @brief A constant environment (no image). */
    explicit EnvironmentMap(const Vec3f& radiance);
    /** @brief Loads a .hdr (Radiance) or .exr image; throws cv::Exception if unreadable. */
    static EnvironmentMap load(const std::string& path,
                               const Matx33f& world_from_env = Matx33f::eye(), float scale = 1.f);
    ~EnvironmentMap();
    EnvironmentMap(EnvironmentMap&&) noexcept;
    EnvironmentMap& operator=(EnvironmentMap&&) noexcept;
    /** @brief Copy: the sampling tables are copied, the (read-only) image is shared. */
    EnvironmentMap(const EnvironmentMap& other);
    /** @brief Copy assignment (see the copy constructor). */
    EnvironmentMap& operator=(const EnvironmentMap& other);

    /** @brief Radiance (RGB) arriving from world direction @p dir (unit). */
    Vec3f eval(const Vec3f& dir) const;
    /** @brief Solid-angle pdf of sample() for @p dir. */
    float pdf(const Vec3f& dir) const;
    /** @brief Samples a direction. @return its radiance; @p dir and @p pdf are set. */
    Vec3f sample(const Vec2f& u, Vec3f& dir, float& pdf) const;
    /** @brief The pixel (x, y) of a world direction, in image coordinates with pixel centres at
    integers (DESIGN): x = u·W − 0.5, y = v·H − 0.5 for the (u, v) ∈ [0,1)² of the class
    comment. A constant environment has no image: throws cv::Exception. */
    Point2f directionToPixel(const Vec3f& dir) const;
    /** @brief The world direction of image point (x, y) (inverse of directionToPixel()). */
    Vec3f pixelToDirection(const Point2f& px) const;
    /** @brief Whether this is a constant environment. */
    bool isConstant() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/** @brief The thesis's environment from a background image (§4.4, Eq. 4.12–4.14): the image
inside a disk (the inpainted background around the object) is mapped onto two hemispheres, the
front one as seen through the disk and the back one mirrored, giving an equirectangular map.
@param background linear CV_32FC3 BGR image.
@param center disk centre in the image (pixels).
@param radius disk radius (pixels).
@param cam_from_world rotation of the camera that took the image (so that the map is in world
axes, z up).
@param out_size size of the equirectangular image to produce (e.g. 512×256).
@return a CV_32FC3 equirectangular image usable with EnvironmentMap. */
CV_EXPORTS Mat imageDiskToEnvironment(InputArray background, Point2f center, float radius,
                                      const Matx33f& cam_from_world, Size out_size);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
