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
#include "isoloft/core/section.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/field3d/partition3d.h"
#include "isoloft/io/label_names.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/volume.h"
#include "isoloft/io/volume_slices.h"

namespace isoloft {

enum class InputFormat { Images, Polylines, Volume, RtStruct, Arrays, Csl, Sections };

/// Names as in the report's "input.format".
inline constexpr std::array<EnumName<InputFormat>, 7> kInputFormatNames{{{InputFormat::Images, "png"},
                                                                         {InputFormat::Polylines, "polylines"},
                                                                         {InputFormat::Volume, "volume"},
                                                                         {InputFormat::RtStruct, "rtstruct"},
                                                                         {InputFormat::Arrays, "arrays"},
                                                                         {InputFormat::Csl, "csl"},
                                                                         {InputFormat::Sections, "sections"}}};
constexpr std::span<const EnumName<InputFormat>> enum_names(InputFormat) { return kInputFormatNames; }

/// One reconstruct() call.
/// RT Structure Sets: a ROI's working grid made finer than the triangle
/// budget's for its narrowest drawn contour (run/inputs.cpp, read_rtstruct_input).
struct GridRefinement {
  double from_mm = 0, to_mm = 0;  ///< the budget's grid, the grid used
  std::string why;                ///< the contour that asked for it (plane, area, thickness)
  bool limited = false;           ///< the refinement stopped at its limit, short of what the contour asks
};

struct Job {
  SliceStack stack;
  std::string name;          ///< "" (one object), or the ROI name (RT Structure Set)
  std::optional<Rgb> color;  ///< the ROI's display colour, if any
  const RtRoi* roi = nullptr;  ///< RT Structure Sets: the ROI (in Inputs::rtstruct)
  /// CSL input: every section in world space (any orientation), read by the
  /// methods that read sections (MethodSpec::reads_sections) instead of `stack` (which stays empty).
  std::vector<Section> sections{};
  std::uint32_t section_label = 0;  ///< the label of `sections` this job reconstructs
  /// CSL input: every label of `sections` as one partition, shared by the jobs (field3d/partition3d.h).
  std::shared_ptr<SharedPartition> partition{};
  std::optional<GridRefinement> refined{};  ///< RT ROIs: set when the grid was refined
};

/// A CSL file (planes at any angle, io/csl.h): one job per label that has a contour.
inline constexpr const char* kCslInputOnly = "not with a CSL input (its planes carry their own poses, in its own units)";

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
  /// Volumes: data files named by a header may lie outside its folder (--allow-external-data).
  bool allow_external_data = false;
  /// Label volumes: the table naming the labels (--label-names); "" = the
  /// table beside the volume if there is one (label_names_beside()).
  std::string label_names;
  /// RT Structure Sets: the method reads sections at any angle
  /// (MethodSpec::reads_sections), so a ROI with contours on oblique planes
  /// is read as sections (io/rtstruct_sections.h) instead of refused.
  bool any_plane = false;
  /// Label volumes annotated along several axes (io/volume_sections.h): the
  /// annotated slices ("k:10,20;i:50", --annotated) or a mask volume on the
  /// same grid marking them (--annotated-mask); each job is then one label's
  /// sections in patient mm (LPS), read by the methods that read sections.
  std::string annotated, annotated_mask;
};

struct Inputs {
  InputFormat format = InputFormat::Images;
  std::vector<std::string> files;  ///< the paths read (report "input.files")
  /// Files a volume header names for its samples (VolumeHeader::data_files):
  /// read with the input, so protected like it from the outputs.
  std::vector<std::string> data_files;
  std::vector<Job> jobs;
  std::vector<std::string> warnings;
  bool ras = false;                ///< outputs in RAS instead of LPS (inputs with a patient frame)
  /// Volume input: the volume and how it was sliced (for a label map and the report).
  std::unique_ptr<Volume> volume;
  std::unique_ptr<VolumeStack> slicing;
  /// RT Structure Set input: the set as read (ROI numbers, names, colours).
  std::unique_ptr<RtStructureSet> rtstruct;
  /// Label volumes: the labels' names (io/label_names.h; empty if no table).
  LabelNames label_names;

  /// Label `label`'s name from the table, or "".
  [[nodiscard]] std::string label_name(std::uint32_t label) const { return label_names.name(label); }

  [[nodiscard]] const SliceStack& first() const { return jobs.front().stack; }
  /// One object per label value (InputKind::Labels).
  [[nodiscard]] bool labels() const { return first().kind == InputKind::Labels; }
};

/// Why --annotated / --annotated-mask cannot be used (an error's second half).
inline constexpr const char* kAnnotatedVolumeOnly = "only with a label volume input (NIfTI, NRRD, MetaImage)";

/// Why an option needs a volume input (an error's second half).
inline constexpr const char* kVolumeInputOnly = "only with a volume input (NIfTI, NRRD, MetaImage)";

/// The input's format, from its name and first bytes.
InputFormat detect_input(const std::vector<std::string>& paths);

/// Reads the input into jobs, applying and checking the input options: an
/// option the input cannot use is an error naming it. A path that is neither
/// a folder nor a regular file (a FIFO, a device) is refused before it is
/// opened; a volume's size is checked against max_memory from its header,
/// before its voxels are read.
/// Sections in world space (a CSL file's, or Python's list of plane poses
/// with polylines or label images) as an input: one job per label drawn on
/// some section (a contour's, or a pixel's other than 0), the labels one
/// partition (Job::partition); format Sections, `name` standing for the file.
/// \throw InputError naming `name` when no section has a contour or a labelled pixel.
Inputs sections_input(std::vector<Section> sections, const std::string& name);

/// \throw InputError / ParamError naming the file or the option; InputError
///        for patient coordinates so far from the origin that the meshes'
///        32-bit floats cannot keep their shape (see kFloatPrecisionFraction).
Inputs read_inputs(const InputRequest& request);

/// A volume already in memory (an image object in Python) read as
/// read_inputs() reads a volume file; `name` stands for its path in messages
/// and the report. \throw as read_inputs().
Inputs volume_input(Volume volume, const std::string& name, const InputRequest& request);

/// Patient coordinates are refused where a 32-bit float (the mesh files'
/// type) steps by more than this share of the pixel: at 1e9 mm it steps by
/// 64 mm. With 0.5 mm pixels the limit is about 65 m from the origin.
inline constexpr double kFloatPrecisionFraction = 0.01;

/// \throw ParamError (naming `option`) if labels are selected but the input is not a label input.
void check_labels(const Inputs& in, const std::vector<std::uint32_t>& labels, const std::string& option);

/// The report's "input": files, format, kind, slices, size, slice z, pixel size, space, axis, ROIs.
nlohmann::json input_report(const Inputs& in);

}  // namespace isoloft
