// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Room face textures: rectification against known textures, orientation round trip through
// the renderer, accumulation over frames.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/datasets/room_sequence.hpp>
#include <opencv2/vbme/render.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

/** PSNR (8-bit units) of @p a against @p b over the pixels where @p mask is non-zero. */
double maskedPsnr(const Mat& a, const Mat& b, const Mat& mask, double peak = 255) {
    Mat d;
    absdiff(a, b, d);
    d = d.mul(d);
    const Scalar s = sum(d.setTo(Scalar::all(0), mask == 0));
    const double n = countNonZero(mask) * 3.0;
    const double mse = (s[0] + s[1] + s[2]) / std::max(n, 1.0);
    return 10 * std::log10(peak * peak / std::max(mse, 1e-12));
}

/** @p img shifted by (@p dx, @p dy) pixels (bilinear, border replicated): the baseline of a
misregistration by that much, measured on the image itself. */
Mat shifted(const Mat& img, double dx, double dy) {
    Mat out;
    warpAffine(img, out, Matx23d(1, 0, dx, 0, 1, dy), img.size(), INTER_LINEAR, BORDER_REPLICATE);
    return out;
}

Camera lookAtCam(const Vec3d& eye, const Vec3d& target, double f, Size size) {
    Camera c = Camera::fromFocal(f, size);
    const Vec3d z = normalize(target - eye);
    const Vec3d x = normalize(z.cross(Vec3d(0, 0, 1)));
    const Vec3d y = z.cross(x);
    for (int k = 0; k < 3; ++k) {
        c.R(0, k) = x[k];
        c.R(1, k) = y[k];
        c.R(2, k) = z[k];
    }
    c.t = -(c.R * eye);
    return c;
}

}  // namespace

// Rectify an exact (albedo-only) render of a textured room and compare each face with its
// known texture on the texels the frame sees.
TEST(RenderRoomTexture, RectifyMatchesKnownTextures) {
    Scene s = syntheticRoomScene(Size(640, 480), 520, 0.25, 1.5);
    const std::map<std::string, Mat> tex = makeRoomTextures(3, 128);
    const Mat frame = renderTexturedRoom(s.camera, s.room, tex, 3);
    int faces_checked = 0;
    for (const std::string& face : Room::faceNames()) {
        Mat t, v;
        rectifyFace(frame, s.camera, s.room, face, tex.at(face).size(), t, v);
        ASSERT_EQ(t.type(), CV_32FC3);
        ASSERT_EQ(v.type(), CV_8U);
        const int seen = countNonZero(v);
        if (seen < 200) continue;
        Mat ref;
        tex.at(face).convertTo(ref, CV_32FC3);
        // Leave out the one-texel rim of the seen region (the image border cuts texels).
        Mat inner;
        erode(v, inner, Mat());
        const double psnr = maskedPsnr(t, ref, inner);
        // Oracles: the rectified face is closer to the truth than the truth itself moved by one
        // texel in x and in y (alignment to a tenth of a texel is RectifyIsAligned's test; here
        // the loss is the resampling of a foreshortened view, which blurs a little), and closer
        // than the truth's mirror image (a flipped face axis).
        const double psnr_tx = maskedPsnr(shifted(ref, 1, 1), ref, inner);
        Mat mirrored;
        flip(ref, mirrored, 1);
        const double psnr_flip = maskedPsnr(mirrored, ref, inner);
        std::printf(
            "[ measured ] rectify %s: %d texels seen, PSNR %.2f dB (truth moved by one "
            "texel in x and y: %.2f dB, mirrored: %.2f dB)\n",
            face.c_str(), seen, psnr, psnr_tx, psnr_flip);
        EXPECT_GT(psnr, psnr_tx) << face;
        EXPECT_GT(psnr, psnr_flip) << face;
        ++faces_checked;
    }
    EXPECT_GE(faces_checked, 3);  // floor, back, left/right/ceiling are in view
}

// Sub-texel alignment: frontal views of every face; the known texture shifted by (dx, dy)
// texels matches the rectified one best at (0, 0). (A pyramid-level coordinate bug once shifted
// the textures by 0.4–0.9 texel while the PSNR test above still passed.)
TEST(RenderRoomTexture, RectifyIsAligned) {
    Scene s = syntheticRoomScene(Size(320, 240), 260, 0.25, 1.5);
    const std::map<std::string, Mat> tex = makeRoomTextures(3, 128);
    struct View {
        const char* face;
        Vec3d eye, target;
    };
    const View views[] = {
        {"floor", {0.2, 1.0, 1.2}, {0.2, 1.01, 0}}, {"ceiling", {0.2, 1.0, 1.2}, {0.2, 1.01, 2.6}},
        {"back", {0.2, 2.5, 1.2}, {0.2, 4, 1.2}},   {"front", {0.2, 0.5, 1.2}, {0.2, -1, 1.2}},
        {"left", {-0.5, 1.5, 1.2}, {-2, 1.5, 1.2}}, {"right", {0.5, 1.5, 1.2}, {2, 1.5, 1.2}}};
    for (const View& vw : views) {
        const Camera c = lookAtCam(vw.eye, vw.target, 260, Size(320, 240));
        const Mat frame = renderTexturedRoom(c, s.room, tex, 2);
        Mat t, v, ref, inner;
        rectifyFace(frame, c, s.room, vw.face, Size(128, 128), t, v);
        tex.at(vw.face).convertTo(ref, CV_32FC3);
        erode(v, inner, Mat(), Point(-1, -1), 3);
        ASSERT_GT(countNonZero(inner), 500) << vw.face;
        double best = 1e300, bx = 9, by = 9;
        for (int iy = -5; iy <= 5; ++iy)
            for (int ix = -5; ix <= 5; ++ix) {
                Mat sh, d;
                const Mat M = (Mat_<double>(2, 3) << 1, 0, 0.1 * ix, 0, 1, 0.1 * iy);
                warpAffine(ref, sh, M, ref.size(), INTER_CUBIC, BORDER_REPLICATE);
                absdiff(t, sh, d);
                d = d.mul(d);
                d.setTo(Scalar::all(0), inner == 0);
                const Scalar e = sum(d);
                if (e[0] + e[1] + e[2] < best)
                    best = e[0] + e[1] + e[2], bx = 0.1 * ix, by = 0.1 * iy;
            }
        std::printf(
            "[ measured ] %s: best-matching shift of the known texture (%.1f, %.1f) texels\n",
            vw.face, bx, by);
        EXPECT_LE(std::abs(bx), 0.1 + 1e-9) << vw.face;
        EXPECT_LE(std::abs(by), 0.1 + 1e-9) << vw.face;
    }
}

// A texture put back into a scene and rendered reproduces the frame: the renderer's texture
// orientation and rectifyFace() agree on every face (room rendered as an emitter of the
// rectified radiance, direct view only).
TEST(RenderRoomTexture, RoundTripThroughRenderer) {
    vbme_test::ScratchDir dir;
    Scene s = syntheticRoomScene(Size(160, 120), 100, 0.1, 1.4);
    // Look at a corner so that floor, two walls and the ceiling are all in view.
    s.camera = lookAtCam(Vec3d(-0.5, 0.5, 1.4), Vec3d(2, 4, 1.8), 80, Size(160, 120));
    s.image_size = s.camera.image_size;
    s.camera.response = Response::LINEAR;
    const std::map<std::string, Mat> tex = makeRoomTextures(5, 64);
    Mat frame8 = renderTexturedRoom(s.camera, s.room, tex, 3), frame;
    frame8.convertTo(frame, CV_32FC3, 1.0 / 255);
    Scene r = s;
    for (const std::string& face : Room::faceNames()) {
        Mat t, v;
        rectifyFace(frame, s.camera, s.room, face, Size(96, 96), t, v);
        RenderImages img;
        img.color = t;
        writeExr(dir / (face + ".exr"), img);
        r.room.textures[face] = dir / (face + ".exr");
    }
    RenderScene::Params rp;
    rp.room_emissive = true;
    Ptr<RenderScene> rs = RenderScene::create(r, rp);
    Renderer::Params p;
    p.spp = 4;
    p.max_depth = 1;
    p.aovs = false;
    RenderImages out;
    Renderer::create(p)->render(*rs, s.camera, out);
    // Compare away from the image border (rectification never sees beyond it).
    Mat mask = Mat::zeros(frame.size(), CV_8U);
    mask(Rect(3, 3, frame.cols - 6, frame.rows - 6)).setTo(255);
    const double psnr = maskedPsnr(out.color, frame, mask, 1.0);
    // Oracle: the round trip (two resamplings) is closer to the frame than the frame itself
    // moved by one pixel; a flipped or misplaced face is far worse.
    const double psnr_px = maskedPsnr(shifted(frame, 1, 0), frame, mask, 1.0);
    std::printf(
        "[ measured ] round trip frame → textures → render: PSNR %.2f dB (frame moved "
        "by one pixel: %.2f dB)\n",
        psnr, psnr_px);
    imwrite(dir / "roundtrip_frame.png", frame8);
    Mat o8;
    out.color.convertTo(o8, CV_8UC3, 255);
    imwrite(dir / "roundtrip_render.png", o8);
    EXPECT_GT(psnr, psnr_px);
}

// Faces partly behind the camera: texels behind it are never marked valid, and the valid ones
// project inside the image.
TEST(RenderRoomTexture, FacePartlyBehindCamera) {
    Scene s = syntheticRoomScene(Size(320, 240), 260, 0.25, 1.5);
    const std::map<std::string, Mat> tex = makeRoomTextures(3, 64);
    const Mat frame = renderTexturedRoom(s.camera, s.room, tex, 1);
    Mat t, v;
    rectifyFace(frame, s.camera, s.room, "left", Size(200, 100), t, v);
    int bad = 0, seen = 0;
    for (int r = 0; r < v.rows; ++r)
        for (int c = 0; c < v.cols; ++c) {
            if (!v.at<uchar>(r, c)) continue;
            ++seen;
            const double u = (c + 0.5) / v.cols, vv = 1 - (r + 0.5) / v.rows;
            const Vec3d P(s.room.min[0], s.room.min[1] + u * 5, vv * 2.6);  // left: +y / +z
            double depth;
            const Point2d px = s.camera.project(P, &depth);
            if (depth <= 0 || px.x < -0.01 || px.y < -0.01 || px.x > 319.01 || px.y > 239.01) ++bad;
        }
    EXPECT_GT(seen, 100);
    EXPECT_LT(seen, v.rows * v.cols);  // the part behind the camera is not seen
    EXPECT_EQ(bad, 0);
}

// The accumulator fills texels that frame 0 does not see from a second camera, and with
// accumulate = false keeps only the last frame.
TEST(RenderRoomTexture, AccumulatorFillsUnseenTexels) {
    Scene s = syntheticRoomScene(Size(320, 240), 260, 0.25, 1.5);
    const std::map<std::string, Mat> tex = makeRoomTextures(7, 128);
    const Camera c0 = s.camera;
    const Camera c1 = lookAtCam(Vec3d(0.3, 1.0, 1.5), Vec3d(-2, 1.5, 1.0), 260, Size(320, 240));
    Mat f0, f1;
    renderTexturedRoom(c0, s.room, tex, 2).convertTo(f0, CV_32FC3, 1.0 / 255);
    renderTexturedRoom(c1, s.room, tex, 2).convertTo(f1, CV_32FC3, 1.0 / 255);
    RoomTextureParams p;
    p.max_size = 256;
    Ptr<RoomTextureAccumulator> acc = RoomTextureAccumulator::create(s.room, c0, p);
    acc->add(f0, c0);
    std::map<std::string, Mat> lin0, seen0, lin, seen;
    acc->textures(lin0, seen0);
    acc->add(f1, c1);
    acc->textures(lin, seen);
    EXPECT_EQ(acc->framesAdded(), 2);
    const int n0 = countNonZero(seen0.at("left")), n1 = countNonZero(seen.at("left"));
    std::printf("[ measured ] left wall texels seen: frame 0 %d, frames 0+1 %d of %d\n", n0, n1,
                seen.at("left").rows * seen.at("left").cols);
    EXPECT_GT(n1, n0 + 1000);
    // The new texels match the known texture.
    Mat ref;
    resize(tex.at("left"), ref, lin.at("left").size(), 0, 0, INTER_AREA);
    ref.convertTo(ref, CV_32FC3, 1.0 / 255);
    Mat added = seen.at("left") & ~seen0.at("left");
    erode(added, added, Mat());
    const double psnr = maskedPsnr(lin.at("left"), ref, added, 1.0);
    // Oracle: closer to the texture than the texture itself moved by one texel.
    const double psnr_tx = maskedPsnr(shifted(ref, 1, 0), ref, added, 1.0);
    std::printf(
        "[ measured ] texels filled from frame 1: PSNR %.2f dB (texture moved by one "
        "texel: %.2f dB)\n",
        psnr, psnr_tx);
    EXPECT_GT(psnr, psnr_tx);
    // Where both frames see it, the blend stays consistent with the texture.
    Mat both = seen.at("back") & seen0.at("back");
    Mat refb;
    resize(tex.at("back"), refb, lin.at("back").size(), 0, 0, INTER_AREA);
    refb.convertTo(refb, CV_32FC3, 1.0 / 255);
    erode(both, both, Mat());
    const double psnr_b = maskedPsnr(lin.at("back"), refb, both, 1.0);
    const double psnr_btx = maskedPsnr(shifted(refb, 1, 0), refb, both, 1.0);
    std::printf(
        "[ measured ] back wall after blending two frames: PSNR %.2f dB (texture moved "
        "by one texel: %.2f dB)\n",
        psnr_b, psnr_btx);
    EXPECT_GT(psnr_b, psnr_btx);

    RoomTextureParams q = p;
    q.accumulate = false;
    Ptr<RoomTextureAccumulator> per = RoomTextureAccumulator::create(s.room, c0, q);
    per->add(f0, c0);
    per->add(f1, c1);
    std::map<std::string, Mat> l2, s2;
    per->textures(l2, s2);
    Mat tv, vv;
    rectifyFace(f1, c1, s.room, "floor", l2.at("floor").size(), tv, vv);
    // per-frame: the textures are the last frame's only (minus its border band)
    EXPECT_EQ(countNonZero(s2.at("floor") & ~vv), 0);
}

// Pixels marked in `ignore` (and their neighbours) never reach a texture.
TEST(RenderRoomTexture, IgnoreMask) {
    Scene s = syntheticRoomScene(Size(160, 120), 130, 0.25, 1.5);
    const std::map<std::string, Mat> tex = makeRoomTextures(3, 64);
    Mat f;
    renderTexturedRoom(s.camera, s.room, tex, 1).convertTo(f, CV_32FC3, 1.0 / 255);
    Mat ignore = Mat::zeros(f.size(), CV_8U);
    ignore.colRange(0, 80).setTo(255);  // left half of the image
    Ptr<RoomTextureAccumulator> a = RoomTextureAccumulator::create(s.room, s.camera);
    Ptr<RoomTextureAccumulator> b = RoomTextureAccumulator::create(s.room, s.camera);
    a->add(f, s.camera);
    b->add(f, s.camera, ignore);
    std::map<std::string, Mat> la, sa, lb, sb;
    a->textures(la, sa);
    b->textures(lb, sb);
    // back wall: seen texels with the mask are a subset, about half
    const int na = countNonZero(sa.at("back")), nb = countNonZero(sb.at("back"));
    EXPECT_EQ(countNonZero(sb.at("back") & ~sa.at("back")), 0);
    EXPECT_GT(nb, na / 4);
    EXPECT_LT(nb, 3 * na / 5);
    // every texel still seen projects right of the mask (x > 80)
    const Size ts = sb.at("back").size();
    int bad = 0;
    for (int r = 0; r < ts.height; ++r)
        for (int c = 0; c < ts.width; ++c)
            if (sb.at("back").at<uchar>(r, c)) {
                const Vec3d P(-2 + 4 * (c + 0.5) / ts.width, 4, 2.6 * (1 - (r + 0.5) / ts.height));
                if (s.camera.project(P).x < 80) ++bad;
            }
    EXPECT_EQ(bad, 0);
}

TEST(RenderRoomTexture, ChooseSizeAndErrors) {
    Scene s = syntheticRoomScene(Size(640, 480), 520, 0.25, 1.5);
    RoomTextureParams p;
    const Size back = chooseFaceTextureSize(s.room, "back", s.camera, p);
    const Size floor = chooseFaceTextureSize(s.room, "floor", s.camera, p);
    std::printf("[ measured ] texture sizes for 640x480, f = 520: back %dx%d, floor %dx%d\n",
                back.width, back.height, floor.width, floor.height);
    // back wall 4 × 2.6 m at 5 m: about 520/5 ≈ 100 pixels per metre (more at its bottom edge)
    EXPECT_NEAR(double(back.width) / back.height, 4 / 2.6, 0.05);
    EXPECT_GE(back.width, 400);
    EXPECT_LE(back.width, 1200);
    p.max_size = 300;
    const Size fl2 = chooseFaceTextureSize(s.room, "floor", s.camera, p);
    EXPECT_LE(std::max(fl2.width, fl2.height), 300);
    Mat t, v;
    EXPECT_THROW(rectifyFace(Mat(480, 640, CV_8UC3, Scalar::all(0)), s.camera, s.room, "attic",
                             Size(64, 64), t, v),
                 cv::Exception);
    EXPECT_THROW(rectifyFace(Mat(10, 10, CV_8UC3, Scalar::all(0)), s.camera, s.room, "floor",
                             Size(64, 64), t, v),
                 cv::Exception);
}
