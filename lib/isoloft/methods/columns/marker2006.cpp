// marker2006: the paper's method (Marker, Braude, Museth & Breen 2006):
// contour points and normals, the MPU curve (2.1), narrow-band distances and
// their extension (2.2), the distance-dependent filter (2.3); Hyman's
// monotone z spline (2.4), dome end caps (not in the paper).
#include "isoloft/methods/method.h"
#include "isoloft/methods/columns/slice_methods.h"
#include "isoloft/methods/params.h"

namespace isoloft {

namespace detail {

const std::vector<std::string>& curve_fit_rows() {
  static const std::vector<std::string> rows{
      "mask_edge_offset", "polyline_spacing", "polyline_raster_width", "sign_guard", "mpu_band", "mask_min_feature",
      "mask_boundary",    "polyline_boundary", "mask_curve.",      "normals.",              "mpu.",       "band.",    "extend.",
      "filter."};
  return rows;
}

void paper_interp_defaults(ReconstructParams& p) {
  p.interp.spline = InterpParams{}.spline;
  p.interp.cap_shape = InterpParams{}.cap_shape;
  p.interp.planes_on_slices = InterpParams{}.planes_on_slices;
}

}  // namespace detail

MethodSpec marker2006_method() {
  return {
      .name = "marker2006",
      .doc = "the paper (Marker et al. 2006): MPU curve, distance extension, filter, Hyman's monotone z spline",
      .defaults =
          [](ReconstructParams& p) {
            detail::paper_interp_defaults(p);
            p.mask_boundary = MaskBoundary::PixelCentres;
            p.polyline_boundary = PolylineBoundary::Fit;
          },
      .rows = detail::curve_fit_rows(),
      .fits_curves = true,
      .slice_field = detail::curve_slice,
  };
}

}  // namespace isoloft
