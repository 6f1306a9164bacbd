// @file interp/track_graph.h
// @brief The parts of a slice field and their matches between slices (the
// track z scheme, interp/track.h).
// A part is an 8-connected region of field > iso. Two parts of consecutive
// knots match if they overlap, or, for a part with no overlapping partner,
// if the bridging rule accepts the pair:
//     |d| <= c_size (a_A + a_B) / 2 + c_tilt h (tan_A + tan_B) / 2
// with d the centroid shift, h the knot spacing, a and b a part's semi-
// extents along d and across it (2 sqrt of the second moments, the pixel's
// own 1/12 px^2 removed: exact for a filled ellipse) and tan = sqrt(max(a^2 /
// b^2 - 1, 0)), the tilt of an oblique cylinder whose cross-section is
// stretched by 1 / cos(tilt) along its motion, which moves h tan(tilt) per
// slice. A round part predicts no motion (a compact part that jumps sideways
// is another object); a part stretched along d predicts an oblique tube's.
// A candidate is kept if it is the best (least |d| / allowed) of its lower or
// of its upper part (one-to-one, or one-to-many at a fork); then, with chain
// support, only if a match into its lower part or out of its upper part
// shifts alike (|d' - d| <= c_vel max(|d|, |d'|)): a structure seen on two
// slices only is ambiguous (two bars end to end look like an oblique tube).
// Pixel (i, j) is the point (i, j); sign convention: positive inside.
#pragma once

#include <cstdint>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/interp/track.h"

namespace isoloft::detail {

/// One part of a slice field.
struct TrackPart {
  long pixels = 0;
  Vec2d centroid{0, 0};
  double sxx = 0, syy = 0, sxy = 0;  ///< central second moments (means over the pixels), px^2
  PixelBox box;    ///< its pixels
  PixelBox shell;  ///< the pixels it owns (nearest part) with field > iso - kTrackShell
  double angle = 0;       ///< of the major principal axis, rad
  double anisotropy = 1;  ///< sqrt of the moments' eigenvalue ratio (1: round)
};

/// The parts of one field: labels (-1 outside every part) and each part.
struct TrackParts {
  Grid2i labels;
  Grid2i owner;  ///< the nearest part of every pixel (empty with fewer than 2 parts: part 0 or none)
  std::vector<TrackPart> parts;
};

/// Field values below iso by more than this are the background's (px): the
/// pixels of a part's shell are read from its pieces, so its knot is
/// reproduced there; beyond it the background (linear, <= iso - this)
/// reproduces it. Far above kSideMargin, so the background is a known outside.
inline constexpr float kTrackShell = 2.0f;

/// Parts of `field` above iso, their moments, owners and shells.
TrackParts track_parts(const Grid2f& field, float iso);

/// Semi-extents of a part along unit u and across it.
std::pair<double, double> part_extents(const TrackPart& p, const Vec2d& u);

struct BridgeTest {
  bool ok = false;
  double distance = 0, allowed = 0;
};
/// The bridging rule for parts a (lower) and b (upper), h apart in z.
BridgeTest bridge_test(const TrackPart& a, const TrackPart& b, double h, const TrackParams& params);

/// A match between part a of a knot and part b of the next.
struct TrackEdge {
  int a = 0, b = 0;
  Vec2d shift{0, 0};  ///< centroid of b - centroid of a
  bool bridge = false;
  long overlap = 0;  ///< pixels in both
};

/// Overlapping pairs and the bridges the rule and the best-candidate filter
/// keep, before chain support. \pre labels of one size.
std::vector<TrackEdge> candidate_edges(const TrackParts& lo, const TrackParts& hi, double h, const TrackParams& params);

/// `edges` without the bridges that no edge of `below` (into their lower
/// part) or `above` (out of their upper part) continues; null: no such
/// interval. \return the bridges dropped.
long drop_unsupported_bridges(std::vector<TrackEdge>& edges, const std::vector<TrackEdge>* below,
                              const std::vector<TrackEdge>* above, double c_vel);

/// The rigid motion a match carries: shift and turn (rad), zero if it does
/// not move (TrackParams::motion). `edges`: all matches of its interval.
struct TrackMotionStep {
  double dx = 0, dy = 0, da = 0;
};
TrackMotionStep edge_motion(const TrackEdge& e, const std::vector<TrackEdge>& edges, const TrackPart& a,
                            const TrackPart& b, const TrackParams& params);

}  // namespace isoloft::detail
