// This file is part of vbme, licensed under the Apache License 2.0 (see
// LICENSE). Camera tracking: COLMAP text IO, Eq. 5.3 and its robust variant,
// and the whole COLMAP run on a synthetic hand-held sequence of a textured room
// with known cameras.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/calib/camera_tracking.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;
namespace fs = std::filesystem;

TEST(CalibColmap, QuaternionRoundTrip) {
    RNG rng(3);
    for (int i = 0; i < 200; ++i) {
        Mat R;
        Rodrigues(Vec3d(rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)), R);
        const Vec4d q = quaternionFromRotation(Matx33d(R));
        EXPECT_NEAR(norm(q), 1.0, 1e-12);
        EXPECT_GE(q[0], 0);
        EXPECT_LT(norm(Mat(rotationFromQuaternion(q)), R), 1e-12);
    }
    // COLMAP's convention: (w, x, y, z); a 90° turn about z.
    const Matx33d Rz = rotationFromQuaternion(Vec4d(std::sqrt(0.5), 0, 0, std::sqrt(0.5)));
    EXPECT_NEAR(Rz(0, 1), -1, 1e-12);
    EXPECT_NEAR(Rz(1, 0), 1, 1e-12);
}

TEST(CalibColmap, TextModelRoundTrip) {
    vbme_test::ScratchDir tmp;
    ColmapModel m;
    ColmapCamera cam;
    cam.size = Size(320, 240);
    cam.params = {300, 300, 160, 120};
    m.cameras[1] = cam;
    for (int i = 1; i <= 3; ++i) {
        ColmapImage im;
        im.id = i;
        Mat R;
        Rodrigues(Vec3d(0.1 * i, -0.2, 0.05), R);
        im.R = Matx33d(R);
        im.t = Vec3d(i, -i * 0.5, 2);
        im.name = format("frame_%05d.png", i - 1);
        im.xys = {Point2d(10.5, 20.25), Point2d(100.125, 3)};
        im.point3d_ids = {7, -1};
        m.images[i] = im;
    }
    ColmapImage bare;  // an image without keypoints: an empty second line
    bare.id = 9;
    bare.name = "frame_00009.png";
    m.images[9] = bare;
    ColmapPoint p;
    p.id = 7;
    p.xyz = Vec3d(0.1, 0.2, 3.3);
    p.rgb = Vec3b(10, 20, 30);
    p.error = 0.42;
    p.track = {{1, 0}, {2, 0}, {3, 0}};
    m.points[7] = p;
    m.writeText(tmp / "model");
    const ColmapModel r = ColmapModel::readText(tmp / "model");
    ASSERT_EQ(r.cameras.size(), 1u);
    EXPECT_EQ(r.cameras.at(1).params, cam.params);
    ASSERT_EQ(r.images.size(), 4u);
    for (int i = 1; i <= 3; ++i) {
        EXPECT_LT(norm(Mat(r.images.at(i).R), Mat(m.images[i].R)), 1e-12);
        EXPECT_EQ(r.images.at(i).t, m.images[i].t);
        EXPECT_EQ(r.images.at(i).name, m.images[i].name);
        EXPECT_EQ(r.images.at(i).xys, m.images[i].xys);
        EXPECT_EQ(r.images.at(i).point3d_ids, m.images[i].point3d_ids);
    }
    EXPECT_TRUE(r.images.at(9).xys.empty());
    EXPECT_EQ(r.points.at(7).track, p.track);
    EXPECT_EQ(r.points.at(7).rgb, p.rgb);
    EXPECT_NE(r.imageByName("frame_00001.png"), nullptr);

    std::ofstream(tmp / "model/points3D.txt") << "# header\n7 0.1 0.2 oops\n";
    try {
        ColmapModel::readText(tmp / "model");
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("points3D.txt:2"), std::string::npos) << e.err;
    }
}

// A run and its resume must pick the same model: several models are read largest first,
// ties in the subdirectories' name order, whatever order the file system lists them in (a
// resumed track-camera once picked another model than the run it resumed, 1.3 cm apart).
TEST(CalibColmap, SeveralTextModelsReadLargestFirstWhateverTheListingOrder) {
    vbme_test::ScratchDir tmp;
    auto model = [](int images, int first_id) {
        ColmapModel m;
        ColmapCamera cam;
        cam.size = Size(64, 48);
        cam.params = {50, 50, 32, 24};
        m.cameras[1] = cam;
        for (int i = 0; i < images; ++i) {
            ColmapImage im;
            im.id = first_id + i;
            im.R = Matx33d::eye();
            im.t = Vec3d(first_id, i, 0);
            im.name = format("frame_%05d.png", i);
            m.images[im.id] = im;
        }
        return m;
    };
    // written in an order that is neither the size order nor the name order
    model(2, 30).writeText(tmp / "sparse_txt/3");
    model(5, 10).writeText(tmp / "sparse_txt/1");
    model(2, 20).writeText(tmp / "sparse_txt/2");
    model(5, 0).writeText(tmp / "sparse_txt/0");
    model(3, 40).writeText(tmp / "sparse_txt/10");
    std::ofstream(tmp / "sparse_txt/not_a_model.txt") << "x\n";
    const std::vector<ColmapModel> ms = ColmapModel::readTextModels(tmp / "sparse_txt");
    ASSERT_EQ(ms.size(), 5u);
    std::vector<int> first_ids;
    for (const auto& m : ms)
        first_ids.push_back(m.images.begin()->first);
    EXPECT_EQ(first_ids, (std::vector<int>{0, 10, 40, 20, 30}));
    EXPECT_TRUE(ColmapModel::readTextModels(tmp / "missing").empty());
}

TEST(CalibColmap, MissingProgramIsAClearError) {
    vbme_test::ScratchDir tmp;
    fs::create_directories(tmp / "frames");
    imwrite(tmp / "frames/frame_00000.png", Mat(32, 32, CV_8UC3, Scalar(1, 2, 3)));
    ColmapOptions o;
    o.executable = "/nonexistent/colmap";
    try {
        runColmapSfM(tmp / "frames", tmp / "work", Matx33d::eye(), Size(32, 32), o);
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("was not found"), std::string::npos) << e.err;
    }
    o.executable = "false";  // a program that fails
    try {
        runColmapSfM(tmp / "frames", tmp / "work", Matx33d::eye(), Size(32, 32), o);
        FAIL();
    } catch (const cv::Exception& e) {
        EXPECT_NE(e.err.find("feature_extractor failed"), std::string::npos) << e.err;
        EXPECT_NE(e.err.find("colmap.log"), std::string::npos) << e.err;
    }
}

TEST(CalibScale, Eq53AndRobustVariantWithOutliers) {
    // 200 points on the walls with true scale 2.5 m per unit and 1 % noise, 40
    // outliers (furniture: the box depth overestimates; a window: far too deep).
    RNG rng(11);
    std::vector<double> box, sfm, err;
    for (int i = 0; i < 200; ++i) {
        const double z = rng.uniform(1.0, 5.0);
        box.push_back(z * (1 + rng.gaussian(0.01)));
        sfm.push_back(z / 2.5);
        err.push_back(rng.uniform(0.1, 1.0));
    }
    for (int i = 0; i < 40; ++i) {
        const double z = rng.uniform(1.0, 3.0);
        box.push_back(z * rng.uniform(1.3, 3.0));
        sfm.push_back(z / 2.5);
        err.push_back(rng.uniform(0.1, 1.0));
    }
    const ScaleEstimate mean = scaleEq53(box, sfm), robust = scaleRobust(box, sfm, err);
    std::printf(
        "Eq. 5.3 mean %.4f (spread %.3f), robust %.4f (spread %.4f, %d "
        "of %d points); truth 2.5\n",
        mean.scale, mean.spread, robust.scale, robust.spread, robust.used, robust.total);
    EXPECT_GT(std::abs(mean.scale - 2.5), 0.1);     // the outliers drag the mean
    EXPECT_LT(std::abs(robust.scale - 2.5), 0.01);  // the robust estimate holds
    EXPECT_LT(robust.spread, 0.02);
    EXPECT_GE(robust.used, 190);
    // Without outliers both agree.
    box.resize(200);
    sfm.resize(200);
    EXPECT_NEAR(scaleEq53(box, sfm).scale, 2.5, 0.01);
}

TEST(CalibScale, BoxDepthMatchesGeometry) {
    Room room;
    room.min = Vec3d(-2, -1, 0);
    room.max = Vec3d(2, 4, 2.6);
    Camera cam = Camera::fromFocal(300, Size(320, 240));
    // Looking along +y (the back wall), level, 1.5 m above the floor at the
    // origin.
    cam.R = Matx33d(1, 0, 0, 0, 0, -1, 0, 1, 0);
    cam.t = -(cam.R * Vec3d(0, 0, 1.5));
    int face = -1;
    EXPECT_NEAR(boxDepthAt(cam, room, imageCenter(cam.image_size), &face), 4.0, 1e-12);
    EXPECT_EQ(Room::faceNames()[face], "back");
    // A pixel looking down onto the floor.
    const Vec3d floor_pt(0.3, 1.0, 0.0);
    const Point2d px = cam.project(floor_pt);
    EXPECT_NEAR(boxDepthAt(cam, room, px, &face), cam.camFromWorld(floor_pt)[2], 1e-9);
    EXPECT_EQ(Room::faceNames()[face], "floor");
}

namespace {

double rotationErrorDeg(const Matx33d& a, const Matx33d& b) {
    const Matx33d d = a * b.t();
    const double c = std::max(-1.0, std::min(1.0, (d(0, 0) + d(1, 1) + d(2, 2) - 1) / 2));
    return std::acos(c) * 180 / CV_PI;
}

}  // namespace

TEST(CalibTracking, ColmapOnSyntheticHandheldRoom) {
    if (vbme_test::run("colmap help").code != 0)
        GTEST_SKIP() << "the colmap program is not installed";
    vbme_test::ScratchDir tmp;
    // A 4 x 5 m room, 2.6 m high; 40 frames at 320x240 of a hand-held walk of
    // ~1.5 m.
    const Scene s0 = syntheticRoomScene();
    const Camera first = s0.camera;
    const int n = 40;
    const std::vector<Camera> truth = handheldCameraPath(first, n, 1.5, 0.01, 0.4, 5);
    const auto textures = makeRoomTextures(3, 1024);
    fs::create_directories(tmp / "frames");
    std::vector<std::string> names;
    for (int i = 0; i < n; ++i) {
        names.push_back(format("frame_%05d.png", i));
        imwrite(tmp / ("frames/" + names.back()),
                renderTexturedRoom(truth[i], s0.room, textures, 2));
    }
    CameraTrackingReport report;
    const CameraPath path = trackCameraFrames(tmp / "frames", names, s0, tmp / "work",
                                              CameraTrackingOptions(), &report);
    ASSERT_EQ(path.frames.size(), (size_t)n);
    double ate2 = 0, worst_rot = 0, placement2 = 0, len_true = 0, len_est = 0;
    int placed = 0;
    // Where a user would put an object: the floor point seen at (w/2, 3h/4) in frame 0.
    const Vec3d ray = first.rayDirection(Point2d(160, 180));
    const Vec3d floor_pt = first.center() + ray * (-first.center()[2] / ray[2]);
    for (int i = 0; i < n; ++i) {
        const Camera est = path.camera(i);
        ate2 += std::pow(norm(est.center() - truth[i].center()), 2);
        worst_rot = std::max(worst_rot, rotationErrorDeg(est.R, truth[i].R));
        double depth = 0;
        const Point2d seen = truth[i].project(floor_pt, &depth);
        if (depth > 0 && Rect(0, 0, 320, 240).contains(Point(cvRound(seen.x), cvRound(seen.y)))) {
            placement2 += std::pow(norm(est.project(floor_pt) - seen), 2);  // only while in view
            ++placed;
        }
        if (std::getenv("VBME_VERBOSE"))
            std::printf(
                "frame %2d: centre err %.2f mm rot err %.3f deg placement %.2f px (%+.2f, %+.2f)\n",
                i, 1000 * norm(est.center() - truth[i].center()),
                rotationErrorDeg(est.R, truth[i].R),
                norm(est.project(floor_pt) - truth[i].project(floor_pt)),
                (est.project(floor_pt) - truth[i].project(floor_pt)).x,
                (est.project(floor_pt) - truth[i].project(floor_pt)).y);
        if (i) {
            len_true += norm(truth[i].center() - truth[i - 1].center());
            len_est += norm(est.center() - path.camera(i - 1).center());
        }
    }
    ASSERT_GT(placed, n / 2);
    const double ate = std::sqrt(ate2 / n), placement = std::sqrt(placement2 / placed),
                 scale_err = std::abs(len_est / len_true - 1);
    std::printf(
        "COLMAP: %d/%d frames registered, %d model(s), reprojection RMS "
        "%.3f px, scale %.4f m/unit (spread %.4f, "
        "%d/%d points), points %.2f mm from the box's faces (median): %s; %.1f s\n",
        report.registered, n, report.models, report.reprojection_rms, report.scale.scale,
        report.scale.spread, report.scale.used, report.scale.total, 1000 * report.face_distance,
        report.confident ? "confident" : ("NOT confident: " + report.doubt).c_str(),
        report.seconds);
    std::printf(
        "ATE %.2f cm, worst rotation error %.3f deg, scale error %.2f "
        "%%, floor-point placement RMS %.3f px over %d frames in view\n",
        ate * 100, worst_rot, scale_err * 100, placement, placed);
    EXPECT_GE(report.registered, n - 2);
    EXPECT_LE(ate, 0.02);
    EXPECT_LE(worst_rot, 0.2);
    EXPECT_LE(scale_err, 0.01);
    EXPECT_LE(placement, 0.5);
    EXPECT_TRUE(report.confident) << report.doubt;  // a good model is not doubted
}

TEST(CalibTracking, BlenderScriptUsesBlenderCameraAxes) {
    vbme_test::ScratchDir tmp;
    CameraPath path;
    path.image_size = Size(320, 240);
    path.K = Camera::fromFocal(260, path.image_size).K;
    CameraPath::Frame f;
    Mat R;
    Rodrigues(Vec3d(-1.4, 0.2, 0.1), R);
    f.R = Matx33d(R);
    f.t = Vec3d(0.1, 0.5, 1.2);
    path.frames = {f};
    Room room;
    room.min = Vec3d(-2, -1, 0);
    room.max = Vec3d(2, 4, 2.6);
    writeBlenderScript(tmp / "track.py", path, room, 30);
    std::ifstream in(tmp / "track.py");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t at = text.find("    ((");
    ASSERT_NE(at, std::string::npos);
    double m[12];
    ASSERT_EQ(
        std::sscanf(text.c_str() + at,
                    " ((%lf, %lf, %lf, %lf), (%lf, %lf, %lf, %lf), (%lf, %lf, %lf, %lf)", &m[0],
                    &m[1], &m[2], &m[3], &m[4], &m[5], &m[6], &m[7], &m[8], &m[9], &m[10], &m[11]),
        12);
    // Blender cameras look down their −z axis with +y up; OpenCV cameras look down +z with y down.
    const Vec3d view = f.R.t() * Vec3d(0, 0, 1), up = f.R.t() * Vec3d(0, -1, 0),
                C = -(f.R.t() * f.t);
    EXPECT_LT(norm(Vec3d(-m[2], -m[6], -m[10]) - view), 1e-9);
    EXPECT_LT(norm(Vec3d(m[1], m[5], m[9]) - up), 1e-9);
    EXPECT_LT(norm(Vec3d(m[3], m[7], m[11]) - C), 1e-9);
    EXPECT_NE(text.find("data.lens = 29.25"), std::string::npos);  // 260 px × 36 mm / 320 px
    EXPECT_NE(text.find("scene.render.fps = 30"), std::string::npos);
}

#if __has_include(<opencv2/vbme/render.hpp>)
#include <opencv2/vbme/render.hpp>

TEST(CalibTracking, TexturedRoomSequenceMatchesVbmeRender) {
    // The camera-tracking tests' frames are an exact albedo ray-cast of a textured box; the
    // same room rendered by vbme_render (albedo AOV, textures decoded from sRGB) must look the
    // same, face orientations included.
    vbme_test::ScratchDir tmp;
    Scene s;
    s.image_size = Size(160, 120);
    s.has_room = true;
    s.room.min = Vec3d(-2, -1, 0);
    s.room.max = Vec3d(2, 4, 2.6);
    const auto textures = makeRoomTextures(3, 256);
    for (const auto& kv : textures) {
        imwrite(tmp / (kv.first + ".png"), kv.second);
        s.room.textures[kv.first] = tmp / (kv.first + ".png");
    }
    Light sky;
    sky.type = Light::ENVIRONMENT;
    sky.radiance = Vec3d(1, 1, 1);
    s.lights = {sky};
    Renderer::Params rp;
    rp.spp = 16;
    rp.max_depth = 1;
    Ptr<RenderScene> scene = RenderScene::create(s);
    Ptr<Renderer> renderer = Renderer::create(rp);
    // Cameras looking at every face: the back wall, the front wall, left, right, down and up.
    const Vec3d eye(0.3, 1.2, 1.4);
    const Vec3d looks[6] = {{0, 1, 0}, {0, -1, 0},     {-1, 0, 0},
                            {1, 0, 0}, {0.1, 0.2, -1}, {0.1, 0.2, 1}};
    for (const Vec3d& look : looks) {
        Camera cam = Camera::fromFocal(90, s.image_size);
        const Vec3d z = normalize(look),
                    up = std::abs(z[2]) > 0.9 ? Vec3d(0, 1, 0) : Vec3d(0, 0, 1);
        const Vec3d x = normalize(z.cross(up)), y = z.cross(x);
        cam.R = Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
        cam.t = -(cam.R * eye);
        RenderImages out;
        renderer->render(*scene, cam, out);
        Mat ours, ours_lin;
        linearize(renderTexturedRoom(cam, s.room, textures, 4), ours_lin, Response::SRGB);
        Mat diff;
        absdiff(out.albedo, ours_lin, diff);
        const Scalar m = mean(diff);
        EXPECT_LT((m[0] + m[1] + m[2]) / 3, 0.005) << "looking along " << look;
        std::printf("looking along (%g, %g, %g): mean |difference| %.4f\n", look[0], look[1],
                    look[2], (m[0] + m[1] + m[2]) / 3);
    }
}
#endif

namespace {

// A COLMAP model of the synthetic room seen by @p cams: points on the box's faces where a 12 x 9
// grid of frame 0's and the last frame's pixels hit it, observed (with 0.3 px noise) by every
// camera that sees them; the model frame is the world scaled by 1/2.
ColmapModel roomModel(const std::vector<Camera>& cams, const Room& room, Size size) {
    const double a = 0.5;
    ColmapModel m;
    ColmapCamera cc;
    cc.size = size;
    const Matx33d& K = cams[0].K;
    cc.params = {K(0, 0), K(1, 1), K(0, 2) + 0.5, K(1, 2) + 0.5};
    m.cameras[1] = cc;
    for (size_t i = 0; i < cams.size(); ++i) {
        ColmapImage im;
        im.id = (int)i + 1;
        im.R = cams[i].R;
        im.t = cams[i].t * a;
        im.name = format("frame_%05d.png", (int)i);
        m.images[im.id] = im;
    }
    RNG rng(7);
    long long id = 0;
    for (const Camera* src : {&cams.front(), &cams.back()})
        for (int gy = 0; gy < 9; ++gy)
            for (int gx = 0; gx < 12; ++gx) {
                const Point2d px((gx + 0.5) * size.width / 12, (gy + 0.5) * size.height / 9);
                const Vec3d X =
                    src->center() + src->rayDirection(px) * (boxDepthAt(*src, room, px) /
                                                             (src->R * src->rayDirection(px))[2]);
                ColmapPoint p;
                p.id = ++id;
                p.xyz = X * a;
                p.error = 0.3;
                for (size_t i = 0; i < cams.size(); ++i) {
                    const Vec3d xc = cams[i].camFromWorld(X);
                    if (xc[2] <= 0.1) continue;
                    const Point2d q(K(0, 0) * xc[0] / xc[2] + K(0, 2) + rng.gaussian(0.3),
                                    K(1, 1) * xc[1] / xc[2] + K(1, 2) + rng.gaussian(0.3));
                    if (q.x < 0 || q.y < 0 || q.x > size.width - 1 || q.y > size.height - 1)
                        continue;
                    ColmapImage& im = m.images[(int)i + 1];
                    p.track.emplace_back(im.id, (int)im.xys.size());
                    im.xys.emplace_back(q.x + 0.5, q.y + 0.5);
                    im.point3d_ids.push_back(p.id);
                }
                m.points[p.id] = p;
            }
    return m;
}

}  // namespace

TEST(CalibTracking, ModelThatDoesNotFitTheRoomIsNotConfident) {
    // The full method's guard, without COLMAP: a model that fits the annotated room is
    // confident; one that does not gives a wrong track, and says so.
    const Scene s0 = syntheticRoomScene();
    const int n = 8;
    const std::vector<Camera> truth = handheldCameraPath(s0.camera, n, 0.6, 0.0, 0.0, 3);
    ColmapModel good = roomModel(truth, s0.room, s0.image_size);
    std::vector<std::string> names;
    for (int i = 0; i < n; ++i)
        names.push_back(format("frame_%05d.png", i));
    auto ate = [&](const CameraPath& p) {
        double se = 0;
        for (int i = 0; i < n; ++i)
            se += std::pow(norm(p.camera(i).center() - truth[i].center()), 2);
        return std::sqrt(se / n);
    };
    CameraTrackingReport rg, rw;
    const CameraPath pg = alignToRoom(good, names, s0, CameraTrackingOptions(), &rg);
    // The same camera path in a room 1.2 m wider to the side and 0.8 m deeper: a self-consistent
    // model (as COLMAP's are, even when wrong) that does not fit the annotated room.
    Room other = s0.room;
    other.max[0] += 1.2;
    other.max[1] += 0.8;
    const ColmapModel wrong = roomModel(truth, other, s0.image_size);
    const CameraPath pw = alignToRoom(wrong, names, s0, CameraTrackingOptions(), &rw);
    std::printf(
        "model that fits the room: ATE %.2f cm, scale spread %.4f, points %.2f mm from the faces "
        "(%s)\nin a room that is not the annotated one: ATE %.2f cm, scale spread %.4f, points "
        "%.2f "
        "mm from the faces (%s)\n",
        100 * ate(pg), rg.scale.spread, 1000 * rg.face_distance, rg.doubt.c_str(), 100 * ate(pw),
        rw.scale.spread, 1000 * rw.face_distance, rw.doubt.c_str());
    EXPECT_LT(ate(pg), 0.01);
    EXPECT_TRUE(rg.confident) << rg.doubt;
    // measured: 0.35 cm, spread 0.0015, 0.16 mm; the wrong room: 3.71 cm, 0.0198, 172.5 mm
    EXPECT_GT(ate(pw), 0.02);    // the track is wrong...
    EXPECT_FALSE(rw.confident);  // ...and says why
    EXPECT_GT(rw.face_distance, CameraTrackingOptions().max_face_distance);
    EXPECT_NE(rw.doubt.find("room's faces"), std::string::npos) << rw.doubt;
}
