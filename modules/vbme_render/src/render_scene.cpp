// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Scene → Embree: room box, meshes (assimp), polygon-light geometry, materials, lights.
#include "render_scene_impl.hpp"

#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <cmath>
#include <cstddef>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <filesystem>
#include <limits>
#include <map>

#include "bsdf_models.hpp"
#include "opencv2/vbme/core/fileio.hpp"
#include "opencv2/vbme/core/params.hpp"

namespace cv {
namespace vbme {

RenderScene::~RenderScene() = default;

RenderScene::Params::Params() = default;

void RenderScene::Params::read(const FileNode& fn) {
    ParamsIn in(fn, "render scene parameters");
    if (const FileNode n = in.take("room_albedo"); !n.empty())
        room_albedo = Vec3f(readVec3(n, "room_albedo"));
    in("room_emissive", room_emissive);
    in("robust", robust);
    in("retrace_leaks", retrace_leaks);
    in.finish();
    check();
}

void RenderScene::Params::check() const {
    for (int c = 0; c < 3; c++)
        checkParam(room_albedo[c] >= 0 && std::isfinite(room_albedo[c]), "render scene parameters",
                   "room_albedo", room_albedo[c], "three finite values >= 0");
}

void RenderScene::Params::write(FileStorage& fs) const {
    writeVec3(fs, "room_albedo", Vec3d(room_albedo));
    fs << "room_emissive" << (int)room_emissive << "robust" << (int)robust << "retrace_leaks"
       << (int)retrace_leaks;
}

Ptr<RenderScene> RenderScene::create(const Scene& scene, const Params& params) {
    return makePtr<render_detail::RenderSceneImpl>(scene, params);
}

namespace render_detail {

MaterialRec makeMaterial(const Material& m) {
    MaterialRec r;
    if (m.type == Material::EMISSIVE) {
        Material black;
        black.type = Material::LAMBERTIAN;
        black.albedo = Vec3d(0, 0, 0);
        r.bsdf = Bsdf::create(black);
        r.emissive = true;
        r.emission = Vec3f(m.radiance);
    } else {
        r.bsdf = Bsdf::create(m);
    }
    r.diffuse = r.bsdf->defaultDiffuse();
    return r;
}

int RenderSceneImpl::addMaterial(MaterialRec m) {
    m.is_delta = m.bsdf->isDelta();
    m.single_lobe = m.bsdf->singleLobe();
    m.lambertian = bsdf_detail::isLambertian(*m.bsdf);
    m.transmission = m.bsdf->hasTransmission();
    m.absorption = m.bsdf->absorption();
    materials_.push_back(std::move(m));
    return (int)materials_.size() - 1;
}

RenderSceneImpl::RenderSceneImpl(const Scene& scene, const Params& params)
    : scene_(scene), params_(params) {
    if (scene_.has_room) addRoom();
    for (size_t i = 0; i < scene_.proxies.size(); ++i)
        addMesh(scene_.proxies[i], GeometryKind::PROXY, (int)i,
                "proxies[" + std::to_string(i) + "]");
    for (size_t i = 0; i < scene_.objects.size(); ++i)
        addMesh(scene_.objects[i], GeometryKind::OBJECT, (int)i,
                "objects[" + std::to_string(i) + "]");

    for (size_t i = 0; i < scene_.lights.size(); ++i)
        addLight(scene_.lights[i], (int)i);

    // Bounds of the finite geometry.
    const float inf = std::numeric_limits<float>::infinity();
    lo_ = Vec3f(inf, inf, inf);
    hi_ = Vec3f(-inf, -inf, -inf);
    for (const auto& g : geoms_)
        for (size_t v = 0; v < g.numVertices(); ++v)
            for (int a = 0; a < 3; ++a) {
                lo_[a] = std::min(lo_[a], g.pos[3 * v + a]);
                hi_[a] = std::max(hi_[a], g.pos[3 * v + a]);
            }
    if (!(lo_[0] <= hi_[0])) {
        lo_ = Vec3f(0, 0, 0);
        hi_ = Vec3f(0, 0, 0);
    }

    for (auto& g : geoms_) {
        g.computeFaceNormals();
        has_objects_ = has_objects_ || g.kind == GeometryKind::OBJECT;
        hittable_emission_ = hittable_emission_ || g.kind == GeometryKind::LIGHT;
    }
    for (const auto& m : materials_)
        hittable_emission_ = hittable_emission_ || m.emissive;
    hittable_emission_ = hittable_emission_ || !infinite_.empty();

    retrace_leaks_ = params_.retrace_leaks && !params_.robust;
    closed_ = scene_.has_room;
    diagonal_ = float(norm(hi_ - lo_));

    device_ = rtcNewDevice(nullptr);
    if (!device_) CV_Error(Error::StsError, "Embree: cannot create a device");
    full_ = buildScene(true, params_.robust);
}

RenderSceneImpl::~RenderSceneImpl() {
    if (full_) rtcReleaseScene(full_);
    if (no_objects_) rtcReleaseScene(no_objects_);
    for (RTCScene r : robust_)
        if (r) rtcReleaseScene(r);
    if (device_) rtcReleaseDevice(device_);
}

size_t RenderSceneImpl::numTriangles() const {
    size_t n = 0;
    for (const auto& g : geoms_)
        n += g.numTriangles();
    return n;
}

void RenderSceneImpl::addRoom() {
    const Room& room = scene_.room;
    GeometryRec g;
    g.kind = GeometryKind::ROOM;
    g.source = 0;
    for (int f = 0; f < 6; ++f) {
        // bottom-left corner, image-right and image-up edges as seen from inside
        const RoomFace_<float> F = room.face<float>(f);
        const std::string& name = Room::faceNames()[f];
        const Vec3f c[4] = {F.bl, F.bl + F.right, F.bl + F.right + F.up, F.bl + F.up};
        const Vec2f uv[4] = {Vec2f(0, 0), Vec2f(1, 0), Vec2f(1, 1), Vec2f(0, 1)};
        const uint32_t base = (uint32_t)g.uv.size();
        const Vec3f n = F.n;
        for (int k = 0; k < 4; ++k) {
            g.pos.insert(g.pos.end(), {c[k][0], c[k][1], c[k][2]});
            g.uv.push_back(uv[k]);
            g.nrm.push_back(n);
        }
        g.idx.insert(g.idx.end(), {base, base + 1, base + 2, base, base + 2, base + 3});

        MaterialRec m;
        Ptr<Texture> tex;
        auto it = room.textures.find(name);
        if (it != room.textures.end())
            tex = Texture::load(it->second, scene_.camera.response, Texture::WRAP_CLAMP,
                                "room.textures." + name);
        Material lam;
        lam.type = Material::LAMBERTIAN;
        if (params_.room_emissive) {
            lam.albedo = Vec3d(0, 0, 0);
            m = makeMaterial(lam);
            m.emissive = true;
            m.emission = tex ? tex->mean() : params_.room_albedo;
            m.emission_tex = tex;
        } else {
            lam.albedo = Vec3d(params_.room_albedo);
            m = makeMaterial(lam);
            m.texture = tex;
        }
        const int mi = addMaterial(m);
        g.prim_material.push_back(mi);
        g.prim_material.push_back(mi);
    }
    g.pos.push_back(0.f);  // Embree reads vertices with 16-byte loads
    geoms_.push_back(std::move(g));
}

namespace {

Vec3f aiColor(const aiMaterial* m, const char* key, unsigned type, unsigned idx, const Vec3f& def,
              bool* found = nullptr) {
    aiColor3D c;
    if (m->Get(key, type, idx, c) == AI_SUCCESS) {
        if (found) *found = true;
        return Vec3f(c.r, c.g, c.b);
    }
    if (found) *found = false;
    return def;
}
float aiFloat(const aiMaterial* m, const char* key, unsigned type, unsigned idx, float def) {
    float v;
    return m->Get(key, type, idx, v) == AI_SUCCESS ? v : def;
}
float maxComp(const Vec3f& v) {
    return std::max(v[0], std::max(v[1], v[2]));
}

}  // namespace

void RenderSceneImpl::addMesh(const SceneObject& o, GeometryKind kind, int index,
                              const std::string& field) {
    if (!std::filesystem::exists(o.mesh))
        CV_Error(Error::StsObjectNotFound, field + ".mesh: file '" + o.mesh + "' does not exist");
    Assimp::Importer importer;
    importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                                aiPrimitiveType_POINT | aiPrimitiveType_LINE);
    const aiScene* sc =
        importer.ReadFile(o.mesh, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                      aiProcess_PreTransformVertices | aiProcess_SortByPType);
    if (!sc || !sc->mRootNode)
        CV_Error(Error::StsParseError,
                 field + ".mesh: cannot load '" + o.mesh + "': " + importer.GetErrorString());

    const Matx44d& W = o.world_from_object;
    Matx33d A;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            A(r, c) = W(r, c);
    const double det = determinant(A);
    if (!(std::abs(det) > 1e-12) || !std::isfinite(det))
        CV_Error(Error::StsBadArg, field + ".world_from_object: not invertible");
    if (std::abs(W(3, 0)) + std::abs(W(3, 1)) + std::abs(W(3, 2)) > 1e-9 ||
        std::abs(W(3, 3) - 1) > 1e-9)
        CV_Error(Error::StsBadArg, field + ".world_from_object: last row must be [0 0 0 1]");
    const Matx33d Ninv = A.inv().t();
    const bool flip = det < 0;
    const std::string folder = parentFolder(o.mesh);

    // Materials of the file (or the scene's override), made once.
    std::vector<int> mat_of(sc->mNumMaterials, -1);
    int override_mat = -1;
    if (o.has_material) override_mat = addMaterial(makeMaterial(o.material));
    std::map<std::string, Ptr<Texture>> textures;
    auto fileMaterial = [&](unsigned mi) -> int {
        if (mat_of[mi] >= 0) return mat_of[mi];
        const aiMaterial* am = sc->mMaterials[mi];
        const Vec3f kd = aiColor(am, AI_MATKEY_COLOR_DIFFUSE, Vec3f(0.6f, 0.6f, 0.6f));
        const Vec3f ks = aiColor(am, AI_MATKEY_COLOR_SPECULAR, Vec3f(0, 0, 0));
        const Vec3f ke = aiColor(am, AI_MATKEY_COLOR_EMISSIVE, Vec3f(0, 0, 0));
        bool has_tf = false;
        const Vec3f tf = aiColor(am, AI_MATKEY_COLOR_TRANSPARENT, Vec3f(1, 1, 1), &has_tf);
        const float ns = aiFloat(am, AI_MATKEY_SHININESS, 0.f);
        const float ni = aiFloat(am, AI_MATKEY_REFRACTI, 1.f);
        const float d = aiFloat(am, AI_MATKEY_OPACITY, 1.f);
        Material m;
        if (d < 1.f) {
            m.type = Material::DIELECTRIC;
            m.ior = ni > 1.f ? ni : 1.5;
            m.roughness = 0;
            Vec3f t = tf;
            if (maxComp(t) <= 0.f) t = Vec3f(1, 1, 1);
            for (int c = 0; c < 3; ++c)
                m.absorption[c] = -std::log(std::min(std::max(t[c], 1e-4f), 1.f));
        } else if (maxComp(ks) > 0.f && ns > 0.f) {
            m.type = Material::PHONG;
            m.kd = Vec3d(kd);
            m.ks = Vec3d(ks);
            m.exponent = ns;
        } else {
            m.type = Material::LAMBERTIAN;
            m.albedo = Vec3d(kd);
        }
        MaterialRec rec = makeMaterial(m);
        if (maxComp(ke) > 0.f) {
            rec.emissive = true;
            rec.emission = ke;
        }
        aiString tex_path;
        if (m.type != Material::DIELECTRIC &&
            am->GetTexture(aiTextureType_DIFFUSE, 0, &tex_path) == AI_SUCCESS &&
            tex_path.length > 0 && tex_path.C_Str()[0] != '*') {
            const std::string p = resolvePath(folder, tex_path.C_Str());
            auto it = textures.find(p);
            if (it == textures.end())
                it = textures
                         .emplace(p, Texture::load(p, Response::SRGB, Texture::WRAP_REPEAT,
                                                   field + ".mesh (map_Kd)"))
                         .first;
            rec.texture = it->second;
        }
        return mat_of[mi] = addMaterial(rec);
    };

    size_t tris = 0;
    for (unsigned k = 0; k < sc->mNumMeshes; ++k) {
        const aiMesh* am = sc->mMeshes[k];
        if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || am->mNumFaces == 0) continue;
        GeometryRec g;
        g.kind = kind;
        g.source = index;
        g.material = override_mat >= 0 ? override_mat : fileMaterial(am->mMaterialIndex);
        g.pos.reserve(3 * am->mNumVertices + 1);
        for (unsigned v = 0; v < am->mNumVertices; ++v) {
            const aiVector3D& p = am->mVertices[v];
            const Vec3d w = A * Vec3d(p.x, p.y, p.z) + Vec3d(W(0, 3), W(1, 3), W(2, 3));
            g.pos.insert(g.pos.end(), {float(w[0]), float(w[1]), float(w[2])});
        }
        g.pos.push_back(0.f);
        if (am->HasNormals()) {
            g.nrm.resize(am->mNumVertices);
            for (unsigned v = 0; v < am->mNumVertices; ++v) {
                const aiVector3D& n = am->mNormals[v];
                Vec3d w = Ninv * Vec3d(n.x, n.y, n.z);
                const double l = norm(w);
                g.nrm[v] = l > 0 ? Vec3f(w / l) : Vec3f(0, 0, 0);
            }
        }
        if (am->HasTextureCoords(0)) {
            g.uv.resize(am->mNumVertices);
            for (unsigned v = 0; v < am->mNumVertices; ++v)
                g.uv[v] = Vec2f(am->mTextureCoords[0][v].x, am->mTextureCoords[0][v].y);
        }
        g.idx.reserve(3 * am->mNumFaces);
        for (unsigned f = 0; f < am->mNumFaces; ++f) {
            const aiFace& face = am->mFaces[f];
            if (face.mNumIndices != 3) continue;
            const Vec3f a = g.vertex(face.mIndices[0]), b = g.vertex(face.mIndices[1]),
                        c = g.vertex(face.mIndices[2]);
            if (norm((b - a).cross(c - a)) == 0.f) continue;  // degenerate: no normal
            if (flip)
                g.idx.insert(g.idx.end(), {face.mIndices[0], face.mIndices[2], face.mIndices[1]});
            else
                g.idx.insert(g.idx.end(), {face.mIndices[0], face.mIndices[1], face.mIndices[2]});
        }
        if (g.idx.empty()) continue;
        tris += g.numTriangles();
        geoms_.push_back(std::move(g));
    }
    if (tris == 0) CV_Error(Error::StsBadArg, field + ".mesh: '" + o.mesh + "' has no triangles");
}

void RenderSceneImpl::addLight(const Light& light, int index) {
    const std::string field = "lights[" + std::to_string(index) + "]";
    Light l = light;
    if (l.type == Light::POLYGON) {
        // Lift the light off the wall it may lie on by twice the ray offset there.
        const Vec3d n = l.polygonNormal();
        for (auto& c : l.corners)
            c += n * double(2.f * epsilon(Vec3f(c)));
    }
    const int ei = (int)emitters_.size();
    emitters_.push_back(Emitter::create(l, field));
    if (emitters_.back()->isInfinite()) infinite_.push_back(ei);
    if (l.type != Light::POLYGON) return;

    GeometryRec g;
    g.kind = GeometryKind::LIGHT;
    g.source = index;
    g.light = ei;
    for (const auto& c : l.corners)
        g.pos.insert(g.pos.end(), {float(c[0]), float(c[1]), float(c[2])});
    g.pos.push_back(0.f);
    for (uint32_t i = 1; i + 1 < l.corners.size(); ++i) {
        const Vec3f a = g.vertex(0), b = g.vertex(i), c = g.vertex(i + 1);
        if (norm((b - a).cross(c - a)) == 0.f) continue;
        g.idx.insert(g.idx.end(), {0u, i, i + 1});
    }
    Material black;
    black.type = Material::LAMBERTIAN;
    black.albedo = Vec3d(0, 0, 0);
    g.material = addMaterial(makeMaterial(black));
    if (!g.idx.empty()) geoms_.push_back(std::move(g));
}

RTCScene RenderSceneImpl::buildScene(bool with_objects, bool robust) const {
    RTCScene s = rtcNewScene(device_);
    rtcSetSceneBuildQuality(s, RTC_BUILD_QUALITY_HIGH);
    // robust: no leaks through the edges neighbouring triangles share
    rtcSetSceneFlags(s, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    for (size_t i = 0; i < geoms_.size(); ++i) {
        const GeometryRec& g = geoms_[i];
        if (!with_objects && g.kind == GeometryKind::OBJECT) continue;
        RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, g.pos.data(),
                                   0, 3 * sizeof(float), g.numVertices());
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, g.idx.data(),
                                   0, 3 * sizeof(uint32_t), g.numTriangles());
        rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
        rtcCommitGeometry(geom);
        rtcAttachGeometryByID(s, geom, (unsigned)i);
        rtcReleaseGeometry(geom);
    }
    rtcCommitScene(s);
    const RTCError err = rtcGetDeviceError(device_);
    if (err != RTC_ERROR_NONE) {
        rtcReleaseScene(s);
        CV_Error(Error::StsError, format("Embree: scene build failed (error %d)", (int)err));
    }
    return s;
}

RTCScene RenderSceneImpl::noObjectsScene() const {
    std::call_once(no_objects_once_, [this] { no_objects_ = buildScene(false, params_.robust); });
    return no_objects_;
}

namespace {

static_assert(offsetof(RTCRay, tnear) == 12 && offsetof(RTCRay, time) == 28 &&
                  offsetof(RTCRay, flags) == 44 && alignof(RTCRay) >= 16,
              "RTCRay: three 16-byte rows");

/* Fills the ray with three 16-byte stores. Embree's single-ray kernels read (org, tnear) and
(dir, time) with 16-byte loads first thing; had they been written by scalar stores (one per
field), those loads could not be forwarded from the store buffer and would wait for the
stores to retire: measured as the hottest instructions of both kernels (perf, cpu-clock). */
inline void setRay(RTCRay& r, const Vec3f& o, const Vec3f& d, float tnear, float tfar) {
#if defined(__SSE2__)
    _mm_store_ps(&r.org_x, _mm_setr_ps(o[0], o[1], o[2], tnear));
    _mm_store_ps(&r.dir_x, _mm_setr_ps(d[0], d[1], d[2], 0.f));  // time 0
    // tfar, mask (all), id 0, flags 0
    _mm_store_ps(&r.tfar,
                 _mm_move_ss(_mm_castsi128_ps(_mm_setr_epi32(0, -1, 0, 0)), _mm_set_ss(tfar)));
#else
    r.org_x = o[0], r.org_y = o[1], r.org_z = o[2], r.tnear = tnear;
    r.dir_x = d[0], r.dir_y = d[1], r.dir_z = d[2], r.time = 0.f;
    r.tfar = tfar, r.mask = 0xffffffffu, r.id = 0, r.flags = 0;
#endif
}

/** One ray's closest hit in @p scene (rtcIntersect1); true when it hit something. */
inline bool intersect1(RTCScene scene, const Vec3f& o, const Vec3f& d, float tnear, float tfar,
                       RTCRayHit& rh) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    setRay(rh.ray, o, d, tnear, tfar);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
}

}  // namespace

bool RenderSceneImpl::intersect(const Vec3f& o, const Vec3f& d, float tnear, float tfar,
                                SurfaceHit& hit, bool with_objects) const {
    RTCRayHit rh;
    const bool found = intersect1(sceneFor(with_objects), o, d, tnear, tfar, rh);
    if (found) fillHit(rh.hit.geomID, rh.hit.primID, rh.hit.u, rh.hit.v, rh.ray.tfar, hit);
    if (maybeLeak(found, tfar, d, hit))
        return intersectRobust(o, d, tnear, tfar, hit, with_objects);
    return found;
}

bool RenderSceneImpl::intersectRobust(const Vec3f& o, const Vec3f& d, float tnear, float tfar,
                                      SurfaceHit& hit, bool with_objects) const {
    const int k = with_objects ? 1 : 0;
    std::call_once(robust_once_[k], [&] { robust_[k] = buildScene(with_objects, true); });
    RTCRayHit rh;
    if (!intersect1(robust_[k], o, d, tnear, tfar, rh)) return false;
    fillHit(rh.hit.geomID, rh.hit.primID, rh.hit.u, rh.hit.v, rh.ray.tfar, hit);
    return true;
}

void RenderSceneImpl::fillHit(unsigned geom, unsigned prim, float u, float v, float t,
                              SurfaceHit& hit) const {
    const GeometryRec& g = geoms_[geom];
    const uint32_t* tri = &g.idx[3 * size_t(prim)];
    const float b1 = u, b2 = v, b0 = 1.f - b1 - b2;
    hit.t = t;
#if defined(__SSE2__)
    // The point with 4-wide loads and arithmetic (the fourth lane is the next vertex's x, or the
    // padding float after the last vertex, and is dropped): the same operations in the same
    // order per coordinate as the scalar code, so the same bits, in a third of the instructions.
    {
        const float* pos = g.pos.data();
        const __m128 p = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(_mm_loadu_ps(pos + 3 * size_t(tri[0])), _mm_set1_ps(b0)),
                       _mm_mul_ps(_mm_loadu_ps(pos + 3 * size_t(tri[1])), _mm_set1_ps(b1))),
            _mm_mul_ps(_mm_loadu_ps(pos + 3 * size_t(tri[2])), _mm_set1_ps(b2)));
        alignas(16) float pv[4];
        _mm_store_ps(pv, p);
        hit.p = Vec3f(pv[0], pv[1], pv[2]);
    }
#else
    const Vec3f v0 = g.vertex(tri[0]), v1 = g.vertex(tri[1]), v2 = g.vertex(tri[2]);
    hit.p = v0 * b0 + v1 * b1 + v2 * b2;
#endif
    const Vec3f ng = g.face_normal[prim];
    hit.ng = ng;
    if (!g.nrm.empty()) {
        Vec3f ns = g.nrm[tri[0]] * b0 + g.nrm[tri[1]] * b1 + g.nrm[tri[2]] * b2;
        const float l2 = ns.dot(ns);
        if (l2 > 1e-12f) {
            ns *= 1.f / std::sqrt(l2);
            if (ns.dot(ng) < 0.f) ns = -ns;
            hit.ns = ns;
        } else {
            hit.ns = ng;
        }
    } else {
        hit.ns = ng;
    }
    hit.uv =
        g.uv.empty() ? Vec2f(b1, b2) : g.uv[tri[0]] * b0 + g.uv[tri[1]] * b1 + g.uv[tri[2]] * b2;
    hit.geom_id = (int)geom;
    hit.prim_id = (int)prim;
    hit.kind = g.kind;
}

void RenderSceneImpl::intersect8(const Vec3f* o, const Vec3f* d, int n, SurfaceHit* hit,
                                 bool* found, bool with_objects) const {
    CV_DbgAssert(n >= 1 && n <= 8);
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    alignas(32) int valid[8];
    RTCRayHit8 rh;
    for (int k = 0; k < 8; ++k) {
        const int j = k < n ? k : 0;  // inactive lanes repeat ray 0 (not traced)
        valid[k] = k < n ? -1 : 0;
        rh.ray.org_x[k] = o[j][0];
        rh.ray.org_y[k] = o[j][1];
        rh.ray.org_z[k] = o[j][2];
        rh.ray.tnear[k] = 0.f;
        rh.ray.dir_x[k] = d[j][0];
        rh.ray.dir_y[k] = d[j][1];
        rh.ray.dir_z[k] = d[j][2];
        rh.ray.time[k] = 0.f;
        rh.ray.tfar[k] = std::numeric_limits<float>::infinity();
        rh.ray.mask[k] = 0xffffffffu;
        rh.ray.id[k] = 0;
        rh.ray.flags[k] = 0;
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, sceneFor(with_objects), &ctx, &rh);
    for (int k = 0; k < n; ++k) {
        found[k] = rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
        if (found[k])
            fillHit(rh.hit.geomID[k], rh.hit.primID[k], rh.hit.u[k], rh.hit.v[k], rh.ray.tfar[k],
                    hit[k]);
        // as intersect() does: the same bits with and without packets
        if (maybeLeak(found[k], std::numeric_limits<float>::infinity(), d[k], hit[k]))
            found[k] = intersectRobust(o[k], d[k], 0.f, std::numeric_limits<float>::infinity(),
                                       hit[k], with_objects);
    }
}

namespace {

template <int W>
struct Packet;
template <>
struct Packet<8> {
    using Ray = RTCRay8;
    static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, Ray* r) {
        rtcOccluded8(valid, s, c, r);
    }
};
template <>
struct Packet<16> {
    using Ray = RTCRay16;
    static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, Ray* r) {
        rtcOccluded16(valid, s, c, r);
    }
};

/* Occlusion of n ≤ W rays as one packet of width W. */
template <int W>
void occludedPacket(RTCScene scene, const Vec3f* o, const Vec3f* d, const float* tfar, int n,
                    bool* blocked) {
    CV_DbgAssert(n >= 1 && n <= W);
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    alignas(64) int valid[W];
    typename Packet<W>::Ray r;
    for (int k = 0; k < W; ++k) {
        const int j = k < n ? k : 0;  // inactive lanes repeat ray 0 (not traced)
        valid[k] = k < n ? -1 : 0;
        r.org_x[k] = o[j][0];
        r.org_y[k] = o[j][1];
        r.org_z[k] = o[j][2];
        r.tnear[k] = 0.f;
        r.dir_x[k] = d[j][0];
        r.dir_y[k] = d[j][1];
        r.dir_z[k] = d[j][2];
        r.time[k] = 0.f;
        r.tfar[k] = tfar[j];
        r.mask[k] = 0xffffffffu;
        r.id[k] = 0;
        r.flags[k] = 0;
    }
    Packet<W>::occluded(valid, scene, &ctx, &r);
    for (int k = 0; k < n; ++k)
        blocked[k] = r.tfar[k] < 0.f;  // Embree sets tfar to −inf on a hit
}

}  // namespace

void RenderSceneImpl::occluded8(const Vec3f* o, const Vec3f* d, const float* tfar, int n,
                                bool* blocked, bool with_objects) const {
    occludedPacket<8>(sceneFor(with_objects), o, d, tfar, n, blocked);
}

void RenderSceneImpl::occluded16(const Vec3f* o, const Vec3f* d, const float* tfar, int n,
                                 bool* blocked, bool with_objects) const {
    occludedPacket<16>(sceneFor(with_objects), o, d, tfar, n, blocked);
}

bool RenderSceneImpl::occluded(const Vec3f& o, const Vec3f& d, float tnear, float tfar,
                               bool with_objects) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r;
    setRay(r, o, d, tnear, tfar);
    rtcOccluded1(sceneFor(with_objects), &ctx, &r);
    return r.tfar < 0.f;  // Embree sets tfar to −inf on a hit
}

}  // namespace render_detail
}  // namespace vbme
}  // namespace cv
