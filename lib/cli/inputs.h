// What `isoloft reconstruct` reads: the input flags as an InputRequest for
// read_inputs() (isoloft/run.h), and the ROI listing of an RT Structure Set.
#pragma once

#include <ostream>
#include <string>

#include "cli/commands.h"
#include "isoloft/run.h"

namespace isoloft::cli {

/// The input flags given (CLI11 counts) as a request.
/// \throw ParamError naming --slice-z if a value is not a number.
InputRequest input_request(const ReconstructArgs& args);

/// Prints the ROIs of an RT Structure Set: name, number, contours, z range.
void list_rois(const std::string& path, std::ostream& out);

}  // namespace isoloft::cli
