// isoloft, the default method: marker2006 with the departures measured to do
// better (docs/decisions.md, "The isoloft method"): the extremum-preserving z
// spline (Dougherty, Edelman, Hyman 1989) and slab end caps (docs/decisions.md,
// "End caps"), ReconstructParams{}'s own.
#include "isoloft/methods/method.h"
#include "isoloft/pipeline.h"

namespace isoloft {

MethodSpec isoloft_method() {
  return {
      .name = "isoloft",
      .doc = "marker2006 with the departures measured to do better (docs/decisions.md): the extremum-preserving z spline, slab end caps",
      .defaults = [](ReconstructParams&) {},  // ReconstructParams{} holds the default method's values
      .rows = detail::curve_fit_rows(),
      .fits_curves = true,
      .slice_field = detail::filtered_marker_slice,
  };
}

}  // namespace isoloft
