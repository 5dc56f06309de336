// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion stage 6: one frame. A differential render of the prepared scene from the frame's
// camera (shared samples, fixed seed), composited onto the input frame.
#include "insertion/stages.hpp"
#include "opencv2/vbme/render/differential.hpp"

namespace cv {
namespace vbme {

void renderInsertionFrame(PreparedInsertion& prepared, int i, InputArray frame,
                          OutputArray composite, DifferentialImages* layers,
                          Mat* composite_linear) {
    CV_Assert(i >= 0 && i < (int)prepared.path.frames.size());
    CV_Assert(frame.size() == prepared.scene.image_size);
    if (!prepared.render_scene) prepared.render_scene = RenderScene::create(prepared.scene);
    if (!prepared.renderer) {
        DifferentialRenderer::Params dp;
        dp.render = prepared.render;
        prepared.renderer = DifferentialRenderer::create(dp);
    }
    const CompositeParams& cp = prepared.composite;
    DifferentialImages local;
    DifferentialImages& im = layers ? *layers : local;
    insertion::renderFrameLayers(prepared, i, im);  // render, motion blur over the shutter
    // ---- exposure and white balance (issue 21): the layers at the frame's exposure ----
    if (i < (int)prepared.gains.size()) insertion::applyFrameGain(im, prepared.gains[i]);
    // ---- end of exposure ----
    // The layers were rendered in the pinhole camera (enlarged to everything a barrel lens shows,
    // lensCoverCamera) and are warped to the lens. The difference layer is denoised where it was
    // rendered, guided by the frame in the same (undistorted) geometry, and only then warped:
    // denoising after the warp spread differences into the border a barrel lens left unrendered
    // (no I_noObj there), which ratio shadows turn black (PipelineInsertDistortion.
    // K1InSceneBeatsIgnoringIt: centroid 2.55 px off instead of 0.41, before the enlargement).
    const Camera cam = prepared.camera(i), cover = lensCoverCamera(cam);
    if (prepared.denoise > 0) {
        if (cam.k1 == 0) {
            denoiseDifference(im, frame, prepared.denoise);
        } else {
            Mat guide;
            undistortImageK1(frame, guide, cam, cover);
            denoiseDifference(im, guide, prepared.denoise);
        }
    }
    distortLayersK1(im, cam, cover);
    Mat linear;
    compositeDifferential(frame, im, linear, cp);
    insertion::addFrameGrain(prepared, i, im, linear);  // the footage's noise on the objects
    encodeComposite(linear, composite, cp.response, frame.depth());
    if (composite_linear) *composite_linear = linear;
}

}  // namespace vbme
}  // namespace cv
