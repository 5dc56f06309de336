// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// The stages of the material edit (thesis chapter 4), one file each in this folder:
//   tracking.cpp     the object's disk per frame (ObjectTracker, lost-frame policy)
//   shape.cpp        the hole to remove and the sphere normals over the disk
//   background.cpp   the object's removal (ConsensusInpainter with the frames' bookkeeping)
//   environment.cpp  the environment map built from the filled frame
//   lighting.cpp     the key light and ambient fitted to the original object's shading
//   rendering.cpp    the object re-rendered in the new material
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
    bool pop(FrameItem& it, Mat& filled);
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

// ---- compositing.cpp

/** The filled 8-bit frame with the rendered box encoded into it. */
void compositeObject(const Mat& filled, const Mat& rendered, Rect box, Response response,
                     Mat& out8);

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv

#endif
