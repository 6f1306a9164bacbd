// @file run.h
// @brief One reconstruction run, as `isoloft reconstruct` and the Python
// module both do it: an input (PNG slices, a polyline file, a label volume or
// an RT Structure Set) read as slice stacks ("jobs"), the pipeline on each,
// every object's mesh in output units, the meshes written by name, and the
// run report's JSON.
//
// Output units: patient mm (LPS) for inputs with a patient frame (volumes,
// RT Structure Sets), else working pixels (the writers scale by pixel_size).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/core/slice_stack.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/volume.h"
#include "isoloft/io/volume_slices.h"
#include "isoloft/pipeline.h"

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
  bool labelmap = false;             ///< a dense label map is wanted (volumes only)
  double max_memory = 0;             ///< bytes (--max-memory), 0 = no limit: checked before decoding
  /// Names the options in errors as Python keywords (z_spacing) instead of flags (--z-spacing).
  bool keyword_names = false;
  /// The option's name in errors: `flag` ("--z-spacing"), or its keyword form.
  [[nodiscard]] std::string name(const std::string& flag) const;
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
};

/// The input's format, from its name and first bytes.
InputFormat detect_input(const std::vector<std::string>& paths);

/// Reads the input into jobs, applying and checking the input options: an
/// option the input cannot use is an error naming it.
/// \throw InputError / ParamError naming the file or the option.
Inputs read_inputs(const InputRequest& request);

/// `name` made safe as a file name part (letters, digits, '-', '_'; others '_').
std::string file_safe(const std::string& name);

/// The file name part of job `job`'s ROI: file_safe(name), with "_<number>"
/// if another job's name gives the same (ROIs selected by number).
std::string roi_file_tag(const Inputs& in, std::size_t job);

/// Distinct colours per object: golden-ratio hue steps at full saturation.
Rgb label_colour(std::size_t i);

/// `path` with `suffix` before its extension ("a/b.ply", "_label2" -> "a/b_label2.ply").
std::string with_suffix(const std::string& path, const std::string& suffix);

/// One reconstructed object of a run.
struct RunObject {
  std::size_t job = 0;   ///< index into Inputs::jobs
  ObjectResult object;   ///< the pipeline's result (mesh in working pixels)
  TriMesh mesh;          ///< in output units: patient mm (LPS), or working pixels
  Rgb colour;            ///< the ROI's display colour, or label_colour(index)
  std::string file;      ///< where write_run_meshes() wrote it
};

struct RunResult {
  std::vector<RunObject> objects;
  StageTimes times;                   ///< summed over the jobs
  std::vector<std::string> warnings;  ///< the input's, then each job's (prefixed by its ROI)
  int threads = 0;                    ///< worker threads available during the run
};

/// \throw ParamError (naming `option`) if labels are selected but the input is not a label input.
void check_labels(const Inputs& in, const std::vector<std::uint32_t>& labels, const std::string& option);

/// reconstruct() on every job in turn; `configure` (optional) adds per-job
/// options (progress, volume planes, ...) before each. No object at all (no
/// contour anywhere) leaves `objects` empty: the caller's error to raise.
RunResult run_jobs(const Inputs& in, const ReconstructParams& params, const std::vector<std::uint32_t>& labels,
                   const std::function<void(const Job&, ReconstructOptions&)>& configure = {});

/// How the run's meshes are written: patient mm with the space named, or
/// pixels times the stack's pixel size.
MeshWriteOptions run_mesh_options(const Inputs& in, bool ascii = false);

/// Whether the run writes one file per object plus a combined one.
bool several_outputs(const Inputs& in, const RunResult& r);

/// Writes the meshes: one object -> `output`; several -> OUT_label<L>.ext
/// (labels) or OUT_<ROI>.ext each, and `output` with a colour per object.
/// Each file goes to stage(path) (identity if empty); sets RunObject::file.
void write_run_meshes(const std::string& output, const Inputs& in, RunResult& r, const MeshWriteOptions& options,
                      const std::function<std::string(const std::string&)>& stage = {});

/// The report's "objects": per object its label, file, ROI, counts, checks,
/// volume and area (output units) and MPU statistics (marker2006).
nlohmann::json objects_report(const Inputs& in, const RunResult& r, Method method);

/// One row of the volume table: an object's closed-surface volume beside
/// the slab volume (contour area x slice spacing, the planning systems' and
/// dicompyler's convention), in output units (patient mm for RT Structure
/// Sets and volumes).
struct VolumeRow {
  std::string name;       ///< ROI name, "label <L>", or "object"
  int number = 0;         ///< ROI number, or the label
  double volume = 0;      ///< of the closed surface, output units^3
  double area = 0;        ///< surface area, output units^2
  double slab = 0;        ///< sum over contour planes of the contour area (even-odd) x the ROI's typical plane step; 0 if the input has no polygons
  int planes = 0;         ///< slices with contours
  bool closed = false;    ///< closed oriented 2-manifold
};
std::vector<VolumeRow> volume_table(const Inputs& in, const RunResult& r);
/// The table as aligned text (cc and cm^2 for patient mm), CSV, or JSON (mm^3, mm^2).
std::string volume_table_text(const std::vector<VolumeRow>& rows, bool patient_mm);
std::string volume_table_csv(const std::vector<VolumeRow>& rows);
nlohmann::json volume_table_json(const std::vector<VolumeRow>& rows);

/// Writes the run's surfaces as an RT Structure Set (io/rtstruct.h,
/// write_rtstruct): each ROI's mesh cut at its input contour planes
/// (mesh/plane_cut.h), its number, name and colour and the input's header
/// kept. \throw ParamError unless the input is an RT Structure Set.
void write_run_rtstruct(const std::string& path, const Inputs& in, const RunResult& r);

/// The report's "input": files, format, kind, slices, size, slice z, pixel size, space, axis, ROIs.
nlohmann::json input_report(const Inputs& in);

/// Wall seconds of the parts of a run outside the pipeline.
struct RunSeconds {
  double read = 0, write = 0, total = 0;
};

/// The whole report, as `isoloft reconstruct --report` writes it.
nlohmann::json run_report(const std::string& git, const std::string& command, const Inputs& in,
                          const ReconstructParams& params, const RunResult& r, const RunSeconds& seconds,
                          const std::vector<std::string>& volume_files);

/// A byte count from "4G", "512M", "64K", "1.5G" (binary units) or plain
/// bytes; 0 = no limit. \throw ParamError naming `option`.
double parse_size(const std::string& text, const std::string& option);
/// E.g. "3.2 GiB", "512 MiB".
std::string size_text(double bytes);
/// \throw ParamError "<option>: <what> needs about X, over the budget of Y ..." if need > limit > 0.
void check_budget(const std::string& option, const std::string& what, double need, double limit);

/// Bytes the input holds up to and through the contour stage (docs/decisions.md,
/// work budget): for each job, its held slice images (volumes; PNG slices are
/// decoded as the pipeline goes), its packed masks and, per slice in flight,
/// a decoded image, the full-size masks and the fill's temporaries; plus a
/// volume input's voxels.
double input_bytes(const Inputs& in);

/// \throw InputError naming the input and why if an object's surface has no
/// triangles (unless `allow_empty`), or if there is no object at all.
void check_surfaces(const Inputs& in, const RunResult& r, bool allow_empty, const std::string& allow_option);

/// Peak resident memory of this process in MiB.
double peak_memory_mib();

}  // namespace isoloft
