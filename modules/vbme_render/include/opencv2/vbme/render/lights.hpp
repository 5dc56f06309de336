// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_LIGHTS_HPP
#define OPENCV_VBME_RENDER_LIGHTS_HPP

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief A light sample drawn for a shading point (next-event estimation). */
struct EmitterSample {
    Vec3f L;             //!< radiance arriving along −wi (RGB; for delta lights: the
                         //!< irradiance-like value whose division by pdf = 1 is exact)
    Vec3f wi;            //!< unit direction from the shading point towards the light
    float dist = 0;      //!< distance to the light point (infinity for distant / environment)
    float pdf = 0;       //!< solid-angle pdf of wi (1 for delta lights)
    bool delta = false;  //!< a Dirac light (point, distant with zero half-angle): no MIS
};

/** @brief A light source of the renderer, made from a scene-file cv::vbme::Light.

- **polygon**: planar, corners wound counter-clockwise seen from the lit side; emits radiance
  `radiance` on that side only; triangulated as a fan from the first corner (the polygon must
  be convex) and sampled uniformly by area @cite Pharr2016.
- **point**: radiant intensity `intensity` (W/sr): L/pdf = I / d².
- **distant**: radiance `radiance` over the cone of half-angle `half_angle_deg` around
  `to_light`, sampled uniformly in the cone; with a zero half-angle it is a Dirac light whose
  `radiance` is taken as the irradiance on a surface facing it.
- **environment**: a constant radiance or an equirectangular image (cv::vbme::EnvironmentMap,
  importance sampled).

Methods are const, thread-safe and allocation-free.
*/
class CV_EXPORTS Emitter {
public:
    virtual ~Emitter();
    /** @brief The kind of light. */
    virtual Light::Type type() const = 0;
    /** @brief Samples a direction towards the light from point @p p with uniform numbers
    @p u. @return false if nothing was sampled (e.g. @p p behind a polygon light). */
    virtual bool sample(const Vec3f& p, const Vec2f& u, EmitterSample& s) const = 0;
    /** @brief For an area light hit at point @p q (distance @p dist along unit direction
    @p wi from @p p): the solid-angle pdf with which sample() draws it. */
    virtual float pdfHit(const Vec3f& p, const Vec3f& wi, float dist) const { return 0.f; }
    /** @brief Radiance leaving an area light at a hit along −@p wi (zero from behind). */
    virtual Vec3f radianceHit(const Vec3f& wi) const { return Vec3f(0, 0, 0); }
    /** @brief For lights at infinity: radiance arriving along −@p dir for a ray escaping in
    direction @p dir. */
    virtual Vec3f radianceEscaped(const Vec3f& dir) const { return Vec3f(0, 0, 0); }
    /** @brief For lights at infinity: solid-angle pdf of sample() for @p dir. */
    virtual float pdfEscaped(const Vec3f& dir) const { return 0.f; }
    /** @brief Whether the light is a Dirac delta (cannot be hit by rays; sample() then ignores
    its `u`, and the path tracer does not draw it). */
    virtual bool isDelta() const { return false; }
    /** @brief Whether the light is at infinity (distant, environment). */
    virtual bool isInfinite() const { return false; }
    /** @brief Total emitted power (W) for area and point lights; for lights at infinity the
    power through a disk of radius @p scene_radius. Used for documentation and statistics. */
    virtual float power(float scene_radius) const = 0;

    /** @brief A renderer light from a scene-file light. Environment images are loaded here
    (throws cv::Exception naming @p field if unreadable). */
    static Ptr<Emitter> create(const Light& light, const std::string& field = "light");
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
