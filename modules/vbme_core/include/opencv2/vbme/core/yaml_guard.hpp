// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_YAML_GUARD_HPP
#define OPENCV_VBME_CORE_YAML_GUARD_HPP

#include <string>

#include <opencv2/core.hpp>

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief Checks, before OpenCV's YAML parser sees it, that @p text (the contents of the YAML
file @p path) is a map at its top level: its first line that is not blank, a comment, a
directive (`%YAML…`) or a document start (`---` alone on its line) must begin at column 0 with
neither `-` nor `[`. Every vbme YAML file is such a map, and OpenCV 4.6's YAML parser never
returns on some documents whose top level is an indented sequence or a line such as `---L:0`
(found by fuzzing the annotation reader; doc/reliability.md). Text whose first non-blank character
is `{` (JSON, a flow map) passes.

Throws cv::Exception (StsParseError) "<path>: line N: …" otherwise. Used by openForReading()
and the annotation reader. */
CV_EXPORTS void checkYamlTopLevel(const std::string& text, const std::string& path);

//! @}

}  // namespace vbme
}  // namespace cv

#endif
