#include "isoloft/methods/columns/field_band.h"
#include "isoloft/methods/columns/slice_methods.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "isoloft/field/filter.h"
#include "isoloft/interp/z_stream.h"
#include "isoloft/methods/params.h"

namespace isoloft::detail {

namespace {

// f(y, x0, x1) for each row piece [x0, x1) of the runs (a run may wrap rows).
template <class F>
void for_run_rows(const std::vector<std::uint32_t>& runs, int width, F&& f) {
  for (std::size_t r = 0; r + 1 < runs.size(); r += 2)
    for (std::uint32_t b = runs[r], e = runs[r + 1]; b < e;) {
      const int y = int(b / std::uint32_t(width)), x = int(b % std::uint32_t(width));
      const std::uint32_t row_end = std::uint32_t(y + 1) * std::uint32_t(width), end = std::min(e, row_end);
      f(y, x, x + int(end - b));
      b = end;
    }
}

// px: traced masks and drawn polygons keep their masks' side beyond this from
// a contour pixel (an 8-adjacent inside/outside pair has a contour pixel
// within 1 of its inside pixel; a polygon's rasterised edge lies within 1 px
// of the edge itself).
constexpr int kGivenBoundaryUnknownWithin = 2;

}  // namespace

Grid2u8 dilate_square(const Grid2u8& g, int r) {
  if (r <= 0) return g;
  const int w = g.width, h = g.height;
  Grid2u8 rows(w, h, 0), out(w, h, 0);
  // A row pass then a column pass of running counts: O(1) per pixel for any r.
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* in = &g.data[g.index(0, y)];
    std::uint8_t* o = &rows.data[rows.index(0, y)];
    int count = 0;
    for (int x = 0; x < std::min(w, r); ++x) count += in[x];
    for (int x = 0; x < w; ++x) {
      if (x + r < w) count += in[x + r];
      if (x - r - 1 >= 0) count -= in[x - r - 1];
      o[x] = count > 0;
    }
  }
  std::vector<int> count(std::size_t(w), 0);
  for (int y = 0; y < std::min(h, r); ++y)
    for (int x = 0; x < w; ++x) count[std::size_t(x)] += rows(x, y);
  for (int y = 0; y < h; ++y) {
    if (y + r < h)
      for (int x = 0; x < w; ++x) count[std::size_t(x)] += rows(x, y + r);
    if (y - r - 1 >= 0)
      for (int x = 0; x < w; ++x) count[std::size_t(x)] -= rows(x, y - r - 1);
    for (int x = 0; x < w; ++x) out(x, y) = count[std::size_t(x)] > 0;
  }
  return out;
}

Grid2<std::int8_t> known_sides(const PackedMasks& m, const PixelBox& box, int u) {
  const int w = box.width(), h = box.height();
  Grid2<std::int8_t> out(w, h, -1);
  if (m.empty) return out;
  for_run_rows(m.inside, m.width, [&](int y, int x0, int x1) {
    if (y < box.y0 || y >= box.y1) return;
    for (int x = std::max(x0, box.x0); x < std::min(x1, box.x1); ++x) out(x - box.x0, y - box.y0) = 1;
  });
  for_run_rows(m.contour, m.width, [&](int y, int x0, int x1) {
    const int xa = std::max(x0 - u, box.x0), xb = std::min(x1 + u, box.x1);
    if (xa >= xb) return;
    for (int yy = std::max(y - u, box.y0); yy <= std::min(y + u, box.y1 - 1); ++yy)
      std::fill_n(&out(xa - box.x0, yy - box.y0), xb - xa, std::int8_t(0));
  });
  // The mesher's outside pad meets the ring: an inside pixel there is a crossing.
  const auto ring = [&](int x, int y) { out(x, y) = std::min<std::int8_t>(out(x, y), 0); };
  for (int x = 0; x < w; ++x) ring(x, 0), ring(x, h - 1);
  for (int y = 0; y < h; ++y) ring(0, y), ring(w - 1, y);
  return out;
}

std::optional<FieldBand::Setup> field_band_setup(const ReconstructParams& p, InputKind kind,
                                                 const std::vector<PackedMasks>& masks) {
  const SplineKind spline = p.interp.spline;
  const bool keeps_sides =
      spline == SplineKind::Monotone || spline == SplineKind::ExtremumPreserving || spline == SplineKind::Linear;
  if (!fits_curves(p.method) || !takes_given_boundary(kind, p) || p.z_scheme != "columns" || p.mc.iso != 0.0f ||
      !keeps_sides)
    return std::nullopt;
  // An isolated empty slice's value reads whole fields under Lowest (every
  // field) and Neighbours (their minima); Depth and Box are constants, Secant reads
  // only fields next to an empty slice, which are whole (FieldBand).
  const IsolatedEmpty rule = p.interp.isolated_empty;
  const bool reads_minima = rule == IsolatedEmpty::Lowest || rule == IsolatedEmpty::Neighbours;
  const std::size_t n = masks.size();
  for (std::size_t k = 0; k < n; ++k) {
    if (!masks[k].empty) continue;
    const bool below = k > 0 && !masks[k - 1].empty, above = k + 1 < n && !masks[k + 1].empty;
    if ((!(below || above) && reads_minima) || p.interp.cap_extent > 1.0) return std::nullopt;
  }
  FieldBand::Setup s;
  s.unknown_within = kGivenBoundaryUnknownWithin;
  s.reach = tangent_reach(spline).value();
  s.filter_reach = filter_reach(p.filter);
  s.trend_caps = p.interp.cap_shape == CapShape::Slab || p.interp.cap_shape == CapShape::Round;
  return s;
}

FieldBand::FieldBand(const std::vector<PackedMasks>& masks, const PixelBox& box, const Setup& setup)
    : masks_(masks), box_(box), setup_(setup), full_(masks.size(), 0) {
  const std::size_t n = masks.size();
  for (std::size_t k = 0; k < n; ++k) {
    const bool empty_next = (k > 0 && masks[k - 1].empty) || (k + 1 < n && masks[k + 1].empty);
    const bool trend = setup.trend_caps && (k == 1 || k + 2 == n);
    full_[k] = k == 0 || k + 1 == n || empty_next || trend;
  }
}

void FieldBand::prepare(std::size_t k0, std::size_t k1) {
  // Slice k is knot k + 1; intervals j (knots j, j + 1) whose splines read
  // knot i: j - reach <= i <= j + 1 + reach.
  const std::size_t n = masks_.size(), r = setup_.reach;
  const std::size_t j_lo = k0 - std::min(k0, r), j_hi = std::min(n, k1 + r);  // intervals [j_lo, j_hi]
  for (; first_ < j_lo && !crossing_.empty(); ++first_) crossing_.pop_front();
  if (crossing_.empty()) first_ = j_lo;
  const std::size_t from = first_ + crossing_.size();
  if (from > j_hi) return;
  // The sides of the slices these intervals join (knots from - 1 .. j_hi + 1).
  const std::size_t s_lo = from > 0 ? from - 1 : 0, s_hi = std::min(n, j_hi + 1);  // slices [s_lo, s_hi)
  std::vector<Grid2<std::int8_t>> sides(s_hi - s_lo);
  tbb::parallel_for(s_lo, s_hi, [&](std::size_t k) {
    if (!masks_[k].empty) sides[k - s_lo] = known_sides(masks_[k], box_, setup_.unknown_within);
  });
  // Null: outside everywhere (a cap, or an empty slice).
  const auto knot = [&](std::size_t i) -> const Grid2<std::int8_t>* {
    if (i == 0 || i > n) return nullptr;
    const Grid2<std::int8_t>& g = sides[i - 1 - s_lo];
    return g.empty() ? nullptr : &g;
  };
  std::vector<Grid2u8> made(j_hi + 1 - from);
  tbb::parallel_for(from, j_hi + 1, [&](std::size_t j) {
    const Grid2<std::int8_t>* a = knot(j);
    const Grid2<std::int8_t>* b = knot(j + 1);
    Grid2u8& c = made[j - from];
    c = Grid2u8(box_.width(), box_.height(), 0);
    if (!a && !b) return;
    for (std::size_t q = 0; q < c.size(); ++q) {
      const std::int8_t sa = a ? a->data[q] : std::int8_t(-1), sb = b ? b->data[q] : std::int8_t(-1);
      c.data[q] = sa == 0 || sa != sb;
    }
  });
  for (auto& g : made) crossing_.push_back(std::move(g));
}

std::optional<SliceBand> FieldBand::band(std::size_t k) const {
  if (full_.at(k)) return std::nullopt;
  const std::size_t i = k + 1, r = setup_.reach, n = masks_.size();
  Grid2u8 crossing(box_.width(), box_.height(), 0);
  for (std::size_t j = i - std::min(i, r + 1); j <= std::min(n, i + r); ++j) {
    const Grid2u8& c = crossing_.at(j - first_);
    for (std::size_t q = 0; q < crossing.size(); ++q) crossing.data[q] |= c.data[q];
  }
  SliceBand out;
  out.needed = dilate_square(crossing, 1);
  out.required = dilate_square(crossing, 1 + setup_.filter_reach);
  return out;
}

}  // namespace isoloft::detail
