// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_DATASETS_INSERTION_SEQUENCE_HPP
#define OPENCV_VBME_DATASETS_INSERTION_SEQUENCE_HPP

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/vbme/calib/frame_calibration.hpp>
#include <opencv2/vbme/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_datasets
//! @{

/** @brief Writes a smooth closed tube along a (2, 3) torus knot (a trefoil lying flat) as a
Wavefront OBJ with vertex normals: the procedural object of the insertion demo and tests.

The object's frame has z up; its bounding box's bottom centre is the origin (so that a
translation puts it on a floor) and its larger horizontal side is @p width; the tube's radius
is about `0.08 · width`, the height about `0.5 · width`. Written atomically.
@param path the .obj file.
@param width overall width in metres.
@param segments samples along the knot; @p sides samples around the tube. */
CV_EXPORTS void writeTorusKnotObj(const std::string& path, double width = 0.28, int segments = 360,
                                  int sides = 24);

/** @brief The world_from_object matrix that puts an object whose bounding-box bottom centre
is its origin on the floor (z = room.min.z) where the ray of @p camera through pixel @p px
meets it, turned by @p yaw_rad about the vertical. Throws cv::Exception when the ray does not
go down to the floor. */
CV_EXPORTS Matx44d floorPlacement(const Camera& camera, const Room& room, Point2d px,
                                  double yaw_rad = 0);

/** @brief A synthetic hand-held video of a textured room, with the annotation a user would
give, for object insertion with a known answer (the `vbme demo` input and the end-to-end
tests).

The true scene is the box room of syntheticRoomScene() with the procedural textures of
makeRoomTextures() as **albedo** of its faces, lit only by lights in the room (a ceiling panel
in view of the first frame and, optionally, a panel on the back wall — a closed room has no
sky); the object is a plastic torus knot (writeTorusKnotObj()) standing on the floor where
the first frame's pixel Params::place looks. The camera walks along handheldCameraPath().
Every frame is path traced once with renderDifferential(): the input video is the room
without the object, the truth the same samples with it (so their difference is the object's
effect alone, without noise between them).

The annotation (FrameAnnotation, the file `vbme calibrate` reads) is what a person would click
on frame 0: room edges as three groups of parallel lines, points where the walls meet the
floor and ceiling, the light polygons (no radiance: the pipeline estimates it), the camera
height and the distance of the wall behind the camera; each clicked point is the true point's
projection plus Gaussian noise of Params::click_noise_px. It does not contain the camera.
By the DESIGN conventions (world origin on the floor below the first camera, +y the horizontal
direction it looks along, z up) the calibrated world frame is the true one.

Files written into the folder given to the constructor: the six face textures
(`tex_<face>.png`), `object.obj`, `annotation.yml`, `true_scene.yml` (camera of frame 0,
room, lights, object, render settings), `true_cameras.yml` (CameraPath of all frames); and by
writeVideos(): `input.mkv`, `truth.mkv` (lossless FFV1) and `region/mask_%05d.png` (255 where
the object changes the picture: its silhouette dilated, and its shadow).

@code
cv::vbme::SyntheticInsertionSequence::Params p;
p.frames = 24;
cv::vbme::SyntheticInsertionSequence seq("demo/input", p);
seq.writeVideos();      // input.mkv, truth.mkv, region/
// … calibrate from seq.annotationPath(), track input.mkv, then:
seq.addObject(calibrated_scene);   // the same object, placed with the calibrated camera
@endcode
*/
class CV_EXPORTS SyntheticInsertionSequence {
public:
    /** @brief Settings. */
    struct CV_EXPORTS Params {
        Params();                     //!< the defaults below
        Size size = Size(640, 480);   //!< frame size
        int frames = 24;              //!< number of frames
        int spp = 16;                 //!< samples per pixel of the renders
        int max_depth = 4;            //!< path length of the renders
        int seed = 1;                 //!< textures, camera shake, click noise and render seed
        double travel = 0.6;          //!< length of the walk (m; see handheldCameraPath())
        double shake_m = 0.004;       //!< hand shake, metres
        double shake_deg = 0.3;       //!< hand shake, degrees
        double focal = 0;             //!< focal length (px); 0: 0.6 × width (80° wide)
        double pitch_deg = 9;         //!< first camera's downward pitch
        double camera_height = 1.5;   //!< first camera's height above the floor (m)
        int texture_size = 1024;      //!< side of each face texture
        double click_noise_px = 0.3;  //!< standard deviation of the clicked points (px)
        /** @brief First-frame pixel under which the object stands; negative: (0.6 w, 0.78 h), which
        stays in view along the default walk. */
        Point2d place = Point2d(-1, -1);
        double object_width = 0.36;                     //!< object size (m)
        double object_yaw_deg = 20;                     //!< object turn about the vertical
        Vec3d object_albedo = Vec3d(0.65, 0.07, 0.04);  //!< plastic diffuse colour (linear RGB)
        double object_roughness = 0.12;                 //!< plastic microfacet α
        Vec3d ceiling_radiance = Vec3d(14, 13, 11.5);   //!< ceiling panel radiance (linear RGB)
        bool wall_light = true;                         //!< also a panel on the back wall
        Vec3d wall_radiance = Vec3d(6, 7, 8);           //!< back-wall panel radiance
        double fps = 24;                                //!< frame rate of the videos
        int threads = 0;                                //!< render threads (0: all cores)
    };

    /** @brief Builds the true scene, the camera path and the annotation, and writes the
    textures, object, annotation and true scene into @p dir (created if needed). Rendering is
    left to renderFrame() / writeVideos(). */
    explicit SyntheticInsertionSequence(const std::string& dir, const Params& params = Params());
    ~SyntheticInsertionSequence();

    /** @brief The settings (defaults resolved: focal, place). */
    const Params& params() const;
    /** @brief The folder of the files. */
    const std::string& dir() const;
    /** @brief The true frame-0 scene: camera, textured room, lights, object, render settings. */
    const Scene& trueScene() const;
    /** @brief The true camera of every frame. */
    const std::vector<Camera>& cameras() const;
    /** @brief The true camera path (as `vbme track-camera` writes it). */
    CameraPath truePath() const;
    /** @brief The user's annotation of frame 0 (also in annotationPath()). */
    const FrameAnnotation& annotation() const;
    /** @brief The object in the true world frame (absolute mesh path, plastic material). */
    const SceneObject& object() const;
    /** @brief Adds the object to @p scene (e.g. the calibrated one), standing on its floor
    under the first-frame pixel Params::place as @p scene's camera sees it, with the demo's
    material and spp / max_depth as render settings. */
    void addObject(Scene& scene) const;

    /** @brief `annotation.yml`. */
    std::string annotationPath() const;
    /** @brief `true_scene.yml`. */
    std::string trueScenePath() const;
    /** @brief `true_cameras.yml`. */
    std::string trueCamerasPath() const;
    /** @brief `input.mkv`: the room without the object (what a user filmed). */
    std::string inputVideoPath() const;
    /** @brief `truth.mkv`: the same frames with the object really there. */
    std::string truthVideoPath() const;
    /** @brief `region/mask_%05d.png` for frame @p i. */
    std::string regionPath(int i) const;

    /** @brief Renders frame @p i: @p input (8-bit BGR, sRGB-encoded, without the object),
    @p truth (with it) and @p region (CV_8U, 255 where the object or its shadow changes the
    picture: the silhouette dilated by 6 px, and the pixels whose smoothed change exceeds 2 %
    of the frame's mean). @p seed ≥ 0 replaces the render seed (Params::seed), e.g. to measure
    the render noise of the truth. */
    void renderFrame(int i, Mat& input, Mat& truth, Mat& region, int seed = -1) const;

    /** @brief The differential truth of frame @p i: @p input (the frame of inputVideoPath(),
    8-bit BGR) with the change the object makes, rendered from the true scene with @p spp
    samples per pixel and render seed @p seed and composited additively (compositeDifferential(),
    SHADOWS_ADDITIVE): the object's pixels from the render, the others
    `input + (I_obj − I_noObj)`.

    It is what an insertion given the true scene would make, with samples of its own: unlike
    truthVideoPath(), whose frames share every sample with the input (and so with an insertion
    that renders the scene at the input's seed and spp), it does not favour one sampling scheme
    of the insertion over another. The samples are drawn as two independent halves (seeds
    @p seed and @p seed + 1, ⌈spp/2⌉ each) whose layers are averaged; @p half_difference
    (optional, CV_32FC3, 8-bit display units) receives half the difference of the two halves'
    composites, whose mean square estimates the mean square of @p truth's own render noise.
    @p truth is 8-bit BGR (sRGB-encoded, rounded).

    @p roi (optional, clipped to the frame) limits the render to a rectangle, e.g. the bounding
    box of regionPath(i) with a margin of a few pixels (the render's camera is the frame's,
    its principal point moved): outside it @p truth is @p input and @p half_difference 0.
    High sample counts stay affordable that way, as the object changes a small part of the
    frame. */
    void renderDifferentialTruth(int i, InputArray input, int spp, int seed, Mat& truth,
                                 Mat* half_difference = nullptr, Rect roi = Rect()) const;

    /** @brief Renders every frame into inputVideoPath(), truthVideoPath() and the region
    masks (skipped when @p force is false and both videos already hold Params::frames frames of
    Params::size, with their masks).
    @return render seconds per frame (0 when skipped). */
    double writeVideos(bool force = false) const;

private:
    struct Impl;
    std::shared_ptr<Impl> impl_;
};

//! @}

}  // namespace vbme
}  // namespace cv

#endif
