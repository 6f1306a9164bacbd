// Options and actions of the isoloft subcommands.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/pipeline.h"
#include "isoloft/run/budget.h"

namespace isoloft::cli {

/// The flags of `isoloft reconstruct` that are not reconstruction parameters
/// (inputs, outputs, run options); the parameters' flags come from the
/// parameter table (ParamFlags).
struct ReconstructArgs {
  std::vector<std::string> inputs;
  std::string output, volume, params_file, report, input_kind, labels;
  double z_spacing = 1.0, pixel_size = 1.0;
  std::string slice_z;
  std::string dump_stages;
  std::string axis;                ///< volumes: i, j or k ("" = the sparse one)
  std::vector<std::string> rois;   ///< RT Structure Sets: ROI names ("" = every ROI with closed contours)
  double voxel_size = 0.5;         ///< RT Structure Sets: working grid, mm
  std::string space;               ///< patient space of the outputs: lps (default) or ras
  std::string labelmap;            ///< the dense label map out (volumes; any input with --reference)
  std::string reference;           ///< the grid of --labelmap: a CT series folder or a volume
  std::string rtstruct;            ///< RT Structure Sets: the surfaces back as an RT Structure Set (or -o OUT.dcm)
  std::string volumes;             ///< the volume table as CSV or JSON
  double rt_point_spacing = 0;     ///< RT Structure Set out: mm between written points (0 = as drawn)
  double rt_min_area = 0;          ///< RT Structure Set out: lost drawn contours under this (mm^2) dropped
  std::string rt_contours;         ///< RT Structure Set out: the per-contour report as CSV
  int threads = 0;
  std::string max_memory = "4G", max_output = "4G";  ///< budget (--max-memory, --max-output)
  long max_files = kDefaultMaxFiles;                  ///< --max-files (0 = no limit)
  bool print_params = false, quiet = false, ascii = false, list_rois = false, allow_empty = false;
  std::string z_slab;  ///< "I/S": z slab I of S (1-based)
  bool allow_external_data = false;                  ///< --allow-external-data
  std::string label_names;                           ///< --label-names
  std::string annotated, annotated_mask;             ///< --annotated, --annotated-mask
  CLI::Option *z_spacing_opt = nullptr, *pixel_size_opt = nullptr, *slice_z_opt = nullptr, *voxel_size_opt = nullptr;
};

/// One CLI11 option per parameter-table row that has a flag, and applying
/// the given ones to a ReconstructParams (after any --params file).
class ParamFlags {
 public:
  void add_to(CLI::App& app);
  /// \throw ParamError naming the flag if a value is out of range.
  void apply(isoloft::ReconstructParams& params) const;
  /// The flag of parameter `key` if it was given on the command line, else "".
  [[nodiscard]] std::string given(const std::string& key) const;
  /// The --method flag's value, if given. \throw ParamError for an unknown name.
  std::optional<isoloft::Method> method() const;

 private:
  struct Flag {
    std::string key;
    CLI::Option* option = nullptr;
    std::string text;  // value of a valued option
    bool set = false;  // a bare bool flag was given
  };
  std::vector<std::unique_ptr<Flag>> flags_;
};

struct SynthOptions {
  std::string shape, out, kind = "contours";
  std::optional<int> size;  ///< default 128; the oblique shapes size their images themselves
  double z_spacing = 8.0;
  std::optional<double> tilt, radius, gap;  ///< the oblique shapes only
  std::optional<int> slices;
  bool list = false;
};

struct EvalOptions {
  std::string mesh, truth, reference, report;
  double pixel_size = 1.0, error_bound = 0.05, threshold = 0;
};

struct JoinOptions {
  std::vector<std::string> parts;  ///< one object's z slab meshes, bottom up
  std::string output, report;
  double decimate_error = 0;  ///< the joined mesh decimated within this, in the parts' units (0: not)
  bool allow_empty = false;
};

class Commands {
 public:
  Commands(CLI::App& app, int argc, char** argv);
  int run();
  /// What the command is doing ("reading X", "reconstructing Y", "writing Z"),
  /// for an error that has no context of its own (e.g. out of memory).
  [[nodiscard]] const std::string& activity() const { return activity_; }
  /// How main() set up the heap, for the report.
  void set_heap(std::string heap) { heap_ = std::move(heap); }

 private:
  int reconstruct();
  int synth();
  int eval();
  int batch();
  int join_slabs();
  CLI::App *reconstruct_ = nullptr, *synth_ = nullptr, *eval_ = nullptr, *batch_ = nullptr, *join_ = nullptr;
  ReconstructArgs r_;
  ParamFlags param_flags_;
  SynthOptions s_;
  EvalOptions e_;
  JoinOptions j_;
  std::string command_line_;
  std::string activity_;
  std::string heap_;
};

}  // namespace isoloft::cli
