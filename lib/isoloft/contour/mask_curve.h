// @file contour/mask_curve.h
// @brief A mask's sub-pixel boundary: the smooth curve that keeps every drawn
// pixel on its side (masks and labels; docs/decisions.md: traced mask boundary).
// The mask (1 inside) is smoothed by a Gaussian, every pixel centre is put
// back on its side with a value margin (inside >= 1/2 + m, outside <= 1/2 - m),
// and the curve is the 1/2 level of that function's samples by marching
// squares, saddles joining the inside (a drawn diagonal line stays one
// piece). Each vertex lies strictly between an inside and an outside pixel
// centre, so the curve separates them exactly. The margin is larger where
// the mask (or its complement) is thinner than `thin_width`, so that 1-2 px
// features keep their width. Sign convention: positive inside.
#pragma once

#include "isoloft/core/grid.h"
#include "isoloft/core/params.h"

namespace isoloft {

struct MaskCurveParams {
  double sigma = 0.7;        ///< px
  double margin = 0.15;      ///< of the 0..1 value range
  double thin_margin = 0.25;  ///< where a side is narrower than thin_width
  double thin_width = 3.0;   ///< px
};

template <>
inline const ParamTable<MaskCurveParams>& params_table<MaskCurveParams>() {
  static const ParamTable<MaskCurveParams> t(
      {
          field("sigma", &MaskCurveParams::sigma, "px",
                "traced mask boundary (not in the paper): Gaussian smoothing the mask before its 1/2 level is traced",
                between(0, 8)),
          field("margin", &MaskCurveParams::margin, "",
                "traced mask boundary: every pixel centre is clamped at least this far on its side of 1/2, so the "
                "curve keeps every drawn pixel inside and every other outside",
                open_between(0, 0.5)),
          field("thin_margin", &MaskCurveParams::thin_margin, "",
                "traced mask boundary: the clamp margin where the mask or its complement is thinner than thin_width "
                "(keeps 1-2 px features at their width)",
                open_between(0, 0.5)),
          field("thin_width", &MaskCurveParams::thin_width, "px",
                "traced mask boundary: features narrower than this take thin_margin", between(0, 64)),
      });
  return t;
}

/// The clamped smoothed mask minus 1/2 at every pixel centre (positive
/// inside): its marching-squares zero set (saddles joining the inside) is the
/// traced boundary. Beyond the grid the mask is 0.
/// @warning An empty mask gives a field without zero crossing (all < 0).
Grid2f clamped_smoothed_mask(const Grid2u8& inside, const MaskCurveParams& params = {});

/// The mask smoothed by a Gaussian of `sigma` px (radius 3 sigma, 0 beyond
/// the grid) minus 1/2, positive inside: its zero set is smooth but, unlike
/// clamped_smoothed_mask()'s, may leave pixel centres on the wrong side
/// (corners, features thinner than about 2 sigma).
Grid2f smoothed_mask(const Grid2u8& inside, double sigma);

namespace detail {

/// Widths whose deep test reaches farther than this (px) take the EDT.
inline constexpr int kThinWindowReach = 3;

/// Per pixel: is its own side (mask or complement) thinner than `width` here?
/// A side is thin at p when no pixel of it within one step (3 x 3) lies
/// width / 2 or more from the side's edge (distance_to_mask_edge_signed).
/// By a window test where that distance is decided within kThinWindowReach px
/// (the default width 3: the 3 x 3 around a pixel), else thin_side_edt.
Grid2u8 thin_side(const Grid2u8& m, double width);
/// The same from the exact distance transform (any width): thin_side's twin.
Grid2u8 thin_side_edt(const Grid2u8& m, double width);

}  // namespace detail

}  // namespace isoloft
