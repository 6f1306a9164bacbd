// @file eval/point_mesh.h
// @brief Distances from points to a triangle mesh: how far an input's own
// contour vertices lie from the surface made of them (the geometric error
// of a working grid, docs/decisions.md: RT grid). Exact point-triangle
// distances: the triangles offered to the points near them (hashed by plane
// and cell), then, for points farther off, a uniform grid of the triangles.
// Units: the mesh's.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "isoloft/core/mesh.h"

namespace isoloft {

/// Distance from each point to the nearest triangle of `mesh`; +inf for every
/// point if the mesh has no triangle.
std::vector<double> point_mesh_distances(const TriMesh& mesh, const std::vector<Vec3d>& points);

/// Mean, 95th percentile and maximum of distances.
struct DistanceSummary {
  long count = 0;
  double mean = 0, p95 = 0, max = 0;
  [[nodiscard]] nlohmann::json to_json(double scale = 1.0) const;
};
DistanceSummary summarize_distances(std::vector<double> d);

}  // namespace isoloft
