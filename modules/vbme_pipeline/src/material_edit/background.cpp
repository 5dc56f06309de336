// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
// Material edit, background stage: the object removed by vbme_inpaint's ConsensusInpainter,
// with each frame's tracking results kept alongside until its fill comes out.
#include "stages.hpp"

namespace cv {
namespace vbme {
namespace material_edit {

namespace {

ConsensusInpainter::Params removalParams(const MaterialEditParams& p) {
    ExemplarInpainter::Params ep;
    ep.method = PATCH_SEARCH_PATCHMATCH;
    ConsensusInpainter::Params cp;
    cp.exemplar = ep;
    cp.temporal_radius = std::max(1, p.lookahead);
    cp.alignment =
        p.inpaint == MATERIAL_EDIT_INPAINT_VIDEO ? CONSENSUS_ALIGN_FLOW : CONSENSUS_ALIGN_NONE;
    cp.shadows = p.shadows;
    return cp;
}

}  // namespace

RemovalFill::RemovalFill(const MaterialEditParams& p)
    : ci_(ConsensusInpainter::create(removalParams(p))) {}

void RemovalFill::push(FrameItem&& it) {
    ci_->push(it.frame, it.hole);
    q_.push_back(std::move(it));
}

void RemovalFill::finish() {
    ci_->finish();
}

bool RemovalFill::pop(FrameItem& it, Mat& filled, Mat* shadow) {
    ConsensusInpainter::FrameStats st;
    Mat sh;
    if (!(shadow ? ci_->pop(filled, &st, sh) : ci_->pop(filled, &st))) return false;
    if (shadow) *shadow = sh;
    it = std::move(q_.front());
    q_.pop_front();
    temporal += st.temporal + st.previous;
    exemplar += st.exemplar;
    return true;
}

}  // namespace material_edit
}  // namespace vbme
}  // namespace cv
