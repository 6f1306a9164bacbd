// The traced mask boundary (contour/mask_curve.h): every drawn pixel centre on
// its side, thin features kept, as the zero set the narrow band traces.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "isoloft/contour/mask_curve.h"
#include "isoloft/field/narrow_band.h"
#include "isoloft/pipeline.h"
#include "isoloft/methods/columns/field_band.h"
#include "isoloft/methods/columns/slice_methods.h"
#include "isoloft/objects/slice_fields.h"

namespace isoloft {
namespace {

// The traced slice field of `mask` (labels input), over the whole grid.
SliceField traced(const Grid2u8& mask, const ReconstructParams& p = {}) {
  detail::SliceMasks m;
  m.inside = mask;
  m.contour = mask_boundary(mask);
  m.empty = false;
  const Slice s;
  return detail::traced_mask_slice(SliceInput{m, s, PixelBox{0, 0, mask.width, mask.height}, InputKind::Labels, mask.width}, p);
}

// Closed loops of the zero set the field was traced from.
int loops(const Grid2f& f) {
  const NarrowBandResult nb = narrow_band_distance(f, [](const Vec2d&) { return 1.0; }, {2.0, 0, 1});
  std::vector<char> seen(nb.segments.size(), 0);
  int n = 0;
  for (std::size_t s = 0; s < seen.size(); ++s) {
    if (seen[s]) continue;
    ++n;
    std::vector<std::size_t> todo{s};
    while (!todo.empty()) {
      const std::size_t k = todo.back();
      todo.pop_back();
      if (seen[k]) continue;
      seen[k] = 1;
      for (const std::int32_t j : nb.links[k])
        if (j >= 0 && !seen[std::size_t(j)]) todo.push_back(std::size_t(j));
    }
  }
  return n;
}

RC_GTEST_PROP(MaskCurve, EveryDrawnPixelCentreStaysOnItsSide, ()) {
  const int w = *rc::gen::inRange(8, 24), h = *rc::gen::inRange(8, 24);
  Grid2u8 mask(w, h, 0);
  // Random blobs and one-pixel lines, away from the border (as in a crop box).
  const int blobs = *rc::gen::inRange(1, 5);
  for (int b = 0; b < blobs; ++b) {
    const double cx = *rc::gen::inRange(3, w - 3), cy = *rc::gen::inRange(3, h - 3), r = *rc::gen::inRange(0, 5);
    for (int y = 2; y < h - 2; ++y)
      for (int x = 2; x < w - 2; ++x)
        if (std::hypot(x - cx, y - cy) <= r) mask(x, y) = 1;
  }
  const int x0 = *rc::gen::inRange(2, w - 2), y0 = *rc::gen::inRange(2, h - 2);
  for (int i = 0; x0 + i < w - 2 && y0 + i < h - 2; ++i) mask(x0 + i, y0 + i) = 1;  // a diagonal line
  const SliceField f = traced(mask);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      RC_ASSERT((f.field(x, y) > 0) == bool(mask(x, y)));
}

// A one-pixel diagonal line and a one-pixel ring stay one piece each
// (saddles join the inside), and keep their pixels inside.
TEST(MaskCurve, OnePixelLinesStayOnePiece) {
  Grid2u8 line(30, 30, 0);
  for (int i = 4; i < 26; ++i) line(i, i) = 1;
  EXPECT_EQ(loops(clamped_smoothed_mask(line)), 1);
  Grid2u8 ring(40, 40, 0);
  for (int a = 0; a < 720; ++a) ring(int(std::lround(20 + 12 * std::cos(a * M_PI / 360))), int(std::lround(20 + 12 * std::sin(a * M_PI / 360)))) = 1;
  EXPECT_EQ(loops(clamped_smoothed_mask(ring)), 2) << "the ring's outer and inner boundary";
}

// A one-pixel-wide bar keeps its width: the thin margin holds the curve
// farther out than the broad margin would. Measured width across the bar's
// middle, from the field's zero crossings along a column.
TEST(MaskCurve, ThinFeaturesKeepTheirWidth) {
  Grid2u8 bar(40, 20, 0);
  for (int x = 5; x < 35; ++x) bar(x, 10) = 1;
  const auto width = [&](const MaskCurveParams& mp) {
    const Grid2f f = clamped_smoothed_mask(bar, mp);
    // Linear zero crossings of the samples above and below row 10 at x = 20.
    const double up = f(20, 10) / (f(20, 10) - f(20, 9)), down = f(20, 10) / (f(20, 10) - f(20, 11));
    return up + down;
  };
  MaskCurveParams broad;
  broad.thin_margin = broad.margin;
  // One pixel drawn: at least 0.6 px wide with the thin margin (the broad
  // margin alone narrows it to about 0.5).
  constexpr double kMinThinWidth = 0.6;
  EXPECT_GE(width(MaskCurveParams{}), kMinThinWidth);
  EXPECT_LT(width(broad), width(MaskCurveParams{}));
}

// The window test and the distance transform name the same thin pixels
// (twins) on random masks, for widths whose window is 3 x 3 to 7 x 7 and
// beyond (the EDT itself), with sides touching the grid's border.
TEST(MaskCurve, ThinSideWindowMatchesTheDistanceTransform) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 12; ++trial) {
    Grid2u8 m(37, 29, 0);
    std::bernoulli_distribution seed(0.08 + 0.04 * (trial % 4));
    for (auto& v : m.data) v = seed(rng);
    // Grown blobs: thick and thin parts side by side.
    for (int grow = 0; grow < trial % 3; ++grow) m = detail::dilate_square(m, 1);
    for (const double width : {0.5, 1.0, 2.0, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0, 9.0}) {
      const Grid2u8 want = detail::thin_side_edt(m, width), got = detail::thin_side(m, width);
      for (int y = 0; y < m.height; ++y)
        for (int x = 0; x < m.width; ++x)
          ASSERT_EQ(got(x, y), want(x, y)) << "trial " << trial << " width " << width << " pixel (" << x << ", " << y << ")";
    }
  }
}

}  // namespace
}  // namespace isoloft
