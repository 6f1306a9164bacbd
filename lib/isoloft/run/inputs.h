// @file run/inputs.h
// @brief A run's input dispatch: PNG slices, a polyline file, a label volume
// or an RT Structure Set (format from the name and first bytes) read into
// slice stacks ("jobs"), the input options checked against the format.
// Option names in errors follow core/option_names.h (flags or keywords).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "isoloft/core/params.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/volume.h"
#include "isoloft/io/volume_slices.h"

namespace isoloft {

enum class InputFormat { Images, Polylines, Volume, RtStruct, Arrays };

/// Names as in the report's "input.format".
inline constexpr std::array<EnumName<InputFormat>, 5> kInputFormatNames{{{InputFormat::Images, "png"},
                                                                         {InputFormat::Polylines, "polylines"},
                                                                         {InputFormat::Volume, "volume"},
                                                                         {InputFormat::RtStruct, "rtstruct"},
                                                                         {InputFormat::Arrays, "arrays"}}};
constexpr std::span<const EnumName<InputFormat>> enum_names(InputFormat) { return kInputFormatNames; }

/// One reconstruct() call.
struct Job {
  SliceStack stack;
  std::string name;          ///< "" (one object), or the ROI name (RT Structure Set)
  std::optional<Rgb> color;  ///< the ROI's display colour, if any
  const RtRoi* roi = nullptr;  ///< RT Structure Sets: the ROI (in Inputs::rtstruct)
};

/// What to read and the input options given (std::nullopt / "" = not given).
struct InputRequest {
  std::vector<std::string> paths;
  std::string kind;                  ///< contours, masks or labels
  std::optional<double> z_spacing;
  std::optional<std::vector<double>> slice_z;
  std::optional<double> pixel_size;
  std::string axis;                  ///< volumes: i, j or k
  std::vector<std::string> rois;     ///< RT Structure Sets
  std::optional<double> voxel_size;  ///< RT Structure Sets, mm
  std::string space;                 ///< lps or ras
  double max_memory = 0;             ///< bytes (--max-memory), 0 = no limit: checked before decoding
};

struct Inputs {
  InputFormat format = InputFormat::Images;
  std::vector<std::string> files;  ///< the paths read (report "input.files")
  std::vector<Job> jobs;
  std::vector<std::string> warnings;
  bool ras = false;                ///< outputs in RAS instead of LPS (inputs with a patient frame)
  /// Volume input: the volume and how it was sliced (for a label map and the report).
  std::unique_ptr<Volume> volume;
  std::unique_ptr<VolumeStack> slicing;
  /// RT Structure Set input: the set as read (ROI numbers, names, colours).
  std::unique_ptr<RtStructureSet> rtstruct;

  [[nodiscard]] const SliceStack& first() const { return jobs.front().stack; }
  /// One object per label value (InputKind::Labels).
  [[nodiscard]] bool labels() const { return first().kind == InputKind::Labels; }
};

/// Why an option needs a volume input (an error's second half).
inline constexpr const char* kVolumeInputOnly = "only with a volume input (NIfTI, NRRD, MetaImage)";

/// The input's format, from its name and first bytes.
InputFormat detect_input(const std::vector<std::string>& paths);

/// Reads the input into jobs, applying and checking the input options: an
/// option the input cannot use is an error naming it.
/// \throw InputError / ParamError naming the file or the option.
Inputs read_inputs(const InputRequest& request);

/// \throw ParamError (naming `option`) if labels are selected but the input is not a label input.
void check_labels(const Inputs& in, const std::vector<std::uint32_t>& labels, const std::string& option);

/// The report's "input": files, format, kind, slices, size, slice z, pixel size, space, axis, ROIs.
nlohmann::json input_report(const Inputs& in);

}  // namespace isoloft
