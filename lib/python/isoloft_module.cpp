// isoloft._isoloft: the library on numpy arrays (pybind11). The Python API
// (argument defaults, paths vs arrays) is isoloft/__init__.py; this file
// turns arrays into slice stacks, runs isoloft/run.h with the GIL released,
// and hands back meshes whose face arrays view the C++ buffers.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/core/params.h"
#include "isoloft/eval/metrics.h"
#include "isoloft/io/mesh/format.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/pipeline.h"
#include "isoloft/run.h"
#include "isoloft/run/reference_labelmap.h"
#include "isoloft/synth/synth.h"

namespace py = pybind11;
using namespace isoloft;

namespace {

PyObject* g_error = nullptr;        // isoloft.Error
PyObject* g_input_error = nullptr;  // isoloft.InputError (also a ValueError)
PyObject* g_param_error = nullptr;  // isoloft.ParamError (also a ValueError)

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// ---------------------------------------------------------------- JSON <-> Python

// Python values as JSON for the parameter tables (which check type and range
// themselves: a float NaN arrives as NaN and is rejected there, by key).
nlohmann::json to_json(const py::handle& o, const std::string& where) {
  if (o.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(o)) return o.cast<bool>();
  if (py::isinstance<py::int_>(o)) {
    const py::int_ i = o.cast<py::int_>();
    if (i < py::int_(0)) return o.cast<std::int64_t>();
    return o.cast<std::uint64_t>();
  }
  if (py::isinstance<py::float_>(o)) return o.cast<double>();
  if (py::isinstance<py::str>(o)) return o.cast<std::string>();
  if (py::isinstance<py::dict>(o)) {
    nlohmann::json j = nlohmann::json::object();
    for (auto [k, v] : o.cast<py::dict>()) {
      const std::string key = py::str(k);
      j[key] = to_json(v, where.empty() ? key : where + "." + key);
    }
    return j;
  }
  if (py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o)) {
    nlohmann::json j = nlohmann::json::array();
    for (const py::handle& v : o.cast<py::sequence>()) j.push_back(to_json(v, where));
    return j;
  }
  if (py::hasattr(o, "item") && py::hasattr(o, "dtype")) return to_json(o.attr("item")(), where);  // numpy scalar
  throw ParamError(where + ": unsupported value of type " + std::string(py::str(o.get_type().attr("__name__"))));
}

// (No static py::object here: it would be released after the interpreter is gone.)
py::object to_python(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// ---------------------------------------------------------------- inputs

// A read or built input, shared by its stacks and results.
using InputsPtr = std::shared_ptr<Inputs>;

struct PyInput {
  InputsPtr in;
  nlohmann::json truth;  // synth(): the shape and stack (what evaluate() reads)
  double read_seconds = 0;
};

// The raw slice images of job j as an (n, h, w) array of the smallest
// unsigned type that holds the stack's range.
py::object stack_images(const SliceStack& st) {
  if (st.has_polygons()) return py::none();
  const auto n = py::ssize_t(st.slices.size()), h = py::ssize_t(st.height), w = py::ssize_t(st.width);
  auto fill = [&](auto tag) {
    using T = decltype(tag);
    py::array_t<T> a({n, h, w});
    T* p = a.mutable_data();
    for (std::size_t k = 0; k < st.slices.size(); ++k) {
      const Grid2u32 lazy = st.load_image ? st.load_image(k) : Grid2u32{};  // PNG stacks decode slice by slice
      for (std::uint32_t v : (st.load_image ? lazy : st.slices[k].image).data) *p++ = T(v);
    }
    return py::object(a);
  };
  if (st.max_value <= 0xFFu) return fill(std::uint8_t{});
  if (st.max_value <= 0xFFFFu) return fill(std::uint16_t{});
  return fill(std::uint32_t{});
}

py::list stack_polygons(const SliceStack& st) {
  py::list out;
  for (const Slice& s : st.slices) {
    py::list loops;
    for (const Polygon& p : s.polygons) {
      py::array_t<double> a({py::ssize_t(p.points.size()), py::ssize_t(2)});
      double* d = a.mutable_data();
      for (const Vec2d& q : p.points) *d++ = q.x(), *d++ = q.y();
      loops.append(a);
    }
    out.append(loops);
  }
  return out;
}

// One 2D slice of the arrays input into `slice`; returns the value range it needs.
std::uint32_t copy_slice(const py::array& a, Slice& slice, int& width, int& height, const std::string& where) {
  if (a.ndim() != 2) throw InputError(where, "expected a 2D array, got " + std::to_string(a.ndim()) + " dimensions");
  const int h = int(a.shape(0)), w = int(a.shape(1));
  if (h < 1 || w < 1) throw InputError(where, "empty image");
  if (width == 0) width = w, height = h;
  if (w != width || h != height)
    throw InputError(where, std::to_string(h) + "x" + std::to_string(w) + " differs from the first slice's " +
                                std::to_string(height) + "x" + std::to_string(width));
  const char kind = a.dtype().kind();
  if (kind != 'b' && kind != 'u' && kind != 'i')
    throw InputError(where, "dtype " + std::string(py::str(a.dtype())) +
                                " is not bool or integer (contour/mask images or integer labels)");
  // One cast to uint32 (numpy checks nothing here; negatives and > 2^32 - 1 are checked first).
  if (kind == 'i' || (kind == 'u' && a.itemsize() > 4)) {
    const auto lo = py::int_(a.attr("min")()), hi = py::int_(a.attr("max")());
    if (lo < py::int_(0)) throw InputError(where, "negative value " + py::repr(lo).cast<std::string>());
    if (hi > py::int_(std::numeric_limits<std::uint32_t>::max()))
      throw InputError(where, "value " + py::repr(hi).cast<std::string>() + " is larger than 2^32 - 1");
  }
  const auto u = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>::ensure(a);
  slice.image = Grid2u32(w, h);
  std::copy(u.data(), u.data() + u.size(), slice.image.data.begin());
  slice.source = where;
  if (kind == 'b') return 1;
  if (kind == 'u' && a.itemsize() == 1) return 0xFFu;
  if (kind == 'u' && a.itemsize() == 2) return 0xFFFFu;
  std::uint32_t m = 1;
  for (std::uint32_t v : slice.image.data) m = std::max(m, v);
  return m;
}

// Closed polygons of one slice: a list of (k, 2) arrays of (x column, y row).
void copy_polygons(const py::handle& loops, Slice& slice, const std::string& where) {
  if (!py::isinstance<py::sequence>(loops)) throw InputError(where, "expected a list of (k, 2) point arrays");
  std::size_t i = 0;
  for (const py::handle& loop : loops.cast<py::sequence>()) {
    const std::string w = where + "[" + std::to_string(i++) + "]";
    const auto p = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(loop);
    if (!p || p.ndim() != 2 || p.shape(1) != 2) throw InputError(w, "expected a (k, 2) array of x, y points");
    if (p.shape(0) < 3) throw InputError(w, "a closed polygon needs at least 3 points");
    Polygon poly;
    for (py::ssize_t k = 0; k < p.shape(0); ++k) {
      const Vec2d q(p.at(k, 0), p.at(k, 1));
      if (!q.allFinite()) throw InputError(w, "point " + std::to_string(k) + " is not finite");
      poly.points.push_back(q);
    }
    slice.polygons.push_back(std::move(poly));
  }
}

// Kind inference (no input=): the share of white pixels whose whole 3x3
// neighbourhood is white. Filled masks have most (a disc of radius 3 px:
// 45 %; the 64 px synthetic sphere's masks: 87 %), 1-2 px wide contour
// curves none (where two curves touch, a few).
constexpr double kMaskInteriorShare = 0.25;   // at least this: filled masks
constexpr double kCurveInteriorShare = 0.02;  // at most this: contour curves

// The white pixels of a stack and how many of them have a white 3x3
// neighbourhood; white: value > threshold.
std::pair<double, double> white_interior(const SliceStack& st, std::uint32_t threshold) {
  double white = 0, interior = 0;
  for (const Slice& s : st.slices) {
    const Grid2u32& g = s.image;
    auto w = [&](int x, int y) { return x >= 0 && y >= 0 && x < g.width && y < g.height && g(x, y) > threshold; };
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        if (!w(x, y)) continue;
        ++white;
        bool all = true;
        for (int dy = -1; dy <= 1 && all; ++dy)
          for (int dx = -1; dx <= 1 && all; ++dx) all = w(x + dx, y + dy);
        interior += all;
      }
  }
  return {white, interior};
}

// The kind of a two-valued (binary) image stack given without input=.
// \throw InputError naming `input` when the shapes do not tell.
InputKind infer_binary_kind(const SliceStack& st, std::uint32_t threshold) {
  const auto [white, interior] = white_interior(st, threshold);
  const double share = white > 0 ? interior / white : 1.0;
  if (share >= kMaskInteriorShare) return InputKind::Masks;
  if (share <= kCurveInteriorShare) return InputKind::Contours;
  char pct[32];
  std::snprintf(pct, sizeof pct, "%.1f %%", 100 * share);
  throw InputError("slices", std::string("cannot tell filled masks from contour curves: ") + pct +
                                 " of the white pixels lie inside a white 3x3 block (filled masks: over " +
                                 std::to_string(int(100 * kMaskInteriorShare)) + " %, 1-pixel curves: none); give " +
                                 option_given("--input", "masks") + " or " + option_given("--input", "contours"));
}

// (n, h, w) arrays or a list of 2D arrays (polylines: a list per slice of
// point arrays, on a grid of image_shape) as a one-job input. kind "": from
// the values (more than two: labels; two: masks or contours by their shapes).
PyInput from_arrays(const py::object& slices, const std::string& kind, std::optional<double> z_spacing,
                    std::optional<std::vector<double>> slice_z, double pixel_size,
                    std::optional<std::pair<int, int>> image_shape, bool binarize) {
  auto in = std::make_shared<Inputs>();
  in->format = InputFormat::Arrays;
  SliceStack st;
  const bool infer = kind.empty();
  if (!infer) st.kind = enum_from_string<InputKind>(kind, "input");
  if (!(std::isfinite(pixel_size) && pixel_size > 0))
    throw ParamError("pixel_size: must be finite and > 0, got " + std::to_string(pixel_size));
  st.pixel_size = pixel_size;
  std::vector<py::object> items;
  if (py::isinstance<py::array>(slices)) {
    const py::array a = slices.cast<py::array>();
    if (a.ndim() != 3 && st.kind != InputKind::Polylines)
      throw InputError("slices", "expected an (n, h, w) array, got " + std::to_string(a.ndim()) + " dimensions");
    for (py::ssize_t k = 0; k < a.shape(0); ++k) items.push_back(a[py::int_(k)]);
  } else if (py::isinstance<py::sequence>(slices) && !py::isinstance<py::str>(slices)) {
    for (const py::handle& h : slices.cast<py::sequence>()) items.push_back(py::reinterpret_borrow<py::object>(h));
  } else {
    throw InputError("slices", "expected an (n, h, w) numpy array or a list of 2D arrays");
  }
  st.slices.resize(items.size());
  if (!infer && st.kind == InputKind::Polylines) {
    if (!image_shape) throw ParamError("image_shape: polylines need the grid size (height, width)");
    st.height = image_shape->first, st.width = image_shape->second;
    if (st.width < 1 || st.height < 1) throw ParamError("image_shape: must be positive");
    st.max_value = 1;
    for (std::size_t k = 0; k < items.size(); ++k) {
      copy_polygons(items[k], st.slices[k], "slices[" + std::to_string(k) + "]");
      st.slices[k].source = "slices[" + std::to_string(k) + "]";
    }
  } else {
    if (image_shape) throw ParamError("image_shape: only with input='polylines' (images carry their size)");
    st.max_value = 0;
    for (std::size_t k = 0; k < items.size(); ++k) {
      const auto a = py::array::ensure(items[k]);
      if (!a) throw InputError("slices[" + std::to_string(k) + "]", "not an array");
      const std::uint32_t m = copy_slice(a, st.slices[k], st.width, st.height, "slices[" + std::to_string(k) + "]");
      st.max_value = std::max(st.max_value, m);
    }
    // Two values (0 and v): a binary image whose white is v (a 0/1 uint8 mask needs no binarize).
    std::optional<std::uint32_t> white;
    bool binary = true;
    for (const Slice& s : st.slices) {
      for (std::uint32_t v : s.image.data) {
        if (v == 0 || v == white) continue;
        if (white) {
          binary = false;
          break;
        }
        white = v;
      }
      if (!binary) break;
    }
    if (binary && st.kind != InputKind::Labels) st.max_value = white.value_or(st.max_value);
    if (infer) {
      if (binary) st.kind = infer_binary_kind(st, st.max_value / 2);
      else if (binarize) st.kind = infer_binary_kind(st, st.max_value / 2);  // gray, thresholded by the pipeline
      else st.kind = InputKind::Labels;
    }
  }
  if (slice_z) {
    if (z_spacing) throw ParamError("give either z_spacing or slice_z, not both");
    if (slice_z->size() != st.slices.size())
      throw ParamError("slice_z has " + std::to_string(slice_z->size()) + " values for " +
                       std::to_string(st.slices.size()) + " slices");
    for (std::size_t k = 0; k < st.slices.size(); ++k) {
      if (!std::isfinite((*slice_z)[k])) throw ParamError("slice_z: value " + std::to_string(k) + " is not finite");
      st.slices[k].z = (*slice_z)[k];
    }
  } else {
    const double dz = z_spacing.value_or(1.0);
    if (!(std::isfinite(dz) && dz > 0)) throw ParamError("z_spacing: must be finite and > 0, got " + std::to_string(dz));
    for (std::size_t k = 0; k < st.slices.size(); ++k) st.slices[k].z = double(k) * dz;
  }
  in->jobs.push_back({std::move(st), "", std::nullopt});
  return {in, {}, 0};
}

// An image object's voxels (float, x fastest) and geometry (LPS) as a volume input.
PyInput from_volume(const py::array& data, const std::array<double, 3>& spacing, const std::array<double, 3>& origin,
                    const py::array_t<double, py::array::c_style | py::array::forcecast>& direction, bool integer,
                    const std::string& name, const std::string& kind, const std::string& axis, const std::string& space,
                    const std::string& label_names) {
  if (data.ndim() != 3) throw InputError(name, "expected a 3D image, got " + std::to_string(data.ndim()) + " dimensions");
  if (direction.ndim() != 2 || direction.shape(0) != 3 || direction.shape(1) != 3)
    throw InputError(name, "the direction must be 3 x 3");
  Volume v;
  for (int a = 0; a < 3; ++a)
    if (data.shape(a) > std::numeric_limits<int>::max())
      throw InputError(name, "axis " + std::to_string(a) + " has " + std::to_string(data.shape(a)) + " voxels (at most 2^31 - 1)");
  v.nz = int(data.shape(0)), v.ny = int(data.shape(1)), v.nx = int(data.shape(2));
  v.spacing = spacing;
  v.origin = origin;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) v.direction(r, c) = direction.at(r, c);
  detail::check_geometry(v, name);  // the checks the volume files pass
  v.integer = integer;
  if (integer) {
    // As the volume readers decode 32-bit integers: labels beyond a float's
    // exact 2^24 through a value table, never merged.
    const char k = data.dtype().kind();
    if (k == 'i' || (k == 'u' && data.itemsize() > 4)) {
      const auto lo = py::int_(data.attr("min")()), hi = py::int_(data.attr("max")());
      if (lo < py::int_(std::numeric_limits<std::int32_t>::min()) || hi > py::int_(std::numeric_limits<std::uint32_t>::max()))
        throw InputError(name, "value " + py::repr(lo < py::int_(0) ? lo : hi).cast<std::string>() +
                                   " is beyond 32-bit integers (labels are 0 .. 2^32 - 1)");
    }
    const bool is_signed = k == 'i' && py::int_(data.attr("min")()) < py::int_(0);
    v.data.resize(std::size_t(data.size()));
    if (is_signed) {
      const auto a = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>::ensure(data);
      detail::decode_volume(reinterpret_cast<const unsigned char*>(a.data()), detail::ScalarType::I32, false, v, name);
    } else {
      const auto a = py::array_t<std::uint32_t, py::array::c_style | py::array::forcecast>::ensure(data);
      detail::decode_volume(reinterpret_cast<const unsigned char*>(a.data()), detail::ScalarType::U32, false, v, name);
    }
  } else {
    const auto f = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(data);
    v.data.assign(f.data(), f.data() + f.size());
  }
  InputRequest r;
  r.kind = kind;
  r.axis = axis;
  r.space = space;
  r.label_names = label_names;
  const auto t0 = Clock::now();
  auto in = std::make_shared<Inputs>();
  {
    py::gil_scoped_release release;
    *in = volume_input(std::move(v), name, r);
  }
  return {in, {}, seconds_since(t0)};
}

PyInput read_input(const std::vector<std::string>& paths, const std::string& kind, std::optional<double> z_spacing,
                   std::optional<std::vector<double>> slice_z, std::optional<double> pixel_size, const std::string& axis,
                   const std::vector<std::string>& rois, std::optional<double> voxel_size, const std::string& space,
                   const std::string& max_memory, bool allow_external_data, const std::string& label_names) {
  InputRequest r;
  r.paths = paths;
  r.kind = kind;
  r.z_spacing = z_spacing;
  r.slice_z = std::move(slice_z);
  r.pixel_size = pixel_size;
  r.axis = axis;
  r.rois = rois;
  r.voxel_size = voxel_size;
  r.space = space;
  r.max_memory = parse_size(max_memory, "max_memory");
  r.allow_external_data = allow_external_data;
  r.label_names = label_names;
  if (paths.empty()) throw ParamError("path: no input given");
  const auto t0 = Clock::now();
  auto in = std::make_shared<Inputs>();
  {
    py::gil_scoped_release release;
    *in = read_inputs(r);
  }
  return {in, {}, seconds_since(t0)};
}

// ---------------------------------------------------------------- results

struct ResultData {
  InputsPtr in;
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

py::object read_only(py::array a) {
  a.attr("flags").attr("writeable") = false;
  return a;
}

// The object's arrays: vertices converted once to float64 in output units
// (the C++ mesh is float32), faces a view of the C++ buffer. The view's base
// is a capsule owning the results (not the Object: that would be a cycle).
void make_arrays(PyObjectResult& o) {
  const RunObject& r = o.object();
  const MeshWriteOptions& mo = o.data->mesh_options;
  // What save() writes: the writer's own float arithmetic.
  const TriMesh placed = mo.frame ? in_patient_space(r.mesh, *mo.frame, mo.ras) : TriMesh{};
  const detail::Scaled scaled{mo.frame ? placed : r.mesh, mo.frame ? 1.0 : mo.scale};
  py::array_t<double> v({py::ssize_t(r.mesh.vertices.size()), py::ssize_t(3)});
  double* p = v.mutable_data();
  for (std::size_t i = 0; i < r.mesh.vertices.size(); ++i) {
    const Vec3f q = scaled[i];
    *p++ = q.x(), *p++ = q.y(), *p++ = q.z();
  }
  o.vertices = read_only(v);
  static_assert(sizeof(std::array<std::int32_t, 3>) == 3 * sizeof(std::int32_t));
  const auto m = py::ssize_t(r.mesh.triangles.size());
  const std::int32_t* t = m ? r.mesh.triangles.front().data() : nullptr;
  const py::capsule owner(new std::shared_ptr<ResultData>(o.data),
                          [](void* p) { delete static_cast<std::shared_ptr<ResultData>*>(p); });
  py::array_t<std::int32_t> f({m, py::ssize_t(3)}, {py::ssize_t(12), py::ssize_t(4)}, t, owner);
  o.faces = read_only(f);
}

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

// Raised from the progress hook (worker threads) to stop the pipeline after
// the Python callback raised or Ctrl-C was pressed; the Python error is kept.
struct CallbackStopped : std::exception {
  [[nodiscard]] const char* what() const noexcept override { return "stopped by the progress callback"; }
};

// The outputs a reconstruct() call writes besides its meshes (save() writes those).
struct PyOutputs {
  std::string volume, labelmap, dump_stages, rtstruct, volumes, report;
  std::string reference;  ///< the grid of labelmap (a CT series folder or a volume)
  RtContourParams rt;       ///< rtstruct's contours (rt_point_spacing, rt_min_area)
  std::string rt_contours;  ///< rtstruct's per-contour report (.csv)
};

PyResult run(const PyInput& input, const py::dict& params_kw, const std::vector<std::uint32_t>& labels,
             std::optional<int> threads, const py::object& progress, bool allow_empty, const PyOutputs& files,
             const std::string& max_memory, const std::string& max_output, long max_files) {
  const InputsPtr in = input.in;
  ReconstructParams params = params_from_json(to_json(params_kw, ""));
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
        files.labelmap, std::make_shared<const ReferenceGrid>(read_reference(files.reference, o.budget.max_memory))));
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

PyObject* new_exception(py::module_& m, const char* name, PyObject* bases, const char* doc) {
  PyObject* e = PyErr_NewExceptionWithDoc((std::string("isoloft.") + name).c_str(), doc, bases, nullptr);
  if (!e) throw py::error_already_set();
  m.add_object(name, py::handle(e));
  return e;
}

}  // namespace

PYBIND11_MODULE(_isoloft, m) {
  m.doc() = "isoloft: closed surfaces from parallel planar contours (Marker et al. 2006); see the isoloft package";
  m.attr("__version__") = ISOLOFT_VERSION;
  m.attr("git") = ISOLOFT_GIT;
  m.attr("cli_path") = ISOLOFT_CLI_PATH;  // the CLI built with this module (isoloft.cli prefers a bundled one)
  // Errors name Python keywords (z_spacing, input='labels'), not the CLI's flags.
  set_option_style(OptionStyle::Keywords);

  g_error = new_exception(m, "Error", PyExc_Exception, "Base of all isoloft errors.");
  g_input_error = new_exception(m, "InputError", py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError)).release().ptr(),
                                "Bad input data: an unreadable, corrupt or inconsistent file or array (names it).");
  g_param_error = new_exception(m, "ParamError", py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError)).release().ptr(),
                                "A parameter or option outside its domain (names it).");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const isoloft::InputError& e) {
      PyErr_SetString(g_input_error, e.what());
    } catch (const isoloft::ParamError& e) {
      PyErr_SetString(g_param_error, e.what());
    } catch (const isoloft::Error& e) {
      PyErr_SetString(g_error, e.what());
    } catch (const nlohmann::json::exception& e) {
      PyErr_SetString(g_param_error, e.what());
    }
  });

  py::class_<PyInput, std::shared_ptr<PyInput>>(m, "Input", "Slice stacks read by isoloft.read() or made by isoloft.synth()")
      .def_property_readonly("format", [](const PyInput& i) { return to_string(i.in->format); })
      .def_property_readonly("files", [](const PyInput& i) { return i.in->files; })
      .def_property_readonly("kind", [](const PyInput& i) { return to_string(i.in->jobs.front().stack.kind); })
      .def_property_readonly("names", [](const PyInput& i) {
        std::vector<std::string> n;
        for (const auto& j : i.in->jobs) n.push_back(j.name);
        return n;
      }, "one per stack: the ROI name (RT Structure Sets), else ''")
      .def_property_readonly("slices", [](const PyInput& i) { return stack_images(i.in->jobs.front().stack); },
                             "(n, h, w) raw slice images of the first stack (None for polygons)")
      .def_property_readonly("polygons", [](const PyInput& i) { return stack_polygons(i.in->jobs.front().stack); },
                             "per slice, a list of (k, 2) x, y arrays (polygon inputs)")
      .def_property_readonly("slice_z", [](const PyInput& i) {
        std::vector<double> z;
        for (const auto& s : i.in->jobs.front().stack.slices) z.push_back(s.z);
        return py::array(py::cast(z));
      }, "z of every slice, working pixels")
      .def_property_readonly("pixel_size", [](const PyInput& i) { return i.in->jobs.front().stack.pixel_size; })
      .def_property_readonly("shape", [](const PyInput& i) {
        const auto& s = i.in->jobs.front().stack;
        return py::make_tuple(s.slices.size(), s.height, s.width);
      })
      .def_property_readonly("space", [](const PyInput& i) -> py::object {
        if (!i.in->jobs.front().stack.patient) return py::none();
        return py::str(i.in->ras ? "RAS" : "LPS");
      })
      .def_property_readonly("patient_axes", [](const PyInput& i) -> py::object {
        const auto& p = i.in->jobs.front().stack.patient;
        if (!p) return py::none();
        py::array_t<double> a({3, 3});
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) a.mutable_at(r, c) = p->axes(r, c);
        return a;
      }, "columns: LPS mm per working pixel along x, y, z (None without a patient frame)")
      .def_property_readonly("patient_origin", [](const PyInput& i) -> py::object {
        const auto& p = i.in->jobs.front().stack.patient;
        if (!p) return py::none();
        return py::array(py::cast(std::vector<double>{p->origin.x(), p->origin.y(), p->origin.z()}));
      })
      .def_property_readonly("annotated_slices", [](const PyInput& i) -> py::object {
        if (!i.in->slicing) return py::none();
        return py::cast(i.in->slicing->annotated);
      }, "volumes: voxel index of every slice along the annotated axis")
      .def_property_readonly("warnings", [](const PyInput& i) { return i.in->warnings; })
      .def_property_readonly("truth", [](const PyInput& i) -> py::object {
        return i.truth.is_null() ? py::object(py::none()) : to_python(i.truth);
      }, "synth(): the analytic shape and stack (as shape.json)")
      .def("__len__", [](const PyInput& i) { return i.in->jobs.front().stack.slices.size(); })
      .def("__repr__", [](const PyInput& i) {
        const auto& s = i.in->jobs.front().stack;
        return "<isoloft.Input " + to_string(i.in->format) + " " + to_string(s.kind) + ", " +
               std::to_string(i.in->jobs.size()) + " stack(s), " + std::to_string(s.slices.size()) + " slices of " +
               std::to_string(s.width) + "x" + std::to_string(s.height) + ">";
      });

  py::class_<PyObjectResult, std::shared_ptr<PyObjectResult>>(m, "Object", "One reconstructed closed surface")
      .def_property_readonly("label", [](const PyObjectResult& o) { return o.object().object.label; })
      .def_property_readonly("roi", [](const PyObjectResult& o) -> py::object {
        const std::string& n = o.data->in->jobs[o.object().job].name;
        return n.empty() ? py::object(py::none()) : py::str(n);
      })
      .def_property_readonly("colour", [](const PyObjectResult& o) {
        const Rgb c = o.object().colour;
        return py::make_tuple(c.r, c.g, c.b);
      })
      .def_readonly("vertices", &PyObjectResult::vertices,
                    "(N, 3) float64, read-only: patient mm (LPS/RAS) for volumes and RT Structure Sets, else pixels * pixel_size")
      .def_readonly("faces", &PyObjectResult::faces, "(M, 3) int32, read-only view of the C++ triangles (counter-clockwise from outside)")
      .def_property_readonly("report", [](const PyObjectResult& o) { return to_python(o.data->report["objects"][o.index]); })
      .def("save", [](const PyObjectResult& o, const py::object& path, bool ascii) {
        MeshWriteOptions mo = object_mesh_options(*o.data->in, o.object(), o.data->mesh_options);
        mo.ascii = ascii;
        const std::string p = py::str(py::module_::import("os").attr("fspath")(path));
        py::gil_scoped_release release;
        write_mesh(p, o.object().mesh, mo);
      }, py::arg("path"), py::arg("ascii") = false, "writes this mesh as the CLI would (.ply .obj .stl .off .vtp .vtk)")
      .def("__repr__", [](const PyObjectResult& o) {
        const auto& m = o.object().mesh;
        return "<isoloft.Object label " + std::to_string(o.object().object.label) + ": " +
               std::to_string(m.vertices.size()) + " vertices, " + std::to_string(m.triangles.size()) + " faces>";
      });

  py::class_<PyProgress>(m, "Progress", "One step of a reconstruct() run, given to its progress callback")
      .def_readonly("label", &PyProgress::label, "the object's label (0: the only object, or a label input's shared scan)")
      .def_property_readonly("roi", [](const PyProgress& p) -> py::object {
        return p.roi.empty() ? py::object(py::none()) : py::str(p.roi);
      }, "the ROI's name (RT Structure Sets), else None")
      .def_readonly("stage", &PyProgress::stage, "contour, mpu+distance, interpolate+mesh or decimate")
      .def_readonly("done", &PyProgress::done, "the object's steps done: only grows")
      .def_readonly("total", &PyProgress::total, "the object's steps known so far (all of them once its fit starts)")
      .def_readonly("stage_done", &PyProgress::stage_done)
      .def_readonly("stage_total", &PyProgress::stage_total)
      .def("__repr__", [](const PyProgress& p) {
        return "<isoloft.Progress " + (p.roi.empty() ? "label " + std::to_string(p.label) : "ROI '" + p.roi + "'") + " " +
               p.stage + " " + std::to_string(p.done) + "/" + std::to_string(p.total) + ">";
      });

  py::class_<PyResult>(m, "Result", "What isoloft.reconstruct() returns")
      .def_readonly("objects", &PyResult::objects)
      .def_property_readonly("report", [](const PyResult& r) { return to_python(r.data->report); },
                             "the CLI's --report as a dict")
      .def_property_readonly("warnings", [](const PyResult& r) { return r.data->run.warnings; })
      .def("save", [](PyResult& r, const py::object& path, bool ascii) {
        const std::string p = py::str(py::module_::import("os").attr("fspath")(path));
        MeshWriteOptions mo = r.data->mesh_options;
        mo.ascii = ascii;
        {
          py::gil_scoped_release release;
          write_run_meshes(p, *r.data->in, r.data->run, mo);
        }
        r.data->report["objects"] = objects_report(*r.data->in, r.data->run, r.data->method);
        std::vector<std::string> files;
        for (const auto& o : r.data->run.objects) files.push_back(o.file);
        if (several_outputs(*r.data->in, r.data->run)) files.push_back(p);
        return files;
      }, py::arg("path"), py::arg("ascii") = false,
         "writes the meshes as `isoloft reconstruct -o path` does; returns the files written")
      .def("__len__", [](const PyResult& r) { return r.data->run.objects.size(); })
      .def("__getitem__", [](const PyResult& r, py::ssize_t i) { return r.objects.attr("__getitem__")(i); });

  m.def("_from_arrays", &from_arrays, py::arg("slices"), py::arg("kind"), py::arg("z_spacing"), py::arg("slice_z"),
        py::arg("pixel_size"), py::arg("image_shape"), py::arg("binarize"));
  m.def("_from_volume", &from_volume, py::arg("data"), py::arg("spacing"), py::arg("origin"), py::arg("direction"),
        py::arg("integer"), py::arg("name"), py::arg("kind"), py::arg("axis"), py::arg("space"),
        py::arg("label_names") = "");
  m.attr("_DEFAULT_MAX_FILES") = kDefaultMaxFiles;
  m.def("_read", &read_input, py::arg("paths"), py::arg("kind"), py::arg("z_spacing"), py::arg("slice_z"),
        py::arg("pixel_size"), py::arg("axis"), py::arg("rois"), py::arg("voxel_size"), py::arg("space"),
        py::arg("max_memory"), py::arg("allow_external_data"), py::arg("label_names") = "");
  m.def("_reconstruct", [](const PyInput& input, const py::dict& params, const std::vector<std::uint32_t>& labels,
                           std::optional<int> threads, const py::object& progress, bool allow_empty,
                           const std::string& volume, const std::string& labelmap, const std::string& dump_stages,
                           const std::string& rtstruct, double rt_point_spacing, double rt_min_area,
                           const std::string& rt_contours, const std::string& volumes, const std::string& report,
                           const std::string& max_memory, const std::string& max_output, long max_files,
                           const std::string& reference) {
          return run(input, params, labels, threads, progress, allow_empty,
                     {volume, labelmap, dump_stages, rtstruct, volumes, report, reference,
                      RtContourParams{rt_point_spacing, rt_min_area}, rt_contours},
                     max_memory, max_output, max_files);
        }, py::arg("input"), py::arg("params"), py::arg("labels"), py::arg("threads"), py::arg("progress"),
        py::arg("allow_empty"), py::arg("volume"), py::arg("labelmap"), py::arg("dump_stages"), py::arg("rtstruct"),
        py::arg("rt_point_spacing"), py::arg("rt_min_area"), py::arg("rt_contours"), py::arg("volumes"), py::arg("report"), py::arg("max_memory"), py::arg("max_output"), py::arg("max_files"),
        py::arg("reference"));
  m.def("_synth", &synth, py::arg("shape"), py::arg("size"), py::arg("z_spacing"), py::arg("kind"));
  m.def("_evaluate", &evaluate, py::arg("mesh"), py::arg("truth"), py::arg("pixel_size"));
  m.def("shapes", &shape_names, "the analytic shapes isoloft.synth() makes");
  m.def("default_params", [] { return to_python(params_to_json(ReconstructParams{})); },
        "every reconstruction parameter with its default (as `isoloft reconstruct --print-params`)");
  m.def("describe_params", [] { return commented_json(params_table<ReconstructParams>(), ReconstructParams{}); },
        "the parameters as commented JSON, each with its unit, range and doc");
}
