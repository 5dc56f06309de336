// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_DATASETS_RENDERED_BALL_CLIP_HPP
#define OPENCV_VBME_DATASETS_RENDERED_BALL_CLIP_HPP

#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/scene.hpp"
#include "opencv2/vbme/track/disk.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_datasets
//! @{

/** @brief A clip rendered with vbme_render: a ball of any material (coloured Lambertian by
default; chrome, glass, plastic, … through Params::material) rolling on a textured floor in
front of a textured wall, lit by a known light (a distant light plus an environment), static
camera, with its ground truth. The input of the material-editing demo, tests and benchmarks;
the same clip with another ball material (same scene, lights, path and seeds) is the
path-traced truth of a material edit.

The scene (world z up, metres): a floor (z = 0, grey and slate tiles) and a wall (x = 1.6,
facing −x, pale grey-green blocks), both proxy meshes with procedural textures of low
saturation, so that the ball is separable from them by hue and saturation; a ball of radius
0.18 m (a smooth UV sphere, the `objects:` mesh, material Lambertian `albedo` or
Params::material) rolling without slipping along the floor from (x, y) = (−0.35, 0.55) to
(0.15, −0.55) over the clip (its centre at z = radius, the mesh turning by distance / radius
about the horizontal axis normal to its motion); a distant key light of half-angle 2° towards `to_light` (irradiance 2.8 on a surface
facing it, warm white) and a constant sky of radiance (0.2, 0.23, 0.28) (RGB). The camera
stands at (−2.4, 0, 1.2) looking along +x, pitched 25° down, with a 60° horizontal field of
view, so the ball rolls from the left of the image to the right, away from the camera, and the
default key light (−0.4, 0.5, 0.75) comes from the upper left, in front of the ball (the ball
is lit from the side the camera sees, its shadow falls behind it to the right; a `to_light`
with x > 0 comes from behind the wall, which then shades the floor). There is no
room box, so DESIGN's room axis naming (+y towards the back wall) does not apply. The ball
stays in the central part of the image: its silhouette, an ellipse under perspective, is within
0.64 pixel of the circle of truthDisk() at 640×480 (see truthDiskError()).

Frame i is path traced (vbme_render's Renderer, max depth 5, the tiles of a frame in parallel)
at Params::spp with seed `seed + i` (noise changes from frame to frame as a camera's would) and
display-encoded with sRGB; frames are a pure function of (Params, i), bitwise identical for any
thread count. The meshes and textures are written once to a private temporary folder that lives
as long as the object (and its copies).
*/
class CV_EXPORTS RenderedBallClip {
public:
    /** @brief What the clip contains and how it is rendered. */
    struct CV_EXPORTS Params {
        Params();                               //!< the defaults below
        Size size = Size(640, 480);             //!< frame size
        int frames = 48;                        //!< number of frames
        int spp = 16;                           //!< samples per pixel
        double fps = 30;                        //!< frame rate of written videos
        Vec3d albedo = Vec3d(0.8, 0.25, 0.05);  //!< ball colour (RGB, linear)
        /** @brief true: the ball is #material (any type, e.g. Material::preset("chrome") or
        "glass", path traced with refraction) instead of a Lambertian of #albedo. */
        bool has_material = false;
        Material material;                        //!< the ball's material when #has_material
        Vec3d to_light = Vec3d(-0.4, 0.5, 0.75);  //!< world direction towards the key light
        uint64 seed = 0;                          //!< sampler seed of frame 0
    };

    /** @brief Prepares the clip: writes the textures and meshes to a temporary folder. Throws
    cv::Exception if a parameter is out of range (size, frames ≥ 1, spp ≥ 1, albedo in [0,1],
    to_light pointing above the floor, an emissive material). */
    explicit RenderedBallClip(const Params& p = Params());
    /** @brief The settings. */
    const Params& params() const;
    /** @brief The scene of frame @p i (camera, floor and wall proxies, lights, the ball as an
    `objects:` mesh); its files live in the clip's temporary folder. */
    Scene scene(int frame) const;
    /** @brief Rendered frame @p i, 8-bit BGR, display-encoded (srgb). */
    Mat frame(int i) const;
    /** @brief Rendered frame @p i, linear scene-referred radiance (CV_32FC3, BGR). */
    Mat frameLinear(int i) const;
    /** @brief The ball's image disk in frame @p i: centre = centroid and radius = equal-area
    radius of the sphere's exact perspective silhouette (an ellipse). */
    Disk truthDisk(int i) const;
    /** @brief Largest distance (pixels) between the sphere's exact silhouette in frame @p i and
    the circle of truthDisk(i): how far the ellipse is from a circle. */
    double truthDiskError(int i) const;
    /** @brief The ball's centre in world coordinates in frame @p i (metres). */
    Vec3d ballCenter(int i) const;
    /** @brief The ball's radius (metres). */
    double ballRadius() const;
    /** @brief Key light direction (unit, towards the light) in camera coordinates. */
    Vec3d truthLightDirCamera() const;
    /** @brief Camera focal length in pixels. */
    double focal() const;
    /** @brief Renders the whole clip: the video (a lossless FFV1 `.mkv`/`.avi`, or a printf
    pattern of PNG images, by the path; see cv::vbme::VideoSink) and the frame-0 mask of the ball
    (8-bit PNG, 255 = ball, from truthDisk(0)), with progress. Both are written under temporary
    names renamed when complete. An empty @p first_mask skips the mask. */
    void write(const std::string& video, const std::string& first_mask) const;
    /** @brief Writes the truth as CSV: `frame,cx,cy,r` (truthDisk per frame). Atomic. */
    void writeTruth(const std::string& csv) const;

private:
    struct Impl;
    std::shared_ptr<Impl> impl_;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
