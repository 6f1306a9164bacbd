// Felzenszwalb & Huttenlocher 2012 exact EDT; see edt.h.
#include "isoloft/field/edt.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Exact squared EDT as integer-valued doubles (+inf: no feature). Kept in
/// double so the signed transforms take sqrt of the exact value.
std::vector<double> squared_edt_exact(const Grid2u8& features) {
  const int w = features.width;
  const int h = features.height;
  std::vector<double> g(features.size(), kInf);
  if (g.empty()) return g;

  // Pass 1: columns. For a 0/inf input the 1D transform is the squared
  // distance to the nearest feature in the column, found by a downward and
  // an upward sweep; sweeping whole rows keeps memory access sequential.
  // Parallel over blocks of columns.
  constexpr int kNone = std::numeric_limits<int>::max() / 2;  // no feature seen yet
  constexpr int kBlock = 256;
  tbb::parallel_for(tbb::blocked_range<int>(0, (w + kBlock - 1) / kBlock), [&](const tbb::blocked_range<int>& r) {
    std::vector<int> dist(static_cast<std::size_t>(kBlock));
    for (int b = r.begin(); b != r.end(); ++b) {
      const int x0 = b * kBlock, x1 = std::min(w, x0 + kBlock), n = x1 - x0;
      std::vector<int> col(std::size_t(n) * std::size_t(h));
      std::fill(dist.begin(), dist.end(), kNone);
      for (int y = 0; y < h; ++y)
        for (int i = 0; i < n; ++i) {
          int& d = dist[std::size_t(i)];
          d = features(x0 + i, y) ? 0 : std::min(d + 1, kNone);
          col[std::size_t(y) * std::size_t(n) + std::size_t(i)] = d;
        }
      std::fill(dist.begin(), dist.end(), kNone);
      for (int y = h - 1; y >= 0; --y)
        for (int i = 0; i < n; ++i) {
          int& d = dist[std::size_t(i)];
          int& c = col[std::size_t(y) * std::size_t(n) + std::size_t(i)];
          d = c == 0 ? 0 : std::min(d + 1, kNone);
          c = std::min(c, d);
          g[features.index(x0 + i, y)] = c >= kNone ? kInf : double(c) * double(c);
        }
    }
  });
  // Pass 2: rows, on the column result; rows are contiguous, so in place via a copy.
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& r) {
    std::vector<double> f(static_cast<std::size_t>(w));
    std::vector<int> v;
    std::vector<double> z;
    for (int y = r.begin(); y != r.end(); ++y) {
      double* row = g.data() + features.index(0, y);
      std::copy(row, row + w, f.begin());
      detail::squared_dt_1d(f.data(), row, w, v, z);
    }
  });
  return g;
}

void require_same_size(const Grid2u8& a, const Grid2u8& b, const char* what) {
  if (a.width != b.width || a.height != b.height)
    throw ParamError(std::string(what) + ": contour is " + std::to_string(a.width) + "x" +
                     std::to_string(a.height) + " but inside is " + std::to_string(b.width) + "x" +
                     std::to_string(b.height));
}

/// Shared by the fast transform and its twin so both map the same exact
/// squared distance to the same float.
float contour_value(double sq, bool on_contour, bool inside) {
  if (on_contour) return 0.0f;
  const float mag = std::isinf(sq) ? kNoSurfaceDistance : float(std::sqrt(sq));
  return inside ? mag : -mag;
}

float mask_value(double sq_to_other_side, bool inside) {
  const float mag = std::isinf(sq_to_other_side) ? kNoSurfaceDistance
                                                 : float(std::sqrt(sq_to_other_side) - 0.5);
  return inside ? mag : -mag;
}

Grid2u8 complement(const Grid2u8& mask) {
  Grid2u8 out(mask.width, mask.height);
  for (std::size_t i = 0; i < mask.size(); ++i) out.data[i] = mask.data[i] ? 0 : 1;
  return out;
}

/// Brute-force squared distance from (x, y) to the nearest non-zero pixel.
double brute_sq(const Grid2u8& features, int x, int y) {
  std::int64_t best = -1;
  for (int fy = 0; fy < features.height; ++fy)
    for (int fx = 0; fx < features.width; ++fx) {
      if (!features(fx, fy)) continue;
      const std::int64_t dx = fx - x, dy = fy - y;
      const std::int64_t d = dx * dx + dy * dy;
      if (best < 0 || d < best) best = d;
    }
  return best < 0 ? kInf : double(best);
}

}  // namespace

namespace detail {

void squared_dt_1d(const double* f, double* d, int n, std::vector<int>& v, std::vector<double>& z) {
  squared_dt_1d_arg(f, d, nullptr, n, v, z);
}

void squared_dt_1d_arg(const double* f, double* d, int* arg, int n, std::vector<int>& v, std::vector<double>& z) {
  v.resize(std::size_t(n) + 1);
  z.resize(std::size_t(n) + 2);
  // Lower envelope of the parabolas y = f[p] + (x - p)^2 over present samples.
  // v[0..k]: roots of the envelope's parabolas; z[i], z[i+1]: range of v[i].
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (std::isinf(f[q])) continue;
    const double fq = f[q] + double(q) * double(q);
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
      continue;
    }
    double s = 0.0;
    for (;;) {
      const int p = v[std::size_t(k)];
      s = (fq - (f[p] + double(p) * double(p))) / (2.0 * double(q - p));
      if (s > z[std::size_t(k)]) break;
      --k;  // z[0] = -inf ends the loop at k = 0
    }
    ++k;
    v[std::size_t(k)] = q;
    z[std::size_t(k)] = s;
    z[std::size_t(k) + 1] = kInf;
  }
  if (k < 0) {
    std::fill(d, d + n, kInf);
    if (arg) std::fill(arg, arg + n, -1);
    return;
  }
  // Values at integers are integers, so an intersection s that is off by
  // rounding can only switch between parabolas that are equal at q: exact.
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[std::size_t(k) + 1] < double(q)) ++k;
    const int p = v[std::size_t(k)];
    const double dq = double(q - p);
    d[q] = dq * dq + f[p];
    if (arg) arg[q] = p;
  }
}

Grid2f squared_edt_brute(const Grid2u8& features) {
  Grid2f out(features.width, features.height);
  for (int y = 0; y < features.height; ++y)
    for (int x = 0; x < features.width; ++x) out(x, y) = float(brute_sq(features, x, y));
  return out;
}

Grid2f distance_to_contour_signed_brute(const Grid2u8& contour, const Grid2u8& inside) {
  require_same_size(contour, inside, "distance_to_contour_signed_brute");
  Grid2f out(contour.width, contour.height);
  for (int y = 0; y < contour.height; ++y)
    for (int x = 0; x < contour.width; ++x)
      out(x, y) = contour_value(brute_sq(contour, x, y), contour(x, y) != 0, inside(x, y) != 0);
  return out;
}

Grid2f nearest_label_brute_sq(const Grid2i& labels) {
  Grid2u8 features(labels.width, labels.height);
  for (std::size_t i = 0; i < labels.size(); ++i) features.data[i] = labels.data[i] >= 0;
  return squared_edt_brute(features);
}

Grid2f distance_to_mask_edge_signed_brute(const Grid2u8& mask) {
  const Grid2u8 outside = complement(mask);
  Grid2f out(mask.width, mask.height);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      const bool in = mask(x, y) != 0;
      out(x, y) = mask_value(brute_sq(in ? outside : mask, x, y), in);
    }
  return out;
}

}  // namespace detail

Grid2f squared_edt(const Grid2u8& features) {
  const std::vector<double> sq = squared_edt_exact(features);
  Grid2f out(features.width, features.height);
  for (std::size_t i = 0; i < sq.size(); ++i) out.data[i] = float(sq[i]);
  return out;
}

Grid2f distance_to_contour_signed(const Grid2u8& contour, const Grid2u8& inside) {
  require_same_size(contour, inside, "distance_to_contour_signed");
  const std::vector<double> sq = squared_edt_exact(contour);
  Grid2f out(contour.width, contour.height);
  for (std::size_t i = 0; i < sq.size(); ++i)
    out.data[i] = contour_value(sq[i], contour.data[i] != 0, inside.data[i] != 0);
  return out;
}

Grid2f distance_to_mask_edge_signed(const Grid2u8& mask) {
  const std::vector<double> to_inside = squared_edt_exact(mask);
  const std::vector<double> to_outside = squared_edt_exact(complement(mask));
  Grid2f out(mask.width, mask.height);
  for (std::size_t i = 0; i < mask.size(); ++i) {
    const bool in = mask.data[i] != 0;
    out.data[i] = mask_value(in ? to_outside[i] : to_inside[i], in);
  }
  return out;
}

Grid2i nearest_label(const Grid2i& labels) {
  const int w = labels.width, h = labels.height;
  Grid2i out(w, h, -1);
  if (labels.empty()) return out;
  // Pass 1, columns: the nearest labelled pixel of each column (a downward
  // and an upward sweep); pass 2, rows: the lower envelope over the column
  // results (squared_dt_1d_arg), whose minimiser names the column whose
  // nearest pixel wins.
  std::vector<double> g(labels.size(), kInf);
  Grid2i near_in_column(w, h, -1);
  tbb::parallel_for(tbb::blocked_range<int>(0, w, 64), [&](const tbb::blocked_range<int>& r) {
    for (int x = r.begin(); x != r.end(); ++x) {
      int last = -1;  // row of the last labelled pixel seen
      for (int y = 0; y < h; ++y) {
        if (labels(x, y) >= 0) last = y;
        if (last >= 0) {
          const double d = double(y - last);
          g[labels.index(x, y)] = d * d;
          near_in_column(x, y) = labels(x, last);
        }
      }
      last = -1;
      for (int y = h - 1; y >= 0; --y) {
        if (labels(x, y) >= 0) last = y;
        if (last < 0) continue;
        const double d = double(last - y);
        if (d * d < g[labels.index(x, y)]) g[labels.index(x, y)] = d * d, near_in_column(x, y) = labels(x, last);
      }
    }
  });
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& r) {
    std::vector<double> d(static_cast<std::size_t>(w));
    std::vector<int> arg(static_cast<std::size_t>(w)), v;
    std::vector<double> z;
    for (int y = r.begin(); y != r.end(); ++y) {
      detail::squared_dt_1d_arg(g.data() + labels.index(0, y), d.data(), arg.data(), w, v, z);
      for (int x = 0; x < w; ++x) out(x, y) = arg[std::size_t(x)] < 0 ? -1 : near_in_column(arg[std::size_t(x)], y);
    }
  });
  return out;
}

}  // namespace isoloft
