// @file interp/spline.h
// @brief z interpolation: a cubic Hermite spline per pixel column (paper 2.4).
// Monotone (the paper's; Hyman 1983): three-point tangents, 0 at a data
// extremum, else clipped to 3 min(|D_{i-1}|, |D_i|), so each interval stays
// between its knots. ExtremumPreserving (Dougherty, Edelman, Hyman 1989): the
// same where the data are monotone; at a smooth data extremum the parabola's
// slope (bounded), so the field does not pause at every slice; an interval
// whose knots share a sign keeps it. CatmullRom and Natural overshoot; Linear.
// Any kind takes non-uniform z. Also the end caps (docs/decisions.md: monotone
// cubic, extremum-preserving cubic, end caps).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/params.h"

namespace isoloft {

enum class SplineKind { Monotone, ExtremumPreserving, CatmullRom, Natural, Linear };

inline constexpr std::array<EnumName<SplineKind>, 5> kSplineKindNames{
    {{SplineKind::Monotone, "monotone"},
     {SplineKind::ExtremumPreserving, "extremum-preserving"},
     {SplineKind::CatmullRom, "catmull-rom"},
     {SplineKind::Natural, "natural"},
     {SplineKind::Linear, "linear"}}};
constexpr std::span<const EnumName<SplineKind>> enum_names(SplineKind) { return kSplineKindNames; }

/// How an object closes beyond its end slices (and next to an empty slice).
/// The cap slice sits cap_extent end spacings beyond the end slice; each
/// shape sets where between them the surface closes (docs/decisions.md: end
/// caps, measured on analytic RT Structure Sets).
enum class CapShape {
  Dome,   ///< the end slice's field lowered by its maximum + cap_depth: a cone-like dome shaped by the end contour's distance field (marker2006, levin)
  Flat,   ///< inside set to -cap_depth: a flat lid cap_extent beyond the end slice, its rim rounded over ~cap_depth
  Round,  ///< a half ellipsoid over the end contour, reaching min(cap_extent spacings, the contour's inradius)
  Slab,   ///< a flat lid with a sharp rim cap_extent beyond the end slice: the slab rule's volume (contour area x spacing)
};
inline constexpr std::array<EnumName<CapShape>, 4> kCapShapeNames{
    {{CapShape::Dome, "dome"}, {CapShape::Flat, "flat"}, {CapShape::Round, "round"}, {CapShape::Slab, "slab"}}};
constexpr std::span<const EnumName<CapShape>> enum_names(CapShape) { return kCapShapeNames; }

/// The field of an empty slice with no non-empty neighbour (an isolated empty
/// slice); its neighbours are closing slices or isolated (docs/decisions.md:
/// "Isolated empty slices take a local value": Box, the default, meshes as
/// Lowest did; Depth, Neighbours and Secant let a label win the partition's
/// competition far from its slices).
enum class IsolatedEmpty {
  Lowest,      ///< the lowest value of all the object's fields, at most -1 (global: every field computed first)
  Depth,       ///< -max(1, cap_depth), the mesher's pad outside the caps (local)
  Neighbours,  ///< the lowest value of the fields within kIsolatedNeighbourSlices slices, at most -max(1, cap_depth) (local)
  Secant,      ///< the line from a non-empty slice through its closing slice continued, at most -max(1, cap_depth) (local)
  Box,         ///< minus the diagonal of the object's crop box: below any distance in it (local)
};
inline constexpr std::array<EnumName<IsolatedEmpty>, 5> kIsolatedEmptyNames{{{IsolatedEmpty::Lowest, "lowest"},
                                                                             {IsolatedEmpty::Depth, "depth"},
                                                                             {IsolatedEmpty::Neighbours, "neighbours"},
                                                                             {IsolatedEmpty::Secant, "secant"},
                                                                             {IsolatedEmpty::Box, "box"}}};
constexpr std::span<const EnumName<IsolatedEmpty>> enum_names(IsolatedEmpty) { return kIsolatedEmptyNames; }

/// IsolatedEmpty::Neighbours: slices on each side read, Monotone's tangent
/// reach (2) + 1, the halo of a z slab.
inline constexpr std::size_t kIsolatedNeighbourSlices = 3;

/// Largest cap_extent accepted, slice spacings.
inline constexpr double kMaxCapExtent = 100.0;

struct InterpParams {
  SplineKind spline = SplineKind::Monotone;
  double cap_extent = 0.5;
  double cap_depth = 1.0;
  CapShape cap_shape = CapShape::Dome;
  IsolatedEmpty isolated_empty = IsolatedEmpty::Box;
  double z_step = 1.0;
  bool planes_on_slices = false;
};

template <>
inline const ParamTable<InterpParams>& params_table<InterpParams>() {
  static const ParamTable<InterpParams> t({
      field("spline", &InterpParams::spline, "",
            "z interpolation of every pixel column (paper 2.4): monotone (Hyman 1983), extremum-preserving (Dougherty, "
            "Edelman, Hyman 1989), catmull-rom, natural, linear")
          .cli("--spline"),
      field("cap_extent", &InterpParams::cap_extent, "spacings",
            "end caps (not in the paper): a virtual outside slice this far beyond each end slice",
            Range{0.0, kMaxCapExtent, true, false}),
      field("cap_depth", &InterpParams::cap_depth, "px",
            "end caps: the virtual slice is the end slice's field lowered by its maximum plus this", above(0)),
      field("cap_shape", &InterpParams::cap_shape, "",
            "end caps (not in the paper): round (a half ellipsoid reaching min(cap_extent spacings, the end contour's "
            "inradius)), slab (a sharp flat lid cap_extent beyond: the slab rule's volume), dome (shaped by the end "
            "contour's distance field, the paper reproduction's) or flat (a lid with a rounded rim)")
          .cli("--caps"),
      field("isolated_empty", &InterpParams::isolated_empty, "",
            "an empty slice with no non-empty neighbour (not in the paper): lowest (the lowest value of all the object's "
            "fields), depth (-max(1, cap_depth)), neighbours (the lowest of the fields within 3 slices) or secant (the "
            "line through the non-empty slice and its closing slice continued) or box (minus the crop box's diagonal); all but "
            "lowest are local"),
      field("z_step", &InterpParams::z_step, "px", "spacing of the sampled z planes (the Marching Cubes grid, paper 2.5)",
            above(0)),
      field("planes_on_slices", &InterpParams::planes_on_slices, "",
            "the z planes run through every slice (a step below z_step when the spacing is not a multiple of it), so the "
            "mesh's cross-section there is the slice's own curve (not in the paper); false: from the lower end cap"),
  });
  return t;
}

/// Tangents of one column. \pre z increasing; z, f, m of one size >= 2.
void spline_tangents(SplineKind kind, std::span<const double> z, std::span<const double> f, std::span<double> m);
/// The same tangents, only m[lo..hi] written (each the value the whole
/// column's call gives). \pre lo <= hi < z.size().
void spline_tangents(SplineKind kind, std::span<const double> z, std::span<const double> f, std::span<double> m,
                     std::size_t lo, std::size_t hi);

/// The cubic Hermite basis at z on the interval [z0, z1], for many columns
/// at one z: value() gives hermite()'s result bit for bit.
struct HermiteBasis {
  HermiteBasis(SplineKind kind, double z0, double z1, double z) {
    const double h = z1 - z0;
    t = (z - z0) / h;
    linear = kind == SplineKind::Linear;
    const double t2 = t * t, t3 = t2 * t;
    h00 = 2 * t3 - 3 * t2 + 1, h10h = (t3 - 2 * t2 + t) * h, h01 = -2 * t3 + 3 * t2, h11h = (t3 - t2) * h;
  }
  [[nodiscard]] double value(double f0, double f1, double m0, double m1) const {
    if (linear) return f0 + t * (f1 - f0);
    return h00 * f0 + h10h * m0 + h01 * f1 + h11h * m1;
  }
  double t, h00, h10h, h01, h11h;  // h10h, h11h: the tangent terms' basis times the interval length
  bool linear;
};

double hermite(SplineKind kind, double z0, double z1, double f0, double f1, double m0, double m1, double z);

/// The knot interval k (z[k] <= q < z[k + 1]) holding q, clamped to the
/// knots: the last interval holds z.back(). \pre z increasing, size >= 2.
std::size_t knot_interval(const std::vector<double>& z, double q);

/// A 1D spline through scalar data (figures, tests).
class Spline1D {
 public:
  Spline1D(std::vector<double> z, std::vector<double> f, SplineKind kind);
  [[nodiscard]] double operator()(double z) const;  ///< clamped to the end values outside [z0, zn]
  [[nodiscard]] const std::vector<double>& tangents() const { return m_; }

 private:
  std::vector<double> z_, f_, m_;
  SplineKind kind_;
};

/// Pixels of a plane as runs per row: row y's runs are
/// runs[first[y]] .. runs[first[y + 1]] - 1, each [x0, x1).
struct PixelRuns {
  std::vector<std::int32_t> first;                 ///< height + 1 offsets into runs
  std::vector<std::array<std::int32_t, 2>> runs;  ///< [x0, x1) in increasing x
  [[nodiscard]] long pixels() const;
};

/// Per-pixel splines through equally sized fields.
/// @warning Beyond [z.front(), z.back()] the end values hold.
class ZInterpolator {
 public:
  /// \throw ParamError unless slices.size() == z.size() >= 2, z increasing, one size.
  ZInterpolator(std::vector<Grid2f> slices, std::vector<double> z, SplineKind kind);
  /// Only the tangents of knots lo..hi (the others not held): evaluate() and
  /// sides() on the intervals between them only (others throw ParamError
  /// unless linear). \pre lo <= hi < z.size().
  ZInterpolator(std::vector<Grid2f> slices, std::vector<double> z, SplineKind kind, std::size_t lo, std::size_t hi);
  /// As above, the tangents of knots lo..lo + given.size() - 1 given, not
  /// computed: each must be the whole column's (e.g. from take_tangents() of
  /// a window whose tangents were exact there). \pre given.size() <= hi - lo + 1.
  ZInterpolator(std::vector<Grid2f> slices, std::vector<double> z, SplineKind kind, std::size_t lo, std::size_t hi,
                std::vector<Grid2f> given);
  /// Moves out the tangents of knots lo..hi (then empty: read no interval
  /// beside them). \pre lo <= hi < z().size().
  std::vector<Grid2f> take_tangents(std::size_t lo, std::size_t hi);
  /// The field at z, parallel over rows; with `only`, just those pixels (the
  /// others keep out's values; out must then be width x height already).
  void evaluate(double z, Grid2f& out, const PixelRuns* only = nullptr) const;
  [[nodiscard]] const std::vector<double>& z() const { return z_; }
  [[nodiscard]] int width() const { return slices_.front().width; }
  [[nodiscard]] int height() const { return slices_.front().height; }
  [[nodiscard]] std::size_t interval(double z) const;
  /// Per pixel the side of iso kept over knot interval k: +1 if the interval
  /// stays above iso + margin, -1 if below iso - margin, else 0 (margin above
  /// evaluate()'s rounding). Monotone and Linear: exact (the knots decide);
  /// other kinds: the knots widened by the cubic's largest overshoot bound.
  void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const;

 private:
  std::vector<Grid2f> slices_, tangents_;
  std::vector<double> z_;
  SplineKind kind_;
};

/// The virtual slice `reach` px (cap_extent x the end spacing) beyond end
/// slice `end` (InterpParams::cap_shape), outside everywhere: dome, `end`
/// lowered by max(0, its maximum) + cap_depth; flat, min(end, 0) -
/// cap_depth; round and slab, set so that the line from `end` to it crosses
/// 0 at the shape's height (round: reach x min(1, M / reach) x sqrt(1 - (1 -
/// f / M)^2) over a pixel of field f, M the maximum; slab: reach), a
/// kLidDepth lower, and (round, slab) no higher than `end`'s trend from the
/// slice before it (`next`, `spacing` px away) continued over the reach, so
/// that a column still narrowing at the end keeps narrowing instead of the
/// monotone spline's limiter holding it at the end contour.
Grid2f cap_slice(const Grid2f& end, const InterpParams& params, double reach, const Grid2f* next = nullptr,
                 double spacing = 0);

/// Round and slab caps: the cap slice lies this far (px) below the value
/// that would put the surface exactly on it, so it is outside.
inline constexpr float kLidDepth = 0.05f;

/// Adds the end caps (not in the paper): a cap_slice() cap_extent end
/// spacings beyond each end slice.
/// \throw ParamError unless slices.size() == z.size() >= 2 and params are valid.
void add_end_caps(std::vector<Grid2f>& slices, std::vector<double>& z, const InterpParams& params);

}  // namespace isoloft
