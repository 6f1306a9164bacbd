// @file fit/point_grid.h
// @brief Uniform bucket grid over 2D points: the MPU fit's spatial index.
// Square buckets, about as many as points, for "in a circle" and "k nearest".
// @warning Queries beyond the points' box clamp to the border buckets and
// widen the search until the answer is certain.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "isoloft/core/mesh.h"

namespace isoloft::detail {

class PointGrid {
 public:
  PointGrid() = default;
  /// \pre every point is finite.
  explicit PointGrid(std::vector<Vec2d> points);

  [[nodiscard]] const std::vector<Vec2d>& points() const { return pts_; }
  [[nodiscard]] std::size_t size() const { return pts_.size(); }
  [[nodiscard]] double bucket_size() const { return h_; }

  /// Indices of the points p with |p - c| <= r (cleared first; bucket order).
  void in_ball(const Vec2d& c, double r, std::vector<int>& out) const;
  /// Number of points p with |p - c| <= r.
  [[nodiscard]] std::size_t count_in_ball(const Vec2d& c, double r) const;
  /// The min(k, size()) points nearest to c as (distance, index), sorted by
  /// distance, ties by index (cleared first).
  void nearest(const Vec2d& c, int k, std::vector<std::pair<double, int>>& out) const;

 private:
  template <class F>
  void for_buckets_in_box(const Vec2d& lo, const Vec2d& hi, F&& f) const;

  std::vector<Vec2d> pts_;
  Vec2d origin_{0.0, 0.0};
  double h_ = 1.0;
  int nx_ = 0, ny_ = 0;
  std::vector<int> start_;  ///< bucket b holds order_[start_[b] .. start_[b + 1])
  std::vector<int> order_;
};

}  // namespace isoloft::detail
