// @file interp/track.h
// @brief The "track" z scheme: slice fields interpolated along the motion of
// their parts (not in the paper, which interpolates each pixel
// column, 2.4).
// Each knot's field is split into its parts (8-connected regions above iso);
// consecutive knots' parts are matched: every overlapping pair, and a part
// with no overlapping partner bridged to a non-overlapping one only where the
// data say so (the bridging rule, track_graph.h). A matched pair that moves
// (TrackParams::motion) carries a rigid motion: its centroid shift and the
// turn of its principal axes. Between knots k and k + 1 every match, fading
// part and appearing part is a piece: a cubic Hermite along its trajectory
// (the values of up to six chained knots read in the moving frame, the
// tangents by the z spline's own rule, InterpParams::spline), and the field
// is the largest piece, over a background below iso. Registration-based
// interpolation of this kind: Penney et al. 2004 (IEEE TMI 23(7)); the part
// matching is closer to Treece et al. 2000 and Albu et al. 2008.
//
// Guarantees (tested): at each knot's z the field is the knot's field, bit
// for bit; along a trajectory whose values are monotone it does not
// overshoot (monotone and extremum-preserving splines); a part that
// overlaps nothing and is not bridged closes between the knots like the
// per-column spline's end of an object; the knots are read in z order and
// held a window of kTrackWindow at a time (memory independent of the knot
// count). sides() is exact where it answers: -1 outside every piece, the
// knots' bound on a piece that does not move, 0 (unknown) on one that moves.
// Sign convention: positive inside; inside iff value > iso.
// @warning A part that moves is read bilinearly between pixels: its field
// there is smoothed by up to half a pixel's interpolation.
// @warning Natural splines take their tangents over the trajectory's own six
// knots, not the whole column.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/interp/spline.h"
#include "isoloft/interp/track_params.h"
#include "isoloft/interp/z_stream.h"

namespace isoloft {

/// Knots TrackStream holds at once: the six a trajectory reads (k - 2 ..
/// k + 3) and the two beyond that decide their bridges' chain support.
inline constexpr std::size_t kTrackWindow = 8;

/// Pieces and matches made, for reports and tests.
struct TrackStats {
  long overlaps = 0;        ///< overlapping pairs matched
  long bridges = 0;         ///< non-overlapping pairs bridged
  long bridges_dropped = 0;  ///< bridge candidates without chain support
  long moving_pieces = 0;   ///< pieces read in a moving frame
  long pieces = 0;
};

class TrackStream final : public PlaneSource {
 public:
  /// `z`: every knot (end caps included); `next`: their fields in z order.
  /// \throw ParamError unless z has >= 2 increasing knots, sizes >= 1, params valid.
  TrackStream(std::vector<double> z, const TrackParams& params, SplineKind kind, float iso, int width, int height,
              ZStream::NextKnot next, ResidentCount* count = nullptr);
  ~TrackStream() override;
  TrackStream(const TrackStream&) = delete;
  TrackStream& operator=(const TrackStream&) = delete;

  [[nodiscard]] int width() const override { return width_; }
  [[nodiscard]] int height() const override { return height_; }
  [[nodiscard]] std::size_t interval(double z) const override;
  /// Pulls knots up to k + 4 and makes the pieces of interval k.
  /// \throw ParamError for a knot of another size, or k below an earlier reach.
  void reach(std::size_t k) override;
  void evaluate(double z, Grid2f& out) const override;
  /// Intervals k of the last two reach() calls.
  void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const override;
  [[nodiscard]] double setup_seconds() const override { return setup_seconds_; }
  [[nodiscard]] const TrackStats& stats() const { return stats_; }

  struct Knot;
  struct Piece;

 private:
  struct Interval;
  void pull();
  void build(std::size_t k);
  Knot& knot(std::size_t j);
  const Interval* built(std::size_t k) const;
  void count(long delta);

  std::vector<double> z_;
  TrackParams params_;
  SplineKind kind_;
  float iso_;
  int width_, height_;
  ZStream::NextKnot next_;
  ResidentCount* count_;
  std::deque<std::unique_ptr<Knot>> knots_;  // knots [first_, first_ + size)
  std::size_t first_ = 0;
  std::deque<std::unique_ptr<Interval>> intervals_;  // the last two built
  long counted_ = 0;
  double setup_seconds_ = 0;
  TrackStats stats_;
};

}  // namespace isoloft
