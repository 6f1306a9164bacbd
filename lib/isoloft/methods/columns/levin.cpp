// levin: the baseline (Levin 1986 style): every slice's exact signed
// Euclidean distance to its contour pixels (or its mask's edge), no fit, no
// filter; Hyman's monotone z spline and dome end caps.
#include <chrono>

#include "isoloft/methods/method.h"
#include "isoloft/methods/columns/slice_methods.h"
#include "isoloft/methods/params.h"

namespace isoloft {

MethodSpec levin_method() {
  return {
      .name = "levin",
      .doc = "baseline: exact per-slice EDT of the contour pixels (Levin 1986 style), no fit, no filter",
      .defaults = detail::paper_interp_defaults,
      .rows = {},
      .fits_curves = false,
      .slice_field =
          [](const SliceInput& in, const ReconstructParams&) {
            const auto t0 = std::chrono::steady_clock::now();
            SliceField r;
            r.field = detail::levin_field(in.masks, in.box, in.kind);
            r.t_dist = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            return r;
          },
  };
}

}  // namespace isoloft
