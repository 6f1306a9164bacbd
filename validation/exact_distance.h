// @file validation/exact_distance.h
// @brief Exact-distance oracle for 2D signed distance fields (paper 2.2).
// From every pixel centre to closed polygons or zero-set segments: squared
// distances in CGAL's Epeck kernel, inside by CGAL::bounded_side_2 (even-odd);
// only the final square root rounds (<= 2 ulp). Candidates from a bucket grid
// with a rounding margin; the brute-force twin must agree bit for bit. Pixel
// (i, j) is (x0 + i, y0 + j). Sign convention: positive inside. CGAL-free header.
#pragma once

#include <array>
#include <functional>
#include <limits>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/slice_stack.h"

namespace isoloft {

/// As field/narrow_band.h's Segment2d.
using Segment2d = std::array<Vec2d, 2>;

/// Value of pixels farther than `band` from every segment (skipped by compare_field()).
inline constexpr double kOutsideBand = std::numeric_limits<double>::quiet_NaN();

struct FieldErrorReport {
  double max_abs_error = 0;   ///< max |field - exact| over checked pixels, px
  double mean_abs_error = 0;  ///< mean |field - exact| over checked pixels, px
  int worst_x = -1, worst_y = -1;  ///< pixel of max_abs_error (-1 if none checked)
  double worst_field = 0, worst_exact = 0;  ///< the two values at the worst pixel
  long sign_errors = 0;  ///< pixels where field and exact distance have strictly opposite signs
  int first_sign_error_x = -1, first_sign_error_y = -1;  ///< first such pixel in row-major order
  long pixels_checked = 0;  ///< pixels with |exact| <= band
};

/// Exact signed distance to closed polygons (> 0 inside an odd number, 0 on an edge).
/// \pre every polygon is simple; they may nest or be disjoint.
/// \throw ParamError if width or height < 0, band < 0 or NaN, x0/y0 not finite;
///        InputError for a polygon of < 3 vertices or a non-finite vertex.
Grid2d exact_signed_distance(const std::vector<Polygon>& polygons, int width, int height, double x0 = 0,
                             double y0 = 0, double band = std::numeric_limits<double>::infinity());

/// Exact signed distance to unordered segments, the sign from `inside` (its size).
/// \throw as above; InputError for a non-finite end point.
/// @warning No segments: +-infinity everywhere, by `inside`.
Grid2d exact_signed_distance(const std::vector<Segment2d>& segments, const Grid2u8& inside, double x0 = 0,
                             double y0 = 0, double band = std::numeric_limits<double>::infinity());

/// A computed field (positive inside) against the exact one where |d| <= band.
/// \throw as exact_signed_distance(); InputError if the field holds NaN.
FieldErrorReport compare_field(const Grid2f& field, const std::vector<Polygon>& polygons, double x0 = 0,
                               double y0 = 0, double band = std::numeric_limits<double>::infinity());

/// The same against segments and `inside`. \throw ParamError on a size mismatch.
FieldErrorReport compare_field(const Grid2f& field, const std::vector<Segment2d>& segments, const Grid2u8& inside,
                               double x0 = 0, double y0 = 0,
                               double band = std::numeric_limits<double>::infinity());

/// Two grids, skipping NaN (kOutsideBand) exact pixels; CGAL-free.
/// \throw ParamError if sizes differ; InputError for a NaN field pixel checked.
FieldErrorReport compare_grids(const Grid2f& field, const Grid2d& exact);

/// The zero set of sampled f (positive inside) as closed polygons, by marching
/// squares (saddles by refine(centre), else the mean of the four samples);
/// with refine, vertices bisected onto its zero (~1e-15 px) where signs agree.
/// \throw InputError if f holds NaN or the zero set leaves the grid (pad it).
/// @warning Loops collapsing to < 3 distinct points are dropped.
std::vector<Polygon> zero_set_polygons(const Grid2f& f, double x0 = 0, double y0 = 0,
                                       const std::function<double(const Vec2d&)>& refine = {});

/// Polygon edges as segments (closing edge included).
std::vector<Segment2d> polygon_segments(const std::vector<Polygon>& polygons);

namespace detail {

/// Exact unsigned distance via the bucket grid; kOutsideBand beyond band; +inf if no segments.
Grid2d exact_unsigned_distance(const std::vector<Segment2d>& segments, int width, int height, double x0, double y0,
                               double band);
/// Every segment exactly; must equal exact_unsigned_distance() bit for bit.
Grid2d exact_unsigned_distance_brute(const std::vector<Segment2d>& segments, int width, int height, double x0,
                                     double y0, double band);
/// Even-odd inside at pixel centres by bounded_side_2 (on an edge: outside).
Grid2u8 exact_inside(const std::vector<Polygon>& polygons, int width, int height, double x0, double y0);

}  // namespace detail
}  // namespace isoloft
