// @file run.h
// @brief One reconstruction run, as `isoloft reconstruct` and the Python
// module both do it: an input read as slice stacks ("jobs", run/inputs.h),
// the pipeline on each under a work budget (run/budget.h), every object's
// mesh in output units, the outputs asked for (run/outputs.h: meshes,
// volumes, label map, stage dumps; run/rtstruct_output.h, run/volume_table.h)
// staged and committed together, and the run report (with the volume table). The front ends only turn their options into an InputRequest
// and RunOptions, and show progress, warnings and errors.
//
// Output units: patient mm (LPS) for inputs with a patient frame (volumes,
// RT Structure Sets), else working pixels (the writers scale by pixel_size).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/pipeline.h"
#include "isoloft/run/budget.h"
#include "isoloft/run/inputs.h"
#include "isoloft/run/outputs.h"
#include "isoloft/run/rtstruct_output.h"
#include "isoloft/run/volume_table.h"

namespace isoloft {

/// Distinct colours per object: golden-ratio hue steps at full saturation.
Rgb label_colour(std::size_t i);

/// One reconstructed object of a run. Its one mesh is object.mesh, in working
/// pixels; the writers place it in output units as they write (patient mm
/// through the job's frame, or pixels times the pixel size:
/// object_mesh_options(), run/outputs.h), so no copy is held.
struct RunObject {
  std::size_t job = 0;   ///< index into Inputs::jobs
  ObjectResult object;   ///< the pipeline's result (mesh in working pixels)
  Rgb colour;            ///< the ROI's display colour, or label_colour(index)
  std::string file;      ///< where its mesh was written (MeshOutput, write_run_meshes())
};

struct RunResult {
  std::vector<RunObject> objects;
  StageTimes times;                   ///< summed over the jobs
  std::vector<std::string> warnings;  ///< the input's, then each job's (prefixed by its ROI)
  int threads = 0;                    ///< worker threads available during the run
  nlohmann::json report;              ///< run(): the whole report, as --report writes it
};

/// One progress step of a run, from worker threads. Objects run side by
/// side, so steps of different objects interleave; per object (job, label)
/// object_done only grows.
struct RunProgress {
  std::size_t job = 0;       ///< index into Inputs::jobs
  std::string_view roi;      ///< the job's ROI name, or ""
  std::uint32_t label = 0;   ///< the object's label (0: the only object, or a labels input's shared scan)
  std::string_view stage;    ///< contour, mpu+distance (levin: distance), interpolate+mesh, decimate
  long done = 0, total = 0;  ///< of this stage
  /// The object's steps over its stages: done so far, and the total known so
  /// far (every stage's once its work estimate is in, before its fit).
  long object_done = 0, object_total = 0;
};

/// How a run goes beyond its input and parameters.
struct RunOptions {
  std::vector<std::uint32_t> labels;  ///< labels input: only these (empty = all)
  Budget budget;
  /// What it writes besides the report, in this order (e.g. MeshOutput first).
  std::vector<std::unique_ptr<RunOutput>> outputs;
  std::string report_path;  ///< the JSON report ("" = none; RunResult::report always)
  /// Files read besides the input (the --params file, a --reference): no output may replace them.
  std::vector<ReadFile> read_files;
  bool allow_empty = false;  ///< an object with no triangles is kept instead of an error
  /// Only this z slab (ReconstructOptions::z_slab): the mesh output alone,
  /// each object's part of the surface (open at the cuts; empty allowed).
  ZSlab z_slab;
  /// The mesh output may write each object once final and free its mesh
  /// (RunOutput::streams_objects(); the result keeps its counts:
  /// ObjectResult::vertex_count()), unless another output reads the meshes.
  bool free_meshes = false;
  int threads = 0;           ///< worker threads (0 = all the environment allows)
  std::function<void(const RunProgress&)> progress;
  /// Every warning, once the jobs are done (before the surfaces are checked).
  std::function<void(const std::string&)> warn;
  /// What the run is doing ("reconstructing label 3 (...)", "writing out.ply"),
  /// for an error that has no context of its own (out of memory).
  std::function<void(const std::string&)> activity;
  std::string git, command;  ///< for the report
  std::string heap;          ///< how the process's heap was set up (report "heap"; "" = not reported)
  double read_seconds = 0;   ///< reading the input (report)
  double seconds_before = 0; ///< spent before run() (reading included), added to the report's total
};

/// The whole run on read inputs: options and budget checked, the jobs
/// reconstructed with every output's hooks, the surfaces checked, the outputs
/// written and committed together with the report (or none of them).
/// \throw ParamError / InputError naming the option or the input; whatever a
///        progress callback throws (the run stops, nothing is written).
RunResult run(const Inputs& in, const ReconstructParams& params, RunOptions& options);

/// What must hold before the input is read (cheap): every output's check_format().
void check_outputs_format(const RunOptions& options, InputFormat format);

/// reconstruct() on every job; `configure` (optional) adds per-job options
/// (progress, volume planes, ...), for every job before any runs; `finished`
/// (optional) is told each job's end. Jobs without per-plane, per-sample or
/// per-slice hooks run side by side (largest first, on_estimate one at a
/// time), else in turn; the result is the same. No object at all (no
/// contour anywhere) leaves `objects` empty: the caller's error to raise.
RunResult run_jobs(const Inputs& in, const ReconstructParams& params, const std::vector<std::uint32_t>& labels,
                   const std::function<void(std::size_t job, ReconstructOptions&)>& configure = {},
                   const std::function<void(std::size_t)>& finished = {});

/// The report's "objects": per object its label, file, ROI, counts, checks,
/// volume and area (output units), MPU statistics (marker2006) and, for RT
/// Structure Set ROIs, the contour vertices' distance to the mesh (output units).
nlohmann::json objects_report(const Inputs& in, const RunResult& r, Method method);

/// Wall seconds of the parts of a run outside the pipeline.
struct RunSeconds {
  double read = 0, write = 0, total = 0;
};

/// The whole report, as `isoloft reconstruct --report` writes it (outputs
/// then add their files: RunOutput::report()).
nlohmann::json run_report(const std::string& git, const std::string& command, const Inputs& in,
                          const ReconstructParams& params, const RunResult& r, const RunSeconds& seconds);

/// \throw InputError naming the input and why if an object's surface has no
/// triangles (unless `allow_empty`), or if there is no object at all.
void check_surfaces(const Inputs& in, const RunResult& r, bool allow_empty);

/// Peak resident memory of this process in MiB.
double peak_memory_mib();

/// The contour vertices of a polygon stack at their slice z (working
/// pixels): what an RT ROI's contour_distance measures.
std::vector<Vec3d> contour_vertices(const SliceStack& st);

}  // namespace isoloft
