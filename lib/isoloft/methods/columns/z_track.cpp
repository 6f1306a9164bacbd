// track: the slice fields interpolated along the motion of their parts
// (interp/track.h): parts matched between slices by overlap and
// the bridging rule, each match a cubic along its trajectory with the z
// spline's own tangents (--spline). Not the default: on real anatomy it does
// not beat the per-column spline (docs/decisions.md, the track z scheme).
#include "isoloft/interp/track.h"
#include "isoloft/methods/method.h"
#include "isoloft/methods/params.h"

namespace isoloft {

ZSchemeSpec track_z_scheme() {
  return {
      .name = "track",
      .doc = "each slice's parts matched to the next slice's (overlap, or the bridging rule) and interpolated along "
             "their motion (Penney et al. 2004 style; --track-motion, --spline)",
      .rows = {"track.", "interp.spline"},
      // The knot window, each knot with its labels and part fields, and the
      // knot values and tangents of two intervals' pieces.
      .resident_knots = [](const ReconstructParams&) -> std::optional<std::size_t> { return 2 * kTrackWindow + 4; },
      .make = [](ZSchemeInput in, const ReconstructParams& p) -> std::unique_ptr<PlaneSource> {
        return std::make_unique<TrackStream>(std::move(in.z), p.track, p.interp.spline, p.mc.iso, in.width, in.height,
                                             std::move(in.next), in.count);
      },
  };
}

}  // namespace isoloft
