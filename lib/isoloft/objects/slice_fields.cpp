#include "isoloft/objects/slice_fields.h"

#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <utility>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/mask_curve.h"
#include "isoloft/contour/rasterize.h"
#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/field/edt.h"
#include "isoloft/field/filter.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"
#include "isoloft/objects/params.h"
#include "isoloft/objects/result.h"

namespace isoloft::detail {

namespace {

// One-line error for a non-binary image in contours/masks mode.
void check_binary(const Slice& s, std::uint32_t max_value) {
  for (int y = 0; y < s.image.height; ++y)
    for (int x = 0; x < s.image.width; ++x) {
      const auto v = s.image(x, y);
      if (v != 0 && v != max_value)
        throw InputError(s.source, "not a binary image: value " + std::to_string(v) + " at pixel (" + std::to_string(x) + ", " +
                                       std::to_string(y) + ") is neither 0 nor " + std::to_string(max_value) +
                                       " (use " + option_given("--input", "labels") + " for label images, or " + option_given("--binarize") +
                                       " to threshold at half range)");
    }
}

}  // namespace

std::size_t slice_window() { return kSlicesPerThread * std::size_t(std::max(1, tbb::this_task_arena::max_concurrency())); }

std::size_t slices_in_flight() { return 2 * slice_window(); }

std::size_t partition_slice_window(std::size_t labels) { return std::max<std::size_t>(1, slice_window() / std::max<std::size_t>(1, labels)); }

SliceMasks slice_masks(const SliceStack& stack, const Slice& s, const ReconstructParams& p, std::uint32_t label) {
  SliceMasks m;
  if (stack.has_polygons()) {
    rasterize_polygons(s.polygons, stack.width, stack.height, m.contour, m.inside);
  } else if (stack.kind == InputKind::Labels) {
    m.inside = Grid2u8(s.image.width, s.image.height, 0);
    for (std::size_t i = 0; i < s.image.size(); ++i) m.inside.data[i] = s.image.data[i] == label;
    m.contour = mask_boundary(m.inside);
  } else {
    if (!p.binarize) check_binary(s, stack.max_value);
    const Grid2u8 white = binarize(s.image, stack.max_value / 2);
    if (stack.kind == InputKind::Masks) {
      m.inside = white;
      m.contour = mask_boundary(white);
    } else {
      FillResult f;
      try {
        f = fill_even_odd(white, p.fill);
      } catch (const InputError& e) {
        throw InputError(s.source, e.problem);
      }
      for (const auto& o : f.open_contours)
        m.warnings.push_back(s.source + ": open contour with ends (" + std::to_string(o.x0) + ", " + std::to_string(o.y0) +
                             ") and (" + std::to_string(o.x1) + ", " + std::to_string(o.y1) + "), gap " +
                             std::to_string(o.gap) + " px: " +
                             (o.repaired ? "closed by a straight segment"
                                         : "too wide to close, treated as a curve without inside"));
      m.inside = std::move(f.inside);
      m.contour = std::move(f.contour);
    }
  }
  m.empty = std::none_of(m.inside.data.begin(), m.inside.data.end(), [](std::uint8_t v) { return v != 0; });
  return m;
}

namespace {
std::vector<std::uint32_t> runs_of(const Grid2u8& g) {
  std::vector<std::uint32_t> runs;
  const std::size_t n = g.size();
  for (std::size_t i = 0; i < n;) {
    if (!g.data[i]) {
      ++i;
      continue;
    }
    const std::size_t begin = i;
    while (i < n && g.data[i]) ++i;
    runs.push_back(std::uint32_t(begin));
    runs.push_back(std::uint32_t(i));
  }
  return runs;
}
Grid2u8 from_runs(const std::vector<std::uint32_t>& runs, int width, int height) {
  Grid2u8 g(width, height, 0);
  for (std::size_t r = 0; r + 1 < runs.size(); r += 2) std::fill(g.data.begin() + runs[r], g.data.begin() + runs[r + 1], 1);
  return g;
}
}  // namespace

PackedMasks pack_masks(const SliceMasks& m) {
  return {m.inside.width, m.inside.height, m.empty, runs_of(m.inside), runs_of(m.contour)};
}

SliceMasks unpack_masks(const PackedMasks& p) {
  SliceMasks m;
  m.inside = from_runs(p.inside, p.width, p.height);
  m.contour = from_runs(p.contour, p.width, p.height);
  m.empty = p.empty;
  return m;
}

std::vector<LabelMasks> label_masks(const Grid2u32& image) {
  const int W = image.width, H = image.height;
  const std::uint32_t* d = image.data.data();
  const std::size_t n = image.size();
  struct Acc {
    LabelMasks out;
    int x0, y0, x1 = -1, y1 = -1;  // inclusive bounds of the contour pixels (those of the inside)
  };
  std::map<std::uint32_t, Acc> acc;
  Acc* last = nullptr;
  auto of = [&](std::uint32_t v) -> Acc& {
    if (last && last->out.label == v) return *last;
    auto [it, added] = acc.try_emplace(v);
    if (added) it->second.out.label = v, it->second.x0 = W, it->second.y0 = H;
    return *(last = &it->second);
  };
  // Inside: the runs of each label in row-major order (runs_of of == label).
  for (std::size_t i = 0; i < n;) {
    const std::uint32_t v = d[i];
    if (!v) {
      ++i;
      continue;
    }
    const std::size_t begin = i;
    while (i < n && d[i] == v) ++i;
    auto& runs = of(v).out.masks.inside;
    runs.push_back(std::uint32_t(begin));
    runs.push_back(std::uint32_t(i));
  }
  // Contour: mask_boundary (a pixel of the label on the image border or with
  // a 4-neighbour of another value), as runs of one label.
  std::uint32_t open = 0;  // label of the contour run ending at the previous pixel, 0 if none
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = std::size_t(y) * std::size_t(W) + std::size_t(x);
      const std::uint32_t v = d[i];
      const bool edge = v && (x == 0 || y == 0 || x == W - 1 || y == H - 1 || d[i - 1] != v || d[i + 1] != v ||
                              d[i - std::size_t(W)] != v || d[i + std::size_t(W)] != v);
      const std::uint32_t now = edge ? v : 0;
      if (open && now != open) of(open).out.masks.contour.push_back(std::uint32_t(i));
      if (now && now != open) of(now).out.masks.contour.push_back(std::uint32_t(i));
      open = now;
      if (edge) {
        Acc& a = of(v);
        a.x0 = std::min(a.x0, x), a.x1 = std::max(a.x1, x), a.y0 = std::min(a.y0, y), a.y1 = std::max(a.y1, y);
      }
    }
  if (open) of(open).out.masks.contour.push_back(std::uint32_t(n));
  std::vector<LabelMasks> out;
  out.reserve(acc.size());
  for (auto& [v, a] : acc) {
    a.out.masks.width = W, a.out.masks.height = H, a.out.masks.empty = false;
    a.out.bounds = {a.x0, a.y0, a.x1 + 1, a.y1 + 1};
    out.push_back(std::move(a.out));
  }
  return out;
}

Grid2u32 labels_around_box(const std::vector<LabelRuns>& runs, int image_width, const PixelBox& box) {
  Grid2u32 labels(box.width() + 2, box.height() + 2, 0);
  const auto W = std::size_t(image_width);
  for (const LabelRuns& l : runs)
    for (std::size_t r = 0; r + 1 < l.inside->size(); r += 2)
      for (std::size_t i = (*l.inside)[r], e = (*l.inside)[r + 1]; i < e;) {  // a run may span rows
        const int y = int(i / W), x = int(i % W);
        const int x1 = int(std::min<std::size_t>(W, std::size_t(x) + (e - i)));
        i += std::size_t(x1 - x);
        if (y < box.y0 || y >= box.y1) continue;
        const int a = std::max(x, box.x0), b = std::min(x1, box.x1);
        if (a < b) std::fill_n(&labels(a - box.x0 + 1, y - box.y0 + 1), b - a, l.label);
      }
  return labels;
}

Grid2f union_healing(const Grid2u32& labels) {
  const int w = labels.width, h = labels.height;
  Grid2u8 uni(w, h, 0);
  for (std::size_t i = 0; i < uni.size(); ++i) uni.data[i] = labels.data[i] != 0;
  const Grid2f d_union = distance_to_mask_edge_signed(uni);
  // Each label's own edge distance, over its bounds plus one pixel.
  std::map<std::uint32_t, PixelBox> bounds;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (const std::uint32_t v = labels(x, y)) {
        auto [it, added] = bounds.try_emplace(v, PixelBox{x, y, x + 1, y + 1});
        PixelBox& b = it->second;
        b = {std::min(b.x0, x), std::min(b.y0, y), std::max(b.x1, x + 1), std::max(b.y1, y + 1)};
      }
  Grid2f out(w - 2, h - 2, 0.0f);
  for (const auto& [v, b0] : bounds) {
    const PixelBox b{b0.x0 - 1, b0.y0 - 1, b0.x1 + 1, b0.y1 + 1};  // within the padded grid
    Grid2u8 own(b.width(), b.height(), 0);
    for (int y = b.y0; y < b.y1; ++y)
      for (int x = b.x0; x < b.x1; ++x) own(x - b.x0, y - b.y0) = labels(x, y) == v;
    const Grid2f d_own = distance_to_mask_edge_signed(own);
    for (int y = b.y0; y < b.y1; ++y)
      for (int x = b.x0; x < b.x1; ++x)
        if (labels(x, y) == v) out(x - 1, y - 1) = std::max(0.0f, d_union(x, y) - d_own(x - b.x0, y - b.y0));
  }
  return out;
}

PixelBox mask_bounds(const SliceMasks& m) {
  if (m.empty) return {};
  const int width = m.inside.width, height = m.inside.height;
  int x0 = width, y0 = height, x1 = -1, y1 = -1;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      if (m.inside(x, y) || m.contour(x, y)) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  if (x1 < 0) return {};
  return {x0, y0, x1 + 1, y1 + 1};
}

PixelBox object_box(const std::vector<PixelBox>& bounds, int width, int height, int margin) {
  int x0 = width, y0 = height, x1 = -1, y1 = -1;  // inclusive
  for (const auto& b : bounds) {
    if (b.empty()) continue;
    x0 = std::min(x0, b.x0), y0 = std::min(y0, b.y0), x1 = std::max(x1, b.x1 - 1), y1 = std::max(y1, b.y1 - 1);
  }
  if (x1 < 0) return {};
  return {std::max(0, x0 - margin), std::max(0, y0 - margin), std::min(width, x1 + margin + 1), std::min(height, y1 + margin + 1)};
}

float most_negative(float so_far, const Grid2f& f) {
  return f.empty() ? so_far : std::min(so_far, *std::min_element(f.data.begin(), f.data.end()));
}

float isolated_ceiling(const InterpParams& interp) { return -float(std::max(1.0, interp.cap_depth)); }

namespace {
// f moved 1 / cap_extent of the way to its cap slice for a gap (px): the
// field of an empty slice next to f.
Grid2f closing(const Grid2f& f, const InterpParams& interp, double gap) {
  Grid2f closed = cap_slice(f, interp, interp.cap_extent * gap);
  if (interp.cap_shape == CapShape::Dome) {
    // The dome's drop, as one float (its outputs unchanged).
    const float top = std::max(0.0f, *std::max_element(f.data.begin(), f.data.end()));
    const float drop = float((top + interp.cap_depth) / interp.cap_extent);
    for (std::size_t i = 0; i < closed.size(); ++i) closed.data[i] = f.data[i] - drop;
  } else {
    for (std::size_t i = 0; i < closed.size(); ++i)
      closed.data[i] = float(f.data[i] + (double(closed.data[i]) - f.data[i]) / interp.cap_extent);
  }
  return closed;
}

bool has(const Grid2f* f) { return f && !f->empty(); }
}  // namespace

Grid2f empty_slice_field(const EmptyNeighbours& nb, float lowest, const PixelBox& box, const InterpParams& interp) {
  // Empty slices (no inside) are all outside. One next to a non-empty slice
  // gets that neighbour's field moved 1 / cap_extent of the way to its cap
  // slice (interp/spline.h, cap_slice, reaching cap_extent of the gap), so
  // the object closes between them like an end cap. With two non-empty
  // neighbours it takes the lower of the two. An isolated one: isolated_empty.
  Grid2f g;
  const auto lower = [&g](Grid2f f) {
    if (g.empty()) {
      g = std::move(f);
    } else {
      for (std::size_t i = 0; i < g.size(); ++i) g.data[i] = std::min(g.data[i], f.data[i]);
    }
  };
  for (const auto& [f, gap] : {std::pair{nb.below, nb.gap_below}, std::pair{nb.above, nb.gap_above}})
    if (has(f)) lower(closing(*f, interp, gap));
  if (!g.empty()) return g;
  const float ceiling = isolated_ceiling(interp);
  switch (interp.isolated_empty) {
    case IsolatedEmpty::Lowest:
      return Grid2f(box.width(), box.height(), lowest);
    case IsolatedEmpty::Neighbours:
      return Grid2f(box.width(), box.height(), std::min(lowest, ceiling));
    case IsolatedEmpty::Depth:
      break;
    case IsolatedEmpty::Box:
      return Grid2f(box.width(), box.height(), std::min(ceiling, -float(std::hypot(box.width(), box.height()))));
    case IsolatedEmpty::Secant:
      // Next to a closing slice (the empty neighbour of a non-empty one): the
      // line from the non-empty field through the closing one, continued, so
      // the closing knot's tangent is that secant, as if nothing lay beyond.
      for (const auto& [f, gap2, gap] : {std::tuple{nb.below2, nb.gap_below2, nb.gap_below},
                                         std::tuple{nb.above2, nb.gap_above2, nb.gap_above}}) {
        if (!has(f)) continue;
        Grid2f line = closing(*f, interp, gap2);
        const double ratio = gap / gap2;
        for (std::size_t i = 0; i < line.size(); ++i)
          line.data[i] = std::min(ceiling, float(line.data[i] + (double(line.data[i]) - f->data[i]) * ratio));
        lower(std::move(line));
      }
      if (!g.empty()) return g;
      break;
  }
  return Grid2f(box.width(), box.height(), ceiling);
}

void fill_empty_slices(std::vector<Grid2f>& fields, const std::vector<double>& z, const PixelBox& box,
                       const InterpParams& interp) {
  const std::size_t n = fields.size();
  float lowest = -1.0f;
  for (const auto& f : fields) lowest = most_negative(lowest, f);
  const auto at = [&](std::size_t k, std::ptrdiff_t d) -> const Grid2f* {
    const std::ptrdiff_t j = std::ptrdiff_t(k) + d;
    return j >= 0 && j < std::ptrdiff_t(n) ? &fields[std::size_t(j)] : nullptr;
  };
  const auto gap = [&](std::size_t k, std::ptrdiff_t d) {  // from slice k + d toward k, 0 past the ends
    const std::ptrdiff_t j = std::ptrdiff_t(k) + d, i = d < 0 ? j + 1 : j - 1;
    return j >= 0 && j < std::ptrdiff_t(n) ? std::abs(z[std::size_t(j)] - z[std::size_t(i)]) : 0.0;
  };
  std::vector<Grid2f> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    if (!fields[k].empty()) continue;
    float near = lowest;
    if (interp.isolated_empty == IsolatedEmpty::Neighbours) {
      near = -1.0f;
      const std::size_t r = kIsolatedNeighbourSlices;
      for (std::size_t j = k - std::min(k, r); j <= std::min(n - 1, k + r); ++j) near = most_negative(near, fields[j]);
    }
    const bool secant = interp.isolated_empty == IsolatedEmpty::Secant;
    const EmptyNeighbours nb{at(k, -1), at(k, 1), secant ? at(k, -2) : nullptr, secant ? at(k, 2) : nullptr,
                             gap(k, -1), gap(k, 1), gap(k, -2), gap(k, 2)};
    out[k] = empty_slice_field(nb, near, box, interp);
  }
  for (std::size_t k = 0; k < n; ++k)
    if (fields[k].empty()) fields[k] = std::move(out[k]);
}

}  // namespace isoloft::detail
