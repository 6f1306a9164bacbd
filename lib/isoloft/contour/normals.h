// Stage 1 (Marker, Braude, Museth, Breen 2006, paper 2.1): contour points and
// their outward unit normals, the input of the MPU curve fit (fit/mpu.h).
//
// Image input: every contour pixel becomes the point at its centre (pixel-centre
// convention, core/grid.h). Its normal follows the paper: the contour is filled
// (boundary and interior white), the filled mask is smoothed by a Gaussian, the
// gradient of the smoothed mask is taken at the contour pixel, normalised and
// negated so that it points outward. The Gaussian and its derivative are applied
// as one sampled derivative-of-Gaussian kernel (exact gradient of the smoothed,
// sampled mask), evaluated only at the contour pixels; beyond the image the mask
// is 0 (outside).
//
// Polygon input: dense samples along each edge, normals perpendicular to the
// edge, oriented outward with the even-odd rule over all polygons (a hole's
// normals point into the hole, an island's away from it).
#pragma once

#include <cstddef>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// Largest Gaussian of the normals, pixels: a (6 sigma + 1)^2 stencil per contour pixel.
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

/// Points with outward unit normals (pixel units, x = column, y = row).
struct OrientedPoints {
  std::vector<Vec2d> points;
  std::vector<Vec2d> normals;  ///< unit length, pointing out of the filled region
  /// Input samples left out because their normal is undefined: contour_normals:
  /// smoothed-mask gradient ~ 0 (e.g. a one-pixel line with no inside);
  /// polygon_points: samples of an edge that is no boundary of the even-odd
  /// fill (covered twice). Zero-length edges give no samples at all.
  std::size_t dropped = 0;
  [[nodiscard]] std::size_t size() const { return points.size(); }
};

/// Contour pixels as points with outward normals (paper 2.1).
/// \param contour non-zero = contour pixel.
/// \param filled_mask non-zero = interior or contour pixel (e.g.
///        fill_even_odd(contour).inside), same size as `contour`.
/// \return one point per contour pixel whose smoothed-mask gradient is not ~0,
///         in row-major order; the others are counted in `dropped`.
/// \pre params.sigma > 0
/// \throw ParamError if sigma <= 0 or not finite, or the two grids differ in size.
OrientedPoints contour_normals(const Grid2u8& contour, const Grid2u8& filled_mask, const NormalsParams& params = {});

/// Dense samples along closed polygons: each edge a -> b gives
/// ceil(|b - a| / spacing) equally spaced samples starting at a (so every
/// vertex is a sample), normal perpendicular to the edge and pointing to the
/// outside of the even-odd fill of all polygons.
/// \pre spacing > 0; every polygon has >= 3 vertices, all finite.
/// \throw ParamError if spacing <= 0 or not finite.
/// \throw InputError (empty file name; the caller prefixes the slice file) if a
///        polygon has fewer than 3 vertices, a non-finite vertex, or zero area.
OrientedPoints polygon_points(const std::vector<Polygon>& polygons, double spacing = 0.5);

namespace detail {

/// Gradient of the Gaussian-smoothed mask (values 0/1, 0 beyond the image) at
/// pixel (x, y), by the sampled derivative-of-Gaussian kernel (radius
/// ceil(3 sigma), smoothing weights normalised to sum 1).
Vec2d smoothed_mask_gradient(const Grid2u8& mask, int x, int y, double sigma);

/// Crossing-number parity of p for one closed polygon (W. R. Franklin's PNPOLY).
bool crossing_parity(const std::vector<Vec2d>& polygon, const Vec2d& p);

/// Even-odd point-in-polygons test: parity summed over all polygons.
bool inside_even_odd(const std::vector<Polygon>& polygons, const Vec2d& p);

}  // namespace detail
}  // namespace isoloft
