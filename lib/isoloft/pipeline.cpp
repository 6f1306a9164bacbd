#include "isoloft/pipeline.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <sstream>
#include <set>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/rasterize.h"
#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"

namespace isoloft {

std::string to_string(Method m) { return m == Method::Levin ? "levin" : "marker2006"; }

Method method_from_string(const std::string& s) {
  if (s == "levin") return Method::Levin;
  if (s == "marker2006") return Method::Marker2006;
  throw ParamError("unknown method '" + s + "' (expected marker2006 or levin)");
}

std::string to_string(InputKind k) {
  switch (k) {
    case InputKind::Contours: return "contours";
    case InputKind::Masks: return "masks";
    case InputKind::Labels: return "labels";
  }
  return "?";
}

InputKind input_kind_from_string(const std::string& s) {
  for (auto k : {InputKind::Contours, InputKind::Masks, InputKind::Labels})
    if (s == to_string(k)) return k;
  throw ParamError("unknown input kind '" + s + "' (expected contours, masks or labels)");
}

namespace detail {

std::vector<std::uint32_t> distinct_labels(const SliceStack& stack) {
  std::set<std::uint32_t> seen;
  for (const auto& s : stack.slices)
    for (auto v : s.image.data)
      if (v) seen.insert(v);
  return {seen.begin(), seen.end()};
}

std::vector<double> sample_planes(double z_begin, double z_end, double step) {
  if (!(step > 0)) throw ParamError("interp.z_step must be positive");
  if (!(z_end > z_begin)) throw ParamError("sample_planes: empty z range");
  // Planes at z_begin + j * step, the last one moved onto z_end exactly when
  // it would fall short (the cap slices bound the volume).
  const long n = long(std::ceil((z_end - z_begin) / step - 1e-9));
  std::vector<double> z;
  z.reserve(std::size_t(n) + 1);
  for (long j = 0; j < n; ++j) z.push_back(z_begin + double(j) * step);
  z.push_back(z_end);
  return z;
}

}  // namespace detail

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct SliceMasks {
  Grid2u8 contour;  // contour pixels (1)
  Grid2u8 inside;   // interior or contour (1)
  bool empty = true;
};

// One-line error for a non-binary image in contours/masks mode.
void check_binary(const Slice& s, std::uint32_t max_value) {
  for (int y = 0; y < s.image.height; ++y)
    for (int x = 0; x < s.image.width; ++x) {
      const auto v = s.image(x, y);
      if (v != 0 && v != max_value)
        throw InputError(s.source, "not a binary image: value " + std::to_string(v) + " at pixel (" + std::to_string(x) + ", " +
                                       std::to_string(y) + ") is neither 0 nor " + std::to_string(max_value) +
                                       " (use --input labels for label images, or --binarize to threshold at half range)");
    }
}

SliceMasks slice_masks(const SliceStack& stack, const Slice& s, const ReconstructParams& p, std::uint32_t label, bool threshold_any,
                       std::vector<std::string>& warnings, std::mutex& warn_mutex) {
  SliceMasks m;
  if (stack.polylines) {
    rasterize_polygons(s.polygons, stack.width, stack.height, m.contour, m.inside);
  } else if (p.input == InputKind::Labels) {
    m.inside = Grid2u8(s.image.width, s.image.height, 0);
    for (std::size_t i = 0; i < s.image.size(); ++i) m.inside.data[i] = s.image.data[i] == label;
    m.contour = mask_boundary(m.inside);
  } else {
    if (!threshold_any) check_binary(s, stack.max_value);
    const Grid2u8 white = binarize(s.image, stack.max_value / 2);
    if (p.input == InputKind::Masks) {
      m.inside = white;
      m.contour = mask_boundary(white);
    } else {
      FillResult f;
      try {
        f = fill_even_odd(white, p.fill);
      } catch (const InputError& e) {
        throw InputError(s.source, e.problem);
      }
      for (const auto& o : f.open_contours) {
        std::lock_guard lock(warn_mutex);
        warnings.push_back(s.source + ": open contour with ends (" + std::to_string(o.x0) + ", " + std::to_string(o.y0) + ") and (" +
                           std::to_string(o.x1) + ", " + std::to_string(o.y1) + "), gap " + std::to_string(o.gap) + " px: " +
                           (o.repaired ? "closed by a straight segment" : "too wide to close, treated as a curve without inside"));
      }
      m.inside = std::move(f.inside);
      m.contour = std::move(f.contour);
    }
  }
  m.empty = std::none_of(m.inside.data.begin(), m.inside.data.end(), [](std::uint8_t v) { return v != 0; });
  return m;
}

template <class T>
Grid2<T> crop(const Grid2<T>& g, const PixelBox& b) {
  Grid2<T> out(b.width(), b.height());
  for (int y = b.y0; y < b.y1; ++y) std::copy_n(&g(b.x0, y), b.width(), &out(0, y - b.y0));
  return out;
}

PixelBox object_box(const std::vector<SliceMasks>& masks, int width, int height, int margin) {
  int x0 = width, y0 = height, x1 = -1, y1 = -1;
  for (const auto& m : masks) {
    if (m.empty) continue;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        if (m.inside(x, y) || m.contour(x, y)) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  }
  if (x1 < 0) return {};
  return {std::max(0, x0 - margin), std::max(0, y0 - margin), std::min(width, x1 + margin + 1), std::min(height, y1 + margin + 1)};
}

// Levin-style field: exact signed EDT at pixel centres (field/edt.h).
Grid2f levin_field(const SliceMasks& m, const PixelBox& b, InputKind input, bool polylines) {
  const Grid2u8 inside = crop(m.inside, b);
  if (input == InputKind::Contours || polylines) return distance_to_contour_signed(crop(m.contour, b), inside);
  return distance_to_mask_edge_signed(inside);
}

// marker2006 (paper 2.1-2.3): contour points + normals, MPU curve, narrow
// band of exact distances to its zero set, extension to the whole grid, filter.
// Fewer contour points than this cannot carry a conic fit (6 coefficients).
constexpr std::size_t kMinMpuPoints = 6;

struct MarkerSlice {
  bool fallback = false;  // fitted no curve (too few points): exact pixel distances instead
  long sign_guarded = 0;  // pixels whose MPU sign the sign guard overruled
  Grid2f field;
  double t_mpu = 0, t_dist = 0;
  MpuResult fit;
  OrientedPoints points;
  Grid2f mpu, distance;
};

MarkerSlice marker_distance(const SliceMasks& m, const Slice& s, const PixelBox& b, const ReconstructParams& p, bool polylines,
                            int stack_width, bool keep) {
  MarkerSlice r;
  auto t0 = Clock::now();
  // Polylines may be fitted on a finer raster (the paper's pelvis): working
  // coordinate x maps to X = k (x + 0.5) - 0.5 (pixel-centre convention at
  // both resolutions), and f is rescaled to working pixels. k = 1 otherwise.
  const bool fine = polylines && p.polyline_raster_width > 0;
  const double k = fine ? double(p.polyline_raster_width) / stack_width : 1.0;
  int fit_w = b.width(), fit_h = b.height();
  if (fine) {
    std::vector<Polygon> polys = s.polygons;
    for (auto& poly : polys)
      for (auto& q : poly.points) q = Vec2d(k * (q.x() - b.x0 + 0.5) - 0.5, k * (q.y() - b.y0 + 0.5) - 0.5);
    fit_w = int(std::ceil(k * b.width())), fit_h = int(std::ceil(k * b.height()));
    Grid2u8 contour, inside;
    rasterize_polygons(polys, fit_w, fit_h, contour, inside);
    r.points = contour_normals(contour, inside, p.normals);
  } else if (polylines) {
    std::vector<Polygon> shifted = s.polygons;
    for (auto& poly : shifted)
      for (auto& q : poly.points) q -= Vec2d(b.x0, b.y0);
    r.points = polygon_points(shifted, p.polyline_spacing);
  } else {
    r.points = contour_normals(crop(m.contour, b), crop(m.inside, b), p.normals);
    if (p.input != InputKind::Contours && p.mask_edge_offset != 0)
      for (std::size_t i = 0; i < r.points.size(); ++i) r.points.points[i] += p.mask_edge_offset * r.points.normals[i];
  }
  if (r.points.size() < kMinMpuPoints) {
    // Too few oriented points to fit a curve (e.g. a one-pixel island, whose
    // normal is undefined): the slice keeps its exact pixel distance field.
    r.field = levin_field(m, b, p.input, polylines);
    r.fallback = true;
    r.t_mpu = seconds_since(t0);
    if (keep) r.mpu = r.distance = r.field;
    return r;
  }
  MpuParams mp = p.mpu;
  mp.domain = Eigen::AlignedBox2d(Vec2d(-0.5, -0.5), Vec2d(fit_w - 0.5, fit_h - 0.5));
  r.fit = fit_mpu(r.points, mp);
  if (fine)  // report the points in working crop coordinates
    for (auto& q : r.points.points) q = (q + Vec2d(0.5, 0.5)) / k - Vec2d(0.5, 0.5);
  Grid2f f = evaluate_on_grid(r.fit.curve, b.width(), b.height(), 0.5 * (k - 1), 0.5 * (k - 1), k);
  if (fine)
    for (float& v : f.data) v = float(v / k);
  if (keep) r.mpu = f;  // the raw fit, before the sign guard
  if (p.sign_guard > 0) {
    // Far from every contour pixel the fill's inside/outside is exact; where
    // the fit disagrees there (a spurious zero crossing), the sample takes the
    // signed pixel distance instead, so no curve piece survives out there.
    const Grid2f trust = distance_to_contour_signed(crop(m.contour, b), crop(m.inside, b));
    for (std::size_t i = 0; i < f.size(); ++i)
      if (std::abs(trust.data[i]) > p.sign_guard && (f.data[i] > 0) != (trust.data[i] > 0)) {
        f.data[i] = trust.data[i];
        ++r.sign_guarded;
      }
  }
  r.t_mpu = seconds_since(t0);
  t0 = Clock::now();
  const MpuCurve& curve = r.fit.curve;
  const auto f_working = [&curve, k](const Vec2d& q) { return curve.value(k * (q + Vec2d(0.5, 0.5)) - Vec2d(0.5, 0.5)) / k; };
  const NarrowBandResult band = narrow_band_distance(f, f_working, p.band);
  r.field = extend_distance(band, p.extend);
  r.t_dist = seconds_since(t0);
  if (keep) r.distance = r.field;
  return r;
}

}  // namespace

namespace detail {

void fill_empty_slices(std::vector<Grid2f>& fields, const PixelBox& box, const InterpParams& interp) {
  // Empty slices (no inside) are all outside. One next to a non-empty slice
  // gets that neighbour's field lowered by (max + cap_depth) / cap_extent, so
  // the object closes between them like an end cap (interp/spline.h): a dome
  // reaching cap_extent of the gap at the contour's deepest point. With two
  // non-empty neighbours it takes the lower of the two. Empty slices with no
  // non-empty neighbour take the most negative value of the object's fields.
  float most_negative = -1.0f;
  for (const auto& f : fields)
    if (!f.empty()) most_negative = std::min(most_negative, *std::min_element(f.data.begin(), f.data.end()));
  std::vector<Grid2f> out(fields.size());
  for (std::size_t k = 0; k < fields.size(); ++k) {
    if (!fields[k].empty()) continue;
    Grid2f g;
    for (std::size_t nb : {k - 1, k + 1}) {
      if (nb >= fields.size() || fields[nb].empty()) continue;  // k - 1 wraps for k = 0
      const Grid2f& f = fields[nb];
      const float top = std::max(0.0f, *std::max_element(f.data.begin(), f.data.end()));
      const float drop = float((top + interp.cap_depth) / interp.cap_extent);
      if (g.empty()) {
        g = f;
        for (float& v : g.data) v -= drop;
      } else {
        for (std::size_t i = 0; i < g.size(); ++i) g.data[i] = std::min(g.data[i], f.data[i] - drop);
      }
    }
    out[k] = g.empty() ? Grid2f(box.width(), box.height(), most_negative) : std::move(g);
  }
  for (std::size_t k = 0; k < fields.size(); ++k)
    if (fields[k].empty()) fields[k] = std::move(out[k]);
}

}  // namespace detail

namespace {

// Pads a field by one pixel of `outside` on every side so the surface closes
// where an object is cut by the image border (within one pixel beyond it).
template <class T>
Grid2<T> pad(const Grid2<T>& g, T outside) {
  Grid2<T> out(g.width + 2, g.height + 2, outside);
  for (int y = 0; y < g.height; ++y) std::copy_n(&g(0, y), g.width, &out(1, y + 1));
  return out;
}

// Pixels count as keeping one side of iso over a knot interval only if both
// knot values are this far (pixels) beyond it: floats near 500 px are 6e-5 px
// apart, so the few roundings of a spline value (float knots and tangents,
// the float result) stay far below it; and it is far below a pixel.
constexpr float kSideMargin = 1e-2f;

void validate(const SliceStack& stack) {
  if (stack.slices.empty()) throw InputError("", "no slices");
  if (stack.slices.size() < 2)
    throw InputError(stack.slices.front().source, "only one slice; a reconstruction needs at least 2 slices");
  for (std::size_t k = 1; k < stack.slices.size(); ++k)
    if (!(stack.slices[k].z > stack.slices[k - 1].z))
      throw InputError(stack.slices[k].source, "slice z must increase strictly (z = " + std::to_string(stack.slices[k].z) +
                                                   " after " + std::to_string(stack.slices[k - 1].z) + ")");
  if (stack.width < 1 || stack.height < 1) throw InputError("", "empty slice images");
}

}  // namespace

ReconstructResult reconstruct(const SliceStack& stack, const ReconstructParams& params, const ReconstructOptions& options) {
  validate(stack);
  if (params.crop_margin < 1) throw ParamError("crop_margin must be at least 1");
  if (params.polyline_raster_width < 0) throw ParamError("polyline_raster_width must be >= 0");
  if (!(params.sign_guard >= 0)) throw ParamError("sign_guard must be >= 0");
  ReconstructResult result;
  std::mutex warn_mutex;
  const std::size_t n = stack.slices.size();
  const bool threshold_any = params.binarize;

  std::vector<std::uint32_t> labels{0};
  if (params.input == InputKind::Labels && !stack.polylines) {
    labels = detail::distinct_labels(stack);
    if (!options.labels.empty()) {
      std::vector<std::uint32_t> keep;
      for (auto l : options.labels) {
        if (!std::binary_search(labels.begin(), labels.end(), l))
          result.warnings.push_back("label " + std::to_string(l) + " does not occur in any slice");
        else
          keep.push_back(l);
      }
      labels = keep;
    }
    if (labels.empty()) result.warnings.push_back("no labels to reconstruct (every slice is 0)");
  }

  auto report = [&](const std::string& stage, long done, long total) {
    if (options.progress) options.progress(stage, done, total);
  };

  for (const std::uint32_t label : labels) {
    ObjectResult obj;
    obj.label = label;
    const std::string what = label ? "label " + std::to_string(label) : "object";

    // Stage: contour pixels and even-odd inside (paper 2.1).
    auto t0 = Clock::now();
    std::vector<SliceMasks> masks(n);
    std::atomic<long> done{0};
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
      masks[k] = slice_masks(stack, stack.slices[k], params, label, threshold_any, result.warnings, warn_mutex);
      report("contour", ++done, long(n));
    });
    obj.slices_with_contours = int(std::count_if(masks.begin(), masks.end(), [](const SliceMasks& m) { return !m.empty; }));
    obj.box = object_box(masks, stack.width, stack.height, params.crop_margin);
    result.times.contour += seconds_since(t0);
    if (obj.slices_with_contours == 0) {
      result.warnings.push_back(what + ": no slice has an inside; nothing to reconstruct");
      continue;
    }

    std::vector<Grid2f> fields(n);
    done = 0;
    if (params.method == Method::Levin) {
      // Stage: exact signed EDT per slice (Levin-style baseline).
      t0 = Clock::now();
      tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
        if (!masks[k].empty) fields[k] = levin_field(masks[k], obj.box, params.input, stack.polylines);
        masks[k] = SliceMasks{};  // release
        report("distance", ++done, long(n));
      });
      result.times.dist += seconds_since(t0);
    } else {
      // Stages: MPU fit (paper 2.1) and distance field (paper 2.2), per slice in
      // parallel; their wall times are split by each slice's share of CPU time.
      t0 = Clock::now();
      std::vector<MarkerSlice> ms(n);
      const bool keep = bool(options.on_slice_fields);
      tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
        if (!masks[k].empty) ms[k] = marker_distance(masks[k], stack.slices[k], obj.box, params, stack.polylines, stack.width, keep);
        masks[k] = SliceMasks{};
        report("mpu+distance", ++done, long(n));
      });
      const double wall = seconds_since(t0);
      double cpu_mpu = 0, cpu_dist = 0;
      for (std::size_t k = 0; k < n; ++k) {
        cpu_mpu += ms[k].t_mpu;
        cpu_dist += ms[k].t_dist;
        obj.fit.points += long(ms[k].points.size());
        if (ms[k].fallback) {
          ++obj.fit.fallback_slices;
          std::lock_guard lock(warn_mutex);
          result.warnings.push_back(stack.slices[k].source + ": " + what + " has fewer than " + std::to_string(kMinMpuPoints) +
                                    " contour points with a defined normal; this slice uses exact pixel distances instead of an MPU curve");
        }
        obj.fit.sign_guarded_pixels += ms[k].sign_guarded;
        obj.fit.sign_guarded_slices += ms[k].sign_guarded > 0;
        obj.fit.leaves += ms[k].fit.leaves;
        obj.fit.leaves_over_tol += ms[k].fit.leaves_over_tol;
        obj.fit.max_depth_reached = std::max(obj.fit.max_depth_reached, ms[k].fit.max_depth_reached);
        obj.fit.max_local_error = std::max(obj.fit.max_local_error, ms[k].fit.max_local_error);
        fields[k] = std::move(ms[k].field);
      }
      if (obj.fit.sign_guarded_pixels > 0)
        result.warnings.push_back(what + ": the MPU fit was positive/negative against the contour fill on " +
                                  std::to_string(obj.fit.sign_guarded_pixels) + " pixels farther than " +
                                  [&] {
                                    std::ostringstream o;
                                    o << params.sign_guard;
                                    return o.str();
                                  }() + " px from the contour, in " +
                                  std::to_string(obj.fit.sign_guarded_slices) +
                                  " slice(s) (spurious zero crossings of the fit, e.g. on thin features); those pixels keep the fill's sign");
      const double share = cpu_mpu + cpu_dist > 0 ? cpu_mpu / (cpu_mpu + cpu_dist) : 0.5;
      result.times.mpu += wall * share;
      result.times.dist += wall * (1 - share);

      // Stage: distance-dependent Gaussian filter (paper 2.3).
      t0 = Clock::now();
      done = 0;
      tbb::parallel_for(std::size_t(0), n, [&](std::size_t k) {
        if (fields[k].empty() || !params.filter.enabled) return;
        fields[k] = distance_filter(fields[k], params.filter);
        report("filter", ++done, long(n));
      });
      result.times.filter += seconds_since(t0);
      if (keep)
        for (std::size_t k = 0; k < n; ++k) {
          if (fields[k].empty()) continue;
          SliceStageFields sf{label, int(k), obj.box, std::move(ms[k].points), std::move(ms[k].mpu), std::move(ms[k].distance), fields[k]};
          options.on_slice_fields(sf);
        }
    }
    t0 = Clock::now();
    detail::fill_empty_slices(fields, obj.box, params.interp);
    result.times.dist += seconds_since(t0);

    // Stage: z splines with end caps (paper 2.4), streamed into Marching Cubes (paper 2.5).
    t0 = Clock::now();
    std::vector<double> z(n);
    for (std::size_t k = 0; k < n; ++k) z[k] = stack.slices[k].z;
    add_end_caps(fields, z, params.interp);
    {  // the slices, their tangents and the Marching Cubes state are freed before decimation
      const ZInterpolator interp(std::move(fields), z, params.interp.spline);
      const std::vector<double> planes = detail::sample_planes(z.front(), z.back(), params.interp.z_step);
      result.times.interp += seconds_since(t0);

      MarchingCubes mc(obj.box.width() + 2, obj.box.height() + 2, obj.box.x0 - 1.0, obj.box.y0 - 1.0, params.mc);
      Grid2f plane;
      const float outside = -float(params.interp.cap_depth);
      double t_interp = 0, t_mesh = 0;
      // Marching Cubes skips the cells that cannot hold the surface
      // (layer_cells_to_visit); the sides of the last two knot intervals are kept.
      const float iso = params.mc.iso;
      const std::int8_t outside_side = outside > iso + kSideMargin ? 1 : outside < iso - kSideMargin ? -1 : 0;
      constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
      std::array<std::size_t, 2> sides_of{kNone, kNone};  // the interval in each slot (k % 2)
      std::array<Grid2<std::int8_t>, 2> sides;
      Grid2<std::int8_t> knot_sides;
      auto sides_for = [&](std::size_t k) -> const Grid2<std::int8_t>& {
        if (sides_of[k % 2] != k) {
          interp.sides(k, iso, kSideMargin, knot_sides);
          sides[k % 2] = pad(knot_sides, outside_side);
          sides_of[k % 2] = k;
        }
        return sides[k % 2];
      };
      std::vector<std::uint8_t> active;
      std::array<std::size_t, 2> active_for{kNone, kNone};
      std::size_t k_prev = kNone;
      for (std::size_t j = 0; j < planes.size(); ++j) {
        auto ta = Clock::now();
        interp.evaluate(planes[j], plane);
        Grid2f padded = pad(plane, outside);
        t_interp += seconds_since(ta);
        if (options.on_plane)
          options.on_plane(label, padded, obj.box.x0 - 1.0, obj.box.y0 - 1.0, planes[j], int(j), int(planes.size()));
        ta = Clock::now();
        const std::size_t k = interp.interval(planes[j]);
        const bool skip = j > 0 && k - k_prev <= 1;  // planes in one or two adjacent intervals
        if (skip && active_for != std::array<std::size_t, 2>{k_prev, k}) {
          const Grid2<std::int8_t>& a = sides_for(k_prev);
          layer_cells_to_visit(a, sides_for(k), active);  // k_prev and k use different slots, or are equal
          active_for = {k_prev, k};
        }
        mc.add_plane(std::move(padded), planes[j], skip ? &active : nullptr);
        k_prev = k;
        t_mesh += seconds_since(ta);
        report("interpolate+mesh", long(j + 1), long(planes.size()));
      }
      auto ta = Clock::now();
      obj.mesh = mc.finish();
      t_mesh += seconds_since(ta);
      result.times.interp += t_interp;
      result.times.mesh += t_mesh;
    }

    // Stage: quadric error decimation (paper 2.5).
    t0 = Clock::now();
    obj.triangles_before_decimation = long(obj.mesh.triangles.size());
    if (params.decimate.max_error > 0) {
      report("decimate", 0, 1);
      decimate(obj.mesh, params.decimate);
      report("decimate", 1, 1);
    }
    result.times.decimate += seconds_since(t0);
    obj.check = check_mesh(obj.mesh);
    if (!obj.check.closed || !obj.check.manifold || !obj.check.oriented)
      result.warnings.push_back(what + ": mesh is not a closed oriented manifold (boundary edges " +
                                std::to_string(obj.check.boundary_edges) + ", non-manifold edges " +
                                std::to_string(obj.check.nonmanifold_edges) + ")");
    result.objects.push_back(std::move(obj));
  }
  return result;
}

}  // namespace isoloft
