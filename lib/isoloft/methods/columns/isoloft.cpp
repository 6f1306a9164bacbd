// isoloft, the default method: marker2006 with the departures measured to do
// better (docs/decisions.md, "The isoloft method"), ReconstructParams{}'s own:
// masks and labels traced to their sub-pixel boundary (contour/mask_curve.h),
// polygons taken as drawn (field/narrow_band.h polygon_narrow_band),
// z planes through the slices, the extremum-preserving z spline (Dougherty,
// Edelman, Hyman 1989), slab end caps (docs/decisions.md, "End caps").
#include "isoloft/methods/method.h"
#include "isoloft/methods/columns/slice_methods.h"
#include "isoloft/methods/params.h"

namespace isoloft {

MethodSpec isoloft_method() {
  return {
      .name = "isoloft",
      .doc = "marker2006 with the departures measured to do better (docs/decisions.md): masks traced to their sub-pixel boundary, polygons as drawn, planes through the slices, the extremum-preserving z spline, slab end caps",
      .defaults = [](ReconstructParams&) {},  // ReconstructParams{} holds the default method's values
      .rows = detail::curve_fit_rows(),
      .fits_curves = true,
      .slice_field = detail::curve_slice,
  };
}

}  // namespace isoloft
