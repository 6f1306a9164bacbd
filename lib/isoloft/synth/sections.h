// @file synth/sections.h
// @brief Drawn sections of an analytic shape on planes in any orientation:
// the synthetic kit of the field3d stage (issue 35). Units: the shape's, taken
// as millimetres. Each section is the shape's exact plane section, polygonised:
// the zero set of Shape::value on the plane, traced by marching squares on a
// raster of `pixel` mm over the shape's bounds and refined onto the surface.
#pragma once

#include <cstdint>
#include <vector>

#include "isoloft/core/section.h"
#include "isoloft/synth/shapes.h"

namespace isoloft {

/// The pose through `point` with unit normal along `normal` (u, v completed).
PlanePose pose_from_normal(const Vec3d& point, const Vec3d& normal);

/// `n` planes through points uniform in the middle 60 % of the shape's bounds,
/// normals uniform on the sphere; reproducible from `seed`.
std::vector<PlanePose> random_poses(const Shape& shape, int n, std::uint32_t seed);

/// Three orthogonal axis planes through the bounds' centre.
std::vector<PlanePose> orthogonal_poses(const Shape& shape);

/// `n` planes normal to z, evenly over the middle 80 % of the bounds' height.
std::vector<PlanePose> parallel_poses(const Shape& shape, int n);

/// One section per pose: closed loops of label 1 (even-odd nesting gives holes).
/// @warning A loop cut by the raster's edge is dropped; the raster covers the
/// bounds with a 2-pixel margin, so only a bounds() that is too small cuts one.
std::vector<Section> analytic_sections(const Shape& shape, const std::vector<PlanePose>& poses, double pixel);

}  // namespace isoloft
