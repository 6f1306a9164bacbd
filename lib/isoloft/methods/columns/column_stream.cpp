// @file methods/columns/column_stream.cpp
// @brief The column streaming engine (methods/columns/column_stream.h): SliceFields,
// KnotFeed, ObjectStream, the samples served on the way.
#include "isoloft/methods/columns/column_stream.h"

#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <deque>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/core/scratch_file.h"
#include "isoloft/mesh/mesh_spill.h"
#include "isoloft/methods/method.h"
#include "isoloft/methods/columns/slice_methods.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft::detail {

namespace {

// Slices below its own an isolated empty slice reads under a local rule:
// `fields` whole (kept by the feed), `values` at least (their lowest values).
struct ReadsBelow {
  std::size_t fields, values;
};
ReadsBelow isolated_reads_below(IsolatedEmpty rule) {
  switch (rule) {
    case IsolatedEmpty::Secant:
      return {2, 2};
    case IsolatedEmpty::Neighbours:
      return {1, kIsolatedNeighbourSlices};
    default:
      return {1, 1};
  }
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
    run.warn(run.stack.slices[k].source + ": " + what + " has fewer than " + std::to_string(kMinMpuPoints) +
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
  // band: the fields are exact only where they reach the mesh (methods/columns/field_band.h).
  // window: slices computed at once (0: slice_window()).
  // first: the first slice handed out (a z slab's).
  SliceFields(const Run& run, ObjectResult& obj, std::vector<PackedMasks>& masks, ResidentCount& count,
              const std::optional<FieldBand::Setup>& band, std::size_t window, std::size_t first = 0)
      : run_(run),
        obj_(obj),
        masks_(masks),
        count_(count),
        window_(window > 0 ? window : slice_window()),
        method_(method_spec(run.params.method.name())) {
    if (band) band_.emplace(masks, obj.box, *band);
    next_ = first;
  }
  ~SliceFields() {
    if (ahead_) cancel_batch(group_);
  }
  SliceFields(const SliceFields&) = delete;
  SliceFields& operator=(const SliceFields&) = delete;

  // Slice k's field (empty for an empty slice), k = first, first + 1, ... in order; its
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
    const SliceMasks m = unpack_masks(masks_[k]);
    masks_[k] = {};
    const std::optional<SliceBand> band = band_ ? band_->band(k) : std::nullopt;
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
  std::vector<PackedMasks>& masks_;  // slice k's dropped once computed
  ResidentCount& count_;
  std::size_t window_;
  const MethodSpec& method_;
  std::optional<FieldBand> band_;
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
// slice's field (empty slices closed as fill_empty_slices does), the
// end cap above. Holds a slice's field while a neighbour may still need it.
// An empty slice with no non-empty neighbour (InterpParams::isolated_empty):
// Lowest takes the lowest value of all the object's fields, so the feed
// computes them all before it: with a scratch folder those not needed yet
// wait on disk (parked) until their knot; the local rules read fields within
// kIsolatedNeighbourSlices.
class KnotFeed {
 public:
  // z: the knot heights (knot_z: slice k at z[k + 1]). scratch_dir: "" holds
  // the fields computed early in memory. range: the first knot (0 or >= 2)
  // and the first slice SliceFields hands out (at most the knot's slice - 1).
  KnotFeed(SliceFields& slices, const std::vector<char>& empty, const std::vector<double>& z, const PixelBox& box,
           const InterpParams& interp, ResidentCount& count, std::string scratch_dir, const SlabRange& range = {})
      : slices_(slices), empty_(empty), z_(z), box_(box), interp_(interp), count_(count), scratch_dir_(std::move(scratch_dir)),
        raw_first_(range.first_slice), knot_(range.first_knot) {
    if (knot_ == 1 || (knot_ > 1 && raw_first_ + 2 > knot_)) throw Error("KnotFeed: a slab's first knot or slice is out of place");
    const auto last = std::find(empty.rbegin(), empty.rend(), char(0));
    last_nonempty_ = std::size_t(empty.rend() - last) - 1;
    if (interp.isolated_empty == IsolatedEmpty::Neighbours) lows_.resize(empty.size(), -1.0f);
  }
  ~KnotFeed() { count_.remove(held_ + long(!pending_.empty()) + long(!before_.empty())); }
  KnotFeed(const KnotFeed&) = delete;
  KnotFeed& operator=(const KnotFeed&) = delete;

  Grid2f next() {
    // A slab's slices below those its first knot reads (slab_range): only
    // their lowest values.
    for (; raw_.empty() && raw_first_ + 1 + raw_below() < knot_; ++raw_first_) {
      const Grid2f f = slices_.take(raw_first_);
      lowest_ = most_negative(lowest_, f);
      if (!lows_.empty()) lows_[raw_first_] = most_negative(-1.0f, f);
      count_.remove(1);
    }
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
  // Slices below its own whose fields a slice's knot reads: its neighbour;
  // Secant, the one beyond.
  [[nodiscard]] std::size_t raw_below() const { return isolated_reads_below(interp_.isolated_empty).fields; }

  [[nodiscard]] bool follows_trend() const {
    return interp_.cap_shape == CapShape::Slab || interp_.cap_shape == CapShape::Round;
  }

  // Slice k's raw field, pulling slices up to k (parked ones read back).
  Grid2f& raw(std::size_t k) {
    pull(k, false);
    const std::size_t i = k - raw_first_;
    if (where_[i] >= 0) {
      Grid2f& f = raw_[i];
      f = Grid2f(box_.width(), box_.height());
      park_->read(where_[i], f.data.data(), f.size() * sizeof(float));
      where_[i] = kHeld;
      ++held_;
      count_.add(1);
    }
    return raw_[i];
  }

  // Pulls the raw fields up to slice k; `park`: a non-empty one goes to the
  // scratch file (when there is a folder) until raw() asks for it. An empty
  // slice's field holds nothing: not counted.
  void pull(std::size_t k, bool park) {
    while (raw_first_ + raw_.size() <= k) {
      const std::size_t j = raw_first_ + raw_.size();
      raw_.push_back(slices_.take(j));
      Grid2f& f = raw_.back();
      lowest_ = most_negative(lowest_, f);
      if (!lows_.empty()) lows_[j] = most_negative(-1.0f, f);
      where_.push_back(f.empty() ? kNothing : kHeld);
      if (f.empty()) {
        count_.remove(1);
        continue;
      }
      ++held_;
      if (!park || scratch_dir_.empty()) continue;
      if (f.width != box_.width() || f.height != box_.height()) throw Error("KnotFeed: a slice field is not the object's box");
      if (!park_) park_.emplace(scratch_dir_, "the slice fields computed ahead");
      where_.back() = park_->size();
      park_->append(f.data.data(), f.size() * sizeof(float));
      f = Grid2f();
      --held_;
      count_.remove(1);
    }
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
      EmptyNeighbours nb;  // deque references survive push_back
      nb.above = k + 1 < n ? &raw(k + 1) : nullptr;
      nb.below = k > 0 ? &raw(k - 1) : nullptr;
      nb.gap_below = k > 0 ? z_[k + 1] - z_[k] : 0.0;
      nb.gap_above = k + 1 < n ? z_[k + 2] - z_[k + 1] : 0.0;
      const bool isolated = (!nb.above || nb.above->empty()) && (!nb.below || nb.below->empty());
      float lowest = -1.0f;  // what Lowest and Neighbours read
      if (isolated) switch (interp_.isolated_empty) {
          case IsolatedEmpty::Lowest:
            // The most negative value of all fields: pull the slices up to the
            // last non-empty one first, parked until the feed reaches them.
            if (last_nonempty_ > k) pull(last_nonempty_, true);
            lowest = lowest_;
            break;
          case IsolatedEmpty::Neighbours: {
            const std::size_t r = kIsolatedNeighbourSlices, hi = std::min(n - 1, k + r);
            pull(hi, false);
            for (std::size_t j = k - std::min(k, r); j <= hi; ++j) lowest = std::min(lowest, lows_[j]);
            break;
          }
          case IsolatedEmpty::Secant:
            nb.below2 = k > 1 ? &raw(k - 2) : nullptr;
            nb.above2 = k + 2 < n ? &raw(k + 2) : nullptr;
            nb.gap_below2 = k > 1 ? z_[k] - z_[k - 1] : 0.0;
            nb.gap_above2 = k + 2 < n ? z_[k + 3] - z_[k + 2] : 0.0;
            break;
          case IsolatedEmpty::Depth:
          case IsolatedEmpty::Box:
            break;
        }
      out = empty_slice_field(nb, lowest, box_, interp_);
    }
    // Slices below k - raw_below() + 1 are no longer read.
    for (; raw_first_ + raw_below() < k + 1; ++raw_first_) {
      if (where_.front() == kHeld) {
        --held_;
        count_.remove(1);
      }
      raw_.pop_front();
      where_.pop_front();
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
  // Per raw_ entry: its offset in park_, or kHeld (in memory), kNothing (empty).
  static constexpr std::int64_t kHeld = -1, kNothing = -2;
  std::deque<std::int64_t> where_;
  long held_ = 0;  // raw_ entries in memory and counted
  std::string scratch_dir_;
  std::optional<ScratchFile> park_;
  std::size_t raw_first_ = 0;
  float lowest_ = -1.0f;  // most_negative of the slices pulled
  std::vector<float> lows_;  // Neighbours: per slice pulled, most_negative(-1, its field)
  std::size_t knot_ = 0;  // the next knot given
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

}  // namespace

// The knot heights: the slices' z and the end caps' (add_end_caps; a cap of
// an empty field is empty).
std::vector<double> knot_z(const Run& run) {
  std::vector<double> z(run.slices());
  for (std::size_t k = 0; k < z.size(); ++k) z[k] = run.stack.slices[k].z;
  std::vector<Grid2f> none(z.size());
  add_end_caps(none, z, run.params.interp);
  return z;
}

SlabRange slab_range(const Run& run, const std::vector<double>& knots, const std::vector<double>& planes,
                     const std::vector<char>& empty) {
  const ZSlab& slab = run.options.z_slab;
  SlabRange r;
  r.plane_end = planes.size();
  if (slab.count == 1 && slab.index == 0) return r;
  const std::string which = "z slab " + std::to_string(slab.index + 1) + " of " + std::to_string(slab.count);
  if (slab.index >= slab.count) throw ParamError(which + ": no such slab");
  const std::optional<std::size_t> reach = tangent_reach(run.params.interp.spline);
  if (run.params.z_scheme != "columns" || !reach)
    throw ParamError(which + ": z slabs need the columns z scheme and a spline of finite tangent reach (not natural)");
  // Cut c: the last plane at or below slice c * n / count.
  const std::size_t n = empty.size();
  const auto cut = [&](std::size_t c) -> std::size_t {
    if (c == 0) return 0;
    if (c == slab.count) return planes.size() - 1;
    const double z = knots[c * n / slab.count + 1];
    return std::size_t(std::upper_bound(planes.begin(), planes.end(), z) - planes.begin()) - 1;
  };
  for (std::size_t c = 0; c < slab.count; ++c)
    if (!(cut(c) < cut(c + 1)))
      throw ParamError(which + ": two cuts fall on one plane (" + std::to_string(n) + " slices, " +
                       std::to_string(planes.size()) + " planes): use fewer slabs");
  r.plane_begin = cut(slab.index);
  r.plane_end = cut(slab.index + 1) + 1;
  if (slab.index == 0) return r;
  // Tangents within reach of the slab's first interval are the whole
  // column's; one knot more for the interval a plane on a knot falls in.
  const std::size_t j = knot_interval(knots, planes[r.plane_begin]), halo = *reach + 2;
  r.first_knot = j >= halo + 2 ? j - halo : 0;
  // The knot of slice k - 1 reads slices k - 2 and k, an isolated empty
  // slice's as interp.isolated_empty says: Lowest reads the lowest value of
  // every field.
  const IsolatedEmpty rule = run.params.interp.isolated_empty;
  bool isolated = false;
  for (std::size_t k = 0; k < n && !isolated && rule == IsolatedEmpty::Lowest; ++k)
    isolated = empty[k] && (k == 0 || empty[k - 1]) && (k + 1 == n || empty[k + 1]);
  const std::size_t below = 1 + isolated_reads_below(rule).values;  // the first knot's slice is first_knot - 1
  r.first_slice = isolated || r.first_knot < below ? 0 : r.first_knot - below;
  return r;
}

namespace {
// Whether the knots span less than one plane step: nothing to mesh.
bool thinner_than_a_step(const std::vector<double>& z, double step) { return (z.back() - z.front()) / step < 1 - 1e-9; }
}  // namespace

// One object's interpolated field, streamed (paper 2.1-2.4): the slice fields
// computed a window at a time, the knot feed, the z scheme's plane source;
// only the packed masks are kept for every slice.
class ObjectStream::Impl {
 public:
  Impl(const Run& run, ObjectResult& obj, std::vector<PackedMasks> masks, KnotTap tap = {},
               const std::optional<FieldBand::Setup>& band = std::nullopt, std::size_t window = 0, std::size_t z_block = 0)
      : run_(run), obj_(obj), masks_(std::move(masks)), empty_(masks_.size()), knots_(knot_z(run)), tap_(std::move(tap)) {
    const ReconstructParams& p = run.params;
    for (std::size_t k = 0; k < masks_.size(); ++k) empty_[k] = masks_[k].empty;
    if (thinner_than_a_step(knots_, p.interp.z_step)) {
      std::ostringstream o;
      o << "the slices span " << knots_.back() - knots_.front() << " px in z (end caps included), less than one plane step "
        << "interp.z_step = " << p.interp.z_step << " px: nothing to mesh (check " << option_name("--z-spacing")
        << " / the slice z)";
      throw InputError(run.stack.slices.front().source, o.str());
    }
    const std::vector<double> all = mesh_planes(knots_, p.interp);
    range_ = slab_range(run, knots_, all, empty_);
    planes_.assign(all.begin() + std::ptrdiff_t(range_.plane_begin), all.begin() + std::ptrdiff_t(range_.plane_end));
    knots_pulled_ = range_.first_knot;
    slices_.emplace(run, obj, masks_, count_, band, window, range_.first_slice);
    feed_.emplace(*slices_, empty_, knots_, obj.box, p.interp, count_, run.options.scratch_dir, range_);
    z_.assign(knots_.begin() + std::ptrdiff_t(range_.first_knot), knots_.end());
    stream_ = z_scheme_spec(p.z_scheme).make(
        ZSchemeInput{z_, obj.box.width(), obj.box.height(), [this] { return next(); }, &count_, z_block}, p);
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  [[nodiscard]] PlaneSource& field() { return *stream_; }
  [[nodiscard]] const std::vector<double>& knots() const { return z_; }
  [[nodiscard]] std::vector<double> planes() const { return planes_; }

  /// The object's mesh and the stream's statistics and times; `interp_seconds`
  /// evaluating planes and samples.
  void finish(StreamMeshResult r, double interp_seconds) {
    const ReconstructParams& p = run_.params;
    obj_.mesh = std::move(r.mesh);
    if (obj_.mesh.triangles.empty() && !(obj_.spilled && obj_.spilled->triangles() > 0)) obj_.empty_reason = empty_reason(run_, slices_->top(), obj_);
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
  std::vector<PackedMasks> masks_;
  std::vector<char> empty_;
  std::vector<double> knots_;  // all (the feed's)
  std::vector<double> z_;      // the stream's: from range_.first_knot
  SlabRange range_;
  std::vector<double> planes_;  // the slab's
  KnotTap tap_;
  std::size_t knots_pulled_ = 0;  // the next knot's index among all
  ResidentCount count_;
  std::optional<SliceFields> slices_;
  std::optional<KnotFeed> feed_;
  std::unique_ptr<PlaneSource> stream_;
};

ObjectStream::ObjectStream(const Run& run, ObjectResult& obj, std::vector<PackedMasks> masks, KnotTap tap,
                           const std::optional<FieldBand::Setup>& band, std::size_t window, std::size_t z_block)
    : impl_(std::make_unique<Impl>(run, obj, std::move(masks), std::move(tap), band, window, z_block)) {}
ObjectStream::~ObjectStream() = default;
PlaneSource& ObjectStream::field() { return impl_->field(); }
const std::vector<double>& ObjectStream::knots() const { return impl_->knots(); }
std::vector<double> ObjectStream::planes() const { return impl_->planes(); }
void ObjectStream::finish(StreamMeshResult r, double interp_seconds) { impl_->finish(std::move(r), interp_seconds); }

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

namespace {

// The mesh's room over the work estimate's triangles: the estimate runs
// 1.5-1.9x below the Marching Cubes triangles on the RT set's ROIs (BODY
// 1.94 M for 2.89 M); room beyond the mesh is never touched, so costs no
// memory, and a mesh beyond it grows as before.
constexpr double kMeshRoomOverEstimate = 2.0;

// Stages (paper 2.1-2.5 but decimation) of one object: its stream meshed
// plane by plane, the fields exact only where they reach the mesh if `band`.
void stream_stages_once(const Run& run, std::vector<PackedMasks> masks, ObjectResult& obj,
                        const std::optional<FieldBand::Setup>& band) {
  const WorkEstimate e = estimate_work(run, masks, obj);
  ObjectStream s(run, obj, std::move(masks), {}, band);
  std::optional<Sampling> sampling;
  if (run.options.on_sample) sampling.emplace(s.field(), run, obj, s.knots());
  PlaneSource& field = sampling ? static_cast<PlaneSource&>(*sampling) : s.field();
  const std::vector<double> planes = s.planes();
  StreamMeshOptions options = mesh_options(run, obj);
  if (e.planes > 0)  // a slab's share of the planes
    options.reserve_triangles =
        std::size_t(kMeshRoomOverEstimate * e.triangles * std::min(1.0, double(planes.size()) / e.planes));
  StreamMeshResult r = mesh_interpolated_field(field, planes, obj.box.x0, obj.box.y0, run.params.mc, options);
  if (sampling) sampling->reach(s.knots().size() - 2);  // any sample the planes did not pass
  const double interp = r.interp_seconds + (sampling ? sampling->seconds() : 0.0);
  s.finish(std::move(r), interp);
}

}  // namespace


// The fields banded (methods/columns/field_band.h) unless a hook sees them or the
// options ask for whole fields. An empty mesh is made again with whole
// fields: its reason quotes the fields' maximum, which a band does not keep.
void stream_stages(const Run& run, std::vector<PackedMasks> masks, ObjectResult& obj) {
  const ReconstructOptions& o = run.options;
  const bool seen = o.on_slice_fields || o.on_plane || o.on_sample || o.whole_fields;
  const std::optional<FieldBand::Setup> band =
      seen ? std::nullopt : field_band_setup(run.params, run.stack.kind, masks);
  if (!band) return stream_stages_once(run, std::move(masks), obj, std::nullopt);
  ReconstructResult part;
  const Run banded{run.stack, run.params, run.options, part, run.label};
  const ObjectResult before = obj;
  stream_stages_once(banded, masks, obj, band);
  if (obj.mesh.triangles.empty() && o.z_slab.count == 1) {
    obj = before;
    return stream_stages_once(run, std::move(masks), obj, std::nullopt);
  }
  for (auto& w : part.warnings) run.warn(std::move(w));
  run.result.times += part.times;
}

}  // namespace isoloft::detail
