// @file python/module_run.cpp
// @brief isoloft._isoloft: a reconstruct() call through isoloft/run.h with
// the GIL released, its meshes as numpy arrays viewing the C++ buffers;
// synth() and evaluate().
#include <atomic>
#include <cmath>
#include <fstream>
#include <set>
#include <tuple>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/eval/metrics.h"
#include "isoloft/io/mesh/format.h"
#include "isoloft/run/reference_labelmap.h"
#include "isoloft/run/unused_params.h"
#include "isoloft/synth/synth.h"
#include "python/module.h"

namespace isoloft::python {

namespace {

py::object read_only(py::array a) {
  a.attr("flags").attr("writeable") = false;
  return a;
}

// The object's arrays: vertices converted once to float64 in output units
// (the C++ mesh is float32, in working pixels), faces a view of the C++
// buffer (a copy with each triangle reversed where the frame mirrors). The
// view's base is a capsule owning the results (not the Object: that would be a cycle).
void make_arrays(PyObjectResult& o) {
  const RunObject& r = o.object();
  const TriMesh& mesh = r.object.mesh;
  const MeshWriteOptions mo = object_mesh_options(*o.data->in, r, o.data->mesh_options);
  // What save() writes: the writer's own float arithmetic.
  const detail::Scaled scaled{mesh, mo.scale, mo.frame ? &*mo.frame : nullptr, mo.ras};
  py::array_t<double> v({py::ssize_t(mesh.vertices.size()), py::ssize_t(3)});
  double* p = v.mutable_data();
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3f q = scaled[i];
    *p++ = q.x(), *p++ = q.y(), *p++ = q.z();
  }
  o.vertices = read_only(v);
  static_assert(sizeof(std::array<std::int32_t, 3>) == 3 * sizeof(std::int32_t));
  const auto m = py::ssize_t(mesh.triangles.size());
  if (mo.frame && mo.frame->axes.determinant() < 0) {
    py::array_t<std::int32_t> f({m, py::ssize_t(3)});
    std::int32_t* q = f.mutable_data();
    for (const auto& t : mesh.triangles) *q++ = t[0], *q++ = t[2], *q++ = t[1];
    o.faces = read_only(f);
    return;
  }
  const std::int32_t* t = m ? mesh.triangles.front().data() : nullptr;
  const py::capsule owner(new std::shared_ptr<ResultData>(o.data),
                          [](void* p) { delete static_cast<std::shared_ptr<ResultData>*>(p); });
  py::array_t<std::int32_t> f({m, py::ssize_t(3)}, {py::ssize_t(12), py::ssize_t(4)}, t, owner);
  o.faces = read_only(f);
}

// Raised from the progress hook (worker threads) to stop the pipeline after
// the Python callback raised or Ctrl-C was pressed; the Python error is kept.
struct CallbackStopped : std::exception {
  [[nodiscard]] const char* what() const noexcept override { return "stopped by the progress callback"; }
};

}  // namespace

PyResult run(const PyInput& input, const py::dict& params_kw, const std::vector<std::uint32_t>& labels,
             std::optional<int> threads, const py::object& progress, bool allow_empty, const PyOutputs& files,
             const std::string& max_memory, const std::string& max_output, long max_files) {
  const InputsPtr in = input.in;
  ReconstructParams params = params_from_json(to_json(params_kw, ""));
  // The keywords given, by row key (a nested dict's entries as "mpu.n_min"),
  // refused as the CLI refuses a flag where the run never reads them.
  std::set<std::string> given;
  for (const auto& [k, v] : params_kw) {
    const std::string key = py::str(k);
    if (!py::isinstance<py::dict>(v)) {
      given.insert(key);
      continue;
    }
    for (const auto& [k2, v2] : v.cast<py::dict>()) given.insert(key + "." + std::string(py::str(k2)));
  }
  refuse_unused_params([&](const std::string& key) { return given.count(key) ? key : std::string(); }, params, *in);
  if (threads && *threads < 1) throw ParamError("threads: must be >= 1, got " + std::to_string(*threads));
  for (std::uint32_t l : labels)
    if (l == 0) throw ParamError("labels: 0 is the background, not a label");
  RunOptions o;
  o.labels = labels;
  if (max_files < 0) throw ParamError("max_files: must be >= 0 (0 = no limit), got " + std::to_string(max_files));
  o.budget = {parse_size(max_memory, "max_memory"), parse_size(max_output, "max_output"), max_files};
  if (!files.volume.empty()) o.outputs.push_back(std::make_unique<VolumeOutput>(files.volume));
  if (!files.reference.empty() && files.labelmap.empty())
    throw ParamError(option_name("--reference") + ": gives the grid of a label map; give " + option_name("--labelmap") +
                     " with it");
  if (!files.labelmap.empty() && !files.reference.empty())
    o.outputs.push_back(std::make_unique<ReferenceLabelmapOutput>(
        files.labelmap, std::make_shared<const ReferenceGrid>(read_reference(files.reference))));
  else if (!files.labelmap.empty())
    o.outputs.push_back(std::make_unique<LabelmapOutput>(files.labelmap));
  if (!files.dump_stages.empty()) o.outputs.push_back(std::make_unique<StageDumpOutput>(files.dump_stages));
  if (files.rtstruct.empty() && (files.rt.point_spacing != 0 || files.rt.min_area != 0 || !files.rt_contours.empty()))
    throw ParamError("rt_point_spacing, rt_min_area and rt_contours: only with rtstruct (an RT Structure Set out)");
  if (!files.rtstruct.empty())
    o.outputs.push_back(std::make_unique<RtStructOutput>(files.rtstruct, "--rtstruct", files.rt, files.rt_contours));
  if (!files.volumes.empty()) o.outputs.push_back(std::make_unique<VolumeTableOutput>(files.volumes));
  o.report_path = files.report;
  o.read_files = {{"--reference", files.reference}};
  o.allow_empty = allow_empty;
  o.threads = threads.value_or(0);
  o.git = ISOLOFT_GIT;
  o.command = "isoloft.reconstruct (Python)";
  o.heap = "the interpreter's, as started";  // the CLI's own setting is the CLI's (lib/cli/main.cpp)
  o.read_seconds = o.seconds_before = input.read_seconds;

  auto data = std::make_shared<ResultData>();
  data->in = in;
  data->reads = o.read_files;
  for (const auto& out : o.outputs)
    for (ReadFile& f : out->read_files()) data->reads.push_back(std::move(f));
  std::optional<py::error_already_set> failed;
  std::atomic<bool> stop{false};
  // Without a callback, Ctrl-C is still looked for, at most every kSignalCheck
  // (each look waits for the GIL, up to a switch interval if Python is busy).
  constexpr auto kSignalCheck = std::chrono::milliseconds(100);
  std::atomic<Clock::rep> last_check{Clock::now().time_since_epoch().count()};
  o.progress = [&](const RunProgress& p) {
    if (stop.load()) throw CallbackStopped{};
    if (progress.is_none()) {
      const auto now = Clock::now().time_since_epoch().count();
      auto last = last_check.load();
      if (Clock::duration(now - last) < kSignalCheck || !last_check.compare_exchange_strong(last, now)) return;
    }
    py::gil_scoped_acquire gil;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (!progress.is_none()) progress(PyProgress{p});
    } catch (py::error_already_set& e) {
      if (!failed) failed = std::move(e);
      stop = true;
      throw CallbackStopped{};
    }
  };
  try {
    py::gil_scoped_release release;
    data->run = isoloft::run(*in, params, o);
  } catch (const CallbackStopped&) {
    throw *failed;
  }
  data->mesh_options = run_mesh_options(*in);
  data->method = params.method;
  data->report = std::move(data->run.report);
  PyResult r{data, py::list()};
  for (std::size_t i = 0; i < data->run.objects.size(); ++i) {
    auto o = std::make_shared<PyObjectResult>();
    o->data = data;
    o->index = i;
    make_arrays(*o);
    r.objects.append(py::cast(o));
  }
  return r;
}

// ---------------------------------------------------------------- synth / evaluate

PyInput synth(const std::string& shape, int size, double z_spacing, const std::string& kind) {
  SynthParams p;
  p.size = size;
  p.z_spacing = z_spacing;
  p.kind = enum_from_string<InputKind>(kind, "kind");
  auto in = std::make_shared<Inputs>();
  in->format = InputFormat::Arrays;
  SynthResult r;
  {
    py::gil_scoped_release release;
    r = synthesize(*make_default_shape(shape, size), p);
  }
  in->jobs.push_back({std::move(r.stack), "", std::nullopt});
  return {in, r.description, 0};
}

// The truth's shape and z range: a synth() input, its description dict or a shape.json path.
std::tuple<std::unique_ptr<Shape>, double, double> truth_shape(const py::object& truth) {
  nlohmann::json j;
  std::string where = "truth";
  if (py::isinstance<PyInput>(truth)) {
    j = truth.cast<const PyInput&>().truth;
    if (j.is_null()) throw ParamError("truth: this input is not from isoloft.synth() (it has no analytic shape)");
  } else if (py::isinstance<py::dict>(truth)) {
    j = nlohmann::json::parse(std::string(py::str(py::module_::import("json").attr("dumps")(truth))));
  } else {
    where = py::str(py::module_::import("os").attr("fspath")(truth));
    std::ifstream f(where);
    if (!f) throw InputError(where, "cannot open truth file");
    try {
      j = nlohmann::json::parse(f);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(where, std::string("not valid JSON: ") + e.what());
    }
  }
  if (!j.contains("shape") || !j.contains("stack")) throw InputError(where, "expected 'shape' and 'stack' (from isoloft synth)");
  std::unique_ptr<Shape> shape;
  try {
    shape = shape_from_json(j["shape"]);
  } catch (const ParamError& e) {
    throw InputError(where, e.what());
  }
  return {std::move(shape), j["stack"].value("z_first", 0.0), j["stack"].value("z_last", 0.0)};
}

py::object evaluate(const py::object& mesh, const py::object& truth, double pixel_size) {
  TriMesh m;
  if (py::isinstance<PyObjectResult>(mesh)) {
    m = mesh.cast<const PyObjectResult&>().object().object.mesh;  // working pixels, as the truth
  } else {
    if (!(std::isfinite(pixel_size) && pixel_size > 0)) throw ParamError("pixel_size: must be finite and > 0");
    const bool attrs = py::hasattr(mesh, "vertices") && py::hasattr(mesh, "faces");
    const py::object vo = attrs ? py::object(mesh.attr("vertices")) : py::object(mesh.cast<py::sequence>()[0]);
    const py::object fo = attrs ? py::object(mesh.attr("faces")) : py::object(mesh.cast<py::sequence>()[1]);
    const auto v = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(vo);
    const auto f = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(fo);
    if (!v || v.ndim() != 2 || v.shape(1) != 3) throw InputError("mesh", "vertices must be an (N, 3) array");
    if (!f || f.ndim() != 2 || f.shape(1) != 3) throw InputError("mesh", "faces must be an (M, 3) array");
    for (py::ssize_t i = 0; i < v.shape(0); ++i)
      m.vertices.emplace_back(float(v.at(i, 0) / pixel_size), float(v.at(i, 1) / pixel_size), float(v.at(i, 2) / pixel_size));
    for (py::ssize_t i = 0; i < f.shape(0); ++i) {
      std::array<std::int32_t, 3> t{};
      for (int k = 0; k < 3; ++k) {
        const std::int64_t x = f.at(i, k);
        if (x < 0 || x >= v.shape(0))
          throw InputError("mesh", "face " + std::to_string(i) + " references vertex " + std::to_string(x) + " of " +
                                       std::to_string(v.shape(0)));
        t[std::size_t(k)] = std::int32_t(x);
      }
      m.triangles.push_back(t);
    }
  }
  auto [shape, z0, z1] = truth_shape(truth);
  MeshToShapeStats s;
  {
    py::gil_scoped_release release;
    s = mesh_to_shape_stats(m, *shape, z0, z1);
  }
  return to_python(s.to_json());
}


}  // namespace isoloft::python
