// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The lens's focal length from a photograph's EXIF block (libexif).
#include "opencv2/vbme/calib/exif.hpp"

#include <cmath>
#include <filesystem>
#include <memory>

#include <libexif/exif-data.h>

namespace cv {
namespace vbme {

namespace {

struct ExifDataFree {
    void operator()(ExifData* d) const { exif_data_unref(d); }
};

// The first entry of @p tag in any IFD, or null.
ExifEntry* entry(ExifData* d, ExifTag tag) {
    for (int i = 0; i < EXIF_IFD_COUNT; ++i)
        if (ExifEntry* e = exif_content_get_entry(d->ifd[i], tag)) return e;
    return nullptr;
}

double number(ExifData* d, ExifTag tag) {
    ExifEntry* e = entry(d, tag);
    if (!e || !e->data || e->components < 1) return 0;
    const ExifByteOrder o = exif_data_get_byte_order(d);
    double v = 0;
    switch (e->format) {
        case EXIF_FORMAT_SHORT:
            if (e->size >= 2) v = exif_get_short(e->data, o);
            break;
        case EXIF_FORMAT_LONG:
            if (e->size >= 4) v = exif_get_long(e->data, o);
            break;
        case EXIF_FORMAT_RATIONAL:
            if (e->size >= 8) {
                const ExifRational r = exif_get_rational(e->data, o);
                v = r.denominator ? double(r.numerator) / r.denominator : 0;
            }
            break;
        case EXIF_FORMAT_SRATIONAL:
            if (e->size >= 8) {
                const ExifSRational r = exif_get_srational(e->data, o);
                v = r.denominator ? double(r.numerator) / r.denominator : 0;
            }
            break;
        default:
            break;
    }
    return std::isfinite(v) && v > 0 ? v : 0;
}

std::string text(ExifData* d, ExifTag tag) {
    ExifEntry* e = entry(d, tag);
    if (!e || !e->data || e->format != EXIF_FORMAT_ASCII) return std::string();
    std::string s(reinterpret_cast<const char*>(e->data), e->size);
    s = s.substr(0, s.find('\0'));
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    return s;
}

}  // namespace

double focalFrom35mm(double focal_35mm, Size image_size) {
    return focal_35mm / std::hypot(36.0, 24.0) * std::hypot(image_size.width, image_size.height);
}

double ExifFocal::focalPixels(Size image_size, std::string* source) const {
    if (source) source->clear();
    const double longer = std::max(image_size.width, image_size.height);
    if (longer <= 0) return 0;
    if (focal_mm > 0 && plane_x_resolution > 0 && plane_unit_mm > 0 && pixel_width > 0) {
        if (source) *source = "focal plane";
        // PixelXDimension is the stored (sensor) width, the longer side for landscape sensors
        return focal_mm * plane_x_resolution / plane_unit_mm * longer /
               std::max<double>(pixel_width, 1);
    }
    if (focal_35mm > 0) {
        if (source) *source = "35 mm equivalent";
        return focalFrom35mm(focal_35mm, image_size);
    }
    return 0;
}

ExifFocal readExifFocal(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        CV_Error(Error::StsObjectNotFound, "'" + path + "': no such file (reading its EXIF)");
    ExifFocal f;
    std::unique_ptr<ExifData, ExifDataFree> d(exif_data_new_from_file(path.c_str()));
    if (!d) return f;
    f.has_exif = true;
    f.focal_mm = number(d.get(), EXIF_TAG_FOCAL_LENGTH);
    f.focal_35mm = number(d.get(), EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM);
    f.plane_x_resolution = number(d.get(), EXIF_TAG_FOCAL_PLANE_X_RESOLUTION);
    switch ((int)number(d.get(), EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT)) {
        case 2:
            f.plane_unit_mm = 25.4;
            break;  // inch
        case 3:
            f.plane_unit_mm = 10;
            break;  // centimetre
        case 4:
            f.plane_unit_mm = 1;
            break;  // millimetre
        default:
            f.plane_unit_mm = 0;
            break;  // 1 (no unit) or absent
    }
    f.pixel_width = (int)number(d.get(), EXIF_TAG_PIXEL_X_DIMENSION);
    f.make = text(d.get(), EXIF_TAG_MAKE);
    f.model = text(d.get(), EXIF_TAG_MODEL);
    return f;
}

}  // namespace vbme
}  // namespace cv
