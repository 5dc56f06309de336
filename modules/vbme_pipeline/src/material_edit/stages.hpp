// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The stages of the material edit (thesis chapter 4), one file each in this folder:
//   tracking.cpp     the object's disk per frame (ObjectTracker, lost-frame policy)
//   shape.cpp        the hole to remove and the sphere normals over the disk
//   background.cpp   the object's removal (ConsensusInpainter with the frames' bookkeeping)
//   environment.cpp  the environment map built from the filled frame
//   lighting.cpp     the key light and ambient fitted to the original object's shading
//   rendering.cpp    the object re-rendered in the new material
//   shadow.cpp       the original object's cast shadow measured, and re-cast for the new material
//   compositing.cpp  the rendered object put into the filled frame
//   editor.cpp       MaterialEditor: the stages joined per frame
//   params.cpp       MaterialEditParams: check, read, write
//   driver.cpp       runMaterialEdit: file to file (decode, MaterialEditor, encode)
#ifndef VBME_PIPELINE_MATERIAL_EDIT_STAGES_HPP
#define VBME_PIPELINE_MATERIAL_EDIT_STAGES_HPP

#include <deque>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/utility.hpp"
#include "opencv2/vbme/inpaint.hpp"
#include "opencv2/vbme/pipeline/material_edit.hpp"
#include "opencv2/vbme/render/environment.hpp"
#include "opencv2/vbme/render/relighting.hpp"
#include "opencv2/vbme/track.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

// ---- tracking.cpp

/** The object's disk in each frame: ObjectTracker from the frame-0 mask; a lost frame returns
the last disk (frame 0: the disk fitted to the mask) with lost set (the editor passes that
frame through unedited), more than max_lost in a row throw. */
class ObjectTrack {
public:
    ObjectTrack(const Mat& first_mask, int max_lost);
    /** Disk of frame @p index (pushed in order); @p lost tells whether the tracker lost it. */
    Disk update(const Mat& frame, int index, bool& lost);

private:
    Ptr<ObjectTracker> tracker_;
    Mat first_mask_;
    int max_lost_;
    bool started_ = false;
    Disk last_good_;
    int consecutive_lost_ = 0;
};

// ---- shape.cpp

/** The region removed around the disk (radius + margin, anti-aliasing-free 1/16-px circle). */
void objectHole(Size size, Point2f center, float radius, double margin, Mat& hole);
/** The box around the disk that the edit re-renders. */
Rect renderBox(Size size, Point2f center, float radius);
/** Orthographic sphere normals over @p box (thesis §4.2; zero outside) and the lighting fit's
mask (the disk shrunk by 1.5 px, away from the anti-aliased rim). */
void sphereNormalsInBox(Rect box, Point2f center, float radius, Mat& normals, Mat& fit_mask);

// ---- background.cpp

/** Per-frame state travelling through the background fill. */
struct FrameItem {
    int index = 0;
    bool lost = false;
    Mat frame;  // original 8-bit BGR
    Mat hole;   // CV_8U full frame, 255 = hole
    Point2f center;
    float radius = 0;
};

/** The object's removal: vbme_inpaint's ConsensusInpainter (a robust vote of the frames within
±radius that see each hole pixel, without alignment for a static camera or aligned by
homography and dense flow), with the frames' bookkeeping alongside. */
class RemovalFill {
public:
    explicit RemovalFill(const MaterialEditParams& p);
    void push(FrameItem&& it);
    void finish();
    /** The next frame's item and fill; @p shadow (if not null) receives the CV_8U map of
    the frame's own shadow pixels the fill removed (empty with shadows "keep"). */
    bool pop(FrameItem& it, Mat& filled, Mat* shadow = nullptr);
    int temporal = 0, exemplar = 0;

private:
    Ptr<ConsensusInpainter> ci_;
    std::deque<FrameItem> q_;
};

// ---- environment.cpp

/** A level camera looking along world +y (z up): X_cam = R·X_world. */
Matx33f cameraFromWorld();
/** The equirectangular environment (@p size) seen in the filled linear frame, taken as a
mirror-ball-like disk inscribed in the frame (imageDiskToEnvironment()). */
Mat environmentFromFrame(const Mat& background_linear, Size size);

// ---- lighting.cpp

/** Key light and ambient fitted to the object's linear pixels over the fit mask. */
LightingFit fitObjectLighting(const Mat& object_linear, const Mat& normals, const Mat& fit_mask,
                              const MaterialEditParams& p);

// ---- rendering.cpp

/** The object re-rendered over the whole linear background (only the disk changes). */
void renderObject(const MaterialEditParams& p, const Mat& background_linear, Point2f center,
                  float radius, double focal, const LightingFit& fit, const EnvironmentMap& env,
                  Mat& rendered);

// ---- shadow.cpp

/** How the new object's shadow is made from the original one. */
enum ShadowKind {
    SHADOW_OPAQUE = 0,  //!< the original attenuation (opaque materials, chrome)
    SHADOW_GLASS = 1    //!< lighter, with a caustic core (dielectrics)
};
/** The kind of shadow @p m casts. */
ShadowKind shadowKindOf(const Material& m);

/** The original object's cast shadow, measured against the filled background. */
struct CastShadow {
    bool found = false;
    Rect roi;                 //!< where atten and region lie (frame pixels)
    Mat atten;                //!< CV_32FC3 linear attenuation (1 = unshadowed) over roi
    Mat region;               //!< CV_8U over roi: the pixels the shadow may change
    Mat hole;                 //!< CV_8U over roi: the object's hole
    Point2f offset;           //!< deficit-weighted centroid of the shadow outside the disk − the
                              //!< disk's centre (pixels): points away from the key light
    double deficit_area = 0;  //!< Σ (1 − mean attenuation) outside the disk (pixels)
};

/** Measures the attenuation frame (8-bit, linearised by @p response) / fill (linear) over the
detected shadow @p shadow_mask (ConsensusInpainter's) grown by 2⌈@p smooth⌉ + 1 px for the
penumbra (@p smooth: ConsensusInpainter::Params::shadow_smooth), denoised (3×3 median, Gaussian
σ = 0.5 px) and completed into the @p hole from around it by push-pull. False when
there is no shadow. */
bool measureCastShadow(const Mat& frame8, Response response, const Mat& filled_lin,
                       const Mat& shadow_mask, const Mat& hole, Point2f center, float radius,
                       double smooth, CastShadow& out);
/** A glass ball's attenuation from the opaque one: the light of the shadow's deficit that the
sphere transmits ((1 − F̄)², F̄ the mean Fresnel reflectance of @p m's index) goes 70 % into a
Gaussian caustic core (σ = half the shadow's equivalent radius) at the shadow's centroid (away
from the key light) and 30 % back over the shadow; tinted by the material's absorption over
0.1 m. */
void glassShadow(const CastShadow& s, Point2f center, const Material& m, Mat& atten);
/** Multiplies @p background_lin by @p atten (over s.roi) on s.region. */
void castShadow(const CastShadow& s, const Mat& atten, Mat& background_lin);

// ---- compositing.cpp

/** The filled 8-bit frame with the rendered box encoded into it. */
void compositeObject(const Mat& filled, const Mat& rendered, Rect box, Response response,
                     Mat& out8);

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv

#endif
