// @file field/marching.h
// @brief Narrow band to a Euclidean distance field on the whole grid (paper 2.2).
// Methods: FastMarching (Sethian 1996, heap), MarchingCorrectness (default;
// Mauch 2003: every trial pixel within kCorrectnessDelta of the least becomes
// known at once); fast sweeping in field/fast_sweeping.h. Updates: ClosestPoint
// (default; Danielsson 1980, Tsai 2002: the least distance to a neighbour's
// nearest band segment, then a walk along the links; a true distance to a
// segment, above the exact one only near medial loci; docs/decisions.md:
// closest-segment propagation) or Eikonal (first-order adjacent-diagonal
// upwind). Sign convention: positive inside, the sign of f kept.
// @warning For ClosestPoint MCC's threshold is a heuristic, not a proof
// (tested against FMM, fast sweeping and brute force).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/mesh.h"
#include "isoloft/core/params.h"
#include "isoloft/field/narrow_band.h"

namespace isoloft {

enum class ExtendMethod { FastMarching, MarchingCorrectness, FastSweeping };
enum class ExtendUpdate { ClosestPoint, Eikonal };

inline constexpr std::array<EnumName<ExtendMethod>, 3> kExtendMethodNames{{{ExtendMethod::FastMarching, "fast-marching"},
                                                                           {ExtendMethod::MarchingCorrectness, "mcc"},
                                                                           {ExtendMethod::FastSweeping, "fast-sweeping"}}};
constexpr std::span<const EnumName<ExtendMethod>> enum_names(ExtendMethod) { return kExtendMethodNames; }
inline constexpr std::array<EnumName<ExtendUpdate>, 2> kExtendUpdateNames{
    {{ExtendUpdate::ClosestPoint, "closest-point"}, {ExtendUpdate::Eikonal, "eikonal"}}};
constexpr std::span<const EnumName<ExtendUpdate>> enum_names(ExtendUpdate) { return kExtendUpdateNames; }

/// Most fast-sweeping cycles accepted.
inline constexpr int kMaxSweepCycles = 10000;

struct ExtendParams {
  ExtendMethod method = ExtendMethod::MarchingCorrectness;
  ExtendUpdate update = ExtendUpdate::ClosestPoint;
  int max_sweep_cycles = 64;
};

template <>
inline const ParamTable<ExtendParams>& params_table<ExtendParams>() {
  static const ParamTable<ExtendParams> t({
      field("method", &ExtendParams::method, "",
            "extension of the narrow band to the whole grid: mcc (marching with a correctness criterion, paper 2.2), "
            "fast-marching, fast-sweeping (the paper's future work)")
          .cli("--extend"),
      field("update", &ExtendParams::update, "",
            "update rule: closest-point (nearly exact Euclidean) or eikonal (first-order upwind)"),
      field("max_sweep_cycles", &ExtendParams::max_sweep_cycles, "cycles",
            "fast sweeping: cap on 4-sweep cycles (it stops when a cycle changes nothing)", between(1, kMaxSweepCycles)),
  });
  return t;
}

/// Signed distance on the whole grid: band pixels unchanged, the others by
/// params.method, signed by band.inside. \pre band from narrow_band_distance.
/// \param required if given (the grid's size): the marching methods stop once
///        its non-zero pixels are known; those hold the values of the whole
///        run bit for bit (a march is a prefix of the whole one), the others
///        only their sign (magnitude unspecified). Fast sweeping ignores it.
/// \throw ParamError if the band's grids or links disagree, `required` has
///        another size, or a parameter is out of range.
/// @warning No known band pixel (no curve): +-kNoSurfaceDistance by band.inside.
Grid2f extend_distance(const NarrowBandResult& band, const ExtendParams& params = {},
                       const Grid2u8* required = nullptr);

/// The methods themselves; the contract of extend_distance.
Grid2f extend_fast_marching(const NarrowBandResult& band, ExtendUpdate update = ExtendUpdate::ClosestPoint,
                            const Grid2u8* required = nullptr);

Grid2f extend_marching_cc(const NarrowBandResult& band, ExtendUpdate update = ExtendUpdate::ClosestPoint,
                          const Grid2u8* required = nullptr);

namespace detail {

struct SegmentGeom {
  double ax, ay, dx, dy, inv;
};

/// Working state: unsigned values, nearest segments, fixed (band) pixels.
struct ExtendState {
  int width = 0, height = 0;
  std::vector<double> value;        ///< ClosestPoint: squared distance; Eikonal: distance; +inf unknown
  std::vector<std::int32_t> seg;    ///< ClosestPoint only: index into the band's segments, -1 unknown
  std::vector<SegmentGeom> geom;    ///< ClosestPoint only: the band's segments
  const std::vector<std::array<std::int32_t, 2>>* links = nullptr;  ///< the band's links
  std::vector<std::uint8_t> fixed;  ///< 1 on band pixels
};

/// Squared distance from (x, y) to segment g.
inline double segment_distance2(const SegmentGeom& g, int x, int y) {
  const double px = x - g.ax, py = y - g.ay;
  double t = (px * g.dx + py * g.dy) * g.inv;
  t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
  const double ex = px - t * g.dx, ey = py - t * g.dy;
  return ex * ex + ey * ey;
}

/// Squared distance from (x, y) to segment k.
inline double segment_distance2(const ExtendState& s, int x, int y, std::int32_t k) {
  return segment_distance2(s.geom[std::size_t(k)], x, y);
}

/// From segment k walks the links both ways while within 0.01 px of the best
/// (<= 32 segments). \return the nearest segment met; d2 its squared distance.
std::int32_t descend_along_curve(const std::vector<SegmentGeom>& geom,
                                 const std::vector<std::array<std::int32_t, 2>>& links, int x, int y, std::int32_t k,
                                 double& d2);
inline std::int32_t descend_along_curve(const ExtendState& s, int x, int y, std::int32_t k, double& d2) {
  return descend_along_curve(s.geom, *s.links, x, y, k, d2);
}

/// extend_marching_cc over ExtendState with the generic update (offer /
/// settle shared with fast marching); extend_marching_cc runs it for Eikonal.
/// For ClosestPoint it is the twin of extend_marching_cc's own march (same
/// offers in the same order: the same floats).
Grid2f marching_cc_generic(const NarrowBandResult& band, ExtendUpdate update, const Grid2u8* required = nullptr);

/// \throw ParamError if the band is inconsistent.
ExtendState init_extend_state(const NarrowBandResult& band, ExtendUpdate update);

enum MarchStatus : std::uint8_t { kFar = 0, kTrial = 1, kKnown = 2 };

/// Eikonal candidate for (x, y) from its neighbours (kKnown ones if status is
/// given); +inf if none is finite.
double eikonal_update(const ExtendState& s, int x, int y, const std::uint8_t* status = nullptr);

/// Signed output: band values as given, others signed by band.inside.
Grid2f finish_extend(const NarrowBandResult& band, const ExtendState& s, ExtendUpdate update);

/// Mauch's correctness threshold on the square grid, px.
inline constexpr double kCorrectnessDelta = 0.70710678118654752440;

}  // namespace detail
}  // namespace isoloft
