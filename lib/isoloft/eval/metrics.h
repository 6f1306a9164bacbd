// Accuracy of a mesh against an analytic shape (pixel units): distances from
// the mesh to the true surface and angles between mesh and true normals,
// split into the slice range and the end caps (beyond the first/last slice,
// where the surface is extrapolated by the cap rule, interp/spline.h).
//
// Mesh -> truth only, sampled at triangle centroids and vertices, weighted by
// area. The two-sided and bounded-error Hausdorff distances, which need a
// spatial index over the mesh, live in validation/ (CGAL).
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
MeshToShapeStats mesh_to_shape_stats(const TriMesh& mesh, const Shape& shape, double z_first, double z_last);

}  // namespace isoloft
