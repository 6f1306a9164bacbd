#include "isoloft/methods/columns/field_band.h"
#include "isoloft/methods/columns/slice_methods.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

#include "isoloft/core/error.h"
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
  Grid2u8 rows(w, h), out(w, h);
  // Row pass: each row zero-padded by r, OR-ed with itself shifted by 1, 2,
  // 4, ... (cur[i]: any of the 2^k from i), then two such windows cover the
  // 2r + 1 around a pixel. Byte loops over contiguous pixels.
  const int span = 2 * r + 1, n = w + 2 * r;
  std::vector<std::uint8_t> cur(std::size_t(n), 0);
  int len = 1;
  while (2 * len <= span) len *= 2;
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* in = &g.data[g.index(0, y)];
    for (int x = 0; x < w; ++x) cur[std::size_t(r + x)] = in[x] != 0;
    std::fill(cur.begin() + r + w, cur.end(), std::uint8_t(0));
    std::fill(cur.begin(), cur.begin() + r, std::uint8_t(0));
    for (int l = 1; l < len; l *= 2) {
      std::uint8_t* c = cur.data();
      for (int i = 0; i + 2 * l <= n; ++i) c[i] |= c[i + l];
    }
    std::uint8_t* o = &rows.data[rows.index(0, y)];
    const std::uint8_t *lo = cur.data(), *hi = cur.data() + (span - len);
    for (int x = 0; x < w; ++x) o[x] = lo[x] | hi[x];
  }
  // Column pass: running counts of the rows pass over y - r .. y + r.
  std::vector<int> count(std::size_t(w), 0);
  const auto add = [&](int y, int sign) {
    const std::uint8_t* row = &rows.data[rows.index(0, y)];
    for (int x = 0; x < w; ++x) count[std::size_t(x)] += sign * row[x];
  };
  for (int y = 0; y < std::min(h, r); ++y) add(y, 1);
  for (int y = 0; y < h; ++y) {
    if (y + r < h) add(y + r, 1);
    if (y - r - 1 >= 0) add(y - r - 1, -1);
    std::uint8_t* o = &out.data[out.index(0, y)];
    for (int x = 0; x < w; ++x) o[x] = count[std::size_t(x)] > 0;
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
  s.whole_ends = p.interp.cap_shape == CapShape::Dome || p.interp.cap_shape == CapShape::Round;
  s.spread = rule == IsolatedEmpty::Secant ? 2 : 1;  // an isolated empty slice's secant reads the slice 2 away
  return s;
}

FieldBand::FieldBand(const std::vector<PackedMasks>& masks, const PixelBox& box, const Setup& setup)
    : masks_(masks), box_(box), setup_(setup), full_(masks.size(), 0), readers_(masks.size()) {
  const std::size_t n = masks.size();
  for (std::size_t k = 0; k < n; ++k) {
    const bool empty_next = (k > 0 && masks[k - 1].empty) || (k + 1 < n && masks[k + 1].empty);
    full_[k] = setup.whole_ends && (k == 0 || k + 1 == n || empty_next);
    // The end caps' knots read no interval their end slices' do not: the
    // trend slice's readers reach the end slice.
    std::size_t first = setup.trend_caps && k == 1 ? 0 : k, last = setup.trend_caps && k + 2 == n ? n - 1 : k;
    for (std::size_t d = 1; d <= setup.spread && d <= k && masks[k - d].empty; ++d) first = std::min(first, k - d);
    for (std::size_t d = 1; d <= setup.spread && k + d < n && masks[k + d].empty; ++d) last = std::max(last, k + d);
    readers_[k] = {first, last};
  }
}

namespace {

// out[i] |= in[i] for i < n, eight bytes at a time (the crossings of every
// interval a knot's splines read are joined per slice and label).
void or_into(std::uint8_t* out, const std::uint8_t* in, std::size_t n) {
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t a, b;
    std::memcpy(&a, out + i, 8);
    std::memcpy(&b, in + i, 8);
    a |= b;
    std::memcpy(out + i, &a, 8);
  }
  for (; i < n; ++i) out[i] |= in[i];
}

// Per knot interval j in [from, to] (knots j, j + 1; slice k is knot k + 1,
// knots 0 and n + 1 the caps) over a w x h box: 1 where the sides (0
// unknown, -1 outside, else a side) are unknown or differ. sides_of(k):
// slice k's, empty for an empty slice; the caps and empty slices are
// outside everywhere.
template <class T, class SidesOf>
std::vector<Grid2u8> interval_crossings(std::size_t n, int w, int h, std::size_t from, std::size_t to,
                                        SidesOf&& sides_of) {
  // The sides of the slices these intervals join (knots from - 1 .. to + 1).
  const std::size_t s_lo = from > 0 ? from - 1 : 0, s_hi = std::min(n, to + 1);  // slices [s_lo, s_hi)
  std::vector<Grid2<T>> sides(s_hi - s_lo);
  tbb::parallel_for(s_lo, s_hi, [&](std::size_t k) { sides[k - s_lo] = sides_of(k); });
  // Null: outside everywhere (a cap, or an empty slice).
  const auto knot = [&](std::size_t i) -> const Grid2<T>* {
    if (i == 0 || i > n) return nullptr;
    const Grid2<T>& g = sides[i - 1 - s_lo];
    return g.empty() ? nullptr : &g;
  };
  std::vector<Grid2u8> made(to + 1 - from);
  tbb::parallel_for(from, to + 1, [&](std::size_t j) {
    const Grid2<T>* a = knot(j);
    const Grid2<T>* b = knot(j + 1);
    Grid2u8& c = made[j - from];
    c = Grid2u8(w, h, 0);
    if (!a && !b) return;
    for (std::size_t q = 0; q < c.size(); ++q) {
      const T sa = a ? a->data[q] : T(-1), sb = b ? b->data[q] : T(-1);
      c.data[q] = sa == 0 || sa != sb;
    }
  });
  return made;
}

// The intervals [j_lo, j_hi] whose splines read the knots of slices [k0, k1)
// (intervals j, knots j and j + 1, read knot i if j - reach <= i <= j + 1 + reach).
std::pair<std::size_t, std::size_t> intervals_read(std::size_t k0, std::size_t k1, std::size_t reach, std::size_t n) {
  return {k0 - std::min(k0, reach), std::min(n, k1 + reach)};
}

// The intervals [j_lo, j_hi] the knots of slices [first, last] read (the
// union of their bands' intervals).
std::pair<std::size_t, std::size_t> slice_intervals(std::size_t first, std::size_t last, std::size_t reach,
                                                    std::size_t n) {
  const std::size_t i0 = first + 1, i1 = last + 1;
  return {i0 - std::min(i0, reach + 1), std::min(n, i1 + reach)};
}

}  // namespace

void FieldBand::prepare(std::size_t k0, std::size_t k1) {
  if (setup_.partition) return setup_.partition->prepare(setup_.label, k0, k1);
  // A slice's band may join its readers' up to `spread` slices away.
  const auto [j_lo, j_hi] = intervals_read(k0, k1, setup_.reach + setup_.spread, masks_.size());
  for (; first_ < j_lo && !crossing_.empty(); ++first_) crossing_.pop_front();
  if (crossing_.empty()) first_ = j_lo;
  const std::size_t from = first_ + crossing_.size();
  if (from > j_hi) return;
  const auto sides_of = [&](std::size_t k) {
    return masks_[k].empty ? Grid2<std::int8_t>() : known_sides(masks_[k], box_, setup_.unknown_within);
  };
  for (auto& g : interval_crossings<std::int8_t>(masks_.size(), box_.width(), box_.height(), from, j_hi, sides_of))
    crossing_.push_back(std::move(g));
}

PartitionCrossings::PartitionCrossings(std::vector<std::vector<PackedMasks>> masks, std::vector<PixelBox> boxes,
                                       const PixelBox& ubox, const FieldBand::Setup& setup)
    : masks_(std::move(masks)), boxes_(std::move(boxes)), ubox_(ubox), setup_(setup), asked_(masks_.size(), 0) {
  setup_.partition.reset();
  for (const PixelBox& b : boxes_)
    if (b.x0 < ubox.x0 || b.y0 < ubox.y0 || b.x1 > ubox.x1 || b.y1 > ubox.y1)
      throw Error("PartitionCrossings: a label's box is not within the union's");
}

Grid2<std::int32_t> PartitionCrossings::slice_sides(std::size_t k) const {
  Grid2<std::int32_t> out(ubox_.width(), ubox_.height(), -1);
  const int u = setup_.unknown_within;
  const auto at = [&](int x, int y) -> std::int32_t& { return out(x - ubox_.x0, y - ubox_.y0); };
  for (std::size_t l = 0; l < masks_.size(); ++l) {
    const PackedMasks& m = masks_[l][k];
    if (m.empty) continue;
    const PixelBox& b = boxes_[l];
    const std::int32_t id = std::int32_t(l) + 1;
    for_run_rows(m.inside, m.width, [&](int y, int x0, int x1) {
      if (y < b.y0 || y >= b.y1) return;
      for (int x = std::max(x0, b.x0); x < std::min(x1, b.x1); ++x) at(x, y) = id;
    });
    // The mesher's outside pad meets the label's box ring (known_sides).
    const auto ring = [&](int x, int y) {
      if (at(x, y) == id) at(x, y) = 0;
    };
    for (int x = b.x0; x < b.x1; ++x) ring(x, b.y0), ring(x, b.y1 - 1);
    for (int y = b.y0; y < b.y1; ++y) ring(b.x0, y), ring(b.x1 - 1, y);
  }
  for (std::size_t l = 0; l < masks_.size(); ++l) {
    const PackedMasks& m = masks_[l][k];
    if (m.empty) continue;
    const PixelBox& b = boxes_[l];
    for_run_rows(m.contour, m.width, [&](int y, int x0, int x1) {
      const int xa = std::max(x0 - u, b.x0), xb = std::min(x1 + u, b.x1);
      if (xa >= xb) return;
      for (int yy = std::max(y - u, b.y0); yy <= std::min(y + u, b.y1 - 1); ++yy)
        std::fill_n(&at(xa, yy), xb - xa, std::int32_t(0));
    });
  }
  return out;
}

void PartitionCrossings::prepare(std::size_t label, std::size_t k0, std::size_t k1_asked) {
  std::lock_guard lock(m_);
  asked_.at(label) = k0;
  const std::size_t n = masks_.empty() ? 0 : masks_[0].size(), r = setup_.reach, spread = setup_.spread;
  // A slice's band may join its readers' up to `spread` slices away: those kept and made too.
  const std::size_t lagging = *std::min_element(asked_.begin(), asked_.end()), keep = lagging - std::min(lagging, spread);
  const std::size_t k1 = std::min(n, k1_asked + spread);
  for (; first_band_ < keep && !bands_.empty(); ++first_band_) bands_.pop_front();
  if (bands_.empty()) first_band_ = std::min(k0 - std::min(k0, spread), keep);
  const std::size_t s_from = first_band_ + bands_.size();
  if (s_from >= k1) return;
  // The intervals slices [s_from, k1) read.
  const auto read = intervals_read(s_from, k1, r, n);
  const std::size_t j_lo = read.first, j_hi = read.second;  // not a structured binding: clang 14 cannot capture one
  for (; first_ < j_lo && !crossing_.empty(); ++first_) crossing_.pop_front();
  if (crossing_.empty()) first_ = j_lo;
  // Under the lock: isolated, so this thread runs no other label's band
  // work (which would wait for the lock) meanwhile.
  tbb::this_task_arena::isolate([&] {
    if (const std::size_t from = first_ + crossing_.size(); from <= j_hi)
      for (auto& g : interval_crossings<std::int32_t>(n, ubox_.width(), ubox_.height(), from, j_hi,
                                                      [&](std::size_t k) { return slice_sides(k); }))
        crossing_.push_back(std::move(g));
    // Each slice's band once for every label: the crossings of the intervals
    // its knot's splines read, dilated as FieldBand::band dilates.
    std::vector<SliceBand> made(k1 - s_from);
    tbb::parallel_for(s_from, k1, [&](std::size_t k) {
      const std::size_t i = k + 1;
      Grid2u8 crossing(ubox_.width(), ubox_.height(), 0);
      for (std::size_t j = i - std::min(i, r + 1); j <= std::min(n, i + r); ++j) {
        const Grid2u8& c = crossing_.at(j - first_);
        or_into(crossing.data.data(), c.data.data(), crossing.size());
      }
      made[k - s_from] = {dilate_square(crossing, 1), dilate_square(crossing, 1 + setup_.filter_reach)};
    });
    for (auto& b : made) bands_.push_back(std::move(b));
  });
}

SliceBand PartitionCrossings::band(std::size_t first, std::size_t last, const PixelBox& box) const {
  // The union's bands OR-ed into one crop (equal to dilating the union of
  // their crossings: a dilation of a union is the union of the dilations).
  SliceBand out{Grid2u8(box.width(), box.height(), 0), Grid2u8(box.width(), box.height(), 0)};
  const auto crop_or = [&](const Grid2u8& g, Grid2u8& c) {
    for (int y = 0; y < c.height; ++y)
      or_into(&c.data[c.index(0, y)], &g.data[g.index(box.x0 - ubox_.x0, y + box.y0 - ubox_.y0)], std::size_t(c.width));
  };
  std::lock_guard lock(m_);
  for (std::size_t k = first; k <= last; ++k) {
    const SliceBand& b = bands_.at(k - first_band_);
    crop_or(b.needed, out.needed);
    crop_or(b.required, out.required);
  }
  return out;
}

std::optional<SliceBand> FieldBand::band(std::size_t k) const {
  if (full_.at(k)) return std::nullopt;
  const auto [first, last] = readers_.at(k);
  if (setup_.partition) return setup_.partition->band(first, last, box_);
  const auto [j0, j1] = slice_intervals(first, last, setup_.reach, masks_.size());
  Grid2u8 crossing(box_.width(), box_.height(), 0);
  for (std::size_t j = j0; j <= j1; ++j) {
    const Grid2u8& c = crossing_.at(j - first_);
    or_into(crossing.data.data(), c.data.data(), crossing.size());
  }
  SliceBand out;
  out.needed = dilate_square(crossing, 1);
  out.required = dilate_square(crossing, 1 + setup_.filter_reach);
  return out;
}

}  // namespace isoloft::detail
