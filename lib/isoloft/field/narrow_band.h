// Stage 3a (paper 2.2): true signed distance to the zero set of an implicit
// curve f (positive inside), at the pixels of a narrow band around it.
//
// Method: the zero set is extracted per grid cell by marching squares (the 2D
// case of Lorensen & Cline 1987; cells join four pixel centres, saddles are
// resolved by f at the cell centre). Each cell-edge vertex starts at the
// linear interpolation of the two samples and, when f itself is given, is
// refined by safeguarded regula falsi (Illinois variant) on f along the edge,
// so it lies on f = 0 to ~1e-9 px. Optionally each cell segment is split and
// the split points are projected onto f = 0 by Newton steps. Every pixel
// within `band_width` of a segment then gets the exact Euclidean distance to
// the nearest segment (not |f| / |grad f|, which is only a first-order
// estimate and wrong for a non-distance f such as r^2 - |p - c|^2).
//
// Units: pixels of the working grid, pixel-centre convention (core/grid.h).
// Sign: positive inside (f > 0), negative outside (f <= 0).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// An implicit curve function, positive inside, evaluated at a point in pixel
/// units (x = column, y = row).
using ImplicitFn = std::function<double(const Vec2d&)>;

/// A piece of the extracted zero set, end points in pixel units.
using Segment2d = std::array<Vec2d, 2>;

struct NarrowBandParams {
  double band_width = 4.0;
  int refine_iterations = 8;
  int segment_splits = 1;
};

/// Most regula-falsi steps and pieces per cell segment accepted (each far past
/// where they change anything: 8 steps reach ~1e-9 px).
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
  /// Signed distance (positive inside) where `known`; elsewhere
  /// +-kNoSurfaceDistance (field/edt.h): only the sign is known there.
  Grid2f distance;
  Grid2u8 known;   ///< 1 where the distance to the nearest segment is <= band_width
  Grid2u8 inside;  ///< 1 where the sample of f is > 0 (the sign of every pixel)
  Grid2i nearest_segment;  ///< index into `segments` of the nearest one where `known`, else -1
  std::vector<Segment2d> segments;  ///< zero-set pieces, one or more per crossed cell (unordered)
  /// links[k][e]: the segment sharing end point e of segment k, -1 where the
  /// curve leaves the grid. Lets the extension walk along the curve.
  std::vector<std::array<std::int32_t, 2>> links;
};

/// Narrow-band signed distance to the zero set of f.
/// \param f_samples f at every pixel centre (positive inside).
/// \param f the same function as a callable, used to refine the vertices (and
///        to resolve saddle cells); may be empty: samples only, vertices by
///        linear interpolation.
/// \pre f_samples is non-empty and holds no NaN; f (if given) agrees with the
///      samples in sign at pixel centres (where it does not, the edge keeps the
///      linearly interpolated vertex). f is called from the calling thread
///      only: 2 + refine_iterations calls per crossed cell edge, one per saddle
///      cell, plus the Newton steps of segment_splits.
/// \return the band; if f has no zero crossing, no segment, no known pixel and
///         +-kNoSurfaceDistance everywhere.
/// \throw InputError if f_samples is empty or contains NaN.
/// \throw ParamError if band_width < sqrt(2), refine_iterations < 0 or
///        segment_splits < 1.
NarrowBandResult narrow_band_distance(const Grid2f& f_samples, const ImplicitFn& f,
                                      const NarrowBandParams& params = {});

namespace detail {

/// Nearest point of segment [a, b] to p (a == b allowed).
Vec2d closest_point_on_segment(const Vec2d& p, const Vec2d& a, const Vec2d& b);

/// Zero of f on the edge pa -> pb, whose samples fa, fb have opposite
/// classification (one > 0, the other <= 0). Linear interpolation of the
/// samples, then `iterations` Illinois steps on f when f is given and agrees.
Vec2d edge_zero(const Vec2d& pa, double fa, const Vec2d& pb, double fb, const ImplicitFn& f, int iterations);

/// Marching-squares zero set of the samples (vertices refined on f if given)
/// with the end-point links between its segments.
struct ZeroSet {
  std::vector<Segment2d> segments;
  std::vector<std::array<std::int32_t, 2>> links;
};
ZeroSet marching_squares(const Grid2f& f_samples, const ImplicitFn& f, int refine_iterations, int segment_splits);

/// O(pixels x segments) twin of the band: unsigned distance from every pixel
/// centre to the nearest of all segments (+infinity if there is none).
Grid2d distance_to_segments_brute(const std::vector<Segment2d>& segments, int width, int height);

}  // namespace detail
}  // namespace isoloft
