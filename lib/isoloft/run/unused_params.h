// @file run/unused_params.h
// @brief The parameters given that the run would never read: one check for
// the CLI's flags and Python's keywords, from the parameter rows.
//
// A row is unread when the chosen method or z scheme does not read it
// (unused_param(), from the registrations), or when the input cannot use it
// (polyline raster width without polylines, the fill options without
// contour images, binarize with labels, the label partition without labels).
#pragma once

#include <functional>
#include <string>

#include "isoloft/objects/params.h"
#include "isoloft/run/inputs.h"

namespace isoloft {

/// The name the user gave a parameter row under (a CLI flag, a Python
/// keyword), or "" if it was not given.
using GivenParam = std::function<std::string(const std::string& key)>;

/// \throw ParamError "<name>: has no effect here, <where it applies>" for the
///        first row given that this run never reads.
void refuse_unused_params(const GivenParam& given, const ReconstructParams& params, const Inputs& in);

}  // namespace isoloft
