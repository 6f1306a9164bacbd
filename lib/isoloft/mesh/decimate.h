// Mesh decimation with quadric error metrics (Garland & Heckbert 1997,
// "Surface Simplification Using Quadric Error Metrics"), paper 2.5, on
// OpenMesh's decimation framework (BaseDecimaterT and its modules, with our
// own loop): halfedge collapses of a vertex into a neighbour, cheapest
// quadric error first, allowed only if
//  - the link condition holds (OpenMesh's is_collapse_ok test, no
//    tetrahedron collapse), so a closed 2-manifold stays one, of the same
//    topology;
//  - no face normal turns by more than max_normal_deviation_deg in one
//    collapse (ModNormalFlippingT): no fold-overs, no zero-area faces;
//  - every point of the original surface stays within max_error of the
//    decimated surface (original vertices exactly; points inside original
//    triangles up to kDecimateSurfaceSlack more): a real geometric bound on
//    the one-sided Hausdorff distance original -> decimated, in pixels.
// The bound follows OpenMesh's ModHausdorffT (each removed vertex is kept in
// the list of its nearest face and re-tested whenever that face changes) but
// lives in our own module (decimate.cpp), merged with the quadric priority:
//  - It keeps the original TRIANGLES, not vertices: bounding only the
//    vertices let points on original edges drift up to ~0.2 px past
//    max_error where a triangle spans a crease of the result (torus at
//    0.25 px: 0.34 px). Each original triangle, or a piece of its midpoint
//    subdivision, is kept with one face to which all its corners are within
//    the bound; the distance to a triangle is convex, so then all its points
//    are. Pieces spanning a crease are split until one face covers each.
//  - ModHausdorffT hands points to faces around v1 whose vertices the
//    Decimater does not re-queue, so a cached "legal" verdict can go stale,
//    and it counts any zero-area face as within tolerance (by inspection of
//    OpenMesh 9). Ours hands pieces only to the faces that were around v0
//    and measures zero-area faces properly.
//  - The bound is tested lazily, only for the collapse at the front of the
//    heap (the order is unchanged: a failed test only raises that vertex's
//    key): ~1/8 of the tests DecimaterT would make.
// Collapses move no vertex: the output vertices are a subset of the input's.
#pragma once

#include "isoloft/core/mesh.h"

namespace isoloft {

/// Numeric slack of the surface bound, pixels: pieces of original triangles
/// are split no finer than this (a point exactly at max_error would need
/// infinitely fine pieces), so points inside original triangles, not their
/// vertices, may end up this much farther than max_error. 1e-3 px: far below
/// any pixel-scale error, ~7 subdivision levels at most in practice.
inline constexpr double kDecimateSurfaceSlack = 1e-3;

struct DecimateParams {
  /// paper 2.5 (Garland & Heckbert 1997 quadric decimation, bounded): largest
  /// distance (pixels) from any point of the original surface to the
  /// decimated one (+ kDecimateSurfaceSlack inside original triangles);
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
