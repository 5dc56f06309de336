// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <cstring>

#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::ScratchDir;

namespace {

Light constantEnvironment(const Vec3d& radiance) {
    Light l;
    l.type = Light::ENVIRONMENT;
    l.radiance = radiance;
    return l;
}

SceneObject sphere(const std::string& mesh, double r, const Vec3d& c, const Material& m) {
    SceneObject o;
    o.mesh = mesh;
    o.world_from_object = vbme_test::placement(r, c);
    o.has_material = true;
    o.material = m;
    return o;
}

// A closed room with a large ceiling light and a sphere: indirect light everywhere.
Scene roomScene(const std::string& dir) {
    vbme_test::writeSphereObj(dir + "/sphere.obj", 24, 48);
    Scene s;
    s.image_size = Size(24, 18);
    s.has_room = true;
    s.room.min = Vec3d(-1.5, -1.5, 0);
    s.room.max = Vec3d(1.5, 1.5, 2.5);
    Light l;
    l.type = Light::POLYGON;
    l.corners = {Vec3d(-0.8, 0.8, 2.5), Vec3d(0.8, 0.8, 2.5), Vec3d(0.8, -0.8, 2.5),
                 Vec3d(-0.8, -0.8, 2.5)};
    l.radiance = Vec3d(4, 4, 4);
    Light dim;  // a small weak light on the back wall (y = 1.5), facing −y
    dim.type = Light::POLYGON;
    dim.corners = {Vec3d(0.1, 1.5, 1.0), Vec3d(0.1, 1.5, 1.4), Vec3d(-0.3, 1.5, 1.4),
                   Vec3d(-0.3, 1.5, 1.0)};
    dim.radiance = Vec3d(0.5, 1.0, 2.0);
    s.lights = {l, dim};
    s.objects = {sphere(dir + "/sphere.obj", 0.5, Vec3d(0.2, 0.3, 0.5),
                        vbme_test::lambertian(Vec3d(0.7, 0.5, 0.3)))};
    s.camera = vbme_test::lookAt(Vec3d(0, -1.4, 1.2), Vec3d(0.1, 0.3, 0.6), 20, s.image_size);
    return s;
}

}  // namespace

// White furnace: an albedo-1 Lambertian sphere inside a constant environment is invisible —
// every pixel renders the environment's radiance.
TEST(RenderIntegrator, WhiteFurnace) {
    ScratchDir dir;
    vbme_test::writeSphereObj(dir / "sphere.obj", 24, 48);
    Scene s;
    s.image_size = Size(16, 16);
    s.lights = {constantEnvironment(Vec3d(0.5, 0.5, 0.5))};
    s.objects = {
        sphere(dir / "sphere.obj", 1, Vec3d(0, 0, 0), vbme_test::lambertian(Vec3d(1, 1, 1)))};
    s.camera = vbme_test::lookAt(Vec3d(0, -4, 0), Vec3d(0, 0, 0), 30, s.image_size);
    Ptr<RenderScene> rs = RenderScene::create(s);
    for (int integrator : {Renderer::PATH, Renderer::REFERENCE}) {
        Renderer::Params p;
        p.spp = 64;
        p.max_depth = 64;
        p.integrator = integrator;
        RenderImages img;
        Renderer::create(p)->render(*rs, s.camera, img);
        ASSERT_GT(countNonZero(img.object), 100);  // the sphere covers most of the image
        const Scalar m = mean(img.color);
        EXPECT_NEAR(m[1], 0.5, 0.005) << "integrator " << integrator;
        double lo, hi;
        minMaxLoc(img.color.reshape(1), &lo, &hi);
        EXPECT_GT(lo, 0.5 * 0.9);
        EXPECT_LT(hi, 0.5 * 1.1);
    }
}

// A Lambertian sphere lit by a distant light (no environment, direct lighting only) against
// analytic shading: L = ρ/π · E · max(0, n·l), n from the normal AOV.
TEST(RenderIntegrator, DiffuseSphereUnderDistantLight) {
    ScratchDir dir;
    vbme_test::writeSphereObj(dir / "sphere.obj", 64, 128);
    Scene s;
    s.image_size = Size(32, 32);
    const Vec3d albedo(0.8, 0.5, 0.2);
    s.objects = {sphere(dir / "sphere.obj", 1, Vec3d(0, 0, 0), vbme_test::lambertian(albedo))};
    Light l;
    l.type = Light::DISTANT;
    l.to_light = normalize(Vec3d(0.5, -0.7, 0.6));
    l.radiance = Vec3d(3, 3, 3);  // half-angle 0: irradiance 3 facing the light
    s.lights = {l};
    s.camera = vbme_test::lookAt(Vec3d(0, -5, 0), Vec3d(0, 0, 0), 60, s.image_size);
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 16;
    p.max_depth = 1;
    RenderImages img;
    Renderer::create(p)->render(*rs, s.camera, img);
    int checked = 0;
    double worst = 0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            if (img.object.at<float>(y, x) < 1.f) continue;
            const Vec3d n(img.normal.at<Vec3f>(y, x));
            const double c = n.dot(l.to_light);
            const Vec3f L = img.color.at<Vec3f>(y, x);  // BGR
            if (c < 0.2) {
                if (c < -0.2) {
                    EXPECT_EQ(L, Vec3f(0, 0, 0));
                }
                continue;
            }
            for (int k = 0; k < 3; ++k) {
                const double ref = albedo[k] / CV_PI * 3.0 * c;
                worst = std::max(worst, std::abs(L[2 - k] - ref) / ref);
            }
            ++checked;
        }
    EXPECT_GT(checked, 150);
    EXPECT_LT(worst, 0.02);
}

// Same with a distant light of 10° half-angle: the cone's irradiance is L·π·sin²θmax at
// normal incidence (θmax ≪ the angle to the terminator), so the same shading law holds.
TEST(RenderIntegrator, DiffuseSphereUnderConeLight) {
    ScratchDir dir;
    vbme_test::writeSphereObj(dir / "sphere.obj", 64, 128);
    Scene s;
    s.image_size = Size(24, 24);
    s.objects = {
        sphere(dir / "sphere.obj", 1, Vec3d(0, 0, 0), vbme_test::lambertian(Vec3d(0.6, 0.6, 0.6)))};
    Light l;
    l.type = Light::DISTANT;
    l.to_light = normalize(Vec3d(0.0, -1.0, 0.3));
    l.radiance = Vec3d(50, 50, 50);
    l.half_angle_deg = 10;
    s.lights = {l};
    s.camera = vbme_test::lookAt(Vec3d(0, -5, 0), Vec3d(0, 0, 0), 22, s.image_size);
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 64;
    p.max_depth = 1;
    RenderImages img;
    Renderer::create(p)->render(*rs, s.camera, img);
    const double st = std::sin(10 * CV_PI / 180), E = 50 * CV_PI * st * st;
    double sum_err = 0, sum_ref = 0;
    for (int y = 0; y < 24; ++y)
        for (int x = 0; x < 24; ++x) {
            if (img.object.at<float>(y, x) < 1.f) continue;
            const double c = Vec3d(img.normal.at<Vec3f>(y, x)).dot(l.to_light);
            if (c < 0.4) continue;  // away from the terminator (cone's penumbra)
            const double ref = 0.6 / CV_PI * E * c;
            sum_err += img.color.at<Vec3f>(y, x)[1] - ref;
            sum_ref += ref;
        }
    ASSERT_GT(sum_ref, 0);
    EXPECT_LT(std::abs(sum_err) / sum_ref, 0.01);
}

// NEE + MIS and the BSDF-sampling-only reference converge to the same image.
TEST(RenderIntegrator, NeeMisMatchesReference) {
    ScratchDir dir;
    Scene s = roomScene(dir.path().string());
    Ptr<RenderScene> rs = RenderScene::create(s);
    ASSERT_LT(s.lights[1].polygonNormal()[1], 0);  // the wall light faces into the room
    Renderer::Params p;
    p.max_depth = 4;
    p.integrator = Renderer::REFERENCE;
    p.spp = 1024;
    RenderImages b;
    Renderer::create(p)->render(*rs, s.camera, b);
    for (int sel : {Renderer::LIGHTS_UNIFORM, Renderer::LIGHTS_POWER}) {
        SCOPED_TRACE(sel == Renderer::LIGHTS_POWER ? "power" : "uniform");
        p.integrator = Renderer::PATH;
        p.light_selection = sel;
        p.spp = 64;
        RenderImages a;
        Renderer::create(p)->render(*rs, s.camera, a);
        const double ma = mean(a.color)[1], mb = mean(b.color)[1];
        EXPECT_GT(ma, 0.1);
        EXPECT_NEAR(ma, mb, 0.01 * mb);
        Mat sa, sb;  // 6×6-pixel blocks
        resize(a.color, sa, Size(4, 3), 0, 0, INTER_AREA);
        resize(b.color, sb, Size(4, 3), 0, 0, INTER_AREA);
        for (int i = 0; i < 12; ++i)
            for (int k = 0; k < 3; ++k) {
                const float va = sa.at<Vec3f>(i / 4, i % 4)[k], vb = sb.at<Vec3f>(i / 4, i % 4)[k];
                EXPECT_NEAR(va, vb, 0.05 * vb + 1e-3) << "block " << i << " channel " << k;
            }
    }
}

// Bitwise identical images for 1, 2 and 4 threads (box and Gaussian filter).
TEST(RenderIntegrator, DeterministicAcrossThreadCounts) {
    ScratchDir dir;
    Scene s = roomScene(dir.path().string());
    Ptr<RenderScene> rs = RenderScene::create(s);
    for (FilterType f : {FILTER_BOX, FILTER_GAUSSIAN}) {
        Renderer::Params p;
        p.spp = 4;
        p.max_depth = 5;
        p.filter = f;
        p.tile_size = 8;
        RenderImages ref;
        p.threads = 1;
        Renderer::create(p)->render(*rs, s.camera, ref);
        for (int t : {2, 4}) {
            p.threads = t;
            RenderImages img;
            Renderer::create(p)->render(*rs, s.camera, img);
            ASSERT_TRUE(img.color.isContinuous() && ref.color.isContinuous());
            EXPECT_EQ(0, std::memcmp(img.color.data, ref.color.data,
                                     ref.color.total() * ref.color.elemSize()))
                << t << " threads, filter " << f;
            EXPECT_EQ(0, std::memcmp(img.albedo.data, ref.albedo.data,
                                     ref.albedo.total() * ref.albedo.elemSize()));
        }
        // another seed gives another image
        p.seed = 1;
        RenderImages other;
        Renderer::create(p)->render(*rs, s.camera, other);
        EXPECT_GT(norm(other.color, ref.color, NORM_INF), 0.0);
    }
}

// Same random numbers with and without the objects: an object that cannot interact with
// anything the camera sees (outside the closed room) changes no bit; a visible one does, and
// only where paths met it or its shadow.
TEST(RenderIntegrator, WithoutObjectsSharesSamples) {
    ScratchDir dir;
    Scene s = roomScene(dir.path().string());
    s.objects[0].world_from_object = vbme_test::placement(0.5, Vec3d(0, 0, 10));  // outside
    Renderer::Params p;
    p.spp = 4;
    p.max_depth = 5;
    RenderImages with, without;
    {
        Ptr<RenderScene> rs = RenderScene::create(s);
        Renderer::create(p)->render(*rs, s.camera, with);
        p.with_objects = false;
        Renderer::create(p)->render(*rs, s.camera, without);
        EXPECT_EQ(0, std::memcmp(with.color.data, without.color.data,
                                 with.color.total() * with.color.elemSize()));
        EXPECT_EQ(countNonZero(with.object), 0);
    }
    {
        // Also equal to a scene that has no objects at all.
        Scene empty = s;
        empty.objects.clear();
        Ptr<RenderScene> rs = RenderScene::create(empty);
        p.with_objects = true;
        RenderImages none;
        Renderer::create(p)->render(*rs, s.camera, none);
        EXPECT_EQ(0, std::memcmp(none.color.data, without.color.data,
                                 none.color.total() * none.color.elemSize()));
    }
    s = roomScene(dir.path().string());
    Ptr<RenderScene> rs = RenderScene::create(s);
    p.with_objects = true;
    Renderer::create(p)->render(*rs, s.camera, with);
    p.with_objects = false;
    Renderer::create(p)->render(*rs, s.camera, without);
    EXPECT_GT(norm(with.color, without.color, NORM_INF), 0.0);
    EXPECT_GT(countNonZero(with.object), 20);
    EXPECT_EQ(countNonZero(without.object), 0);
}

// Beer–Lambert: looking through a 1 m cube of absorbing glass with IOR 1 (no refraction, no
// reflection) at a constant sky gives exp(−σ·1 m).
TEST(RenderIntegrator, BeerLambertAbsorption) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "cube.obj");
    Scene s;
    s.image_size = Size(9, 9);
    s.lights = {constantEnvironment(Vec3d(1, 1, 1))};
    Material glass;
    glass.type = Material::DIELECTRIC;
    glass.ior = 1.0;
    glass.absorption = Vec3d(0.5, 1.0, 2.0);
    SceneObject o;
    o.mesh = dir / "cube.obj";
    o.has_material = true;
    o.material = glass;
    s.objects = {o};
    s.camera =
        vbme_test::lookAt(Vec3d(0, -5, 0), Vec3d(0, 0, 0), 200, s.image_size);  // near-axial rays
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 4;
    p.max_depth = 4;
    RenderImages img;
    Renderer::create(p)->render(*rs, s.camera, img);
    const Vec3f c = img.color.at<Vec3f>(4, 4);  // BGR
    EXPECT_NEAR(c[2], std::exp(-0.5), 1e-4);
    EXPECT_NEAR(c[1], std::exp(-1.0), 1e-4);
    EXPECT_NEAR(c[0], std::exp(-2.0), 1e-4);
    p.with_objects = false;  // the sky itself
    Renderer::create(p)->render(*rs, s.camera, img);
    EXPECT_EQ(img.color.at<Vec3f>(4, 4), Vec3f(1, 1, 1));
}

// Firefly clamp bounds every sample; AOVs can be turned off.
TEST(RenderIntegrator, ClampAndParams) {
    ScratchDir dir;
    Scene s = roomScene(dir.path().string());
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 2;
    p.max_depth = 3;
    p.clamp = 0.25f;
    p.aovs = false;
    RenderImages img;
    const RenderStats st = Renderer::create(p)->render(*rs, s.camera, img);
    double lo, hi;
    minMaxLoc(img.color.reshape(1), &lo, &hi);
    EXPECT_LE(hi, 0.25 + 1e-6);
    EXPECT_TRUE(img.albedo.empty());
    EXPECT_EQ(st.paths, 24 * 18 * 2);
    EXPECT_GE(st.rays, st.paths);
    p.spp = 0;
    EXPECT_THROW(Renderer::create(p), cv::Exception);
    // Params round trip through FileStorage
    Renderer::Params q;
    q.spp = 7;
    q.filter = FILTER_GAUSSIAN;
    q.integrator = Renderer::REFERENCE;
    q.with_objects = false;
    FileStorage fs(".yml", FileStorage::WRITE | FileStorage::MEMORY);
    fs << "render"
       << "{";
    q.write(fs);
    fs << "}";
    FileStorage in(fs.releaseAndGetString(), FileStorage::READ | FileStorage::MEMORY);
    Renderer::Params r;
    r.read(in["render"]);
    EXPECT_EQ(r.spp, 7);
    EXPECT_EQ(r.filter, FILTER_GAUSSIAN);
    EXPECT_EQ(r.integrator, Renderer::REFERENCE);
    EXPECT_FALSE(r.with_objects);
}

// An equirectangular environment seen directly: every pixel shows EnvironmentMap::eval of
// its ray (a smooth map, so the pixel's box filter barely matters).
TEST(RenderIntegrator, EnvironmentImageSeenDirectly) {
    ScratchDir dir;
    Mat env(32, 64, CV_32FC3);
    for (int y = 0; y < env.rows; ++y)
        for (int x = 0; x < env.cols; ++x)
            env.at<Vec3f>(y, x) =
                Vec3f(0.2f + 0.6f * x / env.cols, 0.5f, 0.2f + 0.6f * y / env.rows);
    std::vector<Mat> ch;
    split(env, ch);
    writeExrChannels(dir / "env.exr", {{"R", ch[2]}, {"G", ch[1]}, {"B", ch[0]}});
    Scene s;
    s.image_size = Size(12, 9);
    Light l;
    l.type = Light::ENVIRONMENT;
    l.image = dir / "env.exr";
    l.scale = 2;
    s.lights = {l};
    s.camera = vbme_test::lookAt(Vec3d(0, 0, 0), Vec3d(1, 0.3, 0.2), 10, s.image_size);
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 16;
    RenderImages img;
    Renderer::create(p)->render(*rs, s.camera, img);
    const EnvironmentMap ref = EnvironmentMap::load(l.image, Matx33f::eye(), 2.f);
    const PinholeCamera cam(s.camera);
    for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 12; ++x) {
            Vec3f o, d;
            cam.generateRay(Point2f(x, y), o, d);
            const Vec3f e = ref.eval(d);  // RGB
            const Vec3f c = img.color.at<Vec3f>(y, x);
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(c[2 - k], e[k], 0.03 * e[k]) << x << "," << y;
        }
    // a missing environment image is an error naming the light
    s.lights[0].image = dir / "none.exr";
    try {
        RenderScene::create(s);
        ADD_FAILURE() << "missing environment image accepted";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("lights[0].image"), std::string::npos) << e.err;
    }
}

// The AOVs of the differential pass: `mask` is where the camera sees an object, `object` also
// covers where paths met it indirectly — here its shadow on the floor under a point light.
TEST(RenderIntegrator, ObjectMaskAndInteraction) {
    ScratchDir dir;
    vbme_test::writeSphereObj(dir / "sphere.obj", 16, 32);
    Scene s;
    s.image_size = Size(24, 24);
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    Light l;
    l.type = Light::POINT;
    l.position = Vec3d(0, 0, 2.9);
    l.intensity = Vec3d(5, 5, 5);
    s.lights = {l};
    s.objects = {sphere(dir / "sphere.obj", 0.4, Vec3d(0.8, 0, 1.5),
                        vbme_test::lambertian(Vec3d(0.5, 0.5, 0.5)))};
    // Looking straight down from beside the light. The sphere's shadow on the floor is the disk
    // around x = 0.8·2.9/1.4 = 1.66 of radius ≈ 0.83; the floor point (1.175, 0, 0) lies in it
    // and is seen past the sphere; (−1.5, 0, 0) is lit.
    Camera cam = Camera::fromFocal(6, s.image_size);
    cam.R = Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1);
    cam.t = -(cam.R * Vec3d(-1.0, 0, 2.9));
    Ptr<RenderScene> rs = RenderScene::create(s);
    Renderer::Params p;
    p.spp = 4;
    p.max_depth = 1;
    RenderImages img;
    Renderer::create(p)->render(*rs, cam, img);
    auto pixel = [&](const Vec3d& X) {
        const Point2d q = cam.project(X);
        return Point(cvRound(q.x), int(std::floor(q.y)));
    };
    const Point ps = pixel(Vec3d(1.175, 0, 0)), pb = pixel(Vec3d(0.8, 0, 1.5)),
                pl = pixel(Vec3d(-1.5, 0, 0));
    for (Point q : {ps, pb, pl})
        ASSERT_TRUE(Rect(0, 0, 24, 24).contains(q)) << q;
    EXPECT_EQ(img.mask.at<float>(pb), 1.f);
    EXPECT_EQ(img.object.at<float>(pb), 1.f);
    EXPECT_EQ(img.mask.at<float>(ps), 0.f);
    EXPECT_EQ(img.object.at<float>(ps), 1.f);            // its shadow rays were blocked by it
    EXPECT_EQ(img.color.at<Vec3f>(ps), Vec3f(0, 0, 0));  // and it is in shadow
    EXPECT_EQ(img.object.at<float>(pl), 0.f);            // lit floor: untouched by the object
    EXPECT_GT(img.color.at<Vec3f>(pl)[0], 0.f);
    // Without the objects the same AOVs are empty.
    p.with_objects = false;
    Renderer::create(p)->render(*rs, cam, img);
    EXPECT_EQ(countNonZero(img.object), 0);
    EXPECT_EQ(countNonZero(img.mask), 0);
}

// A point light over the floor of a room with black walls: L = ρ/π · I cos θ / d² at every
// floor pixel (direct light only).
TEST(RenderIntegrator, PointLightOnFloor) {
    Scene s;
    s.image_size = Size(16, 16);
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    Light l;
    l.type = Light::POINT;
    l.position = Vec3d(0.3, -0.2, 1.0);
    l.intensity = Vec3d(2, 3, 4);
    s.lights = {l};
    Camera cam = Camera::fromFocal(6, s.image_size);  // looking straight down from z = 2.5
    cam.R = Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1);
    cam.t = -(cam.R * Vec3d(0, 0, 2.5));
    RenderScene::Params rp;
    rp.room_albedo = Vec3f(0.5f, 0.5f, 0.5f);
    Ptr<RenderScene> rs = RenderScene::create(s, rp);
    Renderer::Params p;
    p.spp = 1;
    p.max_depth = 1;
    // the radiance of the ray through each pixel centre
    Ptr<Renderer> r = Renderer::create(p);
    const PinholeCamera pc(cam);
    for (int y = 0; y < 16; y += 3)
        for (int x = 0; x < 16; x += 3) {
            Vec3f o, d;
            pc.generateRay(Point2f(x, y), o, d);
            const float t = -o[2] / d[2];
            const Vec3d X(o + d * t);
            if (std::abs(X[0]) > 1.9 || std::abs(X[1]) > 1.9) continue;  // floor only
            const Vec3d toL = l.position - X;
            const double d2 = toL.dot(toL), c = toL[2] / std::sqrt(d2);
            const Vec3f L = r->radiance(*rs, o, d, Point(x, y), 0);
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(L[k], 0.5 / CV_PI * l.intensity[k] * c / d2, 1e-4 * L[k] + 1e-7);
        }
}

// The room as a light box: with room_emissive the camera sees the texture itself as radiance.
TEST(RenderIntegrator, EmissiveRoomShowsItsTexture) {
    ScratchDir dir;
    Mat tex(2, 2, CV_32FC3, Scalar(0.25, 0.5, 2.0));  // BGR float: linear as is
    std::vector<Mat> ch;
    split(tex, ch);
    writeExrChannels(dir / "t.exr", {{"R", ch[2]}, {"G", ch[1]}, {"B", ch[0]}});
    Scene s;
    s.image_size = Size(8, 8);
    s.has_room = true;
    s.room.max = Vec3d(4, 4, 4);
    s.room.textures["back"] = dir / "t.exr";
    RenderScene::Params rp;
    rp.room_emissive = true;
    Ptr<RenderScene> rs = RenderScene::create(s, rp);
    Renderer::Params p;
    p.spp = 2;
    p.max_depth = 3;
    RenderImages img;
    Renderer::create(p)->render(
        *rs, vbme_test::lookAt(Vec3d(2, 1, 2), Vec3d(2, 4, 2), 4, s.image_size), img);
    EXPECT_LT(norm(img.color.at<Vec3f>(4, 4) - Vec3f(0.25f, 0.5f, 2.0f)), 1e-6);
}
