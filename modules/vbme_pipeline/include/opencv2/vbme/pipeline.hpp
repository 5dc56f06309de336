// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_PIPELINE_HPP
#define OPENCV_VBME_PIPELINE_HPP

/**
@defgroup vbme_pipeline End-to-end pipelines
The two jobs of vbme as C++ calls: material editing of a filmed object (runMaterialEdit) and
insertion of synthetic objects into hand-held footage of a room (runInsertion; its stages
prepareInsertion and renderInsertionFrame). The `vbme
material-edit` and `vbme insert` commands are thin wrappers around them.
*/

#include "opencv2/vbme/calib.hpp"
#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/inpaint.hpp"
#include "opencv2/vbme/render.hpp"
#include "opencv2/vbme/track.hpp"
#include "opencv2/vbme/pipeline/insertion.hpp"
#include "opencv2/vbme/pipeline/material_edit.hpp"
#include "opencv2/vbme/pipeline/report.hpp"

#endif
