// @file python/module_inputs.cpp
// @brief isoloft._isoloft: Python values and arrays into isoloft's inputs
// (JSON for the parameter tables, paths, slice stacks from arrays, image
// objects as volumes, files read as the CLI reads them).
#include <cmath>
#include <cstdio>
#include <limits>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/text.h"
#include "isoloft/io/volume.h"
#include "isoloft/methods/method.h"
#include "python/module.h"

namespace isoloft::python {

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

// A path argument (str or os.PathLike) as text. \throw ParamError naming `name`.
std::string checked_path(const py::object& path, const std::string& name) {
  if (!py::isinstance<py::str>(path) && !py::isinstance<py::bytes>(path) && !py::hasattr(path, "__fspath__"))
    throw ParamError(name + ": expected a path (str or os.PathLike), got " + std::string(py::str(py::repr(path))));
  const std::string p = py::str(py::module_::import("os").attr("fsdecode")(path));
  if (p.empty()) throw ParamError(name + ": empty path");
  if (p.find('\0') != std::string::npos) throw ParamError(name + ": the path holds a NUL byte");
  return p;
}

// ---------------------------------------------------------------- inputs



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

namespace {

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

}  // namespace

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

namespace {

/// A section's world points (N x 3) may leave its plane by this share of
/// their largest coordinate: float32 arrays round each coordinate by 6e-8 of
/// it, and a plane through them, rounded too, by as much again; 1e-5 leaves
/// room for coordinates computed in float32 and refuses a point a visible
/// share of the section off it.
constexpr double kSectionOffPlaneShare = 1e-5;
/// The pose's axes must be unit and orthogonal within this (float32 axes
/// are off by ~1e-7; a skewed pose would silently shear the drawing).
constexpr double kSectionAxesTolerance = 1e-6;

Vec3d vec3(const py::handle& o, const std::string& where) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(o);
  if (!a || a.ndim() != 1 || a.shape(0) != 3) throw InputError(where, "expected 3 numbers (x, y, z)");
  const Vec3d v(a.at(0), a.at(1), a.at(2));
  if (!v.allFinite()) throw InputError(where, "not finite");
  return v;
}

// One drawn contour {points: N x 2 in-plane or N x 3 world, label, hole} on `pose`.
SectionContour section_contour(const py::handle& o, const PlanePose& pose, const std::string& where) {
  if (!py::isinstance<py::dict>(o)) throw InputError(where, "expected a dict {points, label, hole}");
  const py::dict d = o.cast<py::dict>();
  for (auto [k, v] : d)
    if (const std::string key = py::str(k); key != "points" && key != "label" && key != "hole")
      throw InputError(where, "unknown key '" + key + "' (expected points, label, hole)");
  if (!d.contains("points")) throw InputError(where, "no 'points'");
  const auto p = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(d["points"]);
  if (!p || p.ndim() != 2 || (p.shape(1) != 2 && p.shape(1) != 3))
    throw InputError(where + ".points", "expected an N x 2 (in-plane) or N x 3 (world) array");
  if (p.shape(0) < 3) throw InputError(where + ".points", "a closed contour needs at least 3 points");
  SectionContour c;
  const bool world = p.shape(1) == 3;
  double reach = 0, off = 0;
  for (py::ssize_t k = 0; k < p.shape(0); ++k) {
    if (!world) {
      c.points.emplace_back(p.at(k, 0), p.at(k, 1));
      if (!c.points.back().allFinite()) throw InputError(where + ".points", "point " + std::to_string(k) + " is not finite");
      continue;
    }
    const Vec3d w(p.at(k, 0), p.at(k, 1), p.at(k, 2));
    if (!w.allFinite()) throw InputError(where + ".points", "point " + std::to_string(k) + " is not finite");
    reach = std::max(reach, w.cwiseAbs().maxCoeff());
    off = std::max(off, std::abs(pose.height(w)));
    c.points.push_back(pose.to_plane(w));
  }
  reach = std::max(reach, pose.origin.cwiseAbs().maxCoeff());
  if (world && off > kSectionOffPlaneShare * reach)
    throw InputError(where + ".points", "a point lies " + detail::shortest_text(off) +
                                            " off the section's plane (world points must lie on it)");
  if (d.contains("label")) {
    const py::object l = d["label"];
    if (!py::isinstance<py::int_>(l) || py::isinstance<py::bool_>(l) || l.cast<py::int_>() < py::int_(1) ||
        l.cast<py::int_>() > py::int_(std::numeric_limits<std::uint32_t>::max()))
      throw InputError(where + ".label", "expected an integer from 1 to 2^32 - 1 (0 is outside), got " +
                                             std::string(py::str(py::repr(l))));
    c.label = l.cast<std::uint32_t>();
  }
  if (d.contains("hole")) {
    if (!py::isinstance<py::bool_>(d["hole"])) throw InputError(where + ".hole", "expected True or False");
    c.hole = d["hole"].cast<bool>();
  }
  return c;
}

/// An affine's pixels must be square within this share (a Section has one
/// pixel size; float32 affines are off by ~1e-7 of a spacing).
constexpr double kSectionSquarePixelShare = 1e-6;

/// A label image on a section {image: (n_u, n_v) integers, image[a, b] the
/// pixel at origin + a pixel_size u + b pixel_size v} into `s` (pose set).
void section_image(const py::handle& o, Section& s, const std::string& where) {
  const py::array a = py::array::ensure(o);
  if (!a || a.ndim() != 2 || a.shape(0) < 1 || a.shape(1) < 1)
    throw InputError(where, "expected a 2D integer array (labels, 0 outside)");
  const char kind = a.dtype().kind();
  if (kind != 'u' && kind != 'i' && kind != 'b')
    throw InputError(where, "expected integer labels (0 outside), got dtype " + std::string(py::str(a.dtype())));
  const auto v = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
  const int nu = int(v.shape(0)), nv = int(v.shape(1));
  s.labels = Grid2u32(nu, nv, 0);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const std::int64_t l = v.at(i, j);
      if (l < 0 || l > std::int64_t(std::numeric_limits<std::uint32_t>::max()))
        throw InputError(where, "label " + std::to_string(l) + " at [" + std::to_string(i) + ", " + std::to_string(j) +
                                    "] is out of 0 .. 2^32 - 1");
      s.labels(i, j) = std::uint32_t(l);
    }
}

/// A 4 x 4 affine mapping (a, b, 0, 1), the image's indices, to world
/// points: the pose (origin, u, v) and the pixel size.
void section_affine(const py::handle& o, Section& s, const std::string& where) {
  const auto m = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(o);
  if (!m || m.ndim() != 2 || m.shape(0) != 4 || m.shape(1) != 4) throw InputError(where, "expected a 4 x 4 array");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(m.at(r, c))) throw InputError(where, "not finite");
  if (m.at(3, 0) != 0 || m.at(3, 1) != 0 || m.at(3, 2) != 0 || m.at(3, 3) != 1)
    throw InputError(where, "the last row must be 0 0 0 1");
  const Vec3d cu(m.at(0, 0), m.at(1, 0), m.at(2, 0)), cv(m.at(0, 1), m.at(1, 1), m.at(2, 1));
  const double su = cu.norm(), sv = cv.norm();
  if (!(su > 0) || !(sv > 0)) throw InputError(where, "a pixel axis (column 0 or 1) is zero");
  if (std::abs(su - sv) > kSectionSquarePixelShare * std::max(su, sv))
    throw InputError(where, "pixels must be square (spacing " + detail::shortest_text(su) + " along the first axis, " +
                                detail::shortest_text(sv) + " along the second)");
  s.pose.origin = Vec3d(m.at(0, 3), m.at(1, 3), m.at(2, 3));
  s.pose.u = cu / su;
  s.pose.v = cv / sv;
  s.pixel_size = su;
}

}  // namespace

PyInput from_sections(const py::object& sections) {
  if (!py::isinstance<py::sequence>(sections) || py::isinstance<py::str>(sections))
    throw InputError("sections", "expected a list of dicts {origin, u, v, contours}");
  std::vector<Section> out;
  std::size_t i = 0;
  for (const py::handle& o : sections.cast<py::sequence>()) {
    const std::string where = "sections[" + std::to_string(i++) + "]";
    if (!py::isinstance<py::dict>(o)) throw InputError(where, "expected a dict {origin, u, v, contours}");
    const py::dict d = o.cast<py::dict>();
    for (auto [k, v] : d)
      if (const std::string key = py::str(k); key != "origin" && key != "u" && key != "v" && key != "contours" &&
                                              key != "image" && key != "affine" && key != "pixel_size")
        throw InputError(where, "unknown key '" + key + "' (expected origin, u, v, contours; or image with affine, or "
                                "with origin, u, v, pixel_size)");
    Section s;
    s.source = where;
    const bool image = d.contains("image");
    if (image && d.contains("contours")) throw InputError(where, "give contours or an image, not both");
    if (image && d.contains("affine")) {
      for (const char* key : {"origin", "u", "v", "pixel_size"})
        if (d.contains(key)) throw InputError(where, std::string("'") + key + "' with 'affine' (the affine holds the pose)");
      section_affine(d["affine"], s, where + ".affine");
      section_image(d["image"], s, where + ".image");
      out.push_back(std::move(s));
      continue;
    }
    if (d.contains("affine")) throw InputError(where, "'affine' without 'image'");
    if (!image && d.contains("pixel_size")) throw InputError(where, "'pixel_size' without 'image'");
    for (const char* key : {"origin", "u", "v", image ? "pixel_size" : "contours"})
      if (!d.contains(key)) throw InputError(where, std::string("no '") + key + "'");
    s.pose.origin = vec3(d["origin"], where + ".origin");
    s.pose.u = vec3(d["u"], where + ".u");
    s.pose.v = vec3(d["v"], where + ".v");
    if (image) {
      const py::object ps = d["pixel_size"];
      if (!py::isinstance<py::float_>(ps) && !(py::isinstance<py::int_>(ps) && !py::isinstance<py::bool_>(ps)))
        throw InputError(where + ".pixel_size", "expected a number");
      s.pixel_size = ps.cast<double>();
      if (!(s.pixel_size > 0) || !std::isfinite(s.pixel_size))
        throw InputError(where + ".pixel_size", "must be positive and finite");
    }
    if (!s.pose.orthonormal(kSectionAxesTolerance))
      throw InputError(where, "u and v must be unit and orthogonal (|u| = " + detail::shortest_text(s.pose.u.norm()) +
                                  ", |v| = " + detail::shortest_text(s.pose.v.norm()) +
                                  ", u.v = " + detail::shortest_text(s.pose.u.dot(s.pose.v)) + ")");
    if (image) {
      section_image(d["image"], s, where + ".image");
      out.push_back(std::move(s));
      continue;
    }
    const py::handle cs = d["contours"];
    if (!py::isinstance<py::sequence>(cs) || py::isinstance<py::str>(cs))
      throw InputError(where + ".contours", "expected a list of dicts {points, label, hole}");
    std::size_t k = 0;
    for (const py::handle& c : cs.cast<py::sequence>())
      s.contours.push_back(section_contour(c, s.pose, where + ".contours[" + std::to_string(k++) + "]"));
    out.push_back(std::move(s));
  }
  if (out.empty()) throw InputError("sections", "the list is empty");
  const auto t0 = Clock::now();
  auto in = std::make_shared<Inputs>(sections_input(std::move(out), "sections"));
  return {in, {}, seconds_since(t0)};
}

PyInput read_input(const std::vector<std::string>& paths, const std::string& kind, std::optional<double> z_spacing,
                   std::optional<std::vector<double>> slice_z, std::optional<double> pixel_size, const std::string& axis,
                   const std::vector<std::string>& rois, std::optional<double> voxel_size, const std::string& space,
                   const std::string& max_memory, bool allow_external_data, const std::string& label_names,
                   const std::string& method) {
  InputRequest r;
  if (!method.empty()) {
    const MethodSpec& m = method_spec(method);  // an unknown name: the ParamError naming the known ones
    r.any_plane = m.reads_sections;
  }
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


}  // namespace isoloft::python
