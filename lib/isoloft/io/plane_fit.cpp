// @file io/plane_fit.cpp
// @brief Plane poses and least-squares planes.
#include "isoloft/io/plane_fit.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace isoloft {

PlanePose plane_pose(const Vec3d& unit_normal, double offset) {
  const Vec3d& n = unit_normal;
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(n[k]) < std::abs(n[axis])) axis = k;
  const Vec3d e = Vec3d::Unit(axis);
  PlanePose pose;
  pose.u = (e - e.dot(n) * n).normalized();
  pose.v = n.cross(pose.u);
  pose.origin = offset * n;
  return pose;
}

PlaneFit fit_plane(const std::vector<Vec3d>& points) {
  PlaneFit fit;
  if (points.empty()) return fit;
  for (const Vec3d& p : points) fit.centroid += p;
  fit.centroid /= double(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Vec3d& p : points) cov += (p - fit.centroid) * (p - fit.centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Vec3d n = eig.eigenvectors().col(0).normalized();
  int big = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(n[k]) > std::abs(n[big])) big = k;
  if (n[big] < 0) n = -n;
  fit.normal = n;
  for (const Vec3d& p : points) fit.max_residual = std::max(fit.max_residual, std::abs((p - fit.centroid).dot(n)));
  // The middle eigenvalue: squared spread across the best line, in the plane.
  fit.line_spread = std::sqrt(std::max(0.0, eig.eigenvalues()[1]) / double(points.size()));
  return fit;
}

}  // namespace isoloft
