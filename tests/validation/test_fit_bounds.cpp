// Tests of validation/fit_bounds.h: the Ceres foot-point solver on curves
// whose distances are known in closed form.
#if defined(ISOLOFT_HAVE_VALIDATION)

#include <gtest/gtest.h>
#include <rapidcheck.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "isoloft/contour/normals.h"
#include "isoloft/core/error.h"
#include "isoloft/fit/mpu.h"
#include "validation/fit_bounds.h"

namespace isoloft {
namespace {

// The solver accepts a foot at 1e-8 px (FootPointParams::tolerance); its
// distance is then exact to that plus rounding of coordinates <= ~300 px.
constexpr double kFootTol = 1e-7;

struct Circle {
  Vec2d c;
  double r;
  // Exact signed distance, positive inside.
  [[nodiscard]] double sdf(const Vec2d& p) const { return r - (p - c).norm(); }
  [[nodiscard]] Vec2d sdf_grad(const Vec2d& p) const { return -(p - c).normalized(); }
  // A non-distance implicit with the same zero set, |grad| = 2 |p - c|.
  [[nodiscard]] double quad(const Vec2d& p) const { return r * r - (p - c).squaredNorm(); }
  [[nodiscard]] Vec2d quad_grad(const Vec2d& p) const { return -2.0 * (p - c); }
};

RC_GTEST_PROP(FitBounds, CircleFootDistanceIsExact, ()) {
  const Circle circ{Vec2d(*rc::gen::inRange(-500, 500) / 10.0, *rc::gen::inRange(-500, 500) / 10.0),
                    *rc::gen::inRange(50, 500) / 10.0};
  // Points from 0.2 r to 3 r from the centre (the foot is unique off the centre).
  std::vector<Vec2d> pts;
  for (int i = 0; i < 8; ++i) {
    const double ang = *rc::gen::inRange(0, 6283) / 1000.0;
    const double rho = circ.r * *rc::gen::inRange(200, 3000) / 1000.0;
    pts.push_back(circ.c + rho * Vec2d(std::cos(ang), std::sin(ang)));
  }
  for (const bool quadratic : {false, true}) {
    const auto f = [&](const Vec2d& p) { return quadratic ? circ.quad(p) : circ.sdf(p); };
    const auto g = [&](const Vec2d& p) { return quadratic ? circ.quad_grad(p) : circ.sdf_grad(p); };
    const FitBoundReport r = ceres_point_to_zero_set(f, g, pts);
    RC_ASSERT(r.failures == 0);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double want = std::abs((pts[i] - circ.c).norm() - circ.r);
      if (std::abs(r.distances[i] - want) > kFootTol)
        RC_FAIL("point " + std::to_string(i) + (quadratic ? " (quadratic f)" : " (sdf)") + ": got " +
                std::to_string(r.distances[i]) + ", want " + std::to_string(want));
      RC_ASSERT(std::abs((r.feet[i] - circ.c).norm() - circ.r) <= kFootTol);
    }
  }
}

TEST(FitBounds, ReportsWorstPointAndMean) {
  const Circle circ{Vec2d(10.0, -4.0), 20.0};
  const std::vector<Vec2d> pts = {Vec2d(30.5, -4.0), Vec2d(10.0, 17.0), Vec2d(10.0, -21.0), Vec2d(-9.8, -4.0)};
  const std::vector<double> want = {0.5, 1.0, 3.0, 0.2};
  const FitBoundReport r = ceres_point_to_zero_set([&](const Vec2d& p) { return circ.quad(p); },
                                                   [&](const Vec2d& p) { return circ.quad_grad(p); }, pts);
  ASSERT_EQ(r.failures, 0);
  for (std::size_t i = 0; i < pts.size(); ++i) EXPECT_NEAR(r.distances[i], want[i], kFootTol) << "point " << i;
  EXPECT_EQ(r.worst_index, 2);
  EXPECT_NEAR(r.max_distance, 3.0, kFootTol);
  EXPECT_NEAR(r.mean_distance, 1.175, kFootTol);
}

TEST(FitBounds, TrueCircleAgainstOffsetZeroSet) {
  // Zero set = circle of radius r + 0.3 about the same centre: every true
  // point is exactly 0.3 px from it.
  constexpr double kOffset = 0.3;
  const Circle zero{Vec2d(64.2, 63.7), 30.0 + kOffset};
  const Ellipse2d truth{Vec2d(64.2, 63.7), 30.0, 30.0, 0.0};
  const FitBoundReport r = analytic_curve_to_zero_set([&](const Vec2d& p) { return zero.sdf(p); },
                                                      [&](const Vec2d& p) { return zero.sdf_grad(p); }, truth, 360);
  ASSERT_EQ(r.failures, 0);
  ASSERT_EQ(r.distances.size(), 360u);
  for (std::size_t i = 0; i < r.distances.size(); ++i)
    ASSERT_NEAR(r.distances[i], kOffset, kFootTol) << "sample " << i;
}

TEST(FitBounds, EllipseOnItsOwnZeroSet) {
  const Ellipse2d e{Vec2d(50.0, 40.0), 30.0, 12.0, 0.4};
  // The implicit vanishes on the parameterised curve (to rounding).
  constexpr double kZeroTol = 1e-12;
  for (const Vec2d& p : sample_ellipse(e, 64)) ASSERT_NEAR(e.value(p), 0.0, kZeroTol);
  // Analytic gradient vs central differences (step 1e-5: error ~1e-10).
  constexpr double kStep = 1e-5, kGradTol = 1e-7;
  for (const Vec2d& p : {Vec2d(60.0, 45.0), Vec2d(30.0, 30.0), Vec2d(52.0, 41.0)}) {
    const Vec2d num((e.value(p + Vec2d(kStep, 0)) - e.value(p - Vec2d(kStep, 0))) / (2 * kStep),
                    (e.value(p + Vec2d(0, kStep)) - e.value(p - Vec2d(0, kStep))) / (2 * kStep));
    ASSERT_LT((e.gradient(p) - num).norm(), kGradTol) << "at " << p.transpose();
  }
  const FitBoundReport r = analytic_curve_to_zero_set([&](const Vec2d& p) { return e.value(p); },
                                                      [&](const Vec2d& p) { return e.gradient(p); }, e, 256);
  EXPECT_EQ(r.failures, 0);
  EXPECT_LT(r.max_distance, kFootTol) << "worst sample " << r.worst_index;
}

TEST(FitBounds, MpuFitOfCircleWithinTol) {
  // The oracle's intended use (paper 2.1): the MPU zero set passes within tol
  // of every input point, and within tol of the true circle the points sample.
  const Vec2d c(63.3, 64.7);
  constexpr double kR = 40.0;
  Polygon poly;
  for (int i = 0; i < 400; ++i) {
    const double t = 2.0 * M_PI * i / 400.0;
    poly.points.push_back(c + kR * Vec2d(std::cos(t), std::sin(t)));
  }
  const OrientedPoints pts = polygon_points({poly}, 0.5);
  const MpuParams params;
  const MpuResult fit = fit_mpu(pts, params);
  const auto f = [&](const Vec2d& p) { return fit.curve.value(p); };
  const auto g = [&](const Vec2d& p) { return fit.curve.gradient(p); };
  const FitBoundReport on_points = ceres_point_to_zero_set(f, g, pts.points);
  EXPECT_EQ(on_points.failures, 0);
  EXPECT_LE(on_points.max_distance, params.tol) << "worst point " << on_points.worst_index;
  const FitBoundReport on_truth = analytic_curve_to_zero_set(f, g, Ellipse2d{c, kR, kR, 0.0}, 720);
  EXPECT_EQ(on_truth.failures, 0);
  EXPECT_LE(on_truth.max_distance, params.tol) << "worst sample " << on_truth.worst_index;
}

TEST(FitBounds, NoZeroSetIsAFailure) {
  const auto f = [](const Vec2d& p) { return 1.0 + p.squaredNorm(); };
  const auto g = [](const Vec2d& p) { return Vec2d(2.0 * p); };
  const FitBoundReport r = ceres_point_to_zero_set(f, g, {Vec2d(1, 2), Vec2d(-3, 0.5)});
  EXPECT_EQ(r.failures, 2);
  EXPECT_EQ(r.worst_index, -1);
  EXPECT_TRUE(std::isnan(r.distances[0]));
}

TEST(FitBounds, BadInputThrows) {
  const auto f = [](const Vec2d& p) { return 1.0 - p.norm(); };
  const auto g = [](const Vec2d& p) { return Vec2d(-p.normalized()); };
  EXPECT_THROW(ceres_point_to_zero_set({}, g, {Vec2d(1, 1)}), ParamError);
  FootPointParams bad;
  bad.tolerance = 0;
  EXPECT_THROW(ceres_point_to_zero_set(f, g, {Vec2d(1, 1)}, bad), ParamError);
  EXPECT_THROW(ceres_point_to_zero_set(f, g, {Vec2d(NAN, 1)}), InputError);
  EXPECT_THROW(sample_ellipse(Ellipse2d{Vec2d(0, 0), 0.0, 1.0, 0.0}, 8), ParamError);
}

}  // namespace
}  // namespace isoloft

#endif  // ISOLOFT_HAVE_VALIDATION
