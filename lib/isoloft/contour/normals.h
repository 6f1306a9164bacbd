// @file contour/normals.h
// @brief Contour points with outward unit normals (paper 2.1), the MPU input.
// Images: a point per contour pixel centre, the normal minus the normalised
// gradient of the Gaussian-smoothed filled mask (docs/decisions.md: normals).
// Polygons: edge samples, normals out of the even-odd fill of all polygons.
#pragma once

#include <cstddef>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// Largest sigma accepted, px.
inline constexpr double kMaxNormalsSigma = 64.0;

struct NormalsParams {
  double sigma = 1.5;
};

template <>
inline const ParamTable<NormalsParams>& params_table<NormalsParams>() {
  static const ParamTable<NormalsParams> t({
      field("sigma", &NormalsParams::sigma, "px",
            "Gaussian on the filled mask whose gradient gives the contour normals (paper 2.1)",
            Range{0.0, kMaxNormalsSigma, true, false}),
  });
  return t;
}

struct OrientedPoints {
  std::vector<Vec2d> points;
  std::vector<Vec2d> normals;  ///< unit length, pointing out of the filled region
  /// Samples left out, their normal undefined.
  std::size_t dropped = 0;
  [[nodiscard]] std::size_t size() const { return points.size(); }
};

/// Contour pixels (non-zero) as points with normals, row-major.
/// \param filled_mask interior or contour (e.g. fill_even_odd().inside).
/// \throw ParamError if sigma is not in (0, kMaxNormalsSigma] or sizes differ.
/// @warning A pixel whose smoothed-mask gradient is ~0 (a one-pixel line or
/// island) is dropped.
OrientedPoints contour_normals(const Grid2u8& contour, const Grid2u8& filled_mask, const NormalsParams& params = {});

/// Samples along closed polygons: ceil(|b - a| / spacing) per edge from a.
/// \throw ParamError unless spacing is finite and > 0; InputError (no file
///        name) for a polygon of < 3 vertices, a non-finite one or zero area.
/// @warning A zero-length edge gives no samples; an edge covered twice none
/// (counted in `dropped`).
OrientedPoints polygon_points(const std::vector<Polygon>& polygons, double spacing = 0.5);

namespace detail {

/// Gradient at (x, y) of the Gaussian-smoothed mask.
Vec2d smoothed_mask_gradient(const Grid2u8& mask, int x, int y, double sigma);

/// Crossing-number parity of p for one polygon (Franklin's PNPOLY).
bool crossing_parity(const std::vector<Vec2d>& polygon, const Vec2d& p);

bool inside_even_odd(const std::vector<Polygon>& polygons, const Vec2d& p);

}  // namespace detail
}  // namespace isoloft
