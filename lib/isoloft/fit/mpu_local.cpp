#include "isoloft/fit/mpu_local.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Dense>

namespace isoloft::detail {

double bspline2(double t) {
  t = std::abs(t);
  if (t <= 0.5) return 0.75 - t * t;
  if (t < 1.5) return 0.5 * (1.5 - t) * (1.5 - t);
  return 0.0;
}

double bspline2_derivative(double t) {
  if (t <= 0.5) return -2.0 * t;
  if (t < 1.5) return -(1.5 - t);
  return 0.0;
}

void HeightFn::eval(const Vec2d& x, double& value, Vec2d& grad) const {
  const Vec2d d = x - o;
  const double s = t.dot(d) / scale;
  value = scale * ((a * s + b) * s + c) - n.dot(d);
  grad = (2.0 * a * s + b) * t - n;
}

void Piece::eval(const Vec2d& x, double& value, Vec2d& grad) const {
  if (!conic) {
    h.eval(x, value, grad);
    return;
  }
  const Vec2d s = (x - centre) / scale;
  value = scale * (q[0] * s.x() * s.x() + q[1] * s.x() * s.y() + q[2] * s.y() * s.y() + q[3] * s.x() +
                   q[4] * s.y() + q[5]);
  grad = Vec2d(2.0 * q[0] * s.x() + q[1] * s.y() + q[3], q[1] * s.x() + 2.0 * q[2] * s.y() + q[4]);
}

void Group::eval(const Vec2d& x, double& value, Vec2d& grad) const {
  piece[0].eval(x, value, grad);
  if (count < 2) return;
  double v;
  Vec2d g;
  piece[1].eval(x, v, g);
  if (use_min ? v < value : v > value) {
    value = v;
    grad = g;
  }
}

void LocalFn::eval(const Vec2d& x, double& value, Vec2d& grad) const {
  group[0].eval(x, value, grad);
  if (groups < 2) return;
  double v;
  Vec2d g;
  group[1].eval(x, v, g);
  if (use_min ? v < value : v > value) {
    value = v;
    grad = g;
  }
}

namespace {
/// Solves the normal equations M x = v with a tiny ridge (rank-deficient
/// supports, e.g. collinear points, still give a finite answer).
template <int N>
Eigen::Matrix<double, N, 1> solve_normal_equations(Eigen::Matrix<double, N, N> m,
                                                   const Eigen::Matrix<double, N, 1>& v) {
  const double ridge = 1e-10 * std::max(m.trace() / N, 1e-300);
  m.diagonal().array() += ridge;
  Eigen::Matrix<double, N, 1> x = m.ldlt().solve(v);
  if (!x.allFinite()) x = m.completeOrthogonalDecomposition().solve(v);
  if (!x.allFinite()) x.setZero();
  return x;
}
}  // namespace

HeightFn fit_height(const std::vector<Vec2d>& points, const std::vector<int>& idx, const std::vector<double>& w,
                    const Vec2d& o, const Vec2d& normal, double scale) {
  HeightFn h;
  h.o = o;
  h.n = normal;
  h.t = Vec2d(-normal.y(), normal.x());
  h.scale = scale;
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const Vec2d d = points[idx[k]] - o;
    const double s = h.t.dot(d) / scale, ws = h.n.dot(d) / scale;
    const Eigen::Vector3d a(s * s, s, 1.0);
    m.noalias() += w[k] * a * a.transpose();
    v.noalias() += w[k] * ws * a;
  }
  const Eigen::Vector3d x = solve_normal_equations<3>(m, v);
  h.a = x[0];
  h.b = x[1];
  h.c = x[2];
  return h;
}

Piece fit_conic(const std::vector<Vec2d>& points, const std::vector<Vec2d>& normals, const std::vector<int>& idx,
                const std::vector<double>& w, const Vec2d& centre, double scale) {
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  Mat6 m = Mat6::Zero();
  Vec6 v = Vec6::Zero();
  auto row = [&](const Vec2d& x) {
    const Vec2d s = (x - centre) / scale;
    Vec6 a;
    a << s.x() * s.x(), s.x() * s.y(), s.y() * s.y(), s.x(), s.y(), 1.0;
    return Vec6(scale * a);
  };
  auto add = [&](const Vec6& a, double target, double weight) {
    m.noalias() += weight * a * a.transpose();
    v.noalias() += weight * target * a;
  };
  const double wsum = std::accumulate(w.begin(), w.end(), 0.0);
  if (wsum > 0.0)
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const double wk = w[k] / wsum;
      if (wk == 0.0) continue;
      const Vec2d& p = points[idx[k]];
      const Vec2d& n = normals[idx[k]];
      add(row(p), 0.0, wk);
      add(row(p - kOffSurfaceDelta * n), kOffSurfaceDelta, wk);   // inward: positive
      add(row(p + kOffSurfaceDelta * n), -kOffSurfaceDelta, wk);  // outward: negative
    }
  const Vec6 x = solve_normal_equations<6>(m, v);
  Piece fn;
  fn.conic = true;
  fn.centre = centre;
  fn.scale = scale;
  for (int i = 0; i < 6; ++i) fn.q[i] = x[i];
  return fn;
}

double taubin_error(const LocalFn& fn, const std::vector<Vec2d>& points, const std::vector<int>& idx) {
  double err = 0.0;
  for (int i : idx) {
    double v;
    Vec2d g;
    fn.eval(points[i], v, g);
    const double gn = g.norm();
    const double e = gn > 1e-12 ? std::abs(v) / gn : (v == 0.0 ? 0.0 : std::numeric_limits<double>::infinity());
    err = std::max(err, e);
  }
  return err;
}

bool split_normals(const std::vector<Vec2d>& normals, const std::vector<int>& idx, double min_angle, int min_size,
                   std::vector<int>& first, std::vector<int>& second) {
  first.clear();
  second.clear();
  const int n = static_cast<int>(idx.size());
  if (n < 2 * min_size || min_size < 1) return false;
  std::vector<std::pair<double, int>> ang(n);
  for (int k = 0; k < n; ++k) ang[k] = {std::atan2(normals[idx[k]].y(), normals[idx[k]].x()), idx[k]};
  std::sort(ang.begin(), ang.end());
  // Cut the circle open at its largest gap: start after it, unrolled increasing.
  int cut = 0;
  double gap = ang[0].first + 2.0 * M_PI - ang[n - 1].first;
  for (int k = 1; k < n; ++k)
    if (ang[k].first - ang[k - 1].first > gap) {
      gap = ang[k].first - ang[k - 1].first;
      cut = k;
    }
  std::rotate(ang.begin(), ang.begin() + cut, ang.end());
  for (int k = 1; k < n; ++k)
    if (ang[k].first < ang[k - 1].first) ang[k].first += 2.0 * M_PI;
  std::vector<double> pre(n + 1, 0.0), pre2(n + 1, 0.0);
  for (int k = 0; k < n; ++k) {
    pre[k + 1] = pre[k] + ang[k].first;
    pre2[k + 1] = pre2[k] + ang[k].first * ang[k].first;
  }
  auto sse = [&](int lo, int hi) {  // [lo, hi)
    const double s = pre[hi] - pre[lo], s2 = pre2[hi] - pre2[lo];
    return s2 - s * s / (hi - lo);
  };
  int best = -1;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int k = min_size; k <= n - min_size; ++k) {
    const double c = sse(0, k) + sse(k, n);
    if (c < best_cost) {
      best_cost = c;
      best = k;
    }
  }
  if (best < 0) return false;
  Vec2d m1(0.0, 0.0), m2(0.0, 0.0);
  for (int k = 0; k < n; ++k) (k < best ? m1 : m2) += normals[ang[k].second];
  if (m1.norm() == 0.0 || m2.norm() == 0.0) return false;
  const double sep = std::acos(std::clamp(m1.normalized().dot(m2.normalized()), -1.0, 1.0));
  if (sep < min_angle) return false;
  for (int k = 0; k < n; ++k) (k < best ? first : second).push_back(ang[k].second);
  return true;
}

double FitInput::weight(const Vec2d& p) const {
  return std::max(bspline2(1.5 * (p - centre).norm() / radius), 1e-12);
}

namespace {
double group_error(const FitInput& in, const Group& g, const std::vector<int>& ids) {
  LocalFn fn;
  fn.group[0] = g;
  return taubin_error(fn, in.points, ids);
}

/// Weighted mean normal of ids; `agree` if it is well defined and every normal
/// is within 90 degrees of it.
Vec2d mean_normal(const FitInput& in, const std::vector<int>& ids, const std::vector<double>& w, bool& agree) {
  Vec2d sum(0.0, 0.0);
  for (std::size_t k = 0; k < ids.size(); ++k) sum += w[k] * in.normals[ids[k]];
  const double len = sum.norm();
  agree = len > 0.0 && ids.size() >= 3;
  const Vec2d n = len > 0.0 ? Vec2d(sum / len) : Vec2d(0.0, 1.0);
  for (int i : ids) agree = agree && in.normals[i].dot(n) > 0.0;
  return n;
}
}  // namespace

Piece fit_piece(const FitInput& in, const std::vector<int>& ids, double& error) {
  std::vector<double> w(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) w[k] = in.weight(in.points[ids[k]]);
  Group g;
  g.piece[0] = fit_conic(in.points, in.normals, ids, w, in.centre, in.radius);
  error = group_error(in, g, ids);
  bool agree = false;
  const Vec2d n = mean_normal(in, ids, w, agree);
  if (agree) {
    Group h;
    h.piece[0].h = fit_height(in.points, ids, w, in.centre, n, in.radius);
    const double e = group_error(in, h, ids);
    if (e <= error) {
      error = e;
      return h.piece[0];
    }
  }
  return g.piece[0];
}

bool fit_corner(const FitInput& in, const std::vector<int>& ids, Group& group) {
  std::vector<int> part[2];
  if (!split_normals(in.normals, ids, in.corner_angle, kMinClusterSize, part[0], part[1])) return false;
  Vec2d centroid[2], normal[2];
  for (int c = 0; c < 2; ++c) {
    double err;
    group.piece[c] = fit_piece(in, part[c], err);
    Vec2d sum(0.0, 0.0), nsum(0.0, 0.0);
    for (int i : part[c]) {
      sum += in.points[i];
      nsum += in.normals[i];
    }
    centroid[c] = sum / static_cast<double>(part[c].size());
    normal[c] = nsum.normalized();
  }
  group.count = 2;
  // Convex corner: each cluster lies behind the other's normal; the inside is in both.
  group.use_min = (centroid[1] - centroid[0]).dot(normal[0] - normal[1]) < 0.0;
  return true;
}

Group fit_curve(const FitInput& in, const std::vector<int>& ids, double& error) {
  Group g;
  g.piece[0] = fit_piece(in, ids, error);
  Group c;
  if (fit_corner(in, ids, c)) {
    const double e = group_error(in, c, ids);
    if (e < error) {
      error = e;
      return c;
    }
  }
  return g;
}

LocalFn fit_two_curves(const FitInput& in, const std::vector<int>& a, const std::vector<int>& b) {
  LocalFn fn;
  fn.kind = LocalFn::Kind::TwoCurves;
  fn.groups = 2;
  double err;
  fn.group[0] = fit_curve(in, a, err);
  fn.group[1] = fit_curve(in, b, err);
  double inside = 0.0, v;
  Vec2d g;
  for (int i : b) {
    fn.group[0].eval(in.points[i], v, g);
    inside += v / static_cast<double>(b.size());
  }
  for (int i : a) {
    fn.group[1].eval(in.points[i], v, g);
    inside += v / static_cast<double>(a.size());
  }
  fn.use_min = inside > 0.0;
  return fn;
}

}  // namespace isoloft::detail
