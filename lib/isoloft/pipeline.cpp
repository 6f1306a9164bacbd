#include "isoloft/pipeline.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <exception>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/interp/z_stream.h"
#include "isoloft/methods/method.h"
#include "isoloft/mesh/stream_mesher.h"
#include "isoloft/pipeline/field_band.h"
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
const Method Method::Field3d{"field3d"};

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
        field("mask_boundary", &P::mask_boundary, "",
              "masks/labels: traced (the smooth sub-pixel curve keeping every drawn pixel on its side, fitted exactly: "
              "the distance to it; not in the paper; mask_curve.*) or pixel-centres (the paper 2.1: boundary pixel "
              "centres moved mask_edge_offset out, the MPU fit)")
            .cli("--mask-boundary"),
        field("polyline_boundary", &P::polyline_boundary, "",
              "polylines: drawn (the polygons as drawn: the slice field is the exact distance to their edges, no fit; "
              "not in the paper) or fit (the paper 2.1: points along the edges, the MPU fit)")
            .cli("--polyline-boundary"),
        field("mask_min_feature", &P::mask_min_feature, "px",
              "marker2006, masks/labels: mask features (lines, spurs, islands; notches, holes, gaps) narrower than this "
              "are removed before the contour points are taken, by an opening and a closing with a square of this side "
              "(not in the paper); 1 = the mask as it is",
              between(1, 16)),
        field("label_partition", &P::label_partition, "",
              "labels: every label's field and the background's (minus the field of the labels' union) compete, each "
              "point going to the highest, so touching labels share their boundary and no point inside the union is "
              "left unlabelled (not in the paper); false: each label reconstructed on its own")
            .cli("--independent-labels", false),
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
    ParamTable<P>::nest(rows, checks, "mask_curve", &P::mask_curve, params_table<MaskCurveParams>());
    ParamTable<P>::nest(rows, checks, "normals", &P::normals, params_table<NormalsParams>());
    ParamTable<P>::nest(rows, checks, "mpu", &P::mpu, params_table<MpuParams>());
    ParamTable<P>::nest(rows, checks, "band", &P::band, params_table<NarrowBandParams>());
    ParamTable<P>::nest(rows, checks, "extend", &P::extend, params_table<ExtendParams>());
    ParamTable<P>::nest(rows, checks, "filter", &P::filter, params_table<FilterParams>());
    ParamTable<P>::nest(rows, checks, "interp", &P::interp, params_table<InterpParams>());
    ParamTable<P>::nest(rows, checks, "track", &P::track, params_table<TrackParams>());
    ParamTable<P>::nest(rows, checks, "mc", &P::mc, params_table<MarchingCubesParams>());
    ParamTable<P>::nest(rows, checks, "decimate", &P::decimate, params_table<DecimateParams>());
    ParamTable<P>::nest(rows, checks, "field3d", &P::field3d, params_table<Field3dParams>());
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
  std::uint32_t label = 0;  ///< the object this part of the run is for (0: the only one, or every label)

  [[nodiscard]] std::size_t slices() const { return stack.slices.size(); }
  void progress(const char* stage, long done, long total) const {
    if (options.progress) options.progress(label, stage, done, total);
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
  std::optional<Object> uni;  ///< the labels' union, if asked
};

LabelStackMasks label_stack_masks(const Run& run, bool with_union) {
  const std::size_t n = run.slices();
  std::vector<std::vector<detail::LabelMasks>> per_slice(n);
  std::atomic<long> done{0};
  for_slices(run, 0, n, "contour", done, [&](std::size_t k) {
    with_slice(run.stack, k, [&](const Slice& s) { per_slice[k] = detail::label_masks(s.image); });
  });
  LabelStackMasks out;
  if (with_union) {
    // The union's bounds and emptiness (its field comes from the labels': UnionStream).
    out.uni.emplace();
    for (const auto& slice : per_slice) {
      PixelBox b{run.stack.width, run.stack.height, -1, -1};
      for (const auto& m : slice)
        b = {std::min(b.x0, m.bounds.x0), std::min(b.y0, m.bounds.y0), std::max(b.x1, m.bounds.x1), std::max(b.y1, m.bounds.y1)};
      out.uni->masks.push_back(detail::PackedMasks{run.stack.width, run.stack.height, slice.empty(), {}, {}});
      out.uni->bounds.push_back(slice.empty() ? PixelBox{} : b);
    }
  }
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
  // band: the fields are exact only where they reach the mesh (pipeline/field_band.h).
  SliceFields(const Run& run, ObjectResult& obj, std::vector<detail::PackedMasks>& masks, ResidentCount& count,
              const std::optional<detail::FieldBand::Setup>& band)
      : run_(run),
        obj_(obj),
        masks_(masks),
        count_(count),
        window_(detail::slice_window()),
        method_(method_spec(run.params.method.name())) {
    if (band) band_.emplace(masks, obj.box, *band);
  }
  ~SliceFields() {  // a batch still computing (the caller stopped early, or threw) is cancelled and waited for
    if (!ahead_) return;
    group_.cancel();
    try {
      group_.wait();
    } catch (...) {
    }
  }
  SliceFields(const SliceFields&) = delete;
  SliceFields& operator=(const SliceFields&) = delete;

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
    const std::optional<detail::SliceBand> band = band_ ? band_->band(k) : std::nullopt;
    c.t_contour = seconds_since(t0);
    const SliceInput in{m, run.stack.slices[k], obj_.box, run.stack.kind, run.stack.width,
                        bool(run.options.on_slice_fields), band ? &*band : nullptr};
    c.slice = method_.slice_field(in, run.params);
    return c;
  }

  // Starts the batch of slices from k0 as a task of the run's arena: it
  // computes while the caller meshes the batch before it.
  void start(std::size_t k0) {
    const std::size_t k1 = std::min(run_.slices(), k0 + window_);
    ahead_.emplace(k0);
    batch_.resize(k1 - k0);
    count_.add(long(k1 - k0));  // in flight, then held until the knot feed drops them
    group_.run([this, k0, k1] {
      const auto t0 = Clock::now();
      if (band_) band_->prepare(k0, k1);
      const char* stage = method_.fits_curves ? "mpu+distance" : "distance";
      for_slices(run_, k0, k1, stage, done_, [&](std::size_t k) { batch_[k - k0] = one(k); });
      batch_wall_ = seconds_since(t0);
    });
  }

  // The batch from k0 (computed ahead, or now), and the next one started.
  void compute(std::size_t k0) {
    if (ahead_ && *ahead_ != k0) throw Error("SliceFields::compute: batch out of order");
    if (!ahead_) start(k0);
    ahead_.reset();
    group_.wait();  // rethrows the batch's first failing slice
    ready_ = std::move(batch_);
    batch_.clear();
    for (const Computed& c : ready_) {
      const SliceField& f = c.slice;
      cpu_contour_ += c.t_contour, cpu_mpu_ += f.t_mpu, cpu_dist_ += f.t_dist, cpu_filter_ += f.t_filter;
    }
    wall_ += batch_wall_;
    if (const std::size_t k1 = k0 + ready_.size(); k1 < run_.slices()) start(k1);
  }

  const Run& run_;
  ObjectResult& obj_;
  std::vector<detail::PackedMasks>& masks_;  // slice k's dropped once computed
  ResidentCount& count_;
  std::size_t window_;
  const MethodSpec& method_;
  std::optional<detail::FieldBand> band_;
  std::deque<Computed> ready_;
  std::deque<Computed> batch_;        // the batch computing in group_, from slice *ahead_
  std::optional<std::size_t> ahead_;
  // Isolated: started in one task and waited for in another (the label
  // partition reaches each label's stream from a parallel_for), its
  // cancellation is this object's own (the destructor).
  tbb::task_group_context context_{tbb::task_group_context::isolated};
  tbb::task_group group_{context_};
  double batch_wall_ = 0;
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
  // z: the knot heights (knot_z: slice k at z[k + 1]).
  KnotFeed(SliceFields& slices, const std::vector<char>& empty, const std::vector<double>& z, const PixelBox& box,
           const InterpParams& interp, ResidentCount& count)
      : slices_(slices), empty_(empty), z_(z), box_(box), interp_(interp), count_(count) {
    const auto last = std::find(empty.rbegin(), empty.rend(), char(0));
    last_nonempty_ = std::size_t(empty.rend() - last) - 1;
  }
  ~KnotFeed() { count_.remove(long(raw_.size()) + long(!pending_.empty()) + long(!before_.empty())); }
  KnotFeed(const KnotFeed&) = delete;
  KnotFeed& operator=(const KnotFeed&) = delete;

  Grid2f next() {
    const std::size_t n = empty_.size(), i = knot_++;
    Grid2f out;
    if (i == 1 || i == n + 1) {  // slice 0's field after its cap below; the cap above after slice n - 1
      count_.remove(1);
      out = std::move(pending_);
    } else {
      Grid2f f = slice_field(i == 0 ? 0 : i - 1);
      if (i == 0) {
        // Slice 1, whose trend round and slab caps follow (interp/spline.h, cap_slice).
        const Grid2f* after = follows_trend() && !raw(1).empty() ? &raw(1) : nullptr;
        Grid2f cap = cap_slice(f, interp_, z_[1] - z_[0], after, z_[2] - z_[1]);
        pending_ = std::move(f);
        count_.add(1);
        return cap;
      }
      if (i == n) {
        pending_ = cap_slice(f, interp_, z_[n + 1] - z_[n], before_.empty() ? nullptr : &before_, z_[n] - z_[n - 1]);
        if (!before_.empty()) count_.remove(1);
        before_ = Grid2f();
        count_.add(1);
      }
      out = std::move(f);
    }
    if (i + 1 == n && i >= 1 && follows_trend()) {  // slice n - 2, kept for the cap above
      before_ = out;
      count_.add(1);
    }
    return out;
  }

 private:
  [[nodiscard]] bool follows_trend() const {
    return interp_.cap_shape == CapShape::Slab || interp_.cap_shape == CapShape::Round;
  }

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
      out = detail::empty_slice_field(below, above, lowest_, box_, interp_, k > 0 ? z_[k + 1] - z_[k] : 0.0,
                                      k + 1 < n ? z_[k + 2] - z_[k + 1] : 0.0);
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
  const std::vector<double>& z_;
  PixelBox box_;
  const InterpParams& interp_;
  ResidentCount& count_;
  std::size_t last_nonempty_ = 0;
  std::deque<Grid2f> raw_;  // slices [raw_first_, raw_first_ + size)
  std::size_t raw_first_ = 0;
  float lowest_ = -1.0f;  // detail::most_negative of the slices pulled
  std::size_t knot_ = 0;
  Grid2f pending_;
  Grid2f before_;  // slice n - 2's knot field, for the cap above
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
  void evaluate_runs(double z, Grid2f& out, const PixelRuns& only) const override { field_.evaluate_runs(z, out, only); }
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

// mesh_planes().size(), without making them.
double plane_count(const std::vector<double>& z, const InterpParams& interp) {
  if (!interp.planes_on_slices || z.size() < 3)
    return std::max(0.0, std::ceil((z.back() - z.front()) / interp.z_step - 1e-9)) + 1;
  return std::ceil((z[1] - z.front()) / interp.z_step) + std::ceil((z.back() - z[1]) / interp.z_step) + 1;
}

// Whether the knots span less than one plane step: nothing to mesh.
bool thinner_than_a_step(const std::vector<double>& z, double step) { return (z.back() - z.front()) / step < 1 - 1e-9; }

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
  e.planes = plane_count(z, p.interp);
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
  const double window = double(detail::slices_in_flight()) + (knots ? double(*knots) : double(n)) + 2;
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
      << " px (check " << option_name("--z-spacing") << " / the slice z)";
  } else {
    o << "the object (" << obj.slices_with_contours << " slice(s) with contours, box " << obj.box.width() << "x"
      << obj.box.height() << " px) is smaller than the sampling grid (a pixel in the plane, interp.z_step = "
      << run.params.interp.z_step << " px in z)";
  }
  return o.str();
}

// One object's interpolated field, streamed (paper 2.1-2.4): the slice fields
// computed a window at a time, the knot feed, the z scheme's plane source;
// only the packed masks are kept for every slice.
class ObjectStream {
 public:
  /// Each knot the stream pulls, with its index, goes to `tap` too (if set).
  using KnotTap = std::function<void(std::size_t, const Grid2f&)>;

  ObjectStream(const Run& run, ObjectResult& obj, std::vector<detail::PackedMasks> masks, KnotTap tap = {},
               const std::optional<detail::FieldBand::Setup>& band = std::nullopt)
      : run_(run), obj_(obj), masks_(std::move(masks)), empty_(masks_.size()), z_(knot_z(run)), tap_(std::move(tap)) {
    const ReconstructParams& p = run.params;
    for (std::size_t k = 0; k < masks_.size(); ++k) empty_[k] = masks_[k].empty;
    if (thinner_than_a_step(z_, p.interp.z_step)) {
      std::ostringstream o;
      o << "the slices span " << z_.back() - z_.front() << " px in z (end caps included), less than one plane step "
        << "interp.z_step = " << p.interp.z_step << " px: nothing to mesh (check " << option_name("--z-spacing")
        << " / the slice z)";
      throw InputError(run.stack.slices.front().source, o.str());
    }
    slices_.emplace(run, obj, masks_, count_, band);
    feed_.emplace(*slices_, empty_, z_, obj.box, p.interp, count_);
    stream_ = z_scheme_spec(p.z_scheme).make(ZSchemeInput{z_, obj.box.width(), obj.box.height(), [this] { return next(); }, &count_}, p);
  }
  ObjectStream(const ObjectStream&) = delete;
  ObjectStream& operator=(const ObjectStream&) = delete;

  [[nodiscard]] PlaneSource& field() { return *stream_; }
  [[nodiscard]] const std::vector<double>& knots() const { return z_; }
  [[nodiscard]] std::vector<double> planes() const {
    return mesh_planes(z_, run_.params.interp);
  }
  [[nodiscard]] const ObjectResult& object() const { return obj_; }

  /// The object's mesh and the stream's statistics and times; `interp_seconds`
  /// evaluating planes and samples.
  void finish(StreamMeshResult r, double interp_seconds) {
    const ReconstructParams& p = run_.params;
    obj_.mesh = std::move(r.mesh);
    if (obj_.mesh.triangles.empty()) obj_.empty_reason = empty_reason(run_, slices_->top(), obj_);
    obj_.peak_resident_fields = count_.peak;
    slices_->add_times(run_.result.times);
    run_.result.times.interp += interp_seconds + stream_->setup_seconds();
    run_.result.times.mesh += r.mesh_seconds;
    if (fits_curves(p.method)) warn_fit(run_, slices_->fallbacks(), obj_.fit, object_name(obj_.label));
  }

 private:
  Grid2f next() {
    Grid2f f = feed_->next();
    if (tap_) tap_(knots_pulled_, f);
    ++knots_pulled_;
    return f;
  }

  const Run& run_;
  ObjectResult& obj_;
  std::vector<detail::PackedMasks> masks_;
  std::vector<char> empty_;
  std::vector<double> z_;
  KnotTap tap_;
  std::size_t knots_pulled_ = 0;
  ResidentCount count_;
  std::optional<SliceFields> slices_;
  std::optional<KnotFeed> feed_;
  std::unique_ptr<PlaneSource> stream_;
};

// The mesher's options for an object: the pad outside the end caps' value,
// --volume planes, progress.
StreamMeshOptions mesh_options(const Run& run, const ObjectResult& obj) {
  StreamMeshOptions o;
  o.outside = -float(run.params.interp.cap_depth);
  if (run.options.on_plane)
    o.on_plane = [&run, label = obj.label](const Grid2f& plane, double x0, double y0, double zz, int index, int planes) {
      run.options.on_plane(label, plane, x0, y0, zz, index, planes);
    };
  o.progress = [&run](long done, long total) { run.progress("interpolate+mesh", done, total); };
  return o;
}

// Stages (paper 2.1-2.5 but decimation) of one object: its stream meshed
// plane by plane, the fields exact only where they reach the mesh if `band`.
void stream_stages_once(const Run& run, std::vector<detail::PackedMasks> masks, ObjectResult& obj,
                        const std::optional<detail::FieldBand::Setup>& band) {
  ObjectStream s(run, obj, std::move(masks), {}, band);
  std::optional<Sampling> sampling;
  if (run.options.on_sample) sampling.emplace(s.field(), run, obj, s.knots());
  PlaneSource& field = sampling ? static_cast<PlaneSource&>(*sampling) : s.field();
  StreamMeshResult r = mesh_interpolated_field(field, s.planes(), obj.box.x0, obj.box.y0, run.params.mc, mesh_options(run, obj));
  if (sampling) sampling->reach(s.knots().size() - 2);  // any sample the planes did not pass
  const double interp = r.interp_seconds + (sampling ? sampling->seconds() : 0.0);
  s.finish(std::move(r), interp);
}

// The fields banded (pipeline/field_band.h) unless a hook sees them or the
// options ask for whole fields. An empty mesh is made again with whole
// fields: its reason quotes the fields' maximum, which a band does not keep.
void stream_stages(const Run& run, std::vector<detail::PackedMasks> masks, ObjectResult& obj) {
  const ReconstructOptions& o = run.options;
  const bool seen = o.on_slice_fields || o.on_plane || o.on_sample || o.whole_fields;
  const std::optional<detail::FieldBand::Setup> band =
      seen ? std::nullopt : detail::field_band_setup(run.params, run.stack.kind, masks);
  if (!band) return stream_stages_once(run, std::move(masks), obj, std::nullopt);
  ReconstructResult part;
  const Run banded{run.stack, run.params, run.options, part, run.label};
  const ObjectResult before = obj;
  stream_stages_once(banded, masks, obj, band);
  if (obj.mesh.triangles.empty()) {
    obj = before;
    return stream_stages_once(run, std::move(masks), obj, std::nullopt);
  }
  for (auto& w : part.warnings) run.warn(std::move(w));
  run.result.times += part.times;
}

// What bounds a label's partition field psi_l = phi_l - max(phi_m (m != l),
// -phi_union) over a knot interval, for cell skipping: the background's
// competitor is -phi_union, so psi_l <= phi_l + phi_union, and a cell is
// surely outside where both fields surely are (iso at most the margin);
// nothing else is known (a label claims gaps where its own field is < 0).
class PartitionSides final : public PlaneSource {
 public:
  // The union's sides of one interval, shared by every label (thread-safe).
  class UnionSides {
   public:
    explicit UnionSides(const PlaneSource& uni) : uni_(uni) {}
    const Grid2<std::int8_t>& of(std::size_t k, float iso, float margin) {
      std::lock_guard lock(m_);
      if (k != k_) {
        uni_.sides(k, iso, margin, sides_);
        k_ = k;
      }
      return sides_;
    }

   private:
    const PlaneSource& uni_;
    std::mutex m_;
    std::size_t k_ = std::size_t(-1);
    Grid2<std::int8_t> sides_;
  };

  PartitionSides(const PlaneSource& label, const PixelBox& box, UnionSides& uni, const PixelBox& ubox)
      : label_(label), uni_(uni), dx_(box.x0 - ubox.x0), dy_(box.y0 - ubox.y0) {}
  [[nodiscard]] int width() const override { return label_.width(); }
  [[nodiscard]] int height() const override { return label_.height(); }
  [[nodiscard]] std::size_t interval(double z) const override { return label_.interval(z); }
  void reach(std::size_t) override {}
  void evaluate(double, Grid2f&) const override { throw Error("PartitionSides: sides only"); }
  void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const override {
    label_.sides(k, iso, margin, out);
    if (!(iso <= margin)) {
      std::fill(out.data.begin(), out.data.end(), std::int8_t(0));
      return;
    }
    const Grid2<std::int8_t>& us = uni_.of(k, iso, margin);
    for (int y = 0; y < out.height; ++y)
      for (int x = 0; x < out.width; ++x) {
        std::int8_t& o = out(x, y);
        o = o == -1 && us(x + dx_, y + dy_) == -1 ? std::int8_t(-1) : std::int8_t(0);
      }
  }

 private:
  const PlaneSource& label_;
  UnionSides& uni_;
  int dx_, dy_;
};

// The highest and second-highest field over the union's box at one height:
// the background's (-phi_union) and every label's over its own box (beyond
// it a label is outside), and whose the highest is (-1: the background).
struct Competition {
  Grid2f top1, top2;
  Grid2<std::int32_t> who;

  // phi[l] over boxes[l] for the labels l < labels; phi[labels] the union's.
  void compute(const std::vector<Grid2f>& phi, const std::vector<PixelBox>& boxes, std::size_t labels) {
    const Grid2f& uni = phi[labels];
    const PixelBox& ubox = boxes[labels];
    top1 = uni;
    for (float& v : top1.data) v = -v;
    top2 = Grid2f(uni.width, uni.height, -std::numeric_limits<float>::infinity());
    who = Grid2<std::int32_t>(uni.width, uni.height, -1);
    for (std::size_t l = 0; l < labels; ++l) {
      const PixelBox& b = boxes[l];
      for (int y = 0; y < b.height(); ++y) {
        const float* f = &phi[l](0, y);
        const std::size_t row = std::size_t(y + b.y0 - ubox.y0) * std::size_t(uni.width) + std::size_t(b.x0 - ubox.x0);
        float* t1 = top1.data.data() + row;
        float* t2 = top2.data.data() + row;
        std::int32_t* w = who.data.data() + row;
        for (int x = 0; x < b.width(); ++x) {
          const float v = f[x];
          if (v > t1[x]) {
            t2[x] = t1[x], t1[x] = v, w[x] = std::int32_t(l);
          } else if (v > t2[x]) {
            t2[x] = v;
          }
        }
      }
    }
  }

  // Label l's partition field over its box: its field minus the best other.
  // A tie goes to the first label in order: the highest's value is at least
  // the least positive float, so exactly one label claims every point.
  void psi(std::size_t l, const Grid2f& phi, const PixelBox& b, const PixelBox& ubox, Grid2f& out) const {
    out = Grid2f(b.width(), b.height());
    for (int y = 0; y < b.height(); ++y)
      for (int x = 0; x < b.width(); ++x) {
        const int ux = x + b.x0 - ubox.x0, uy = y + b.y0 - ubox.y0;
        out(x, y) = who(ux, uy) == std::int32_t(l) ? std::max(phi(x, y) - top2(ux, uy), kTieWinner)
                                                   : phi(x, y) - top1(ux, uy);
      }
  }
  static constexpr float kTieWinner = std::numeric_limits<float>::denorm_min();
};

// One object of a label partition: its own Run (warnings, times), result and masks.
struct PartitionObject {
  Run run;
  ObjectResult& obj;
  std::vector<detail::PackedMasks> masks;
};

// The labels' union as a field, from the labels' own knots: knot i is the
// highest label knot i at each pixel, plus, inside the union, how much
// farther the union's edge is than the pixel's own label's edge
// (detail::union_healing): zero wherever a label meets only the background, so
// there the union's field is its label's, and deep across the boundaries
// between labels, so the union does not dip to zero along them. The labels'
// streams deposit each knot as they pull it (before the union pulls it: the
// same knots, in lockstep).
class UnionStream {
 public:
  UnionStream(const Run& run, ObjectResult& obj, std::size_t labels)
      : run_(run), obj_(obj), labels_(labels), z_(knot_z(run)) {
    stream_ = z_scheme_spec(run.params.z_scheme)
                  .make(ZSchemeInput{z_, obj.box.width(), obj.box.height(), [this] { return next(); }, &count_}, run.params);
  }
  [[nodiscard]] PlaneSource& field() { return *stream_; }

  // Label knot i over `box`, max-accumulated (thread-safe).
  void deposit(std::size_t i, const Grid2f& f, const PixelBox& box) {
    std::lock_guard lock(m_);
    Pending& d = pending_[i];
    if (d.field.empty()) d.field = Grid2f(obj_.box.width(), obj_.box.height(), -float(run_.params.crop_margin));
    for (int y = 0; y < box.height(); ++y)
      for (int x = 0; x < box.width(); ++x) {
        float& u = d.field(x + box.x0 - obj_.box.x0, y + box.y0 - obj_.box.y0);
        u = std::max(u, f(x, y));
      }
    ++d.labels;
  }

  void finish(double interp_seconds) {
    obj_.peak_resident_fields = count_.peak;
    run_.result.times.interp += interp_seconds + stream_->setup_seconds();
  }

 private:
  struct Pending {
    Grid2f field;
    std::size_t labels = 0;
  };

  Grid2f next() {
    const std::size_t i = next_++;
    Pending d;
    {
      std::lock_guard lock(m_);
      const auto it = pending_.find(i);
      if (it == pending_.end() || it->second.labels != labels_) throw Error("UnionStream: knot pulled before every label's");
      d = std::move(it->second);
      pending_.erase(it);
    }
    // Knots 1..n are the slices (0 and n + 1 the end caps: no healing).
    if (i >= 1 && i <= run_.slices())
      with_slice(run_.stack, i - 1, [&](const Slice& s) {
        const Grid2f h = detail::union_healing(s.image, obj_.box);
        for (std::size_t j = 0; j < h.size(); ++j) d.field.data[j] += h.data[j];
      });
    return std::move(d.field);
  }

  const Run& run_;
  ObjectResult& obj_;
  std::size_t labels_;
  std::vector<double> z_;
  ResidentCount count_;
  std::mutex m_;
  std::map<std::size_t, Pending> pending_;
  std::size_t next_ = 0;
  std::unique_ptr<PlaneSource> stream_;
};

// Stages (paper 2.1-2.5 but decimation) of a label partition
// (ReconstructParams::label_partition): every label's field and the union's
// streamed in lockstep; at every plane and sample height label l's field
// becomes psi_l = phi_l - max(phi_m (m != l), -phi_union), positive where l's
// field is the highest of the labels' and the background's. So neighbours l
// and m share the zero set of psi_l = -psi_m = phi_l - phi_m, a point inside
// the union goes to its nearest label, and a label that meets only the
// background keeps its own surface (there phi_union = phi_l). The union (the
// last object) is not meshed.
void partition_stages(const Run& run, std::vector<PartitionObject>& objects) {
  const std::size_t labels = objects.size() - 1;
  std::vector<PixelBox> boxes(labels + 1);
  for (std::size_t i = 0; i <= labels; ++i) boxes[i] = objects[i].obj.box;
  const PixelBox& ubox = boxes[labels];
  UnionStream uni(objects[labels].run, objects[labels].obj, labels);
  std::vector<std::unique_ptr<ObjectStream>> streams(labels);
  for (std::size_t l = 0; l < labels; ++l)
    streams[l] = std::make_unique<ObjectStream>(
        objects[l].run, objects[l].obj, std::move(objects[l].masks),
        [&uni, box = boxes[l]](std::size_t i, const Grid2f& f) { uni.deposit(i, f, box); });
  const std::vector<double>& knots = streams[0]->knots();
  // Heights in order: every plane, and every sample height within the knots.
  struct Height {
    double z;
    bool sample;
  };
  std::vector<Height> heights;
  const std::vector<double> planes = streams[0]->planes();
  for (const double z : planes) heights.push_back({z, false});
  if (run.options.on_sample)
    for (const double z : run.options.sample_z)
      if (z >= knots.front() && z <= knots.back()) heights.push_back({z, true});
  std::stable_sort(heights.begin(), heights.end(), [](const Height& a, const Height& b) { return a.z < b.z; });

  PartitionSides::UnionSides union_sides(uni.field());
  std::vector<PartitionSides> bounds;
  std::vector<std::unique_ptr<StreamMesher>> meshers(labels);
  bounds.reserve(labels);
  for (std::size_t l = 0; l < labels; ++l) {
    bounds.emplace_back(streams[l]->field(), boxes[l], union_sides, ubox);
    StreamMeshOptions o = mesh_options(objects[l].run, objects[l].obj);
    o.progress = nullptr;  // once per plane for all labels, below
    meshers[l] = std::make_unique<StreamMesher>(bounds[l], boxes[l].x0, boxes[l].y0, run.params.mc, std::move(o));
  }
  std::vector<Grid2f> phi(labels + 1), psi(labels);
  std::vector<double> seconds(labels + 1, 0.0);
  Competition c;
  const bool serial_planes = bool(run.options.on_plane);
  long done = 0;
  const long count = long(planes.size());
  for (const Height& h : heights) {
    const std::size_t k = streams[0]->field().interval(h.z);
    // The labels first: their knots feed the union's.
    tbb::parallel_for(std::size_t(0), labels + 1, [&](std::size_t i) {
      if (i == labels) return;
      PlaneSource& f = streams[i]->field();
      f.reach(k);
      const auto t0 = Clock::now();
      f.evaluate(h.z, phi[i]);
      seconds[i] += seconds_since(t0);
    });
    uni.field().reach(k);
    auto t0 = Clock::now();
    uni.field().evaluate(h.z, phi[labels]);
    seconds[labels] += seconds_since(t0);
    t0 = Clock::now();
    c.compute(phi, boxes, labels);
    tbb::parallel_for(std::size_t(0), labels, [&](std::size_t l) {
      c.psi(l, phi[l], boxes[l], ubox, psi[l]);
      if (!h.sample && !serial_planes) meshers[l]->add(psi[l], h.z, k, count);
    });
    if (!h.sample && serial_planes)  // on_plane sees the labels' planes one label at a time, in label order
      for (std::size_t l = 0; l < labels; ++l) meshers[l]->add(psi[l], h.z, k, count);
    const double shared = seconds_since(t0) / double(labels);
    for (std::size_t l = 0; l < labels; ++l) seconds[l] += shared;
    if (h.sample) {
      for (std::size_t l = 0; l < labels; ++l) run.options.on_sample(objects[l].obj.label, psi[l], boxes[l], h.z);
    } else {
      ++done;  // every label's planes advance together
      for (std::size_t l = 0; l < labels; ++l) objects[l].run.progress("interpolate+mesh", done, count);
    }
  }
  for (std::size_t l = 0; l < labels; ++l) streams[l]->finish(meshers[l]->finish(), seconds[l]);
  uni.finish(seconds[labels]);
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
  const Run run{stack, params, options, result, 0};
  std::optional<LabelStackMasks> labelled;
  if (stack.kind == InputKind::Labels) {
    const auto t0 = Clock::now();
    labelled = label_stack_masks(run, params.label_partition);
    result.times.contour += seconds_since(t0);
  }
  const std::vector<std::uint32_t> asked = objects_to_reconstruct(run, labelled ? &*labelled : nullptr);
  // A partition needs every label (asked or not) and their union (last).
  const bool partition = labelled && params.label_partition && labelled->objects.size() >= 2 && !asked.empty();
  std::vector<std::uint32_t> labels = asked;
  if (partition) {
    labels.clear();
    for (const auto& [label, o] : labelled->objects) labels.push_back(label);
  }
  // Each object's masks, then its stages: objects are independent, so they
  // run side by side unless a callback sees them object by object (stage
  // fields, planes, samples) or they form a partition; each keeps its own
  // warnings and times, joined in label order, so the result is the serial one.
  const std::size_t n = labels.size() + (partition ? 1 : 0);
  std::vector<ObjectResult> objects(n);
  std::vector<std::vector<detail::PackedMasks>> masks(n);
  std::vector<ReconstructResult> parts(n);
  for (std::size_t l = 0; l < n; ++l) {
    const Run part{stack, params, options, parts[l], l < labels.size() ? labels[l] : 0};
    ObjectResult& obj = objects[l];
    const auto t0 = Clock::now();
    if (l == labels.size()) {  // the union
      masks[l] = label_contours(part, std::move(*labelled->uni), obj);
    } else if (labelled) {
      obj.label = labels[l];
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
  auto finish = [&](std::size_t l) {
    const Run part{stack, params, options, parts[l], objects[l].label};
    try {
      decimate_stage(part, objects[l]);
      check_stage(part, objects[l]);
    } catch (...) {
      errors[l] = std::current_exception();
    }
  };
  if (partition) {
    std::vector<PartitionObject> po;
    for (std::size_t l = 0; l < n; ++l) po.push_back({Run{stack, params, options, parts[l], objects[l].label}, objects[l], std::move(masks[l])});
    partition_stages(run, po);
    tbb::parallel_for(std::size_t(0), labels.size(), finish);
    for (std::size_t l = 0; l < labels.size(); ++l)
      if (errors[l]) std::rethrow_exception(errors[l]);
    // The asked labels, in order; the other competitors' and the union's results are dropped.
    for (std::size_t l = 0; l < n; ++l) {
      for (auto& w : parts[l].warnings) result.warnings.push_back(std::move(w));
      result.times += parts[l].times;
    }
    for (const std::uint32_t label : asked)
      result.objects.push_back(objects[std::size_t(std::find(labels.begin(), labels.end(), label) - labels.begin())]);
    return result;
  }
  auto stages = [&](std::size_t l) {
    const Run part{stack, params, options, parts[l], labels[l]};
    ObjectResult& obj = objects[l];
    try {
      if (obj.slices_with_contours == 0) {
        part.warn(object_name(obj.label) + ": no slice has an inside; nothing to reconstruct");
        return;
      }
      stream_stages(part, std::move(masks[l]), obj);
    } catch (...) {
      errors[l] = std::current_exception();
      return;
    }
    finish(l);
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
