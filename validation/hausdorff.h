// Hausdorff distances between triangle meshes, and between a mesh and an
// analytic shape, as certified intervals (pixel units).
//
// Mesh vs mesh: CGAL::Polygon_mesh_processing::bounded_error_Hausdorff_distance
// (CGAL 5.5; the bounded-error one-sided Hausdorff distance of Sebastian,
// Krivokuca, Bousquet, "Bounded-error one-sided Hausdorff distance for triangle
// meshes" -- returns a value R with |R - H| <= error_bound), intersected with
// a bound from dense sampling: with the first mesh cut into sub-triangles of
// side <= spacing, and d_i the distance of sub-triangle i's centroid to the
// other mesh (CGAL AABB tree), max_i d_i <= H <= max_i (d_i + r_i), r_i the
// sub-triangle's circumradius about its centroid (the distance to a surface
// is 1-Lipschitz). The samples also give area-weighted mean and 99th percentile.
//
// Mesh vs analytic shape (synth/shapes.h): mesh -> truth from the same
// sub-triangle samples and Shape::distance, max in [max d_i, max (d_i + r_i)];
// truth -> mesh from a sampling of the true surface: the centres of the
// voxels of side h that can hold a surface point (|value| <= (sqrt(3)/2) h,
// found coarse-to-fine from 4 px voxels), projected by Shape::closest_point.
// Every surface point is then within sqrt(3) h of a sample, so the true max
// lies in [sampled max, sampled max + sqrt(3) h] (rigorous for shapes with
// exact() == true; for the others closest_point is a gradient projection).
// The upper ends are guaranteed but loose (Lipschitz bounds: + r_i, + sqrt(3) h);
// the lower ends are the sampled maxima that eval/metrics.h-style reports
// quote. Both directions are split, like eval/metrics.h, into the slice range
// z in [z_first, z_last] and the end caps beyond, by the z of the sample (so
// only the union of the two regions carries the guarantee at the seam).
//
// Units: pixels. This header is CGAL-free; CGAL is confined to hausdorff.cpp.
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
  /// Longest side of the sub-triangles sampled on a mesh, px. 0.5 px: half a
  /// pixel resolves pixel-scale errors in the mean and p99, and bounds the
  /// sampling slack of the Hausdorff upper bound by r_i <= 0.29 px.
  double spacing = 0.5;
  /// Cap on the samples per mesh; `spacing` grows (for that mesh) to respect it,
  /// so a 1000^2-pixel reconstruction costs seconds, not minutes.
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

/// Two-sided mesh comparison (file comment).
/// \param error_bound CGAL's bound on |R - H|, px (> 0).
/// \pre triangle indices valid; meshes need not be closed or manifold
///      (non-manifold faces are added to CGAL's Surface_mesh as separate pieces).
/// \throw InputError if a mesh has no triangles, a non-finite vertex or a bad index.
/// \throw ParamError if error_bound <= 0 or a sampling parameter is not positive.
MeshDistanceReport mesh_distance(const TriMesh& a, const TriMesh& b, double error_bound,
                                 const MeshSamplingParams& sampling = {});

enum class Verdict { Pass, Fail, Undecided };

/// Pass if upper <= threshold, Fail if lower > threshold, else Undecided (the
/// interval straddles the threshold: tighten the error bound).
Verdict hausdorff_verdict(const HausdorffInterval& h, double threshold);
const char* to_string(Verdict v);

/// Distances in one direction within one region.
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
  /// Voxel side h of the truth sampling, px. 0.25 px: every surface point is
  /// within sqrt(3) h = 0.43 px of a sample, so a sub-pixel gap of the mesh is
  /// still seen, at ~sqrt(3) / h^2 = 28 samples per px^2 of surface.
  double truth_spacing = 0.25;
  /// Cap on the truth samples; h doubles (from truth_spacing) to respect it.
  long max_truth_samples = 2'000'000;
};

struct TruthDistanceReport {
  TruthRegionStats in_range;  ///< samples with z in [z_first, z_last]
  TruthRegionStats caps;      ///< samples beyond the first or last slice
  HausdorffInterval hausdorff;  ///< two-sided, both regions
  double truth_spacing = 0;     ///< h actually used, px
  [[nodiscard]] nlohmann::json to_json() const;
};

/// Two-sided accuracy of a mesh against the analytic shape it should
/// reconstruct (file comment).
/// \pre the mesh is in the shape's coordinates (pixel units).
/// \throw InputError if the mesh has no triangles, a non-finite vertex or a bad index.
/// \throw ParamError if a spacing or cap is not positive, or z_first > z_last.
TruthDistanceReport mesh_to_truth(const TriMesh& mesh, const Shape& truth, double z_first, double z_last,
                                  const TruthDistanceParams& params = {});

namespace detail {

/// Sub-triangle samples of a mesh (CGAL-free): per triangle n = ceil(longest
/// edge / spacing) subdivisions, n^2 congruent sub-triangles; plus every
/// vertex with weight 0 and radius 0 (they sharpen the lower bound of a max).
struct MeshSamples {
  std::vector<Vec3d> points;    ///< sub-triangle centroids, then vertices
  std::vector<double> weights;  ///< area of the sub-triangle, px^2 (0 for vertices)
  std::vector<double> radius;   ///< max distance from the point to its sub-triangle's corners
  std::vector<int> face;        ///< triangle index (-1 for vertices)
  double spacing = 0;           ///< spacing actually used
};
MeshSamples sample_mesh(const TriMesh& mesh, double spacing, long max_samples);

/// Naive twin of mesh_distance's one-sided bound (CGAL's naive test style):
/// the samples of `a` against every triangle of `b` by brute force
/// (CGAL::squared_distance, no tree): [max d_i, max (d_i + r_i)].
HausdorffInterval hausdorff_naive(const TriMesh& a, const TriMesh& b, double spacing);

/// Samples of the shape's surface by hierarchical voxels (file comment): on
/// return every surface point is within sqrt(3) h of a sample (exact shapes).
/// \param h in: wanted voxel side (px); out: the side used (doubled while the
///        next level would exceed max_samples).
std::vector<Vec3d> sample_shape_surface(const Shape& shape, double& h, long max_samples);

/// Weighted 99th percentile and mean of values (weights >= 0; all-zero
/// weights count equally). Returns {mean, p99}.
std::pair<double, double> weighted_mean_p99(const std::vector<double>& values, const std::vector<double>& weights);

}  // namespace detail
}  // namespace isoloft
