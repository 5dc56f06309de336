// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// MaterialEditor: the stages of this folder joined per frame. push() tracks the object and
// queues the frame for removal; pop() takes the next filled frame and runs shape refinement,
// environment, lighting, rendering and compositing on it.
#include <memory>

#include <opencv2/imgproc.hpp>

#include "stages.hpp"

namespace cv {
namespace vbme {

MaterialEditor::~MaterialEditor() = default;

namespace material_edit {

namespace {

enum Stage {
    TRACKING,
    SHAPE,
    INPAINTING,
    ENVIRONMENT,
    LIGHTING,
    SHADOW,
    RENDERING,
    COMPOSITING,
    NSTAGES
};
const char* const kStageNames[NSTAGES] = {"tracking", "shape",  "inpainting", "environment",
                                          "lighting", "shadow", "rendering",  "compositing"};

Mat checkedFirstMask(InputArray _mask) {
    const Mat m = _mask.getMat();
    if (m.empty() || m.type() != CV_8UC1)
        CV_Error(Error::StsBadArg,
                 "MaterialEditor: the first mask must be a non-empty CV_8UC1 "
                 "image (non-zero = object)");
    Mat mask;
    compare(m, 0, mask, CMP_GT);
    const int n = countNonZero(mask);
    if (n == 0) CV_Error(Error::StsBadArg, "MaterialEditor: the first mask is empty (no object)");
    if (n == (int)m.total())
        CV_Error(Error::StsBadArg, "MaterialEditor: the first mask marks every pixel");
    return mask;
}

const MaterialEditParams& checked(const MaterialEditParams& p) {
    p.check();
    return p;
}

class Editor final : public MaterialEditor {
public:
    Editor(const MaterialEditParams& p, InputArray first_mask, const Ptr<EnvironmentMap>& env)
        : p_(checked(p)), env_(env), fill_(p_) {
        const Mat mask = checkedFirstMask(first_mask);
        size_ = mask.size();
        focal_ = p_.focal > 0 ? p_.focal : Camera::focalFromFov(size_.width, 60.0);
        track_.reset(new ObjectTrack(mask, p_.max_lost));
        report_.pipeline = "material-edit";
        for (int s = 0; s < NSTAGES; s++)
            report_.seconds.emplace_back(kStageNames[s], 0.0);
    }

    void push(InputArray _frame) override {
        if (finished_) CV_Error(Error::StsError, "MaterialEditor: push() after finish()");
        const Mat frame = _frame.getMat();
        if (frame.type() != CV_8UC3 || frame.size() != size_)
            CV_Error(Error::StsBadArg,
                     format("MaterialEditor: frame %d is not an 8-bit BGR image of the first "
                            "mask's size %dx%d",
                            pushed_, size_.width, size_.height));
        FrameItem it;
        it.index = pushed_;
        {
            ScopedTimer t(sec(TRACKING));
            const Disk d = track_->update(frame, pushed_, it.lost);
            it.center = d.center;
            it.radius = d.radius;
        }
        if (it.lost) report_.frames_lost++;
        {
            ScopedTimer t(sec(SHAPE));
            // A lost frame keeps its pixels: the tracker does not know where the object is (it
            // may be hidden), so neither removing nor drawing a disk would be right.
            if (it.lost)
                it.hole = Mat::zeros(size_, CV_8UC1);
            else
                objectHole(size_, it.center, it.radius, p_.hole_margin, it.hole);
            it.frame = frame;
        }
        {
            ScopedTimer t(sec(INPAINTING));
            fill_.push(std::move(it));
        }
        ++pushed_;
        report_.frames_total = pushed_;
    }

    void finish() override {
        if (finished_) return;
        finished_ = true;
        ScopedTimer t(sec(INPAINTING));
        fill_.finish();
    }

    bool pop(OutputArray edited, OutputArray background, OutputArray hole,
             OutputArray environment) override {
        FrameItem it;
        Mat filled, shadow_mask;
        const bool recast = p_.shadows == SHADOWS_REMOVE;
        {
            ScopedTimer t(sec(INPAINTING));
            if (!fill_.pop(it, filled, recast ? &shadow_mask : nullptr)) return false;
        }
        Point2f c = it.center;
        float r = it.radius;
        if (it.lost) {
            // The input frame passes through unedited (nothing was removed from it).
            FrameResult res;
            res.index = it.index;
            res.lost = true;
            res.disk = Vec3f(c.x, c.y, r);
            results_.push_back(res);
            edited.assign(it.frame);
            if (background.needed()) background.assign(filled);
            if (hole.needed()) hole.assign(it.hole);
            if (environment.needed()) environment.release();
            finishFrame();
            return true;
        }
        {
            ScopedTimer t(sec(ENVIRONMENT));
            linearize(filled, bg_lin_, p_.response);
        }
        const Rect big = Rect(Point(cvFloor(c.x - r - 6), cvFloor(c.y - r - 6)),
                              Point(cvCeil(c.x + r + 7), cvCeil(c.y + r + 7))) &
                         Rect(Point(0, 0), size_);
        {
            ScopedTimer t(sec(LIGHTING));
            linearize(it.frame(big), big_lin_, p_.response);
        }
        if (p_.refine_disk) {
            ScopedTimer t(sec(SHAPE));
            const Point2f tl((float)big.x, (float)big.y);
            const Disk d = refineDisk(big_lin_, bg_lin_(big), Disk(c - tl, r));
            c = d.center + tl;
            r = d.radius;
        }
        const Rect box = renderBox(size_, c, r);
        {
            ScopedTimer t(sec(SHAPE));
            sphereNormalsInBox(box, c, r, normals_, fit_mask_);
        }
        Mat eq;
        EnvironmentMap frame_env(Vec3f(0, 0, 0));
        if (!env_) {
            ScopedTimer t(sec(ENVIRONMENT));
            eq = environmentFromFrame(bg_lin_, p_.env_size);
            frame_env = EnvironmentMap(eq);
        }
        const EnvironmentMap& env = env_ ? *env_ : frame_env;
        LightingFit fit;
        {
            ScopedTimer t(sec(LIGHTING));
            fit = fitObjectLighting(big_lin_(box - big.tl()), normals_, fit_mask_, p_);
        }
        FrameResult res;
        res.index = it.index;
        res.lost = it.lost;
        res.disk = Vec3f(c.x, c.y, r);
        res.to_light = Vec3d(fit.to_light[0], fit.to_light[1], fit.to_light[2]);
        res.fit_rms = fit.rms;
        res.albedo = Vec3d(fit.albedo[0], fit.albedo[1], fit.albedo[2]);
        // With shadows "remove" the original shadow is gone from the fill: the new object
        // casts one fitting its material, measured from the original (shadow.cpp).
        CastShadow cs;
        Mat shadowed = filled;
        if (recast) {
            ScopedTimer t(sec(SHADOW));
            const ConsensusInpainter::Params cp;
            if (measureCastShadow(it.frame, p_.response, bg_lin_, shadow_mask, it.hole, c, r,
                                  cp.shadow_smooth, cs)) {
                res.shadow_offset = Vec2f(cs.offset.x, cs.offset.y);
                Mat atten;
                if (shadowKindOf(p_.material) == SHADOW_GLASS)
                    glassShadow(cs, c, p_.material, atten);
                else
                    atten = cs.atten;
                castShadow(cs, atten, bg_lin_);
                Mat enc;
                encode(bg_lin_(cs.roi), enc, p_.response, CV_8U);
                shadowed = filled.clone();
                enc.copyTo(shadowed(cs.roi), cs.region);
            }
        }
        results_.push_back(res);
        {
            ScopedTimer t(sec(RENDERING));
            renderObject(p_, bg_lin_, c, r, focal_, fit, env, rendered_);
        }
        Mat out8;
        {
            ScopedTimer t(sec(COMPOSITING));
            compositeObject(shadowed, rendered_, box, p_.response, out8);
        }
        edited.assign(out8);
        if (background.needed()) background.assign(filled);
        if (hole.needed()) hole.assign(it.hole);
        if (environment.needed()) {
            if (eq.empty())
                environment.release();
            else
                environment.assign(eq);
        }
        finishFrame();
        return true;
    }

    const std::vector<FrameResult>& results() const override { return results_; }
    const PipelineReport& report() const override { return report_; }

private:
    double& sec(Stage s) { return report_.seconds[s].second; }

    void finishFrame() {
        report_.frames_processed++;
        report_.total_seconds = 0;  // the editor's own time: the sum of its stages
        for (const auto& st : report_.seconds)
            report_.total_seconds += st.second;
        report_.setFigure("pixels_temporal", fill_.temporal);
        report_.setFigure("pixels_exemplar", fill_.exemplar);
    }

    MaterialEditParams p_;
    Ptr<EnvironmentMap> env_;
    RemovalFill fill_;
    std::unique_ptr<ObjectTrack> track_;
    Size size_;
    double focal_ = 0;
    int pushed_ = 0;
    bool finished_ = false;
    std::vector<FrameResult> results_;
    PipelineReport report_;
    Mat bg_lin_, big_lin_, rendered_, normals_, fit_mask_;
};

}  // namespace

}  // namespace material_edit

Ptr<MaterialEditor> MaterialEditor::create(const MaterialEditParams& params, InputArray first_mask,
                                           const Ptr<EnvironmentMap>& environment) {
    return makePtr<material_edit::Editor>(params, first_mask, environment);
}

}  // namespace vbme
}  // namespace cv
