#include "isoloft/fit/mpu.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>
#include <unordered_map>

#include "isoloft/core/error.h"

namespace isoloft {

using detail::bspline2;
using detail::bspline2_derivative;
using detail::LocalFn;

// ---------------------------------------------------------------- evaluation

Eigen::AlignedBox2d MpuCurve::root_box() const {
  const Vec2d h(root_half_, root_half_);
  return {root_centre_ - h, root_centre_ + h};
}

void MpuCurve::accumulate(const Vec2d& p, double& num, double& den, Vec2d* dnum, Vec2d* dden) const {
  num = den = 0.0;
  if (dnum) dnum->setZero();
  if (dden) dden->setZero();
  if (nodes_.empty()) return;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!node.box.contains(p)) continue;
    if (node.first_child >= 0) {
      for (int k = 0; k < 4; ++k) stack[top++] = node.first_child + k;
      continue;
    }
    const Leaf& leaf = leaves_[node.leaf];
    const Vec2d d = p - leaf.centre;
    const double r = d.norm();
    const double t = 1.5 * r / leaf.radius;
    if (t >= 1.5) continue;
    const double w = bspline2(t);
    double q;
    Vec2d gq;
    leaf.fn.eval(p, q, gq);
    num += w * q;
    den += w;
    if (dnum) {
      const Vec2d gw = r > 0.0 ? Vec2d(bspline2_derivative(t) * 1.5 / leaf.radius * d / r) : Vec2d(0.0, 0.0);
      *dnum += gw * q + w * gq;
      *dden += gw;
    }
  }
}

void MpuCurve::fallback_eval(const Vec2d& p, double& value, Vec2d& grad) const {
  std::vector<std::pair<double, int>> nn;
  grid_.nearest(p, 1, nn);
  const Vec2d& q = grid_.points()[nn[0].second];
  const Vec2d d = p - q;
  const double dist = nn[0].first;
  const double s = (q - p).dot(normals_[nn[0].second]) > 0.0 ? 1.0 : -1.0;
  value = s * dist;
  grad = dist > 0.0 ? Vec2d(s * d / dist) : Vec2d(-normals_[nn[0].second]);
}

double MpuCurve::fallback(const Vec2d& p) const {
  if (grid_.size() == 0) return -kEmpty;
  double v;
  Vec2d g;
  fallback_eval(p, v, g);
  return v;
}

void MpuCurve::value_and_gradient(const Vec2d& p, double& value, Vec2d& gradient) const {
  if (nodes_.empty()) {
    value = -kEmpty;
    gradient.setZero();
    return;
  }
  double num, den;
  Vec2d dnum, dden;
  accumulate(p, num, den, &dnum, &dden);
  if (den >= w_floor_) {
    value = num / den;
    gradient = (dnum * den - num * dden) / (den * den);
    return;
  }
  double f;
  Vec2d gf;
  fallback_eval(p, f, gf);
  const double w0 = w_floor_ - den;  // total weight is w_floor_
  value = (num + w0 * f) / w_floor_;
  gradient = (dnum - dden * f + w0 * gf) / w_floor_;
}

double MpuCurve::value(const Vec2d& p) const {
  if (nodes_.empty()) return -kEmpty;
  double num, den;
  accumulate(p, num, den, nullptr, nullptr);
  if (den >= w_floor_) return num / den;
  return (num + (w_floor_ - den) * fallback(p)) / w_floor_;
}

Vec2d MpuCurve::gradient(const Vec2d& p) const {
  double v;
  Vec2d g;
  value_and_gradient(p, v, g);
  return g;
}

std::vector<std::pair<int, double>> MpuCurve::weights(const Vec2d& p) const {
  std::vector<std::pair<int, double>> out;
  if (nodes_.empty()) return out;
  double den = 0.0;
  for (std::size_t i = 0; i < leaves_.size(); ++i) {
    const double t = 1.5 * (p - leaves_[i].centre).norm() / leaves_[i].radius;
    if (t >= 1.5) continue;
    out.emplace_back(static_cast<int>(i), bspline2(t));
    den += out.back().second;
  }
  double total = den;
  if (den < w_floor_) {
    out.emplace_back(-1, w_floor_ - den);
    total = w_floor_;
  }
  for (auto& e : out) e.second /= total;
  return out;
}

Grid2f evaluate_on_grid(const MpuCurve& curve, int width, int height, double x0, double y0, double step,
                        const Grid2u8* where) {
  if (width < 0 || height < 0)
    throw ParamError("evaluate MPU on grid: size " + std::to_string(width) + "x" + std::to_string(height) +
                     " is negative");
  if (!(step > 0.0) || !std::isfinite(step))
    throw ParamError("evaluate MPU on grid: step must be a finite number > 0 (got " + std::to_string(step) + ")");
  if (where && (where->width != width || where->height != height))
    throw ParamError("evaluate MPU on grid: the mask of pixels to evaluate is " + std::to_string(where->width) + "x" +
                     std::to_string(where->height) + ", the grid " + std::to_string(width) + "x" +
                     std::to_string(height));
  Grid2f out(width, height, static_cast<float>(-MpuCurve::kEmpty));
  if (width == 0 || height == 0 || curve.nodes_.empty()) return out;
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    std::vector<double> num(width), den(width);
    std::vector<int> stack;
    for (int j = rows.begin(); j < rows.end(); ++j) {
      // Pixels lo..hi of this row are evaluated (those of `where` among them).
      int lo = 0, hi = width - 1;
      const std::uint8_t* mask = where ? &(*where)(0, j) : nullptr;
      if (mask) {
        while (lo <= hi && !mask[lo]) ++lo;
        while (hi >= lo && !mask[hi]) --hi;
        if (lo > hi) continue;
      }
      const double y = y0 + j * step;
      const double xmin = x0 + lo * step, xmax = x0 + hi * step;
      std::fill(num.begin() + lo, num.begin() + hi + 1, 0.0);
      std::fill(den.begin() + lo, den.begin() + hi + 1, 0.0);
      // Leaves whose support circle meets this row, each added over its span.
      stack.assign(1, 0);
      while (!stack.empty()) {
        const MpuCurve::Node& node = curve.nodes_[stack.back()];
        stack.pop_back();
        if (y < node.box.min().y() || y > node.box.max().y() || node.box.max().x() < xmin || node.box.min().x() > xmax)
          continue;
        if (node.first_child >= 0) {
          for (int k = 0; k < 4; ++k) stack.push_back(node.first_child + k);
          continue;
        }
        const MpuCurve::Leaf& leaf = curve.leaves_[node.leaf];
        const double dy = y - leaf.centre.y();
        const double R = leaf.radius;
        if (std::abs(dy) >= R) continue;
        const double hw = std::sqrt(R * R - dy * dy);
        const int i0 = std::max(lo, static_cast<int>(std::ceil((leaf.centre.x() - hw - x0) / step)));
        const int i1 = std::min(hi, static_cast<int>(std::floor((leaf.centre.x() + hw - x0) / step)));
        for (int i = i0; i <= i1; ++i) {
          if (mask && !mask[i]) continue;
          const Vec2d p(x0 + i * step, y);
          const double t = 1.5 * (p - leaf.centre).norm() / R;
          if (t >= 1.5) continue;
          const double w = bspline2(t);
          num[i] += w * leaf.fn.value(p);
          den[i] += w;
        }
      }
      for (int i = lo; i <= hi; ++i) {
        if (mask && !mask[i]) continue;
        double v;
        if (den[i] >= curve.w_floor_) {
          v = num[i] / den[i];
        } else {
          const Vec2d p(x0 + i * step, y);
          v = (num[i] + (curve.w_floor_ - den[i]) * curve.fallback(p)) / curve.w_floor_;
        }
        out(i, j) = static_cast<float>(v);
      }
    }
  });
  return out;
}

// ---------------------------------------------------------------- fitting

namespace {

struct Scratch {
  std::vector<int> idx;
  std::vector<double> w;
  std::vector<std::pair<double, int>> nn;
  std::vector<int> comp_count;
  std::vector<int> touched;
  std::vector<std::vector<int>> parts;
  int touched_pieces = 0;
  std::vector<detail::AuxPoint> aux;
  std::vector<int> ring;  ///< ring checks in the leaf's core
};

struct Cell {
  Vec2d centre;
  double half = 0.0;
  int depth = 0;
  double parent_radius = std::numeric_limits<double>::infinity();
  int n_start = std::numeric_limits<int>::max();  ///< first N_min of the support reduction: the parent's last
};

/// Union-find over points linked closer than `link`.
std::vector<int> point_components(const detail::PointGrid& grid, double link, int& count) {
  const int n = static_cast<int>(grid.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  std::vector<int> near;
  for (int i = 0; i < n; ++i) {
    grid.in_ball(grid.points()[i], link, near);
    for (int j : near) {
      const int a = find(i), b = find(j);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<int> label(n, -1), comp(n);
  count = 0;
  for (int i = 0; i < n; ++i) {
    const int r = find(i);
    if (label[r] < 0) label[r] = count++;
    comp[i] = label[r];
  }
  return comp;
}

}  // namespace

class MpuBuilder {
 public:
  MpuBuilder(const OrientedPoints& in, const MpuParams& prm) : p_(prm), normals_(in.normals) {
    grid_ = detail::PointGrid(in.points);
    n_eff_ = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(prm.n_min), in.points.size()));
    // Median nearest-neighbour spacing sets the link length of the pieces.
    std::vector<double> spacing;
    std::vector<std::pair<double, int>> nn;
    const std::size_t n = in.points.size();
    const std::size_t stride = std::max<std::size_t>(1, n / 2000);
    for (std::size_t i = 0; i < n; i += stride) {
      grid_.nearest(in.points[i], 2, nn);
      if (nn.size() == 2) spacing.push_back(nn[1].first);
    }
    double med = 0.0;
    if (!spacing.empty()) {
      std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2),
                       spacing.end());
      med = spacing[spacing.size() / 2];
    }
    link_ = p_.component_link * med;
    comp_ = point_components(grid_, link_, ncomp_);
    ring_checks();
    // Weighted error: full weight a little beyond the cell's corners (t =
    // 0.75 / alpha there); ring checks: the radius over R within which a
    // leaf weighs at least what it weighs on its own cell's corners.
    weight_ref_ = p_.weighted_error ? bspline2(detail::kFullErrorReach * 0.75 / p_.alpha) : 0.0;
    core_fraction_ = 0.5 / p_.alpha;
    comp_size_.assign(ncomp_, 0);
    for (int c : comp_) ++comp_size_[c];
  }

  MpuResult build() {
    const std::vector<Vec2d>& pts = grid_.points();
    Eigen::AlignedBox2d box;
    for (const Vec2d& q : pts) box.extend(q);
    if (!p_.domain.isEmpty()) box.extend(p_.domain);
    MpuResult res;
    MpuCurve& curve = res.curve;
    curve.root_centre_ = box.center();
    curve.root_half_ = 0.5 * box.sizes().maxCoeff() * 1.02 + 0.5;  // points strictly inside
    curve.w_floor_ = 0.5 * bspline2(0.75 / p_.alpha);

    std::vector<Cell> cells{Cell{curve.root_centre_, curve.root_half_, 0}};
    std::vector<MpuCurve::Node> nodes(1);
    std::vector<int> level{0};
    tbb::enumerable_thread_specific<Scratch> scratch;
    while (!level.empty()) {
      std::vector<MpuCurve::Leaf> fits(level.size());
      std::vector<char> outside(level.size(), 0);
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, level.size()),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          Scratch& s = scratch.local();
                          for (std::size_t k = r.begin(); k < r.end(); ++k) {
                            if ((outside[k] = !in_domain(cells[level[k]], s))) continue;
                            fits[k] = fit_cell(cells[level[k]], s);
                          }
                        });
      std::vector<int> next;
      for (std::size_t k = 0; k < level.size(); ++k) {
        const int id = level[k];
        const Cell cell = cells[id];
        if (outside[k]) {  // no local function: the node keeps an empty box
          ++res.cells_outside_domain;
          continue;
        }
        ++res.cells;
        res.max_depth_reached = std::max(res.max_depth_reached, cell.depth);
        // A cell whose support had to grow to more than kSupportShrink of its
        // parent's radius is not subdivided: its children would grow back to
        // about the same points (file comment).
        // Unless its support touches more pieces of data than one local
        // function joins: children may see fewer.
        const bool stalled = fits[k].support_bound && fits[k].radius > detail::kSupportShrink * cell.parent_radius &&
                             fits[k].pieces <= detail::kMaxComponents;
        if ((fits[k].error > p_.tol || !fits[k].sign_ok) && cell.depth < p_.max_depth && !stalled) {
          nodes[id].first_child = static_cast<int>(nodes.size());
          const double h = 0.5 * cell.half;
          for (int c = 0; c < 4; ++c) {
            const Vec2d off((c & 1) ? h : -h, (c & 2) ? h : -h);
            cells.push_back(Cell{cell.centre + off, h, cell.depth + 1, fits[k].radius, fits[k].n_last});
            nodes.emplace_back();
            next.push_back(static_cast<int>(nodes.size()) - 1);
          }
          continue;
        }
        MpuCurve::Leaf& leaf = fits[k];
        nodes[id].leaf = static_cast<int>(curve.leaves_.size());
        const Vec2d rr(leaf.radius, leaf.radius);
        nodes[id].box = Eigen::AlignedBox2d(leaf.centre - rr, leaf.centre + rr);
        ++res.leaves;
        res.max_local_error = std::max(res.max_local_error, leaf.error);
        if (leaf.error > p_.tol) {
          ++res.leaves_over_tol;
          res.leaves_over_tol_at_max_depth += cell.depth == p_.max_depth ? 1 : 0;
        }
        res.sign_check_failures += leaf.sign_ok ? 0 : 1;
        res.grown_leaves += leaf.grown ? 1 : 0;
        switch (leaf.fn.kind) {
          case LocalFn::Kind::Quadric: ++res.quadric_leaves; break;
          case LocalFn::Kind::Height: ++res.height_leaves; break;
          case LocalFn::Kind::Corner: ++res.corner_leaves; break;
          case LocalFn::Kind::Components: ++res.component_leaves; break;
        }
        curve.leaves_.push_back(std::move(leaf));
      }
      level.swap(next);
    }
    // Children follow their parents: one backward pass collects the bounds.
    for (int i = static_cast<int>(nodes.size()) - 1; i >= 0; --i)
      if (nodes[i].first_child >= 0)
        for (int c = 0; c < 4; ++c) nodes[i].box.extend(nodes[nodes[i].first_child + c].box);
    curve.nodes_ = std::move(nodes);
    curve.normals_ = normals_;
    curve.grid_ = grid_;
    res.components = ncomp_;
    return res;
  }

 private:
  /// The cell comes within MpuParams::domain_distance of a point (always
  /// true without a domain distance).
  bool in_domain(const Cell& cell, Scratch& s) const {
    if (p_.domain_distance <= 0.0) return true;
    grid_.nearest(cell.centre, 1, s.nn);
    return !s.nn.empty() && s.nn[0].first <= p_.domain_distance + std::sqrt(2.0) * cell.half;
  }

  /// Support radius (MPU growth + component rule) of a cell with radius r0.
  /// exact: grow to the distance of the next point instead of in (1 + lambda) steps.
  double support_radius(const Vec2d& c, double r0, int n_target, bool exact, Scratch& s, bool& grown) const {
    grown = false;
    if (grid_.count_in_ball(c, r0) >= static_cast<std::size_t>(n_target)) return r0;
    grid_.nearest(c, n_target, s.nn);
    if (s.comp_count.size() != comp_size_.size()) s.comp_count.assign(comp_size_.size(), 0);
    s.touched.clear();
    std::size_t pos = 0;
    int incomplete = 0;
    double r = r0;
    for (;;) {
      while (pos < s.nn.size() && s.nn[pos].first <= r) {
        const int comp = comp_[s.nn[pos].second];
        if (s.comp_count[comp]++ == 0) {
          s.touched.push_back(comp);
          ++incomplete;
        }
        if (s.comp_count[comp] == comp_size_[comp]) --incomplete;
        ++pos;
      }
      if (pos >= static_cast<std::size_t>(n_target) || (pos >= 1 && incomplete == 0) || pos >= s.nn.size()) break;
      r = exact ? s.nn[pos].first : r * (1.0 + p_.lambda);
      grown = true;
    }
    for (int comp : s.touched) s.comp_count[comp] = 0;
    return r;
  }

  /// The cell's local fit with N_min points, or, while a grown support misses
  /// tol, with n_min halved down to n_floor (file comment).
  MpuCurve::Leaf fit_cell(const Cell& cell, Scratch& s) const {
    const double r0 = p_.alpha * 2.0 * std::sqrt(2.0) * cell.half;
    bool grown = false;
    // A child starts where its parent's support reduction ended: the parent's
    // larger circle failed with every larger N_min (file comment).
    int n = std::min(n_eff_, cell.n_start);
    sign_checks(cell, s);  // the cell's, for every support below
    double radius = support_radius(cell.centre, r0, n, n < n_eff_, s, grown);
    MpuCurve::Leaf best = fit_support(cell, radius, grown, n, s);
    best.support_bound = grown;
    const int floor = std::min(n_eff_, p_.n_floor);
    while ((best.error > p_.tol || !best.sign_ok) && best.support_bound && n > floor) {
      n = std::max(floor, n / 2);
      radius = support_radius(cell.centre, r0, n, true, s, grown);
      if (!grown) {
        // The cell's own circle holds n points: MPU's support for this N_min.
        // If it misses tol too, smaller cells, not smaller supports, are the
        // way on; let it be subdivided.
        MpuCurve::Leaf leaf = fit_support(cell, radius, grown, n, s);
        if ((leaf.sign_ok && !best.sign_ok) || (leaf.sign_ok == best.sign_ok && leaf.error < best.error))
          best = std::move(leaf);
        best.support_bound = false;
        break;
      }
      if (radius >= best.radius) continue;  // same support, same fit
      MpuCurve::Leaf leaf = fit_support(cell, radius, grown, n, s);
      if ((leaf.sign_ok && !best.sign_ok) || (leaf.sign_ok == best.sign_ok && leaf.error < best.error)) {
        leaf.support_bound = true;
        best = std::move(leaf);
      }
    }
    best.n_last = n;
    return best;
  }

  MpuCurve::Leaf fit_support(const Cell& cell, double R, bool grown, int n_target, Scratch& s) const {
    const std::vector<Vec2d>& pts = grid_.points();
    MpuCurve::Leaf leaf;
    leaf.centre = cell.centre;
    leaf.half_size = cell.half;
    leaf.depth = cell.depth;
    leaf.radius = R;
    leaf.grown = grown;
    leaf.n_target = n_target;
    grid_.in_ball(cell.centre, R, s.idx);
    leaf.support = static_cast<int>(s.idx.size());
    const detail::FitInput in{pts, normals_, cell.centre, R, p_.corner_angle * M_PI / 180.0, link_, weight_ref_};

    // MPU's choice: mean normal of the weighted support; a height function if
    // every normal is within 90 degrees of it and N <= 2 N_min, else a conic.
    s.w.resize(s.idx.size());
    Vec2d nsum(0.0, 0.0);
    for (std::size_t k = 0; k < s.idx.size(); ++k) {
      s.w[k] = in.weight(pts[s.idx[k]]);
      nsum += s.w[k] * normals_[s.idx[k]];
    }
    const double nlen = nsum.norm();
    const Vec2d nbar = nlen > 0.0 ? Vec2d(nsum / nlen) : Vec2d(0.0, 1.0);
    bool agree = nlen > 0.0 && s.idx.size() >= 3;
    for (int i : s.idx) agree = agree && normals_[i].dot(nbar) > 0.0;
    const bool many = static_cast<int>(s.idx.size()) > 2 * n_target;

    // Candidates are ranked by (passes the sign checks, error): a model that
    // contradicts the sign the nearest points give at a check point is kept
    // only if every candidate does. s.aux: the cell's (fit_cell).
    ring_.in_ball(cell.centre, core_fraction_ * R, s.ring);
    leaf.error = std::numeric_limits<double>::infinity();
    bool leaf_checked = false;
    const auto checks_pass = [&](const LocalFn& fn) {
      for (const detail::AuxPoint& q : s.aux)
        if ((fn.value(q.q) > 0.0) != (q.d > 0.0)) return false;
      // The ring checks where this leaf has full weight.
      for (int k : s.ring)
        if ((fn.value(ring_.points()[k]) > 0.0) != bool(ring_inside_[k])) return false;
      return true;
    };
    // Kept: the first candidate that passes the checks, then any that passes
    // them with a smaller error; until one passes, the least error. Errors
    // stop at the best so far, and a candidate that cannot win on error is
    // not checked.
    auto consider = [&](const LocalFn& fn) {
      double e;
      bool ok;
      if (leaf_checked) {
        e = in.error(fn, s.idx, leaf.error);
        if (!(e < leaf.error) || !(ok = checks_pass(fn))) return;
      } else if ((ok = checks_pass(fn))) {
        e = in.error(fn, s.idx);
      } else {
        e = in.error(fn, s.idx, leaf.error);
        if (!(e < leaf.error)) return;
      }
      leaf.fn = fn;
      leaf.error = e;
      leaf_checked = ok;
    };
    auto good = [&] { return leaf_checked && leaf.error <= p_.tol; };
    auto height = [&] {
      LocalFn fn;
      fn.kind = LocalFn::Kind::Height;
      fn.group[0].piece[0].h = detail::fit_height(pts, s.idx, s.w, cell.centre, nbar, R);
      return fn;
    };
    auto conic = [&] {
      LocalFn fn;
      fn.kind = LocalFn::Kind::Quadric;
      fn.group[0].piece[0] = detail::fit_conic(pts, normals_, s.idx, s.w, cell.centre, R);
      return fn;
    };
    const bool height_first = agree && !many;
    consider(height_first ? height() : conic());
    // Past MPU: if the chosen model misses tol or a sign check, the other
    // single model, then a two-part model are tried too (file comment).
    if (!good()) {
      if (height_first)
        consider(conic());
      else if (agree)
        consider(height());
    }
    if (!good()) {
      split_components(s);
      leaf.pieces = s.touched_pieces;
      if (s.parts.size() >= 2) {
        consider(detail::fit_components(in, s.parts, p_.tol));
      } else {
        const detail::NormalAngles angles = detail::normal_angles(normals_, s.idx);
        for (int k = 2; k <= 3 && !good(); ++k) {
          LocalFn corner;
          corner.kind = LocalFn::Kind::Corner;
          if (detail::fit_corner(in, s.idx, k, corner.group[0], &angles)) consider(corner);
        }
      }
    }
    leaf.sign_ok = leaf_checked;
    return leaf;
  }

  /// The support's points by connected piece of the data, the
  /// kMaxComponents largest (s.parts; one entry if the support touches one
  /// piece). s.touched_pieces: how many it touches.
  void split_components(Scratch& s) const {
    s.parts.clear();
    if (s.comp_count.size() != comp_size_.size()) s.comp_count.assign(comp_size_.size(), 0);
    s.touched.clear();
    for (int i : s.idx)
      if (s.comp_count[comp_[i]]++ == 0) s.touched.push_back(comp_[i]);
    std::sort(s.touched.begin(), s.touched.end(), [&](int a, int b) {
      return s.comp_count[a] > s.comp_count[b] || (s.comp_count[a] == s.comp_count[b] && a < b);
    });
    s.touched_pieces = static_cast<int>(s.touched.size());
    const std::size_t keep = std::min<std::size_t>(s.touched.size(), detail::kMaxComponents);
    s.parts.assign(keep, {});
    for (int i : s.idx)
      for (std::size_t k = 0; k < keep; ++k)
        if (comp_[i] == s.touched[k]) s.parts[k].push_back(i);
    for (int c : s.touched) s.comp_count[c] = 0;
  }

  /// Sign checks on the ring around the data: the integer lattice points q
  /// (pixel centres of the grid the points came from) whose nearest point lies
  /// kRingNear .. kRingFar away, their side from that point's tangent (as
  /// nearest_side). A curve within tol of every point has these sides unless
  /// it strays from the data, which is what they catch (e.g. a spike's two
  /// sides running on past its tip).
  void ring_checks() {
    const std::vector<Vec2d>& pts = grid_.points();
    // Lattice point (x, y) -> (distance, index) of its nearest point within kRingFar.
    std::unordered_map<std::int64_t, std::pair<double, int>> near;
    const auto key = [](std::int64_t x, std::int64_t y) { return x * (std::int64_t(1) << 32) + (y & 0xffffffff); };
    const int reach = static_cast<int>(std::ceil(detail::kRingFar));
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const auto cx = static_cast<std::int64_t>(std::floor(pts[i].x()));
      const auto cy = static_cast<std::int64_t>(std::floor(pts[i].y()));
      for (std::int64_t y = cy - reach; y <= cy + reach + 1; ++y)
        for (std::int64_t x = cx - reach; x <= cx + reach + 1; ++x) {
          const double d = (Vec2d(double(x), double(y)) - pts[i]).norm();
          if (d > detail::kRingFar) continue;
          const auto [it, fresh] = near.try_emplace(key(x, y), d, static_cast<int>(i));
          if (!fresh && d < it->second.first) it->second = {d, static_cast<int>(i)};
        }
    }
    struct Check {
      Vec2d q;
      bool inside;
    };
    std::vector<Check> checks;
    for (const auto& [k, e] : near) {
      if (e.first < detail::kRingNear) continue;
      const Vec2d q(double(k >> 32), double(static_cast<std::int32_t>(k & 0xffffffff)));
      const double d = (pts[e.second] - q).dot(normals_[e.second]);  // > 0: q is behind = inside
      if (std::abs(d) >= std::cos(detail::kSideAngle) * e.first) checks.push_back({q, d > 0.0});
    }
    // In lattice order, so that the fit does not depend on the hash order.
    std::sort(checks.begin(), checks.end(), [](const Check& a, const Check& b) {
      return a.q.y() < b.q.y() || (a.q.y() == b.q.y() && a.q.x() < b.q.x());
    });
    std::vector<Vec2d> where;
    where.reserve(checks.size());
    ring_inside_.reserve(checks.size());
    for (const Check& c : checks) {
      where.push_back(c.q);
      ring_inside_.push_back(c.inside);
    }
    ring_ = detail::PointGrid(std::move(where));
  }

  /// MPU's auxiliary points (cell corners and centre, here also the edge
  /// midpoints) as sign checks, their side from nearest_side, kept at least
  /// kSignCheckMargin from the data. The nearest point, not MPU's 6 nearest:
  /// in front of a wedge's tip the two sides' tangents both see q inside.
  void sign_checks(const Cell& cell, Scratch& s) const {
    s.aux.clear();
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b) {
        const Vec2d q = cell.centre + cell.half * Vec2d(a, b);
        double d;
        if (nearest_side(q, detail::kSignCheckMargin, s, d)) s.aux.push_back({q, d});
      }
  }

  /// Which side of the data q lies on, from its nearest point p: d = (p - q) .
  /// n_p (> 0: behind the normal, inside). False (no check) if p is nearer than
  /// min_dist or q lies off p's normal by more than kSideAngle (beside the
  /// data, e.g. off the end of an open piece, the tangent does not tell).
  bool nearest_side(const Vec2d& q, double min_dist, Scratch& s, double& d) const {
    grid_.nearest(q, 1, s.nn);
    if (s.nn.empty() || s.nn[0].first < min_dist) return false;
    d = (grid_.points()[s.nn[0].second] - q).dot(normals_[s.nn[0].second]);
    return std::abs(d) >= std::cos(detail::kSideAngle) * s.nn[0].first;
  }

  MpuParams p_;
  detail::PointGrid grid_;
  std::vector<Vec2d> normals_;
  int n_eff_ = 0;
  double link_ = 0.0;
  std::vector<int> comp_, comp_size_;
  detail::PointGrid ring_;         ///< ring_checks: where
  std::vector<char> ring_inside_;  ///< ring_checks: the side there (1 = inside)
  double weight_ref_ = 0.0;        ///< FitInput::weight_ref (0 without weighted_error)
  double core_fraction_ = 0.0;     ///< a leaf weighs >= b(0.75 / alpha) within this x R: 1 / (2 alpha)
  int ncomp_ = 0;
};

MpuResult fit_mpu(const OrientedPoints& in, const MpuParams& p) {
  params_table<MpuParams>().validate(p);
  if (!p.domain.isEmpty() && !(p.domain.min().allFinite() && p.domain.max().allFinite()))
    throw ParamError("MPU fit: domain is not finite");
  if (in.points.empty()) throw InputError("", "MPU fit: no contour points");
  if (in.points.size() != in.normals.size())
    throw InputError("", "MPU fit: " + std::to_string(in.points.size()) + " points but " +
                             std::to_string(in.normals.size()) + " normals");
  for (std::size_t i = 0; i < in.points.size(); ++i) {
    if (!in.points[i].allFinite()) throw InputError("", "MPU fit: point " + std::to_string(i) + " is not finite");
    if (!in.normals[i].allFinite() || std::abs(in.normals[i].norm() - 1.0) > 1e-3)
      throw InputError("", "MPU fit: normal " + std::to_string(i) + " is not a finite unit vector");
  }
  return MpuBuilder(in, p).build();
}

}  // namespace isoloft
