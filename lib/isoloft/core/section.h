// @file core/section.h
// @brief Drawn sections in world space: a plane pose in millimetres and what
// was drawn on it (closed polylines with labels and holes, or a 2D label
// image). Every reader hands sections to the pipeline; a parallel stack is
// the special case of sections that share a normal.
//
// Conventions: world coordinates in millimetres (DICOM patient LPS for
// medical inputs, the file's own frame for CSL); in-plane coordinates (s, t)
// in millimetres along the pose's axes u and v; the normal is u x v, so a
// polyline drawn counter-clockwise in (s, t) winds counter-clockwise seen
// from the normal's side.
// @warning A pose whose axes are not orthonormal is the reader's error to
// refuse (PlanePose::orthonormal()); nothing here repairs one.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"

namespace isoloft {

/// A plane in world millimetres: in-plane point (s, t) lies at origin + s u + t v.
struct PlanePose {
  Vec3d origin = Vec3d::Zero();
  Vec3d u = Vec3d::UnitX();  ///< first in-plane unit axis
  Vec3d v = Vec3d::UnitY();  ///< second in-plane unit axis, orthogonal to u

  [[nodiscard]] Vec3d normal() const { return u.cross(v); }
  [[nodiscard]] Vec3d to_world(const Vec2d& p) const { return origin + u * p.x() + v * p.y(); }
  [[nodiscard]] Vec2d to_plane(const Vec3d& w) const {
    const Vec3d d = w - origin;
    return {d.dot(u), d.dot(v)};
  }
  /// Signed distance of `w` from the plane along normal(), mm.
  [[nodiscard]] double height(const Vec3d& w) const { return (w - origin).dot(normal()); }
  /// Whether u and v are unit and orthogonal within `tol`.
  [[nodiscard]] bool orthonormal(double tol = 1e-9) const {
    return std::abs(u.norm() - 1) <= tol && std::abs(v.norm() - 1) <= tol && std::abs(u.dot(v)) <= tol;
  }
};

/// A closed polyline drawn on a section, in-plane millimetres, closing edge implied.
struct SectionContour {
  std::vector<Vec2d> points;
  std::uint32_t label = 1;  ///< the object whose region it bounds (0 is never an object)
  bool hole = false;        ///< bounds a hole in `label`'s region (inside of it is outside the object)
};

/// One drawn section.
struct Section {
  PlanePose pose;
  /// Drawn polylines; per label, inside by even-odd nesting of its contours.
  std::vector<SectionContour> contours;
  /// Or a label image on the plane: pixel (i, j)'s centre lies at
  /// pose.to_world({i * pixel_size, j * pixel_size}); 0 is outside every object.
  Grid2u32 labels;
  double pixel_size = 0;  ///< mm per pixel of `labels` (0 without an image)
  std::string source;     ///< file and plane, for messages ("eight_15.csl, plane 3")

  [[nodiscard]] bool is_image() const { return !labels.empty(); }
};

}  // namespace isoloft
