// @file interp/track_params.h
// @brief The track z scheme's parameters (interp/track.h), apart so that
// ReconstructParams (pipeline.h) holds them without the scheme.
#pragma once

#include <array>
#include <span>

#include "isoloft/core/params.h"

namespace isoloft {

/// Which matched pairs move with their parts (docs/decisions.md: the track z scheme).
enum class TrackMotion {
  Gated,     ///< bridges, and one-to-one overlapping pairs of IoU <= iou_max (thin oblique parts)
  RuleOnly,  ///< bridges only: overlapping pairs keep their pixel columns
  Auto,      ///< bridges, and one-to-one overlapping pairs of areas within similar_area
};
inline constexpr std::array<EnumName<TrackMotion>, 3> kTrackMotionNames{
    {{TrackMotion::Gated, "gated"}, {TrackMotion::RuleOnly, "rule-only"}, {TrackMotion::Auto, "auto"}}};
constexpr std::span<const EnumName<TrackMotion>> enum_names(TrackMotion) { return kTrackMotionNames; }

/// Measured values: docs/decisions.md, "The track z scheme" (the tilted-tube kit, experiments/tilted_tubes.cpp).
struct TrackParams {
  TrackMotion motion = TrackMotion::Gated;
  double iou_max = 0.3;
  double similar_area = 1.5;
  double c_size = 1.0;
  double c_tilt = 1.5;
  bool chain_support = true;
  double c_vel = 1.2;
  double rotate_min_anisotropy = 1.3;
  double screw_min_angle = 10.0;
};

template <>
inline const ParamTable<TrackParams>& params_table<TrackParams>() {
  static const ParamTable<TrackParams> t({
      field("motion", &TrackParams::motion, "",
            "which matched parts move between slices: gated (bridges and one-to-one pairs overlapping by IoU <= "
            "iou_max), rule-only (bridges only), auto (bridges and one-to-one pairs of similar area)")
          .cli("--track-motion"),
      field("iou_max", &TrackParams::iou_max, "",
            "motion gated: a one-to-one overlapping pair moves if its intersection over union is at most this",
            between(0, 1)),
      field("similar_area", &TrackParams::similar_area, "",
            "motion auto: a one-to-one overlapping pair moves if its larger area is at most this times the smaller",
            at_least(1)),
      field("c_size", &TrackParams::c_size, "",
            "bridging rule: parts that do not overlap connect if their centroids are at most c_size x their mean "
            "semi-extent along the shift plus the tilt term apart",
            at_least(0))
          .cli("--track-c-size"),
      field("c_tilt", &TrackParams::c_tilt, "",
            "bridging rule: tilt term, c_tilt x spacing x the mean tangent of the tilt an oblique tube of each "
            "part's cross-section has (its elongation along the shift)",
            at_least(0))
          .cli("--track-c-tilt"),
      field("chain_support", &TrackParams::chain_support, "",
            "bridging rule: a bridge must be continued by a match of similar shift into its lower or out of its "
            "upper part (a part seen on two slices only is ambiguous)"),
      field("c_vel", &TrackParams::c_vel, "",
            "chain support: the continuing shift may differ by at most c_vel x the larger of the two", at_least(0)),
      field("rotate_min_anisotropy", &TrackParams::rotate_min_anisotropy, "",
            "a moving pair also turns by its principal axes' angle if both parts are at least this elongated "
            "(sqrt of the moments' eigenvalue ratio)",
            at_least(1)),
      field("screw_min_angle", &TrackParams::screw_min_angle, "deg",
            "a pair turning by more than this moves on a screw (an arc about the motion's fixed point), else on a "
            "Catmull-Rom path through the chained shifts",
            between(0, 90)),
  });
  return t;
}

}  // namespace isoloft
