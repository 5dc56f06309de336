// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_ROOM_TEXTURE_HPP
#define OPENCV_VBME_RENDER_ROOM_TEXTURE_HPP

#include <map>
#include <string>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"
#include "opencv2/vbme/core/scene.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_render
//! @{

/** @brief Options of the room texture maps (thesis §5.1.2, the room's radiance textures).

A face's texture maps the face rectangle onto an image of Size(W, H) in the orientation the
renderer uses (RenderScene; DESIGN "Room textures"): image right / image up are floor +x / +y,
ceiling +x / −y, back +x / +z, front −x / +z, left +y / +z, right −y / +z. Texel (col, row)
is the face point bl + u·right + v·up with u = (col + ½)/W, v = 1 − (row + ½)/H.
*/
struct CV_EXPORTS RoomTextureParams {
    double texel_scale = 1.0;  //!< texels per image pixel at the sharpest view of the face
    int min_size = 64;         //!< smallest texture side
    int max_size = 2048;       //!< largest texture side
    bool accumulate = true;    //!< false: the thesis's per-frame textures (add() replaces)
    /** @brief Reads the fields present in @p fn. */
    void read(const FileNode& fn);
    /** @brief Writes the fields. */
    void write(FileStorage& fs) const;
    /** @brief Throws a cv::Exception naming the first field outside its valid range. */
    void check() const;
};

/** @brief The texture size of room face @p face for frames like @p camera's.

The thesis used a fixed 1000 × 1000 texture per face. Here the face is sampled on a 32 × 32
grid; at the points that @p camera sees (in front of it, inside the image) the local
magnification (pixels per metre, the geometric mean of the two singular values of the
projection's Jacobian on the face) is measured and its maximum m taken, so that the texture has
`texel_scale` texels per image pixel where the face is seen sharpest. A face the camera does
not see gets the largest m of the faces it sees (a hand-held camera sees the other walls at
similar distances); if it sees none, m = f / d with f the focal length and d the distance from
the camera to the face rectangle. Sides are then (face width, face height)·m·texel_scale,
scaled together so that the larger side is at most `max_size`, and each side clamped to
[`min_size`, `max_size`].
@param room the room box.
@param face a face name of Room::faceNames().
@param camera a camera with its image size set (e.g. the first frame's).
@param p options. */
CV_EXPORTS Size chooseFaceTextureSize(const Room& room, const std::string& face,
                                      const Camera& camera,
                                      const RoomTextureParams& p = RoomTextureParams());

/** @brief Rectifies a frame onto one room face (the homography of the face's corners,
evaluated per texel).

Every texel's face point is projected into the frame; it is used only when it lies in front of
the camera (depth > 10⁻⁶ of the room size, so faces partly behind the camera are cut at the
near plane per texel, never folded through infinity), faces the camera, and falls inside the
image (pixel centres 0 … w−1, 0 … h−1). The frame is sampled bilinearly from a Gaussian pyramid
level chosen by the texel's footprint (log₂ of its larger axis in pixels, blended between the two
nearest levels), so that a texture smaller than the image does not alias. Geometry in front of
the room (proxies, people) is not taken into account: mask it out with
RoomTextureAccumulator::add()'s `ignore`.
@param frame the frame, any depth, 3 channels.
@param camera its camera (K, cam_from_world, image size = frame size).
@param room the room box.
@param face a face name of Room::faceNames().
@param tex_size the texture size (e.g. chooseFaceTextureSize()).
@param texture receives CV_32FC3 values in the frame's units (0 where not seen).
@param valid receives CV_8U, 255 where the texel was seen. */
CV_EXPORTS void rectifyFace(InputArray frame, const Camera& camera, const Room& room,
                            const std::string& face, Size tex_size, OutputArray texture,
                            OutputArray valid);

/** @brief Accumulates the room's six face textures over many frames.

The thesis recomputed the textures in every frame from that frame alone, so texels that frame
does not see were missing. With `accumulate` (default) each add() blends the new frame into a
running weighted mean per texel, so texels unseen in frame 0 are filled from frames that see
them. An observation's weight is
`w = σ_min² · b`, where σ_min is the smaller singular value of the Jacobian of the
texel → pixel map (pixels per texel along the texel's worst direction: small when the face is
far away or seen at a grazing angle, so sharp, frontal views dominate), and `b` ramps from 0 to
1 over a border band of max(2, 1 % of the smaller image side) pixels from the image edge
(texels within one band of the edge are dropped, the next band blends in, which hides seams and
lens vignetting at the border). With `accumulate` = false, add() replaces the textures by those
of the new frame (the thesis's behaviour).

Texture sizes are fixed at create() by chooseFaceTextureSize() for the first camera.
Per texel the work is one projection and one bilinear pyramid lookup, in parallel over rows,
allocation-free (the frame's pyramid is built once per add()).
*/
class CV_EXPORTS RoomTextureAccumulator {
public:
    virtual ~RoomTextureAccumulator();
    /** @brief An empty accumulator for @p room, textures sized for @p first_camera. */
    static Ptr<RoomTextureAccumulator> create(const Room& room, const Camera& first_camera,
                                              const RoomTextureParams& p = RoomTextureParams());
    /** @brief Adds a frame.
    @param frame_linear CV_32FC3 linear BGR frame (camera.image_size).
    @param camera its camera.
    @param ignore optional CV_8U mask of the frame's size, non-zero = do not use the pixel
    (dilated by one pixel, so that bilinear samples never reach a masked pixel). */
    virtual void add(InputArray frame_linear, const Camera& camera,
                     InputArray ignore = noArray()) = 0;
    /** @brief Per face name (Room::faceNames()): the linear CV_32FC3 texture (0 where unseen)
    and a CV_8U mask, 255 where some frame saw the texel. */
    virtual void textures(std::map<std::string, Mat>& linear,
                          std::map<std::string, Mat>& seen) const = 0;
    /** @brief Number of add() calls so far. */
    virtual int framesAdded() const = 0;
    /** @brief The texture size of each face (Room::faceNames() order). */
    virtual std::map<std::string, Size> textureSizes() const = 0;
};

/** @brief Fills the texels of a room texture that no frame saw, by exemplar inpainting.

The texture is normalised by the 99.5th percentile of its seen values, encoded to 8 bits with
the sRGB curve, filled with ExemplarInpainter, and only the unseen texels are decoded back
(seen texels are left bit for bit). A texture whose longer side exceeds 256 texels is filled
at that reduced size and the fill upsampled: unseen texels only light inserted objects
indirectly or show in their reflections, so their detail matters little, and exemplar filling
of megapixel holes would dominate the room's preparation. A texture with no seen texel becomes
mid-grey (0.18).
@param texture_linear CV_32FC3 linear texture (RoomTextureAccumulator::textures()), filled in
place.
@param seen CV_8U mask of the texture's size, non-zero where a frame saw the texel. */
CV_EXPORTS void fillUnseenTexels(InputOutputArray texture_linear, InputArray seen);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
