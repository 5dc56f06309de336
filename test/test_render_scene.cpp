// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include <gtest/gtest.h>

#include <fstream>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/render.hpp>

#include "test_render_util.hpp"
#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
using vbme_test::ScratchDir;

namespace {

// Camera at the room centre looking at a face, oriented as the face's texture convention says
// (rows: image right, image down, forward).
Camera faceCamera(const std::string& face, const Vec3d& centre, double f, Size sz) {
    Camera c = Camera::fromFocal(f, sz);
    Vec3d r, d, z;
    if (face == "floor") r = {1, 0, 0}, d = {0, -1, 0}, z = {0, 0, -1};
    if (face == "ceiling") r = {1, 0, 0}, d = {0, 1, 0}, z = {0, 0, 1};
    if (face == "back") r = {1, 0, 0}, d = {0, 0, -1}, z = {0, 1, 0};
    if (face == "front") r = {-1, 0, 0}, d = {0, 0, -1}, z = {0, -1, 0};
    if (face == "left") r = {0, 1, 0}, d = {0, 0, -1}, z = {-1, 0, 0};
    if (face == "right") r = {0, -1, 0}, d = {0, 0, -1}, z = {1, 0, 0};
    for (int k = 0; k < 3; ++k)
        c.R(0, k) = r[k], c.R(1, k) = d[k], c.R(2, k) = z[k];
    c.t = -(c.R * centre);
    return c;
}

Renderer::Params aovParams() {
    Renderer::Params p;
    p.spp = 4;
    p.max_depth = 1;
    p.threads = 2;
    return p;
}

}  // namespace

// Every room face shows its texture the way a viewer inside sees it (doc: floor image-up +y,
// ceiling image-up −y, walls upright): a 4×4 texture with red / green / blue / white quadrants
// (top-left, top-right, bottom-left, bottom-right) appears unmirrored and upright.
TEST(RenderScene, RoomTextureOrientation) {
    ScratchDir dir;
    Mat tex(4, 4, CV_8UC3);
    tex(Rect(0, 0, 2, 2)).setTo(Scalar(0, 0, 255));      // top-left red (BGR)
    tex(Rect(2, 0, 2, 2)).setTo(Scalar(0, 255, 0));      // top-right green
    tex(Rect(0, 2, 2, 2)).setTo(Scalar(255, 0, 0));      // bottom-left blue
    tex(Rect(2, 2, 2, 2)).setTo(Scalar(255, 255, 255));  // bottom-right white
    imwrite(dir / "t.png", tex);
    Scene s;
    s.image_size = Size(32, 32);
    s.has_room = true;
    s.room.min = Vec3d(0, 0, 0);
    s.room.max = Vec3d(4, 4, 4);
    for (const auto& f : Room::faceNames())
        s.room.textures[f] = dir / "t.png";
    Ptr<RenderScene> rs = RenderScene::create(s);
    Ptr<Renderer> r = Renderer::create(aovParams());
    for (const auto& face : Room::faceNames()) {
        RenderImages img;
        r->render(*rs, faceCamera(face, Vec3d(2, 2, 2), 16, s.image_size), img);
        const Vec3f tl = img.albedo.at<Vec3f>(8, 8), tr = img.albedo.at<Vec3f>(8, 23),
                    bl = img.albedo.at<Vec3f>(23, 8), br = img.albedo.at<Vec3f>(23, 23);
        EXPECT_LT(norm(tl - Vec3f(0, 0, 1)), 1e-3) << face << " top-left " << tl;
        EXPECT_LT(norm(tr - Vec3f(0, 1, 0)), 1e-3) << face << " top-right " << tr;
        EXPECT_LT(norm(bl - Vec3f(1, 0, 0)), 1e-3) << face << " bottom-left " << bl;
        EXPECT_LT(norm(br - Vec3f(1, 1, 1)), 1e-3) << face << " bottom-right " << br;
        // inward normals
        const Vec3f n = img.normal.at<Vec3f>(16, 16);
        const Matx33d Rf = faceCamera(face, Vec3d(2, 2, 2), 16, s.image_size).R;
        const Vec3d fwd(Rf(2, 0), Rf(2, 1), Rf(2, 2));
        EXPECT_NEAR(Vec3d(n).dot(fwd), -1.0, 1e-4) << face;
    }
}

// 8-bit room textures are decoded with the camera response (sRGB 128 → 0.2158).
TEST(RenderScene, RoomTextureIsLinearised) {
    ScratchDir dir;
    imwrite(dir / "g.png", Mat(2, 2, CV_8UC3, Scalar(128, 128, 128)));
    Scene s;
    s.image_size = Size(8, 8);
    s.has_room = true;
    s.room.max = Vec3d(4, 4, 4);
    s.room.textures["back"] = dir / "g.png";
    for (Response resp : {Response::SRGB, Response::LINEAR}) {
        s.camera.response = resp;
        Ptr<RenderScene> rs = RenderScene::create(s);
        RenderImages img;
        Renderer::create(aovParams())
            ->render(*rs, faceCamera("back", Vec3d(2, 2, 2), 4, s.image_size), img);
        EXPECT_NEAR(img.albedo.at<Vec3f>(4, 4)[1], linearize(128.f / 255.f, resp), 1e-5);
    }
}

// OBJ + MTL: Kd → albedo, map_Kd → textured albedo, Ke → emission seen directly, d < 1 →
// a dielectric; a scene `material:` overrides the file.
TEST(RenderScene, MtlMaterials) {
    ScratchDir dir;
    {
        std::ofstream m(dir / "m.mtl");
        m << "newmtl kd\nKd 0.2 0.4 0.6\nKs 0 0 0\n";
        m << "newmtl glow\nKd 0 0 0\nKe 3 2 1\n";
        m << "newmtl tex\nKd 1 1 1\nmap_Kd tex.png\n";
    }
    imwrite(dir / "tex.png", Mat(2, 2, CV_8UC3, Scalar(255, 0, 0)));  // blue in RGB
    vbme_test::writeCubeObj(dir / "kd.obj", "m.mtl", "kd");
    vbme_test::writeCubeObj(dir / "glow.obj", "m.mtl", "glow");
    vbme_test::writeCubeObj(dir / "tex.obj", "m.mtl", "tex");
    Scene s;
    s.image_size = Size(16, 16);
    for (const char* n : {"kd", "glow", "tex"}) {
        SceneObject o;
        o.mesh = dir / (std::string(n) + ".obj");
        o.world_from_object = vbme_test::placement(1, Vec3d(0, 0, 0));
        s.objects = {o};
        Ptr<RenderScene> rs = RenderScene::create(s);
        RenderImages img;
        const Camera cam = vbme_test::lookAt(Vec3d(0, -3, 0), Vec3d(0, 0, 0), 16, s.image_size);
        Renderer::create(aovParams())->render(*rs, cam, img);
        const Vec3f a = img.albedo.at<Vec3f>(8, 8), c = img.color.at<Vec3f>(8, 8);
        if (std::string(n) == "kd") {
            EXPECT_LT(norm(a - Vec3f(0.6f, 0.4f, 0.2f)), 1e-6) << a;
        }
        if (std::string(n) == "glow") {
            EXPECT_LT(norm(c - Vec3f(1, 2, 3)), 1e-6) << c;
        }
        if (std::string(n) == "tex") {
            EXPECT_LT(norm(a - Vec3f(1, 0, 0)), 1e-6) << a;
        }
        EXPECT_EQ(img.object.at<float>(8, 8), 1.f);
        EXPECT_EQ(img.object.at<float>(0, 0), 0.f);
        if (std::string(n) == "kd") {  // the scene's material wins over the MTL
            s.objects[0].has_material = true;
            s.objects[0].material = vbme_test::lambertian(Vec3d(0.9, 0.1, 0.1));
            rs = RenderScene::create(s);
            Renderer::create(aovParams())->render(*rs, cam, img);
            EXPECT_LT(norm(img.albedo.at<Vec3f>(8, 8) - Vec3f(0.1f, 0.1f, 0.9f)), 1e-6);
        }
    }
}

// Geometry kinds are queryable per hit; the "without objects" scene does not see objects.
TEST(RenderScene, GeometryKindsAndObjectlessScene) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "c.obj");
    Scene s;
    s.image_size = Size(8, 8);
    s.has_room = true;
    s.room.min = Vec3d(-2, -2, 0);
    s.room.max = Vec3d(2, 2, 3);
    SceneObject o;
    o.mesh = dir / "c.obj";
    o.world_from_object = vbme_test::placement(0.5, Vec3d(0, 0, 1));
    s.objects = {o};
    o.world_from_object = vbme_test::placement(0.5, Vec3d(1, 0, 1));
    s.proxies = {o};
    Light l;
    l.type = Light::POLYGON;
    l.corners = {Vec3d(-0.5, 0.5, 3), Vec3d(0.5, 0.5, 3), Vec3d(0.5, -0.5, 3),
                 Vec3d(-0.5, -0.5, 3)};
    l.radiance = Vec3d(1, 1, 1);
    s.lights = {l};
    Ptr<RenderScene> rs = RenderScene::create(s);
    SurfaceHit h;
    ASSERT_TRUE(rs->intersect(Vec3f(0, -1.5f, 1), Vec3f(0, 1, 0), 0, 100, h));
    EXPECT_EQ(h.kind, GeometryKind::OBJECT);
    EXPECT_NEAR(h.t, 1.25f, 1e-5);
    EXPECT_NEAR(h.ng[1], -1.f, 1e-6);  // outward
    EXPECT_EQ(rs->geometryKind(h.geom_id), GeometryKind::OBJECT);
    EXPECT_EQ(rs->geometrySource(h.geom_id), 0);
    ASSERT_TRUE(rs->intersect(Vec3f(0, -1.5f, 1), Vec3f(0, 1, 0), 0, 100, h, false));
    EXPECT_EQ(h.kind, GeometryKind::ROOM);
    EXPECT_NEAR(h.t, 3.5f, 1e-5);
    EXPECT_NEAR(h.ng[1], -1.f, 1e-6);  // back wall faces into the room
    ASSERT_TRUE(rs->intersect(Vec3f(1, -1.5f, 1), Vec3f(0, 1, 0), 0, 100, h, false));
    EXPECT_EQ(h.kind, GeometryKind::PROXY);
    ASSERT_TRUE(rs->intersect(Vec3f(0, 0, 2), Vec3f(0, 0, 1), 0, 100, h));
    EXPECT_EQ(h.kind, GeometryKind::LIGHT);  // the light, not the ceiling it lies on
    EXPECT_TRUE(rs->occluded(Vec3f(0, -1.5f, 1), Vec3f(0, 1, 0), 0, 2));
    EXPECT_FALSE(rs->occluded(Vec3f(0, -1.5f, 1), Vec3f(0, 1, 0), 0, 2, false));
}

// Embree's fast kernels let rays aimed exactly at an edge slip through (measured: 5 % of the rays
// aimed at a closed room's edges and face diagonals escape it; 7 % of those aimed from outside at
// a cube's edges get inside it and meet the back of a face). The default (robust off,
// retrace_leaks on) traces such rays again in robust mode: no escape and nothing inside, as with
// Embree's robust mode on every ray.
TEST(RenderScene, LeakingRaysAreTracedAgainRobustly) {
    ScratchDir dir;
    vbme_test::writeCubeObj(dir / "c.obj");
    Scene s;
    s.has_room = true;
    s.room.min = Vec3d(-2.13, -1.71, 0);
    s.room.max = Vec3d(2.57, 3.09, 2.71);
    SceneObject o;
    o.mesh = dir / "c.obj";
    o.world_from_object = vbme_test::placement(0.7, Vec3d(0.31, 0.43, 1.17));
    s.objects = {o};
    const Vec3f lo(s.room.min), hi(s.room.max);
    auto corner = [&](int b) {
        return Vec3f(b & 1 ? hi[0] : lo[0], b & 2 ? hi[1] : lo[1], b & 4 ? hi[2] : lo[2]);
    };
    // the room's 12 edges and 12 face diagonals (corner pairs differing in one or two axes)
    std::vector<std::pair<int, int>> room_edges;
    for (int a = 0; a < 8; ++a)
        for (int b = a + 1; b < 8; ++b)
            if (__builtin_popcount(a ^ b) <= 2) room_edges.push_back({a, b});
    // the cube's corners as the mesh has them (placed in double, stored in float)
    auto cube = [](int b) {
        return Vec3f(Vec3d(0.31, 0.43, 1.17) +
                     0.7 * Vec3d(b & 1 ? 0.5 : -0.5, b & 2 ? 0.5 : -0.5, b & 4 ? 0.5 : -0.5));
    };
    const int n = 20000;
    int escapes[3] = {0, 0, 0}, backs[3] = {0, 0, 0}, cube_rays[3] = {0, 0, 0},
        cube_leaks[3] = {0, 0, 0};
    for (int mode = 0; mode < 3; ++mode) {  // fast kernels alone, default, robust
        RenderScene::Params p;
        p.robust = mode == 2;
        p.retrace_leaks = mode == 1;
        Ptr<RenderScene> rs = RenderScene::create(s, p);
        RNG rng(11);
        SurfaceHit h;
        for (int i = 0; i < n; ++i) {
            // from inside the room (and outside the cube) to a point on a room edge
            Vec3f org;
            do {
                org =
                    Vec3f(rng.uniform(lo[0] + 0.1f, hi[0] - 0.1f),
                          rng.uniform(lo[1] + 0.1f, hi[1] - 0.1f), rng.uniform(0.1f, hi[2] - 0.1f));
            } while (std::abs(org[0] - 0.31f) < 0.5f && std::abs(org[1] - 0.43f) < 0.5f &&
                     std::abs(org[2] - 1.17f) < 0.5f);
            const auto& e = room_edges[i % room_edges.size()];
            const Vec3f q =
                corner(e.first) + (corner(e.second) - corner(e.first)) * rng.uniform(0.f, 1.f);
            const Vec3f d = normalize(q - org);
            if (!rs->intersect(org, d, 0.f, std::numeric_limits<float>::infinity(), h))
                ++escapes[mode];
            else if (d.dot(h.ng) > 0.f)
                ++backs[mode];
            // from there to a point on an edge of the cube where two faces it sees meet: a ray
            // that slips through gets inside and meets the back of a face
            const int axis = (i / 4) % 3, b1 = (axis + 1) % 3, b2 = (axis + 2) % 3;
            const int base = (i % 2) << b1 | ((i / 2) % 2) << b2;
            const Vec3f p =
                cube(base) + (cube(base | 1 << axis) - cube(base)) * rng.uniform(0.05f, 0.95f);
            Vec3f n1(0, 0, 0), n2(0, 0, 0);
            n1[b1] = base >> b1 & 1 ? 1.f : -1.f;
            n2[b2] = base >> b2 & 1 ? 1.f : -1.f;
            if ((org - p).dot(n1) < 0.05f || (org - p).dot(n2) < 0.05f) continue;
            ++cube_rays[mode];
            const Vec3f dc = normalize(p - org);
            if (rs->intersect(org, dc, 0.f, std::numeric_limits<float>::infinity(), h) &&
                h.kind == GeometryKind::OBJECT && dc.dot(h.ng) > 0.f)
                ++cube_leaks[mode];
        }
    }
    std::printf(
        "%d rays at the room's edges and diagonals: escapes %d / %d / %d, back faces %d / "
        "%d / %d; %d at the cube's edges: inside %d / %d / %d (fast "
        "kernels alone / default / robust)\n",
        n, escapes[0], escapes[1], escapes[2], backs[0], backs[1], backs[2], cube_rays[0],
        cube_leaks[0], cube_leaks[1], cube_leaks[2]);
    EXPECT_GT(escapes[0], n / 100);  // the leaks exist
    EXPECT_GT(cube_leaks[0], 0);
    for (int mode = 1; mode < 3; ++mode) {
        EXPECT_EQ(escapes[mode], 0) << mode;
        EXPECT_EQ(backs[mode], 0) << mode;
        EXPECT_EQ(cube_leaks[mode], 0) << mode;
    }
}

TEST(RenderScene, ErrorsNameTheField) {
    ScratchDir dir;
    auto expectError = [](const Scene& s, const std::string& what) {
        try {
            RenderScene::create(s);
            ADD_FAILURE() << "no error for " << what;
        } catch (const cv::Exception& e) {
            EXPECT_NE(e.err.find(what), std::string::npos) << e.err;
        }
    };
    Scene s;
    s.image_size = Size(8, 8);
    SceneObject o;
    o.mesh = dir / "missing.obj";
    s.objects = {o};
    expectError(s, "objects[0].mesh");
    {
        std::ofstream f(dir / "bad.obj");
        f << "this is not a mesh\n";
    }
    s.objects[0].mesh = dir / "bad.obj";
    expectError(s, "objects[0].mesh");
    vbme_test::writeCubeObj(dir / "c.obj");
    s.objects[0].mesh = dir / "c.obj";
    s.objects[0].world_from_object = Matx44d::zeros();
    s.objects[0].world_from_object(3, 3) = 1;
    expectError(s, "objects[0].world_from_object");
    s.objects.clear();
    s.proxies = {o};
    expectError(s, "proxies[0].mesh");
    s.proxies.clear();
    s.has_room = true;
    s.room.textures["floor"] = dir / "nope.png";
    expectError(s, "room.textures.floor");

    // Through the scene file: an unknown material is reported with its field.
    {
        std::ofstream f(dir / "s.yml");
        f << "%YAML:1.0\nimage_size: [8, 8]\ncamera: { K: [[8, 0, 3.5], [0, 8, 3.5], [0, 0, 1]] }\n"
          << "objects:\n  - { mesh: c.obj, material: { type: velvet } }\n";
    }
    try {
        Scene::read(dir / "s.yml");
        ADD_FAILURE() << "unknown material accepted";
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("objects[0].material"), std::string::npos) << e.err;
    }
}

namespace {
std::string base64(const unsigned char* d, size_t n) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string s;
    for (size_t i = 0; i < n; i += 3) {
        const uint32_t v = (uint32_t(d[i]) << 16) | (i + 1 < n ? uint32_t(d[i + 1]) << 8 : 0) |
                           (i + 2 < n ? uint32_t(d[i + 2]) : 0);
        s += t[(v >> 18) & 63];
        s += t[(v >> 12) & 63];
        s += i + 1 < n ? t[(v >> 6) & 63] : '=';
        s += i + 2 < n ? t[v & 63] : '=';
    }
    return s;
}
}  // namespace

// PLY and glTF load through assimp too, placed by world_from_object (here a translation
// and a mirroring that must keep the normal on the outside).
TEST(RenderScene, LoadsPlyAndGltf) {
    ScratchDir dir;
    {
        std::ofstream f(dir / "tri.ply");
        f << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
          << "property float z\nelement face 1\nproperty list uchar int "
             "vertex_indices\nend_header\n"
          << "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    }
    {
        const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
        std::ofstream f(dir / "tri.gltf");
        f << "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
          << "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":"
             "0}}]}],"
          << "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
          << base64(reinterpret_cast<const unsigned char*>(v), 36) << "\"}],"
          << "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36}],"
          << "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":"
             "\"VEC3\","
          << "\"min\":[0,0,0],\"max\":[1,1,0]}]}";
    }
    for (const char* name : {"tri.ply", "tri.gltf"}) {
        Scene s;
        s.image_size = Size(4, 4);
        SceneObject o;
        o.mesh = dir / name;
        o.world_from_object = vbme_test::placement(2, Vec3d(0, 0, 1));
        s.objects = {o};
        Ptr<RenderScene> rs = RenderScene::create(s);
        EXPECT_EQ(rs->numTriangles(), 1u) << name;
        SurfaceHit h;
        ASSERT_TRUE(rs->intersect(Vec3f(0.5f, 0.5f, 3), Vec3f(0, 0, -1), 0, 100, h)) << name;
        EXPECT_NEAR(h.t, 2.f, 1e-5) << name;
        EXPECT_NEAR(h.ng[2], 1.f, 1e-6) << name;
        EXPECT_FALSE(rs->intersect(Vec3f(1.5f, 1.5f, 3), Vec3f(0, 0, -1), 0, 100, h)) << name;
        // mirrored in z: the triangle's normal stays on its (mirrored) outside
        s.objects[0].world_from_object(2, 2) = -2;
        rs = RenderScene::create(s);
        ASSERT_TRUE(rs->intersect(Vec3f(0.5f, 0.5f, 3), Vec3f(0, 0, -1), 0, 100, h)) << name;
        EXPECT_NEAR(h.ng[2], -1.f, 1e-6) << name;
    }
}
