// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_CAMERA_HPP
#define OPENCV_VBME_CORE_CAMERA_HPP

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "opencv2/vbme/core/response.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief A pinhole camera in the OpenCV convention (x right, y down, z forward).

A world point X maps to the camera frame by `X_cam = R * X_world + t` (`cam_from_world`), then
to pixels by K. Pixel centres sit at integer coordinates, so the image centre of a w×h image is
((w−1)/2, (h−1)/2). COLMAP puts pixel centres at +0.5: use toColmapPrincipalPoint() and
fromColmapPrincipalPoint() at that boundary. Rendering at another size scales K with scaled().

Lens distortion (optional, k1 ≠ 0): one radial coefficient. A point whose pinhole projection is
p (normalised `x = K⁻¹ p`) is seen by the real lens at `p_d = K x (1 + k1 |x|²)` — OpenCV's
k1 with the other coefficients 0, and exactly COLMAP's SIMPLE_RADIAL `k` (same normalised
coordinates; only the principal point moves by 0.5). project(), rayDirection() and the
renderer stay pinhole: they describe the *undistorted* image. distortPixel() and
undistortPixel() cross between the two; undistortImageK1() and distortImageK1() warp whole
images.
*/
struct CV_EXPORTS Camera {
    Matx33d K = Matx33d::eye();          //!< intrinsics: fx, fy, skew, cx, cy
    Matx33d R = Matx33d::eye();          //!< rotation of cam_from_world
    Vec3d t = Vec3d(0, 0, 0);            //!< translation of cam_from_world
    Size image_size;                     //!< image size in pixels (width, height)
    Response response = Response::SRGB;  //!< how the footage was display-encoded
    /** @brief Radial distortion of the footage's lens, `x_d = x (1 + k1 |x|²)` with
    `x = K⁻¹ p` (0: none). Written to files only when not 0. */
    double k1 = 0;

    /** @brief A camera with focal length @p f (pixels) and the principal point at the centre
    of an image of size @p size; identity pose. */
    static Camera fromFocal(double f, Size size);
    /** @brief Focal length in pixels of a pinhole camera whose horizontal field of view is
    @p hfov_deg degrees on an image @p width pixels wide: `(w/2) / tan(hfov/2)`. Throws unless
    width > 0 and 0 < hfov_deg < 180. */
    static double focalFromFov(int width, double hfov_deg);

    /** @brief Maps a world point to the camera frame (`R * X + t`). */
    Vec3d camFromWorld(const Vec3d& X_world) const { return R * X_world + t; }
    /** @brief Maps a camera-frame point back to the world frame (`R^T (X − t)`). */
    Vec3d worldFromCam(const Vec3d& X_cam) const { return R.t() * (X_cam - t); }
    /** @brief Camera centre in world coordinates (`−R^T t`). */
    Vec3d center() const { return -(R.t() * t); }

    /** @brief Projects a world point to pixel coordinates.
    @param X_world point in world coordinates (metres).
    @param depth if not null, receives the point's z in the camera frame (positive in front).
    @return pixel coordinates; meaningless when the depth is not positive. */
    Point2d project(const Vec3d& X_world, double* depth = nullptr) const;

    /** @brief Unit direction, in world coordinates, of the ray through pixel @p px. */
    Vec3d rayDirection(const Point2d& px) const;

    /** @brief The same camera for an image of size @p size: K is scaled so that pixel centres
    keep the DESIGN convention (integer centres), i.e. `(x + 0.5) * s − 0.5`. */
    Camera scaled(Size size) const;

    /** @brief Where the lens puts the point whose pinhole (undistorted) pixel is @p p:
    `K x (1 + k1 |x|²)`, x = K⁻¹ p. The identity when k1 = 0. */
    Point2d distortPixel(const Point2d& p) const;
    /** @brief Inverse of distortPixel(): the pinhole pixel of a pixel @p p of the distorted
    frame (Newton's method on the radius). For barrel distortion (k1 < 0) the radial map
    folds back at `|x|² = 1 / (3 |k1|)`; a @p p beyond the largest radius it reaches has no
    undistorted point: NaN is returned. */
    Point2d undistortPixel(const Point2d& p) const;
    /** @brief project() followed by distortPixel(): where the real lens images a world point. */
    Point2d projectDistorted(const Vec3d& X_world, double* depth = nullptr) const {
        return distortPixel(project(X_world, depth));
    }

    /** @brief 4×4 cam_from_world matrix. */
    Matx44d camFromWorldMatrix() const;

    /** @brief Principal point in COLMAP's convention (pixel centres at +0.5). */
    Point2d toColmapPrincipalPoint() const { return Point2d(K(0, 2) + 0.5, K(1, 2) + 0.5); }
    /** @brief Sets the principal point from COLMAP's convention (subtracts 0.5). */
    void fromColmapPrincipalPoint(const Point2d& c) {
        K(0, 2) = c.x - 0.5;
        K(1, 2) = c.y - 0.5;
    }

    /** @brief Writes the camera as a FileStorage map body (K, R, t, response; k1 when not
    0). */
    void write(FileStorage& fs) const;
    /** @brief Reads a camera written by write(); matrices may also be nested sequences.
    Throws cv::Exception naming the missing or malformed field. */
    void read(const FileNode& node);
};

/** @brief The undistorted (pinhole) image of a frame filmed through @p cam's lens: pixel p
takes the frame's value at cam.distortPixel(p) (cv::remap), same size and K. A copy when
cam.k1 = 0. Pixels whose source lies outside the frame (pincushion, k1 > 0, near the corners)
follow @p border_mode. Calibration, camera tracking and the room model see frames through
this. */
CV_EXPORTS void undistortImageK1(InputArray distorted, OutputArray undistorted, const Camera& cam,
                                 int interpolation = INTER_LINEAR,
                                 int border_mode = BORDER_REPLICATE);

/** @brief The inverse warp: an image of the pinhole camera @p cam (a render) as @p cam's lens
shows it. Pixel p of the result takes the source's value at cam.undistortPixel(p); where that
lies outside the source or does not exist, the result is 0 (barrel distortion, k1 < 0, shows
more than the pinhole image holds near the frame's edges). A copy when cam.k1 = 0. Insertion
warps every differential-rendering layer so before compositing with the footage. */
CV_EXPORTS void distortImageK1(InputArray undistorted, OutputArray distorted, const Camera& cam,
                               int interpolation = INTER_LINEAR);

/** @brief The pinhole camera whose image holds everything @p cam's lens shows: the same pose,
focal lengths and k1, the principal point moved by whole pixels and the image enlarged so that
the undistorted point (Camera::undistortPixel) of every pixel of @p cam's frame lies inside it,
with a 2-pixel border for interpolation. Barrel distortion (k1 < 0) sees more near the frame's
edges than the pinhole image of the same size and K: a render of this camera, warped by the
distortImageK1() that takes the source camera, fills the whole frame. For
k1 ≥ 0 (and where the barrel frame reaches beyond the fold, up to the fold's radius) the image
is not made smaller than @p cam's: @p cam itself is returned when k1 = 0. */
CV_EXPORTS Camera lensCoverCamera(const Camera& cam);

/** @brief distortImageK1() for an image rendered by another pinhole camera @p source of the
same pose and focal lengths (e.g. lensCoverCamera(cam)): pixel p of the result (of size
cam.image_size) takes the source's value at `source.K · cam.K⁻¹ · cam.undistortPixel(p)`; 0
where that lies outside the source. With source = cam it is the warp above. */
CV_EXPORTS void distortImageK1(InputArray undistorted, OutputArray distorted, const Camera& cam,
                               const Camera& source, int interpolation = INTER_LINEAR);

/** @brief undistortImageK1() into another pinhole camera @p target of the same pose and focal
lengths (e.g. lensCoverCamera(cam)): pixel p of the result (of size target.image_size) takes the
frame's value at `cam.distortPixel(cam.K · target.K⁻¹ · p)`, following @p border_mode outside
the frame. */
CV_EXPORTS void undistortImageK1(InputArray distorted, OutputArray undistorted, const Camera& cam,
                                 const Camera& target, int interpolation = INTER_LINEAR,
                                 int border_mode = BORDER_REPLICATE);

/** @brief Principal point at the image centre of the DESIGN convention: ((w−1)/2, (h−1)/2). */
CV_EXPORTS Point2d imageCenter(Size size);

/** @brief Converts a rotation to a proper orthonormal matrix (nearest rotation by SVD). */
CV_EXPORTS Matx33d orthonormalize(const Matx33d& R);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
