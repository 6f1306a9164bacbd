// Tests of field/filter.h: the distance-dependent Gaussian filter (paper 2.3,
// equation 3).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/field/filter.h"
#include "test_names.h"

namespace isoloft {
namespace {

// filter_sigma is a closed formula evaluated in double.
constexpr double kSigmaTol = 1e-12;
// Float sums: a row of at most 2r + 1 float products is off by <= 2r u
// |values| (u = FLT_EPSILON / 2), the weights by u each, the output rounding
// by u: 24 FLT_EPSILON covers r <= 9 (sigma_max = 3) with room.
double float_sum_tol(double max_abs) { return 24.0 * FLT_EPSILON * max_abs; }


double max_abs(const Grid2f& g) {
  double m = 0.0;
  for (const float v : g.data) m = std::max(m, std::abs(double(v)));
  return m;
}

TEST(DistanceFilter, SigmaFollowsEquation3) {
  const FilterParams p;  // d_min 4, d_max 15, sigma_min 0.5, sigma_max 3
  EXPECT_EQ(filter_sigma(0.0, p), 0.0);
  EXPECT_EQ(filter_sigma(4.0, p), 0.0);
  EXPECT_NEAR(filter_sigma(4.0 + 1e-9, p), 0.5, 1e-9);  // jumps to sigma_min just past d_min
  // (|d| - d_min) / (d_max - d_min) = 1/3: (1 - cos(pi/3)) / 2 = 1/4.
  EXPECT_NEAR(filter_sigma(4.0 + 11.0 / 3.0, p), 0.5 + 2.5 * 0.25, kSigmaTol);
  // Midpoint: (1 - cos(pi/2)) / 2 = 1/2.
  EXPECT_NEAR(filter_sigma(9.5, p), 1.75, kSigmaTol);
  // 2/3: (1 - cos(2 pi / 3)) / 2 = 3/4.
  EXPECT_NEAR(filter_sigma(4.0 + 22.0 / 3.0, p), 0.5 + 2.5 * 0.75, kSigmaTol);
  EXPECT_NEAR(filter_sigma(15.0 - 1e-9, p), 3.0, 1e-9);
  EXPECT_EQ(filter_sigma(15.0, p), 3.0);
  EXPECT_EQ(filter_sigma(1e6, p), 3.0);
  double prev = 0.0;
  for (double d = 4.01; d < 16.0; d += 0.01) {
    const double s = filter_sigma(d, p);
    ASSERT_GE(s, prev) << "sigma not monotone at |d| = " << d;
    prev = s;
  }
}

TEST(DistanceFilter, LinearFieldIsUnchangedAwayFromTheBorder) {
  // A symmetric kernel reproduces a linear function exactly.
  constexpr int n = 64;
  Grid2f d(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) d(x, y) = float(20.0 + 0.6 * x + 0.8 * y);  // |grad d| = 1, all > d_max
  const Grid2f out = distance_filter(d);
  const int margin = int(std::ceil(3.0 * FilterParams{}.sigma_max));
  const double tol = float_sum_tol(max_abs(d));
  for (int y = margin; y < n - margin; ++y)
    for (int x = margin; x < n - margin; ++x) ASSERT_NEAR(out(x, y), d(x, y), tol) << pixel_at(x, y);
}

TEST(DistanceFilter, ReducesTheMedialAxisCrease) {
  // Exact signed distance of the square [18, 78]^2: its diagonals are creases
  // where the 5-point Laplacian is -2 (d = min of two unit-slope planes), -4
  // at the centre where all four meet.
  constexpr int n = 96;
  constexpr double lo = 18.0, hi = 78.0;
  Grid2f d(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const double ox = std::max({lo - x, 0.0, x - hi}), oy = std::max({lo - y, 0.0, y - hi});
      d(x, y) = ox > 0 || oy > 0 ? float(-std::hypot(ox, oy)) : float(std::min({x - lo, hi - x, y - lo, hi - y}));
    }
  const Grid2f out = distance_filter(d);
  auto max_laplacian = [&](const Grid2f& g) {
    double m = 0.0;
    for (int y = 1; y + 1 < n; ++y)
      for (int x = 1; x + 1 < n; ++x) {
        if (d(x, y) <= FilterParams{}.d_max) continue;  // the inner square, sigma = sigma_max
        const double lap = double(g(x + 1, y)) + g(x - 1, y) + g(x, y + 1) + g(x, y - 1) - 4.0 * g(x, y);
        m = std::max(m, std::abs(lap));
      }
    return m;
  };
  const double before = max_laplacian(d), after = max_laplacian(out);
  EXPECT_NEAR(before, 4.0, 1e-5);
  // sigma = 3 spreads the unit slope jump over ~6 px: the crease's second
  // difference drops to ~1/(sigma sqrt(2 pi)) per unit jump, well below half.
  EXPECT_LT(after, 0.5 * before) << "before " << before << ", after " << after;
}

TEST(DistanceFilter, DisabledAndNoSurfaceFieldsPassThrough) {
  Grid2f d(20, 10);
  for (std::size_t i = 0; i < d.size(); ++i) d.data[i] = float(int(i % 37) - 18);
  FilterParams off;
  off.enabled = false;
  EXPECT_EQ(distance_filter(d, off), d);
  const Grid2f empty(20, 10, -kNoSurfaceDistance);
  const Grid2f out = distance_filter(empty);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 20; ++x) ASSERT_NEAR(out(x, y), -kNoSurfaceDistance, float_sum_tol(kNoSurfaceDistance)) << pixel_at(x, y);
}

TEST(DistanceFilter, RejectsBadInput) {
  const Grid2f d(4, 4, 10.0f);
  auto with = [](auto set) {
    FilterParams p;
    set(p);
    return p;
  };
  EXPECT_THROW(distance_filter(d, with([](FilterParams& p) { p.d_min = -1; })), ParamError);
  EXPECT_THROW(distance_filter(d, with([](FilterParams& p) { p.d_max = 4; })), ParamError);
  EXPECT_THROW(distance_filter(d, with([](FilterParams& p) { p.sigma_min = -0.1; })), ParamError);
  EXPECT_THROW(distance_filter(d, with([](FilterParams& p) { p.sigma_max = 0.25; })), ParamError);
  EXPECT_THROW(distance_filter(d, with([](FilterParams& p) { p.sigma_max = 100; })), ParamError);
  EXPECT_THROW(distance_filter(d, with([](FilterParams& p) { p.d_max = std::nan(""); })), ParamError);
  Grid2f nan = d;
  nan(1, 2) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(distance_filter(nan), InputError);
}

// Random fields (including sign changes between neighbours, where averaging
// would flip signs) and random valid parameters.
RC_GTEST_PROP(DistanceFilter, KeepsSignsAndTheInnerBand, ()) {
  const int w = *rc::gen::inRange(1, 25), h = *rc::gen::inRange(1, 25);
  Grid2f d(w, h);
  for (float& v : d.data) v = float(*rc::gen::inRange(-4000, 4001) / 100.0);
  FilterParams p;
  p.d_min = *rc::gen::inRange(0, 801) / 100.0;
  p.d_max = p.d_min + *rc::gen::inRange(50, 2001) / 100.0;
  p.sigma_min = *rc::gen::inRange(0, 301) / 100.0;
  p.sigma_max = p.sigma_min + *rc::gen::inRange(0, 301) / 100.0;
  const Grid2f out = distance_filter(d, p);
  const Grid2f twin = detail::distance_filter_naive(d, p);
  const double tol = float_sum_tol(max_abs(d));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float in = d(x, y), o = out(x, y);
      if (std::abs(double(in)) <= p.d_min) {
        if (std::bit_cast<std::uint32_t>(o) != std::bit_cast<std::uint32_t>(in))
          RC_FAIL("value within d_min changed at " + pixel_at(x, y));
        continue;
      }
      if ((o > 0.0f) != (in > 0.0f) || o == 0.0f) RC_FAIL("sign flipped at " + pixel_at(x, y));
      if (std::abs(double(o)) < float(p.d_min)) RC_FAIL("pulled inside d_min at " + pixel_at(x, y));
      if (std::abs(double(o) - twin(x, y)) > tol)
        RC_FAIL("fast " + std::to_string(o) + " vs naive twin " + std::to_string(twin(x, y)) + " at " + pixel_at(x, y));
    }
}

}  // namespace
}  // namespace isoloft
