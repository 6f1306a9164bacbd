// columns: the paper's z interpolation (2.4): a cubic Hermite spline per
// pixel column through the slice fields (InterpParams::spline), streamed a
// window of knots at a time (interp/z_stream.h).
#include "isoloft/methods/method.h"
#include "isoloft/methods/params.h"

namespace isoloft {

ZSchemeSpec columns_z_scheme() {
  return {
      .name = "columns",
      .doc = "a spline per pixel column through the slice fields (paper 2.4; --spline)",
      .rows = {"interp.spline"},
      .resident_knots = [](const ReconstructParams& p) -> std::optional<std::size_t> {
        // The spline's knots around a block: the tangent reach on each side.
        const std::optional<std::size_t> reach = tangent_reach(p.interp.spline);
        if (!reach) return std::nullopt;
        return 2 * (*reach + 1);
      },
      .make = [](ZSchemeInput in, const ReconstructParams& p) -> std::unique_ptr<PlaneSource> {
        return std::make_unique<ZStream>(std::move(in.z), p.interp.spline, in.width, in.height, std::move(in.next),
                                         in.count, in.block > 0 ? in.block : kZStreamBlock);
      },
  };
}

}  // namespace isoloft
