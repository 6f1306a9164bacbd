// @file partition/partition.cpp
// @brief The label partition (partition/partition.h): the union's field from
// the labels' knots, the competition at each height, the cell sides that let
// the mesher skip.
#include "isoloft/partition/partition.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>

#include "isoloft/core/error.h"
#include "isoloft/methods/method.h"
#include "isoloft/mesh/mesh_spill.h"
#include "isoloft/mesh/stream_mesher.h"
#include "isoloft/methods/columns/column_stream.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft::detail {

namespace {

// Intervals per z block of every label's and the union's columns stream
// (kZStreamBlock alone: 8): streamed in lockstep, every label holds its
// block's knots and tangents at once, (block + 2 reach + 1) x 2 fields, so a
// short block bounds the partition's fields; its tangents are recomputed
// over more overlap (the same values: the same knots within reach).
constexpr std::size_t kPartitionZBlock = 2;

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
  // Row blocks side by side (it runs between the labels' parallel loops):
  // each pixel sees the labels in order, as one pass would.
  void compute(const std::vector<Grid2f>& phi, const std::vector<PixelBox>& boxes, std::size_t labels) {
    const Grid2f& uni = phi[labels];
    const PixelBox& ubox = boxes[labels];
    const int w = uni.width;
    if (top1.width != w || top1.height != uni.height) {
      top1 = top2 = Grid2f(w, uni.height);
      who = Grid2<std::int32_t>(w, uni.height);
    }
    tbb::parallel_for(tbb::blocked_range<int>(0, uni.height, kCompetitionRows), [&](const tbb::blocked_range<int>& rows) {
      for (int uy = rows.begin(); uy < rows.end(); ++uy) {
        const std::size_t row = std::size_t(uy) * std::size_t(w);
        const float* u = uni.data.data() + row;
        float* t1 = top1.data.data() + row;
        float* t2 = top2.data.data() + row;
        std::int32_t* wh = who.data.data() + row;
        for (int x = 0; x < w; ++x) t1[x] = -u[x];
        std::fill(t2, t2 + w, -std::numeric_limits<float>::infinity());
        std::fill(wh, wh + w, std::int32_t(-1));
        for (std::size_t l = 0; l < labels; ++l) {
          const PixelBox& b = boxes[l];
          const int y = uy + ubox.y0 - b.y0;
          if (y < 0 || y >= b.height()) continue;
          const float* f = &phi[l](0, y);
          const std::size_t dx = std::size_t(b.x0 - ubox.x0);
          for (int x = 0; x < b.width(); ++x) {
            const float v = f[x];
            const std::size_t ux = dx + std::size_t(x);
            if (v > t1[ux]) {
              t2[ux] = t1[ux], t1[ux] = v, wh[ux] = std::int32_t(l);
            } else if (v > t2[ux]) {
              t2[ux] = v;
            }
          }
        }
      }
    });
  }

  // Label l's partition field over its box: its field minus the best other.
  // A tie goes to the first label in order: the highest's value is at least
  // the least positive float, so exactly one label claims every point.
  // Every value of `out` is written: its storage kept from plane to plane.
  void psi(std::size_t l, const Grid2f& phi, const PixelBox& b, const PixelBox& ubox, Grid2f& out) const {
    if (out.width != b.width() || out.height != b.height()) out = Grid2f(b.width(), b.height());
    for (int y = 0; y < b.height(); ++y)
      for (int x = 0; x < b.width(); ++x) {
        const int ux = x + b.x0 - ubox.x0, uy = y + b.y0 - ubox.y0;
        out(x, y) = who(ux, uy) == std::int32_t(l) ? std::max(phi(x, y) - top2(ux, uy), kTieWinner)
                                                   : phi(x, y) - top1(ux, uy);
      }
  }
  static constexpr float kTieWinner = std::numeric_limits<float>::denorm_min();
  // Rows of the union's box per task of compute(): a few tasks per thread
  // on a few-hundred-row box.
  static constexpr int kCompetitionRows = 16;
};

// The union's healing (union_healing) of slices [s0, s1), handed out in
// order; each batch of `window` slices computed ahead as a task of the run's
// arena, as the labels' slice fields are (SliceFields), so the loop that
// waits for the union's knots does not compute it. The label images come
// from the labels' inside runs (copied from their masks), not decoded again.
class HealingAhead {
 public:
  // runs[s]: every label's inside runs of slice s (label, runs).
  using SliceRuns = std::vector<std::pair<std::uint32_t, std::vector<std::uint32_t>>>;
  HealingAhead(std::vector<SliceRuns> runs, int image_width, const PixelBox& box, std::size_t s0, std::size_t s1,
               std::size_t window)
      : runs_(std::move(runs)), width_(image_width), box_(box), next_(s0), s1_(s1), window_(std::max<std::size_t>(1, window)) {}
  ~HealingAhead() {
    if (ahead_) cancel_batch(group_);
  }
  HealingAhead(const HealingAhead&) = delete;
  HealingAhead& operator=(const HealingAhead&) = delete;

  Grid2f take(std::size_t s) {
    if (s != next_ || s >= s1_) throw Error("HealingAhead::take: slices out of order");
    if (ready_.empty()) compute(s);
    Grid2f h = std::move(ready_.front());
    ready_.pop_front();
    ++next_;
    return h;
  }

 private:
  Grid2f one(std::size_t s) {
    std::vector<LabelRuns> r;
    for (const auto& [label, inside] : runs_[s]) r.push_back({label, &inside});
    Grid2f h = union_healing(labels_around_box(r, width_, box_));
    SliceRuns().swap(runs_[s]);
    return h;
  }
  void start(std::size_t k0) {
    const std::size_t k1 = std::min(s1_, k0 + window_);
    ahead_ = k0;
    batch_.assign(k1 - k0, Grid2f());
    group_.run([this, k0, k1] { tbb::parallel_for(k0, k1, [&](std::size_t s) { batch_[s - k0] = one(s); }); });
  }
  void compute(std::size_t k0) {
    if (ahead_ && *ahead_ != k0) throw Error("HealingAhead::compute: batch out of order");
    if (!ahead_) start(k0);
    ahead_.reset();
    group_.wait();  // rethrows the batch's error
    ready_.assign(std::make_move_iterator(batch_.begin()), std::make_move_iterator(batch_.end()));
    batch_.clear();
    if (const std::size_t k1 = k0 + ready_.size(); k1 < s1_) start(k1);
  }

  std::vector<SliceRuns> runs_;
  int width_;
  PixelBox box_;
  std::size_t next_, s1_, window_;
  std::optional<std::size_t> ahead_;
  std::vector<Grid2f> batch_;
  std::deque<Grid2f> ready_;
  tbb::task_group group_;
};

// The labels' union as a field, from the labels' own knots: knot i is the
// highest label knot i at each pixel, plus, inside the union, how much
// farther the union's edge is than the pixel's own label's edge
// (union_healing): zero wherever a label meets only the background, so
// there the union's field is its label's, and deep across the boundaries
// between labels, so the union does not dip to zero along them. The labels'
// streams deposit each knot as they pull it (before the union pulls it: the
// same knots, in lockstep).
class UnionStream {
 public:
  // first_knot: the labels' streams' (a z slab's); runs: as HealingAhead's,
  // every slice's.
  UnionStream(const Run& run, ObjectResult& obj, std::size_t labels, std::size_t first_knot,
              std::vector<HealingAhead::SliceRuns> runs)
      : run_(run), obj_(obj), labels_(labels), z_(knot_z(run)), next_(first_knot) {
    z_.erase(z_.begin(), z_.begin() + std::ptrdiff_t(first_knot));
    // Knots 1..n are the slices (0 and n + 1 the end caps: no healing).
    const std::size_t last_knot = first_knot + z_.size() - 1;
    healing_.emplace(std::move(runs), run.stack.width, obj.box, first_knot - std::min<std::size_t>(first_knot, 1),
                     std::min(run.slices(), last_knot), std::max(kPartitionZBlock, partition_slice_window(labels)));
    stream_ = z_scheme_spec(run.params.z_scheme)
                  .make(ZSchemeInput{z_, obj.box.width(), obj.box.height(), [this] { return next(); }, &count_,
                                     kPartitionZBlock},
                        run.params);
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
    if (i >= 1 && i <= run_.slices()) {
      const Grid2f h = healing_->take(i - 1);
      for (std::size_t j = 0; j < h.size(); ++j) d.field.data[j] += h.data[j];
    }
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
  std::optional<HealingAhead> healing_;
  std::unique_ptr<PlaneSource> stream_;
};

}  // namespace

namespace {

// partition_stages, the labels' fields banded by `band` (its partition set) if given.
void partition_stages_once(const Run& run, std::vector<PartitionObject>& objects,
                           const std::optional<FieldBand::Setup>& band) {
  const std::size_t labels = objects.size() - 1;
  std::vector<PixelBox> boxes(labels + 1);
  for (std::size_t i = 0; i <= labels; ++i) boxes[i] = objects[i].obj.box;
  const PixelBox& ubox = boxes[labels];
  const std::vector<double> all_knots = knot_z(run);
  const SlabRange range =
      slab_range(run, all_knots, mesh_planes(all_knots, run.params.interp), std::vector<char>(run.slices(), 0));
  std::vector<HealingAhead::SliceRuns> runs(run.slices());
  for (std::size_t l = 0; l < labels; ++l)
    for (std::size_t k = 0; k < run.slices(); ++k)
      if (!objects[l].masks[k].empty) runs[k].emplace_back(objects[l].obj.label, objects[l].masks[k].inside);
  UnionStream uni(objects[labels].run, objects[labels].obj, labels, range.first_knot, std::move(runs));
  std::vector<std::unique_ptr<ObjectStream>> streams(labels);
  for (std::size_t l = 0; l < labels; ++l) {
    std::optional<FieldBand::Setup> own = band;
    if (own) own->label = l;
    streams[l] = std::make_unique<ObjectStream>(
        objects[l].run, objects[l].obj, std::move(objects[l].masks),
        [&uni, box = boxes[l]](std::size_t i, const Grid2f& f) { uni.deposit(i, f, box); }, own,
        partition_slice_window(labels), kPartitionZBlock);
  }
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
  // Every label's mesh grows until the last plane: out of memory meanwhile
  // when the objects are written one by one (on_object) anyway.
  std::vector<std::shared_ptr<MeshSpill>> spills(labels);
  const bool spill = run.options.on_object && !run.options.scratch_dir.empty();
  bounds.reserve(labels);
  for (std::size_t l = 0; l < labels; ++l) {
    bounds.emplace_back(streams[l]->field(), boxes[l], union_sides, ubox);
    StreamMeshOptions o = mesh_options(objects[l].run, objects[l].obj);
    o.progress = nullptr;  // once per plane for all labels, below
    if (spill) o.spill = (spills[l] = std::make_shared<MeshSpill>(run.options.scratch_dir)).get();
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
  for (std::size_t l = 0; l < labels; ++l) {
    objects[l].obj.spilled = spills[l];
    streams[l]->finish(meshers[l]->finish(), seconds[l]);
  }
  uni.finish(seconds[labels]);
}

}  // namespace

// Stages (paper 2.1-2.5 but decimation) of a label partition
// (ReconstructParams::label_partition): every label's field and the union's
// streamed in lockstep; at every plane and sample height label l's field
// becomes psi_l = phi_l - max(phi_m (m != l), -phi_union), positive where l's
// field is the highest of the labels' and the background's. So neighbours l
// and m share the zero set of psi_l = -psi_m = phi_l - phi_m, a point inside
// the union goes to its nearest label, and a label that meets only the
// background keeps its own surface (there phi_union = phi_l). The union (the
// last object) is not meshed. The labels' fields are exact only where some
// label's side is unknown or changes (PartitionCrossings) unless a hook sees
// them or the options ask for whole fields; a label's empty mesh makes them
// all again with whole fields (its reason quotes its fields' maximum).
void partition_stages(const Run& run, std::vector<PartitionObject>& objects) {
  const std::size_t labels = objects.size() - 1;
  const ReconstructOptions& o = run.options;
  std::optional<FieldBand::Setup> band;
  if (!(o.on_slice_fields || o.on_plane || o.on_sample || o.whole_fields))
    for (std::size_t l = 0; l < labels; ++l)
      if (!(band = field_band_setup(run.params, run.stack.kind, objects[l].masks))) break;
  if (!band) return partition_stages_once(run, objects, std::nullopt);
  std::vector<std::vector<PackedMasks>> masks(labels);
  std::vector<PixelBox> boxes(labels);
  for (std::size_t l = 0; l < labels; ++l) masks[l] = objects[l].masks, boxes[l] = objects[l].obj.box;
  band->partition = std::make_shared<PartitionCrossings>(std::move(masks), std::move(boxes), objects[labels].obj.box, *band);
  // Each object's warnings and times kept apart until the banded run stands.
  std::vector<ReconstructResult> parts(objects.size());
  std::vector<ObjectResult> before;
  std::vector<PartitionObject> banded;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const Run& r = objects[i].run;
    before.push_back(objects[i].obj);
    banded.push_back({Run{r.stack, r.params, r.options, parts[i], r.label}, objects[i].obj, objects[i].masks});
  }
  partition_stages_once(run, banded, band);
  const auto empty = [](const PartitionObject& p) {
    return p.obj.mesh.triangles.empty() && !(p.obj.spilled && p.obj.spilled->triangles() > 0);
  };
  if (o.z_slab.count == 1 && std::any_of(banded.begin(), banded.end() - 1, empty)) {
    for (std::size_t i = 0; i < objects.size(); ++i) objects[i].obj = before[i];
    return partition_stages_once(run, objects, std::nullopt);
  }
  for (std::size_t i = 0; i < objects.size(); ++i) {
    for (auto& w : parts[i].warnings) objects[i].run.warn(std::move(w));
    objects[i].run.result.times += parts[i].times;
  }
}

}  // namespace isoloft::detail
