#include "isoloft/fit/point_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace isoloft::detail {

PointGrid::PointGrid(std::vector<Vec2d> points) : pts_(std::move(points)) {
  if (pts_.empty()) return;
  Vec2d lo = pts_[0], hi = pts_[0];
  for (const Vec2d& p : pts_) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec2d ext = hi - lo;
  const double n = static_cast<double>(pts_.size());
  // About one bucket per point over the bounding box; never more than 1024
  // buckets along a side (a nearly one-dimensional set would ask for more).
  h_ = std::max({std::sqrt(ext.x() * ext.y() / n), ext.maxCoeff() / 1024.0, 1e-9});
  origin_ = lo;
  nx_ = std::max(1, static_cast<int>(std::floor(ext.x() / h_)) + 1);
  ny_ = std::max(1, static_cast<int>(std::floor(ext.y() / h_)) + 1);
  std::vector<int> bucket(pts_.size());
  start_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  for (std::size_t i = 0; i < pts_.size(); ++i) {
    const int bx = std::clamp(static_cast<int>((pts_[i].x() - lo.x()) / h_), 0, nx_ - 1);
    const int by = std::clamp(static_cast<int>((pts_[i].y() - lo.y()) / h_), 0, ny_ - 1);
    bucket[i] = by * nx_ + bx;
    ++start_[bucket[i] + 1];
  }
  for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
  order_.resize(pts_.size());
  std::vector<int> fill(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < pts_.size(); ++i) order_[fill[bucket[i]]++] = static_cast<int>(i);
}

template <class F>
void PointGrid::for_buckets_in_box(const Vec2d& lo, const Vec2d& hi, F&& f) const {
  if (pts_.empty()) return;
  const double fx0 = std::floor((lo.x() - origin_.x()) / h_), fx1 = std::floor((hi.x() - origin_.x()) / h_);
  const double fy0 = std::floor((lo.y() - origin_.y()) / h_), fy1 = std::floor((hi.y() - origin_.y()) / h_);
  if (fx1 < 0 || fy1 < 0 || fx0 > nx_ - 1 || fy0 > ny_ - 1) return;
  const int x0 = static_cast<int>(std::max(fx0, 0.0)), x1 = static_cast<int>(std::min<double>(fx1, nx_ - 1));
  const int y0 = static_cast<int>(std::max(fy0, 0.0)), y1 = static_cast<int>(std::min<double>(fy1, ny_ - 1));
  for (int by = y0; by <= y1; ++by)
    for (int bx = x0; bx <= x1; ++bx) {
      const int b = by * nx_ + bx;
      for (int k = start_[b]; k < start_[b + 1]; ++k) f(order_[k]);
    }
}

void PointGrid::in_ball(const Vec2d& c, double r, std::vector<int>& out) const {
  out.clear();
  const double r2 = r * r;
  const Vec2d rr(r, r);
  for_buckets_in_box(c - rr, c + rr, [&](int i) {
    if ((pts_[i] - c).squaredNorm() <= r2) out.push_back(i);
  });
}

std::size_t PointGrid::count_in_ball(const Vec2d& c, double r) const {
  std::size_t n = 0;
  const double r2 = r * r;
  const Vec2d rr(r, r);
  for_buckets_in_box(c - rr, c + rr, [&](int i) { n += (pts_[i] - c).squaredNorm() <= r2 ? 1 : 0; });
  return n;
}

void PointGrid::nearest(const Vec2d& c, int k, std::vector<std::pair<double, int>>& out) const {
  out.clear();
  if (pts_.empty() || k <= 0) return;
  const std::size_t want = std::min<std::size_t>(static_cast<std::size_t>(k), pts_.size());
  const int ci = std::clamp(static_cast<int>(std::floor((c.x() - origin_.x()) / h_)), 0, nx_ - 1);
  const int cj = std::clamp(static_cast<int>(std::floor((c.y() - origin_.y()) / h_)), 0, ny_ - 1);
  std::vector<std::pair<double, int>>& cand = out;  // squared distances while searching
  const double inf = std::numeric_limits<double>::infinity();
  for (int r = 0;; ++r) {
    const int i0 = ci - r, i1 = ci + r, j0 = cj - r, j1 = cj + r;
    // Visit the ring of buckets at Chebyshev index distance r.
    auto visit = [&](int bi, int bj) {
      if (bi < 0 || bj < 0 || bi >= nx_ || bj >= ny_) return;
      const int b = bj * nx_ + bi;
      for (int q = start_[b]; q < start_[b + 1]; ++q) cand.emplace_back((pts_[order_[q]] - c).squaredNorm(), order_[q]);
    };
    if (r == 0) {
      visit(ci, cj);
    } else {
      for (int bi = std::max(i0, 0); bi <= std::min(i1, nx_ - 1); ++bi) {
        visit(bi, j0);
        visit(bi, j1);
      }
      for (int bj = std::max(j0 + 1, 0); bj <= std::min(j1 - 1, ny_ - 1); ++bj) {
        visit(i0, bj);
        visit(i1, bj);
      }
    }
    // Every point outside the visited rectangle lies beyond one of its sides
    // that is not on the grid border: at least this far from c.
    double g = inf;
    if (i0 > 0) g = std::min(g, c.x() - (origin_.x() + i0 * h_));
    if (i1 < nx_ - 1) g = std::min(g, origin_.x() + (i1 + 1) * h_ - c.x());
    if (j0 > 0) g = std::min(g, c.y() - (origin_.y() + j0 * h_));
    if (j1 < ny_ - 1) g = std::min(g, origin_.y() + (j1 + 1) * h_ - c.y());
    if (g == inf) break;  // all buckets visited
    if (cand.size() >= want && g > 0.0) {
      const double g2 = g * g;
      std::size_t sure = 0;
      for (const auto& e : cand) sure += e.first <= g2 ? 1 : 0;
      if (sure >= want) break;
    }
  }
  std::partial_sort(cand.begin(), cand.begin() + static_cast<std::ptrdiff_t>(want), cand.end());
  cand.resize(want);
  for (auto& e : cand) e.first = std::sqrt(e.first);
}

}  // namespace isoloft::detail
