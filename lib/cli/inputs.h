// What `isoloft reconstruct` reads: PNG slices, a polyline file, a label
// volume (NIfTI, NRRD, MetaImage) or a DICOM RT Structure Set, as one or more
// slice stacks to reconstruct ("jobs"), with the flags that only some inputs
// take checked against the input.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/volume.h"
#include "isoloft/io/volume_slices.h"

namespace isoloft::cli {

enum class InputFormat { Images, Polylines, Volume, RtStruct };

/// One reconstruct() call.
struct Job {
  SliceStack stack;
  std::string name;          ///< "" (one object), or the ROI name (RT Structure Set)
  std::optional<Rgb> color;  ///< the ROI's display colour, if any
};

struct Inputs {
  InputFormat format = InputFormat::Images;
  std::vector<Job> jobs;
  std::vector<std::string> warnings;
  /// Volume input: the volume and how it was sliced (for --labelmap and the report).
  std::unique_ptr<Volume> volume;
  std::unique_ptr<VolumeStack> slicing;
};

/// The input's format, from its name and first bytes.
InputFormat detect_input(const std::vector<std::string>& inputs);

/// Reads the input into jobs, applying and checking the input flags
/// (--input, --z-spacing, --slice-z, --pixel-size, --axis, --roi,
/// --voxel-size): a flag the input cannot use is an error naming it.
/// \throw InputError / ParamError naming the file or the flag.
Inputs read_inputs(const ReconstructArgs& args);

/// Bytes a stack of `slices` width x height slices holds up to and through
/// the contour stage: decoded images (`images`: 4 bytes a pixel), every
/// slice's contour and inside masks, and the fill's temporaries of the slices
/// in flight (docs/decisions.md, work budget).
double stack_bytes(double slices, double width, double height, bool images);

/// Prints the ROIs of an RT Structure Set: name, number, contours, z range.
void list_rois(const std::string& path, std::ostream& out);

/// `name` made safe as a file name part (letters, digits, '-', '_'; others '_').
std::string file_safe(const std::string& name);

}  // namespace isoloft::cli
