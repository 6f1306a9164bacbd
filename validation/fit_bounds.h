// @file validation/fit_bounds.h
// @brief Distances from points to the zero set of f by Ceres foot points (paper 2.1).
// Each foot q of p solves f(q) = 0, (q - p) x grad f(q) = 0 (Levenberg-Marquardt
// from q = p); for a fit's input points, or a sampled true curve (circle,
// ellipse), against its zero set. Pixel units; Ceres only in fit_bounds.cpp.
// @warning The system also admits far feet: a distance is the nearest one only
// if the nearest branch was found (points near the curve); else it is larger.
#pragma once

#include <functional>
#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft {

struct FootPointParams {
  /// LM iterations per point (defaults: docs/decisions.md, Ceres foot points).
  int max_iterations = 50;
  /// Accept a foot when |f| / |grad f| and the off-normal offset are below this, px.
  double tolerance = 1e-8;
  /// Step of the central differences of grad f in the Jacobian, px.
  double hessian_step = 1e-5;
};

struct FitBoundReport {
  double max_distance = 0;   ///< max |q - p| over converged points, px
  double mean_distance = 0;  ///< mean |q - p| over converged points, px
  int worst_index = -1;      ///< index of max_distance (-1 if none converged)
  int failures = 0;          ///< points where the solver did not reach `tolerance`
  std::vector<double> distances;  ///< per point |q - p|; NaN where it failed
  std::vector<Vec2d> feet;        ///< per point the foot q (last iterate where it failed)
};

/// Distance from each point to the zero set of f (calling thread only).
/// \throw ParamError if f or grad is empty or a parameter is not positive;
///        InputError naming a non-finite point.
/// @warning Points where the solver does not converge count as `failures` (NaN distance).
FitBoundReport ceres_point_to_zero_set(const std::function<double(const Vec2d&)>& f,
                                       const std::function<Vec2d(const Vec2d&)>& grad, const std::vector<Vec2d>& points,
                                       const FootPointParams& params = {});

/// Ellipse (circle if a == b): centre, semi-axes a, b, rotation (rad); pixels.
struct Ellipse2d {
  Vec2d centre{0, 0};
  double a = 1, b = 1;
  double angle = 0;
  [[nodiscard]] Vec2d point(double t) const;
  /// Positive inside, exact zero set, |grad| ~ 1 near it (as synth/shapes.h).
  [[nodiscard]] double value(const Vec2d& p) const;
  [[nodiscard]] Vec2d gradient(const Vec2d& p) const;
};

/// Equally spaced in the parameter. \throw ParamError if samples < 1 or a, b <= 0.
std::vector<Vec2d> sample_ellipse(const Ellipse2d& e, int samples);

/// The ellipse sampled, each sample's foot on f = 0: max_distance is a lower
/// bound of the Hausdorff distance truth -> zero set, sharp to half a spacing.
/// \throw as ceres_point_to_zero_set() and sample_ellipse().
FitBoundReport analytic_curve_to_zero_set(const std::function<double(const Vec2d&)>& f,
                                          const std::function<Vec2d(const Vec2d&)>& grad, const Ellipse2d& truth,
                                          int samples = 1024, const FootPointParams& params = {});

}  // namespace isoloft
