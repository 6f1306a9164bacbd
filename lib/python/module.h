// @file python/module.h
// @brief The pieces of the Python module isoloft._isoloft (pybind11) shared by
// its files: argument conversions and inputs (module_inputs.cpp), runs,
// results, synth and evaluate (module_run.cpp), the bindings
// (isoloft_module.cpp). Internal to the module.
#pragma once

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "isoloft/core/params.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/pipeline.h"
#include "isoloft/run.h"
#include "isoloft/run/rtstruct_output.h"

namespace isoloft::python {

namespace py = pybind11;

using Clock = std::chrono::steady_clock;
inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// ---------------------------------------------------------------- conversions (module_inputs.cpp)

/// Python values as JSON for the parameter tables (which check type and range
/// themselves: a float NaN arrives as NaN and is rejected there, by key).
nlohmann::json to_json(const py::handle& o, const std::string& where);
/// JSON as Python values (dicts, lists, numbers).
py::object to_python(const nlohmann::json& j);
/// A path argument (str, bytes or os.PathLike) as text. \throw ParamError naming `name`.
std::string checked_path(const py::object& path, const std::string& name);

// ---------------------------------------------------------------- inputs (module_inputs.cpp)

// A read or built input, shared by its stacks and results.
using InputsPtr = std::shared_ptr<Inputs>;

struct PyInput {
  InputsPtr in;
  nlohmann::json truth;  // synth(): the shape and stack (what evaluate() reads)
  double read_seconds = 0;
};

/// The raw slice images of the first stack as an (n, h, w) array of the
/// smallest unsigned type that holds the stack's range (None for polygons).
py::object stack_images(const SliceStack& st);
/// Per slice, a list of (k, 2) x, y arrays.
py::list stack_polygons(const SliceStack& st);
/// (n, h, w) arrays or a list of 2D arrays (polylines: per slice a list of
/// point arrays on a grid of image_shape) as a one-job input.
PyInput from_arrays(const py::object& slices, const std::string& kind, std::optional<double> z_spacing,
                    std::optional<std::vector<double>> slice_z, double pixel_size,
                    std::optional<std::pair<int, int>> image_shape, bool binarize);
/// An image object's voxels (x fastest) and geometry (LPS) as a volume input.
PyInput from_volume(const py::array& data, const std::array<double, 3>& spacing, const std::array<double, 3>& origin,
                    const py::array_t<double, py::array::c_style | py::array::forcecast>& direction, bool integer,
                    const std::string& name, const std::string& kind, const std::string& axis, const std::string& space,
                    const std::string& label_names);
/// A list of sections {origin, u, v, contours: [{points, label, hole}]}
/// (world units, N x 2 in-plane or N x 3 world points), or with a label
/// image {image, affine} / {image, origin, u, v, pixel_size} (image[a, b]
/// at origin + pixel_size (a u + b v)), as a Sections input
/// (run/inputs.h, sections_input). \throw InputError naming "sections[i]...".
PyInput from_sections(const py::object& sections);
/// What `isoloft reconstruct` reads, from paths.
PyInput read_input(const std::vector<std::string>& paths, const std::string& kind, std::optional<double> z_spacing,
                   std::optional<std::vector<double>> slice_z, std::optional<double> pixel_size, const std::string& axis,
                   const std::vector<std::string>& rois, std::optional<double> voxel_size, const std::string& space,
                   const std::string& max_memory, bool allow_external_data, const std::string& label_names,
                   const std::string& method);

// ---------------------------------------------------------------- runs and results (module_run.cpp)

struct ResultData {
  InputsPtr in;
  std::vector<ReadFile> reads;  // what the run read besides its input: save() never replaces them
  RunResult run;
  MeshWriteOptions mesh_options;
  Method method = ReconstructParams{}.method;
  nlohmann::json report;
};

struct PyObjectResult {
  std::shared_ptr<ResultData> data;
  std::size_t index = 0;
  py::object vertices;  // (N, 3) float64, output units, read-only
  py::object faces;     // (M, 3) int32 viewing the C++ triangles, read-only

  [[nodiscard]] const RunObject& object() const { return data->run.objects[index]; }
};

struct PyResult {
  std::shared_ptr<ResultData> data;
  py::list objects;
};

// One step of progress, for the Python callback.
struct PyProgress {
  std::uint32_t label;
  std::string roi, stage;
  long done, total, stage_done, stage_total;
  explicit PyProgress(const RunProgress& p)
      : label(p.label), roi(p.roi), stage(p.stage), done(p.object_done), total(p.object_total), stage_done(p.done),
        stage_total(p.total) {}
};

// The outputs a reconstruct() call writes besides its meshes (save() writes those).
struct PyOutputs {
  std::string volume, labelmap, dump_stages, rtstruct, volumes, report;
  std::string reference;  ///< the grid of labelmap (a CT series folder or a volume)
  RtContourParams rt;       ///< rtstruct's contours (rt_point_spacing, rt_min_area)
  std::string rt_contours;  ///< rtstruct's per-contour report (.csv)
};

/// One reconstruct() call: the run (GIL released), its objects as arrays.
PyResult run(const PyInput& input, const py::dict& params_kw, const std::vector<std::uint32_t>& labels,
             std::optional<int> threads, const py::object& progress, bool allow_empty, const PyOutputs& files,
             const std::string& max_memory, const std::string& max_output, long max_files);
/// An analytic shape cut into a slice stack.
PyInput synth(const std::string& shape, int size, double z_spacing, const std::string& kind);
/// Distances from a mesh to the analytic truth.
py::object evaluate(const py::object& mesh, const py::object& truth, double pixel_size);

}  // namespace isoloft::python
