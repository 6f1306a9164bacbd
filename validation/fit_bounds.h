// Error bound of an implicit curve fit (paper 2.1, MPU): the distance from
// given points to the zero set of f, each found as the foot point q of the
// point p by solving, with Ceres (Levenberg-Marquardt), the 2 x 2 system
//
//   f(q) = 0,   (q - p) x grad f(q) = 0,
//
// the first-order conditions of min |q - p|^2 s.t. f(q) = 0 (q on the curve,
// q - p along the curve normal). Started at q = p, the first step is the
// Newton projection along grad f, so the solver lands on the nearby foot;
// the system also admits far feet (local maxima of |q - p|), so a reported
// distance is the distance to *a* foot point: an upper bound of the true
// distance to the zero set only if the nearest branch was found, which holds
// for points within the reach of the curve (the usual case: points on or near
// the fitted curve).
//
// Used two ways: the input points of the fit against its zero set (MPU's
// "zero set within tol of every point"), and a dense sampling of a true
// analytic curve (circle, ellipse) against the zero set ("the curve passes no
// farther than tol from the true curve").
//
// Units: pixels. This header is Ceres-free; Ceres is confined to fit_bounds.cpp.
#pragma once

#include <functional>
#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft {

struct FootPointParams {
  /// Levenberg-Marquardt iterations per point; the system is 2 x 2 and
  /// converges quadratically near the foot, so 50 only bounds pathological cases.
  int max_iterations = 50;
  /// A foot is accepted when |f(q)| / |grad f(q)| (distance of q from the zero
  /// set, first order) and |(q - p) x grad f| / |grad f| (off-normal offset)
  /// are both below this, pixels: far below any pixel-scale tolerance.
  double tolerance = 1e-8;
  /// Step of the central differences of grad f that give the Jacobian's
  /// second-derivative terms, pixels (they steer convergence only; the
  /// residuals themselves are exact).
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

/// Distance from each point to the zero set of f by Ceres (file comment).
/// f and grad are called from the calling thread only (any callable will do).
/// \param f the implicit function (any sign convention, |grad f| > 0 near the zero set)
/// \param grad its gradient
/// \throw ParamError if f or grad is empty, max_iterations < 1, tolerance <= 0 or hessian_step <= 0.
/// \throw InputError if a point is not finite (names its index).
FitBoundReport ceres_point_to_zero_set(const std::function<double(const Vec2d&)>& f,
                                       const std::function<Vec2d(const Vec2d&)>& grad, const std::vector<Vec2d>& points,
                                       const FootPointParams& params = {});

/// An ellipse (a circle if a == b): centre, semi-axes a (along the rotated x
/// axis) and b, rotation angle in radians. Pixel units.
struct Ellipse2d {
  Vec2d centre{0, 0};
  double a = 1, b = 1;
  double angle = 0;
  /// Point at parameter t in [0, 2 pi).
  [[nodiscard]] Vec2d point(double t) const;
  /// Smooth implicit, positive inside: min(a, b) * (1 - |(u / a, v / b)|) with
  /// (u, v) the rotated offset from the centre (the ellipsoid convention of
  /// synth/shapes.h: exact zero set, |grad| ~ 1 near the curve).
  [[nodiscard]] double value(const Vec2d& p) const;
  [[nodiscard]] Vec2d gradient(const Vec2d& p) const;
};

/// `samples` points of the ellipse, equally spaced in its parameter.
/// \throw ParamError if samples < 1 or a, b <= 0.
std::vector<Vec2d> sample_ellipse(const Ellipse2d& e, int samples);

/// Distance from the true analytic curve to the zero set of f: the ellipse
/// sampled at `samples` parameters, each sample's foot on f = 0 by
/// ceres_point_to_zero_set(). max_distance is then a lower bound of the
/// one-sided Hausdorff distance truth -> zero set, sharp to within half the
/// sample spacing.
/// \throw as ceres_point_to_zero_set() and sample_ellipse().
FitBoundReport analytic_curve_to_zero_set(const std::function<double(const Vec2d&)>& f,
                                          const std::function<Vec2d(const Vec2d&)>& grad, const Ellipse2d& truth,
                                          int samples = 1024, const FootPointParams& params = {});

}  // namespace isoloft
