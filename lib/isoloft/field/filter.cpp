#include "isoloft/field/filter.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

void check_field(const Grid2f& d) {
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x)
      if (std::isnan(d(x, y)))
        throw InputError("distance field", "NaN at pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")");
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

Grid2f distance_filter(const Grid2f& d, const FilterParams& p) {
  params_table<FilterParams>().validate(p);
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
    tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
      for (int y = rows.begin(); y != rows.end(); ++y) {
        const float* row = d.data.data() + d.index(0, y);
        for (int x = 0; x < w; ++x) {
          const int xa = std::max(0, x - far.r), xb = std::min(w - 1, x + far.r);
          const float* gx = far.g.data() + (far.r - x);
          float s = 0.0f, sx = 0.0f;
          for (int xx = xa; xx <= xb; ++xx) {
            s += gx[xx] * row[xx];
            sx += gx[xx];
          }
          rows_pass(x, y) = s / sx;
        }
      }
    });
  }
  Grid2f out(w, h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const float in = d(x, y);
        const double a = std::abs(double(in));
        if (a <= p.d_min) {
          out(x, y) = in;
          continue;
        }
        if (a >= p.d_max) {
          const int ya = std::max(0, y - far.r), yb = std::min(h - 1, y + far.r);
          const float* gy = far.g.data() + (far.r - y);
          double acc = 0.0, sy = 0.0;
          for (int yy = ya; yy <= yb; ++yy) {
            acc += double(gy[yy]) * rows_pass(x, yy);
            sy += gy[yy];
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
        for (int yy = ya; yy <= yb; ++yy) {
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
