// Inside/outside of a slice from its contour pixels, by even-odd nesting.
//
// Digital topology (Rosenfeld; Kong & Rosenfeld, "Digital topology", CVGIP
// 48, 1989): contour pixels are 8-connected, the rest 4-connected, so a
// closed 8-curve separates the 4-connected background. A slice may hold
// several contours, holes and islands in holes (Marker et al. 2006, paper
// 2.1: "contours may be nested"): a background region's depth is the least
// number of contour components crossed to reach it from outside the image,
// and odd depth means inside. Beyond the image is outside: regions touching
// the image border have depth 0, so a contour clipped by the border (its
// ends on the border) encloses nothing; a closed contour may touch the border.
// Contour components are crossed as a whole: curves that touch or cross
// merge into one component, so their overlap is not an even-odd hole.
//
// Open contours (a gap in a drawn curve) do not separate anything. Rule:
// a contour component adjacent to at most one background region and having
// endpoints (see below) is open. If its two closest endpoints are at most
// `max_gap` apart, that gap is closed with a Bresenham segment (one gap per
// component; with more than two ends, e.g. a spur, the closest pair is taken
// as the gap); otherwise it is reported unrepaired and acts as a curve with
// no inside (its pixels stay contour pixels, hence "inside"). An endpoint is a contour pixel whose
// contour 8-neighbours form one contiguous run of length 1 or 2 around it
// (this also finds the ends of 4-connected, staircase-drawn curves). A
// component adjacent to one region but without endpoints (a dot, a solid
// blob) is a closed curve with no interior: not reported. A stray stroke no
// longer than max_gap is "repaired" onto itself and still has no interior.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "isoloft/core/grid.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// What fill_even_odd does with open contours.
enum class OpenContourPolicy {
  Repair,  ///< close gaps <= max_gap, report the rest in FillResult::open_contours
  Error,   ///< close gaps <= max_gap, throw on the rest (max_gap = 0: reject any open contour)
  Ignore,  ///< change nothing; report every open contour as unrepaired
};

inline constexpr std::array<EnumName<OpenContourPolicy>, 3> kOpenContourPolicyNames{
    {{OpenContourPolicy::Repair, "repair"}, {OpenContourPolicy::Error, "error"}, {OpenContourPolicy::Ignore, "ignore"}}};
constexpr std::span<const EnumName<OpenContourPolicy>> enum_names(OpenContourPolicy) { return kOpenContourPolicyNames; }

/// Even-odd fill parameters (not in the paper, which assumes closed contours).
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

/// One open contour component found in the input.
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
  Grid2u8 contour;           ///< 0/1 contour after repair
  int contour_components = 0;  ///< 8-connected components of `contour`
  int max_depth = 0;         ///< deepest background region (0: no closed contour)
  std::vector<OpenContour> open_contours;
};

/// Even-odd fill of a contour image (non-zero = contour pixel).
/// \pre params.max_gap >= 0
/// \throw ParamError if max_gap < 0.
/// \throw InputError (empty file name; the caller prefixes the slice file)
///        naming the endpoint pixels if policy is Error and an open contour
///        cannot be repaired.
FillResult fill_even_odd(const Grid2u8& contour, const FillParams& params = {});

/// Pixels of the mask (non-zero) having a 4-neighbour outside the mask or
/// lying on the image border: an 8-connected closed curve per 4-connected
/// mask piece (paper 2.1: "each label's boundary pixels are its contours").
/// Note that a mask piece thinner than ~3 px becomes all boundary, so its
/// holes are lost by a later fill; use the mask itself as `inside` when you
/// have it.
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

/// Connected components of the pixels whose (value != 0) equals
/// `foreground`, 8- or 4-connected. labels gets the component index
/// (numbered in row-major order of first pixel) or -1. Returns the count.
int label_components(const Grid2u8& image, bool foreground, bool eight_connected, Grid2i& labels);

/// True if (x, y) is an endpoint of the contour (rule in the file comment).
bool is_endpoint(const Grid2u8& contour, int x, int y);

/// Sets the pixels of the 8-connected Bresenham segment (x0,y0)-(x1,y1)
/// that lie in the grid to 1.
void draw_segment(Grid2u8& image, int x0, int y0, int x1, int y1);

}  // namespace detail
}  // namespace isoloft
