#include "isoloft/field/filter.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>
#include <numbers>
#include <string>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

void check_field(const Grid2f& d) {
  int any_nan = 0;  // one pass without a branch (an int: vectorised), then the first NaN named
  for (const float v : d.data) any_nan |= v != v;
  if (!any_nan) return;
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x)
      if (std::isnan(d(x, y)))
        throw InputError("distance field", "NaN at pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")");
}

// The first i in [from, n) with mask[i] != 0, else n; eight bytes at a time
// over zeros.
int next_set(const std::uint8_t* mask, int from, int n) {
  int i = from;
  for (std::uint64_t eight = 0; i + 8 <= n; i += 8) {
    std::memcpy(&eight, mask + i, sizeof eight);
    if (eight != 0) break;
  }
  while (i < n && !mask[i]) ++i;
  return i;
}

// Stencil radius ceil(3 sigma); the epsilon keeps 3 * 0.5 from rounding up.
int stencil_radius(double sigma) { return int(std::ceil(3.0 * sigma - 1e-9)); }

// The sign rule: keep the input's sign, |out| >= d_min.
float clamp_to_side(float in, double filtered, double d_min) {
  const float floor_abs = d_min > 0.0 ? float(d_min) : std::numeric_limits<float>::min();
  return in > 0.0f ? std::max(float(filtered), floor_abs) : std::min(float(filtered), -floor_abs);
}

}  // namespace

double filter_sigma(double abs_d, const FilterParams& p) {
  if (abs_d <= p.d_min) return 0.0;
  if (abs_d >= p.d_max) return p.sigma_max;
  const double t = (abs_d - p.d_min) / (p.d_max - p.d_min);
  return p.sigma_min + (p.sigma_max - p.sigma_min) * 0.5 * (1.0 - std::cos(std::numbers::pi * t));
}

int filter_reach(const FilterParams& p) {
  return p.enabled ? stencil_radius(double(std::lround(p.sigma_max / kSigmaQuantum)) * kSigmaQuantum) : 0;
}

namespace {

// Per row y, the columns [lo, hi] whose row pass the far pixels of `only`
// read (rows y - r .. y + r); lo > hi: none. Without `only`, every column.
std::vector<std::pair<int, int>> row_pass_spans(const Grid2f& d, const Grid2u8* only, double d_max, int r) {
  const int w = d.width, h = d.height;
  std::vector<std::pair<int, int>> span(std::size_t(h), {0, w - 1});
  if (!only) return span;
  std::vector<std::pair<int, int>> far(std::size_t(h), {w, -1});  // needed far pixels of each row
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (only->data[d.index(x, y)] && std::abs(double(d(x, y))) >= d_max)
        far[std::size_t(y)].first = std::min(far[std::size_t(y)].first, x), far[std::size_t(y)].second = x;
  for (int y = 0; y < h; ++y) {
    auto& s = span[std::size_t(y)];
    s = {w, -1};
    for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy)
      s.first = std::min(s.first, far[std::size_t(yy)].first), s.second = std::max(s.second, far[std::size_t(yy)].second);
  }
  return span;
}

}  // namespace

Grid2f distance_filter(const Grid2f& d, const FilterParams& p, const Grid2u8* only) {
  params_table<FilterParams>().validate(p);
  if (only && (only->width != d.width || only->height != d.height))
    throw ParamError("distance filter: the mask of pixels to filter is " + std::to_string(only->width) + "x" +
                     std::to_string(only->height) + ", the field " + std::to_string(d.width) + "x" +
                     std::to_string(d.height));
  if (!p.enabled || d.empty()) return d;
  check_field(d);
  // 1D weights per quantized sigma: kernel k has sigma k * kSigmaQuantum.
  const long k0 = std::lround(p.sigma_min / kSigmaQuantum), k1 = std::lround(p.sigma_max / kSigmaQuantum);
  struct Kernel {
    int r = 0;
    std::vector<float> g;  // g[j + r] = exp(-j^2 / (2 sigma^2)), j in [-r, r]
  };
  std::vector<Kernel> kernels(std::size_t(k1 - k0 + 1));
  for (long k = k0; k <= k1; ++k) {
    Kernel& K = kernels[std::size_t(k - k0)];
    const double sigma = double(k) * kSigmaQuantum;
    K.r = sigma > 0.0 ? stencil_radius(sigma) : 0;
    K.g.resize(std::size_t(2 * K.r + 1));
    for (int j = -K.r; j <= K.r; ++j)
      K.g[std::size_t(j + K.r)] = sigma > 0.0 ? float(std::exp(-double(j * j) / (2.0 * sigma * sigma))) : 1.0f;
  }
  const int w = d.width, h = d.height;
  // Pixels at |d| >= d_max all have sigma_max. For one fixed sigma the
  // clipped, normalized 2D Gaussian average is the product of two clipped,
  // normalized 1D ones, so a row pass then a column pass give the same value
  // (up to float rounding) with 2 (2r + 1) instead of (2r + 1)^2 products.
  // An exact identity, not a separable approximation.
  const Kernel& far = kernels.back();  // sigma_max
  const bool any_far =
      std::any_of(d.data.begin(), d.data.end(), [&](float v) { return std::abs(double(v)) >= p.d_max; });
  Grid2f rows_pass;
  if (any_far) {
    rows_pass = Grid2f(w, h);
    const std::vector<std::pair<int, int>> spans = row_pass_spans(d, only, p.d_max, far.r);
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
      for (int y = rows.begin(); y != rows.end(); ++y) {
        const auto [x_lo, x_hi] = spans[std::size_t(y)];
        if (x_lo > x_hi) continue;
        const float* row = d.data.data() + d.index(0, y);
        const auto one = [&](int x) {
          const int xa = std::max(0, x - far.r), xb = std::min(w - 1, x + far.r);
          const float* gx = far.g.data() + (far.r - x);
          float s = 0.0f, sx = 0.0f;
          for (int xx = xa; xx <= xb; ++xx) {
            s += gx[xx] * row[xx];
            sx += gx[xx];
          }
          rows_pass(x, y) = s / sx;
        };
        // Away from the row's ends the stencil is whole: its weight sum is
        // one number, and four pixels' sums run side by side (each in its
        // own order, so the same floats as one() gives).
        const int n = 2 * far.r + 1, interior0 = far.r, interior1 = w - far.r;  // [interior0, interior1)
        float whole = 0.0f;
        for (int j = 0; j < n; ++j) whole += far.g[std::size_t(j)];
        for (int x = x_lo; x <= x_hi;) {
          if (x < interior0 || x + 4 > std::min(interior1, x_hi + 1)) {
            one(x++);
            continue;
          }
          const float* src = row + (x - far.r);
          float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f, s3 = 0.0f;
          for (int j = 0; j < n; ++j) {
            const float g = far.g[std::size_t(j)];
            s0 += g * src[j], s1 += g * src[j + 1], s2 += g * src[j + 2], s3 += g * src[j + 3];
          }
          float* o = &rows_pass(x, y);
          o[0] = s0 / whole, o[1] = s1 / whole, o[2] = s2 / whole, o[3] = s3 / whole;
          x += 4;
        }
      }
    });
  }
  Grid2f out(w, h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      const int ya_far = std::max(0, y - far.r), yb_far = std::min(h - 1, y + far.r);
      const float* gy_far = far.g.data() + (far.r - y);
      const auto is_far = [&](int x) { return std::abs(double(d(x, y))) >= p.d_max; };
      const std::uint8_t* wanted = only ? &only->data[d.index(0, y)] : nullptr;
      const auto all_wanted = [&](int x) { return !wanted || (wanted[x] && wanted[x + 1] && wanted[x + 2] && wanted[x + 3]); };
      for (int x = 0; x < w; ++x) {
        if (wanted && !wanted[x]) {  // a run of pixels kept as they are, copied at once
          const int end = next_set(wanted, x + 1, w);
          std::copy(&d.data[d.index(x, y)], &d.data[d.index(0, y)] + end, &out.data[out.index(x, y)]);
          x = end - 1;
          continue;
        }
        if (any_far && x + 4 <= w && all_wanted(x) && is_far(x) && is_far(x + 1) && is_far(x + 2) && is_far(x + 3)) {
          // Four far pixels side by side: the column pass below, each sum in
          // its own order (the same doubles), over contiguous loads.
          double acc0 = 0.0, acc1 = 0.0, acc2 = 0.0, acc3 = 0.0, sy = 0.0;
          for (int yy = ya_far; yy <= yb_far; ++yy) {
            const double g = double(gy_far[yy]);
            const float* rp = &rows_pass(x, yy);
            acc0 += g * rp[0], acc1 += g * rp[1], acc2 += g * rp[2], acc3 += g * rp[3];
            sy += gy_far[yy];
          }
          out(x, y) = clamp_to_side(d(x, y), acc0 / sy, p.d_min);
          out(x + 1, y) = clamp_to_side(d(x + 1, y), acc1 / sy, p.d_min);
          out(x + 2, y) = clamp_to_side(d(x + 2, y), acc2 / sy, p.d_min);
          out(x + 3, y) = clamp_to_side(d(x + 3, y), acc3 / sy, p.d_min);
          x += 3;
          continue;
        }
        const float in = d(x, y);
        const double a = std::abs(double(in));
        if (a <= p.d_min) {
          out(x, y) = in;
          continue;
        }
        if (a >= p.d_max) {
          double acc = 0.0, sy = 0.0;
          for (int yy = ya_far; yy <= yb_far; ++yy) {
            acc += double(gy_far[yy]) * rows_pass(x, yy);
            sy += gy_far[yy];
          }
          out(x, y) = clamp_to_side(in, acc / sy, p.d_min);
          continue;
        }
        const long k = std::clamp(std::lround(filter_sigma(a, p) / kSigmaQuantum), k0, k1);
        const Kernel& K = kernels[std::size_t(k - k0)];
        const int xa = std::max(0, x - K.r), xb = std::min(w - 1, x + K.r);
        const int ya = std::max(0, y - K.r), yb = std::min(h - 1, y + K.r);
        const float* gx = K.g.data() + (K.r - x);  // gx[xx] = g(xx - x)
        const float* gy = K.g.data() + (K.r - y);
        double sx = 0.0, sy = 0.0, acc = 0.0;
        for (int xx = xa; xx <= xb; ++xx) sx += gx[xx];
        int yy = ya;
        for (; yy + 3 <= yb; yy += 4) {  // four rows' sums side by side, each in the one-row order
          const float* r0 = d.data.data() + d.index(0, yy);
          const float *r1 = r0 + w, *r2 = r1 + w, *r3 = r2 + w;
          float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f, s3 = 0.0f;
          for (int xx = xa; xx <= xb; ++xx) {
            const float g = gx[xx];
            s0 += g * r0[xx], s1 += g * r1[xx], s2 += g * r2[xx], s3 += g * r3[xx];
          }
          acc += double(gy[yy]) * double(s0);
          sy += gy[yy];
          acc += double(gy[yy + 1]) * double(s1);
          sy += gy[yy + 1];
          acc += double(gy[yy + 2]) * double(s2);
          sy += gy[yy + 2];
          acc += double(gy[yy + 3]) * double(s3);
          sy += gy[yy + 3];
        }
        for (; yy <= yb; ++yy) {
          const float* row = d.data.data() + d.index(0, yy);
          float s = 0.0f;
          for (int xx = xa; xx <= xb; ++xx) s += gx[xx] * row[xx];
          acc += double(gy[yy]) * double(s);
          sy += gy[yy];
        }
        out(x, y) = clamp_to_side(in, acc / (sx * sy), p.d_min);
      }
    }
  });
  return out;
}

namespace detail {

double quantized_sigma(double sigma) { return double(std::lround(sigma / kSigmaQuantum)) * kSigmaQuantum; }

Grid2f distance_filter_naive(const Grid2f& d, const FilterParams& p) {
  params_table<FilterParams>().validate(p);
  if (!p.enabled || d.empty()) return d;
  check_field(d);
  Grid2f out(d.width, d.height);
  for (int y = 0; y < d.height; ++y) {
    for (int x = 0; x < d.width; ++x) {
      const float in = d(x, y);
      if (std::abs(double(in)) <= p.d_min) {
        out(x, y) = in;
        continue;
      }
      const double sigma = quantized_sigma(filter_sigma(std::abs(double(in)), p));
      const int r = sigma > 0.0 ? stencil_radius(sigma) : 0;
      double acc = 0.0, wsum = 0.0;
      for (int yy = std::max(0, y - r); yy <= std::min(d.height - 1, y + r); ++yy) {
        for (int xx = std::max(0, x - r); xx <= std::min(d.width - 1, x + r); ++xx) {
          const double r2 = double((xx - x) * (xx - x) + (yy - y) * (yy - y));
          const double wgt = sigma > 0.0 ? std::exp(-r2 / (2.0 * sigma * sigma)) : (r2 == 0.0 ? 1.0 : 0.0);
          acc += wgt * d(xx, yy);
          wsum += wgt;
        }
      }
      out(x, y) = clamp_to_side(in, acc / wsum, p.d_min);
    }
  }
  return out;
}

}  // namespace detail
}  // namespace isoloft
