// @file eval/metrics.h
// @brief Accuracy of a mesh against an analytic shape (pixel units).
// Mesh -> truth distances at triangle centroids and vertices, area-weighted,
// and normal angles, in the slice range and in the end caps. Two-sided and
// bounded-error Hausdorff distances: validation/ (CGAL).
#pragma once

#include <nlohmann/json.hpp>

#include "isoloft/core/mesh.h"
#include "isoloft/synth/shapes.h"

namespace isoloft {

struct SurfaceStats {
  double area = 0;             ///< px^2
  double mean_distance = 0;    ///< area-weighted mean of |distance| at centroids, px
  double rms_distance = 0;     ///< px
  double p99_distance = 0;     ///< 99th percentile (area-weighted) at centroids, px
  double max_distance = 0;     ///< max over vertices and centroids, px
  double mean_normal_angle_deg = 0;  ///< area-weighted mean angle, face normal vs true normal
  long triangles = 0;
  [[nodiscard]] nlohmann::json to_json() const;
};

struct MeshToShapeStats {
  SurfaceStats in_range;  ///< centroid z in [z_first, z_last]
  SurfaceStats caps;      ///< beyond the first or last slice
  [[nodiscard]] nlohmann::json to_json() const;
};

/// \pre the mesh is in the shape's coordinates (pixel units).
/// @warning A region without triangles reports zeros.
MeshToShapeStats mesh_to_shape_stats(const TriMesh& mesh, const Shape& shape, double z_first, double z_last);

}  // namespace isoloft
