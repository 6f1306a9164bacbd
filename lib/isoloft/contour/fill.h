// @file contour/fill.h
// @brief Inside/outside of a slice from its contour pixels; open-contour repair.
// Even-odd nesting (paper 2.1), contour 8-connected, background 4-connected
// (Kong & Rosenfeld 1989): a region's depth is the least number of contour
// components crossed from beyond the image; odd = inside, contour pixels too.
// A component next to at most one region, with endpoints, is open: its
// closest ends are joined if at most max_gap apart (docs/decisions.md: open
// contours), else it is a curve without inside: it leaves the contour and
// takes the inside/outside of the region around it.
// @warning Touching or crossing curves merge: no even-odd overlap.
// @warning A contour ending on the image border encloses nothing; a dot or
// solid blob has no interior and is not reported.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/params.h"

namespace isoloft {

enum class OpenContourPolicy {
  Repair,  ///< close gaps <= max_gap, report the rest in FillResult::open_contours
  Error,   ///< close gaps <= max_gap, throw on the rest (max_gap = 0: reject any open contour)
  Ignore,  ///< change nothing; report every open contour as unrepaired
};

inline constexpr std::array<EnumName<OpenContourPolicy>, 3> kOpenContourPolicyNames{
    {{OpenContourPolicy::Repair, "repair"}, {OpenContourPolicy::Error, "error"}, {OpenContourPolicy::Ignore, "ignore"}}};
constexpr std::span<const EnumName<OpenContourPolicy>> enum_names(OpenContourPolicy) { return kOpenContourPolicyNames; }

/// Not in the paper; docs in the table rows.
struct FillParams {
  int max_gap = 3;
  OpenContourPolicy open_policy = OpenContourPolicy::Repair;
};

template <>
inline const ParamTable<FillParams>& params_table<FillParams>() {
  static const ParamTable<FillParams> t({
      field("max_gap", &FillParams::max_gap, "px",
            "largest gap closed in an open contour (distance of the two end pixel centres)", at_least(0))
          .cli("--max-gap"),
      field("open_contours", &FillParams::open_policy, "",
            "open contours: repair (close gaps <= max_gap, warn), error, or ignore (a curve without inside)")
          .cli("--open-contours"),
  });
  return t;
}

struct OpenContour {
  int component = -1;       ///< 8-connected component index in the input (row-major order of first pixel)
  int x0 = 0, y0 = 0;       ///< the closest pair of endpoints (equal if only one endpoint)
  int x1 = 0, y1 = 0;
  double gap = 0.0;         ///< their distance in pixels; +inf with a single endpoint
  bool repaired = false;    ///< closed by a segment
  int ends = 0;             ///< endpoints found (2 for a simple open curve)
};

struct FillResult {
  Grid2u8 inside;            ///< 1 = interior (odd depth) or contour pixel
  Grid2u8 contour;           ///< 0/1 contour after repair, without the open contours left open
  int contour_components = 0;  ///< 8-connected components of `contour`
  int max_depth = 0;         ///< deepest background region (0: no closed contour)
  std::vector<OpenContour> open_contours;
};

/// Even-odd fill of a contour image (non-zero = contour).
/// \throw ParamError if max_gap < 0; InputError (no file name) naming the ends
///        if the policy is Error and an open contour cannot be repaired.
FillResult fill_even_odd(const Grid2u8& contour, const FillParams& params = {});

/// Mask pixels with a 4-neighbour outside or on the border: a closed 8-curve
/// per 4-connected piece (paper 2.1).
/// @warning A piece thinner than ~3 px is all boundary: keep the mask as inside.
Grid2u8 mask_boundary(const Grid2u8& mask);

/// The mask without its features narrower than `width` pixels: an opening
/// (erosion, then dilation) by a width x width square removes the inside
/// features that hold no such square (one-pixel lines, spurs, islands), then a
/// closing by the same square fills the outside ones (notches, holes, gaps
/// between pieces). Every part of the mask or of its outside that holds a
/// width x width square is kept exactly. Beyond the image is outside.
/// width <= 1 returns the mask unchanged.
Grid2u8 remove_thin_features(const Grid2u8& mask, int width);

/// 1 where value > threshold, else 0.
Grid2u8 binarize(const Grid2u32& values, std::uint32_t threshold);

namespace detail {

/// Components of (value != 0) == foreground, row-major. \return the count.
int label_components(const Grid2u8& image, bool foreground, bool eight_connected, Grid2i& labels);

/// A contour pixel whose contour 8-neighbours form one run of 1 or 2.
bool is_endpoint(const Grid2u8& contour, int x, int y);

/// Sets the in-grid pixels of the 8-connected Bresenham segment.
void draw_segment(Grid2u8& image, int x0, int y0, int x1, int y1);

}  // namespace detail
}  // namespace isoloft
