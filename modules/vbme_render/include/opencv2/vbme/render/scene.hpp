// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_SCENE_HPP
#define OPENCV_VBME_RENDER_SCENE_HPP

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/render/lights.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief What a piece of render geometry stands for (queryable per hit). */
enum class GeometryKind {
    ROOM = 0,    //!< the room box
    PROXY = 1,   //!< a `proxies:` mesh (in both differential-rendering passes)
    OBJECT = 2,  //!< an `objects:` mesh (only in the "with objects" pass)
    LIGHT = 3    //!< the surface of a polygon light
};

/** @brief A surface hit returned by RenderScene::intersect(). */
struct CV_EXPORTS SurfaceHit {
    float t = 0;       //!< ray distance
    Vec3f p;           //!< world position
    Vec3f ng;          //!< unit geometric normal (outside of the mesh, into the room)
    Vec3f ns;          //!< unit shading normal, on the side of ng
    Vec2f uv;          //!< texture coordinates
    int geom_id = -1;  //!< geometry index (see RenderScene::geometryKind)
    int prim_id = -1;  //!< triangle index within the geometry
    GeometryKind kind = GeometryKind::ROOM;  //!< what was hit
};

/** @brief A cv::vbme::Scene turned into Embree geometry @cite Wald2014, materials and lights,
built once and shared by every render of it.

- **Room**: six inward-facing quads (two triangles each). The texture of each face is mapped
  the way a viewer standing upright inside the room sees it: for a wall, facing it (image top =
  up, z); for the floor, facing the back wall and looking down (image top towards `back`); for
  the ceiling, facing the back wall and looking up (image top towards `front`). So, image right
  / image up: floor +x / +y; ceiling +x / −y; back +x / +z; front −x / +z; left +y / +z; right
  −y / +z. 8- and 16-bit textures are linearised with the scene camera's response, float
  textures are taken as linear; filtering is bilinear, clamped at the edges. Faces are
  Lambertian with the texture as albedo (Params::room_albedo without a texture), or emissive
  with the texture as radiance (Params::room_emissive).
- **Objects and proxies**: meshes loaded with assimp (OBJ with MTL, PLY, glTF, …) and placed
  by `world_from_object`. Without a `material:` in the scene, MTL materials map to: `Ke` ≠ 0 →
  emission (plus a black Lambertian); `d` < 1 → dielectric with IOR `Ni` (1.5 if unset) and
  absorption −ln(`Tf`) per metre; `Ks` ≠ 0 and `Ns` > 0 → Phong {Kd, Ks, Ns}; otherwise
  Lambertian {Kd}; `map_Kd` (8-bit, sRGB-decoded, repeated) replaces the diffuse colour.
- **Polygon lights** are also geometry (kind LIGHT, moved 10⁻⁵ of the scene size towards their
  lit side so that a light lying on a wall is not hidden by it), so paths can hit them.

Two Embree scenes share the geometry buffers: one with everything, one without the
`objects:` meshes (built on first use), for the two passes of differential rendering; with
Params::retrace_leaks, a robust copy of each is built when a first ray needs it.
*/
class CV_EXPORTS RenderScene {
public:
    /** @brief Options of the scene build. */
    struct CV_EXPORTS Params {
        Params();                                     //!< Defaults as below.
        Vec3f room_albedo = Vec3f(0.8f, 0.8f, 0.8f);  //!< albedo of untextured room faces
        bool room_emissive = false;  //!< room textures are radiance (emitters), not albedo
        /** @brief Embree's robust mode for every ray (RTC_SCENE_FLAG_ROBUST: conservative
        traversal and a watertight triangle test, so that no ray slips through the edges shared by
        neighbouring triangles). Off (the default), Embree's faster kernels trace every ray first;
        see retrace_leaks. */
        bool robust = false;
        /** @brief With robust off: a closest-hit ray (intersect()) whose outcome only a leak can
        produce is traced again in robust mode (a second BVH, built on first need) — a ray that
        escapes a closed room (the scene has a `room:`; tfar beyond the scene's diagonal), or that
        meets the back of an opaque (non-transmissive) surface (d · ng > 0: it got inside a mesh, or
        behind a one-sided surface, where the robust trace confirms it). Occlusion rays are not
        checked. Off: Embree's fast kernels alone, as Embree's own `pathtracer` runs. */
        bool retrace_leaks = true;
        /** @brief Reads the fields present in @p fn; an unknown key or a value check()
        refuses is an error. */
        void read(const FileNode& fn);
        /** @brief Writes the fields. */
        void write(FileStorage& fs) const;
        /** @brief Throws a cv::Exception naming the first field outside its valid range. */
        void check() const;
    };

    virtual ~RenderScene();

    /** @brief Builds the render scene. Throws cv::Exception naming the scene field at fault
    (missing or unreadable mesh or texture, mesh without triangles, …). */
    static Ptr<RenderScene> create(const Scene& scene, const Params& params = Params());

    /** @brief The scene it was built from. */
    virtual const Scene& scene() const = 0;
    /** @brief Number of geometries (valid geom_id are 0 … n−1). */
    virtual int numGeometries() const = 0;
    /** @brief Kind of geometry @p geom_id. */
    virtual GeometryKind geometryKind(int geom_id) const = 0;
    /** @brief Index of the geometry's source in the scene: room → 0, proxy / object → index
    in `proxies` / `objects`, light → index in `lights`. */
    virtual int geometrySource(int geom_id) const = 0;
    /** @brief Number of triangles in total. */
    virtual size_t numTriangles() const = 0;
    /** @brief The lights (one per scene light, in order). */
    virtual const std::vector<Ptr<Emitter>>& emitters() const = 0;
    /** @brief Axis-aligned bounds of all finite geometry (world). */
    virtual void bounds(Vec3f& lo, Vec3f& hi) const = 0;

    /** @brief Closest hit along the ray o + t·d, t in (tnear, tfar).
    @param with_objects false: ignore the `objects:` meshes. @return whether something was hit. */
    virtual bool intersect(const Vec3f& o, const Vec3f& d, float tnear, float tfar, SurfaceHit& hit,
                           bool with_objects = true) const = 0;
    /** @brief Whether anything blocks the ray o + t·d for t in (tnear, tfar). */
    virtual bool occluded(const Vec3f& o, const Vec3f& d, float tnear, float tfar,
                          bool with_objects = true) const = 0;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
