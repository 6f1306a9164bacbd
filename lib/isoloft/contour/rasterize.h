// Polygons (polyline input) to contour pixels and inside pixels.
//
// Contour: every edge is scan-converted by a DDA over its real-valued
// endpoints (cf. Bresenham 1965, generalised to non-integer endpoints): the
// pixels of both endpoints, plus, for every integer column (row, if the edge
// is steeper than 45 degrees) the edge spans, the pixel whose centre is
// nearest to the edge along that column. Consecutive pixels are 8-adjacent
// and consecutive edges share their vertex pixel, so each polygon becomes a
// closed 8-connected curve. If an edge crosses the segment between two
// 4-adjacent pixel centres, one of the two is marked, so the curve separates
// the 4-connected background exactly where the polygon does, and
// fill_even_odd of the contour agrees with `inside` while distinct polygons
// stay more than ~3 px apart and notches are wider than that (closer curves
// merge, and can enclose an outside pocket that the fill then calls inside);
// prefer `inside` from here over re-filling the contour.
//
// Inside: the even-odd rule (crossing number, as in point-in-polygon tests)
// of all polygons together, evaluated exactly at pixel centres by scanlines,
// OR-ed with the contour pixels.
#pragma once

#include <array>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// Rasterises closed polygons (vertices in pixel units, closing edge
/// implied) onto a width x height grid. Pixels outside the grid are dropped,
/// so a polygon crossing the border gives an open curve there.
/// Degenerate polygons are allowed: no vertex = nothing, one vertex = one
/// pixel, two = a segment (no area).
/// \pre width >= 0, height >= 0, all vertices finite.
/// \throw ParamError on a negative size.
/// \throw InputError (empty file name; the caller prefixes the slice file)
///        naming the polygon and vertex if a coordinate is not finite.
void rasterize_polygons(const std::vector<Polygon>& polys, int width, int height, Grid2u8& contour,
                        Grid2u8& inside);

/// Pixel centres (x = column, y = row) of the non-zero pixels, row-major.
std::vector<Vec2d> contour_points(const Grid2u8& contour);

namespace detail {

/// The pixels the DDA marks for the segment p -> q, in order from p's pixel
/// to q's, consecutive duplicates removed, restricted to [0,width) x
/// [0,height).
std::vector<std::array<int, 2>> segment_pixels(const Vec2d& p, const Vec2d& q, int width, int height);

}  // namespace detail
}  // namespace isoloft
