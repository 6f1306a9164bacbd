#include "isoloft/pipeline.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <exception>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/interp/z_stream.h"
#include "isoloft/methods/method.h"
#include "isoloft/mesh/stream_mesher.h"
#include "isoloft/pipeline/slice_fields.h"

namespace isoloft {

namespace {
// The method and z scheme rows' docs: each registered one's own line.
template <class Spec>
std::string registry_doc(const std::vector<Spec>& specs, const std::string& what) {
  std::string doc;
  for (const Spec& s : specs) doc += (doc.empty() ? "" : "; ") + s.name + ": " + s.doc;
  return doc + "; " + what;
}
std::string method_doc() { return registry_doc(methods(), "picks the defaults of the other keys"); }
std::string z_scheme_doc() { return registry_doc(z_schemes(), "how the slice fields are interpolated in z (paper 2.4)"); }
}  // namespace

const Method Method::Isoloft{"isoloft"};
const Method Method::Marker2006{"marker2006"};
const Method Method::Levin{"levin"};

template <>
const ParamTable<ReconstructParams>& params_table<ReconstructParams>() {
  static const ParamTable<ReconstructParams> table = [] {
    using P = ReconstructParams;
    ParamTable<P>::Rows rows{
        name_field("method", &P::method, method_doc(), method_names()).cli("--method"),
        name_field("z_scheme", &P::z_scheme, z_scheme_doc(), z_scheme_names()).cli("--z-scheme"),
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
    ParamTable<P>::nest(rows, checks, "track", &P::track, params_table<TrackParams>());
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

bool fits_curves(const Method& m) { return method_spec(m.name()).fits_curves; }

ReconstructParams method_defaults(const Method& m) {
  ReconstructParams p;
  method_spec(m.name()).defaults(p);
  p.method = m;
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

// f(slice k) with k's image: the stack's own, or decoded now (lazy stacks).
template <class F>
auto with_slice(const SliceStack& stack, std::size_t k, F&& f) {
  if (!stack.load_image) return f(stack.slices[k]);
  Slice s = stack.slices[k];
  s.image = stack.load_image(k);
  return f(std::as_const(s));
}

// f(k) for the slices [k0, k1) in parallel, reported as `stage` of `total`;
// the first failing slice in order is rethrown, independent of thread timing.
template <class F>
void for_slices(const Run& run, std::size_t k0, std::size_t k1, const char* stage, std::atomic<long>& done, F&& f) {
  std::vector<std::exception_ptr> errors(k1 - k0);
  const long n = long(run.slices());
  tbb::parallel_for(k0, k1, [&](std::size_t k) {
    try {
      f(k);
    } catch (...) {
      errors[k - k0] = std::current_exception();
    }
    run.progress(stage, ++done, n);
  });
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
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

// A label stack's masks (paper 2.1) for every label at once: each slice
// decoded and scanned once (detail::label_masks), not once per label.
struct LabelStackMasks {
  struct Object {
    std::vector<detail::PackedMasks> masks;  // per slice
    std::vector<PixelBox> bounds;
  };
  std::map<std::uint32_t, Object> objects;
};

LabelStackMasks label_stack_masks(const Run& run) {
  const std::size_t n = run.slices();
  std::vector<std::vector<detail::LabelMasks>> per_slice(n);
  std::atomic<long> done{0};
  for_slices(run, 0, n, "contour", done, [&](std::size_t k) {
    with_slice(run.stack, k, [&](const Slice& s) { per_slice[k] = detail::label_masks(s.image); });
  });
  LabelStackMasks out;
  for (std::size_t k = 0; k < n; ++k)
    for (auto& m : per_slice[k]) {
      auto [it, added] = out.objects.try_emplace(m.label);
      if (added) {
        it->second.masks.assign(n, detail::PackedMasks{run.stack.width, run.stack.height, true, {}, {}});
        it->second.bounds.assign(n, PixelBox{});
      }
      it->second.masks[k] = std::move(m.masks);
      it->second.bounds[k] = m.bounds;
    }
  return out;
}

// The objects: one (label 0), or each label of a label stack (those asked for).
std::vector<std::uint32_t> objects_to_reconstruct(const Run& run, const LabelStackMasks* labelled) {
  const std::vector<std::uint32_t>& asked = run.options.labels;
  if (run.stack.kind != InputKind::Labels) {
    if (!asked.empty()) throw ParamError("labels: a label selection needs labels input (InputKind::Labels)");
    return {0};
  }
  std::set<std::uint32_t> seen;
  for (const auto& [label, object] : labelled->objects) seen.insert(label);
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

void finish_contours(const Run& run, const std::vector<detail::PackedMasks>& masks, const std::vector<PixelBox>& bounds,
                     ObjectResult& obj) {
  obj.slices_with_contours = int(std::count_if(masks.begin(), masks.end(), [](const auto& m) { return !m.empty; }));
  obj.box = detail::object_box(bounds, run.stack.width, run.stack.height, run.params.crop_margin);
}

// Stage (paper 2.1): contour and inside of every slice, kept packed until
// its fields are computed; their union gives the crop box.
std::vector<detail::PackedMasks> contour_stage(const Run& run, ObjectResult& obj) {
  const std::size_t n = run.slices();
  std::vector<detail::PackedMasks> masks(n);
  std::vector<PixelBox> bounds(n);
  std::vector<std::vector<std::string>> warnings(n);
  std::atomic<long> done{0};
  for_slices(run, 0, n, "contour", done, [&](std::size_t k) {
    SliceMasks m =
        with_slice(run.stack, k, [&](const Slice& s) { return detail::slice_masks(run.stack, s, run.params, obj.label); });
    bounds[k] = detail::mask_bounds(m);
    warnings[k] = std::move(m.warnings);
    masks[k] = detail::pack_masks(m);
  });
  for (auto& w : warnings)
    for (auto& line : w) run.warn(std::move(line));
  finish_contours(run, masks, bounds, obj);
  return masks;
}

// A label's masks from label_stack_masks.
std::vector<detail::PackedMasks> label_contours(const Run& run, LabelStackMasks::Object&& labelled, ObjectResult& obj) {
  finish_contours(run, labelled.masks, labelled.bounds, obj);
  return std::move(labelled.masks);
}

void add_fit_stats(FitStats& s, const SliceField& m) {
  s.points += long(m.points.size());
  s.fallback_slices += m.fallback;
  s.sign_guarded_pixels += m.sign_guarded;
  s.sign_guarded_slices += m.sign_guarded > 0;
  s.leaves += m.fit.leaves;
  s.leaves_over_tol += m.fit.leaves_over_tol;
  s.max_depth_reached = std::max(s.max_depth_reached, m.fit.max_depth_reached);
  s.max_local_error = std::max(s.max_local_error, m.fit.max_local_error);
}

void warn_fit(const Run& run, const std::vector<std::size_t>& fallbacks, const FitStats& fit, const std::string& what) {
  for (const std::size_t k : fallbacks)
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

// Stages (paper 2.1-2.3, or a baseline) slice by slice from the packed masks:
// the method's slice field (MethodSpec::slice_field). Computed slice_window()
// slices at a time in parallel, handed out in slice order.
class SliceFields {
 public:
  SliceFields(const Run& run, ObjectResult& obj, std::vector<detail::PackedMasks>& masks, ResidentCount& count)
      : run_(run),
        obj_(obj),
        masks_(masks),
        count_(count),
        window_(detail::slice_window()),
        method_(method_spec(run.params.method.name())) {}

  // Slice k's field (empty for an empty slice), k = 0, 1, ... in order; its
  // fit statistics and stage fields are recorded as it is handed out.
  Grid2f take(std::size_t k) {
    if (k != next_) throw Error("SliceFields::take: slices out of order");
    if (ready_.empty()) compute(k);
    Computed c = std::move(ready_.front());
    ready_.pop_front();
    ++next_;
    SliceField& f = c.slice;
    for (const float v : f.field.data) top_ = std::max(top_, v);
    if (!f.field.empty() && method_.fits_curves) {
      add_fit_stats(obj_.fit, f);
      if (f.fallback) fallbacks_.push_back(k);
      if (run_.options.on_slice_fields)
        run_.options.on_slice_fields(SliceStageFields{obj_.label, int(k), obj_.box, std::move(f.points), std::move(f.mpu),
                                                      std::move(f.distance), f.field});
    }
    return std::move(f.field);
  }

  // Splits the wall time of the batches by each stage's share of the CPU time.
  void add_times(StageTimes& t) const {
    const double cpu = cpu_contour_ + cpu_mpu_ + cpu_dist_ + cpu_filter_;
    if (!(cpu > 0)) return;
    t.contour += wall_ * cpu_contour_ / cpu;
    t.mpu += wall_ * cpu_mpu_ / cpu;
    t.dist += wall_ * cpu_dist_ / cpu;
    t.filter += wall_ * cpu_filter_ / cpu;
  }
  [[nodiscard]] const std::vector<std::size_t>& fallbacks() const { return fallbacks_; }
  /// The largest value of the slice fields handed out (the end caps lie below it).
  [[nodiscard]] float top() const { return top_; }

 private:
  struct Computed {
    SliceField slice;       // the method's field, statistics, stage fields if asked
    double t_contour = 0;   // CPU seconds unpacking the masks
  };

  Computed one(std::size_t k) const {
    Computed c;
    if (masks_[k].empty) return c;
    const Run& run = run_;
    const auto t0 = Clock::now();
    const SliceMasks m = detail::unpack_masks(masks_[k]);
    masks_[k] = {};
    c.t_contour = seconds_since(t0);
    const SliceInput in{m, run.stack.slices[k], obj_.box, run.stack.kind, run.stack.width,
                        bool(run.options.on_slice_fields)};
    c.slice = method_.slice_field(in, run.params);
    return c;
  }

  void compute(std::size_t k0) {
    const auto t0 = Clock::now();
    const std::size_t k1 = std::min(run_.slices(), k0 + window_);
    ready_.resize(k1 - k0);
    count_.add(long(k1 - k0));  // in flight, then held until the knot feed drops them
    const char* stage = method_.fits_curves ? "mpu+distance" : "distance";
    for_slices(run_, k0, k1, stage, done_, [&](std::size_t k) { ready_[k - k0] = one(k); });
    for (const Computed& c : ready_) {
      const SliceField& f = c.slice;
      cpu_contour_ += c.t_contour, cpu_mpu_ += f.t_mpu, cpu_dist_ += f.t_dist, cpu_filter_ += f.t_filter;
    }
    wall_ += seconds_since(t0);
  }

  const Run& run_;
  ObjectResult& obj_;
  std::vector<detail::PackedMasks>& masks_;  // slice k's dropped once computed
  ResidentCount& count_;
  std::size_t window_;
  const MethodSpec& method_;
  std::deque<Computed> ready_;
  std::size_t next_ = 0;
  std::atomic<long> done_{0};
  std::vector<std::size_t> fallbacks_;
  double wall_ = 0, cpu_contour_ = 0, cpu_mpu_ = 0, cpu_dist_ = 0, cpu_filter_ = 0;
  float top_ = -std::numeric_limits<float>::infinity();
};

// The knots of the z splines in z order (paper 2.4): the end cap below, every
// slice's field (empty slices closed as detail::fill_empty_slices does), the
// end cap above. Holds a slice's field while a neighbour may still need it.
class KnotFeed {
 public:
  KnotFeed(SliceFields& slices, const std::vector<char>& empty, const PixelBox& box, const InterpParams& interp,
           ResidentCount& count)
      : slices_(slices), empty_(empty), box_(box), interp_(interp), count_(count) {
    const auto last = std::find(empty.rbegin(), empty.rend(), char(0));
    last_nonempty_ = std::size_t(empty.rend() - last) - 1;
  }
  ~KnotFeed() { count_.remove(long(raw_.size()) + long(!pending_.empty())); }
  KnotFeed(const KnotFeed&) = delete;
  KnotFeed& operator=(const KnotFeed&) = delete;

  Grid2f next() {
    const std::size_t n = empty_.size(), i = knot_++;
    if (i == 1 || i == n + 1) {  // slice 0's field after its cap below; the cap above after slice n - 1
      count_.remove(1);
      return std::move(pending_);
    }
    Grid2f f = slice_field(i == 0 ? 0 : i - 1);
    if (i == 0) {
      Grid2f cap = cap_slice(f, interp_);
      pending_ = std::move(f);
      count_.add(1);
      return cap;
    }
    if (i == n) {
      pending_ = cap_slice(f, interp_);
      count_.add(1);
    }
    return f;
  }

 private:
  // Slice k's raw field, pulling slices up to k.
  Grid2f& raw(std::size_t k) {
    while (raw_first_ + raw_.size() <= k) {
      raw_.push_back(slices_.take(raw_first_ + raw_.size()));
      lowest_ = detail::most_negative(lowest_, raw_.back());
    }
    return raw_[k - raw_first_];
  }

  // Slice k's knot field, once for each k in order.
  Grid2f slice_field(std::size_t k) {
    const std::size_t n = empty_.size();
    Grid2f out;
    if (!empty_[k]) {
      Grid2f& f = raw(k);
      const bool neighbour_needs = k + 1 < n && empty_[k + 1];
      out = neighbour_needs ? f : std::move(f);
    } else {
      const Grid2f* above = k + 1 < n ? &raw(k + 1) : nullptr;  // deque references survive push_back
      const Grid2f* below = k > 0 ? &raw(k - 1) : nullptr;
      const bool isolated = (!above || above->empty()) && (!below || below->empty());
      // The most negative value of all fields: pull (and hold) the slices up
      // to the last non-empty one first.
      if (isolated && last_nonempty_ > k) raw(last_nonempty_);
      out = detail::empty_slice_field(below, above, lowest_, box_, interp_);
    }
    // Slices below k are no longer anyone's neighbour.
    for (; raw_first_ < k; ++raw_first_) {
      raw_.pop_front();
      count_.remove(1);
    }
    return out;
  }

  SliceFields& slices_;
  const std::vector<char>& empty_;
  PixelBox box_;
  const InterpParams& interp_;
  ResidentCount& count_;
  std::size_t last_nonempty_ = 0;
  std::deque<Grid2f> raw_;  // slices [raw_first_, raw_first_ + size)
  std::size_t raw_first_ = 0;
  float lowest_ = -1.0f;  // detail::most_negative of the slices pulled
  std::size_t knot_ = 0;
  Grid2f pending_;
};

// ReconstructOptions::on_sample served as the planes pass its heights.
class Sampling final : public PlaneSource {
 public:
  Sampling(PlaneSource& field, const Run& run, const ObjectResult& obj, const std::vector<double>& knot_z)
      : field_(field), run_(run), obj_(obj) {
    for (const double zs : run.options.sample_z)
      if (zs >= knot_z.front() && zs <= knot_z.back()) z_.push_back(zs);
    std::stable_sort(z_.begin(), z_.end());
  }
  [[nodiscard]] int width() const override { return field_.width(); }
  [[nodiscard]] int height() const override { return field_.height(); }
  [[nodiscard]] std::size_t interval(double z) const override { return field_.interval(z); }
  void reach(std::size_t k) override {
    for (; next_ < z_.size() && field_.interval(z_[next_]) <= k; ++next_) {
      field_.reach(field_.interval(z_[next_]));
      const auto t0 = Clock::now();
      field_.evaluate(z_[next_], sampled_);
      seconds_ += seconds_since(t0);
      run_.options.on_sample(obj_.label, sampled_, obj_.box, z_[next_]);
    }
    field_.reach(k);
  }
  void evaluate(double z, Grid2f& out) const override { field_.evaluate(z, out); }
  void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const override {
    field_.sides(k, iso, margin, out);
  }
  [[nodiscard]] double seconds() const { return seconds_; }

 private:
  PlaneSource& field_;
  const Run& run_;
  const ObjectResult& obj_;
  std::vector<double> z_;
  std::size_t next_ = 0;
  Grid2f sampled_;
  double seconds_ = 0;
};

// The knot heights: the slices' z and the end caps' (add_end_caps; a cap of
// an empty field is empty).
std::vector<double> knot_z(const Run& run) {
  std::vector<double> z(run.slices());
  for (std::size_t k = 0; k < z.size(); ++k) z[k] = run.stack.slices[k].z;
  std::vector<Grid2f> none(z.size());
  add_end_caps(none, z, run.params.interp);
  return z;
}

// Estimate constants (docs/decisions.md, work budget: measured on the
// synthetic sphere and the frog).
// Live float copies of each resident slice field: the field, the spline's
// coefficients and one stage's output beside its input.
constexpr double kFieldCopies = 3;
// Bytes of a mesh triangle before decimation, at the peak: vertices and
// triangles, the decimator's quadrics, edge heap and links, the mesh check's
// edge map.
constexpr double kBytesPerTriangle = 160;
// Bytes a fine polyline raster pixel holds while fitted: the contour and
// inside masks.
constexpr double kRasterBytesPerPixel = 2;

// Plane count of sample_planes() over the capped z range, without making it.
double plane_count(const std::vector<double>& z, double step) {
  return std::max(0.0, std::ceil((z.back() - z.front()) / step - 1e-9)) + 1;
}

// Pixels in the runs of a packed mask (begin, end, begin, end, ...).
double run_pixels(const std::vector<std::uint32_t>& runs) {
  double n = 0;
  for (std::size_t i = 0; i + 1 < runs.size(); i += 2) n += double(runs[i + 1] - runs[i]);
  return n;
}

// Marching Cubes crosses the surface ~2 triangles per pixel of contour per
// plane: between two slices the contour length runs from one's to the
// other's; the caps add their end contour's band and ~2 triangles per
// inside pixel of the end slices. Fields resident at once: the slices
// computed together, the spline's knots around a block, the caps.
WorkEstimate estimate_work(const Run& run, const std::vector<detail::PackedMasks>& masks, const ObjectResult& obj) {
  const ReconstructParams& p = run.params;
  WorkEstimate e;
  e.label = obj.label;
  e.box = obj.box;
  e.slices = long(run.slices());
  const std::vector<double> z = knot_z(run);
  e.planes = plane_count(z, p.interp.z_step);
  const std::size_t n = masks.size();
  std::vector<double> perimeter(n + 2, 0.0), area(n + 2, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    if (masks[k].empty) continue;
    perimeter[k + 1] = run_pixels(masks[k].contour);
    area[k + 1] = run_pixels(masks[k].inside);
  }
  perimeter[0] = perimeter[1], perimeter[n + 1] = perimeter[n];
  for (std::size_t k = 0; k + 1 < z.size(); ++k)
    e.triangles += (perimeter[k] + perimeter[k + 1]) * (z[k + 1] - z[k]) / p.interp.z_step;
  e.triangles += 2 * (area[1] + area[n]);
  const double pixels = double(obj.box.width()) * double(obj.box.height());
  e.plane_bytes = double(obj.box.width() + 2) * double(obj.box.height() + 2) * sizeof(float);
  const std::optional<std::size_t> knots = z_scheme_spec(p.z_scheme).resident_knots(p);
  const double window = double(detail::slice_window()) + (knots ? double(*knots) : double(n)) + 2;
  e.field_bytes = std::min(double(n + 2), window) * pixels * sizeof(float) * kFieldCopies;
  if (run.stack.kind == InputKind::Polylines && fits_curves(p.method) && p.polyline_raster_width > 0) {
    const double k = double(p.polyline_raster_width) / run.stack.width;
    const double in_flight = std::min(double(n), double(tbb::this_task_arena::max_concurrency()));
    e.field_bytes += in_flight * k * k * pixels * kRasterBytesPerPixel;
  }
  e.mesh_bytes = e.triangles * kBytesPerTriangle;
  return e;
}

// Why an object's mesh came out empty, given its fields' maximum.
std::string empty_reason(const Run& run, float top, const ObjectResult& obj) {
  std::ostringstream o;
  if (!(top > run.params.mc.iso)) {
    o << "the interpolated field never rises above mc.iso = " << run.params.mc.iso << " (its maximum is " << top
      << " px): no surface crosses it";
  } else if (const double span = run.stack.slices.back().z - run.stack.slices.front().z; span < run.params.interp.z_step) {
    o << "the slices span " << span << " px in z, less than one plane step interp.z_step = " << run.params.interp.z_step
      << " px (check --z-spacing / the slice z)";
  } else {
    o << "the object (" << obj.slices_with_contours << " slice(s) with contours, box " << obj.box.width() << "x"
      << obj.box.height() << " px) is smaller than the sampling grid (a pixel in the plane, interp.z_step = "
      << run.params.interp.z_step << " px in z)";
  }
  return o.str();
}

// Stages (paper 2.1-2.5 but decimation) streamed: the slice fields computed
// a window at a time, the z splines through a window of knots, each plane
// meshed and dropped; only the packed masks are kept for every slice.
void stream_stages(const Run& run, std::vector<detail::PackedMasks> masks, ObjectResult& obj) {
  const ReconstructParams& p = run.params;
  std::vector<char> empty(masks.size());
  for (std::size_t k = 0; k < masks.size(); ++k) empty[k] = masks[k].empty;
  ResidentCount count;
  SliceFields slices(run, obj, masks, count);
  KnotFeed feed(slices, empty, obj.box, p.interp, count);
  const std::vector<double> z = knot_z(run);
  if (plane_count(z, p.interp.z_step) < 2) {
    std::ostringstream o;
    o << "the slices span " << z.back() - z.front() << " px in z (end caps included), less than one plane step "
      << "interp.z_step = " << p.interp.z_step << " px: nothing to mesh (check --z-spacing / the slice z)";
    throw InputError(run.stack.slices.front().source, o.str());
  }
  const std::unique_ptr<PlaneSource> stream = z_scheme_spec(p.z_scheme).make(
      ZSchemeInput{z, obj.box.width(), obj.box.height(), [&] { return feed.next(); }, &count}, p);
  std::optional<Sampling> sampling;
  if (run.options.on_sample) sampling.emplace(*stream, run, obj, z);
  PlaneSource& field = sampling ? static_cast<PlaneSource&>(*sampling) : *stream;

  StreamMeshOptions o;
  o.outside = -float(p.interp.cap_depth);
  if (run.options.on_plane)
    o.on_plane = [&](const Grid2f& plane, double x0, double y0, double zz, int index, int planes) {
      run.options.on_plane(obj.label, plane, x0, y0, zz, index, planes);
    };
  o.progress = [&](long done, long total) { run.progress("interpolate+mesh", done, total); };
  StreamMeshResult r = mesh_interpolated_field(field, sample_planes(z.front(), z.back(), p.interp.z_step), obj.box.x0,
                                               obj.box.y0, p.mc, o);
  if (sampling) sampling->reach(z.size() - 2);  // any sample the planes did not pass
  obj.mesh = std::move(r.mesh);
  if (obj.mesh.triangles.empty()) obj.empty_reason = empty_reason(run, slices.top(), obj);
  obj.peak_resident_fields = count.peak;
  slices.add_times(run.result.times);
  run.result.times.interp += r.interp_seconds + stream->setup_seconds() + (sampling ? sampling->seconds() : 0.0);
  run.result.times.mesh += r.mesh_seconds;
  if (fits_curves(p.method)) warn_fit(run, slices.fallbacks(), obj.fit, object_name(obj.label));
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
  std::optional<LabelStackMasks> labelled;
  if (stack.kind == InputKind::Labels) {
    const auto t0 = Clock::now();
    labelled = label_stack_masks(run);
    result.times.contour += seconds_since(t0);
  }
  const std::vector<std::uint32_t> labels = objects_to_reconstruct(run, labelled ? &*labelled : nullptr);
  // Each object's masks, then its stages: objects are independent, so they
  // run side by side unless a callback sees them object by object (stage
  // fields, planes, samples); each keeps its own warnings and times, joined
  // in label order, so the result is the serial one.
  const std::size_t n = labels.size();
  std::vector<ObjectResult> objects(n);
  std::vector<std::vector<detail::PackedMasks>> masks(n);
  std::vector<ReconstructResult> parts(n);
  for (std::size_t l = 0; l < n; ++l) {
    const Run part{stack, params, options, parts[l]};
    ObjectResult& obj = objects[l];
    obj.label = labels[l];
    const auto t0 = Clock::now();
    if (labelled) {
      LabelStackMasks::Object& o = labelled->objects.at(obj.label);
      const bool again = std::find(labels.begin() + std::ptrdiff_t(l) + 1, labels.end(), obj.label) != labels.end();
      masks[l] = label_contours(part, again ? LabelStackMasks::Object(o) : std::move(o), obj);
    } else {
      masks[l] = contour_stage(part, obj);
    }
    parts[l].times.contour += seconds_since(t0);
    // Before any fit, object by object in label order (it may throw: over budget).
    if (options.on_estimate && obj.slices_with_contours > 0) options.on_estimate(estimate_work(part, masks[l], obj));
  }
  std::vector<std::exception_ptr> errors(n);
  auto stages = [&](std::size_t l) {
    const Run part{stack, params, options, parts[l]};
    ObjectResult& obj = objects[l];
    try {
      if (obj.slices_with_contours == 0) {
        part.warn(object_name(obj.label) + ": no slice has an inside; nothing to reconstruct");
        return;
      }
      stream_stages(part, std::move(masks[l]), obj);
      decimate_stage(part, obj);
      check_stage(part, obj);
    } catch (...) {
      errors[l] = std::current_exception();
    }
  };
  const bool side_by_side = n > 1 && !options.on_slice_fields && !options.on_plane && !options.on_sample;
  if (side_by_side) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t l = r.begin(); l < r.end(); ++l) stages(l);
    });
  }
  for (std::size_t l = 0; l < n; ++l) {
    if (!side_by_side) stages(l);
    if (errors[l]) std::rethrow_exception(errors[l]);  // the first object's in label order, as run one by one
    ReconstructResult& part = parts[l];
    for (auto& w : part.warnings) result.warnings.push_back(std::move(w));
    result.times += part.times;
    if (objects[l].slices_with_contours > 0) result.objects.push_back(std::move(objects[l]));
  }
  return result;
}

}  // namespace isoloft
