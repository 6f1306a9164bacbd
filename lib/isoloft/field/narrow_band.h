// @file field/narrow_band.h
// @brief Exact signed distance to an implicit curve's zero set near it (paper 2.2).
// The zero set by marching squares (saddles by f at the cell centre), vertices
// refined on f (Illinois regula falsi), optionally segments split onto f = 0;
// pixels within band_width get the exact distance to the nearest segment, not
// |f| / |grad f| (docs/decisions.md: exact distances in a band). Sign
// convention: positive where the sample of f > 0. Units: pixels.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// An implicit curve, positive inside, at a point in pixel units.
using ImplicitFn = std::function<double(const Vec2d&)>;

using Segment2d = std::array<Vec2d, 2>;

struct NarrowBandParams {
  double band_width = 4.0;
  int refine_iterations = 8;
  int segment_splits = 1;
};

/// Most regula-falsi steps and pieces per segment accepted.
inline constexpr int kMaxRefineIterations = 64, kMaxSegmentSplits = 64;

template <>
inline const ParamTable<NarrowBandParams>& params_table<NarrowBandParams>() {
  static const ParamTable<NarrowBandParams> t({
      field("band_width", &NarrowBandParams::band_width, "px",
            "half-width of the band of exact distances to the curve (paper 2.2); >= sqrt(2): every crossed cell's corners",
            at_least(1.4142135623730951)),
      field("refine_iterations", &NarrowBandParams::refine_iterations, "steps",
            "Illinois regula-falsi steps placing each cell-edge vertex on the curve", between(0, kMaxRefineIterations)),
      field("segment_splits", &NarrowBandParams::segment_splits, "pieces",
            "pieces per cell segment, interior points projected onto the curve (1 = straight chords)",
            between(1, kMaxSegmentSplits)),
  });
  return t;
}

struct NarrowBandResult {
  /// Signed distance where `known`, elsewhere +-kNoSurfaceDistance (sign only).
  Grid2f distance;
  Grid2u8 known;   ///< 1 where the distance to the nearest segment is <= band_width
  Grid2u8 inside;  ///< 1 where the sample of f is > 0 (the sign of every pixel)
  Grid2i nearest_segment;  ///< index into `segments` of the nearest one where `known`, else -1
  std::vector<Segment2d> segments;  ///< zero-set pieces, one or more per crossed cell (unordered)
  /// links[k][e]: the segment at end e of segment k; -1 where the curve leaves the grid.
  std::vector<std::array<std::int32_t, 2>> links;
};

/// Narrow-band signed distance to the zero set of f, sampled at every pixel
/// centre (f_samples); f itself (calling thread only; may be empty) refines
/// vertices and resolves saddles.
/// \throw InputError if f_samples is empty or holds NaN; ParamError for a
///        parameter out of range.
/// @warning Where f disagrees in sign with a sample, the edge keeps the linear vertex.
/// @warning No zero crossing: no segment, no known pixel, +-kNoSurfaceDistance.
NarrowBandResult narrow_band_distance(const Grid2f& f_samples, const ImplicitFn& f,
                                      const NarrowBandParams& params = {});

/// Narrow-band signed distance to drawn polygons (pixel units, closed, even-odd):
/// their edges are the zero set, exactly; `inside` (the even-odd rule at pixel
/// centres, contour/rasterize.h even_odd_inside) signs every pixel. Zero-length edges are
/// dropped; links follow each polygon around.
/// \throw InputError if inside is empty; ParamError for a parameter out of range.
/// @warning A polygon of fewer than 2 distinct vertices adds no segment.
NarrowBandResult polygon_narrow_band(const std::vector<Polygon>& polygons, const Grid2u8& inside,
                                     const NarrowBandParams& params = {});

namespace detail {
/// The band of r.segments over r.inside's grid: known, nearest_segment, distance.
void fill_band(NarrowBandResult& r, double band_width);

/// Nearest point of [a, b] to p (a == b allowed).
Vec2d closest_point_on_segment(const Vec2d& p, const Vec2d& a, const Vec2d& b);

/// Zero on pa -> pb (one sample > 0, one <= 0): linear, then Illinois steps on f.
Vec2d edge_zero(const Vec2d& pa, double fa, const Vec2d& pb, double fb, const ImplicitFn& f, int iterations);

/// Marching-squares zero set of the samples, with its segment links.
struct ZeroSet {
  std::vector<Segment2d> segments;
  std::vector<std::array<std::int32_t, 2>> links;
};
ZeroSet marching_squares(const Grid2f& f_samples, const ImplicitFn& f, int refine_iterations, int segment_splits);

/// Brute-force twin: distance to the nearest segment (+inf if none).
Grid2d distance_to_segments_brute(const std::vector<Segment2d>& segments, int width, int height);

}  // namespace detail
}  // namespace isoloft
