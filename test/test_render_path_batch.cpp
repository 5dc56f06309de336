// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Renderer::Params::path_batch: a pixel's paths advanced together stage by stage (shadow rays in
// packets) give the image of one path at a time, bit for bit.
#include <gtest/gtest.h>

#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::ScratchDir;

namespace {

/** A closed 4×4×3 m room with a glass ball (delta BSDF, absorption), a glossy Phong cube
(two lobes) and a matte cube; lit by a point light and, when @p area, a ceiling polygon
light too (two lights: the light choice is drawn; emission can be hit). */
Scene batchScene(const std::string& dir, bool area, Size size) {
    vbme_test::writeCubeObj(dir + "/cube.obj", "", "", 1.0, true);
    vbme_test::writeSphereObj(dir + "/ball.obj", 12, 24);
    Scene s;
    s.image_size = size;
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    Light point;
    point.type = Light::POINT;
    point.position = Vec3d(-0.8, -0.5, 2.2);
    point.intensity = Vec3d(6, 5, 4);
    s.lights = {point};
    if (area) {
        Light l;
        l.type = Light::POLYGON;
        l.corners = {Vec3d(0.6, 0.3, 3), Vec3d(1.2, 0.3, 3), Vec3d(1.2, -0.3, 3),
                     Vec3d(0.6, -0.3, 3)};  // counter-clockwise seen from below
        l.radiance = Vec3d(15, 15, 15);
        s.lights.push_back(l);
    }
    SceneObject glass;
    glass.mesh = dir + "/ball.obj";
    glass.world_from_object = vbme_test::placement(0.35, Vec3d(0.3, 0.2, 0.35));
    glass.has_material = true;
    glass.material.type = Material::DIELECTRIC;
    glass.material.ior = 1.5;
    glass.material.absorption = Vec3d(0.5, 0.2, 0.1);
    SceneObject glossy;
    glossy.mesh = dir + "/cube.obj";
    glossy.world_from_object = vbme_test::placement(0.5, Vec3d(-0.6, 0.5, 0));
    glossy.has_material = true;
    glossy.material.type = Material::PHONG;
    glossy.material.kd = Vec3d(0.4, 0.2, 0.1);
    glossy.material.ks = Vec3d(0.3, 0.3, 0.3);
    glossy.material.exponent = 20;
    SceneObject matte;
    matte.mesh = dir + "/cube.obj";
    matte.world_from_object = vbme_test::placement(0.4, Vec3d(0.9, -0.6, 0));
    matte.has_material = true;
    matte.material = vbme_test::lambertian(Vec3d(0.2, 0.6, 0.3));
    s.objects = {glass, glossy, matte};
    s.camera = vbme_test::lookAt(Vec3d(0, -1.9, 1.6), Vec3d(0, 0.3, 0.4), size.width * 0.6, size);
    return s;
}

void expectSameImages(const RenderImages& a, const RenderImages& b, const std::string& what) {
    ASSERT_EQ(a.color.size(), b.color.size()) << what;
    EXPECT_EQ(norm(a.color, b.color, NORM_INF), 0.0) << what;
    EXPECT_EQ(a.albedo.empty(), b.albedo.empty()) << what;
    if (!a.albedo.empty()) {
        EXPECT_EQ(norm(a.albedo, b.albedo, NORM_INF), 0.0) << what;
        EXPECT_EQ(norm(a.normal, b.normal, NORM_INF), 0.0) << what;
        EXPECT_EQ(norm(a.object, b.object, NORM_INF), 0.0) << what;
        EXPECT_EQ(norm(a.mask, b.mask, NORM_INF), 0.0) << what;
    }
}

}  // namespace

// Batches of 16 (the default) and of 5 (13 spp: batches end mid-packet) against one path at a
// time, 1 and 2 threads, Embree's robust mode on and off, with and without an area light (a
// drawn light choice, emission that paths hit), PATH and REFERENCE, clamping, AOVs.
TEST(RenderPathBatch, SameBitsAsOnePathAtATime) {
    ScratchDir dir;
    const Size size(24, 16);
    int compared = 0;
    for (const bool area : {false, true}) {
        const Scene s = batchScene(dir.path().string(), area, size);
        for (const bool robust : {true, false}) {
            RenderScene::Params sp;
            sp.robust = robust;
            const Ptr<RenderScene> rs = RenderScene::create(s, sp);
            for (const int integrator : {(int)Renderer::PATH, (int)Renderer::REFERENCE}) {
                if (integrator == Renderer::REFERENCE && !(area && robust)) continue;
                Renderer::Params p;
                p.spp = 13;
                p.max_depth = 4;
                p.seed = 5;
                p.integrator = integrator;
                p.aovs = false;
                p.clamp = area ? 20.f : 0.f;
                p.path_batch = 0;
                p.threads = 1;
                RenderImages ref;
                const RenderStats st_ref = Renderer::create(p)->render(*rs, s.camera, ref);
                ASSERT_GT(norm(ref.color, NORM_INF), 0.0);
                for (const int batch : {16, 5})
                    for (const int threads : {1, 2}) {
                        p.path_batch = batch;
                        p.threads = threads;
                        RenderImages img;
                        const RenderStats st = Renderer::create(p)->render(*rs, s.camera, img);
                        const std::string what =
                            format("area %d robust %d integrator %d batch %d threads %d", (int)area,
                                   (int)robust, integrator, batch, threads);
                        expectSameImages(ref, img, what);
                        EXPECT_EQ(st.rays, st_ref.rays) << what;
                        EXPECT_EQ(st.paths, st_ref.paths) << what;
                        ++compared;
                    }
            }
        }
    }
    EXPECT_EQ(compared, 5 * 4);
}

// With AOVs: a render without the objects, and one with them, where the shadow rays must tell
// whether an object blocks them (closest-hit rays; the `object` image): the colour and every
// AOV the same bit for bit.
TEST(RenderPathBatch, AovsSameBits) {
    ScratchDir dir;
    const Scene s = batchScene(dir.path().string(), true, Size(20, 14));
    const Ptr<RenderScene> rs = RenderScene::create(s);
    for (const bool with_objects : {false, true}) {
        Renderer::Params p;
        p.spp = 8;
        p.max_depth = 3;
        p.with_objects = with_objects;
        p.threads = 2;
        p.path_batch = 0;
        RenderImages ref, img;
        Renderer::create(p)->render(*rs, s.camera, ref);
        p.path_batch = 16;
        Renderer::create(p)->render(*rs, s.camera, img);
        ASSERT_FALSE(img.albedo.empty());
        EXPECT_GT(norm(img.albedo, NORM_INF), 0.0);
        if (with_objects) {
            EXPECT_GT(norm(img.object, NORM_INF), 0.0);  // objects were met
        }
        expectSameImages(ref, img, with_objects ? "with objects" : "without objects");
    }
}

// Renderer::Params::batch_simd: the batch's vector stage (AVX2 where the processor has it: Sobol
// draws, Lambertian directions) against the batch's scalar code, bit for bit (1 and 2 threads,
// batches of 16 and 5, one and two lights, AOVs). Without AVX2 both are the scalar code.
TEST(RenderPathBatch, SimdSameBitsAsScalar) {
    ScratchDir dir;
    int compared = 0;
    for (const bool area : {false, true}) {
        const Scene s = batchScene(dir.path().string(), area, Size(24, 16));
        const Ptr<RenderScene> rs = RenderScene::create(s);
        for (const int batch : {16, 5})
            for (const int threads : {1, 2}) {
                Renderer::Params p;
                p.spp = 13;
                p.max_depth = 4;
                p.seed = 3;
                p.aovs = area;
                p.with_objects = area;
                p.path_batch = batch;
                p.threads = threads;
                p.batch_simd = false;
                RenderImages ref, img;
                const RenderStats st_ref = Renderer::create(p)->render(*rs, s.camera, ref);
                ASSERT_GT(norm(ref.color, NORM_INF), 0.0);
                p.batch_simd = true;
                const RenderStats st = Renderer::create(p)->render(*rs, s.camera, img);
                const std::string what =
                    format("area %d batch %d threads %d", (int)area, batch, threads);
                expectSameImages(ref, img, what);
                EXPECT_EQ(st.rays, st_ref.rays) << what;
                ++compared;
            }
    }
    EXPECT_EQ(compared, 8);
}
