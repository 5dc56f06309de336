// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Differential rendering: the two renders, the objects' coverage, the compositor, EXR layers.
#include "opencv2/vbme/render/differential.hpp"
#include "opencv2/vbme/core/params.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/render/camera.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "render_scene_impl.hpp"

namespace cv {
namespace vbme {

CoverageMethod parseCoverage(const std::string& name) {
    if (name == "projected") return COVERAGE_PROJECTED;
    if (name == "rays") return COVERAGE_PRIMARY_RAYS;
    CV_Error(Error::StsBadArg, "coverage: unknown '" + name + "' (expected projected or rays)");
}

FrameSeeding parseFrameSeeding(const std::string& name) {
    if (name == "fixed") return SEEDS_FIXED;
    if (name == "per-frame") return SEEDS_PER_FRAME;
    CV_Error(Error::StsBadArg,
             "frame seeding: unknown '" + name + "' (expected fixed or per-frame)");
}

uint64 frameSeed(uint64 seed, int frame, FrameSeeding mode) {
    if (frame < 0)
        CV_Error(Error::StsBadArg, cv::format("frameSeed: frame is %d, expected ≥ 0", frame));
    if (mode == SEEDS_FIXED) return seed;
    if (mode != SEEDS_PER_FRAME)
        CV_Error(Error::StsBadArg, "frameSeed: mode must be SEEDS_FIXED or SEEDS_PER_FRAME");
    // SplitMix64 finaliser of the seed combined with the frame index.
    return mix64(seed ^ (0x9E3779B97F4A7C15ull * (uint64(frame) + 1)));
}

DifferentialRenderer::~DifferentialRenderer() = default;
DifferentialRenderer::Params::Params() = default;

void DifferentialRenderer::Params::read(const FileNode& fn) {
    ParamsIn in(fn, "differential renderer parameters");
    in("render", render);
    in.choice("method", method, {{"one_pass", (int)ONE_PASS}, {"two_pass", (int)TWO_PASS}});
    in("independent", independent);
    if (const FileNode n = in.take("coverage"); !n.empty())
        coverage = parseCoverage((std::string)n);
    in("coverage_supersampling", coverage_supersampling);
    in("coverage_occlusion", coverage_occlusion);
    in.finish();
    check();
}

void DifferentialRenderer::Params::check() const {
    const char* w = "differential renderer parameters";
    render.check();
    checkParam(method == ONE_PASS || method == TWO_PASS, w, "method", method,
               "ONE_PASS (0) or TWO_PASS (1)");
    checkParam(coverage == COVERAGE_PROJECTED || coverage == COVERAGE_PRIMARY_RAYS, w, "coverage",
               coverage, "COVERAGE_PROJECTED or COVERAGE_PRIMARY_RAYS");
    checkParam(coverage_supersampling >= 1 && coverage_supersampling <= 8, w,
               "coverage_supersampling", coverage_supersampling, "1 … 8");
}

void DifferentialRenderer::Params::write(FileStorage& fs) const {
    fs << "render"
       << "{";
    render.write(fs);
    fs << "}";
    fs << "method" << (method == TWO_PASS ? "two_pass" : "one_pass");
    fs << "independent" << (int)independent;
    fs << "coverage" << (coverage == COVERAGE_PRIMARY_RAYS ? "rays" : "projected");
    fs << "coverage_supersampling" << coverage_supersampling;
    fs << "coverage_occlusion" << (int)coverage_occlusion;
}

void CompositeParams::read(const FileNode& fn) {
    ParamsIn in(fn, "composite parameters");
    in("alpha", alpha);
    if (const FileNode n = in.take("response"); !n.empty())
        response = parseResponse((std::string)n);
    in.choice("shadows", shadows, {{"additive", SHADOWS_ADDITIVE}, {"ratio", SHADOWS_RATIO}});
    in.finish();
    check();
}

void CompositeParams::check() const {
    checkParam(std::isfinite(alpha), "composite parameters", "alpha", alpha, "a finite number");
}

void CompositeParams::write(FileStorage& fs) const {
    fs << "alpha" << alpha << "response" << toString(response) << "shadows" << toString(shadows);
}

std::string toString(CompositeParams::Shadows s) {
    return s == CompositeParams::SHADOWS_RATIO ? "ratio" : "additive";
}

CompositeParams::Shadows parseShadows(const std::string& name, const std::string& field) {
    if (name == "additive") return CompositeParams::SHADOWS_ADDITIVE;
    if (name == "ratio") return CompositeParams::SHADOWS_RATIO;
    CV_Error(Error::StsBadArg,
             field + ": unknown shadow compositing '" + name + "' (valid: additive, ratio)");
}

namespace {

using render_detail::RenderSceneImpl;

/** Seed of the second render when the two must be independent. */
uint64 independentSeed(uint64 seed) {
    return mix64(seed + 0x9E3779B97F4A7C15ull);
}

class DifferentialRendererImpl : public DifferentialRenderer {
public:
    explicit DifferentialRendererImpl(const Params& p) { setParams(p); }
    const Params& getParams() const override { return p_; }
    void setParams(const Params& p) override {
        p.check();
        p_ = p;
    }

    RenderStats render(const RenderScene& scene, const Camera& camera, DifferentialImages& out,
                       Progress* progress) const override {
        Renderer::Params rp = p_.render;
        // The primary-ray mask and the interaction fraction are AOVs of the render with objects.
        rp.aovs = rp.aovs || p_.coverage == COVERAGE_PRIMARY_RAYS;
        RenderImages with, without;
        RenderStats st;
        if (p_.method == ONE_PASS && !p_.independent) {
            st = Renderer::create(rp)->renderDifferential(scene, camera, with, without, progress);
        } else {
            rp.with_objects = true;
            st = Renderer::create(rp)->render(scene, camera, with, progress);
            rp.with_objects = false;
            rp.aovs = false;
            if (p_.independent) rp.seed = independentSeed(rp.seed);
            const RenderStats st2 = Renderer::create(rp)->render(scene, camera, without, progress);
            st.seconds += st2.seconds;
            st.rays += st2.rays;
        }
        out.obj = with.color;
        out.noobj = without.color;
        subtract(out.obj, out.noobj, out.diff);
        out.object = with.object;
        out.samples = with.samples;
        if (p_.coverage == COVERAGE_PRIMARY_RAYS)
            out.mask = with.mask;
        else
            projectObjectCoverage(scene, camera, out.mask, p_.coverage_supersampling,
                                  p_.coverage_occlusion);
        return st;
    }

private:
    Params p_;
};

/** Camera-space polygon clipped to z ≥ znear (Sutherland–Hodgman against one plane). */
int clipNear(const Vec3d in[3], double znear, Vec3d out[4]) {
    int n = 0;
    for (int i = 0; i < 3; ++i) {
        const Vec3d& a = in[i];
        const Vec3d& b = in[(i + 1) % 3];
        const bool ia = a[2] >= znear, ib = b[2] >= znear;
        if (ia) out[n++] = a;
        if (ia != ib) {
            const double s = (znear - a[2]) / (b[2] - a[2]);
            out[n++] = a + (b - a) * s;
        }
    }
    return n;
}

/** Sets the bits of the sub-samples of @p bits (n×n a pixel) inside the 2-D triangle abc. */
void rasterize(const Point2d& a, const Point2d& b, const Point2d& c, int n, Size sz,
               std::vector<uint64_t>& bits) {
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (!(std::abs(area) > 0)) return;
    const double sgn = area > 0 ? 1.0 : -1.0;
    // Sub-sample g (global index along an axis) sits at (g + ½)/n − ½.
    auto first = [n](double v) { return (int)std::ceil((v + 0.5) * n - 0.5); };
    auto last = [n](double v) { return (int)std::floor((v + 0.5) * n - 0.5); };
    const int gx0 = std::max(0, first(std::min({a.x, b.x, c.x})));
    const int gx1 = std::min(sz.width * n - 1, last(std::max({a.x, b.x, c.x})));
    const int gy0 = std::max(0, first(std::min({a.y, b.y, c.y})));
    const int gy1 = std::min(sz.height * n - 1, last(std::max({a.y, b.y, c.y})));
    auto edge = [sgn](const Point2d& p, const Point2d& q, double x, double y) {
        return sgn * ((q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x));
    };
    for (int gy = gy0; gy <= gy1; ++gy) {
        const double y = (gy + 0.5) / n - 0.5;
        for (int gx = gx0; gx <= gx1; ++gx) {
            const double x = (gx + 0.5) / n - 0.5;
            // Closed triangle: shared edges are covered by both, and bits are OR-ed.
            if (edge(a, b, x, y) >= 0 && edge(b, c, x, y) >= 0 && edge(c, a, x, y) >= 0)
                bits[size_t(gy / n) * sz.width + gx / n] |= uint64_t(1) << ((gy % n) * n + gx % n);
        }
    }
}

int popcount64(uint64_t v) {
    int c = 0;
    for (; v; v &= v - 1)
        ++c;
    return c;
}

}  // namespace

Ptr<DifferentialRenderer> DifferentialRenderer::create(const Params& params) {
    return makePtr<DifferentialRendererImpl>(params);
}

void projectObjectCoverage(const RenderScene& scene_in, const Camera& camera, OutputArray mask,
                           int supersampling, bool occlusion) {
    const int n = supersampling;
    if (n < 1 || n > 8)
        CV_Error(Error::StsBadArg,
                 cv::format("projectObjectCoverage: supersampling is %d, expected 1 … 8", n));
    const Size sz = camera.image_size;
    CV_Assert(sz.width > 0 && sz.height > 0 && "projectObjectCoverage: empty camera image size");
    const auto* scene = dynamic_cast<const RenderSceneImpl*>(&scene_in);
    CV_Assert(scene && "projectObjectCoverage: the scene must come from RenderScene::create");
    std::vector<uint64_t> bits(size_t(sz.area()), 0);
    const Matx33d& K = camera.K;
    // Near plane: well in front of the centre, tiny against any room.
    const double znear = 1e-4;
    for (int g = 0; g < scene->numGeometries(); ++g) {
        const auto& geom = scene->geometry(g);
        if (geom.kind != GeometryKind::OBJECT) continue;
        std::vector<Vec3d> cam_pts(geom.numVertices());
        for (size_t v = 0; v < cam_pts.size(); ++v)
            cam_pts[v] = camera.camFromWorld(Vec3d(geom.vertex((uint32_t)v)));
        for (size_t tri = 0; tri < geom.numTriangles(); ++tri) {
            const Vec3d in[3] = {cam_pts[geom.idx[3 * tri]], cam_pts[geom.idx[3 * tri + 1]],
                                 cam_pts[geom.idx[3 * tri + 2]]};
            Vec3d poly[4];
            const int m = clipNear(in, znear, poly);
            if (m < 3) continue;
            Point2d q[4];
            for (int i = 0; i < m; ++i) {
                const Vec3d h = K * poly[i];
                q[i] = Point2d(h[0] / h[2], h[1] / h[2]);
            }
            for (int i = 1; i + 1 < m; ++i)
                rasterize(q[0], q[i], q[i + 1], n, sz, bits);
        }
    }
    if (occlusion) {
        // Keep a sub-sample only if its camera ray meets an object before anything else.
        const PinholeCamera cam(camera);
        for (int y = 0; y < sz.height; ++y)
            for (int x = 0; x < sz.width; ++x) {
                uint64_t& b = bits[size_t(y) * sz.width + x];
                for (uint64_t rest = b; rest; rest &= rest - 1) {
                    int k = 0;
                    while (!((rest >> k) & 1u))
                        ++k;
                    const float sx = x - 0.5f + ((k % n) + 0.5f) / n;
                    const float sy = y - 0.5f + ((k / n) + 0.5f) / n;
                    Vec3f o, d;
                    cam.generateRay(Point2f(sx, sy), o, d);
                    SurfaceHit hit;
                    if (scene->intersect(o, d, 0.f, std::numeric_limits<float>::infinity(), hit,
                                         true) &&
                        hit.kind != GeometryKind::OBJECT)
                        b &= ~(uint64_t(1) << k);
                }
            }
    }
    mask.create(sz, CV_32FC1);
    Mat M = mask.getMat();
    const float inv = 1.f / float(n * n);
    for (int y = 0; y < sz.height; ++y) {
        float* row = M.ptr<float>(y);
        for (int x = 0; x < sz.width; ++x)
            row[x] = float(popcount64(bits[size_t(y) * sz.width + x])) * inv;
    }
}

namespace {

// The compositor of both overloads; @p noobj is empty for additive shadows.
void compositeLayers(const Mat& bg, const Mat& obj, const Mat& diff, const Mat& noobj, const Mat& M,
                     OutputArray linear, const CompositeParams& params) {
    if (bg.empty() || bg.channels() != 3)
        CV_Error(Error::StsBadArg,
                 "compositeDifferential: the background must be a 3-channel "
                 "(BGR) image");
    auto sizeText = [](const Mat& m) { return cv::format("%dx%d", m.cols, m.rows); };
    const bool ratio = params.shadows == CompositeParams::SHADOWS_RATIO;
    std::vector<std::pair<const char*, const Mat*>> layers = {{"obj", &obj}, {"diff", &diff}};
    if (ratio) layers.push_back({"noobj", &noobj});
    for (const auto& pr : layers) {
        const Mat& m = *pr.second;
        if (m.type() != CV_32FC3 || m.size() != bg.size())
            CV_Error(Error::StsBadArg,
                     cv::format("compositeDifferential: %s is %s of type %d, expected CV_32FC3 "
                                "of the background's size %s",
                                pr.first, sizeText(m).c_str(), m.type(), sizeText(bg).c_str()));
    }
    if (M.type() != CV_32FC1 || M.size() != bg.size())
        CV_Error(Error::StsBadArg,
                 cv::format("compositeDifferential: mask is %s of type %d, expected CV_32FC1 of "
                            "the background's size %s",
                            sizeText(M).c_str(), M.type(), sizeText(bg).c_str()));
    Mat lin;
    linearize(bg, lin, params.response);
    linear.create(bg.size(), CV_32FC3);
    Mat out = linear.getMat();
    const float alpha = params.alpha;
    for (int y = 0; y < bg.rows; ++y) {
        const Vec3f* I = lin.ptr<Vec3f>(y);
        const Vec3f* O = obj.ptr<Vec3f>(y);
        const Vec3f* D = diff.ptr<Vec3f>(y);
        const Vec3f* N = ratio ? noobj.ptr<Vec3f>(y) : nullptr;
        const float* m = M.ptr<float>(y);
        Vec3f* R = out.ptr<Vec3f>(y);
        for (int x = 0; x < bg.cols; ++x) {
            const float w = std::min(1.f, std::max(0.f, m[x]));
            for (int c = 0; c < 3; ++c) {
                const float d = D[x][c];
                float back;
                if (ratio && d < 0.f) {
                    // the fraction of the model's light the objects take, taken from the footage
                    const float n = N[x][c];
                    const float lost = n > 0.f ? std::max(-1.f, d / n) : -1.f;
                    back = I[x][c] * std::max(0.f, 1.f + alpha * lost);
                } else {
                    back = std::max(0.f, I[x][c] + alpha * d);
                }
                // Written so that w = 0 gives `back` exactly (and w = 1 gives obj exactly).
                R[x][c] = w == 0.f ? back : (w == 1.f ? O[x][c] : w * O[x][c] + (1.f - w) * back);
            }
        }
    }
}

}  // namespace

void compositeDifferential(InputArray background_in, InputArray obj_in, InputArray diff_in,
                           InputArray mask_in, OutputArray linear, const CompositeParams& params) {
    if (params.shadows == CompositeParams::SHADOWS_RATIO)
        CV_Error(Error::StsBadArg,
                 "compositeDifferential: ratio shadows need the noobj layer (use the "
                 "DifferentialImages overload)");
    compositeLayers(background_in.getMat(), obj_in.getMat(), diff_in.getMat(), Mat(),
                    mask_in.getMat(), linear, params);
}

void compositeDifferential(InputArray background, const DifferentialImages& layers,
                           OutputArray linear, const CompositeParams& params) {
    compositeLayers(background.getMat(), layers.obj, layers.diff, layers.noobj, layers.mask, linear,
                    params);
}

void compositeDifferentialDisplay(InputArray background, const DifferentialImages& layers,
                                  OutputArray display, const CompositeParams& params) {
    Mat linear, enc;
    compositeDifferential(background, layers, linear, params);
    encode(linear, enc, params.response, CV_32F);
    min(max(enc, 0.0), 1.0, enc);
    enc.convertTo(display, CV_32F, 255.0);
}

void encodeComposite(InputArray linear, OutputArray encoded, Response response, int ddepth) {
    if (ddepth == CV_8U) {
        encode(linear, encoded, response, CV_8U);
        return;
    }
    if (ddepth != CV_16U)
        CV_Error(Error::StsBadArg, "encodeComposite: ddepth must be CV_8U or CV_16U");
    Mat f;
    encode(linear, f, response, CV_32F);
    f.convertTo(encoded, CV_16U, 65535.0);
}

void writeDifferentialExr(const std::string& path, const DifferentialImages& im,
                          InputArray composite_in,
                          const std::map<std::string, std::string>& attributes) {
    if (im.obj.type() != CV_32FC3 || im.noobj.type() != CV_32FC3 || im.diff.type() != CV_32FC3 ||
        im.mask.type() != CV_32FC1)
        CV_Error(Error::StsBadArg,
                 "writeDifferentialExr: obj, noobj, diff must be CV_32FC3 and "
                 "mask CV_32FC1");
    Mat comp = composite_in.empty() ? im.obj : composite_in.getMat();
    CV_Assert(comp.type() == CV_32FC3 && comp.size() == im.obj.size() &&
              "writeDifferentialExr: the composite must be CV_32FC3 of the layers' size");
    std::vector<std::pair<std::string, Mat>> ch;
    auto addRgb = [&ch](const std::string& prefix, const Mat& bgr) {
        Mat c[3];
        split(bgr, c);
        ch.emplace_back(prefix + "R", c[2]);
        ch.emplace_back(prefix + "G", c[1]);
        ch.emplace_back(prefix + "B", c[0]);
    };
    addRgb("", comp);
    addRgb("obj.", im.obj);
    addRgb("noobj.", im.noobj);
    addRgb("diff.", im.diff);
    ch.emplace_back("mask", im.mask);
    if (!im.object.empty()) ch.emplace_back("object", im.object);
    writeExrChannels(path, ch, attributes);
}

DifferentialImages readDifferentialExr(const std::string& path, OutputArray composite,
                                       std::map<std::string, std::string>* attributes) {
    std::map<std::string, Mat> ch = readExrChannels(path, attributes);
    std::string missing;
    for (const char* name : {"obj.R", "obj.G", "obj.B", "diff.R", "diff.G", "diff.B", "mask"})
        if (!ch.count(name)) missing += std::string(missing.empty() ? "" : ", ") + name;
    if (!missing.empty())
        CV_Error(Error::StsBadArg, "'" + path + "' lacks the differential-rendering channels " +
                                       missing +
                                       " (expected obj.R/G/B, diff.R/G/B and mask, "
                                       "as `vbme render --differential` writes them)");
    auto merged = [&ch](const std::string& prefix) {
        Mat out;
        merge(std::vector<Mat>{ch[prefix + "B"], ch[prefix + "G"], ch[prefix + "R"]}, out);
        return out;
    };
    DifferentialImages im;
    im.obj = merged("obj.");
    im.diff = merged("diff.");
    if (ch.count("noobj.R") && ch.count("noobj.G") && ch.count("noobj.B"))
        im.noobj = merged("noobj.");
    else
        subtract(im.obj, im.diff, im.noobj);
    im.mask = ch["mask"];
    if (ch.count("object")) im.object = ch["object"];
    if (composite.needed()) {
        if (ch.count("R") && ch.count("G") && ch.count("B"))
            merged("").copyTo(composite);
        else
            composite.release();
    }
    return im;
}

void distortLayersK1(DifferentialImages& im, const Camera& cam, const Camera& source) {
    if (cam.k1 == 0 && source.K == cam.K && source.image_size == cam.image_size) return;
    for (Mat* m : {&im.obj, &im.noobj, &im.diff, &im.mask, &im.object})
        if (!m->empty()) distortImageK1(*m, *m, cam, source);
    if (!im.samples.empty()) distortImageK1(im.samples, im.samples, cam, source, INTER_NEAREST);
}

}  // namespace vbme
}  // namespace cv
