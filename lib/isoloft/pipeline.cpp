#include "isoloft/pipeline.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <set>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/mesh/stream_mesher.h"
#include "isoloft/pipeline/slice_fields.h"

namespace isoloft {

template <>
const ParamTable<ReconstructParams>& params_table<ReconstructParams>() {
  static const ParamTable<ReconstructParams> table = [] {
    using P = ReconstructParams;
    ParamTable<P>::Rows rows{
        field("method", &P::method, "",
              "isoloft (marker2006 with measured departures, docs/decisions.md), marker2006 (the paper) or levin "
              "(per-slice exact EDT baseline, no fit, no filter); picks the defaults of the other keys")
            .cli("--method"),
        field("binarize", &P::binarize, "",
              "threshold non-binary contour/mask images at half range instead of rejecting them")
            .cli("--binarize"),
        field("mask_edge_offset", &P::mask_edge_offset, "px",
              "marker2006, masks/labels: contour points move this far out along their normals, from the boundary pixel "
              "centres (paper 2.1) onto the mask's edge",
              between(-2, 2)),
        field("polyline_spacing", &P::polyline_spacing, "px",
              "marker2006, polylines: spacing of the contour points sampled along every polygon edge", between(0.01, 100)),
        field("polyline_raster_width", &P::polyline_raster_width, "px",
              "marker2006, polylines: fit on a raster this many pixels across, as the paper's pelvis (2000); 0 = fit the "
              "polygons directly",
              between(0, kMaxPolylineRaster))
            .cli("--raster-resolution"),
        field("sign_guard", &P::sign_guard, "px",
              "marker2006: pixels farther than this from every contour pixel keep the contour fill's inside/outside where "
              "the MPU sign disagrees (not in the paper); 0 = the pure MPU sign",
              at_least(0))
            .cli("--sign-guard"),
        field("mpu_band", &P::mpu_band, "px",
              "marker2006: the MPU curve is fitted and evaluated only within this distance of a contour pixel, where "
              "the narrow band needs it (paper 2.2); beyond it only the sign is needed and the contour fill gives it; 0 "
              "= fit and evaluate the whole crop box",
              Range{0.0, 1e4, false, false})
            .cli("--mpu-band"),
        field("mask_min_feature", &P::mask_min_feature, "px",
              "marker2006, masks/labels: mask features (lines, spurs, islands; notches, holes, gaps) narrower than this "
              "are removed before the contour points are taken, by an opening and a closing with a square of this side "
              "(not in the paper); 1 = the mask as it is",
              between(1, 16)),
        field("crop_margin", &P::crop_margin, "px",
              "each object is processed in the bounding box of its contours plus this margin (room for the filter's "
              "stencils)",
              at_least(1)),
    };
    std::vector<ParamTable<P>::Check> checks{[](const P& p, const std::string& at) {
      if (p.mpu_band > 0 && p.mpu_band < kMinMpuBand)
        throw ParamError(at + "mpu_band: must be 0 (the whole crop box) or at least " + std::to_string(kMinMpuBand) +
                         " px, got " + std::to_string(p.mpu_band));
      if (!(-p.interp.cap_depth <= double(p.mc.iso)))
        throw ParamError(at + "mc.iso: must be above -interp.cap_depth (" + std::to_string(-p.interp.cap_depth) +
                         ", the value outside the end caps), got " + std::to_string(p.mc.iso));
    }};
    ParamTable<P>::nest(rows, checks, "fill", &P::fill, params_table<FillParams>());
    ParamTable<P>::nest(rows, checks, "normals", &P::normals, params_table<NormalsParams>());
    ParamTable<P>::nest(rows, checks, "mpu", &P::mpu, params_table<MpuParams>());
    ParamTable<P>::nest(rows, checks, "band", &P::band, params_table<NarrowBandParams>());
    ParamTable<P>::nest(rows, checks, "extend", &P::extend, params_table<ExtendParams>());
    ParamTable<P>::nest(rows, checks, "filter", &P::filter, params_table<FilterParams>());
    ParamTable<P>::nest(rows, checks, "interp", &P::interp, params_table<InterpParams>());
    ParamTable<P>::nest(rows, checks, "mc", &P::mc, params_table<MarchingCubesParams>());
    ParamTable<P>::nest(rows, checks, "decimate", &P::decimate, params_table<DecimateParams>());
    return ParamTable<P>(std::move(rows), std::move(checks));
  }();
  return table;
}

nlohmann::json params_to_json(const ReconstructParams& p) { return params_table<ReconstructParams>().to_json(p); }

ReconstructParams params_from_json(const nlohmann::json& j, const ReconstructParams& base) {
  return params_table<ReconstructParams>().from_json(j, base);
}

ReconstructParams method_defaults(Method m) {
  ReconstructParams p;
  p.method = m;
  if (m != Method::Isoloft) p.interp.spline = InterpParams{}.spline;
  return p;
}

ReconstructParams params_from_json(const nlohmann::json& j, std::optional<Method> method) {
  if (!method && j.is_object() && j.contains("method"))
    method = params_table<ReconstructParams>().from_json({{"method", j["method"]}}).method;
  ReconstructParams p = params_from_json(j, method_defaults(method.value_or(ReconstructParams{}.method)));
  if (method) p.method = *method;
  return p;
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

using detail::MarkerSlice;
using detail::SliceMasks;

// What every stage of one reconstruct() call shares.
struct Run {
  const SliceStack& stack;
  const ReconstructParams& params;
  const ReconstructOptions& options;
  ReconstructResult& result;

  [[nodiscard]] std::size_t slices() const { return stack.slices.size(); }
  void progress(const char* stage, long done, long total) const {
    if (options.progress) options.progress(stage, done, total);
  }
  void warn(std::string w) const { result.warnings.push_back(std::move(w)); }
};

// f(k) for every slice k in parallel, reporting progress as `stage`.
template <class F>
void for_each_slice(const Run& run, const char* stage, F&& f) {
  std::atomic<long> done{0};
  const long n = long(run.slices());
  tbb::parallel_for(std::size_t(0), run.slices(), [&](std::size_t k) {
    f(k);
    run.progress(stage, ++done, n);
  });
}

void check_stack(const SliceStack& stack) {
  if (stack.slices.empty()) throw InputError("", "no slices");
  if (stack.slices.size() < 2)
    throw InputError(stack.slices.front().source, "only one slice; a reconstruction needs at least 2 slices");
  for (std::size_t k = 1; k < stack.slices.size(); ++k)
    if (!(stack.slices[k].z > stack.slices[k - 1].z))
      throw InputError(stack.slices[k].source, "slice z must increase strictly (z = " + std::to_string(stack.slices[k].z) +
                                                   " after " + std::to_string(stack.slices[k - 1].z) + ")");
  if (stack.width < 1 || stack.height < 1) throw InputError("", "empty slice images");
}

std::string object_name(std::uint32_t label) { return label ? "label " + std::to_string(label) : "object"; }

// The objects: one (label 0), or each label of a label stack (those asked for).
std::vector<std::uint32_t> objects_to_reconstruct(const Run& run) {
  const std::vector<std::uint32_t>& asked = run.options.labels;
  if (run.stack.kind != InputKind::Labels) {
    if (!asked.empty()) throw ParamError("labels: a label selection needs labels input (InputKind::Labels)");
    return {0};
  }
  std::set<std::uint32_t> seen;
  for (const auto& s : run.stack.slices)
    for (auto v : s.image.data)
      if (v) seen.insert(v);
  std::vector<std::uint32_t> labels(seen.begin(), seen.end());
  if (!asked.empty()) {
    std::vector<std::uint32_t> keep;
    for (auto l : asked) {
      if (seen.count(l)) keep.push_back(l);
      else run.warn("label " + std::to_string(l) + " does not occur in any slice");
    }
    labels = std::move(keep);
  }
  if (labels.empty()) run.warn("no labels to reconstruct (every slice is 0)");
  return labels;
}

// Stage (paper 2.1): contour pixels and inside of every slice.
std::vector<SliceMasks> contour_stage(const Run& run, std::uint32_t label) {
  std::vector<SliceMasks> masks(run.slices());
  for_each_slice(run, "contour", [&](std::size_t k) {
    masks[k] = detail::slice_masks(run.stack, run.stack.slices[k], run.params, label);
  });
  for (auto& m : masks)
    for (auto& w : m.warnings) run.warn(std::move(w));
  return masks;
}

// Stage (Levin baseline): exact signed EDT per slice.
std::vector<Grid2f> levin_stage(const Run& run, std::vector<SliceMasks>& masks, const PixelBox& box) {
  std::vector<Grid2f> fields(run.slices());
  for_each_slice(run, "distance", [&](std::size_t k) {
    if (!masks[k].empty) fields[k] = detail::levin_field(masks[k], box, run.stack.kind);
    masks[k] = SliceMasks{};  // release
  });
  return fields;
}

// Stages (paper 2.1-2.2): MPU curve and its distance field, per slice.
std::vector<MarkerSlice> fit_stage(const Run& run, std::vector<SliceMasks>& masks, const PixelBox& box) {
  std::vector<MarkerSlice> out(run.slices());
  const bool keep = bool(run.options.on_slice_fields);
  for_each_slice(run, "mpu+distance", [&](std::size_t k) {
    if (!masks[k].empty)
      out[k] = detail::marker_slice(masks[k], run.stack.slices[k], box, run.params, run.stack.kind, run.stack.width, keep);
    masks[k] = SliceMasks{};  // release
  });
  return out;
}

void add_fit_stats(FitStats& s, const MarkerSlice& m) {
  s.points += long(m.points.size());
  s.fallback_slices += m.fallback;
  s.sign_guarded_pixels += m.sign_guarded;
  s.sign_guarded_slices += m.sign_guarded > 0;
  s.leaves += m.fit.leaves;
  s.leaves_over_tol += m.fit.leaves_over_tol;
  s.max_depth_reached = std::max(s.max_depth_reached, m.fit.max_depth_reached);
  s.max_local_error = std::max(s.max_local_error, m.fit.max_local_error);
}

void warn_fit(const Run& run, const std::vector<MarkerSlice>& slices, const FitStats& fit, const std::string& what) {
  for (std::size_t k = 0; k < slices.size(); ++k)
    if (slices[k].fallback)
      run.warn(run.stack.slices[k].source + ": " + what + " has fewer than " + std::to_string(detail::kMinMpuPoints) +
               " contour points with a defined normal; this slice uses exact pixel distances instead of an MPU curve");
  if (fit.sign_guarded_pixels == 0) return;
  std::ostringstream guard;
  guard << run.params.sign_guard;
  run.warn(what + ": the MPU fit was positive/negative against the contour fill on " +
           std::to_string(fit.sign_guarded_pixels) + " pixels farther than " + guard.str() + " px from the contour, in " +
           std::to_string(fit.sign_guarded_slices) +
           " slice(s) (spurious zero crossings of the fit, e.g. on thin features); those pixels keep the fill's sign");
}

// Stage (paper 2.3): the distance-dependent Gaussian filter of every field.
void filter_stage(const Run& run, std::vector<Grid2f>& fields) {
  if (!run.params.filter.enabled) return;
  for_each_slice(run, "filter", [&](std::size_t k) {
    if (!fields[k].empty()) fields[k] = distance_filter(fields[k], run.params.filter);
  });
}

// marker2006 (paper 2.1-2.3): fit, distance, filter; the MPU and distance
// wall times are split by each stage's share of the CPU time.
std::vector<Grid2f> marker_stages(const Run& run, std::vector<SliceMasks>& masks, ObjectResult& obj) {
  auto t0 = Clock::now();
  std::vector<MarkerSlice> slices = fit_stage(run, masks, obj.box);
  const double wall = seconds_since(t0);
  double cpu_mpu = 0, cpu_dist = 0;
  std::vector<Grid2f> fields(run.slices());
  for (std::size_t k = 0; k < slices.size(); ++k) {
    cpu_mpu += slices[k].t_mpu;
    cpu_dist += slices[k].t_dist;
    add_fit_stats(obj.fit, slices[k]);
    fields[k] = std::move(slices[k].field);
  }
  warn_fit(run, slices, obj.fit, object_name(obj.label));
  const double share = cpu_mpu + cpu_dist > 0 ? cpu_mpu / (cpu_mpu + cpu_dist) : 0.5;
  run.result.times.mpu += wall * share;
  run.result.times.dist += wall * (1 - share);

  t0 = Clock::now();
  filter_stage(run, fields);
  run.result.times.filter += seconds_since(t0);
  if (run.options.on_slice_fields)
    for (std::size_t k = 0; k < fields.size(); ++k) {
      if (fields[k].empty()) continue;
      MarkerSlice& m = slices[k];
      run.options.on_slice_fields(SliceStageFields{obj.label, int(k), obj.box, std::move(m.points), std::move(m.mpu),
                                                   std::move(m.distance), fields[k]});
    }
  return fields;
}

// Stages (paper 2.4-2.5): z splines with end caps, streamed into Marching Cubes.
TriMesh mesh_stage(const Run& run, std::vector<Grid2f> fields, const ObjectResult& obj) {
  const ReconstructParams& p = run.params;
  auto t0 = Clock::now();
  std::vector<double> z(run.slices());
  for (std::size_t k = 0; k < z.size(); ++k) z[k] = run.stack.slices[k].z;
  add_end_caps(fields, z, p.interp);
  const ZInterpolator field(std::move(fields), z, p.interp.spline);
  const std::vector<double> planes = sample_planes(z.front(), z.back(), p.interp.z_step);
  if (run.options.on_sample) {
    Grid2f sampled;
    for (const double zs : run.options.sample_z) {
      if (zs < z.front() || zs > z.back()) continue;
      field.evaluate(zs, sampled);
      run.options.on_sample(obj.label, sampled, obj.box, zs);
    }
  }
  run.result.times.interp += seconds_since(t0);

  StreamMeshOptions o;
  o.outside = -float(p.interp.cap_depth);
  if (run.options.on_plane)
    o.on_plane = [&](const Grid2f& plane, double x0, double y0, double zz, int index, int count) {
      run.options.on_plane(obj.label, plane, x0, y0, zz, index, count);
    };
  o.progress = [&](long done, long total) { run.progress("interpolate+mesh", done, total); };
  StreamMeshResult r = mesh_interpolated_field(field, planes, obj.box.x0, obj.box.y0, p.mc, o);
  run.result.times.interp += r.interp_seconds;
  run.result.times.mesh += r.mesh_seconds;
  return std::move(r.mesh);
}

// Stage (paper 2.5): bounded quadric error decimation.
void decimate_stage(const Run& run, ObjectResult& obj) {
  const auto t0 = Clock::now();
  obj.triangles_before_decimation = long(obj.mesh.triangles.size());
  if (run.params.decimate.max_error > 0) {
    run.progress("decimate", 0, 1);
    decimate(obj.mesh, run.params.decimate);
    run.progress("decimate", 1, 1);
  }
  run.result.times.decimate += seconds_since(t0);
}

void check_stage(const Run& run, ObjectResult& obj) {
  obj.check = check_mesh(obj.mesh);
  if (!obj.check.closed || !obj.check.manifold || !obj.check.oriented)
    run.warn(object_name(obj.label) + ": mesh is not a closed oriented manifold (boundary edges " +
             std::to_string(obj.check.boundary_edges) + ", non-manifold edges " +
             std::to_string(obj.check.nonmanifold_edges) + ")");
}

}  // namespace

ReconstructResult reconstruct(const SliceStack& stack, const ReconstructParams& params, const ReconstructOptions& options) {
  check_stack(stack);
  params_table<ReconstructParams>().validate(params);
  ReconstructResult result;
  const Run run{stack, params, options, result};
  for (const std::uint32_t label : objects_to_reconstruct(run)) {
    ObjectResult obj;
    obj.label = label;
    auto t0 = Clock::now();
    std::vector<SliceMasks> masks = contour_stage(run, label);
    obj.slices_with_contours = int(std::count_if(masks.begin(), masks.end(), [](const SliceMasks& m) { return !m.empty; }));
    obj.box = detail::object_box(masks, stack.width, stack.height, params.crop_margin);
    result.times.contour += seconds_since(t0);
    if (obj.slices_with_contours == 0) {
      run.warn(object_name(label) + ": no slice has an inside; nothing to reconstruct");
      continue;
    }
    std::vector<Grid2f> fields;
    if (params.method == Method::Levin) {
      t0 = Clock::now();
      fields = levin_stage(run, masks, obj.box);
      result.times.dist += seconds_since(t0);
    } else {
      fields = marker_stages(run, masks, obj);
    }
    t0 = Clock::now();
    detail::fill_empty_slices(fields, obj.box, params.interp);
    result.times.dist += seconds_since(t0);
    obj.mesh = mesh_stage(run, std::move(fields), obj);
    decimate_stage(run, obj);
    check_stage(run, obj);
    result.objects.push_back(std::move(obj));
  }
  return result;
}

}  // namespace isoloft
