// @file contour/rasterize.h
// @brief Polygons (polyline input) to contour pixels and inside pixels.
// Contour: a DDA over each edge's real endpoints (Bresenham generalised), a
// closed 8-curve per polygon; inside: the even-odd rule at pixel centres,
// plus the contour pixels.
// @warning Polygons closer than ~3 px merge in the contour, whose fill then
// differs from `inside`: use `inside` (docs/decisions.md: polygon inside).
#pragma once

#include <array>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// Rasterises closed polygons (pixel units) onto a width x height grid.
/// \throw ParamError on a negative size; InputError (no file name) naming a
///        non-finite vertex.
/// @warning Pixels beyond the grid are dropped: a polygon crossing the border
/// gives an open curve there.
/// @warning 0, 1 or 2 vertices give nothing, a pixel, a segment (no inside).
void rasterize_polygons(const std::vector<Polygon>& polys, int width, int height, Grid2u8& contour,
                        Grid2u8& inside);

/// The even-odd rule at pixel centres alone (rasterize_polygons' inside
/// also holds every contour pixel, whose centre may lie outside).
/// \throw as rasterize_polygons.
Grid2u8 even_odd_inside(const std::vector<Polygon>& polys, int width, int height);

/// Centres of the non-zero pixels, row-major.
std::vector<Vec2d> contour_points(const Grid2u8& contour);

namespace detail {

/// The in-grid pixels the DDA marks for p -> q, in order, without repeats.
std::vector<std::array<int, 2>> segment_pixels(const Vec2d& p, const Vec2d& q, int width, int height);

}  // namespace detail
}  // namespace isoloft
