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

template <class T>
Grid2<T> pad(const Grid2<T>& g, T outside) {
  Grid2<T> out(g.width + 2, g.height + 2, outside);
  for (int y = 0; y < g.height; ++y) std::copy_n(&g(0, y), g.width, &out(1, y + 1));
  return out;
}

// The padded side maps of the last two knot intervals, one slot per interval
// parity: consecutive layers share an interval.
class SideCache {
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

}  // namespace

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

StreamMeshResult mesh_interpolated_field(const ZInterpolator& field, const std::vector<double>& planes, double x0,
                                         double y0, const MarchingCubesParams& mc, const StreamMeshOptions& options) {
  WholeField whole(field);
  return mesh_interpolated_field(whole, planes, x0, y0, mc, options);
}

StreamMeshResult mesh_interpolated_field(PlaneSource& field, const std::vector<double>& planes, double x0, double y0,
                                         const MarchingCubesParams& mc, const StreamMeshOptions& options) {
  if (planes.size() < 2) throw ParamError("mesh_interpolated_field: needs at least 2 planes");
  if (!(options.outside <= mc.iso)) throw ParamError("mesh_interpolated_field: the pad value must be outside (<= iso)");
  const float iso = mc.iso;
  const std::int8_t pad_side = options.outside < iso - kSideMargin ? -1 : 0;
  SideCache sides(field, iso, pad_side);
  MarchingCubes builder(field.width() + 2, field.height() + 2, x0 - 1.0, y0 - 1.0, mc);
  const std::size_t builder_cells = std::size_t(field.width() + 1) * std::size_t(field.height() + 1);
  StreamMeshResult out;
  Grid2f plane;
  std::vector<std::uint8_t> visit;
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::array<std::size_t, 2> visit_for{kNone, kNone};  // the interval pair `visit` was made for
  std::size_t k_prev = kNone;
  const long count = long(planes.size());
  for (std::size_t j = 0; j < planes.size(); ++j) {
    const std::size_t k = field.interval(planes[j]);
    field.reach(k);  // untimed: a stream's knots may be computed here
    auto t0 = Clock::now();
    field.evaluate(planes[j], plane);
    Grid2f padded = pad(plane, options.outside);
    out.interp_seconds += seconds_since(t0);
    if (options.on_plane) options.on_plane(padded, x0 - 1.0, y0 - 1.0, planes[j], int(j), int(count));
    t0 = Clock::now();
    // Planes in one or two adjacent knot intervals: the layer may skip cells.
    const bool skip = options.skip_cells && j > 0 && k - k_prev <= 1;
    if (skip && visit_for != std::array<std::size_t, 2>{k_prev, k}) {
      const Grid2<std::int8_t>& below = sides.of(k_prev);  // k_prev and k use different slots, or are equal
      layer_cells_to_visit(below, sides.of(k), visit);
      visit_for = {k_prev, k};
    }
    if (j > 0) {
      const long layer = long(builder_cells);
      out.cells += layer;
      out.cells_visited += skip ? long(std::count(visit.begin(), visit.end(), std::uint8_t(1))) : layer;
    }
    builder.add_plane(std::move(padded), planes[j], skip ? &visit : nullptr);
    k_prev = k;
    out.mesh_seconds += seconds_since(t0);
    if (options.progress) options.progress(long(j + 1), count);
  }
  const auto t0 = Clock::now();
  out.mesh = builder.finish();
  out.mesh_seconds += seconds_since(t0);
  return out;
}

}  // namespace isoloft
