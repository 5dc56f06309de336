// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Room albedo: Retinex on a synthetic shading × reflectance image, and irradiance albedo
// against the known albedo of a path-traced room (Retinex on the same for comparison).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>
#include <opencv2/vbme/render.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

/** A 3 × 3 × 2.4 m room with known albedo textures (EXR) and a square ceiling light. */
Scene albedoTestRoom(const vbme_test::ScratchDir& dir, std::map<std::string, Mat>& albedo,
                     int tex = 32) {
    Scene s;
    s.image_size = Size(64, 48);
    s.camera = Camera::fromFocal(60, s.image_size);
    s.has_room = true;
    s.room.min = Vec3d(-1.5, -1.5, 0);
    s.room.max = Vec3d(1.5, 1.5, 2.4);
    const std::map<std::string, Mat> t8 = makeRoomTextures(11, 2 * tex);
    for (const std::string& face : Room::faceNames()) {
        Mat a;
        resize(t8.at(face), a, Size(tex, tex), 0, 0, INTER_AREA);
        a.convertTo(a, CV_32FC3, 0.7 / 255, 0.15);  // albedo in [0.15, 0.85]
        albedo[face] = a;
        RenderImages img;
        img.color = a;
        writeExr(dir / (face + "_albedo.exr"), img);
        s.room.textures[face] = dir / (face + "_albedo.exr");
    }
    Light l;
    l.type = Light::POLYGON;
    const double z = 2.4, h = 0.3;
    l.corners = {Vec3d(-h, -h, z), Vec3d(-h, h, z), Vec3d(h, h, z), Vec3d(h, -h, z)};
    if (l.polygonNormal()[2] > 0) std::reverse(l.corners.begin(), l.corners.end());
    l.radiance = Vec3d(12, 11, 9);
    s.lights.push_back(l);
    return s;
}

/** The radiance leaving every texel of every face, path traced (Lambertian: view-independent). */
std::map<std::string, Mat> texelRadiance(const Scene& s, int spp) {
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = spp;
    p.max_depth = 8;
    Ptr<Renderer> r = Renderer::create(p);
    std::map<std::string, Mat> out;
    const Vec3d lo = s.room.min, hi = s.room.max;
    const Vec3d ex(hi[0] - lo[0], 0, 0), ey(0, hi[1] - lo[1], 0), ez(0, 0, hi[2] - lo[2]);
    struct F {
        const char* name;
        Vec3d bl, right, up;
    };
    const F faces[6] = {{"floor", lo, ex, ey},
                        {"ceiling", Vec3d(lo[0], hi[1], hi[2]), ex, -ey},
                        {"left", lo, ey, ez},
                        {"right", Vec3d(hi[0], hi[1], lo[2]), -ey, ez},
                        {"front", Vec3d(hi[0], lo[1], lo[2]), -ex, ez},
                        {"back", Vec3d(lo[0], hi[1], lo[2]), ex, ez}};
    for (int f = 0; f < 6; ++f) {
        const Size sz = s.room.textures.empty() ? Size(24, 24) : Size(24, 24);
        Mat L(sz, CV_32FC3);
        const Vec3d n = normalize(faces[f].right.cross(faces[f].up));
        parallel_for_(Range(0, sz.height), [&](const Range& rows) {
            for (int y = rows.start; y < rows.end; ++y)
                for (int x = 0; x < sz.width; ++x) {
                    const double u = (x + 0.5) / sz.width, v = 1 - (y + 0.5) / sz.height;
                    const Vec3d P = faces[f].bl + faces[f].right * u + faces[f].up * v;
                    const Vec3f o(P + n * 0.01), d(-n);
                    Vec3f sum(0, 0, 0);
                    for (int k = 0; k < spp; ++k)
                        sum += r->radiance(*rs, o, d, Point(x, y + 64 * f), (uint32_t)k);
                    sum *= 1.f / spp;
                    L.at<Vec3f>(y, x) = Vec3f(sum[2], sum[1], sum[0]);  // RGB → BGR
                }
        });
        out[faces[f].name] = L;
    }
    return out;
}

/** Mean relative error |a − b| / b over @p mask, all channels; with @p fit_scale, after the
least-squares scale of a onto b. */
double relError(const Mat& a, const Mat& b, const Mat& mask, bool fit_scale = false) {
    double ab = 0, aa = 0;
    for (int y = 0; y < a.rows; ++y)
        for (int x = 0; x < a.cols; ++x)
            if (mask.at<uchar>(y, x))
                for (int c = 0; c < 3; ++c) {
                    ab += a.at<Vec3f>(y, x)[c] * b.at<Vec3f>(y, x)[c];
                    aa += a.at<Vec3f>(y, x)[c] * a.at<Vec3f>(y, x)[c];
                }
    const double k = fit_scale && aa > 0 ? ab / aa : 1.0;
    double e = 0;
    int n = 0;
    for (int y = 0; y < a.rows; ++y)
        for (int x = 0; x < a.cols; ++x)
            if (mask.at<uchar>(y, x))
                for (int c = 0; c < 3; ++c) {
                    e += std::abs(k * a.at<Vec3f>(y, x)[c] - b.at<Vec3f>(y, x)[c]) /
                         b.at<Vec3f>(y, x)[c];
                    ++n;
                }
    return e / std::max(n, 1);
}

}  // namespace

// Retinex separates a piecewise-constant reflectance from smooth grey shading.
TEST(RenderAlbedo, RetinexSeparatesSmoothShading) {
    Mat refl(96, 128, CV_32FC3, Scalar(0.6, 0.6, 0.6));
    rectangle(refl, Rect(10, 10, 40, 30), Scalar(0.2, 0.3, 0.7), FILLED);
    rectangle(refl, Rect(70, 40, 40, 45), Scalar(0.8, 0.5, 0.3), FILLED);
    circle(refl, Point(40, 70), 15, Scalar(0.3, 0.3, 0.3), FILLED);
    Mat tex(refl.size(), CV_32FC3);
    for (int y = 0; y < tex.rows; ++y)
        for (int x = 0; x < tex.cols; ++x) {
            const float sh = 0.5f * std::exp(1.2f * x / tex.cols - 0.6f * y / tex.rows);
            tex.at<Vec3f>(y, x) = refl.at<Vec3f>(y, x) * sh;
        }
    Mat a;
    RetinexParams p;
    retinexAlbedo(tex, a, p);
    ASSERT_EQ(a.type(), CV_32FC3);
    const Mat all = Mat(tex.size(), CV_8U, Scalar(255));
    const double e_fit = relError(a, refl, all, true), e_tex = relError(tex, refl, all, true);
    std::printf(
        "[ measured ] Retinex on shading × reflectance: error %.4f after scale fit "
        "(texture itself: %.4f)\n",
        e_fit, e_tex);
    EXPECT_LT(e_fit, 0.05);
    EXPECT_LT(e_fit, 0.3 * e_tex);
    // White convention: the 99th percentile of luminance is 0.9.
    Mat l;
    cvtColor(a, l, COLOR_BGR2GRAY);
    double mx;
    minMaxLoc(l, nullptr, &mx);
    EXPECT_LE(mx, 1.0);
    EXPECT_GT(mx, 0.8);
}

// The irradiance albedo recovers the known albedo of a path-traced room; Retinex on the same
// radiance is reported for comparison.
TEST(RenderAlbedo, IrradianceAlbedoMatchesKnownAlbedo) {
    vbme_test::ScratchDir dir;
    std::map<std::string, Mat> truth;
    const Scene s = albedoTestRoom(dir, truth, 24);
    const int64 t0 = getTickCount();
    const std::map<std::string, Mat> L = texelRadiance(s, 64);
    const double t_ref = (getTickCount() - t0) / getTickFrequency();
    // Seen: everything but the front wall (never filmed) and the ceiling texels under the
    // light (they show the light, not the wall).
    std::map<std::string, Mat> seen;
    for (const auto& kv : L) {
        Mat m(kv.second.size(), CV_8U, Scalar(kv.first == "front" ? 0 : 255));
        if (kv.first == "ceiling")
            for (int y = 0; y < m.rows; ++y)
                for (int x = 0; x < m.cols; ++x) {
                    const double px = -1.5 + 3 * (x + 0.5) / m.cols;
                    const double py = 1.5 - 3 * (1 - (y + 0.5) / m.rows);  // ceiling up = −y
                    if (std::abs(px) < 0.4 && std::abs(py) < 0.4) m.at<uchar>(y, x) = 0;
                }
        seen[kv.first] = m;
    }
    std::map<std::string, Mat> A, E;
    IrradianceAlbedoParams p;
    p.grid = 24;
    p.spp = 64;
    p.iterations = 3;
    const int64 t1 = getTickCount();
    irradianceAlbedo(s, L, seen, A, p, &E);
    const double t_alb = (getTickCount() - t1) / getTickFrequency();
    double e_irr = 0, e_ret = 0, e_ret_fit = 0;
    int nf = 0;
    for (const std::string& face : Room::faceNames()) {
        if (face == "front") continue;
        ASSERT_EQ(A.at(face).size(), L.at(face).size());
        const double ei = relError(A.at(face), truth.at(face), seen.at(face));
        Mat Lm = L.at(face).clone(), r;
        Lm.setTo(Scalar::all(0), seen.at(face) == 0);
        retinexAlbedo(Lm, r);
        const double er = relError(r, truth.at(face), seen.at(face));
        const double erf = relError(r, truth.at(face), seen.at(face), true);
        std::printf(
            "[ measured ] %s: irradiance albedo error %.4f, Retinex %.4f (%.4f after "
            "the best scale)\n",
            face.c_str(), ei, er, erf);
        e_irr += ei;
        e_ret += er;
        e_ret_fit += erf;
        ++nf;
    }
    e_irr /= nf;
    e_ret /= nf;
    e_ret_fit /= nf;
    // The front wall was never seen: its albedo is the mean of the seen ones.
    const Scalar fm = mean(A.at("front"));
    std::printf(
        "[ measured ] mean relative albedo error: irradiance %.4f, Retinex %.4f "
        "(%.4f after per-face scale); front (unseen) filled with %.3f; reference "
        "radiance %.2f s, irradiance albedo %.2f s\n",
        e_irr, e_ret, e_ret_fit, fm[1], t_ref, t_alb);
    // 64-spp texel radiance has ~3 % noise per texel; the irradiance grid adds interpolation
    // error near the room's edges.
    EXPECT_LT(e_irr, 0.08);
    EXPECT_LT(e_irr, e_ret_fit);
    EXPECT_GT(fm[1], 0.3);
    EXPECT_LT(fm[1], 0.7);
}

// Unseen texels without the iterations: one pass gives a usable but worse estimate; the
// iterations change only the indirect light from unseen texels.
TEST(RenderAlbedo, IrradianceAlbedoZeroMeansUnseen) {
    vbme_test::ScratchDir dir;
    std::map<std::string, Mat> truth;
    Scene s = albedoTestRoom(dir, truth, 16);
    // A crude radiance: albedo × (light radiance scaled) where seen; front unseen (zeros).
    std::map<std::string, Mat> L;
    for (const auto& kv : truth)
        L[kv.first] =
            kv.first == "front" ? Mat::zeros(kv.second.size(), CV_32FC3) : Mat(kv.second * 0.1);
    std::map<std::string, Mat> A;
    IrradianceAlbedoParams p;
    p.grid = 8;
    p.spp = 16;
    irradianceAlbedo(s, L, A, p);
    ASSERT_EQ(A.size(), 6u);
    for (const auto& kv : A) {
        double mn, mx;
        minMaxLoc(kv.second.reshape(1), &mn, &mx);
        EXPECT_GE(mn, 0.0) << kv.first;
        EXPECT_LE(mx, 1.0) << kv.first;
    }
    // Front: constant fill.
    Scalar m, sd;
    meanStdDev(A.at("front"), m, sd);
    EXPECT_LT(sd[0], 1e-6);
    EXPECT_THROW(irradianceAlbedo(Scene(), L, A, p), cv::Exception);
}

// The white point fixes the lights' common scale: with the lights annotated 3× too dim (LDR
// clipping makes annotated radiance a lower bound), irradianceAlbedoWhitePoint() given the
// room's true white point brings them back to the true power and the albedo to the truth,
// where plain irradianceAlbedo() with the dim lights is off by the factor.
TEST(RenderAlbedo, WhitePointFixesTheLightScale) {
    vbme_test::ScratchDir dir;
    std::map<std::string, Mat> truth;
    const Scene s = albedoTestRoom(dir, truth, 24);  // texelRadiance() gives 24 x 24
    const std::map<std::string, Mat> L = texelRadiance(s, 32);
    std::map<std::string, Mat> seen;
    std::vector<float> white_values;
    for (const auto& kv : L) {
        seen[kv.first] = Mat(kv.second.size(), CV_8U, Scalar(kv.first == "front" ? 0 : 255));
        if (kv.first == "front") continue;
        // the truth's white point as the function measures it: largest channel, 99th
        // percentile over the seen, unclipped texels
        const Mat& a = truth.at(kv.first);
        for (int y = 0; y < a.rows; ++y)
            for (int x = 0; x < a.cols; ++x) {
                const Vec3f l = kv.second.at<Vec3f>(y, x), v = a.at<Vec3f>(y, x);
                if (std::max({l[0], l[1], l[2]}) < 0.95f)
                    white_values.push_back(std::max({v[0], v[1], v[2]}));
            }
    }
    ASSERT_FALSE(white_values.empty());
    std::nth_element(white_values.begin(), white_values.begin() + white_values.size() * 99 / 100,
                     white_values.end());
    const double white = white_values[white_values.size() * 99 / 100];
    const double kDim = 3;
    Scene dim = s;
    dim.room.textures.clear();
    dim.lights[0].radiance = s.lights[0].radiance / kDim;
    IrradianceAlbedoParams p;
    p.grid = 16;
    p.spp = 32;
    std::map<std::string, Mat> plain, fixed;
    irradianceAlbedo(dim, L, seen, plain, p);
    Scene scaled = dim;
    const double k = irradianceAlbedoWhitePoint(scaled, L, seen, fixed, white, p);
    double e_plain = 0, e_fixed = 0;
    int nf = 0;
    for (const std::string& face : Room::faceNames()) {
        if (face == "front") continue;
        e_plain += relError(plain.at(face), truth.at(face), seen.at(face));
        e_fixed += relError(fixed.at(face), truth.at(face), seen.at(face));
        ++nf;
    }
    e_plain /= nf;
    e_fixed /= nf;
    const double power_ratio = scaled.lights[0].radiance[0] / s.lights[0].radiance[0];
    std::printf(
        "[ measured ] white point %.3f: light scale %.4f (truth %.1f), light power / true %.4f; "
        "mean relative albedo error %.4f (dim lights, no white point: %.4f)\n",
        white, k, kDim, power_ratio, e_fixed, e_plain);
    EXPECT_NEAR(k, kDim, 0.1 * kDim);
    EXPECT_NEAR(power_ratio, 1.0, 0.1);
    EXPECT_LT(e_fixed, 0.1);
    EXPECT_LT(e_fixed, 0.5 * e_plain);
    // Lights at their true power in a room whose whitest surfaces are darker than the white
    // point asked for (grey walls): the lights stay as they are (never scaled down, which
    // would darken everything rendered with them by white / true white) and the albedo is the
    // truth's.
    Scene exact = s;
    exact.room.textures.clear();
    std::map<std::string, Mat> exact_albedo;
    const double brighter_white = std::min(1.0, 1.3 * white);
    ASSERT_GT(brighter_white, 1.1 * white);
    EXPECT_EQ(irradianceAlbedoWhitePoint(exact, L, seen, exact_albedo, brighter_white, p), 1.0);
    EXPECT_EQ(exact.lights[0].radiance, s.lights[0].radiance);
    double e_exact = 0;
    for (const std::string& face : Room::faceNames())
        if (face != "front")
            e_exact += relError(exact_albedo.at(face), truth.at(face), seen.at(face));
    e_exact /= nf;
    std::printf(
        "[ measured ] exact lights, white point %.3f above the room's %.3f: light scale "
        "1, mean relative albedo error %.4f\n",
        brighter_white, white, e_exact);
    EXPECT_LT(e_exact, 0.1);
    // white = 0: one pass, lights untouched
    Scene same = dim;
    std::map<std::string, Mat> again;
    EXPECT_EQ(irradianceAlbedoWhitePoint(same, L, seen, again, 0.0, p), 1.0);
    EXPECT_EQ(same.lights[0].radiance, dim.lights[0].radiance);
}
