// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Insertion stage 6: one frame. A differential render of the prepared scene from the frame's
// camera (shared samples, fixed seed), composited onto the input frame.
#include "insertion/stages.hpp"
#include "opencv2/vbme/render/differential.hpp"

namespace cv {
namespace vbme {

namespace {
// The footage's lens (Camera::k1): the layers, rendered in the undistorted pinhole camera, are
// warped to where that lens shows them, so they line up with the (distorted) input frame.
void distortLayers(DifferentialImages& im, const Camera& cam) {
    if (cam.k1 == 0) return;
    for (Mat* m : {&im.obj, &im.noobj, &im.diff, &im.mask, &im.object})
        if (!m->empty()) distortImageK1(*m, *m, cam);
    if (!im.samples.empty()) distortImageK1(im.samples, im.samples, cam, INTER_NEAREST);
}
}  // namespace

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
    // The difference layer is denoised where it was rendered, guided by the frame in the same
    // (undistorted) geometry, and only then warped to the lens: denoising after the warp
    // spread differences into the border a barrel lens leaves unrendered (no I_noObj there),
    // which ratio shadows turn black (PipelineInsertDistortion.K1InSceneBeatsIgnoringIt:
    // centroid 2.55 px off instead of 0.41).
    if (prepared.denoise > 0) {
        const Camera& cam = prepared.scene.camera;
        if (cam.k1 == 0) {
            denoiseDifference(im, frame, prepared.denoise);
        } else {
            Mat guide;
            undistortImageK1(frame, guide, cam);
            denoiseDifference(im, guide, prepared.denoise);
        }
    }
    distortLayers(im, prepared.scene.camera);
    Mat linear;
    compositeDifferential(frame, im, linear, cp);
    insertion::addFrameGrain(prepared, i, im, linear);  // the footage's noise on the objects
    encodeComposite(linear, composite, cp.response, frame.depth());
    if (composite_linear) *composite_linear = linear;
}

}  // namespace vbme
}  // namespace cv
