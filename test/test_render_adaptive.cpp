// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Speed features of the renderer: adaptive sampling of differential renders (determinism,
// schedule, unbiasedness against uniform sampling) and texture filtering on secondary hits
// (mip level selection, unchanged camera hits, image unchanged beyond noise).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::ScratchDir;

namespace {

/** Room 4×4×3 m with a ceiling light and a grey cube standing on the floor, seen from above. */
Scene cubeRoom(const std::string& cube_obj, Size size) {
    Scene s;
    s.image_size = size;
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    Light l;
    l.type = Light::POLYGON;  // counter-clockwise seen from below
    l.corners = {Vec3d(1.0, 0.3, 3), Vec3d(1.6, 0.3, 3), Vec3d(1.6, -0.3, 3), Vec3d(1.0, -0.3, 3)};
    l.radiance = Vec3d(20, 20, 20);
    s.lights = {l};
    SceneObject o;
    o.mesh = cube_obj;
    o.world_from_object = vbme_test::placement(0.6, Vec3d(0, 0, 0.3));
    o.has_material = true;
    o.material = vbme_test::lambertian(Vec3d(0.5, 0.5, 0.5));
    s.objects = {o};
    s.camera = vbme_test::lookAt(Vec3d(0, -1.8, 1.7), Vec3d(0, 0, 0.2), size.width * 0.6, size);
    s.camera.response = Response::SRGB;
    return s;
}

/** A W×W 8-bit image of c×c-texel black and white checks. */
Mat checker(int W, int c) {
    Mat m(W, W, CV_8UC3);
    for (int y = 0; y < W; ++y)
        for (int x = 0; x < W; ++x)
            m.at<Vec3b>(y, x) = ((x / c + y / c) % 2) ? Vec3b(255, 255, 255) : Vec3b(0, 0, 0);
    return m;
}

}  // namespace

// Adaptive sampling: bitwise identical for 1 and 2 threads; untouched pixels stop at the
// minimum with diff exactly 0; touched pixels take more; the stats count the samples taken.
TEST(RenderAdaptive, DeterministicScheduleAndExactZeros) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    const Scene s = cubeRoom(dir / "cube.obj", Size(40, 30));
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 64;
    p.max_depth = 3;
    p.tile_size = 8;
    p.adaptive_min_spp = 4;
    p.adaptive_error = 1.0f;
    p.adaptive_radius = 0;  // untouched pixels go on only by the roulette
    RenderImages w1, n1, w2, n2;
    p.threads = 1;
    const RenderStats st1 = Renderer::create(p)->renderDifferential(*rs, s.camera, w1, n1);
    p.threads = 2;
    const RenderStats st2 = Renderer::create(p)->renderDifferential(*rs, s.camera, w2, n2);
    EXPECT_EQ(norm(w1.color, w2.color, NORM_INF), 0.0);
    EXPECT_EQ(norm(n1.color, n2.color, NORM_INF), 0.0);
    ASSERT_FALSE(w1.samples.empty());
    EXPECT_EQ(norm(w1.samples, w2.samples, NORM_INF), 0.0);
    EXPECT_EQ(st1.paths, st2.paths);
    EXPECT_EQ(st1.paths, (int64)sum(w1.samples)[0]);
    int untouched = 0, stopped = 0, more = 0;
    for (int y = 0; y < w1.samples.rows; ++y)
        for (int x = 0; x < w1.samples.cols; ++x) {
            const float n = w1.samples.at<float>(y, x);
            EXPECT_GE(n, 4.f);
            EXPECT_LE(n, 64.f);
            if (w1.object.at<float>(y, x) == 0.f) {
                // no path met the object: the difference is exactly 0
                ++untouched;
                stopped += n == 4.f;
                EXPECT_EQ(w1.color.at<Vec3f>(y, x), n1.color.at<Vec3f>(y, x));
            } else if (n > 4.f) {
                ++more;
            }
        }
    // Untouched pixels stop at the minimum except for the roulette's share (0.25).
    EXPECT_EQ(stopped, st1.pixels_untouched);
    EXPECT_GT(untouched, 0);
    EXPECT_GT(stopped, untouched / 2);
    EXPECT_GT(more, 20);
    // A tighter target costs more samples.
    p.adaptive_error = 0.25f;
    RenderImages w3, n3;
    const RenderStats st3 = Renderer::create(p)->renderDifferential(*rs, s.camera, w3, n3);
    EXPECT_GT(st3.paths, st1.paths);
    // Off: no sample map, every pixel at spp.
    p.adaptive_min_spp = 0;
    p.spp = 4;
    RenderImages w4, n4;
    const RenderStats st4 = Renderer::create(p)->renderDifferential(*rs, s.camera, w4, n4);
    EXPECT_TRUE(w4.samples.empty());
    EXPECT_EQ(st4.paths, int64(40 * 30 * 4));
}

namespace {

/** Two-sample t statistic of the image-mean difference, adaptive (8 … 64 spp) against uniform
16 spp, over K independent seeds each. */
double adaptiveBiasT(const RenderScene& rs, const Scene& s, float roulette, int radius,
                     double* rel) {
    const int K = 6;
    std::vector<double> ma, mu;
    double spp_adaptive = 0;
    for (int k = 0; k < K; ++k) {
        Renderer::Params p;
        p.max_depth = 3;
        p.seed = 1000 + k;
        p.spp = 64;
        p.adaptive_min_spp = 8;
        p.adaptive_error = 0.5f;
        p.adaptive_roulette = roulette;
        p.adaptive_radius = radius;
        RenderImages w, n;
        const RenderStats st = Renderer::create(p)->renderDifferential(rs, s.camera, w, n);
        spp_adaptive += double(st.paths) / (24 * 18) / K;
        ma.push_back(mean(Mat(w.color - n.color).reshape(1))[0]);
        p.adaptive_min_spp = 0;
        p.spp = 16;
        p.seed = 2000 + k;
        Renderer::create(p)->renderDifferential(rs, s.camera, w, n);
        mu.push_back(mean(Mat(w.color - n.color).reshape(1))[0]);
    }
    auto meanVar = [](const std::vector<double>& v, double& m, double& var) {
        m = 0;
        for (double x : v)
            m += x / v.size();
        var = 0;
        for (double x : v)
            var += (x - m) * (x - m) / (v.size() - 1);
    };
    double m1, v1, m2, v2;
    meanVar(ma, m1, v1);
    meanVar(mu, m2, v2);
    EXPECT_LT(m2, 0.0);  // the cube's shadow darkens the floor on average
    const double t = (m1 - m2) / std::sqrt(v1 / K + v2 / K + 1e-30);
    std::printf(
        "roulette %.2f, radius %d: mean diff adaptive %.6f (%.1f spp), uniform 16 spp %.6f, "
        "t = %.2f\n",
        roulette, radius, m1, spp_adaptive, m2, t);
    *rel = std::abs(m1 - m2) / std::abs(m2);
    return t;
}

}  // namespace

// The adaptive estimate of the difference layer agrees with uniform sampling within noise:
// the image-mean difference over independent seeds, compared by a two-sample t statistic.
// Without the roulette and the neighbourhood (untouched pixels always stop at the minimum) the
// same test sees the bias of the missed rare paths.
TEST(RenderAdaptive, UnbiasedAgainstUniformWithinNoise) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    const Scene s = cubeRoom(dir / "cube.obj", Size(24, 18));
    Ptr<RenderScene> rs = RenderScene::create(s);
    double rel;
    const Renderer::Params def;
    const double t = adaptiveBiasT(*rs, s, def.adaptive_roulette, def.adaptive_radius, &rel);
    EXPECT_LT(std::abs(t), 4.0);
    EXPECT_LT(rel, 0.06);
    const double t1 = adaptiveBiasT(*rs, s, def.adaptive_roulette, 0, &rel);  // roulette only
    EXPECT_LT(std::abs(t1), 4.0);
    const double t0 = adaptiveBiasT(*rs, s, 0.f, 0, &rel);
    EXPECT_GT(std::abs(t0), 4.0);
}

// Mip level selection: 4×4-texel checks in a 64² texture stay black and white up to a
// footprint of 4 texels (level 2: one check per texel) and average to grey from 8 (level 3).
TEST(RenderTextureFilter, MipLevelSelection) {
    Mat img;
    checker(64, 4).convertTo(img, CV_32FC3, 1.0 / 255);
    const Ptr<Texture> t = Texture::createImage(img, Texture::WRAP_REPEAT);
    const Vec2f uv(6.f / 64, 1.f - 2.f / 64);  // centre of the white check [4, 8) × [0, 4)
    const Vec3f full = t->eval(uv);
    EXPECT_NEAR(full[0], 1.f, 1e-6f);
    EXPECT_EQ(t->evalFiltered(uv, 0.f), full);
    EXPECT_EQ(t->evalFiltered(uv, 1.9f / 64), full);  // below 2 texels: the full image
    for (float texels : {2.f, 3.f, 4.f, 7.9f}) {
        const Vec3f v = t->evalFiltered(uv, texels / 64);
        EXPECT_NEAR(v[0], 1.f, 1e-6f) << texels;
        EXPECT_NEAR(v[2], 1.f, 1e-6f) << texels;
    }
    for (float texels : {8.f, 16.f, 1000.f}) {
        const Vec3f v = t->evalFiltered(uv, texels / 64);
        // grey: the linear mean 0.5 stored as 8-bit sRGB (within half a code value)
        EXPECT_NEAR(v[1], 0.5f, 0.003f) << texels;
    }
    // Values above 1 keep float levels: no clipping.
    const Ptr<Texture> hdr = Texture::createImage(Mat(img * 4.0), Texture::WRAP_REPEAT);
    EXPECT_NEAR(hdr->evalFiltered(uv, 8.f / 64)[0], 2.f, 1e-5f);
    // A constant texture ignores the footprint.
    EXPECT_EQ(Texture::createConstant(Vec3f(0.1f, 0.2f, 0.3f))->evalFiltered(uv, 0.5f),
              Vec3f(0.1f, 0.2f, 0.3f));
}

// Filtering after diffuse bounces leaves the camera-ray hits as they were (albedo AOV bitwise)
// and changes the image of a finely textured room by less than the noise of another seed.
TEST(RenderTextureFilter, CameraHitsUnchangedImageWithinNoise) {
    ScratchDir dir;
    imwrite(dir / "checks.png", checker(256, 1));
    Scene s;
    s.image_size = Size(32, 24);
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    for (const char* f : {"floor", "ceiling", "left", "right", "front", "back"})
        s.room.textures[f] = dir / "checks.png";
    Light l;
    l.type = Light::POINT;
    l.position = Vec3d(0.5, 0.5, 2.5);
    l.intensity = Vec3d(20, 20, 20);
    s.lights = {l};
    s.camera = vbme_test::lookAt(Vec3d(0, -1.8, 1.7), Vec3d(0, 0, 0.5), 20, s.image_size);
    s.camera.response = Response::SRGB;
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 64;
    p.max_depth = 4;
    RenderImages off, on, other;
    const RenderStats st_off = Renderer::create(p)->render(*rs, s.camera, off);
    p.texture_cone = 0.1f;
    Renderer::create(p)->render(*rs, s.camera, on);
    p.texture_cone = 0.f;
    p.seed = 99;
    Renderer::create(p)->render(*rs, s.camera, other);
    EXPECT_EQ(norm(off.albedo, on.albedo, NORM_INF), 0.0);
    const double change = norm(off.color, on.color, NORM_L2);
    const double noise = norm(off.color, other.color, NORM_L2);
    const double m_off = mean(off.color.reshape(1))[0], m_on = mean(on.color.reshape(1))[0];
    std::printf(
        "filtered vs full: L2 %.4f, another seed: L2 %.4f; means %.5f vs %.5f (%lld "
        "rays)\n",
        change, noise, m_on, m_off, (long long)st_off.rays);
    EXPECT_GT(change, 0.0);  // the filter was used
    EXPECT_LT(change, noise);
    EXPECT_NEAR(m_on, m_off, 0.02 * m_off);
}
