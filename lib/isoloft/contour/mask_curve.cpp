#include "isoloft/contour/mask_curve.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "isoloft/field/edt.h"

namespace isoloft {

namespace {

// Separable Gaussian of a 0/1 image, zero beyond the grid; radius 3 sigma.
// Each pixel's sum runs over its (clipped) stencil from the lowest offset up;
// whole stencils add one offset at a time to a row of sums (the same order per
// pixel, the same floats) so the loops run over contiguous pixels.
Grid2f gaussian(const Grid2u8& m, double sigma) {
  const int w = m.width, h = m.height;
  Grid2f out(w, h);
  for (std::size_t i = 0; i < m.size(); ++i) out.data[i] = m.data[i] ? 1.0f : 0.0f;
  if (!(sigma > 0)) return out;
  const int r = int(std::ceil(3 * sigma));
  std::vector<float> wt(std::size_t(2 * r + 1));
  double sum = 0;
  for (int i = -r; i <= r; ++i) sum += wt[std::size_t(i + r)] = float(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& v : wt) v = float(v / sum);
  // Rows without a mask pixel sum to +0 (every product is +0): skipped, as
  // are output rows whose stencil meets only such rows.
  std::vector<char> row_set(static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* row = &m.data[m.index(0, y)];
    row_set[std::size_t(y)] = std::any_of(row, row + w, [](std::uint8_t v) { return v != 0; });
  }
  Grid2f tmp(w, h);
  const int x0 = std::min(r, w), x1 = std::max(x0, w - r);  // [x0, x1): whole row stencils
  for (int y = 0; y < h; ++y) {
    if (!row_set[std::size_t(y)]) continue;
    const float* in = &out.data[out.index(0, y)];
    float* __restrict t = &tmp.data[tmp.index(0, y)];
    const auto clipped = [&](int x) {
      float s = 0;
      for (int i = std::max(-r, -x); i <= std::min(r, w - 1 - x); ++i) s += wt[std::size_t(i + r)] * in[x + i];
      t[x] = s;
    };
    for (int x = 0; x < x0; ++x) clipped(x);
    for (int x = x1; x < w; ++x) clipped(x);
    std::fill(t + x0, t + x1, 0.0f);
    for (int i = -r; i <= r; ++i) {
      const float g = wt[std::size_t(i + r)];
      const float* __restrict src = in + i;
      for (int x = x0; x < x1; ++x) t[x] += g * src[x];
    }
  }
  for (int y = 0; y < h; ++y) {
    float* __restrict o = &out.data[out.index(0, y)];
    std::fill(o, o + w, 0.0f);
    const int i0 = std::max(-r, -y), i1 = std::min(r, h - 1 - y);
    if (std::none_of(&row_set[std::size_t(y + i0)], &row_set[std::size_t(y + i1)] + 1, [](char v) { return v != 0; })) continue;
    for (int i = i0; i <= i1; ++i) {
      const float g = wt[std::size_t(i + r)];
      const float* __restrict src = &tmp.data[tmp.index(0, y + i)];
      for (int x = 0; x < w; ++x) o[x] += g * src[x];
    }
  }
  return out;
}

}  // namespace

namespace detail {

Grid2u8 thin_side_edt(const Grid2u8& m, double width) {
  // Positive on each pixel's own side: the distance to the edge between the two.
  const Grid2f d = distance_to_mask_edge_signed(m);
  Grid2u8 thin(m.width, m.height, 0);
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      const float sign = m(x, y) ? 1.0f : -1.0f;
      float deepest = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int u = x + dx, v = y + dy;
          if (u < 0 || v < 0 || u >= m.width || v >= m.height || m(u, v) != m(x, y)) continue;
          deepest = std::max(deepest, sign * d(u, v));
        }
      thin(x, y) = deepest < 0.5 * width;
    }
  return thin;
}

Grid2u8 thin_side(const Grid2u8& m, double width) {
  // A pixel is deep when its distance to the edge, float(sqrt(s) - 0.5) for
  // s the squared distance to the nearest pixel of the other side (as
  // distance_to_mask_edge_signed gives it), is >= width / 2: when no pixel of
  // the other side lies at a squared distance below s_min.
  const double half = 0.5 * width;
  constexpr int kPastReach = (kThinWindowReach + 1) * (kThinWindowReach + 1);  // any width: the loop ends
  int s_min = 1;
  while (s_min <= kPastReach && double(float(std::sqrt(double(s_min)) - 0.5)) < half) ++s_min;
  const int r = int(std::ceil(std::sqrt(double(s_min))));
  if (r > kThinWindowReach) return thin_side_edt(m, width);
  const int w = m.width, h = m.height;
  if (w == 0 || h == 0) return Grid2u8(w, h);
  // The window's row dy holds the pixels |dx| <= span[dy + r] (-1: none).
  std::vector<int> span(std::size_t(2 * r + 1), -1);
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = 0; dx <= r && dx * dx + dy * dy < s_min; ++dx) span[std::size_t(dy + r)] = dx;
  Grid2u8 side(w, h), deep(w, h, 1);
  const std::uint8_t* in = m.data.data();
  std::uint8_t* sides = side.data.data();  // raw: a byte store may alias a vector's own pointer
  for (std::size_t i = 0, n = m.size(); i < n; ++i) sides[i] = in[i] != 0;
  // Row v's `run[s]`: every pixel of row v within s of x (in the grid) is on
  // x's side. Deep (every window pixel in the grid on p's side) is the AND,
  // over the window's rows, of row p.y + dy's run[span] at x and its side
  // at x being p's. Byte loops over contiguous pixels.
  const int widest = *std::max_element(span.begin(), span.end());
  std::vector<std::vector<std::uint8_t>> run(std::size_t(widest + 1), std::vector<std::uint8_t>(std::size_t(w), 1));
  for (int v = 0; v < h; ++v) {
    const std::uint8_t* sv = &side.data[side.index(0, v)];
    for (int s = 1; s <= widest; ++s) {
      const std::uint8_t* prev = run[std::size_t(s - 1)].data();
      std::uint8_t* __restrict cur = run[std::size_t(s)].data();
      const auto edge = [&](int x) {
        const bool left = x - s < 0 || sv[x - s] == sv[x], right = x + s >= w || sv[x + s] == sv[x];
        cur[x] = prev[x] & std::uint8_t(left && right);
      };
      const int x0 = std::min(s, w), x1 = std::max(x0, w - s);  // [x0, x1): both ends in the grid
      for (int x = 0; x < x0; ++x) edge(x);
      for (int x = x0; x < x1; ++x) cur[x] = prev[x] & std::uint8_t(sv[x - s] == sv[x]) & std::uint8_t(sv[x + s] == sv[x]);
      for (int x = x1; x < w; ++x) edge(x);
    }
    for (int dy = -r; dy <= r; ++dy) {
      const int y = v - dy, s = span[std::size_t(dy + r)];
      if (s < 0 || y < 0 || y >= h) continue;
      const std::uint8_t* rs = run[std::size_t(s)].data();
      const std::uint8_t* sy = &side.data[side.index(0, y)];
      std::uint8_t* __restrict d = &deep.data[deep.index(0, y)];
      for (int x = 0; x < w; ++x) d[x] &= std::uint8_t(rs[x] & (sv[x] == sy[x]));
    }
  }
  // Thin: no pixel of its own side within one step (3 x 3) is deep. Bit 0:
  // a deep inside pixel, bit 1 a deep outside one, OR-ed over the 3 x 3.
  Grid2u8 rows(w, h), thin(w, h);
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* d = &deep.data[deep.index(0, y)];
    const std::uint8_t* sy = &side.data[side.index(0, y)];
    std::uint8_t* __restrict o = &rows.data[rows.index(0, y)];
    const auto bits = [&](int x) { return std::uint8_t((d[x] & sy[x]) | (d[x] & (sy[x] ^ 1)) * 2); };
    const auto edge = [&](int x) { o[x] = std::uint8_t((x > 0 ? bits(x - 1) : 0) | bits(x) | (x + 1 < w ? bits(x + 1) : 0)); };
    edge(0);
    for (int x = 1; x + 1 < w; ++x) o[x] = std::uint8_t(bits(x - 1) | bits(x) | bits(x + 1));
    if (w > 1) edge(w - 1);
  }
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* above = &rows.data[rows.index(0, std::max(0, y - 1))];
    const std::uint8_t* here = &rows.data[rows.index(0, y)];
    const std::uint8_t* below = &rows.data[rows.index(0, std::min(h - 1, y + 1))];
    const std::uint8_t* sy = &side.data[side.index(0, y)];
    std::uint8_t* __restrict t = &thin.data[thin.index(0, y)];
    for (int x = 0; x < w; ++x) t[x] = ((above[x] | here[x] | below[x]) & (2 - sy[x])) == 0;
  }
  return thin;
}

}  // namespace detail

Grid2f smoothed_mask(const Grid2u8& inside, double sigma) {
  Grid2f f = gaussian(inside, sigma);
  for (float& v : f.data) v -= 0.5f;
  return f;
}

Grid2f clamped_smoothed_mask(const Grid2u8& inside, const MaskCurveParams& p) {
  Grid2f f = gaussian(inside, p.sigma);
  const bool adaptive = p.thin_margin != p.margin && p.thin_width > 0;
  const Grid2u8 thin = adaptive ? detail::thin_side(inside, p.thin_width) : Grid2u8();
  // Both sides' clamps computed and one selected: no branch per pixel.
  const float thin_m = float(p.thin_margin), broad_m = float(p.margin);
  const auto clamp = [&](std::size_t i, bool thin_here) {
    const float m = thin_here ? thin_m : broad_m, v = f.data[i];
    const float up = std::max(v, 0.5f + m), down = std::min(v, 0.5f - m);
    f.data[i] = (inside.data[i] ? up : down) - 0.5f;
  };
  if (adaptive)
    for (std::size_t i = 0; i < f.size(); ++i) clamp(i, thin.data[i] != 0);
  else
    for (std::size_t i = 0; i < f.size(); ++i) clamp(i, false);
  return f;
}

}  // namespace isoloft
