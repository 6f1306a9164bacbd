// z interpolation through the slices (paper 2.4): every pixel column is one
// cubic Hermite spline through its slice values.
//
// Kinds:
//  - Monotone: Fritsch-Carlson/Hyman monotone cubic Hermite. Three-point
//    (parabolic) tangents, then Hyman's filter (Hyman 1983, "Accurate
//    monotonicity preserving cubic interpolation", SIAM J. Sci. Stat. Comput.
//    4(4)): m_i = 0 at a local extremum of the data, otherwise m_i keeps the
//    sign of the data and |m_i| <= 3 min(|D_{i-1}|, |D_i|). The interpolant is
//    then monotone on every interval where the data are, and never leaves the
//    range of the two data values of an interval (paper 2.4, Fig. 8/9).
//  - CatmullRom: m_i = (f_{i+1} - f_{i-1}) / (z_{i+1} - z_{i-1}) (may overshoot).
//  - Natural: C2 natural cubic spline (f'' = 0 at the ends), via its tangents.
//  - Linear: piecewise linear.
// Non-uniform z works for every kind. Ends use one-sided estimates.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/params.h"

namespace isoloft {

enum class SplineKind { Monotone, CatmullRom, Natural, Linear };

inline constexpr std::array<EnumName<SplineKind>, 4> kSplineKindNames{{{SplineKind::Monotone, "monotone"},
                                                                       {SplineKind::CatmullRom, "catmull-rom"},
                                                                       {SplineKind::Natural, "natural"},
                                                                       {SplineKind::Linear, "linear"}}};
constexpr std::span<const EnumName<SplineKind>> enum_names(SplineKind) { return kSplineKindNames; }

/// How an object closes beyond its end slices (and next to an empty slice).
enum class CapShape {
  Dome,  ///< the end slice's field lowered by its maximum + cap_depth: a dome shaped by the end contour's distance field
  Flat,  ///< inside set to -cap_depth: a flat lid cap_extent beyond the end slice, its rim rounded over ~cap_depth
};
inline constexpr std::array<EnumName<CapShape>, 2> kCapShapeNames{{{CapShape::Dome, "dome"}, {CapShape::Flat, "flat"}}};
constexpr std::span<const EnumName<CapShape>> enum_names(CapShape) { return kCapShapeNames; }

/// Largest end-cap distance accepted, slice spacings.
inline constexpr double kMaxCapExtent = 100.0;

struct InterpParams {
  SplineKind spline = SplineKind::Monotone;
  double cap_extent = 0.5;
  double cap_depth = 1.0;
  CapShape cap_shape = CapShape::Dome;
  double z_step = 1.0;
};

template <>
inline const ParamTable<InterpParams>& params_table<InterpParams>() {
  static const ParamTable<InterpParams> t({
      field("spline", &InterpParams::spline, "",
            "z interpolation of every pixel column (paper 2.4): monotone (Hyman 1983), catmull-rom, natural, linear")
          .cli("--spline"),
      field("cap_extent", &InterpParams::cap_extent, "spacings",
            "end caps (not in the paper): a virtual outside slice this far beyond each end slice",
            Range{0.0, kMaxCapExtent, true, false}),
      field("cap_depth", &InterpParams::cap_depth, "px",
            "end caps: the virtual slice is the end slice's field lowered by its maximum plus this", above(0)),
      field("cap_shape", &InterpParams::cap_shape, "",
            "end caps: dome (shaped by the end contour's distance field) or flat (a lid cap_extent beyond the end slice)")
          .cli("--caps"),
      field("z_step", &InterpParams::z_step, "px", "spacing of the sampled z planes (the Marching Cubes grid, paper 2.5)",
            above(0)),
  });
  return t;
}

/// Hermite tangents of one column: f at strictly increasing z, n >= 2.
/// \pre z.size() == f.size() == m.size() >= 2
void spline_tangents(SplineKind kind, std::span<const double> z, std::span<const double> f, std::span<double> m);

/// Evaluate the Hermite piece on [z0, z1] (linear kind ignores m).
double hermite(SplineKind kind, double z0, double z1, double f0, double f1, double m0, double m1, double z);

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

/// Per-pixel splines through a stack of equally sized fields.
class ZInterpolator {
 public:
  /// \pre slices.size() == z.size() >= 2, z strictly increasing, all slices the same size.
  /// \throw ParamError otherwise.
  ZInterpolator(std::vector<Grid2f> slices, std::vector<double> z, SplineKind kind);
  /// Field at height z (clamped to [z.front(), z.back()]); parallel over rows.
  void evaluate(double z, Grid2f& out) const;
  [[nodiscard]] const std::vector<double>& z() const { return z_; }
  [[nodiscard]] int width() const { return slices_.front().width; }
  [[nodiscard]] int height() const { return slices_.front().height; }
  /// The knot interval k (z[k] <= z <= z[k + 1]) that evaluate(z) uses.
  [[nodiscard]] std::size_t interval(double z) const;
  /// Per pixel, the side of `iso` the field keeps over all of knot interval
  /// k: +1 above iso + margin at both knots, -1 below iso - margin at both, 0
  /// otherwise. Exact for the kinds that stay between their knot values
  /// (monotone: Hyman's tangents keep each cubic monotone, Fritsch & Carlson
  /// 1980 alpha, beta <= 3; linear); all 0 for the others, which overshoot.
  /// margin (pixels) must exceed the float rounding of evaluate().
  void sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const;

 private:
  std::vector<Grid2f> slices_, tangents_;
  std::vector<double> z_;
  SplineKind kind_;
};

/// The virtual slice beyond end slice `end` (InterpParams::cap_shape): outside
/// (<= -cap_depth) everywhere.
Grid2f cap_slice(const Grid2f& end, const InterpParams& params);

/// Adds the end-cap virtual slices of InterpParams to (slices, z).
/// \pre slices.size() == z.size() >= 2
void add_end_caps(std::vector<Grid2f>& slices, std::vector<double>& z, const InterpParams& params);

}  // namespace isoloft
