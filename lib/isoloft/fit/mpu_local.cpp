#include "isoloft/fit/mpu_local.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

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

void CurvePiece::eval(const Vec2d& x, double& value, Vec2d& grad) const {
  if (!conic) {
    h.eval(x, value, grad);
    return;
  }
  const Vec2d s = (x - centre) / scale;
  value =
      scale * (q[0] * s.x() * s.x() + q[1] * s.x() * s.y() + q[2] * s.y() * s.y() + q[3] * s.x() + q[4] * s.y() + q[5]);
  grad = Vec2d(2.0 * q[0] * s.x() + q[1] * s.y() + q[3], q[1] * s.x() + 2.0 * q[2] * s.y() + q[4]);
}

void Group::eval(const Vec2d& x, double& value, Vec2d& grad) const {
  auto pick = [](bool take_min, double& v, Vec2d& g, double v2, const Vec2d& g2) {
    if (take_min ? v2 < v : v2 > v) {
      v = v2;
      g = g2;
    }
  };
  piece[0].eval(x, value, grad);
  if (count < 2) return;
  if (count == 2 || op == Op::Min || op == Op::Max) {
    const bool take_min = op == Op::Min || op == Op::MinOfMax;
    for (int i = 1; i < count; ++i) {
      double v;
      Vec2d g;
      piece[i].eval(x, v, g);
      pick(take_min, value, grad, v, g);
    }
    return;
  }
  // Three pieces, mixed: inner op over the two others, outer op with the lone one.
  const bool inner_min = op == Op::MaxOfMin;
  const int a = (lone + 1) % 3, b = (lone + 2) % 3;
  double va, vb, vl;
  Vec2d ga, gb, gl;
  piece[a].eval(x, va, ga);
  piece[b].eval(x, vb, gb);
  piece[lone].eval(x, vl, gl);
  pick(inner_min, va, ga, vb, gb);
  pick(!inner_min, va, ga, vl, gl);
  value = va;
  grad = ga;
}

void LocalFn::eval(const Vec2d& x, double& value, Vec2d& grad) const {
  if (joins == 0) {
    group[0].eval(x, value, grad);
    return;
  }
  std::array<double, 2 * kMaxComponents - 1> v;
  std::array<Vec2d, 2 * kMaxComponents - 1> g;
  for (int i = 0; i < groups; ++i) group[i].eval(x, v[i], g[i]);
  for (int j = 0; j < joins; ++j) {
    const Join& J = join[j];
    const bool first = J.use_min ? v[J.a] <= v[J.b] : v[J.a] >= v[J.b];
    v[groups + j] = first ? v[J.a] : v[J.b];
    g[groups + j] = first ? g[J.a] : g[J.b];
  }
  value = v[groups + joins - 1];
  grad = g[groups + joins - 1];
}

namespace {
/// Solves the normal equations M x = v with a tiny ridge: M is a weighted sum
/// of outer products (positive semi-definite), so M + ridge I is positive
/// definite and rank-deficient supports (e.g. collinear points) still give a
/// finite answer from LDLT. Only non-finite input can give a non-finite x; the
/// fit is then zero (no rank-revealing fallback: it cost 28 s of compile and
/// could not return a finite answer from non-finite input either).
template <int N>
Eigen::Matrix<double, N, 1> solve_normal_equations(Eigen::Matrix<double, N, N> m,
                                                   const Eigen::Matrix<double, N, 1>& v) {
  const double ridge = 1e-10 * std::max(m.trace() / N, 1e-300);
  m.diagonal().array() += ridge;
  Eigen::Matrix<double, N, 1> x = m.ldlt().solve(v);
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

CurvePiece fit_conic(const std::vector<Vec2d>& points, const std::vector<Vec2d>& normals, const std::vector<int>& idx,
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
      // Off-surface pair p -/+ delta n with values +/- delta, as the central
      // difference (Q(p - delta n) - Q(p + delta n)) / 2 = delta: exact for a
      // conic, it is delta grad Q(p) . n = -delta, so the pair fixes
      // orientation and scale without biasing the zero set (two separate
      // off-surface rows would: a circle's Q is not linear along n).
      add(0.5 * (row(p - kOffSurfaceDelta * n) - row(p + kOffSurfaceDelta * n)), kOffSurfaceDelta, wk);
    }
  const Vec6 x = solve_normal_equations<6>(m, v);
  CurvePiece fn;
  fn.conic = true;
  fn.centre = centre;
  fn.scale = scale;
  for (int i = 0; i < 6; ++i) fn.q[i] = x[i];
  return fn;
}

namespace {
// |Q(p)| / |grad Q(p)|: infinite where Q != 0 has no gradient.
double taubin_distance(const LocalFn& fn, const Vec2d& p) {
  double v;
  Vec2d g;
  fn.eval(p, v, g);
  const double gn = g.norm();
  return gn > 1e-12 ? std::abs(v) / gn : (v == 0.0 ? 0.0 : std::numeric_limits<double>::infinity());
}
}  // namespace

double taubin_error(const LocalFn& fn, const std::vector<Vec2d>& points, const std::vector<int>& idx) {
  double err = 0.0;
  for (int i : idx) err = std::max(err, taubin_distance(fn, points[i]));
  return err;
}

NormalAngles normal_angles(const std::vector<Vec2d>& normals, const std::vector<int>& idx) {
  NormalAngles a;
  const int n = static_cast<int>(idx.size());
  if (n == 0) return a;
  std::vector<std::pair<double, int>>& ang = a.order;
  ang.resize(n);
  for (int i = 0; i < n; ++i) ang[i] = {std::atan2(normals[idx[i]].y(), normals[idx[i]].x()), idx[i]};
  std::sort(ang.begin(), ang.end());
  // Cut the circle open at its largest gap: start after it, unrolled increasing.
  int cut = 0;
  double gap = ang[0].first + 2.0 * M_PI - ang[n - 1].first;
  for (int i = 1; i < n; ++i)
    if (ang[i].first - ang[i - 1].first > gap) {
      gap = ang[i].first - ang[i - 1].first;
      cut = i;
    }
  std::rotate(ang.begin(), ang.begin() + cut, ang.end());
  for (int i = 1; i < n; ++i)
    if (ang[i].first < ang[i - 1].first) ang[i].first += 2.0 * M_PI;
  a.pre.assign(n + 1, 0.0);
  a.pre2.assign(n + 1, 0.0);
  for (int i = 0; i < n; ++i) {
    a.pre[i + 1] = a.pre[i] + ang[i].first;
    a.pre2[i + 1] = a.pre2[i] + ang[i].first * ang[i].first;
  }
  return a;
}

bool split_normals(const std::vector<Vec2d>& normals, const std::vector<int>& idx, int k, double min_angle,
                   int min_size, std::vector<std::vector<int>>& parts) {
  return split_normals(normals, normal_angles(normals, idx), k, min_angle, min_size, parts);
}

bool split_normals(const std::vector<Vec2d>& normals, const NormalAngles& angles, int k, double min_angle,
                   int min_size, std::vector<std::vector<int>>& parts) {
  parts.clear();
  const std::vector<std::pair<double, int>>& ang = angles.order;
  const int n = static_cast<int>(ang.size());
  if (k < 2 || k > 3 || min_size < 1 || n < k * min_size) return false;
  const std::vector<double>&pre = angles.pre, &pre2 = angles.pre2;
  auto sse = [&](int lo, int hi) {  // [lo, hi)
    const double s = pre[hi] - pre[lo], s2 = pre2[hi] - pre2[lo];
    return s2 - s * s / (hi - lo);
  };
  // Optimal contiguous split: bounds b[0] = 0 < b[1] < ... < b[k] = n.
  std::vector<int> best;
  double best_cost = std::numeric_limits<double>::infinity();
  if (k == 2) {
    for (int i = min_size; i <= n - min_size; ++i)
      if (const double c = sse(0, i) + sse(i, n); c < best_cost) {
        best_cost = c;
        best = {0, i, n};
      }
  } else {
    // Split positions on a stride of n / 64: O(64^2) instead of O(n^2), and
    // the clusters of a corner are far wider than n / 64 points.
    const int stride = std::max(1, n / 64);
    for (int i = min_size; i <= n - 2 * min_size; i += stride)
      for (int j = i + min_size; j <= n - min_size; j += stride)
        if (const double c = sse(0, i) + sse(i, j) + sse(j, n); c < best_cost) {
          best_cost = c;
          best = {0, i, j, n};
        }
  }
  if (best.empty()) return false;
  std::vector<Vec2d> mean(k, Vec2d(0.0, 0.0));
  for (int c = 0; c < k; ++c)
    for (int i = best[c]; i < best[c + 1]; ++i) mean[c] += normals[ang[i].second];
  for (int c = 0; c + 1 < k; ++c) {
    if (mean[c].norm() == 0.0 || mean[c + 1].norm() == 0.0) return false;
    const double sep = std::acos(std::clamp(mean[c].normalized().dot(mean[c + 1].normalized()), -1.0, 1.0));
    if (sep < min_angle) return false;
  }
  parts.assign(k, {});
  for (int c = 0; c < k; ++c)
    for (int i = best[c]; i < best[c + 1]; ++i) parts[c].push_back(ang[i].second);
  return true;
}

double FitInput::weight(const Vec2d& p) const { return std::max(bspline2(1.5 * (p - centre).norm() / radius), 1e-12); }

double FitInput::error(const LocalFn& fn, const std::vector<int>& ids, double bound) const {
  double err = 0.0;
  for (int i : ids) {
    double e = taubin_distance(fn, points[i]);
    if (weight_ref > 0.0 && e > 0.0) {
      const double share = std::min(1.0, bspline2(1.5 * (points[i] - centre).norm() / radius) / weight_ref);
      e = share > 0.0 ? e * share : 0.0;  // no inf x 0 on the circle itself
    }
    err = std::max(err, e);
    if (err > bound) break;
  }
  return err;
}

namespace {
double group_error(const FitInput& in, const Group& g, const std::vector<int>& ids,
                   double bound = std::numeric_limits<double>::infinity()) {
  LocalFn fn;
  fn.group[0] = g;
  return in.error(fn, ids, bound);
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

CurvePiece fit_piece(const FitInput& in, const std::vector<int>& ids, double& error) {
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
    const double e = group_error(in, h, ids, error);
    if (e <= error) {
      error = e;
      return h.piece[0];
    }
  }
  return g.piece[0];
}

namespace {
/// Connected parts of ids (union-find over links shorter than `link`).
std::vector<std::vector<int>> connected_parts(const std::vector<Vec2d>& points, const std::vector<int>& ids,
                                              double link) {
  const int m = static_cast<int>(ids.size());
  std::vector<int> parent(m);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  const double l2 = link * link;
  auto link_pair = [&](int i, int j) {
    if ((points[ids[i]] - points[ids[j]]).squaredNorm() <= l2) parent[find(j)] = find(i);
  };
  // Only pairs less than `link` apart in x can be linked: a sweep over the
  // points in x order tests those (with a margin for rounding), the same
  // links as testing every pair, so the same parts (union order does not
  // matter).
  std::vector<std::pair<double, int>> by_x(m);
  for (int i = 0; i < m; ++i) by_x[i] = {points[ids[i]].x(), i};
  std::sort(by_x.begin(), by_x.end());
  // x gaps up to `link` plus a rounding margin: a pair the squared-norm test
  // links is never skipped by its x gap.
  constexpr double kSweepRelativeMargin = 1e-6, kSweepAbsoluteMargin = 1e-12;
  const double reach = link * (1.0 + kSweepRelativeMargin) + kSweepAbsoluteMargin;
  for (int a = 0; a < m; ++a)
    for (int b = a + 1; b < m && by_x[b].first - by_x[a].first <= reach; ++b)
      link_pair(std::min(by_x[a].second, by_x[b].second), std::max(by_x[a].second, by_x[b].second));
  std::vector<int> label(m, -1);
  std::vector<std::vector<int>> parts;
  for (int i = 0; i < m; ++i) {
    const int r = find(i);
    if (label[r] < 0) {
      label[r] = static_cast<int>(parts.size());
      parts.emplace_back();
    }
    parts[label[r]].push_back(ids[i]);
  }
  return parts;
}
}  // namespace

bool fit_corner(const FitInput& in, const std::vector<int>& ids, int k, Group& group, const NormalAngles* angles) {
  std::vector<std::vector<int>> clusters, part;
  const bool split = angles ? split_normals(in.normals, *angles, k, in.corner_angle, kMinClusterSize, clusters)
                            : split_normals(in.normals, ids, k, in.corner_angle, kMinClusterSize, clusters);
  if (!split) return false;
  for (const auto& c : clusters)
    for (auto& p : connected_parts(in.points, c, in.link)) {
      if (static_cast<int>(p.size()) < 3) return false;  // a stray point: no piece
      part.push_back(std::move(p));
    }
  const int m = static_cast<int>(part.size());
  if (m < 2 || m > 3) return false;
  std::vector<Vec2d> centroid(m), normal(m);
  for (int c = 0; c < m; ++c) {
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
  group.count = m;
  group.lone = 0;
  if (m == 2) {
    // Convex corner: each part lies behind the other's normal; the inside is in both.
    group.op = (centroid[1] - centroid[0]).dot(normal[0] - normal[1]) < 0.0 ? Group::Op::Min : Group::Op::Max;
    return true;
  }
  Group best = group;
  double best_err = std::numeric_limits<double>::infinity();
  for (Group::Op op : {Group::Op::Min, Group::Op::Max, Group::Op::MaxOfMin, Group::Op::MinOfMax})
    for (int lone = 0; lone < ((op == Group::Op::Min || op == Group::Op::Max) ? 1 : 3); ++lone) {
      Group g = group;
      g.op = op;
      g.lone = lone;
      if (const double e = group_error(in, g, ids, best_err); e < best_err) {
        best_err = e;
        best = g;
      }
    }
  group = best;
  return true;
}

Group fit_curve(const FitInput& in, const std::vector<int>& ids, double tol, double& error) {
  Group best;
  best.piece[0] = fit_piece(in, ids, error);
  NormalAngles angles;
  for (int k = 2; k <= 3 && error > tol; ++k) {
    if (k == 2) angles = normal_angles(in.normals, ids);
    Group c;
    if (!fit_corner(in, ids, k, c, &angles)) continue;
    if (const double e = group_error(in, c, ids, error); e < error) {
      error = e;
      best = c;
    }
  }
  return best;
}

LocalFn fit_components(const FitInput& in, const std::vector<std::vector<int>>& parts, double tol) {
  LocalFn fn;
  fn.kind = LocalFn::Kind::Components;
  fn.groups = static_cast<int>(parts.size());
  double err;
  for (int i = 0; i < fn.groups; ++i) fn.group[i] = fit_curve(in, parts[i], tol, err);
  // Open nodes and their points; join the best pair until one is left.
  std::vector<int> open(fn.groups);
  std::iota(open.begin(), open.end(), 0);
  std::vector<std::vector<int>> pts(parts.begin(), parts.end());
  while (open.size() > 1) {
    double best = std::numeric_limits<double>::infinity();
    LocalFn best_fn;
    std::size_t bi = 0, bj = 1;
    for (std::size_t i = 0; i < open.size(); ++i)
      for (std::size_t j = i + 1; j < open.size(); ++j) {
        std::vector<int> both = pts[i];
        both.insert(both.end(), pts[j].begin(), pts[j].end());
        for (bool use_min : {true, false}) {
          LocalFn trial = fn;
          trial.join[trial.joins] = {use_min, static_cast<std::int8_t>(open[i]), static_cast<std::int8_t>(open[j])};
          ++trial.joins;
          // Evaluate the new node alone: it is the last one.
          if (const double e = in.error(trial, both, best); e < best) {
            best = e;
            best_fn = trial;
            bi = i;
            bj = j;
          }
        }
      }
    fn = best_fn;
    pts[bi].insert(pts[bi].end(), pts[bj].begin(), pts[bj].end());
    pts.erase(pts.begin() + static_cast<std::ptrdiff_t>(bj));
    open[bi] = fn.groups + fn.joins - 1;
    open.erase(open.begin() + static_cast<std::ptrdiff_t>(bj));
  }
  return fn;
}

}  // namespace isoloft::detail
