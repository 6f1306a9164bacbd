// @file mesh/decimate.h
// @brief Bounded quadric-error decimation (paper 2.5; Garland & Heckbert 1997).
// Halfedge collapses in quadric order, legal only if the link condition holds,
// no face normal turns by more than max_normal_deviation_deg, and every point
// of the original surface stays within max_error of the result (each original
// triangle or piece of it held by a covering face: mesh/decimate_bound.h;
// docs/decisions.md: decimation bound). With min_angle_deg, faces left below
// it are then flipped, collapsed, or lifted by moving a vertex (an edge
// collapsed into a point near it, a cap's apex moved towards its long edge, a
// corner relaxed), each under the same bound, and later collapses make no new
// one (no guarantee: a few stay). Large meshes run first in z slabs
// concurrently; the output is the same for any thread count. Output vertices
// are input vertices, unless min_angle_deg moved them (rounded to float
// before they are measured against the bound).
// Reference: validation/decimate_openmesh.h. Units: pixels.
// @warning Boundary vertices, and vertices whose faces form several fans, are
// never moved nor collapsed into.
// @warning A mesh flat in z is decimated as one slab.
#pragma once

#include <cstddef>

#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// Slack of the bound inside original triangles, px (pieces are split no finer).
inline constexpr double kDecimateSurfaceSlack = 1e-3;

struct DecimateParams {
  double max_error = 0.0;
  double max_normal_deviation_deg = 60.0;
  double min_angle_deg = 0.0;
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
      field("min_angle_deg", &DecimateParams::min_angle_deg, "deg",
            "no collapse leaves a face with a smaller least angle unless it had one; faces still below it are "
            "flipped, collapsed or have a vertex moved where the bound allows (slivers); 0 = off",
            between(0, 30)),
  });
  return t;
}

struct DecimateResult {
  long triangles_before = 0;
  long triangles_after = 0;
  long flips = 0;             ///< edges flipped to lift slivers (min_angle_deg)
  long sliver_collapses = 0;  ///< slivers collapsed away (min_angle_deg)
  long sliver_moves = 0;      ///< slivers lifted by moving a vertex (min_angle_deg)
};

/// Decimates `mesh` in place (renumbered; unused vertices kept).
/// \pre a consistently oriented 2-manifold, maybe with boundary.
/// \throw ParamError for a parameter out of range; InputError naming the
///        triangle for an index out of range, a repeated vertex, or an edge
///        used twice in one direction.
/// @warning max_error = 0 or no triangles: unchanged.
DecimateResult decimate(TriMesh& mesh, const DecimateParams& params);

namespace detail {
/// decimate() with a given slab count (tests).
DecimateResult decimate_in_slabs(TriMesh& mesh, const DecimateParams& params, std::size_t slabs);
}  // namespace detail

}  // namespace isoloft
