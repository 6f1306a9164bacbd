#include "isoloft/mesh/stream_mesher.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "isoloft/core/error.h"

namespace isoloft {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// `g` inside a border of `outside` into `out`. An `out` of the padded size
// is a plane this mesher padded before (its border holds `outside` already):
// only the inside rows are written.
template <class T>
void pad_into(const Grid2<T>& g, T outside, Grid2<T>& out) {
  if (out.width != g.width + 2 || out.height != g.height + 2) out = Grid2<T>(g.width + 2, g.height + 2, outside);
  for (int y = 0; y < g.height; ++y) std::copy_n(&g(0, y), g.width, &out(1, y + 1));
}

// pad_into(), but only the pixels `runs` of g copied (the others of `out`
// are left as they are).
void pad_runs_into(const Grid2f& g, float outside, const PixelRuns& runs, Grid2f& out) {
  if (out.width != g.width + 2 || out.height != g.height + 2) out = Grid2f(g.width + 2, g.height + 2, outside);
  for (int y = 0; y < g.height; ++y)
    for (std::int32_t r = runs.first[std::size_t(y)]; r < runs.first[std::size_t(y) + 1]; ++r) {
      const auto [x0, x1] = runs.runs[std::size_t(r)];
      std::copy_n(&g(x0, y), x1 - x0, &out(x0 + 1, y + 1));
    }
}

template <class T>
Grid2<T> pad(const Grid2<T>& g, T outside) {
  Grid2<T> out;
  pad_into(g, outside, out);
  return out;
}

}  // namespace

// The padded side maps of the last two knot intervals, one slot per interval
// parity: consecutive layers share an interval.
class StreamMesher::SideCache {
 public:
  SideCache(const PlaneSource& field, float iso, std::int8_t pad_side) : field_(field), iso_(iso), pad_side_(pad_side) {}

  const Grid2<std::int8_t>& of(std::size_t k) {
    if (interval_[k % 2] != k) {
      field_.sides(k, iso_, kSideMargin, knot_sides_);
      padded_[k % 2] = pad(knot_sides_, pad_side_);
      interval_[k % 2] = k;
    }
    return padded_[k % 2];
  }

 private:
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  const PlaneSource& field_;
  float iso_;
  std::int8_t pad_side_;
  std::array<std::size_t, 2> interval_{kNone, kNone};
  std::array<Grid2<std::int8_t>, 2> padded_;
  Grid2<std::int8_t> knot_sides_;
};

std::vector<double> sample_planes(double z_begin, double z_end, double step) {
  if (!(step > 0)) throw ParamError("interp.z_step must be positive");
  if (!(z_end > z_begin)) throw ParamError("sample_planes: empty z range");
  const long n = long(std::ceil((z_end - z_begin) / step - 1e-9));
  std::vector<double> z;
  z.reserve(std::size_t(n) + 1);
  for (long j = 0; j < n; ++j) z.push_back(z_begin + double(j) * step);
  z.push_back(z_end);
  return z;
}

// A slice within this share of a step of a plane of the z_step grid is on it
// (the knots' own rounding: z read as decimal strings, then scaled).
constexpr double kOnGridSteps = 1e-6;

std::vector<double> mesh_planes(const std::vector<double>& z, const InterpParams& interp) {
  if (!interp.planes_on_slices || z.size() < 3) return sample_planes(z.front(), z.back(), interp.z_step);
  if (!(interp.z_step > 0)) throw ParamError("interp.z_step must be positive");
  const double anchor = z[1];
  auto on_grid = [&](double step) {
    for (std::size_t k = 2; k + 1 < z.size(); ++k) {
      const double j = (z[k] - anchor) / step;
      if (std::abs(j - std::round(j)) > kOnGridSteps) return false;
    }
    return true;
  };
  // A slice off the z_step grid (a spacing not a multiple of z_step, or
  // uneven spacing) would be cut between planes, its section interpolated
  // linearly across it: an island drawn on that slice alone can vanish
  // (issue 38: BODY on a 0.94 mm grid, its planes 3 mm apart). Evenly spaced
  // slices then get the largest step below z_step that divides their
  // spacing (still one step throughout, as --volume's NRRD needs); uneven
  // ones each knot interval split into equal steps of at most z_step.
  double step = interp.z_step;
  if (!on_grid(step) && z.size() > 3) {
    const double spacing = z[2] - z[1];
    const double divided = spacing / std::ceil(spacing / step - 1e-9);
    if (on_grid(divided)) step = divided;
  }
  if (on_grid(step)) {
    // No tolerance below and above: the first and last planes must be outside the caps.
    const long below = long(std::ceil((anchor - z.front()) / step)), above = long(std::ceil((z.back() - anchor) / step));
    std::vector<double> planes;
    planes.reserve(std::size_t(below + above + 1));
    for (long j = -below; j <= above; ++j) planes.push_back(anchor + double(j) * step);
    return planes;
  }
  std::vector<double> planes{z.front()};
  for (std::size_t k = 0; k + 1 < z.size(); ++k) {
    const long n = std::max(1L, long(std::ceil((z[k + 1] - z[k]) / step - 1e-9)));
    for (long i = 1; i < n; ++i) planes.push_back(z[k] + (z[k + 1] - z[k]) * double(i) / double(n));
    planes.push_back(z[k + 1]);
  }
  return planes;
}

StreamMeshResult mesh_interpolated_field(const ZInterpolator& field, const std::vector<double>& planes, double x0,
                                         double y0, const MarchingCubesParams& mc, const StreamMeshOptions& options) {
  WholeField whole(field);
  return mesh_interpolated_field(whole, planes, x0, y0, mc, options);
}

StreamMesher::StreamMesher(const PlaneSource& field, double x0, double y0, const MarchingCubesParams& mc,
                           StreamMeshOptions options)
    : field_(field),
      options_(std::move(options)),
      sides_(std::make_unique<SideCache>(field, mc.iso, options_.outside < mc.iso - kSideMargin ? std::int8_t(-1)
                                                                                                 : std::int8_t(0))),
      builder_(field.width() + 2, field.height() + 2, x0 - 1.0, y0 - 1.0, mc),
      x0_(x0),
      y0_(y0) {
  if (!(options_.outside <= mc.iso)) throw ParamError("mesh_interpolated_field: the pad value must be outside (<= iso)");
  builder_.spill_into(options_.spill);
  if (!options_.spill && options_.reserve_triangles > 0) builder_.reserve(options_.reserve_triangles);
}

StreamMesher::~StreamMesher() = default;

bool StreamMesher::layer_visit(std::size_t k) {
  // Planes in one or two adjacent knot intervals: the layer may skip cells.
  const bool skip = options_.skip_cells && builder_.planes_added() > 0 && k - k_prev_ <= 1;
  if (skip && visit_for_ != std::array<std::size_t, 2>{k_prev_, k}) {
    const Grid2<std::int8_t>& below = sides_->of(k_prev_);  // k_prev and k use different slots, or are equal
    layer_cells_to_visit(below, sides_->of(k), visit_);
    visit_for_ = {k_prev_, k};
    visited_ = long(std::count(visit_.begin(), visit_.end(), std::uint8_t(1)));
  }
  return skip;
}

const PixelRuns* StreamMesher::needed(std::size_t k, bool next_in_interval) {
  next_needed_ = needed_runs(k, next_in_interval);
  return next_needed_;
}

const PixelRuns* StreamMesher::needed_runs(std::size_t k, bool next_in_interval) {
  // The layer above reads only cells visited in (k, k), a subset of those
  // visited in (k_prev, k): no cell keeps one side over k_prev and k but
  // not over k alone. A next plane in another interval: all pixels.
  if (options_.on_plane || !next_in_interval || !layer_visit(k)) return nullptr;
  if (needed_for_ == visit_for_) return &needed_;  // planes of one interval pair share it
  const auto t0 = Clock::now();
  const int w = field_.width(), h = field_.height(), cw = w + 1;  // visit_: (w + 1) x (h + 1) padded cells
  needed_.first.assign(std::size_t(h) + 1, 0);
  needed_.runs.clear();
  std::vector<std::uint8_t> need(static_cast<std::size_t>(w));
  for (int y = 0; y < h; ++y) {
    // Pixel (x, y) is padded (x + 1, y + 1): a corner of padded cells x, x + 1 in rows y, y + 1.
    const std::uint8_t *c0 = visit_.data() + std::size_t(y) * std::size_t(cw), *c1 = c0 + cw;
    for (int x = 0; x < w; ++x) need[std::size_t(x)] = c0[x] | c0[x + 1] | c1[x] | c1[x + 1];
    const std::uint8_t *b = need.data(), *e = b + w;
    for (const std::uint8_t* p = std::find(b, e, 1); p != e;) {
      const std::uint8_t* q = std::find(p, e, 0);
      needed_.runs.push_back({std::int32_t(p - b), std::int32_t(q - b)});
      p = std::find(q, e, 1);
    }
    needed_.first[std::size_t(y) + 1] = std::int32_t(needed_.runs.size());
  }
  needed_for_ = visit_for_;
  out_.mesh_seconds += seconds_since(t0);
  return &needed_;
}

void StreamMesher::add(const Grid2f& plane, double z, std::size_t k, long count) {
  const auto t0 = Clock::now();
  Grid2f padded = std::move(spare_);
  if (next_needed_) pad_runs_into(plane, options_.outside, *next_needed_, padded);
  else pad_into(plane, options_.outside, padded);
  next_needed_ = nullptr;
  const std::size_t j = std::size_t(builder_.planes_added());
  if (options_.on_plane) options_.on_plane(padded, x0_ - 1.0, y0_ - 1.0, z, int(j), int(count));
  const bool skip = layer_visit(k);
  if (j > 0) {
    const long layer = long(field_.width() + 1) * long(field_.height() + 1);
    out_.cells += layer;
    out_.cells_visited += skip ? visited_ : layer;
  }
  builder_.add_plane(std::move(padded), z, skip ? &visit_ : nullptr, &spare_);
  k_prev_ = k;
  out_.mesh_seconds += seconds_since(t0);
  if (options_.progress) options_.progress(long(j + 1), count);
}

StreamMeshResult StreamMesher::finish() {
  const auto t0 = Clock::now();
  out_.mesh = builder_.finish();
  out_.mesh_seconds += seconds_since(t0);
  return std::move(out_);
}

StreamMeshResult mesh_interpolated_field(PlaneSource& field, const std::vector<double>& planes, double x0, double y0,
                                         const MarchingCubesParams& mc, const StreamMeshOptions& options) {
  if (planes.size() < 2) throw ParamError("mesh_interpolated_field: needs at least 2 planes");
  StreamMesher mesher(field, x0, y0, mc, options);
  Grid2f plane(field.width(), field.height());
  double interp_seconds = 0;
  long pixels = 0, evaluated = 0;
  const long count = long(planes.size());
  for (std::size_t j = 0; j < planes.size(); ++j) {
    const double z = planes[j];
    const std::size_t k = field.interval(z);
    field.reach(k);  // untimed: a stream's knots may be computed here
    const bool next_in_interval = j + 1 == planes.size() || field.interval(planes[j + 1]) == k;
    const PixelRuns* only = mesher.needed(k, next_in_interval);
    const auto t0 = Clock::now();
    if (only)
      field.evaluate_runs(z, plane, *only);
    else
      field.evaluate(z, plane);
    interp_seconds += seconds_since(t0);
    pixels += long(plane.size());
    evaluated += only ? only->pixels() : long(plane.size());
    mesher.add(plane, z, k, count);
  }
  StreamMeshResult out = mesher.finish();
  out.interp_seconds = interp_seconds;
  out.pixels = pixels;
  out.pixels_evaluated = evaluated;
  return out;
}

}  // namespace isoloft
