// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Internals of RenderScene shared with the integrators (private to vbme_render).
#ifndef VBME_RENDER_SCENE_IMPL_HPP
#define VBME_RENDER_SCENE_IMPL_HPP

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <vector>

#include "opencv2/vbme/render/bsdf.hpp"
#include "opencv2/vbme/render/scene.hpp"
#include "opencv2/vbme/render/texture.hpp"

namespace cv {
namespace vbme {
namespace render_detail {

/** A surface's appearance: BSDF, optional diffuse texture, optional emission. */
struct MaterialRec {
    Ptr<Bsdf> bsdf;
    Ptr<Texture> texture;       // diffuse colour; null: bsdf->defaultDiffuse()
    Ptr<Texture> emission_tex;  // emitted radiance texture (emissive room); null: `emission`
    Vec3f diffuse;              // constant diffuse colour
    Vec3f emission;             // constant emitted radiance (both sides)
    bool emissive = false;
    bool is_delta = false;
    bool single_lobe = false;  // the BSDF's sample() ignores u_lobe
    bool lambertian = false;   // bsdf_detail::isLambertian: inline sample and eval
    bool transmission = false;
    Vec3f absorption;

    Vec3f diffuseAt(const Vec2f& uv) const { return texture ? texture->eval(uv) : diffuse; }
    /** Diffuse colour averaged over a footprint @p width wide in texture coordinates. */
    Vec3f diffuseFiltered(const Vec2f& uv, float width) const {
        return texture ? texture->evalFiltered(uv, width) : diffuse;
    }
    Vec3f emissionAt(const Vec2f& uv) const {
        return emission_tex ? emission_tex->eval(uv) : emission;
    }
};

/** One Embree triangle geometry with its attributes (world space). */
struct GeometryRec {
    GeometryKind kind = GeometryKind::ROOM;
    int source = 0;
    std::vector<float> pos;          // xyz per vertex, +1 float of padding for Embree
    std::vector<Vec3f> nrm;          // per vertex (optional)
    std::vector<Vec2f> uv;           // per vertex (optional)
    std::vector<uint32_t> idx;       // 3 per triangle
    std::vector<int> prim_material;  // per triangle (optional)
    std::vector<Vec3f> face_normal;  // per triangle: unit geometric normal (computeFaceNormals)
    int material = -1;               // when prim_material is empty
    int light = -1;                  // emitter index (LIGHT)
    size_t numVertices() const { return pos.size() / 3; }
    size_t numTriangles() const { return idx.size() / 3; }
    Vec3f vertex(uint32_t i) const { return Vec3f(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]); }
    /** Fills face_normal: (v1 − v0) × (v2 − v0), normalised, for every triangle — once here
    instead of at every hit (a square root and a division on each path vertex's chain). */
    void computeFaceNormals() {
        face_normal.resize(numTriangles());
        for (size_t f = 0; f < face_normal.size(); ++f) {
            const uint32_t* tri = &idx[3 * f];
            const Vec3f v0 = vertex(tri[0]), v1 = vertex(tri[1]), v2 = vertex(tri[2]);
            Vec3f ng = (v1 - v0).cross(v2 - v0);
            ng *= 1.f / std::sqrt(ng.dot(ng));
            face_normal[f] = ng;
        }
    }
};

class RenderSceneImpl : public RenderScene {
public:
    RenderSceneImpl(const Scene& scene, const Params& params);
    ~RenderSceneImpl() override;

    const Scene& scene() const override { return scene_; }
    int numGeometries() const override { return (int)geoms_.size(); }
    GeometryKind geometryKind(int g) const override { return geoms_.at(g).kind; }
    int geometrySource(int g) const override { return geoms_.at(g).source; }
    size_t numTriangles() const override;
    const std::vector<Ptr<Emitter>>& emitters() const override { return emitters_; }
    void bounds(Vec3f& lo, Vec3f& hi) const override {
        lo = lo_;
        hi = hi_;
    }
    bool intersect(const Vec3f& o, const Vec3f& d, float tnear, float tfar, SurfaceHit& hit,
                   bool with_objects = true) const override;
    bool occluded(const Vec3f& o, const Vec3f& d, float tnear, float tfar,
                  bool with_objects = true) const override;
    /** Closest hits of @p n ≤ 8 rays o[k] + t·d[k], t in (0, ∞), traced as one packet
    (rtcIntersect8, coherent): found[k] tells whether hit[k] was filled. Meant for camera rays,
    which start at one point and fan out over a pixel. */
    void intersect8(const Vec3f* o, const Vec3f* d, int n, SurfaceHit* hit, bool* found,
                    bool with_objects) const;
    /** Occlusion of @p n ≤ 8 rays o[k] + t·d[k], t in (0, tfar[k]), traced as one packet
    (rtcOccluded8): blocked[k] tells whether something lies on ray k. */
    void occluded8(const Vec3f* o, const Vec3f* d, const float* tfar, int n, bool* blocked,
                   bool with_objects) const;
    /** occluded8() for @p n ≤ 16 rays (rtcOccluded16). */
    void occluded16(const Vec3f* o, const Vec3f* d, const float* tfar, int n, bool* blocked,
                    bool with_objects) const;

    const GeometryRec& geometry(int g) const { return geoms_[g]; }
    const MaterialRec& material(int g, int prim) const {
        const GeometryRec& r = geoms_[g];
        return materials_[r.prim_material.empty() ? r.material : r.prim_material[prim]];
    }
    /** Ray-offset distance at point @p p: safely above float rounding there (10⁻⁵ of the
    largest coordinate, at least 10 µm). Depends on the point only, not on the scene content,
    so renders with and without objects offset identically. */
    static float epsilon(const Vec3f& p) {
        const float m = std::max(std::abs(p[0]), std::max(std::abs(p[1]), std::abs(p[2])));
        return 1e-5f * std::max(m, 1.f);
    }
    /** Texture-coordinate length per world length on triangle @p prim of geometry @p g
    (√(uv area / world area); barycentric (b1, b2) when the geometry has no uv). */
    float uvPerLength(int g, int prim) const {
        const GeometryRec& r = geoms_[g];
        const uint32_t* tri = &r.idx[3 * size_t(prim)];
        const Vec3f a = r.vertex(tri[0]), b = r.vertex(tri[1]), c = r.vertex(tri[2]);
        const Vec3f n = (b - a).cross(c - a);
        const float world2 = std::sqrt(n.dot(n));
        float uv2 = 1.f;
        if (!r.uv.empty()) {
            const Vec2f p = r.uv[tri[1]] - r.uv[tri[0]], q = r.uv[tri[2]] - r.uv[tri[0]];
            uv2 = std::abs(p[0] * q[1] - p[1] * q[0]);
        }
        return world2 > 0.f ? std::sqrt(uv2 / world2) : 0.f;
    }
    /** Index of the emitter of a LIGHT geometry. */
    int lightOf(int g) const { return geoms_[g].light; }
    /** Whether any `objects:` geometry exists. */
    bool hasObjects() const { return has_objects_; }
    /** Whether a ray can pick up emission by hitting something or escaping: an area light, an
    emissive surface or an emitter at infinity. Without, only next-event estimation lights a
    path, and the ray after its last shadow ray cannot add to it. */
    bool hasHittableEmission() const { return hittable_emission_; }
    /** Emitters at infinity (indices into emitters()). */
    const std::vector<int>& infiniteEmitters() const { return infinite_; }

private:
    /** The hit record of triangle @p prim of geometry @p geom at barycentrics (u, v), distance t.
     */
    void fillHit(unsigned geom, unsigned prim, float u, float v, float t, SurfaceHit& hit) const;
    void addRoom();
    void addMesh(const SceneObject& o, GeometryKind kind, int index, const std::string& field);
    void addLight(const Light& l, int index);
    int addMaterial(MaterialRec m);
    RTCScene sceneFor(bool with_objects) const { return with_objects ? full_ : noObjectsScene(); }
    RTCScene noObjectsScene() const;
    RTCScene buildScene(bool with_objects, bool robust) const;
    /** Whether a closest-hit query's outcome calls for the robust trace (retrace_leaks): a miss
    in a closed room of a ray longer than the scene's diagonal, or a hit on the back of an
    opaque surface. */
    bool maybeLeak(bool found, float tfar, const Vec3f& d, const SurfaceHit& hit) const {
        if (!retrace_leaks_) return false;
        if (!found) return closed_ && tfar > diagonal_;
        return d.dot(hit.ng) > 0.f && !material(hit.geom_id, hit.prim_id).transmission;
    }
    /** intersect() in Embree's robust mode (the scenes built on first use). */
    bool intersectRobust(const Vec3f& o, const Vec3f& d, float tnear, float tfar, SurfaceHit& hit,
                         bool with_objects) const;

    Scene scene_;
    Params params_;
    std::vector<GeometryRec> geoms_;
    std::vector<MaterialRec> materials_;
    std::vector<Ptr<Emitter>> emitters_;
    std::vector<int> infinite_;
    Vec3f lo_, hi_;
    RTCDevice device_ = nullptr;
    mutable RTCScene full_ = nullptr;
    mutable RTCScene no_objects_ = nullptr;
    mutable std::once_flag no_objects_once_;
    // retrace_leaks: robust copies of full_ and no_objects_, built on first need
    mutable RTCScene robust_[2] = {nullptr, nullptr};  // [with_objects]
    mutable std::once_flag robust_once_[2];
    bool retrace_leaks_ = false;  // params_.retrace_leaks && !params_.robust
    bool closed_ = false;         // the scene has a room box (a ray from inside cannot escape)
    float diagonal_ = 0.f;        // |hi_ − lo_|
    bool has_objects_ = false;
    bool hittable_emission_ = false;
};

MaterialRec makeMaterial(const Material& m);

}  // namespace render_detail
}  // namespace vbme
}  // namespace cv

#endif
