// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Image-space re-rendering (render/relighting.hpp): lighting fit, shaders, compositing, each
// against an analytic oracle (spheres rendered analytically in this file).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/render/environment.hpp"
#include "opencv2/vbme/render/relighting.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

const float kPi = 3.14159265f;

double angleDeg(const Vec3f& a, const Vec3f& b) {
    const double c = a.dot(b) / (norm(a) * norm(b));
    return std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / CV_PI;
}

/** Analytic Lambertian sphere (orthographic normals) under a directional light of irradiance
E plus an ambient radiance `amb + grad·(−ω_y)` (brighter from above): its irradiance is
`π·amb + (2π/3)·grad·(−n_y)`, exact. Linear BGR; normals and a mask of the inner disk. */
struct AnalyticSphere {
    Size size{96, 96};
    Point2f c{47.5f, 47.5f};
    float r = 40;
    Vec3f albedo{0.7f, 0.4f, 0.2f};  // RGB
    Vec3f to_light{0.4f, -0.5f, -0.77f};
    float E = 2.5f, amb = 0.1f, grad = 0.05f;
    Mat image, normals, mask;
    void render() {
        image.create(size, CV_32FC3);
        image.setTo(Scalar::all(0.05));
        normals = Mat::zeros(size, CV_32FC3);
        mask = Mat::zeros(size, CV_8U);
        const Vec3f d = to_light / (float)norm(to_light);
        for (int y = 0; y < size.height; y++)
            for (int x = 0; x < size.width; x++) {
                const float dx = (x - c.x) / r, dy = (y - c.y) / r;
                if (dx * dx + dy * dy > 1) continue;
                const Vec3f n = sphereNormalAt((float)x, (float)y, c, r);
                const float irr =
                    E * std::max(0.f, n.dot(d)) + kPi * amb + 2 * kPi / 3 * grad * -n[1];
                const Vec3f rgb = albedo * (irr / kPi);
                image.at<Vec3f>(y, x) = Vec3f(rgb[2], rgb[1], rgb[0]);
                normals.at<Vec3f>(y, x) = n;
                if (dx * dx + dy * dy < 0.9f) mask.at<uchar>(y, x) = 255;
            }
    }
};

double psnrMasked(const Mat& a8, const Mat& b8, const Mat& mask) {
    double se = 0;
    int n = 0;
    for (int y = 0; y < a8.rows; y++)
        for (int x = 0; x < a8.cols; x++) {
            if (!mask.at<uchar>(y, x)) continue;
            for (int c = 0; c < 3; c++) {
                const double d = a8.at<Vec3b>(y, x)[c] - (double)b8.at<Vec3b>(y, x)[c];
                se += d * d;
            }
            n += 3;
        }
    const double mse = se / std::max(1, n);
    return mse <= 1e-12 ? 99.0 : 10 * std::log10(255.0 * 255.0 / mse);
}

}  // namespace

// A constant radiance L gives irradiance πL whatever the normal; the SH basis is orthonormal
// enough that a projection of Y_lm itself returns it.
TEST(RenderRelighting, SHConstantIrradiance) {
    SHLighting sh;
    for (auto& c : sh.coeffs)
        c = Vec3f(0, 0, 0);
    sh.coeffs[0] = Vec3f(1, 2, 3) * (1.f / 0.282095f);  // L(ω) = (1, 2, 3)
    const Vec3f e = sh.irradiance(Vec3f(0.3f, -0.4f, -0.866f) * (1.f / 0.99998f));
    EXPECT_NEAR(e[0], kPi, 1e-4);
    EXPECT_NEAR(e[2], 3 * kPi, 1e-4);
    EXPECT_NEAR(sh.radiance(Vec3f(0, 1, 0))[1], 2.f, 1e-5);
}

// The fit recovers a known light direction on an analytically rendered Lambertian sphere.
TEST(RenderRelighting, FitRecoversLightDirection) {
    const Vec3f dirs[] = {Vec3f(0.4f, -0.5f, -0.77f), Vec3f(-0.7f, -0.2f, -0.5f),
                          Vec3f(0.1f, -0.9f, -0.3f), Vec3f(0.8f, 0.3f, 0.2f)};
    for (const Vec3f& d : dirs) {
        AnalyticSphere s;
        s.to_light = d;
        s.render();
        Mat img8, lin;
        encode(s.image, img8, Response::SRGB, CV_8U);  // what a video holds
        linearize(img8, lin, Response::SRGB);
        const LightingFit fit = fitLighting(lin, s.normals, s.mask);
        const double err = angleDeg(fit.to_light, d);
        std::printf(
            "[ measured ] light (%.2f %.2f %.2f): fitted (%.3f %.3f %.3f), error %.2f deg, "
            "rms %.4f\n",
            d[0], d[1], d[2], fit.to_light[0], fit.to_light[1], fit.to_light[2], err, fit.rms);
        EXPECT_LT(err, 10.0);
        // Albedo ratios (green/red, blue/red) of the object.
        EXPECT_NEAR(fit.albedo[1] / fit.albedo[0], 0.4 / 0.7, 0.05);
        EXPECT_NEAR(fit.albedo[2] / fit.albedo[0], 0.2 / 0.7, 0.05);
    }
}

// A material edit against an analytic truth (not through the SH code that made the fit): the
// lighting fitted on an 8-bit frame of one Lambertian sphere re-renders a sphere of another
// albedo, which is compared with that sphere rendered analytically under the true light. The
// true albedo's largest channel is LightFitParams::albedo_max, the scale the fit assumes, so
// that the fitted light has the true strength. Oracle: the edit is within one 8-bit code value
// of the truth on average (the precision of its input), and far better than a baseline that
// re-renders with the same fitted strengths but a light from the camera (the usual guess when
// no light is estimated).
TEST(RenderRelighting, RelitAlbedoEditMatchesAnalyticTruth) {
    AnalyticSphere s;
    s.albedo = Vec3f(LightFitParams().albedo_max, 0.4f, 0.2f);  // RGB
    s.render();
    Mat img8, lin;
    encode(s.image, img8, Response::SRGB, CV_8U);
    linearize(img8, lin, Response::SRGB);
    const LightingFit fit = fitLighting(lin, s.normals, s.mask);

    // the edit: a different albedo (RGB)
    AnalyticSphere truth = s;
    truth.albedo = Vec3f(0.3f, 0.6f, 0.5f);
    truth.render();
    Mat truth8;
    encode(truth.image, truth8, Response::SRGB, CV_8U);
    Material m;
    m.type = Material::LAMBERTIAN;
    m.albedo = Vec3d(0.3, 0.6, 0.5);
    auto relight = [&](const Vec3f& to_light) {
        CombinationShader shader;
        shader.add(makePtr<LightShader>(m, to_light, fit.irradiance));
        ImageShader::Params ip;
        shader.add(makePtr<ImageShader>(m, nullptr, &fit.ambient, nullptr, ip));
        Mat out, out8;
        // the truth's background, so that only the sphere differs
        renderSphere(truth.image, s.c, s.r, 1e6, shader, out);
        encode(out, out8, Response::SRGB, CV_8U);
        return out8;
    };
    const Mat edit8 = relight(fit.to_light), base8 = relight(Vec3f(0, 0, -1));
    Mat inner = Mat::zeros(s.size, CV_8U);
    circle(inner, Point(cvRound(s.c.x), cvRound(s.c.y)), cvRound(s.r - 1.5f), Scalar(255), FILLED);
    const int n = countNonZero(inner);
    auto meanAbs = [&](const Mat& a) {
        Mat d;
        absdiff(a, truth8, d);
        const Scalar sum = cv::sum(d.setTo(Scalar::all(0), ~inner));
        return (sum[0] + sum[1] + sum[2]) / (3.0 * n);
    };
    const double e_edit = meanAbs(edit8), e_base = meanAbs(base8);
    std::printf(
        "[ measured ] albedo edit vs analytic truth over %d pixels: mean |error| %.3f "
        "code values (PSNR %.2f dB); headlight baseline %.3f (%.2f dB)\n",
        n, e_edit, psnrMasked(edit8, truth8, inner), e_base, psnrMasked(base8, truth8, inner));
    EXPECT_LT(e_edit, 1.0);
    EXPECT_LT(e_edit, e_base);
}

// A mirror sphere shows a bright spot of the environment where the mirror law says: the
// normal at the spot bisects the view direction and the spot's direction.
TEST(RenderRelighting, MirrorReflectionPosition) {
    const Matx33f cam_from_world(1, 0, 0, 0, 0, -1, 0, 1, 0);  // level camera, world z up
    Mat eq(128, 256, CV_32FC3, Scalar::all(0.05));
    EnvironmentMap probe(eq);
    const Vec3f d_cam =
        Vec3f(0.35f, -0.45f, -0.82f) * (1.f / (float)norm(Vec3f(0.35f, -0.45f, -0.82f)));
    const Vec3f d_world = cam_from_world.t() * d_cam;
    const Point2f spot = probe.directionToPixel(d_world);
    circle(eq, Point(cvRound(spot.x), cvRound(spot.y)), 2, Scalar::all(50), FILLED);
    EnvironmentMap env(eq);
    const Size size(96, 96);
    const Point2f c(47.5f, 47.5f);
    const float r = 40;
    for (const char* name : {"mirror", "chrome"}) {
        const Material m = Material::preset(name);
        ImageShader::Params ip;
        ip.world_from_camera = cam_from_world.t();
        ImageShader shader(m, &env, nullptr, nullptr, ip);
        Mat bg(size, CV_32FC3, Scalar::all(0)), out, shaded;
        renderSphere(bg, c, r, 1e6, shader, out, shaded);  // focal 1e6: wo = (0, 0, −1)
        Mat lum;
        cvtColor(shaded, lum, COLOR_BGR2GRAY);
        Point peak;
        minMaxLoc(lum, nullptr, nullptr, nullptr, &peak);
        // Centroid of the bright spot.
        double sx = 0, sy = 0, sw = 0;
        for (int y = 0; y < size.height; y++)
            for (int x = 0; x < size.width; x++) {
                const float v = lum.at<float>(y, x);
                if (v > 1.f) {
                    sx += v * x;
                    sy += v * y;
                    sw += v;
                }
            }
        ASSERT_GT(sw, 0) << name;
        const Vec3f h = (d_cam + Vec3f(0, 0, -1)) * (1.f / (float)norm(d_cam + Vec3f(0, 0, -1)));
        const Point2f pred(c.x + r * h[0], c.y + r * h[1]);
        const double err = std::hypot(sx / sw - pred.x, sy / sw - pred.y);
        std::printf(
            "[ measured ] %s: spot at (%.2f, %.2f), mirror law (%.2f, %.2f), error %.2f px\n", name,
            sx / sw, sy / sw, pred.x, pred.y, err);
        EXPECT_LT(err, 1.5) << name;
    }
}

// A glass ball is a ball lens: a marker behind it, left of its centre, appears on the right.
TEST(RenderRelighting, GlassInvertsBackground) {
    const Size size(120, 96);
    Mat bg(size, CV_32FC3, Scalar::all(0.2));
    const Point2f c(59.5f, 47.5f);
    const float r = 30;
    // Red marker left of the centre, behind the ball.
    rectangle(bg, Rect(cvRound(c.x) - 14, cvRound(c.y) - 4, 8, 8), Scalar(0, 0, 1), FILLED);
    Mat eq(64, 128, CV_32FC3, Scalar::all(0.2));
    EnvironmentMap env(eq);
    const double focal = Camera::focalFromFov(size.width, 60);
    SphereRefraction refr;
    refr.background = bg;
    refr.center = c;
    refr.radius = r;
    refr.focal = focal;
    ImageShader::Params ip;
    ImageShader shader(Material::preset("glass"), &env, nullptr, &refr, ip);
    Mat out, shaded;
    renderSphere(bg, c, r, focal, shader, out, shaded);
    double left = 0, right = 0, sx = 0;
    for (int y = 0; y < size.height; y++)
        for (int x = 0; x < size.width; x++) {
            if (std::hypot(x - c.x, y - c.y) > r - 1) continue;
            const Vec3f v = shaded.at<Vec3f>(y, x);
            const float red = std::max(0.f, v[2] - 0.5f * (v[0] + v[1]));
            (x < c.x ? left : right) += red;
            sx += red * x;
        }
    ASSERT_GT(left + right, 0);
    std::printf(
        "[ measured ] glass: red seen right of centre %.1f%%, centroid x %.1f (ball "
        "centre %.1f, marker centre %.1f)\n",
        100 * right / (left + right), sx / (left + right), c.x, c.x - 10);
    EXPECT_GT(right / (left + right), 0.9);
    EXPECT_GT(sx / (left + right), c.x + 2);
}

// Edge coverage: the summed coverage of a disk is its area.
TEST(RenderRelighting, DiskCoverageArea) {
    for (float r : {5.3f, 17.f, 40.25f}) {
        const Point2f c(50.3f, 49.8f);
        double sum = 0;
        for (int y = 0; y < 100; y++)
            for (int x = 0; x < 100; x++)
                sum += diskCoverage((float)x, (float)y, c, r);
        EXPECT_NEAR(sum / (CV_PI * r * r), 1.0, 0.01) << r;
    }
}

// A narrow area light on a Lambertian surface gives what the point-like light gives.
TEST(RenderRelighting, AreaLightMatchesDistantLight) {
    Material m;
    m.type = Material::LAMBERTIAN;
    m.albedo = Vec3d(0.5, 0.6, 0.7);
    const Vec3f d(0.3f, -0.6f, -0.74f);
    LightShader point(m, d, Vec3f(2, 2, 2));
    AreaLightShader area(m, d, Vec3f(2, 2, 2), 0.05f, 16);
    double max_rel = 0;
    for (int i = 0; i < 50; i++) {
        const float a = i * 0.37f, b = 0.2f + i * 0.02f;
        ShadingPoint p;
        p.n = Vec3f(std::sin(b) * std::cos(a), std::sin(b) * std::sin(a), -std::cos(b));
        p.wo = Vec3f(0, 0, -1);
        p.pixel = Point2f((float)i, 0.f);
        const Vec3f lp = point.shade(p), la = area.shade(p);
        if (lp[1] > 0.05f) max_rel = std::max(max_rel, std::abs(la[1] - lp[1]) / (double)lp[1]);
    }
    std::printf("[ measured ] area vs distant light: max relative difference %.4f\n", max_rel);
    EXPECT_LT(max_rel, 0.02);
}

// The area light on a glossy plastic (MIS near the highlight, light sampling alone away from
// it) agrees with a brute-force quadrature of f·cos·L over the light's cone.
TEST(RenderRelighting, AreaLightPlasticMatchesQuadrature) {
    const Material m = Material::preset("blue");
    const Ptr<Bsdf> bsdf = Bsdf::create(m);
    const Vec3f d = Vec3f(0.3f, -0.5f, -0.81f) * (1.f / (float)norm(Vec3f(0.3f, -0.5f, -0.81f)));
    const float half = 0.05f, cos_max = std::cos(half);
    const Vec3f E(2, 2, 2);
    AreaLightShader area(m, d, E, half, 1024);
    const float omega = 2 * kPi * (1 - cos_max);
    double worst = 0;
    for (int i = 0; i < 12; i++) {
        // Normals from the highlight's (half-vector) towards the rim.
        const Vec3f h = (d + Vec3f(0, 0, -1)) * (1.f / (float)norm(d + Vec3f(0, 0, -1)));
        const float t = i * 0.06f;
        Vec3f n = h * std::cos(t) + Vec3f(1, 0, 0) * std::sin(t);
        n *= 1.f / (float)norm(n);
        ShadingPoint p;
        p.n = n;
        p.wo = Vec3f(0, 0, -1);
        p.pixel = Point2f((float)i, 3.f);
        const Vec3f got = area.shade(p);
        // Quadrature: a fine polar grid over the cone, in the normal's local frame.
        Vec3f t1 = n.cross(Vec3f(0, 1, 0));
        t1 *= 1.f / (float)norm(t1);
        const Vec3f t2 = n.cross(t1);
        Vec3f u1 = d.cross(Vec3f(0, 1, 0));
        u1 *= 1.f / (float)norm(u1);
        const Vec3f u2 = d.cross(u1);
        const Vec3f wo_l(p.wo.dot(t1), p.wo.dot(t2), p.wo.dot(n));
        double ref = 0;
        const int NR = 200, NP = 200;
        for (int a = 0; a < NR; a++)
            for (int b = 0; b < NP; b++) {
                const float z = 1 - (a + 0.5f) / NR * (1 - cos_max);
                const float s = std::sqrt(1 - z * z), ph = 2 * kPi * (b + 0.5f) / NP;
                const Vec3f w = d * z + u1 * (s * std::cos(ph)) + u2 * (s * std::sin(ph));
                const Vec3f wi_l(w.dot(t1), w.dot(t2), w.dot(n));
                if (wi_l[2] <= 0) continue;
                ref += bsdf->eval(wo_l, wi_l, bsdf->defaultDiffuse())[2] * wi_l[2];
            }
        ref *= (double)E[2] / omega * omega / (NR * NP);
        const double rel = std::abs(got[2] - ref) / std::max(ref, 1e-3);
        worst = std::max(worst, rel);
    }
    std::printf("[ measured ] plastic area light vs quadrature: worst relative error %.4f\n",
                worst);
    // Measured 0.34 % (at the highlight, where MIS samples are noisy; 64 samples gave 6 %).
    EXPECT_LT(worst, 0.02);
}
