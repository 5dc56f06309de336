// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Path tracer (NEE + MIS) and reference integrator, TBB over tiles, deterministic sampling.
#include "opencv2/vbme/render/integrator.hpp"
#include "opencv2/vbme/core/params.hpp"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "batch_simd.hpp"
#include "bsdf_models.hpp"
#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/render/camera.hpp"
#include "opencv2/vbme/render/sampler.hpp"
#include "render_scene_impl.hpp"
#include "sampling.hpp"
#include "sobol_impl.hpp"

namespace cv {
namespace vbme {

Renderer::~Renderer() = default;

Renderer::Params::Params() = default;

int Renderer::parseLightSelection(const std::string& name) {
    if (name == "uniform") return LIGHTS_UNIFORM;
    if (name == "power") return LIGHTS_POWER;
    CV_Error(Error::StsBadArg,
             "light_selection: unknown '" + name + "' (expected uniform or power)");
}

Renderer::Params Renderer::Params::fromScene(const RenderSettings& s) {
    Params p;
    p.spp = s.spp;
    p.max_depth = s.max_depth;
    p.seed = s.seed;
    return p;
}

void Renderer::Params::read(const FileNode& fn) {
    ParamsIn in(fn, "renderer parameters");
    in("spp", spp);
    in("max_depth", max_depth);
    in("seed", seed);
    in("threads", threads);
    in.choice("integrator", integrator, {{"path", (int)PATH}, {"reference", (int)REFERENCE}});
    in("with_objects", with_objects);
    if (const FileNode n = in.take("filter"); !n.empty()) filter = parseFilter((std::string)n);
    in("clamp", clamp);
    in("rr_depth", rr_depth);
    in("tile_size", tile_size);
    in("aovs", aovs);
    if (const FileNode n = in.take("light_selection"); !n.empty())
        light_selection = parseLightSelection((std::string)n);
    in("adaptive_min_spp", adaptive_min_spp);
    in("adaptive_error", adaptive_error);
    in("texture_cone", texture_cone);
    in("adaptive_roulette", adaptive_roulette);
    in("adaptive_radius", adaptive_radius);
    in("path_batch", path_batch);
    in.finish();
    check();
}

void Renderer::Params::check() const {
    const char* w = "renderer parameters";
    checkParam(spp > 0, w, "spp", spp, "> 0");
    checkParam(max_depth > 0, w, "max_depth", max_depth, "> 0");
    checkParam(threads >= 0, w, "threads", threads, ">= 0 (0: all cores)");
    checkParam(integrator == PATH || integrator == REFERENCE, w, "integrator", integrator,
               "PATH (0) or REFERENCE (1)");
    checkParam(filter == FILTER_BOX || filter == FILTER_GAUSSIAN, w, "filter", filter,
               "FILTER_BOX (0) or FILTER_GAUSSIAN (1)");
    checkParam(clamp >= 0, w, "clamp", clamp, ">= 0 (0: off)");
    checkParam(rr_depth >= 0, w, "rr_depth", rr_depth, ">= 0");
    checkParam(tile_size > 0, w, "tile_size", tile_size, "> 0 pixels");
    checkParam(light_selection == LIGHTS_UNIFORM || light_selection == LIGHTS_POWER, w,
               "light_selection", light_selection, "LIGHTS_UNIFORM (0) or LIGHTS_POWER (1)");
    checkParam(adaptive_min_spp >= 0, w, "adaptive_min_spp", adaptive_min_spp, ">= 0 (0: off)");
    checkParam(adaptive_error > 0, w, "adaptive_error", adaptive_error, "> 0");
    checkParam(texture_cone >= 0, w, "texture_cone", texture_cone, ">= 0 (0: off)");
    checkParam(adaptive_roulette >= 0 && adaptive_roulette <= 1, w, "adaptive_roulette",
               adaptive_roulette, "[0, 1]");
    checkParam(adaptive_radius >= 0, w, "adaptive_radius", adaptive_radius, ">= 0");
    checkParam(path_batch >= 0, w, "path_batch", path_batch, ">= 0 (0, 1: one path at a time)");
}

void Renderer::Params::write(FileStorage& fs) const {
    fs << "spp" << spp << "max_depth" << max_depth << "seed" << (double)seed << "threads"
       << threads;
    fs << "integrator" << (integrator == REFERENCE ? "reference" : "path");
    fs << "with_objects" << (int)with_objects;
    fs << "filter" << (filter == FILTER_GAUSSIAN ? "gaussian" : "box");
    fs << "clamp" << clamp << "rr_depth" << rr_depth << "tile_size" << tile_size << "aovs"
       << (int)aovs;
    fs << "light_selection" << (light_selection == LIGHTS_POWER ? "power" : "uniform");
    fs << "adaptive_min_spp" << adaptive_min_spp << "adaptive_error" << adaptive_error;
    fs << "texture_cone" << texture_cone << "adaptive_roulette" << adaptive_roulette
       << "adaptive_radius" << adaptive_radius << "path_batch" << path_batch;
}

namespace {

using render_detail::MaterialRec;
using render_detail::RenderSceneImpl;
using sampling::powerHeuristic;

constexpr float kInf = std::numeric_limits<float>::infinity();

inline float maxComp(const Vec3f& v) {
    return std::max(v[0], std::max(v[1], v[2]));
}
inline bool isBlack(const Vec3f& v) {
    return v[0] == 0.f && v[1] == 0.f && v[2] == 0.f;
}
inline Vec3f mul(const Vec3f& a, const Vec3f& b) {
    return Vec3f(a[0] * b[0], a[1] * b[1], a[2] * b[2]);
}

/** @p v read one float at a time. A vector written by a callee float by float (or as a float
and a pair) and read back with one wider load cannot be forwarded from the store buffer: the
load waits for the stores to retire. The empty asm statements keep the compiler from merging
the three loads. */
inline Vec3f load3(const Vec3f& v) {
    float a = v[0], b = v[1], c = v[2];
#if defined(__GNUC__) && defined(__SSE2__)
    asm("" : "+x"(a));
    asm("" : "+x"(b));
    asm("" : "+x"(c));
#endif
    return Vec3f(a, b, c);
}

/** Discrete distribution over the scene's lights for next-event estimation. */
struct LightSelector {
    std::vector<float> pmf, cdf;  // cdf has n + 1 entries
    std::vector<uint8_t> delta;   // per light: a Dirac delta (its sample() ignores u)
    int select(float u) const {
        const int n = (int)pmf.size();
        int i = int(std::upper_bound(cdf.begin() + 1, cdf.end() - 1, u) - (cdf.begin() + 1));
        return std::min(std::max(i, 0), n - 1);
    }
};

LightSelector makeSelector(const RenderSceneImpl& scene, int mode) {
    LightSelector s;
    const auto& em = scene.emitters();
    const int n = (int)em.size();
    if (n == 0) return s;
    s.pmf.assign(n, 1.f / n);
    s.delta.resize(n);
    for (int i = 0; i < n; ++i)
        s.delta[i] = em[i]->isDelta() ? 1 : 0;
    if (mode == Renderer::LIGHTS_POWER) {
        Vec3f lo, hi;
        scene.bounds(lo, hi);
        const float radius = std::max(0.5f * float(norm(hi - lo)), 1e-3f);
        std::vector<double> p(n);
        double sum = 0;
        for (int i = 0; i < n; ++i)
            sum += p[i] = std::max(0.0, (double)em[i]->power(radius));
        // 90 % by power, 10 % uniform, so that no light is starved.
        if (sum > 0)
            for (int i = 0; i < n; ++i)
                s.pmf[i] = float(0.9 * p[i] / sum + 0.1 / n);
    }
    s.cdf.assign(n + 1, 0.f);
    for (int i = 0; i < n; ++i)
        s.cdf[i + 1] = s.cdf[i] + s.pmf[i];
    for (auto& c : s.cdf)
        c /= s.cdf[n];
    s.cdf[n] = 1.f;
    return s;
}

/** What a path reports besides its radiance. */
struct PathInfo {
    Vec3f albedo, normal;
    bool touched_object = false;  // a vertex on an object, or a shadow ray blocked by one
    bool sees_object = false;     // the camera ray's first hit is an object
    bool forked = false;          // the fork state (differential rendering) was recorded
    int64 rays = 0;
};

/** The camera ray's closest hit, traced ahead in a packet with its pixel's other samples. */
struct CameraHit {
    SurfaceHit hit;
    bool found = false;
};

/** The state of a path at the start of a vertex: everything trace() needs to resume it. */
struct PathState {
    Vec3f L = Vec3f(0, 0, 0), beta = Vec3f(1, 1, 1);
    float prev_pdf = 0.f;
    bool prev_delta = true;  // the camera ray counts as specular: no MIS on what it sees
    Vec3f prev_p, o, d;      // previous vertex; the ray about to be traced
    int depth = 0;           // index of the vertex the ray is looking for
    // Ray cone @cite Amanatides1984: width at o and spread angle (radians); `filtered`: a
    // non-specular bounce happened, so texture lookups are filtered over the cone.
    float cone_width = 0.f, cone_spread = 0.f;
    bool filtered = false;
    static PathState start(const Vec3f& o, const Vec3f& d, float pixel_spread = 0.f) {
        PathState s;
        s.prev_p = s.o = o;
        s.d = d;
        s.cone_spread = pixel_spread;
        return s;
    }
};

/** The sampler of a path batch: PixelSampler's draws with each lane's bit-reversed sample index
(PixelSampler::get2D(dim, rindex)), the pixel's scramble seeds hashed once and kept. */
using BatchSampler = PixelSampler;

/** One path of a batch (RendererImpl::traceBatch): its state, and what one stage of a vertex
hands the next. */
struct Lane {
    PathState s;
    PathInfo info;
    uint32_t rindex = 0;  // bit-reversed sample index
    SurfaceHit hit;
    bool found = false;
    // shading → continuation
    const Bsdf* bsdf = nullptr;
    bool lambertian = false;  // MaterialRec::lambertian: the vector stage samples it
    sampling::Frame frame;
    Vec3f wo, diffuse;
    float eps = 0.f, cone_width = 0.f;
    BsdfSample bs;
    bool sampled = false, last = false;
    float u_lobe = 0.f;  // the lobe's number (vector stage: the BSDF sampled after the light)
    // next-event estimation: the shadow ray and what its contribution needs
    bool shadow = false, blocked = false;
    int li = 0;
    Vec3f so, wi_local, f;
    float tfar = 0.f;
    EmitterSample es;
};

/** The most paths RendererImpl::traceBatch advances together. */
constexpr int kMaxBatch = 64;
static_assert(kMaxBatch % batch_simd::kWidth == 0, "whole groups of vector lanes");

class RendererImpl : public Renderer {
public:
    explicit RendererImpl(const Params& p) { setParams(p); }
    const Params& getParams() const override { return p_; }
    void setParams(const Params& p) override {
        p.check();
        p_ = p;
    }
    RenderStats render(const RenderScene& scene, const Camera& camera, RenderImages& out,
                       Progress* progress) const override;
    RenderStats renderDifferential(const RenderScene& scene, const Camera& camera,
                                   RenderImages& with_objects, RenderImages& without_objects,
                                   Progress* progress) const override;
    Vec3f radiance(const RenderScene& scene, const Vec3f& o, const Vec3f& d, const Point& pixel,
                   uint32_t index) const override {
        PathInfo info;
        const SobolSampler sampler(p_.seed);
        const RenderSceneImpl& rs = impl(scene);
        const LightSelector sel = makeSelector(rs, p_.light_selection);
        PixelSampler ps(sampler.pixelKey(pixel));
        ps.setIndex(index);
        return trace(rs, sel, ps, PathState::start(o, d), p_.with_objects,
                     p_.aovs && p_.with_objects && rs.hasObjects(), info, nullptr);
    }

private:
    static const RenderSceneImpl& impl(const RenderScene& s) {
        const auto* r = dynamic_cast<const RenderSceneImpl*>(&s);
        CV_Assert(r && "Renderer: the scene must come from RenderScene::create");
        return *r;
    }
    /* Traces the path from state @p s (with or without the objects). @p track_objects: shadow
    rays are closest-hit rays so that a blocking object is noticed. @p fork (needs
    track_objects): receives the state at the start of the first vertex where the path
    interacts with an object (info.forked is then set) — resuming it without the objects gives
    the path of the render without them, sample for sample. */
    Vec3f trace(const RenderSceneImpl& scene, const LightSelector& lights, PixelSampler& sampler,
                PathState s, bool with_objects, bool track_objects, PathInfo& info, PathState* fork,
                const CameraHit* camera_hit = nullptr) const;
    /* Traces the paths of lanes[0 … n) (n ≤ kMaxBatch, all at depth 0, from lanes[k].s and
    lanes[k].rindex) together, stage by stage: closest hits of all live paths, then the shading
    of all, then their shadow rays, then their continuation. Every path does what trace() does
    for it (no fork), in the same order: the same bits. @p camera_hits: the
    camera rays' hits, traced ahead (or null). @p track_objects: as in trace() (shadow rays
    are closest-hit rays, one at a time). Leaves each radiance in lanes[k].s.L (0 if not
    finite, as trace() returns). */
    void traceBatch(const RenderSceneImpl& scene, const LightSelector& lights,
                    BatchSampler& sampler, Lane* lanes, int n, bool with_objects,
                    bool track_objects, const CameraHit* camera_hits) const;
    RenderStats renderImpl(const RenderScene& scene, const Camera& camera, RenderImages& out,
                           RenderImages* without, Progress* progress) const;
    Params p_;
};

/** The path escaped: adds what the infinite emitters send back along @p s.d to @p s.L,
weighted against the last vertex's light sample when @p nee (trace() and traceBatch()). */
inline void addEscaped(const RenderSceneImpl& scene, const LightSelector& lights, bool nee,
                       PathState& s) {
    const auto& emitters = scene.emitters();
    for (int li : scene.infiniteEmitters()) {
        const Emitter& e = *emitters[li];
        const Vec3f Le = e.radianceEscaped(s.d);
        if (isBlack(Le)) continue;
        float w = 1.f;
        if (nee && !s.prev_delta)
            w = powerHeuristic(1, s.prev_pdf, 1, lights.pmf[li] * e.pdfEscaped(s.d));
        s.L += mul(s.beta, Le) * w;
    }
}

/** At @p hit of material @p m: Beer–Lambert absorption when the ray leaves a dielectric through
this face, then the emission met (a light's, weighted against the last vertex's light sample
when @p nee, and an emissive material's) added to @p s.L (trace() and traceBatch()). */
inline void absorbAndAddEmitted(const RenderSceneImpl& scene, const LightSelector& lights,
                                const MaterialRec& m, const SurfaceHit& hit, bool nee,
                                PathState& s) {
    const float cos_out = s.d.dot(hit.ng);  // > 0: the ray leaves the mesh through this face
    if (m.transmission && cos_out > 0.f && !isBlack(m.absorption)) {
        for (int c = 0; c < 3; ++c)
            s.beta[c] *= std::exp(-m.absorption[c] * hit.t);
    }
    if (hit.kind == GeometryKind::LIGHT) {
        const int li = scene.lightOf(hit.geom_id);
        const Emitter& e = *scene.emitters()[li];
        const Vec3f Le = e.radianceHit(s.d);
        if (!isBlack(Le)) {
            float w = 1.f;
            if (nee && !s.prev_delta)
                w = powerHeuristic(1, s.prev_pdf, 1,
                                   lights.pmf[li] * e.pdfHit(s.prev_p, s.d, hit.t));
            s.L += mul(s.beta, Le) * w;
        }
    }
    if (m.emissive) s.L += mul(s.beta, m.emissionAt(hit.uv));
}

Vec3f RendererImpl::trace(const RenderSceneImpl& scene, const LightSelector& lights,
                          PixelSampler& sampler, PathState s, bool with_objects, bool track_objects,
                          PathInfo& info, PathState* fork, const CameraHit* camera_hit) const {
    const bool nee = p_.integrator == PATH;
    const auto& emitters = scene.emitters();
    const int n_lights = (int)emitters.size();

    Vec3f &L = s.L, &beta = s.beta, &prev_p = s.prev_p, &o = s.o, &d = s.d;
    float& prev_pdf = s.prev_pdf;
    bool& prev_delta = s.prev_delta;
    SurfaceHit hit;
    PathState at_vertex;  // s at the start of this vertex (only kept while a fork may come)

    for (;; ++s.depth) {
        const int depth = s.depth;
        if (fork && !info.forked) at_vertex = s;
        ++info.rays;
        bool found;
        if (camera_hit) {  // the first ray, already traced in a packet
            found = camera_hit->found;
            if (found) hit = camera_hit->hit;
            camera_hit = nullptr;
        } else {
            found = scene.intersect(o, d, 0.f, kInf, hit, with_objects);
        }
        if (!found) {
            addEscaped(scene, lights, nee, s);
            break;
        }
        if (hit.kind == GeometryKind::OBJECT) {
            info.touched_object = true;
            if (fork && !info.forked) {
                *fork = at_vertex;
                info.forked = true;
            }
            if (depth == 0) info.sees_object = true;
        }
        const MaterialRec& m = scene.material(hit.geom_id, hit.prim_id);
        const float cone_width = s.cone_width + s.cone_spread * hit.t;
        const Vec3f diffuse =
            s.filtered && m.texture
                ? m.diffuseFiltered(hit.uv,
                                    cone_width * scene.uvPerLength(hit.geom_id, hit.prim_id))
                : m.diffuseAt(hit.uv);
        if (depth == 0) {
            info.albedo = diffuse;
            info.normal = hit.ns;
        }
        absorbAndAddEmitted(scene, lights, m, hit, nee, s);
        if (depth >= p_.max_depth) break;

        const float eps = RenderSceneImpl::epsilon(hit.p);
        const sampling::Frame frame(hit.ns);
        const Vec3f wo = frame.toLocal(-d);
        const Bsdf& bsdf = *m.bsdf;

        // Next-event estimation: one light, chosen uniformly.
        // Light choice and BSDF lobe share one stratified pair (dimensions 4 and 5 of the vertex).
        static_assert(
            PathDims::kBsdfLobe == PathDims::kLightSelect + 1 && PathDims::kLightSelect % 2 == 0,
            "light choice and lobe form one pair");
        // Numbers nothing would read are not drawn (the choice among one light, the lobe of a
        // one-lobe BSDF, the point on a delta light): the others stay the same.
        const bool nee_here = nee && n_lights > 0 && !m.is_delta;
        const Vec2f u_sel_lobe = (nee_here && n_lights > 1) || !m.single_lobe
                                     ? sampler.get2D(PathDims::dim(depth, PathDims::kLightSelect))
                                     : Vec2f(0.f, 0.f);
        // The last vertex: when nothing can be hit or escaped to that emits, the ray the BSDF
        // would sample adds nothing (unless what it meets must be known: track_objects).
        const bool last =
            depth + 1 >= p_.max_depth && !track_objects && nee && !scene.hasHittableEmission();
        // BSDF sampling, ahead of the shadow ray: neither depends on the other, so the core
        // overlaps the sampler's and the BSDF's dependency chain with the shadow ray's traversal
        // (the same numbers as drawn after it).
        BsdfSample bs;
        bool sampled = false;
        if (!last) {
            const Vec2f ud = sampler.get2D(PathDims::dim(depth, PathDims::kBsdfDir));
            sampled = m.lambertian ? bsdf_detail::lambertianSample(wo, ud, diffuse, bs)
                                   : bsdf.sample(wo, ud, u_sel_lobe[1], diffuse, bs);
        }
        if (nee_here) {
            const float ul = u_sel_lobe[0];
            const int li = n_lights > 1 ? lights.select(ul) : 0;
            const Vec2f u = lights.delta[li]
                                ? Vec2f(0.f, 0.f)
                                : sampler.get2D(PathDims::dim(depth, PathDims::kLightPos));
            EmitterSample es;
            if (emitters[li]->sample(hit.p, u, es) && es.pdf > 0.f && !isBlack(es.L)) {
                const Vec3f wi = frame.toLocal(es.wi);
                const Vec3f f = m.lambertian ? bsdf_detail::lambertianEval(wo, wi, diffuse)
                                             : bsdf.eval(wo, wi, diffuse);
                if (!isBlack(f)) {
                    const float side = es.wi.dot(hit.ng) > 0.f ? 1.f : -1.f;
                    const Vec3f so = hit.p + hit.ng * (side * eps);
                    const float tfar = std::isinf(es.dist) ? kInf : es.dist * (1.f - 1e-4f) - eps;
                    ++info.rays;
                    bool blocked;
                    if (track_objects) {
                        // closest hit instead of any hit, to tell whether an object blocks
                        SurfaceHit sh;
                        blocked = tfar > 0.f && scene.intersect(so, es.wi, 0.f, tfar, sh, true);
                        if (blocked && sh.kind == GeometryKind::OBJECT) {
                            info.touched_object = true;
                            if (fork && !info.forked) {
                                *fork = at_vertex;
                                info.forked = true;
                            }
                        }
                    } else {
                        blocked = tfar > 0.f && scene.occluded(so, es.wi, 0.f, tfar, with_objects);
                    }
                    if (tfar > 0.f && !blocked) {
                        const float light_pdf = lights.pmf[li] * es.pdf;
                        const float w =
                            es.delta ? 1.f
                                     : powerHeuristic(1, light_pdf, 1, bsdf.pdf(wo, wi, diffuse));
                        L += mul(beta, mul(f, es.L)) * (std::abs(wi[2]) * w / light_pdf);
                    }
                }
            }
        }

        if (last || !sampled) break;
        if (isBlack(bs.weight) || !(bs.pdf > 0.f)) break;
        beta = mul(beta, bs.weight);
        Vec3f wi = frame.toWorld(bs.wi);
        wi *= 1.f / std::sqrt(wi.dot(wi));
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        prev_p = hit.p;
        s.cone_width = cone_width;
        if (!bs.delta && p_.texture_cone > 0.f) {
            s.cone_spread = std::max(s.cone_spread, p_.texture_cone);
            s.filtered = true;
        }
        const float side = wi.dot(hit.ng) > 0.f ? 1.f : -1.f;
        o = hit.p + hit.ng * (side * eps);
        d = wi;

        if (depth + 1 >= p_.rr_depth) {
            const float q = std::max(0.05f, 1.f - maxComp(beta));
            const float ur = sampler.get1D(PathDims::dim(depth, PathDims::kRoulette));
            if (ur < q) break;
            beta *= 1.f / (1.f - q);
        }
    }
    if (!(std::isfinite(L[0]) && std::isfinite(L[1]) && std::isfinite(L[2]))) return Vec3f(0, 0, 0);
    return L;
}

void RendererImpl::traceBatch(const RenderSceneImpl& scene, const LightSelector& lights,
                              BatchSampler& sampler, Lane* lanes, int n, bool with_objects,
                              bool track_objects, const CameraHit* camera_hits) const {
    CV_DbgAssert(n >= 0 && n <= kMaxBatch);
    const bool nee = p_.integrator == PATH;
    const auto& emitters = scene.emitters();
    const int n_lights = (int)emitters.size();
    const bool hittable_emission = scene.hasHittableEmission();
    // The vector stage where the processor has it (and Params::batch_simd asks for it).
    const bool simd = p_.batch_simd && batch_simd::available();
    int live[kMaxBatch], shaded[kMaxBatch];
    int n_live = n;
    for (int k = 0; k < n; ++k)
        live[k] = k;

    while (n_live > 0) {
        // 1. The closest hit of every live path.
        for (int j = 0; j < n_live; ++j) {
            Lane& l = lanes[live[j]];
            ++l.info.rays;
            if (camera_hits && l.s.depth == 0) {  // the camera ray, already traced in a packet
                const CameraHit& ch = camera_hits[live[j]];
                l.found = ch.found;
                if (l.found) l.hit = ch.hit;
            } else {
                l.found = scene.intersect(l.s.o, l.s.d, 0.f, kInf, l.hit, with_objects);
            }
        }
        // 2. Shading: emission met, then the BSDF sample and the light sample with its shadow
        // ray (as trace() does up to its shadow ray).
        int n_shaded = 0;
        for (int j = 0; j < n_live; ++j) {
            Lane& l = lanes[live[j]];
            PathState& s = l.s;
            const int depth = s.depth;
            const Vec3f& d = s.d;
            const SurfaceHit& hit = l.hit;
            if (!l.found) {
                addEscaped(scene, lights, nee, s);
                continue;  // the path ends
            }
            if (hit.kind == GeometryKind::OBJECT) {
                l.info.touched_object = true;
                if (depth == 0) l.info.sees_object = true;
            }
            const MaterialRec& m = scene.material(hit.geom_id, hit.prim_id);
            l.cone_width = s.cone_width + s.cone_spread * hit.t;
            l.diffuse =
                s.filtered && m.texture
                    ? m.diffuseFiltered(hit.uv,
                                        l.cone_width * scene.uvPerLength(hit.geom_id, hit.prim_id))
                    : m.diffuseAt(hit.uv);
            if (depth == 0) {
                l.info.albedo = l.diffuse;
                l.info.normal = hit.ns;
            }
            absorbAndAddEmitted(scene, lights, m, hit, nee, s);
            if (depth >= p_.max_depth) continue;  // the path ends

            l.eps = RenderSceneImpl::epsilon(hit.p);
            l.frame = sampling::Frame(hit.ns);
            l.wo = l.frame.toLocal(-d);
            l.bsdf = m.bsdf.get();
            l.lambertian = m.lambertian;
            const bool nee_here = nee && n_lights > 0 && !m.is_delta;
            const Vec2f u_sel_lobe =
                (nee_here && n_lights > 1) || !m.single_lobe
                    ? sampler.get2D(PathDims::dim(depth, PathDims::kLightSelect), l.rindex)
                    : Vec2f(0.f, 0.f);
            l.last = depth + 1 >= p_.max_depth && !track_objects && nee && !hittable_emission;
            l.sampled = false;
            l.u_lobe = u_sel_lobe[1];
            if (!l.last && !simd) {
                const Vec2f ud = sampler.get2D(PathDims::dim(depth, PathDims::kBsdfDir), l.rindex);
                l.sampled = m.lambertian  // inline, no virtual call (same bits)
                                ? bsdf_detail::lambertianSample(l.wo, ud, l.diffuse, l.bs)
                                : l.bsdf->sample(l.wo, ud, u_sel_lobe[1], l.diffuse, l.bs);
            }
            l.shadow = false;
            if (nee_here) {
                const float ul = u_sel_lobe[0];
                const int li = n_lights > 1 ? lights.select(ul) : 0;
                const Vec2f u =
                    lights.delta[li]
                        ? Vec2f(0.f, 0.f)
                        : sampler.get2D(PathDims::dim(depth, PathDims::kLightPos), l.rindex);
                EmitterSample& es = l.es;
                if (emitters[li]->sample(hit.p, u, es) && es.pdf > 0.f && !isBlack(es.L)) {
                    l.wi_local = l.frame.toLocal(load3(es.wi));
                    l.f = m.lambertian ? bsdf_detail::lambertianEval(l.wo, l.wi_local, l.diffuse)
                                       : l.bsdf->eval(l.wo, l.wi_local, l.diffuse);
                    if (!isBlack(l.f)) {
                        const float side = es.wi.dot(hit.ng) > 0.f ? 1.f : -1.f;
                        l.so = hit.p + hit.ng * (side * l.eps);
                        l.tfar = std::isinf(es.dist) ? kInf : es.dist * (1.f - 1e-4f) - l.eps;
                        ++l.info.rays;
                        l.li = li;
                        l.shadow = true;
                    }
                }
            }
            shaded[n_shaded++] = live[j];
        }
        // 2b. Vector stage (AVX2): the BSDF samples of the shaded paths, after their light
        // samples (each path's two samples are independent: the same numbers, the same bits).
        // The Sobol draws of all lanes at once; the Lambertian lanes' cosine-hemisphere
        // directions too; other BSDFs sample one lane at a time from the drawn numbers.
        if (simd && n_shaded > 0) {
            alignas(32) uint32_t rix[kMaxBatch];
            alignas(32) float ux[kMaxBatch], uy[kMaxBatch], wx[kMaxBatch], wy[kMaxBatch],
                wz[kMaxBatch];
            int need[kMaxBatch], n_need = 0;
            for (int j = 0; j < n_shaded; ++j) {
                const Lane& l = lanes[shaded[j]];
                if (l.last) continue;
                rix[n_need] = l.rindex;
                need[n_need++] = shaded[j];
            }
            if (n_need > 0) {
                const int n_pad = (n_need + batch_simd::kWidth - 1) & ~(batch_simd::kWidth - 1);
                for (int k = n_need; k < n_pad; ++k)
                    rix[k] = 0;
                const int depth = lanes[need[0]].s.depth;  // all live paths are at one depth
                const uint32_t dim = PathDims::dim(depth, PathDims::kBsdfDir);
                batch_simd::draw2D(sobol_detail::pairSeeds(sampler.key(), dim >> 1), rix, n_pad, ux,
                                   uy);
                batch_simd::cosineHemisphere(ux, uy, n_pad, wx, wy, wz);
                for (int k = 0; k < n_need; ++k) {
                    Lane& l = lanes[need[k]];
                    if (l.lambertian) {  // with the direction computed above
                        l.sampled = bsdf_detail::lambertianFromDirection(
                            l.wo, Vec3f(wx[k], wy[k], wz[k]), l.diffuse, l.bs);
                    } else {
                        l.sampled =
                            l.bsdf->sample(l.wo, Vec2f(ux[k], uy[k]), l.u_lobe, l.diffuse, l.bs);
                    }
                }
            }
        }
        // 3. The shadow rays, in packets (rtcOccluded16 / 8): at the first vertex a pixel's
        // shadow rays start from nearly one point and go to the same light (coherent), deeper
        // ones less so. A packet finds the same hits as one ray at a time (tested).
        if (track_objects) {
            // closest hits instead of any hits, to tell whether an object blocks (as trace())
            for (int j = 0; j < n_shaded; ++j) {
                Lane& l = lanes[shaded[j]];
                if (!l.shadow) continue;
                SurfaceHit sh;
                l.blocked = l.tfar > 0.f && scene.intersect(l.so, l.es.wi, 0.f, l.tfar, sh, true);
                if (l.blocked && sh.kind == GeometryKind::OBJECT) l.info.touched_object = true;
            }
        } else {
            const int width = lanes[live[0]].s.depth == 0 ? 16 : 8;
            int idx[16], m = 0;
            Vec3f po[16], pd[16];
            float pt[16];
            bool pb[16];
            auto flush = [&] {
                if (width == 16)
                    scene.occluded16(po, pd, pt, m, pb, with_objects);
                else
                    scene.occluded8(po, pd, pt, m, pb, with_objects);
                for (int k = 0; k < m; ++k)
                    lanes[idx[k]].blocked = pb[k];
                m = 0;
            };
            for (int j = 0; j < n_shaded; ++j) {
                Lane& l = lanes[shaded[j]];
                if (!l.shadow) continue;
                if (!(l.tfar > 0.f)) {
                    l.blocked = false;
                    continue;
                }
                idx[m] = shaded[j];
                po[m] = l.so;
                pd[m] = l.es.wi;
                pt[m] = l.tfar;
                if (++m == width) flush();
            }
            if (m) flush();
        }
        // 4. The light's contribution, then the next ray (or the end of the path).
        n_live = 0;
        for (int j = 0; j < n_shaded; ++j) {
            Lane& l = lanes[shaded[j]];
            PathState& s = l.s;
            const int depth = s.depth;
            Vec3f& beta = s.beta;
            const SurfaceHit& hit = l.hit;
            if (l.shadow && l.tfar > 0.f && !l.blocked) {
                const EmitterSample& es = l.es;
                const float light_pdf = lights.pmf[l.li] * es.pdf;
                const float w = es.delta ? 1.f
                                         : powerHeuristic(1, light_pdf, 1,
                                                          l.bsdf->pdf(l.wo, l.wi_local, l.diffuse));
                s.L += mul(beta, mul(l.f, es.L)) * (std::abs(l.wi_local[2]) * w / light_pdf);
            }
            const BsdfSample& bs = l.bs;
            if (l.last || !l.sampled) continue;
            if (isBlack(bs.weight) || !(bs.pdf > 0.f)) continue;
            beta = mul(beta, bs.weight);
            Vec3f wi = l.frame.toWorld(bs.wi);
            wi *= 1.f / std::sqrt(wi.dot(wi));
            s.prev_pdf = bs.pdf;
            s.prev_delta = bs.delta;
            s.prev_p = hit.p;
            s.cone_width = l.cone_width;
            if (!bs.delta && p_.texture_cone > 0.f) {
                s.cone_spread = std::max(s.cone_spread, p_.texture_cone);
                s.filtered = true;
            }
            const float side = wi.dot(hit.ng) > 0.f ? 1.f : -1.f;
            s.o = hit.p + hit.ng * (side * l.eps);
            s.d = wi;
            if (depth + 1 >= p_.rr_depth) {
                const float q = std::max(0.05f, 1.f - maxComp(beta));
                const float ur = sampler.get1D(PathDims::dim(depth, PathDims::kRoulette), l.rindex);
                if (ur < q) continue;
                beta *= 1.f / (1.f - q);
            }
            ++s.depth;
            live[n_live++] = shaded[j];
        }
    }
    for (int k = 0; k < n; ++k) {
        const Vec3f& L = lanes[k].s.L;
        if (!(std::isfinite(L[0]) && std::isfinite(L[1]) && std::isfinite(L[2])))
            lanes[k].s.L = Vec3f(0, 0, 0);
    }
}

RenderStats RendererImpl::render(const RenderScene& scene_in, const Camera& camera,
                                 RenderImages& out, Progress* progress) const {
    return renderImpl(scene_in, camera, out, nullptr, progress);
}

RenderStats RendererImpl::renderDifferential(const RenderScene& scene, const Camera& camera,
                                             RenderImages& with_objects,
                                             RenderImages& without_objects,
                                             Progress* progress) const {
    CV_Assert(&with_objects != &without_objects &&
              "Renderer::renderDifferential: the two outputs must be different objects");
    return renderImpl(scene, camera, with_objects, &without_objects, progress);
}

RenderStats RendererImpl::renderImpl(const RenderScene& scene_in, const Camera& camera,
                                     RenderImages& out, RenderImages* without,
                                     Progress* progress) const {
    ScopedTimer timer;
    const RenderSceneImpl& scene = impl(scene_in);
    const PinholeCamera cam(camera);
    const Size sz = camera.image_size;
    const SobolSampler sampler(p_.seed);
    const LightSelector lights = makeSelector(scene, p_.light_selection);
    const int ts = p_.tile_size;
    const int tiles_x = (sz.width + ts - 1) / ts, tiles_y = (sz.height + ts - 1) / ts;

    out.color.create(sz, CV_32FC3);
    if (p_.aovs) {
        out.albedo.create(sz, CV_32FC3);
        out.normal.create(sz, CV_32FC3);
        out.object.create(sz, CV_32FC1);
        out.mask.create(sz, CV_32FC1);
    } else {
        out.albedo.release();
        out.normal.release();
        out.object.release();
        out.mask.release();
    }
    // Differential: trace with the objects; a path that interacts with one is resumed without
    // them from the vertex where it first did (the fork), otherwise it counts for both.
    const bool differential = without != nullptr;
    const bool with_objects = differential || p_.with_objects;
    const bool track_objects = scene.hasObjects() && with_objects && (differential || p_.aovs);
    if (differential) {
        without->color.create(sz, CV_32FC3);
        without->albedo.release();
        without->normal.release();
        without->object.release();
        without->mask.release();
    }
    std::atomic<int64> rays{0}, paths{0}, untouched{0};
    const uint32_t spp = (uint32_t)p_.spp;
    const bool adaptive = differential && p_.adaptive_min_spp > 0;
    const uint32_t n_min = adaptive ? std::min(spp, (uint32_t)p_.adaptive_min_spp) : spp;
    if (adaptive)
        out.samples.create(sz, CV_32FC1);
    else
        out.samples.release();
    // Half-width of the 95 % interval of a pixel's composite, in 8-bit display values: the
    // standard error of the mean of Y mapped through the camera's response at the level.
    const Response response = camera.response;
    // Spread angle of a camera ray's cone: one pixel at the image centre.
    const float pixel_spread = float(1.0 / std::max(camera.K(0, 0), camera.K(1, 1)));
    auto pixelError = [response](const double* ys, const double* yq, const double* lev,
                                 uint32_t m) {
        double err = 0;
        for (int k = 0; k < 3; ++k) {
            const double mean = ys[k] / m;
            const double var = std::max(0.0, (yq[k] - ys[k] * mean) / (m - 1));
            const double h = 1.96 * std::sqrt(var / m);
            const double level = std::max(0.0, lev[k] / m);
            const double hi = encode(float(level + h), response);
            const double lo = encode(float(std::max(0.0, level - h)), response);
            err = std::max(err, 0.5 * (hi - lo) * 255.0);
        }
        return err;
    };

    // Adaptive sampling runs in two phases: every pixel's minimum (kept in `pilot`), then,
    // once the whole image's minimum is known, the rest; an untouched pixel goes on when a
    // pixel within adaptive_radius was touched (a function of the minimum samples only, so
    // still the same for any number of threads).
    struct Pilot {
        double c[3], a[3], n[3], cn[3], ys[3], yq[3], lev[3], dp[3], obj, msk;
    };
    std::vector<Pilot> pilot(adaptive ? size_t(sz.area()) : 0);
    std::vector<uint8_t> near_touched(adaptive ? size_t(sz.area()) : 0, 0);
    int phase = adaptive ? 0 : 1;
    // Paths of a pixel in batches (traceBatch), except for differential renders (forks).
    const bool batched = p_.path_batch > 1 && !differential;
    const uint32_t batch = (uint32_t)std::min(p_.path_batch, kMaxBatch);
    const bool simd_film = batched && p_.batch_simd && batch_simd::available();
    auto renderTile = [&](int tile) {
        const int x0 = (tile % tiles_x) * ts, y0 = (tile / tiles_x) * ts;
        std::vector<Lane> lanes(batched ? batch : 0);
        std::vector<CameraHit> batch_hits(batched ? batch : 0);
        // a batch's film points and camera ray directions (once per tile: arrays of Vec3f and
        // Point2f are zeroed by their constructors)
        std::vector<Point2f> batch_film(batched ? batch : 0);
        std::vector<Vec3f> batch_dirs(batched ? batch : 0);
        // Camera rays in packets of up to 8 samples of a pixel (they start at one point and fan
        // out over the pixel: coherent), traced ahead of their paths (constructed once per
        // tile, not zeroed again for every pixel).
        constexpr uint32_t kPacket = 8;
        Vec3f cam_o[kPacket], cam_d[kPacket];
        SurfaceHit cam_hit[kPacket];
        bool cam_found[kPacket];
        const int x1 = std::min(x0 + ts, sz.width), y1 = std::min(y0 + ts, sz.height);
        int64 tile_rays = 0, tile_paths = 0, tile_untouched = 0;
        for (int y = y0; y < y1; ++y) {
            for (int x = x0; x < x1; ++x) {
                const uint64 px = sampler.pixelKey(Point(x, y));
                PixelSampler ps(px);
                double c[3] = {0, 0, 0}, a[3] = {0, 0, 0}, n[3] = {0, 0, 0}, obj = 0, msk = 0;
                double cn[3] = {0, 0, 0};  // without the objects (differential)
                // Adaptive sampling: the composite's per-sample value Y (L where the camera
                // ray sees an object, L − Ln elsewhere) and its display level.
                double ys[3] = {0, 0, 0}, yq[3] = {0, 0, 0}, lev[3] = {0, 0, 0};
                double dp[3] = {0, 0, 0}, dl[3] = {0, 0, 0};  // Σ(L − Ln): minimum, later
                uint32_t taken = 0;
                uint32_t packet_begin = 0, packet_end = 0;  // of cam_o … cam_found
                // One sample's radiance (and, differential, without the objects) into the sums.
                auto accumulate = [&](Vec3f L, Vec3f Ln, const PathInfo& info) {
                    if (p_.clamp > 0.f) {
                        const float mc = maxComp(L);
                        if (mc > p_.clamp) L *= p_.clamp / mc;
                        const float mn = maxComp(Ln);
                        if (mn > p_.clamp) Ln *= p_.clamp / mn;
                    }
                    for (int k = 0; k < 3; ++k) {
                        cn[k] += Ln[k];
                        c[k] += L[k];
                        a[k] += info.albedo[k];
                        n[k] += info.normal[k];
                    }
                    if (adaptive) {
                        double* dsum = taken < n_min ? dp : dl;
                        for (int k = 0; k < 3; ++k)
                            dsum[k] += double(L[k]) - Ln[k];
                        for (int k = 0; k < 3; ++k) {
                            const double yv = info.sees_object ? L[k] : double(L[k]) - Ln[k];
                            ys[k] += yv;
                            yq[k] += yv * yv;
                            lev[k] += info.sees_object ? L[k] : Ln[k];
                        }
                    }
                    obj += info.touched_object ? 1.0 : 0.0;
                    msk += info.sees_object ? 1.0 : 0.0;
                    tile_rays += info.rays;
                };
                auto takeSamples = [&](uint32_t upto) {
                    if (batched) {
                        BatchSampler bsamp(px);
                        while (taken < upto) {
                            const int nb = (int)std::min<uint32_t>(upto - taken, batch);
                            // the film's numbers of all lanes at once (vector code)
                            alignas(32) uint32_t rix[kMaxBatch];
                            alignas(32) float fx[kMaxBatch], fy[kMaxBatch];
                            if (simd_film) {
                                const int n_pad =
                                    (nb + batch_simd::kWidth - 1) & ~(batch_simd::kWidth - 1);
                                for (int k = 0; k < n_pad; ++k)
                                    rix[k] = BatchSampler::reversedIndex(taken + k);
                                batch_simd::draw2D(
                                    sobol_detail::pairSeeds(px, PathDims::kFilm >> 1), rix, n_pad,
                                    fx, fy);
                            }
                            // the film points first, then their rays four at a time
                            Point2f* film = batch_film.data();
                            Vec3f* dirs = batch_dirs.data();
                            for (int k = 0; k < nb; ++k) {
                                Lane& l = lanes[k];
                                l.rindex = BatchSampler::reversedIndex(taken + k);
                                const Vec2f off = filterOffset(
                                    p_.filter, simd_film ? Vec2f(fx[k], fy[k])
                                                         : bsamp.get2D(PathDims::kFilm, l.rindex));
                                film[k] = Point2f(x + off[0], y + off[1]);
                            }
                            cam.generateRays(film, nb, dirs);
                            for (int k = 0; k < nb; ++k) {
                                Lane& l = lanes[k];
                                // PathState::start(o, d, pixel_spread), field by field in
                                // place (a temporary copied over would be read back with wider
                                // loads than its stores: no store forwarding).
                                PathState& st = l.s;
                                st.o = cam.origin();
                                st.d = dirs[k];
                                st.prev_p = st.o;
                                st.L = Vec3f(0, 0, 0);
                                st.beta = Vec3f(1, 1, 1);
                                st.prev_pdf = 0.f;
                                st.prev_delta = true;
                                st.depth = 0;
                                st.cone_width = 0.f;
                                st.cone_spread = pixel_spread;
                                st.filtered = false;
                                l.info.albedo = l.info.normal = Vec3f(0, 0, 0);
                                l.info.touched_object = l.info.sees_object = l.info.forked = false;
                                l.info.rays = 0;
                            }
                            if (p_.camera_packets) {
                                // packets of up to 8 samples, from sample 0 on (as below)
                                for (int k0 = 0; k0 < nb;) {
                                    const int k1 =
                                        std::min(nb, k0 + int(kPacket - (taken + k0) % kPacket));
                                    for (int k = k0; k < k1; ++k) {
                                        cam_o[k - k0] = lanes[k].s.o;
                                        cam_d[k - k0] = lanes[k].s.d;
                                    }
                                    scene.intersect8(cam_o, cam_d, k1 - k0, cam_hit, cam_found,
                                                     with_objects);
                                    for (int k = k0; k < k1; ++k) {
                                        batch_hits[k].found = cam_found[k - k0];
                                        if (cam_found[k - k0]) batch_hits[k].hit = cam_hit[k - k0];
                                    }
                                    k0 = k1;
                                }
                            }
                            traceBatch(scene, lights, bsamp, lanes.data(), nb, with_objects,
                                       track_objects,
                                       p_.camera_packets ? batch_hits.data() : nullptr);
                            for (int k = 0; k < nb; ++k, ++taken)
                                accumulate(lanes[k].s.L, lanes[k].s.L, lanes[k].info);
                        }
                        return;
                    }
                    for (; taken < upto; ++taken) {
                        if (p_.camera_packets && taken >= packet_end) {
                            packet_begin = taken;
                            packet_end = std::min(upto, taken + kPacket);
                            Point2f film[kPacket];
                            for (uint32_t k = packet_begin; k < packet_end; ++k) {
                                ps.setIndex(k);
                                const Vec2f off =
                                    filterOffset(p_.filter, ps.get2D(PathDims::kFilm));
                                film[k - packet_begin] = Point2f(x + off[0], y + off[1]);
                                cam_o[k - packet_begin] = cam.origin();
                            }
                            cam.generateRays(film, int(packet_end - packet_begin), cam_d);
                            scene.intersect8(cam_o, cam_d, int(packet_end - packet_begin), cam_hit,
                                             cam_found, with_objects);
                        }
                        ps.setIndex(taken);
                        CameraHit ch;
                        Vec3f o, d;
                        if (p_.camera_packets) {
                            const uint32_t k = taken - packet_begin;
                            ch.found = cam_found[k];
                            if (ch.found) ch.hit = cam_hit[k];
                            o = cam_o[k];
                            d = cam_d[k];
                        } else {
                            const Vec2f off = filterOffset(p_.filter, ps.get2D(PathDims::kFilm));
                            cam.generateRay(Point2f(x + off[0], y + off[1]), o, d);
                        }
                        PathInfo info;
                        PathState fork;
                        Vec3f L =
                            trace(scene, lights, ps, PathState::start(o, d, pixel_spread),
                                  with_objects, track_objects, info, differential ? &fork : nullptr,
                                  p_.camera_packets ? &ch : nullptr);
                        Vec3f Ln = L;
                        if (info.forked) {
                            PathInfo info_n;
                            Ln = trace(scene, lights, ps, fork, false, false, info_n, nullptr);
                            tile_rays += info_n.rays;
                        }
                        accumulate(L, Ln, info);
                    }
                };
                const size_t pi = size_t(y) * sz.width + x;
                if (adaptive && phase == 1) {  // resume from the stored minimum
                    const Pilot& q = pilot[pi];
                    for (int k = 0; k < 3; ++k) {
                        c[k] = q.c[k], a[k] = q.a[k], n[k] = q.n[k], cn[k] = q.cn[k];
                        ys[k] = q.ys[k], yq[k] = q.yq[k], lev[k] = q.lev[k], dp[k] = q.dp[k];
                    }
                    obj = q.obj;
                    msk = q.msk;
                    taken = n_min;
                } else {
                    takeSamples(n_min);
                }
                if (phase == 0) {
                    Pilot& q = pilot[pi];
                    for (int k = 0; k < 3; ++k) {
                        q.c[k] = c[k], q.a[k] = a[k], q.n[k] = n[k], q.cn[k] = cn[k];
                        q.ys[k] = ys[k], q.yq[k] = yq[k], q.lev[k] = lev[k], q.dp[k] = dp[k];
                    }
                    q.obj = obj;
                    q.msk = msk;
                    continue;
                }
                double later_weight = 1.0;  // 1 / probability of taking the later samples
                if (adaptive && taken < spp) {
                    bool go = true;
                    if (obj == 0 && !near_touched[pi]) {  // no path here or near met one
                        const float u = float((px * 0x9E3779B97F4A7C15ull) >> 40) * 0x1p-24f;
                        if (u < p_.adaptive_roulette)
                            later_weight = 1.0 / p_.adaptive_roulette;
                        else
                            go = false;
                    }
                    if (go) {
                        // How many more: from the minimum's error alone (so that the later
                        // samples are independent of the decision), at least one batch.
                        double more = n_min;
                        if (obj > 0 && taken >= 2) {
                            const double e = pixelError(ys, yq, lev, taken) / p_.adaptive_error;
                            more = std::max(more, std::ceil(n_min * e * e) - n_min);
                        }
                        takeSamples((uint32_t)std::min<double>(spp, n_min + more));
                    } else {
                        ++tile_untouched;
                    }
                }
                if (adaptive) out.samples.at<float>(y, x) = float(taken);
                tile_paths += taken;
                const double inv_spp = 1.0 / taken;
                double dest[3];  // the difference's estimate (adaptive)
                if (adaptive && taken > n_min) {
                    // The minimum and the later samples weighed by their counts (the mean of
                    // all samples taken); the roulette's weight on the later ones. A weight
                    // fixed by the cap (n_min / spp) instead made the estimate rest on the
                    // later samples alone.
                    const double alpha = double(n_min) / taken, m = taken - n_min;
                    for (int k = 0; k < 3; ++k)
                        dest[k] = alpha * dp[k] / n_min + (1 - alpha) * later_weight * dl[k] / m;
                } else {
                    for (int k = 0; k < 3; ++k)
                        dest[k] = dp[k] / n_min;
                }
                if (adaptive) {
                    Vec3f wo, wn;
                    for (int k = 0; k < 3; ++k) {
                        wn[2 - k] = float(cn[k] * inv_spp);
                        wo[2 - k] = wn[2 - k] + float(dest[k]);
                    }
                    out.color.at<Vec3f>(y, x) = wo;
                    without->color.at<Vec3f>(y, x) = wn;
                } else {
                    out.color.at<Vec3f>(y, x) =
                        Vec3f(float(c[2] * inv_spp), float(c[1] * inv_spp), float(c[0] * inv_spp));
                    if (differential)
                        without->color.at<Vec3f>(y, x) = Vec3f(
                            float(cn[2] * inv_spp), float(cn[1] * inv_spp), float(cn[0] * inv_spp));
                }
                if (p_.aovs) {
                    out.albedo.at<Vec3f>(y, x) =
                        Vec3f(float(a[2] * inv_spp), float(a[1] * inv_spp), float(a[0] * inv_spp));
                    const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                    out.normal.at<Vec3f>(y, x) =
                        l > 0 ? Vec3f(float(n[0] / l), float(n[1] / l), float(n[2] / l))
                              : Vec3f(0, 0, 0);
                    out.object.at<float>(y, x) = float(obj * inv_spp);
                    out.mask.at<float>(y, x) = float(msk * inv_spp);
                }
            }
            if (progress && phase == 1) progress->tick(x1 - x0);
        }
        rays += tile_rays;
        paths += tile_paths;
        untouched += tile_untouched;
    };

    const int n_tiles = tiles_x * tiles_y;
    auto pass = [&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, n_tiles, 1),
                          [&](const tbb::blocked_range<int>& r) {
                              for (int t = r.begin(); t != r.end(); ++t)
                                  renderTile(t);
                          });
    };
    auto body = [&] {
        pass();
        if (phase == 1) return;
        // Which pixels have a touched pixel within the radius (square window).
        const int R = std::max(0, p_.adaptive_radius);
        for (int y = 0; y < sz.height; ++y)
            for (int x = 0; x < sz.width; ++x) {
                if (pilot[size_t(y) * sz.width + x].obj == 0) continue;
                for (int v = std::max(0, y - R); v <= std::min(sz.height - 1, y + R); ++v)
                    for (int u = std::max(0, x - R); u <= std::min(sz.width - 1, x + R); ++u)
                        near_touched[size_t(v) * sz.width + u] = 1;
            }
        phase = 1;
        pass();
    };
    if (p_.threads > 0) {
        // Allow more workers than cores when asked (TBB's default cap is the core count).
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, (size_t)p_.threads);
        tbb::task_arena arena(p_.threads);
        arena.execute(body);
    } else {
        // In the caller's arena, so that a limit set around the call (runLimited) applies.
        body();
    }

    RenderStats st;
    st.seconds = timer.stop();
    st.paths = paths.load();
    st.pixels_untouched = untouched.load();
    st.rays = rays.load();
    return st;
}

}  // namespace

Ptr<Renderer> Renderer::create(const Params& params) {
    return makePtr<RendererImpl>(params);
}

}  // namespace vbme
}  // namespace cv
