// @file mesh/stream_mesher.h
// @brief The z-interpolated field (paper 2.4) streamed plane by plane into
// Marching Cubes (paper 2.5), visiting only the cells that may hold the surface.
//
// The field is a ZInterpolator over the slice fields (with their end caps).
// Each sampled plane is padded by one pixel of `outside` on every side, so a
// surface cut by the crop border closes within one pixel beyond it, handed to
// the streaming MarchingCubes builder and dropped: memory O(width x height)
// beyond the interpolator's slices.
//
// Cell skipping, the contract of this unit: a spline kind that stays between
// its knot values over every knot interval (monotone, linear:
// ZInterpolator::sides()) tells per pixel the side of iso the field keeps over
// an interval when both knots lie beyond iso by more than kSideMargin. A cell
// of the layer between two planes is skipped when its four corners keep one
// known side, the same over both planes' intervals (layer_cells_to_visit); the
// pad has `outside`'s side. Such a cell cannot hold the surface, so the mesh
// is bit for bit the one Marching Cubes gives on every cell
// (MeshOptions::skip_cells = false; tested against it).
//
// Sign convention: positive inside; a sample is inside iff value > iso.
// @warning Layers whose planes lie more than one knot interval apart (slices
// denser than the plane step) visit every cell.
// @warning Catmull-Rom and natural splines overshoot their knots: they know no
// sides, and every cell is visited.
#pragma once

#include <functional>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/interp/spline.h"
#include "isoloft/mesh/marching_cubes.h"

namespace isoloft {

/// A pixel keeps one side of iso over a knot interval only if both knot
/// values are this far beyond it (pixels): floats near 500 px are 6e-5 px
/// apart, so the few roundings of a spline value (float knots and tangents,
/// the float result) stay far below it; and it is far below a pixel.
inline constexpr float kSideMargin = 1e-2f;

/// Called with every padded plane (origin x0, y0 of its pixel (0, 0)), its
/// z, index and the plane count, e.g. to write the interpolated volume.
using PlaneCallback = std::function<void(const Grid2f& plane, double x0, double y0, double z, int index, int count)>;

struct StreamMeshOptions {
  float outside = -1.0f;  ///< value of the one-pixel pad (must be outside: <= iso)
  bool skip_cells = true;  ///< false: visit every cell (the oracle of the skipping)
  PlaneCallback on_plane;  ///< optional
  std::function<void(long done, long total)> progress;  ///< optional, once per plane
};

struct StreamMeshResult {
  TriMesh mesh;                ///< closed and oriented wherever the pad is outside
  double interp_seconds = 0;   ///< wall time evaluating the spline
  double mesh_seconds = 0;     ///< wall time in Marching Cubes
  long cells = 0;              ///< cells of all layers
  long cells_visited = 0;      ///< of those, the ones Marching Cubes looked at
};

/// Marching Cubes of `field` on the planes z = `planes` (increasing, within
/// the field's z range); field pixel (i, j) is at (x0 + i, y0 + j).
/// \throw ParamError if planes has fewer than 2 entries, is not increasing,
///        or `outside` is not below mc.iso.
StreamMeshResult mesh_interpolated_field(const ZInterpolator& field, const std::vector<double>& planes, double x0,
                                         double y0, const MarchingCubesParams& mc, const StreamMeshOptions& options = {});

/// Sample positions of the planes between the cap slices z_begin and z_end:
/// z_begin + j * step, the last one moved onto z_end exactly when it would
/// fall short (the cap slices bound the volume).
/// \throw ParamError if step <= 0 or z_end <= z_begin.
std::vector<double> sample_planes(double z_begin, double z_end, double step);

}  // namespace isoloft
