// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CALIB_EXIF_HPP
#define OPENCV_VBME_CALIB_EXIF_HPP

#include <string>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_calib
//! @{

/** @brief What a photograph's EXIF block says about its lens (readExifFocal()). Zero where
the file does not say. */
struct CV_EXPORTS ExifFocal {
    bool has_exif = false;          //!< the file has an EXIF block libexif could parse
    double focal_mm = 0;            //!< FocalLength (0x920A), millimetres
    double focal_35mm = 0;          //!< FocalLengthIn35mmFilm (0xA405), millimetres
    double plane_x_resolution = 0;  //!< FocalPlaneXResolution (0xA20E), pixels per unit
    double plane_unit_mm = 0;       //!< FocalPlaneResolutionUnit (0xA210) in mm (25.4, 10, 1)
    int pixel_width = 0;            //!< PixelXDimension (0xA002): the width the plane refers to
    std::string make, model;        //!< Make (0x010F), Model (0x0110)

    /** @brief The focal length in pixels of an image @p image_size (as decoded, i.e. after the
    EXIF orientation is applied, so width and height may be swapped against the sensor's), or 0
    when the EXIF does not give one.

    From the focal plane resolution when present (exact for the sensor's pixels: f_mm ×
    resolution / unit, scaled by the image's longer side over PixelXDimension's, which is the
    sensor's longer side as stored), else from the 35 mm equivalent (the diagonal of a 36 × 24 mm
    frame, 43.27 mm, over the image's diagonal in pixels: exact for a crop of a 3:2 frame, an
    approximation for 4:3 sensors, whose makers state the equivalent for the diagonal too).
    @param image_size the decoded image's size.
    @param source if not null, receives which tags were used ("focal plane", "35 mm
    equivalent"), or empty. */
    double focalPixels(Size image_size, std::string* source = nullptr) const;
};

/** @brief The focal length in pixels of a 35 mm equivalent focal length @p focal_35mm for an
image of @p image_size: the 36 × 24 mm frame's diagonal (43.27 mm) maps to the image's diagonal
(the convention of CIPA DC-008 for FocalLengthIn35mmFilm). */
CV_EXPORTS double focalFrom35mm(double focal_35mm, Size image_size);

/** @brief Reads the lens's focal length from the EXIF block of a photograph (JPEG, or another
container libexif reads), through libexif.

A file without EXIF, or with an EXIF block libexif cannot parse, gives `has_exif = false`
(not an error: most frames of a video, screenshots and PNGs have none); a file that cannot be
read at all throws cv::Exception naming it. Values that are not finite or not positive are
left 0. */
CV_EXPORTS ExifFocal readExifFocal(const std::string& path);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
