// @file io/plane_fit.h
// @brief The pose the readers give a plane, and the least-squares plane of
// a contour's points (RT Structure Sets).
#pragma once

#include <vector>

#include "isoloft/core/section.h"

namespace isoloft {

/// The pose of the plane {x : n . x = offset}, n unit: origin offset n (the
/// plane's point nearest the world origin), u the world axis least aligned
/// with n (the first of equals) made orthogonal to n, v = n x u. An axial
/// plane (n = +z) gets u = x, v = y; the pose depends on the plane only.
PlanePose plane_pose(const Vec3d& unit_normal, double offset);

/// A least-squares plane.
struct PlaneFit {
  Vec3d normal = Vec3d::UnitZ();  ///< unit; its largest-magnitude component positive (+z for axial planes)
  Vec3d centroid = Vec3d::Zero();
  double max_residual = 0;  ///< largest distance of a point from the plane
  /// RMS distance of the points from their best line in the plane: 0 for
  /// collinear points, whose plane is undetermined.
  double line_spread = 0;
};

/// The plane through the centroid minimising the squared distances (normal:
/// the covariance's eigenvector of the least eigenvalue).
/// @warning Fewer than 3 points or collinear points give line_spread 0 and an
/// arbitrary normal: the caller refuses them.
PlaneFit fit_plane(const std::vector<Vec3d>& points);

}  // namespace isoloft
