// z splines (paper 2.4): each kind reproduces its defining property, and the
// monotone kind never overshoots (Hyman 1983), while Catmull-Rom and natural
// cubic do on some monotone data.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "isoloft/core/error.h"
#include "isoloft/interp/spline.h"

using namespace isoloft;

namespace {
// Round-off of double Hermite evaluation on values of order 100.
constexpr double kEvalTol = 1e-9;
// Samples per interval when scanning an interpolant.
constexpr int kScan = 64;

constexpr SplineKind kAllKinds[] = {SplineKind::Monotone, SplineKind::ExtremumPreserving, SplineKind::CatmullRom,
                                    SplineKind::Natural, SplineKind::Linear};

std::vector<double> knots(const std::vector<double>& gaps) {
  std::vector<double> z{0.0};
  for (double g : gaps) z.push_back(z.back() + g);
  return z;
}
}  // namespace

TEST(Spline, EveryKindInterpolatesItsData) {
  const std::vector<double> z{0, 1, 3, 3.5, 7}, f{2, -1, 4, 4, 0};
  for (auto kind : kAllKinds) {
    const Spline1D s(z, f, kind);
    for (std::size_t i = 0; i < z.size(); ++i) EXPECT_NEAR(s(z[i]), f[i], kEvalTol) << to_string(kind) << " knot " << i;
  }
}

TEST(Spline, CubicKindsReproduceLinesAndLinearIsPiecewiseLinear) {
  const std::vector<double> z{0, 2, 3, 7, 8};
  std::vector<double> f;
  for (double v : z) f.push_back(3 - 0.5 * v);
  for (auto kind : kAllKinds) {
    const Spline1D s(z, f, kind);
    for (double q = 0; q <= 8; q += 0.125) EXPECT_NEAR(s(q), 3 - 0.5 * q, kEvalTol) << to_string(kind) << " at z=" << q;
  }
}

TEST(Spline, NaturalHasContinuousSecondDerivativeAndZeroAtEnds) {
  const std::vector<double> z{0, 1, 2.5, 4, 4.5, 6}, f{0, 2, 1, 3, 2.5, 0};
  const Spline1D s(z, f, SplineKind::Natural);
  const auto& m = s.tangents();
  // Second derivative of the Hermite piece on [z_k, z_k+1] at its two ends.
  auto d2_start = [&](std::size_t k) {
    const double h = z[k + 1] - z[k];
    return (6 * (f[k + 1] - f[k]) - h * (4 * m[k] + 2 * m[k + 1])) / (h * h);
  };
  auto d2_end = [&](std::size_t k) {
    const double h = z[k + 1] - z[k];
    return (-6 * (f[k + 1] - f[k]) + h * (2 * m[k] + 4 * m[k + 1])) / (h * h);
  };
  constexpr double kC2Tol = 1e-9;  // round-off of the tridiagonal solve
  for (std::size_t k = 1; k + 1 < z.size(); ++k) EXPECT_NEAR(d2_end(k - 1), d2_start(k), kC2Tol) << "knot " << k;
  EXPECT_NEAR(d2_start(0), 0.0, kC2Tol);
  EXPECT_NEAR(d2_end(z.size() - 2), 0.0, kC2Tol);
}

TEST(Spline, CatmullRomTangentsAreCentralDifferences) {
  const std::vector<double> z{0, 1, 3, 4}, f{0, 1, 5, 2};
  const Spline1D s(z, f, SplineKind::CatmullRom);
  EXPECT_NEAR(s.tangents()[1], (5.0 - 0.0) / 3.0, kEvalTol);
  EXPECT_NEAR(s.tangents()[2], (2.0 - 1.0) / 3.0, kEvalTol);
}

TEST(Spline, MonotoneIsFlatAtLocalExtremaOfTheData) {
  const std::vector<double> z{0, 1, 2, 3}, f{0, 5, 1, 1};
  const Spline1D s(z, f, SplineKind::Monotone);
  EXPECT_EQ(s.tangents()[1], 0.0);
  EXPECT_EQ(s.tangents()[2], 0.0);
}

TEST(Spline, RejectsNonIncreasingKnotsAndUnknownNames) {
  EXPECT_THROW(Spline1D({0, 1, 1}, {0, 1, 2}, SplineKind::Monotone), ParamError);
  EXPECT_THROW(enum_from_string<SplineKind>("cubic", "spline"), ParamError);
  EXPECT_EQ(enum_from_string<SplineKind>("catmull-rom", "spline"), SplineKind::CatmullRom);
}

// On any data, every interval of the monotone spline is monotone and stays
// within the range of its two data values (Hyman 1983; paper 2.4).
RC_GTEST_PROP(SplineProperty, MonotoneNeverLeavesItsIntervalRange, ()) {
  const int n = *rc::gen::inRange(2, 9);
  const auto gaps = *rc::gen::container<std::vector<double>>(std::size_t(n - 1), rc::gen::map(rc::gen::inRange(1, 200), [](int v) { return v / 10.0; }));
  const auto f = *rc::gen::container<std::vector<double>>(std::size_t(n), rc::gen::map(rc::gen::inRange(-1000, 1000), [](int v) { return v / 10.0; }));
  const auto z = knots(gaps);
  const Spline1D s(z, f, SplineKind::Monotone);
  for (int k = 0; k + 1 < n; ++k) {
    const double lo = std::min(f[k], f[k + 1]), hi = std::max(f[k], f[k + 1]);
    double prev = f[k];
    const double dir = f[k + 1] >= f[k] ? 1.0 : -1.0;
    for (int i = 1; i <= kScan; ++i) {
      const double q = z[k] + (z[k + 1] - z[k]) * i / kScan;
      const double v = s(q);
      RC_ASSERT(v >= lo - kEvalTol);
      RC_ASSERT(v <= hi + kEvalTol);
      RC_ASSERT(dir * (v - prev) >= -kEvalTol);
      prev = v;
    }
  }
}

// Random knots and values in 0.1 steps (values in [-100, 100]).
std::pair<std::vector<double>, std::vector<double>> random_data(int n) {
  const auto gaps = *rc::gen::container<std::vector<double>>(std::size_t(n - 1), rc::gen::map(rc::gen::inRange(1, 200), [](int v) { return v / 10.0; }));
  const auto f = *rc::gen::container<std::vector<double>>(std::size_t(n), rc::gen::map(rc::gen::inRange(-1000, 1000), [](int v) { return v / 10.0; }));
  return {knots(gaps), f};
}

// Extremum-preserving: where the data are monotone (sorted), every interval
// stays within its two data values, as Hyman's (no overshoot).
RC_GTEST_PROP(SplineProperty, ExtremumPreservingIsMonotoneOnMonotoneData, ()) {
  const int n = *rc::gen::inRange(2, 9);
  auto [z, f] = random_data(n);
  std::sort(f.begin(), f.end());
  if (*rc::gen::arbitrary<bool>()) std::reverse(f.begin(), f.end());
  const Spline1D s(z, f, SplineKind::ExtremumPreserving);
  for (int k = 0; k + 1 < n; ++k) {
    const double lo = std::min(f[k], f[k + 1]), hi = std::max(f[k], f[k + 1]);
    for (int i = 0; i <= kScan; ++i) {
      const double v = s(z[k] + (z[k + 1] - z[k]) * i / kScan);
      RC_ASSERT(v >= lo - kEvalTol);
      RC_ASSERT(v <= hi + kEvalTol);
    }
  }
}

// Extremum-preserving, any data: an interval whose two values share a sign
// keeps it throughout (no zero crossing the slices do not have: the field's
// inside/outside between slices is decided by the slices).
RC_GTEST_PROP(SplineProperty, ExtremumPreservingKeepsTheSignOfEachInterval, ()) {
  const int n = *rc::gen::inRange(2, 9);
  const auto [z, f] = random_data(n);
  const Spline1D s(z, f, SplineKind::ExtremumPreserving);
  for (int k = 0; k + 1 < n; ++k) {
    if (f[k] * f[k + 1] <= 0.0) continue;
    for (int i = 0; i <= kScan; ++i) RC_ASSERT(s(z[k] + (z[k + 1] - z[k]) * i / kScan) * f[k] > 0.0);
  }
}

// No pause at an extremum: samples of a smooth bump whose peak lies between
// knots. Hyman's tangent there is 0 (the curve flattens at the knot); the
// extremum-preserving one follows the parabola, so its peak moves toward the
// true one and its error is smaller everywhere it matters.
TEST(Spline, ExtremumPreservingDoesNotPauseAtASmoothExtremum) {
  const double peak = 3.3;  // between knots 3 and 4
  auto bump = [&](double x) { return 10.0 * std::cos((x - peak) / 4.0); };
  std::vector<double> z, f;
  for (int i = 0; i <= 8; ++i) {
    z.push_back(i);
    f.push_back(bump(i));
  }
  const Spline1D hyman(z, f, SplineKind::Monotone), ep(z, f, SplineKind::ExtremumPreserving);
  EXPECT_EQ(hyman.tangents()[3], 0.0);
  EXPECT_GT(ep.tangents()[3], 0.0) << "the peak lies to the right of knot 3";
  double worst_h = 0, worst_e = 0, top_z = 0, top = -1e9;
  for (int i = 0; i <= 8 * kScan; ++i) {
    const double q = 8.0 * i / (8 * kScan);
    worst_h = std::max(worst_h, std::abs(hyman(q) - bump(q)));
    worst_e = std::max(worst_e, std::abs(ep(q) - bump(q)));
    if (ep(q) > top) top = ep(q), top_z = q;
  }
  // Measured: Hyman 0.033, extremum-preserving 0.0093 (0.28x); half keeps
  // the claim "clearly smaller" with room for other tangent estimates.
  constexpr double kMaxErrorShareOfHyman = 0.5;
  EXPECT_LT(worst_e, kMaxErrorShareOfHyman * worst_h) << "extremum-preserving " << worst_e << " vs Hyman " << worst_h;
  EXPECT_GT(top_z, 3.0) << "the interpolant's peak moved off the knot toward " << peak;
}

// A kink, not a smooth extremum (second differences change sign): the
// extremum-preserving tangent is Hyman's 0.
TEST(Spline, ExtremumPreservingIsFlatAtAKink) {
  const std::vector<double> z{0, 1, 2, 3, 4}, f{0, 4, 5, 1, 3};
  const Spline1D s(z, f, SplineKind::ExtremumPreserving);
  EXPECT_EQ(s.tangents()[2], 0.0);
}

// The counterpart: on monotone data Catmull-Rom and natural splines overshoot
// (the paper's Fig. 9 "lip"). Data: a step, as a distance field sees at a
// contour that appears between slices.
TEST(Spline, CatmullRomAndNaturalOvershootOnMonotoneData) {
  const std::vector<double> z{0, 1, 2, 3, 4}, f{0, 0, 0, 10, 10};
  for (auto kind : {SplineKind::CatmullRom, SplineKind::Natural}) {
    const Spline1D s(z, f, kind);
    double lo = 0, hi = 10;
    for (int i = 0; i <= 4 * kScan; ++i) {
      const double v = s(4.0 * i / (4 * kScan));
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
    EXPECT_TRUE(lo < -0.1 || hi > 10.1) << to_string(kind) << " stayed in [" << lo << ", " << hi << "]";
  }
  const Spline1D m(z, f, SplineKind::Monotone);
  for (int i = 0; i <= 4 * kScan; ++i) {
    const double v = m(4.0 * i / (4 * kScan));
    EXPECT_GE(v, -kEvalTol);
    EXPECT_LE(v, 10 + kEvalTol);
  }
}

TEST(ZInterpolator, MatchesTheScalarSplineAtEveryPixel) {
  const std::vector<double> z{0, 4, 6, 12};
  std::vector<Grid2f> slices;
  for (std::size_t k = 0; k < z.size(); ++k) {
    Grid2f g(3, 2);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) g(x, y) = float((x + 1) * std::sin(double(k) + y) * 5);
    slices.push_back(g);
  }
  for (auto kind : kAllKinds) {
    const ZInterpolator zi(slices, z, kind);
    Grid2f out;
    for (double q : {0.0, 1.5, 4.0, 5.2, 9.9, 12.0}) {
      zi.evaluate(q, out);
      for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x) {
          std::vector<double> f;
          for (const auto& s : slices) f.push_back(s(x, y));
          constexpr double kFloatTol = 1e-4;  // fields and tangents are stored as float
          EXPECT_NEAR(out(x, y), Spline1D(z, f, kind)(q), kFloatTol) << to_string(kind) << " pixel (" << x << ", " << y << ") z=" << q;
        }
    }
  }
}

// Monotone and extremum-preserving tangents are computed knot by knot over
// the planes (not column by column): the same bits as spline_tangents() on
// each column, for 2 and 3 knots, the ends, flat and sign-changing data
// (smooth extrema), and knot subranges (secants held from the one two knots below).
TEST(ZInterpolator, KnotByKnotTangentsAreTheColumnsBitForBit) {
  const int w = 5, h = 3;
  for (const SplineKind kind : {SplineKind::Monotone, SplineKind::ExtremumPreserving})
  for (const std::vector<double>& z : {std::vector<double>{0, 3}, std::vector<double>{0, 1, 4},
                                       std::vector<double>{-2, 0, 0.5, 3, 7, 8}}) {
    const std::size_t n = z.size();
    std::vector<Grid2f> slices;
    for (std::size_t k = 0; k < n; ++k) {
      Grid2f g(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) g(x, y) = x == 0 ? 1.5f : float(std::sin(0.7 * double(k) * (x + 1) + y) * (y + 1));
      slices.push_back(g);
    }
    for (const auto& [lo, hi] : {std::pair<std::size_t, std::size_t>{0, n - 1}, {n > 2 ? 1 : 0, n - 1}, {n > 4 ? 3 : 0, n - 2}}) {
      const ZInterpolator zi(slices, z, kind, lo, hi);
      const std::size_t k = lo == 0 ? 0 : lo;  // an interval whose two tangents are held
      if (k + 1 > hi) continue;
      const double q = 0.3 * z[k] + 0.7 * z[k + 1];
      Grid2f out;
      zi.evaluate(q, out);
      const HermiteBasis basis(kind, z[k], z[k + 1], q);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          std::vector<double> f, m(n);
          for (const auto& s : slices) f.push_back(s(x, y));
          spline_tangents(kind, z, f, m);
          const float want = float(basis.value(f[k], f[k + 1], double(float(m[k])), double(float(m[k + 1]))));
          EXPECT_EQ(out(x, y), want) << to_string(kind) << " " << n << " knots, pixel (" << x << ", " << y << ")";
        }
    }
  }
}

// The tangent planes bit for bit those of spline_tangents on each column, on
// columns that rise, fall, turn, flatten (plateaus, -0) and change sign: the
// interior knots' two-pixels-at-a-time path, its odd last pixel and the
// pixels it leaves to the whole rule; sides() the scalar rule on each pixel.
TEST(ZInterpolator, TangentPlanesAreTheColumnsTangentsBitForBit) {
  const int w = 9, h = 7;  // 63 pixels: an odd one after the pairs
  const std::vector<double> z{-2, 0, 0.5, 3, 7, 8, 11.25};
  const std::size_t n = z.size();
  std::vector<Grid2f> slices;
  for (std::size_t k = 0; k < n; ++k) {
    Grid2f g(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int kind = (x + 3 * y) % 6;
        const double t = double(k);
        g(x, y) = kind == 0   ? 1e6f                                            // plateau
                  : kind == 1 ? (k % 3 == 1 ? -0.0f : 0.0f)                     // signed zeros
                  : kind == 2 ? float(0.5 * t * (x + 1) - y)                    // monotone
                  : kind == 3 ? float(-(t - 3.0) * (t - 3.0) + x - y)           // one extremum
                  : kind == 4 ? float(k >= 2 && k <= 3 ? 4.0 : 0.5 * t + y)     // a flat interval
                              : float(std::sin(0.9 * t * (x + 1) + y) * (y + 1));  // turns, sign changes
      }
    slices.push_back(g);
  }
  for (const SplineKind kind : {SplineKind::Monotone, SplineKind::ExtremumPreserving}) {
    ZInterpolator zi(slices, z, kind);
    // sides(): four pixels at a time, and the last three, give the scalar rule.
    constexpr float kMargin = 1e-2f, kIso = 0.3f;
    Grid2<std::int8_t> side;
    for (std::size_t k = 0; k + 1 < n; ++k) {
      zi.sides(k, kIso, kMargin, side);
      const float reach = float((z[k + 1] - z[k]) * 4.0 / 27.0);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          std::vector<double> f, m(n);
          for (const auto& s : slices) f.push_back(s(x, y));
          spline_tangents(kind, z, f, m);
          const float a = slices[k](x, y), b = slices[k + 1](x, y);
          const float slack = kind == SplineKind::Monotone ? 0.0f : reach * (std::abs(float(m[k])) + std::abs(float(m[k + 1])));
          const float lo = std::min(a, b) - slack, hi = std::max(a, b) + slack;
          EXPECT_EQ(side(x, y), lo > kIso + kMargin ? 1 : hi < kIso - kMargin ? -1 : 0) << to_string(kind) << " interval " << k;
        }
    }
    const std::vector<Grid2f> planes = zi.take_tangents(0, n - 1);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        std::vector<double> f, m(n);
        for (const auto& s : slices) f.push_back(s(x, y));
        spline_tangents(kind, z, f, m);
        for (std::size_t k = 0; k < n; ++k) {
          const float want = float(m[k]), got = planes[k](x, y);
          EXPECT_EQ(std::memcmp(&want, &got, sizeof want), 0)
              << to_string(kind) << " knot " << k << ", pixel (" << x << ", " << y << "): " << got << " vs " << want;
        }
      }
  }
}

// evaluate() on pixel runs (the streaming mesher's band) and on the whole
// plane are twins: the same bits on the runs, the other pixels untouched.
TEST(ZInterpolator, RunsGiveTheWholePlanesValuesThereAndLeaveTheRest) {
  const int w = 7, h = 5;
  const std::vector<double> z{0, 2, 5, 6};
  std::vector<Grid2f> slices;
  for (std::size_t k = 0; k < z.size(); ++k) {
    Grid2f g(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) g(x, y) = float(std::cos(0.7 * x + 1.3 * y + double(k)) * 3);
    slices.push_back(g);
  }
  PixelRuns runs;  // row 0: none; row 1: [0, 2) and [4, 7); row 2: all; rows 3-4: [3, 4)
  runs.first = {0, 0, 2, 3, 4, 5};
  runs.runs = {{0, 2}, {4, 7}, {0, w}, {3, 4}, {3, 4}};
  ASSERT_EQ(runs.pixels(), 2 + 3 + w + 1 + 1);
  constexpr float kUntouched = -1234.5f;
  for (auto kind : kAllKinds) {
    const ZInterpolator zi(slices, z, kind);
    for (double q : {0.0, 1.1, 2.0, 4.4, 6.0}) {
      Grid2f whole, part(w, h, kUntouched);
      zi.evaluate(q, whole);
      zi.evaluate(q, part, &runs);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          bool in = false;
          for (int r = runs.first[std::size_t(y)]; r < runs.first[std::size_t(y) + 1]; ++r)
            in |= x >= runs.runs[std::size_t(r)][0] && x < runs.runs[std::size_t(r)][1];
          EXPECT_EQ(part(x, y), in ? whole(x, y) : kUntouched)
              << to_string(kind) << " pixel (" << x << ", " << y << ") z=" << q;
        }
    }
    Grid2f wrong(w + 1, h);
    EXPECT_THROW(zi.evaluate(1.0, wrong, &runs), ParamError) << to_string(kind);
  }
}

// ZInterpolator::sides(): a pixel said to keep one side of iso over a knot
// interval does so at every height in it (every kind); for monotone and
// linear the side is given exactly when both knots are beyond iso by more than
// the margin, for the others only then (their overshoot bound may withhold it).
// Values in 0.1 px steps around iso, so many knots sit within the margin.
RC_GTEST_PROP(ZInterpolatorProperty, SidesHoldOverTheirInterval, ()) {
  constexpr float kMargin = 1e-2f;  // pixels; far above the float rounding of values below 10 px
  const int n = *rc::gen::inRange(2, 7), w = *rc::gen::inRange(1, 9);
  const float iso = *rc::gen::element(0.0f, 0.3f, -1.0f);
  const auto kind = *rc::gen::elementOf(std::vector<SplineKind>(std::begin(kAllKinds), std::end(kAllKinds)));
  const bool exact = kind == SplineKind::Monotone || kind == SplineKind::Linear;
  const auto gaps = *rc::gen::container<std::vector<double>>(std::size_t(n - 1), rc::gen::map(rc::gen::inRange(1, 100), [](int v) { return v / 10.0; }));
  const auto z = knots(gaps);
  std::vector<Grid2f> slices;
  for (int k = 0; k < n; ++k) {
    Grid2f g(w, 1);
    for (int x = 0; x < w; ++x) g(x, 0) = float(*rc::gen::inRange(-30, 30)) / 10.0f + iso;
    slices.push_back(g);
  }
  const ZInterpolator zi(slices, z, kind);
  Grid2<std::int8_t> side;
  Grid2f out;
  for (int k = 0; k + 1 < n; ++k) {
    zi.sides(std::size_t(k), iso, kMargin, side);
    for (int x = 0; x < w; ++x) {
      const float lo = std::min(slices[k](x, 0), slices[k + 1](x, 0)), hi = std::max(slices[k](x, 0), slices[k + 1](x, 0));
      if (exact) RC_ASSERT(side(x, 0) == (lo > iso + kMargin ? 1 : hi < iso - kMargin ? -1 : 0));
      else RC_ASSERT(side(x, 0) == 0 || side(x, 0) == (lo > iso + kMargin ? 1 : -1));
    }
    for (int i = 0; i <= kScan; ++i) {
      const double q = z[k] + (z[k + 1] - z[k]) * i / kScan;
      zi.evaluate(q, out);
      for (int x = 0; x < w; ++x)
        if (side(x, 0) != 0) RC_ASSERT((out(x, 0) > iso) == (side(x, 0) > 0));
    }
  }
}

// The overshoot bound withholds a side the knots alone would give: a step
// 0, 0, 10, 10 overshoots below 0 in Catmull-Rom's first interval.
TEST(ZInterpolator, OvershootingKindsWithholdASideNearTheirKnots) {
  const std::vector<double> z{0, 1, 2, 3};
  std::vector<Grid2f> slices;
  for (float v : {0.5f, 0.5f, 10.0f, 10.0f}) slices.emplace_back(1, 1, v);
  Grid2<std::int8_t> side;
  ZInterpolator(slices, z, SplineKind::CatmullRom).sides(1, 0.0f, 1e-2f, side);
  EXPECT_EQ(side(0, 0), 0) << "its bound 4/27 (4.75 + 4.75) = 1.41 exceeds the knot value 0.5";
  ZInterpolator(slices, z, SplineKind::Monotone).sides(1, 0.0f, 1e-2f, side);
  EXPECT_EQ(side(0, 0), 1);
}

TEST(EndCaps, VirtualSlicesAreOutsideAndHalfASpacingAway) {
  std::vector<Grid2f> slices{Grid2f(2, 1, 3.0f), Grid2f(2, 1, -1.0f), Grid2f(2, 1, 2.0f)};
  slices[0](1, 0) = -2.0f;
  std::vector<double> z{0, 8, 10};
  InterpParams p;
  add_end_caps(slices, z, p);
  ASSERT_EQ(slices.size(), 5u);
  EXPECT_DOUBLE_EQ(z.front(), -4.0);
  EXPECT_DOUBLE_EQ(z.back(), 11.0);
  for (float v : slices.front().data) EXPECT_LE(v, -float(p.cap_depth));
  for (float v : slices.back().data) EXPECT_LE(v, -float(p.cap_depth));
  EXPECT_FLOAT_EQ(slices.front()(0, 0), 3.0f - 3.0f - float(p.cap_depth));
}
