#include "isoloft/contour/mask_curve.h"

#include <algorithm>
#include <cmath>
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

// Per pixel: is its own side (mask or complement) thinner than `width` here?
// A side is thin at p when no pixel of it within one step (3 x 3) lies
// width / 2 or more from the side's edge.
Grid2u8 thin_side(const Grid2u8& m, double width) {
  Grid2u8 complement(m.width, m.height, 0);
  for (std::size_t i = 0; i < m.size(); ++i) complement.data[i] = !m.data[i];
  // Positive on each side: the distance to the edge between the two.
  const Grid2f d_in = distance_to_mask_edge_signed(m), d_out = distance_to_mask_edge_signed(complement);
  Grid2u8 thin(m.width, m.height, 0);
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      const Grid2f& d = m(x, y) ? d_in : d_out;
      float deepest = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int u = x + dx, v = y + dy;
          if (u < 0 || v < 0 || u >= m.width || v >= m.height || m(u, v) != m(x, y)) continue;
          deepest = std::max(deepest, d(u, v));
        }
      thin(x, y) = deepest < 0.5 * width;
    }
  return thin;
}

}  // namespace

Grid2f clamped_smoothed_mask(const Grid2u8& inside, const MaskCurveParams& p) {
  Grid2f f = gaussian(inside, p.sigma);
  const bool adaptive = p.thin_margin != p.margin && p.thin_width > 0;
  const Grid2u8 thin = adaptive ? thin_side(inside, p.thin_width) : Grid2u8();
  for (std::size_t i = 0; i < f.size(); ++i) {
    const float m = float(adaptive && thin.data[i] ? p.thin_margin : p.margin);
    float& v = f.data[i];
    v = (inside.data[i] ? std::max(v, 0.5f + m) : std::min(v, 0.5f - m)) - 0.5f;
  }
  return f;
}

}  // namespace isoloft
