// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// read/write/check of the render module's params structs: every field survives a round trip,
// unknown keys and out-of-range values are refused by name.
#include <gtest/gtest.h>

#include "opencv2/vbme/render/albedo.hpp"
#include "opencv2/vbme/render/differential.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "opencv2/vbme/render/integrator.hpp"
#include "opencv2/vbme/render/light_estimation.hpp"
#include "opencv2/vbme/render/relighting.hpp"
#include "opencv2/vbme/render/room_texture.hpp"
#include "opencv2/vbme/render/scene.hpp"
#include "params_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using namespace vbme_test;

namespace {

Renderer::Params changedRenderer() {
    Renderer::Params p;
    p.spp = 8;
    p.max_depth = 4;
    p.seed = 99;
    p.threads = 2;
    p.integrator = Renderer::REFERENCE;
    p.with_objects = false;
    p.filter = FILTER_GAUSSIAN;
    p.clamp = 10.f;
    p.rr_depth = 5;
    p.tile_size = 32;
    p.aovs = false;
    p.light_selection = Renderer::LIGHTS_POWER;
    p.adaptive_min_spp = 4;
    p.adaptive_error = 1.f;
    p.texture_cone = 0.05f;
    p.adaptive_roulette = 0.5f;
    p.adaptive_radius = 3;
    p.path_batch = 4;
    return p;
}

}  // namespace

TEST(RenderParams, RendererParams) {
    expectRoundTrip(changedRenderer());
    expectUnknownKeyRefused<Renderer::Params>("max_depth");
    Renderer::Params bad;
    bad.spp = 0;
    expectRejected(bad, "spp");
    bad = Renderer::Params();
    bad.adaptive_roulette = 2.f;
    expectRejected(bad, "adaptive_roulette");
    // create() refuses through check(), naming the field
    bad = Renderer::Params();
    bad.tile_size = 0;
    EXPECT_NE(thrownBy([&] { Renderer::create(bad); }).find("tile_size"), std::string::npos);
}

TEST(RenderParams, DifferentialRendererParams) {
    DifferentialRenderer::Params p;
    p.render = changedRenderer();
    p.method = DifferentialRenderer::TWO_PASS;
    p.independent = true;
    p.coverage = COVERAGE_PRIMARY_RAYS;
    p.coverage_supersampling = 4;
    p.coverage_occlusion = false;
    expectRoundTrip(p);
    expectUnknownKeyRefused<DifferentialRenderer::Params>("coverage");
    DifferentialRenderer::Params bad;
    bad.coverage_supersampling = 9;
    expectRejected(bad, "coverage_supersampling");
    bad = DifferentialRenderer::Params();
    bad.render.max_depth = 0;
    expectRejected(bad, "max_depth");
}

TEST(RenderParams, CompositeParams) {
    CompositeParams p;
    p.alpha = 0.5f;
    p.response = Response::LINEAR;
    p.shadows = CompositeParams::SHADOWS_RATIO;
    expectRoundTrip(p);
    expectUnknownKeyRefused<CompositeParams>("alpha");
    CompositeParams bad;
    bad.alpha = std::numeric_limits<float>::infinity();
    EXPECT_NE(thrownBy([&] { bad.check(); }).find(".alpha = "), std::string::npos);
}

TEST(RenderParams, ExposureParams) {
    ExposureParams p;
    p.sensitivity = 100.f;
    p.fstop = 4.f;
    p.exposure = 0.5f;
    p.gamma = 2.4f;
    expectRoundTrip(p);
    expectUnknownKeyRefused<ExposureParams>("fstop");
    ExposureParams bad;
    bad.fstop = 0;
    expectRejected(bad, "fstop");
}

TEST(RenderParams, LightEstimationParams) {
    LightEstimationParams p;
    p.method = LightEstimationParams::HILL_CLIMB;
    p.render_size = Size(40, 30);
    p.spp = 8;
    p.max_depth = 2;
    p.max_iterations = 3;
    p.tolerance = 1e-2;
    p.clip_level = 0.9;
    p.per_frame_gain = true;
    p.seed = 5;
    expectRoundTrip(p);
    expectUnknownKeyRefused<LightEstimationParams>("render_size");
    LightEstimationParams bad;
    bad.clip_level = 0;
    expectRejected(bad, "clip_level");
}

TEST(RenderParams, AlbedoParams) {
    RetinexParams r;
    r.threshold = 0.1;
    r.max_side = 128;
    r.chroma_threshold = 0.05;
    r.white = 0.8;
    r.white_percentile = 95.0;
    expectRoundTrip(r);
    expectUnknownKeyRefused<RetinexParams>("white");
    RetinexParams bad_r;
    bad_r.white_percentile = 0;
    expectRejected(bad_r, "white_percentile");

    IrradianceAlbedoParams i;
    i.grid = 16;
    i.spp = 8;
    i.iterations = 2;
    i.seed = 4;
    expectRoundTrip(i);
    expectUnknownKeyRefused<IrradianceAlbedoParams>("grid");
    IrradianceAlbedoParams bad_i;
    bad_i.iterations = 0;
    expectRejected(bad_i, "iterations");
}

TEST(RenderParams, RoomTextureAndSceneParams) {
    RoomTextureParams t;
    t.texel_scale = 0.5;
    t.min_size = 32;
    t.max_size = 1024;
    t.accumulate = false;
    expectRoundTrip(t);
    expectUnknownKeyRefused<RoomTextureParams>("texel_scale");
    RoomTextureParams bad_t;
    bad_t.max_size = 16;  // below min_size
    expectRejected(bad_t, "max_size");

    RenderScene::Params s;
    s.room_albedo = Vec3f(0.5f, 0.25f, 0.75f);
    s.room_emissive = true;
    s.robust = true;
    s.retrace_leaks = false;
    expectRoundTrip(s);
    expectUnknownKeyRefused<RenderScene::Params>("room_albedo");
    RenderScene::Params bad_s;
    bad_s.room_albedo = Vec3f(-0.5f, 0.5f, 0.5f);
    expectRejected(bad_s, "room_albedo");
}

TEST(RenderParams, LightFitAndImageShaderParams) {
    LightFitParams f;
    f.albedo_max = 0.5f;
    f.min_facing = 0.25f;
    f.max_value = 0.9f;
    f.max_pixels = 1000;
    f.ridge = 0.01f;
    f.fixed_direction = true;
    f.fixed_to_light = Vec3f(0, 1, 0);
    expectRoundTrip(f);
    expectUnknownKeyRefused<LightFitParams>("ridge");
    LightFitParams bad_f;
    bad_f.albedo_max = 0;
    expectRejected(bad_f, "albedo_max");

    ImageShader::Params s;
    s.samples = 4;
    s.mirror_roughness = 0.2f;
    s.sharp_pdf = 4.f;
    s.world_from_camera = Matx33f(0, -1, 0, 1, 0, 0, 0, 0, 1);  // 90° about z
    expectRoundTrip(s);
    expectUnknownKeyRefused<ImageShader::Params>("samples");
    ImageShader::Params bad_s;
    bad_s.world_from_camera = Matx33f::diag(Vec3f(2, 1, 1));  // not a rotation
    expectRejected(bad_s, "world_from_camera");
}
