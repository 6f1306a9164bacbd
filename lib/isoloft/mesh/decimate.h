// Mesh decimation with quadric error metrics (Garland & Heckbert 1997,
// "Surface Simplification Using Quadric Error Metrics"), paper 2.5: halfedge
// collapses of a vertex into a neighbour, cheapest quadric error first,
// allowed only if
//  - the link condition holds (the one-rings of the two vertices share only
//    the two opposite vertices; no tetrahedron collapse), so a closed
//    2-manifold stays one, of the same topology;
//  - no face normal turns by more than max_normal_deviation_deg in one
//    collapse: no fold-overs, no zero-area faces;
//  - every point of the original surface stays within max_error of the
//    decimated surface (original vertices exactly; points inside original
//    triangles up to kDecimateSurfaceSlack more): a real geometric bound on
//    the one-sided Hausdorff distance original -> decimated, in pixels.
// The bound (decimate_bound.h) keeps the original TRIANGLES, not vertices:
// each original triangle, or a piece of its midpoint subdivision, is held by
// one current face to which all its corners are within the bound; the
// distance to a triangle is convex, so then all its points are. A collapse
// must re-cover the pieces of the faces it changes (after OpenMesh's
// ModHausdorffT, which bounds only vertices: that let points on original
// edges drift ~0.1 px past max_error where a triangle spans a crease).
//
// decimate() is the fast path (flat arrays, no halfedge structure): rounds
// over the collapse candidates of the vertices whose neighbourhood changed,
// each round in increasing quadric error (bucketed to ~1 %), every candidate
// tested exactly and made at once if legal; vertices touched by a collapse
// wait for the next round. Pieces are stored as 16-byte keys (triangle,
// subdivision path; corners recomputed bit for bit when tested), each face's
// in pre-order, so sibling pieces merge back in one linear pass. Large
// meshes run first in z slabs concurrently (vertices next to another slab
// held), then the seams: the slab count depends on the mesh alone, so the
// output is the same for any thread count. detail::decimate_openmesh() is
// the strictly greedy reference on OpenMesh's Decimater (one heap), 3.3-7x
// slower (decimate_openmesh.cpp), kept as the test oracle: both obey the
// same bound and topology rules.
// Boundary vertices (open input) and vertices whose faces do not form one
// fan are never moved nor collapsed into in the fast path.
// Collapses move no vertex: the output vertices are a subset of the input's.
#pragma once

#include <cstddef>

#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// Numeric slack of the surface bound, pixels: pieces of original triangles
/// are split no finer than this (a point exactly at max_error would need
/// infinitely fine pieces), so points inside original triangles, not their
/// vertices, may end up this much farther than max_error. 1e-3 px: far below
/// any pixel-scale error, ~7 subdivision levels at most in practice.
inline constexpr double kDecimateSurfaceSlack = 1e-3;

struct DecimateParams {
  double max_error = 0.0;
  double max_normal_deviation_deg = 60.0;
};

template <>
inline const ParamTable<DecimateParams>& params_table<DecimateParams>() {
  static const ParamTable<DecimateParams> t({
      field("max_error", &DecimateParams::max_error, "px",
            "quadric decimation (paper 2.5) keeping every point of the surface within this of the result; 0 = off",
            at_least(0))
          .cli("--decimate-error"),
      field("max_normal_deviation_deg", &DecimateParams::max_normal_deviation_deg, "deg",
            "largest turn of a face normal in one collapse (no fold-overs)", open_between(0, 90)),
  });
  return t;
}

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
///        triangle repeats a vertex, or one of its edges is already used in
///        the same direction (an edge of three triangles, or a flipped one).
DecimateResult decimate(TriMesh& mesh, const DecimateParams& params);

namespace detail {
/// decimate() with a given number of z slabs decimated concurrently before
/// the seams (decimate() picks it from the triangle count; tests force it).
DecimateResult decimate_in_slabs(TriMesh& mesh, const DecimateParams& params, std::size_t slabs);
}  // namespace detail

}  // namespace isoloft
