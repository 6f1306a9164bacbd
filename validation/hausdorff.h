// @file validation/hausdorff.h
// @brief Certified Hausdorff intervals: mesh vs mesh, mesh vs analytic shape.
// Mesh vs mesh: CGAL's bounded_error_Hausdorff_distance (Sebastian et al.)
// intersected with sampling: sub-triangles of side <= spacing, d_i a centroid's
// distance to the other mesh, max d_i <= H <= max (d_i + r_i), r_i its farthest
// corner. Mesh vs shape: those samples against Shape::distance, and voxel
// centres of side h near the surface projected by closest_point: H in [max,
// max + sqrt(3) h] (rigorous if exact()). Pixel units; split as eval/metrics.h.
// @warning Samples are split by their z: at the seam only the union of the two
// regions carries the guarantee. Header CGAL-free; CGAL in hausdorff.cpp.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

#include "isoloft/core/mesh.h"
#include "isoloft/synth/shapes.h"

namespace isoloft {

/// The true one-sided Hausdorff distance lies in [lower, upper], px.
struct HausdorffInterval {
  double lower = 0;
  double upper = 0;
  [[nodiscard]] nlohmann::json to_json() const { return {{"lower_px", lower}, {"upper_px", upper}}; }
};

struct MeshSamplingParams {
  /// Longest sub-triangle side, px (docs/decisions.md: sampling densities).
  double spacing = 0.5;
  /// Cap on samples per mesh; `spacing` grows to respect it.
  long max_samples = 2'000'000;
};

struct MeshDistanceReport {
  HausdorffInterval a_to_b, b_to_a;         ///< one-sided Hausdorff distances
  double cgal_a_to_b = 0, cgal_b_to_a = 0;  ///< raw bounded_error_Hausdorff_distance results
  double mean_a_to_b = 0, mean_b_to_a = 0;  ///< area-weighted mean distance, px
  double p99_a_to_b = 0, p99_b_to_a = 0;    ///< area-weighted 99th percentile, px
  long samples_a = 0, samples_b = 0;        ///< sub-triangle samples used
  [[nodiscard]] HausdorffInterval symmetric() const;  ///< two-sided Hausdorff distance
  [[nodiscard]] nlohmann::json to_json() const;
};

/// Two-sided mesh comparison; error_bound is CGAL's bound on |R - H| (> 0).
/// Meshes need not be closed or manifold.
/// \throw InputError if a mesh has no triangles, a non-finite vertex or a bad
///        index; ParamError if error_bound or a sampling parameter is not positive.
MeshDistanceReport mesh_distance(const TriMesh& a, const TriMesh& b, double error_bound,
                                 const MeshSamplingParams& sampling = {});

enum class Verdict { Pass, Fail, Undecided };

/// Pass if upper <= threshold, Fail if lower > threshold, else Undecided
/// (tighten the error bound).
Verdict hausdorff_verdict(const HausdorffInterval& h, double threshold);

/// Distance from every point to the nearest point of the mesh's surface
/// (CGAL AABB tree, exact up to double rounding), in the mesh's units.
/// \throw InputError if the mesh has no triangles or a bad vertex/index.
std::vector<double> point_to_mesh_distances(const TriMesh& mesh, const std::vector<Vec3d>& points);
const char* to_string(Verdict v);

struct DirectedStats {
  double mean = 0;         ///< weighted mean distance, px
  double p99 = 0;          ///< weighted 99th percentile, px
  HausdorffInterval max;   ///< the true maximum lies in it (see file comment)
  double weight = 0;       ///< mesh side: sampled area, px^2; truth side: number of samples
  long samples = 0;
  [[nodiscard]] nlohmann::json to_json() const;
};

struct TruthRegionStats {
  DirectedStats mesh_to_truth;  ///< from the mesh's sub-triangle samples
  DirectedStats truth_to_mesh;  ///< from the projected grid samples of the true surface
  double mean_normal_angle_deg = 0;  ///< area-weighted angle, face normal vs true normal at the foot
  [[nodiscard]] nlohmann::json to_json() const;
};

struct TruthDistanceParams {
  MeshSamplingParams mesh;  ///< sub-triangle sampling of the mesh
  /// Voxel side h of the truth sampling, px.
  double truth_spacing = 0.25;
  /// Cap on truth samples; h doubles to respect it.
  long max_truth_samples = 2'000'000;
};

struct TruthDistanceReport {
  TruthRegionStats in_range;  ///< samples with z in [z_first, z_last]
  TruthRegionStats caps;      ///< samples beyond the first or last slice
  HausdorffInterval hausdorff;  ///< two-sided, both regions
  double truth_spacing = 0;     ///< h actually used, px
  [[nodiscard]] nlohmann::json to_json() const;
};

/// Two-sided accuracy of a mesh against its analytic shape (same coordinates).
/// \throw InputError if the mesh has no triangles, a non-finite vertex or a
///        bad index; ParamError for a non-positive spacing or cap, z_first > z_last.
TruthDistanceReport mesh_to_truth(const TriMesh& mesh, const Shape& truth, double z_first, double z_last,
                                  const TruthDistanceParams& params = {});

namespace detail {

/// Per triangle ceil(longest edge / spacing)^2 congruent sub-triangles, plus
/// every vertex (weight and radius 0: they sharpen the lower bounds).
struct MeshSamples {
  std::vector<Vec3d> points;    ///< sub-triangle centroids, then vertices
  std::vector<double> weights;  ///< area of the sub-triangle, px^2 (0 for vertices)
  std::vector<double> radius;   ///< max distance from the point to its sub-triangle's corners
  std::vector<int> face;        ///< triangle index (-1 for vertices)
  double spacing = 0;           ///< spacing actually used
};
MeshSamples sample_mesh(const TriMesh& mesh, double spacing, long max_samples);

/// Brute-force twin of one direction of mesh_distance (no tree).
HausdorffInterval hausdorff_naive(const TriMesh& a, const TriMesh& b, double spacing);

/// Surface samples by hierarchical voxels, each surface point within sqrt(3) h
/// of one; h in: wanted side, out: the side used.
std::vector<Vec3d> sample_shape_surface(const Shape& shape, double& h, long max_samples);

/// {mean, weighted 99th percentile}; all-zero weights count equally.
std::pair<double, double> weighted_mean_p99(const std::vector<double>& values, const std::vector<double>& weights);

}  // namespace detail
}  // namespace isoloft
