// Ceres foot-point solver (see fit_bounds.h).
#include "validation/fit_bounds.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

using ImplicitF = std::function<double(const Vec2d&)>;
using GradientF = std::function<Vec2d(const Vec2d&)>;

double cross(const Vec2d& a, const Vec2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Residuals r0 = f(q), r1 = (q - p) x grad f(q) with the analytic Jacobian
// [grad f; d/dq ((q - p) x g)], the Hessian of f by central differences of grad.
class FootCost final : public ceres::SizedCostFunction<2, 2> {
 public:
  FootCost(const ImplicitF& f, const GradientF& grad, const Vec2d& p, double h) : f_(f), grad_(grad), p_(p), h_(h) {}

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const Vec2d q(params[0][0], params[0][1]);
    const Vec2d g = grad_(q);
    const Vec2d d = q - p_;
    residuals[0] = f_(q);
    residuals[1] = cross(d, g);
    if (!std::isfinite(residuals[0]) || !std::isfinite(residuals[1])) return false;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      const Vec2d ex(h_, 0.0), ey(0.0, h_);
      const Vec2d hx = (grad_(q + ex) - grad_(q - ex)) / (2.0 * h_);  // d grad / dx
      const Vec2d hy = (grad_(q + ey) - grad_(q - ey)) / (2.0 * h_);  // d grad / dy
      double* J = jacobians[0];  // row-major 2 x 2
      J[0] = g.x();
      J[1] = g.y();
      // d/dq_k (d.x g.y - d.y g.x) = e_k.x g.y - e_k.y g.x + d.x dg.y/dq_k - d.y dg.x/dq_k
      J[2] = g.y() + d.x() * hx.y() - d.y() * hx.x();
      J[3] = -g.x() + d.x() * hy.y() - d.y() * hy.x();
      for (int i = 0; i < 4; ++i)
        if (!std::isfinite(J[i])) return false;
    }
    return true;
  }

 private:
  const ImplicitF& f_;
  const GradientF& grad_;
  Vec2d p_;
  double h_;
};

// Foot point of p; false if the solver does not reach the tolerance.
bool solve_foot(const ImplicitF& f, const GradientF& grad, const Vec2d& p, const FootPointParams& params, Vec2d& q) {
  double x[2] = {p.x(), p.y()};
  ceres::Problem::Options popts;
  ceres::Problem problem(popts);
  problem.AddResidualBlock(new FootCost(f, grad, p, params.hessian_step), nullptr, x);
  ceres::Solver::Options opts;
  opts.linear_solver_type = ceres::DENSE_QR;
  opts.max_num_iterations = params.max_iterations;
  opts.logging_type = ceres::SILENT;
  opts.minimizer_progress_to_stdout = false;
  opts.num_threads = 1;
  // Let the iteration run to round-off; acceptance is decided below on the residuals.
  opts.function_tolerance = 1e-20;
  opts.gradient_tolerance = 1e-24;
  opts.parameter_tolerance = 1e-16;
  ceres::Solver::Summary summary;
  ceres::Solve(opts, &problem, &summary);
  q = Vec2d(x[0], x[1]);
  if (!q.allFinite()) return false;
  const Vec2d g = grad(q);
  const double gn = g.norm();
  if (!(gn > 0) || !std::isfinite(gn)) return false;
  const double off_curve = std::abs(f(q)) / gn;
  const double off_normal = std::abs(cross(q - p, g)) / gn;
  return off_curve <= params.tolerance && off_normal <= params.tolerance * std::max(1.0, (q - p).norm());
}

}  // namespace

FitBoundReport ceres_point_to_zero_set(const ImplicitF& f, const GradientF& grad, const std::vector<Vec2d>& points,
                                       const FootPointParams& params) {
  if (!f || !grad) throw ParamError("ceres_point_to_zero_set: f and grad must be given");
  if (params.max_iterations < 1) throw ParamError("ceres_point_to_zero_set: max_iterations must be >= 1");
  if (!(params.tolerance > 0)) throw ParamError("ceres_point_to_zero_set: tolerance must be > 0");
  if (!(params.hessian_step > 0)) throw ParamError("ceres_point_to_zero_set: hessian_step must be > 0");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      throw InputError("", "ceres_point_to_zero_set: point " + std::to_string(i) + " is not finite");
  FitBoundReport r;
  r.distances.assign(points.size(), std::numeric_limits<double>::quiet_NaN());
  r.feet.resize(points.size());
  double sum = 0;
  long ok = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    Vec2d q;
    const bool converged = solve_foot(f, grad, points[i], params, q);
    r.feet[i] = q;
    if (!converged) {
      ++r.failures;
      continue;
    }
    const double d = (q - points[i]).norm();
    r.distances[i] = d;
    sum += d;
    ++ok;
    if (r.worst_index < 0 || d > r.max_distance) {
      r.max_distance = d;
      r.worst_index = int(i);
    }
  }
  if (ok > 0) r.mean_distance = sum / double(ok);
  return r;
}

Vec2d Ellipse2d::point(double t) const {
  const double c = std::cos(angle), s = std::sin(angle);
  const double u = a * std::cos(t), v = b * std::sin(t);
  return centre + Vec2d(c * u - s * v, s * u + c * v);
}

double Ellipse2d::value(const Vec2d& p) const {
  const double c = std::cos(angle), s = std::sin(angle);
  const Vec2d d = p - centre;
  const double u = c * d.x() + s * d.y(), v = -s * d.x() + c * d.y();
  return std::min(a, b) * (1.0 - std::hypot(u / a, v / b));
}

Vec2d Ellipse2d::gradient(const Vec2d& p) const {
  const double c = std::cos(angle), s = std::sin(angle);
  const Vec2d d = p - centre;
  const double u = c * d.x() + s * d.y(), v = -s * d.x() + c * d.y();
  const double r = std::hypot(u / a, v / b);
  if (!(r > 0)) return Vec2d::Zero();
  // d/du, d/dv of -m r, then back to world axes (rotation transpose).
  const double m = std::min(a, b);
  const double gu = -m * u / (a * a * r), gv = -m * v / (b * b * r);
  return Vec2d(c * gu - s * gv, s * gu + c * gv);
}

std::vector<Vec2d> sample_ellipse(const Ellipse2d& e, int samples) {
  if (samples < 1) throw ParamError("sample_ellipse: samples must be >= 1");
  if (!(e.a > 0) || !(e.b > 0)) throw ParamError("sample_ellipse: semi-axes must be > 0");
  std::vector<Vec2d> pts(static_cast<std::size_t>(samples));
  for (int i = 0; i < samples; ++i) pts[std::size_t(i)] = e.point(2.0 * M_PI * i / samples);
  return pts;
}

FitBoundReport analytic_curve_to_zero_set(const ImplicitF& f, const GradientF& grad, const Ellipse2d& truth,
                                          int samples, const FootPointParams& params) {
  return ceres_point_to_zero_set(f, grad, sample_ellipse(truth, samples), params);
}

}  // namespace isoloft
