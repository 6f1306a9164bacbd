#include "isoloft/contour/mask_curve.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "isoloft/field/edt.h"

namespace isoloft {

namespace {

// Separable Gaussian of a 0/1 image, zero beyond the grid; radius 3 sigma.
Grid2f gaussian(const Grid2u8& m, double sigma) {
  Grid2f out(m.width, m.height, 0.0f);
  for (std::size_t i = 0; i < m.size(); ++i) out.data[i] = m.data[i] ? 1.0f : 0.0f;
  if (!(sigma > 0)) return out;
  const int r = int(std::ceil(3 * sigma));
  std::vector<float> w(std::size_t(2 * r + 1));
  double sum = 0;
  for (int i = -r; i <= r; ++i) sum += w[std::size_t(i + r)] = float(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& v : w) v = float(v / sum);
  Grid2f tmp(m.width, m.height, 0.0f);
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      float s = 0;
      for (int i = std::max(-r, -x); i <= std::min(r, m.width - 1 - x); ++i) s += w[std::size_t(i + r)] * out(x + i, y);
      tmp(x, y) = s;
    }
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      float s = 0;
      for (int i = std::max(-r, -y); i <= std::min(r, m.height - 1 - y); ++i) s += w[std::size_t(i + r)] * tmp(x, y + i);
      out(x, y) = s;
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
  // Pixels at least `reach` from the border test their window without bounds checks.
  struct Window {
    std::vector<std::pair<int, int>> offsets;
    std::vector<std::ptrdiff_t> linear;
    int reach = 0;
  };
  const auto window = [w](int reach, int s_below) {
    Window win;
    win.reach = reach;
    for (int dy = -reach; dy <= reach; ++dy)
      for (int dx = -reach; dx <= reach; ++dx)
        if (dx * dx + dy * dy < s_below) win.offsets.emplace_back(dx, dy), win.linear.push_back(std::ptrdiff_t(dy) * w + dx);
    return win;
  };
  // all(x, y, win, pred): pred(u, v, index) for every window pixel in the grid.
  const auto all = [w, h](int x, int y, const Window& win, const auto& pred) {
    const std::size_t i = std::size_t(y) * std::size_t(w) + std::size_t(x);
    if (x >= win.reach && y >= win.reach && x + win.reach < w && y + win.reach < h) {
      for (const std::ptrdiff_t d : win.linear)
        if (!pred(std::size_t(std::ptrdiff_t(i) + d))) return false;
      return true;
    }
    for (const auto& [dx, dy] : win.offsets) {
      const int u = x + dx, v = y + dy;
      if (u >= 0 && v >= 0 && u < w && v < h && !pred(std::size_t(v) * std::size_t(w) + std::size_t(u))) return false;
    }
    return true;
  };
  const Window near = window(r, s_min), step = window(1, 3);  // step: the 3 x 3
  Grid2u8 deep(w, h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::uint8_t side = m(x, y);
      deep(x, y) = all(x, y, near, [&](std::size_t q) { return m.data[q] == side; });
    }
  // Thin: no pixel of its own side within one step (3 x 3) is deep.
  Grid2u8 thin(w, h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::uint8_t side = m(x, y);
      thin(x, y) = all(x, y, step, [&](std::size_t q) { return m.data[q] != side || !deep.data[q]; });
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
  for (std::size_t i = 0; i < f.size(); ++i) {
    const float m = float(adaptive && thin.data[i] ? p.thin_margin : p.margin);
    float& v = f.data[i];
    v = (inside.data[i] ? std::max(v, 0.5f + m) : std::min(v, 0.5f - m)) - 0.5f;
  }
  return f;
}

}  // namespace isoloft
