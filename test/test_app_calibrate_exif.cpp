// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// A photograph's focal length from its EXIF block (readExifFocal, issue 19) and its use as the
// focal prior of `vbme calibrate --image F.jpg --auto`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

#include <libexif/exif-data.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/vbme/calib.hpp>
#include <opencv2/vbme/core/scene.hpp>
#include <opencv2/vbme/datasets/room.hpp>

#include "vbme_test_util.hpp"

using namespace cv;
using namespace cv::vbme;

namespace {

/** What the test writes into an EXIF block (0: the tag is left out). */
struct Tags {
    int focal_35mm = 0;
    double focal_mm = 0;
    double plane_res = 0;  // pixels per inch
    int pixel_width = 0;
    const char* model = nullptr;
};

void addEntry(ExifData* d, ExifIfd ifd, ExifTag tag, ExifFormat fmt, unsigned components,
              const void* bytes, unsigned size) {
    ExifMem* mem = exif_mem_new_default();
    ExifEntry* e = exif_entry_new_mem(mem);
    e->tag = tag;
    e->format = fmt;
    e->components = components;
    e->size = size;
    e->data = static_cast<unsigned char*>(exif_mem_alloc(mem, size));
    std::memcpy(e->data, bytes, size);
    exif_content_add_entry(d->ifd[ifd], e);
    exif_entry_unref(e);
    exif_mem_unref(mem);
}

/** The APP1 payload ("Exif\0\0" + TIFF) of an EXIF block with @p t, little-endian. */
std::vector<uchar> exifBlock(const Tags& t) {
    ExifData* d = exif_data_new();
    exif_data_set_byte_order(d, EXIF_BYTE_ORDER_INTEL);
    const ExifByteOrder o = EXIF_BYTE_ORDER_INTEL;
    unsigned char b[8];
    if (t.focal_35mm > 0) {
        exif_set_short(b, o, (ExifShort)t.focal_35mm);
        addEntry(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM, EXIF_FORMAT_SHORT, 1, b, 2);
    }
    if (t.focal_mm > 0) {
        exif_set_rational(b, o, ExifRational{(ExifLong)std::lround(t.focal_mm * 100), 100});
        addEntry(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH, EXIF_FORMAT_RATIONAL, 1, b, 8);
    }
    if (t.plane_res > 0) {
        exif_set_rational(b, o, ExifRational{(ExifLong)std::lround(t.plane_res), 1});
        addEntry(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_X_RESOLUTION, EXIF_FORMAT_RATIONAL, 1, b,
                 8);
        exif_set_short(b, o, 2);  // inches
        addEntry(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT, EXIF_FORMAT_SHORT, 1, b,
                 2);
    }
    if (t.pixel_width > 0) {
        exif_set_long(b, o, (ExifLong)t.pixel_width);
        addEntry(d, EXIF_IFD_EXIF, EXIF_TAG_PIXEL_X_DIMENSION, EXIF_FORMAT_LONG, 1, b, 4);
    }
    if (t.model) {
        const unsigned n = (unsigned)std::strlen(t.model) + 1;
        addEntry(d, EXIF_IFD_0, EXIF_TAG_MODEL, EXIF_FORMAT_ASCII, n, t.model, n);
    }
    unsigned char* buf = nullptr;
    unsigned int len = 0;
    exif_data_save_data(d, &buf, &len);
    std::vector<uchar> out(buf, buf + len);
    free(buf);
    exif_data_unref(d);
    return out;
}

/** @p img as a JPEG with @p app1 spliced in after the start-of-image marker. */
void writeJpeg(const std::string& path, const Mat& img, const std::vector<uchar>& app1) {
    std::vector<uchar> jpg;
    ASSERT_TRUE(imencode(".jpg", img, jpg, {IMWRITE_JPEG_QUALITY, 95}));
    ASSERT_GE(jpg.size(), 4u);
    std::vector<uchar> out(jpg.begin(), jpg.begin() + 2);
    if (!app1.empty()) {
        const size_t n = app1.size() + 2;
        ASSERT_LT(n, 65536u);
        const uchar head[4] = {0xFF, 0xE1, uchar(n >> 8), uchar(n & 0xFF)};
        out.insert(out.end(), head, head + 4);
        out.insert(out.end(), app1.begin(), app1.end());
    }
    out.insert(out.end(), jpg.begin() + 2, jpg.end());
    std::ofstream(path, std::ios::binary)
        .write((const char*)out.data(), (std::streamsize)out.size());
}

}  // namespace

// The tags come back as written; the focal length in pixels follows the focal plane when it is
// there (exact) and the 35 mm equivalent otherwise; no EXIF, a damaged one and a missing file
// each say so.
TEST(AppCalibrateExif, ReadsTheFocalTags) {
    vbme_test::ScratchDir dir;
    const Mat img(480, 640, CV_8UC3, Scalar(90, 120, 150));
    Tags t;
    t.focal_35mm = 28;
    t.focal_mm = 4.25;
    t.model = "Test Phone 1";
    writeJpeg(dir / "a.jpg", img, exifBlock(t));
    ExifFocal f = readExifFocal(dir / "a.jpg");
    ASSERT_TRUE(f.has_exif);
    EXPECT_EQ(f.focal_35mm, 28);
    EXPECT_NEAR(f.focal_mm, 4.25, 1e-12);
    EXPECT_EQ(f.model, "Test Phone 1");
    std::string source;
    EXPECT_NEAR(f.focalPixels(Size(640, 480), &source), 28 / std::hypot(36.0, 24.0) * 800, 1e-9);
    EXPECT_EQ(source, "35 mm equivalent");

    // a 4.25 mm lens on a sensor of 2400 pixels per inch, stored 4000 pixels wide, the image
    // decoded at 640: 4.25 / 25.4 * 2400 px on the sensor, × 640 / 4000
    t.plane_res = 2400;
    t.pixel_width = 4000;
    writeJpeg(dir / "b.jpg", img, exifBlock(t));
    f = readExifFocal(dir / "b.jpg");
    EXPECT_NEAR(f.focalPixels(Size(640, 480), &source), 4.25 / 25.4 * 2400 * 640 / 4000, 1e-6);
    EXPECT_EQ(source, "focal plane");

    imwrite(dir / "c.png", img);
    writeJpeg(dir / "d.jpg", img, {});
    for (const char* name : {"c.png", "d.jpg"}) {
        f = readExifFocal(dir / name);
        EXPECT_FALSE(f.has_exif) << name;
        EXPECT_EQ(f.focalPixels(Size(640, 480)), 0.0) << name;
    }
    // an APP1 that says Exif and then holds noise: no crash, no focal length
    std::vector<uchar> junk = {'E', 'x', 'i', 'f', 0, 0, 'I', 'I', 42, 0, 8, 0, 0, 0, 0xFF, 0x7F};
    RNG rng(7);
    for (int i = 0; i < 300; ++i)
        junk.push_back((uchar)rng.uniform(0, 256));
    writeJpeg(dir / "e.jpg", img, junk);
    EXPECT_NO_THROW(f = readExifFocal(dir / "e.jpg"));
    EXPECT_EQ(f.focal_35mm, 0.0);
    EXPECT_THROW(readExifFocal(dir / "none.jpg"), cv::Exception);
}

// `vbme calibrate --image F.jpg --auto` takes the EXIF focal length as its prior, the same as
// --focal-35mm with that value; --no-exif ignores it; --focal-35mm overrides it.
TEST(AppCalibrateExif, CalibrateTakesTheExifPrior) {
    vbme_test::ScratchDir dir;
    Camera cam = Camera::fromFocal(520, Size(640, 480));
    Matx33d yaw, pitch;
    Rodrigues(Vec3d(0, 0, -25 * CV_PI / 180), yaw);
    Rodrigues(Vec3d(10 * CV_PI / 180, 0, 0), pitch);
    cam.R = pitch * Matx33d(1, 0, 0, 0, 0, -1, 0, 1, 0) * yaw;
    placeCamera(cam, 1.5);
    Room room;
    room.min = Vec3d(-2.2, -1.4, 0);
    room.max = Vec3d(2.6, 3.0, 2.7);
    Tags t;
    t.focal_35mm = 28;  // 517.7 px at 640×480, near the true 520
    writeJpeg(dir / "room.jpg", drawSyntheticRoom(cam, room, 0.5, 1.0, 3), exifBlock(t));
    const std::string base = std::string(VBME_EXE) + " calibrate --image " + dir / "room.jpg" +
                             " --auto --camera-height 1.5 --out ";
    auto r = vbme_test::run(base + dir / "exif.yml");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("focal prior from the EXIF"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("517.7 px"), std::string::npos) << r.output;
    r = vbme_test::run(base + dir / "given.yml --focal-35mm 28");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find("focal prior from the EXIF"), std::string::npos) << r.output;
    EXPECT_EQ(Scene::read(dir / "exif.yml").camera.K(0, 0),
              Scene::read(dir / "given.yml").camera.K(0, 0));
    r = vbme_test::run(base + dir / "none.yml --no-exif");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find("focal prior from the EXIF"), std::string::npos) << r.output;
    const double f = Scene::read(dir / "exif.yml").camera.K(0, 0);
    std::printf("focal with the EXIF prior %.2f px, without %.2f px (true 520)\n", f,
                Scene::read(dir / "none.yml").camera.K(0, 0));
    EXPECT_LT(std::abs(f / 520 - 1), 0.05);
}
