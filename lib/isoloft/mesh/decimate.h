// Mesh decimation with quadric error metrics (Garland & Heckbert 1997,
// "Surface Simplification Using Quadric Error Metrics"), paper 2.5, on
// OpenMesh's DecimaterT: halfedge collapses of a vertex into a neighbour,
// cheapest quadric error first, allowed only if
//  - the link condition holds (OpenMesh's is_collapse_ok test, no
//    tetrahedron collapse), so a closed 2-manifold stays one, of the same
//    topology;
//  - no face normal turns by more than max_normal_deviation_deg in one
//    collapse (ModNormalFlippingT): no fold-overs, no zero-area faces;
//  - every original vertex stays within max_error of the decimated surface:
//    a real geometric bound (one-sided Hausdorff distance from the original
//    vertices), in pixels.
// The bound follows OpenMesh's ModHausdorffT (each removed vertex is kept in
// the list of its nearest face and re-tested whenever that face changes) but
// lives in our own module (decimate.cpp), merged with the quadric priority:
//  - ModHausdorffT hands points to faces around v1 whose vertices the
//    Decimater does not re-queue, so a cached "legal" verdict can go stale,
//    and it counts any zero-area face as within tolerance (by inspection of
//    OpenMesh 9; not observed in our tests). Ours hands points only to the
//    faces that were around v0 and measures zero-area faces properly.
//  - The bound test runs only for candidates whose quadric error can still
//    win, ~1.2-1.6x faster than ModQuadricT + ModHausdorffT.
// Collapses move no vertex: the output vertices are a subset of the input's.
#pragma once

#include "isoloft/core/mesh.h"

namespace isoloft {

struct DecimateParams {
  /// paper 2.5 (Garland & Heckbert 1997 quadric decimation, bounded): largest
  /// distance (pixels) from any original vertex to the decimated surface;
  /// 0 = no decimation.
  double max_error = 0.0;
  /// Largest rotation (degrees) of any face normal in one collapse
  /// (OpenMesh ModNormalFlippingT); in (0, 90) so that collapses creating
  /// flipped or zero-area faces are always rejected.
  double max_normal_deviation_deg = 60.0;
};

struct DecimateResult {
  long triangles_before = 0;
  long triangles_after = 0;
};

/// Decimates `mesh` in place; vertices not used by any triangle are kept.
/// \pre mesh is a consistently oriented 2-manifold, possibly with boundary
///      (e.g. Marching Cubes output); a closed one stays closed.
/// \throw ParamError if max_error is negative or not finite, or
///        max_normal_deviation_deg is not in (0, 90).
/// \throw InputError naming the triangle if an index is out of range, a
///        triangle repeats a vertex, or OpenMesh cannot add it (its edge is
///        already used twice or in the same direction).
DecimateResult decimate(TriMesh& mesh, const DecimateParams& params);

}  // namespace isoloft
