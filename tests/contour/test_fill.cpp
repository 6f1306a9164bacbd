// Even-odd fill of contour images on hand-made slices: nesting, borders,
// thick curves, open contours; mask_boundary and binarize.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "isoloft/contour/fill.h"
#include "isoloft/core/error.h"
#include "test_names.h"

namespace isoloft {
namespace {

constexpr int kW = 64, kH = 64;  // slice size of the hand-made cases
constexpr int kPad = 24;         // margin for curves drawn beyond the slice, then cropped


/// Compares two 0/1 grids, one failure per differing pixel (at most 10).
void expect_grid_eq(const Grid2u8& got, const Grid2u8& want, const std::string& what) {
  ASSERT_EQ(got.width, want.width) << what;
  ASSERT_EQ(got.height, want.height) << what;
  int failures = 0;
  for (int y = 0; y < got.height; ++y)
    for (int x = 0; x < got.width; ++x)
      if (got(x, y) != want(x, y) && failures++ < 10)
        ADD_FAILURE() << what << " at " << pixel_at(x, y) << ": got " << int(got(x, y)) << ", want "
                      << int(want(x, y));
}

Grid2u8 make(int w, int h, const std::function<bool(int, int)>& pred) {
  Grid2u8 g(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) g(x, y) = pred(x, y) ? 1 : 0;
  return g;
}

bool in_disk(int x, int y, double cx, double cy, double r) {
  return (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r;
}

Grid2u8 disk(double cx, double cy, double r) {
  return make(kW, kH, [&](int x, int y) { return in_disk(x, y, cx, cy, r); });
}

/// The closed 8-connected boundary curve of a digital disk, drawn on a
/// padded canvas and cropped, so a circle crossing the border stays clipped
/// (open at the border) instead of being closed along it.
Grid2u8 circle(double cx, double cy, double r) {
  const Grid2u8 big = mask_boundary(make(kW + 2 * kPad, kH + 2 * kPad, [&](int x, int y) {
    return in_disk(x - kPad, y - kPad, cx, cy, r);
  }));
  return make(kW, kH, [&](int x, int y) { return big(x + kPad, y + kPad) != 0; });
}

Grid2u8 unite(const Grid2u8& a, const Grid2u8& b) {
  Grid2u8 out = a;
  for (std::size_t i = 0; i < out.size(); ++i) out.data[i] = (a.data[i] || b.data[i]) ? 1 : 0;
  return out;
}

/// Square outline [x0,x1] x [y0,y1], one pixel thick.
Grid2u8 square(int x0, int y0, int x1, int y1) {
  return make(kW, kH, [&](int x, int y) {
    const bool in = x >= x0 && x <= x1 && y >= y0 && y <= y1;
    return in && (x == x0 || x == x1 || y == y0 || y == y1);
  });
}

int count_8_components(const Grid2u8& g) {
  Grid2i labels;
  return detail::label_components(g, true, true, labels);
}

TEST(ContourFill, SingleCircle) {
  const FillResult r = fill_even_odd(circle(30, 30, 12));
  expect_grid_eq(r.inside, disk(30, 30, 12), "inside");
  EXPECT_EQ(r.contour_components, 1);
  EXPECT_EQ(r.max_depth, 1);
  EXPECT_TRUE(r.open_contours.empty());
}

TEST(ContourFill, TwoDisjointCircles) {
  const FillResult r = fill_even_odd(unite(circle(16, 16, 9), circle(44, 40, 12)));
  expect_grid_eq(r.inside, unite(disk(16, 16, 9), disk(44, 40, 12)), "inside");
  EXPECT_EQ(r.contour_components, 2);
  EXPECT_EQ(r.max_depth, 1);
}

TEST(ContourFill, AnnulusHasAHole) {
  const FillResult r = fill_even_odd(unite(circle(32, 32, 25), circle(32, 32, 12)));
  // Inside the outer disk, and not strictly inside the hole curve.
  const Grid2u8 outer = disk(32, 32, 25), hole = disk(32, 32, 12), hole_curve = circle(32, 32, 12);
  const Grid2u8 want = make(kW, kH, [&](int x, int y) { return outer(x, y) && (!hole(x, y) || hole_curve(x, y)); });
  expect_grid_eq(r.inside, want, "inside");
  EXPECT_EQ(r.contour_components, 2);
  EXPECT_EQ(r.max_depth, 2);
}

TEST(ContourFill, IslandInsideHoleHasDepthThree) {
  const Grid2u8 c = unite(unite(circle(32, 32, 28), circle(32, 32, 17)), circle(32, 32, 7));
  const FillResult r = fill_even_odd(c);
  const Grid2u8 outer = disk(32, 32, 28), hole = disk(32, 32, 17), hole_curve = circle(32, 32, 17),
                island = disk(32, 32, 7);
  const Grid2u8 want = make(kW, kH, [&](int x, int y) {
    return (outer(x, y) && (!hole(x, y) || hole_curve(x, y))) || island(x, y);
  });
  expect_grid_eq(r.inside, want, "inside");
  EXPECT_EQ(r.contour_components, 3);
  EXPECT_EQ(r.max_depth, 3);
}

TEST(ContourFill, ClosedCircleTouchingTheBorderIsFilled) {
  // Centre 12 px from the left edge, radius 12: the curve runs along x = 0.
  const Grid2u8 c = circle(12, 30, 12);
  ASSERT_TRUE(c(0, 30)) << "test setup: the circle should touch the border at " << pixel_at(0, 30);
  const FillResult r = fill_even_odd(c);
  expect_grid_eq(r.inside, disk(12, 30, 12), "inside");
  EXPECT_EQ(r.max_depth, 1);
}

TEST(ContourFill, ContourClippedByTheBorderEnclosesNothing) {
  // Half the circle lies beyond x < 0: its ends are on the border, so the
  // region it bounds touches the border and is outside (documented rule).
  const Grid2u8 c = circle(-2, 30, 12);
  const FillResult r = fill_even_odd(c);
  expect_grid_eq(r.inside, c, "inside");
  EXPECT_EQ(r.max_depth, 0);
  EXPECT_TRUE(r.open_contours.empty()) << "a clipped curve separating two border regions is not open";
}

TEST(ContourFill, EmptySliceIsAllOutside) {
  const FillResult r = fill_even_odd(Grid2u8(kW, kH));
  expect_grid_eq(r.inside, Grid2u8(kW, kH), "inside");
  EXPECT_EQ(r.contour_components, 0);
  EXPECT_EQ(r.max_depth, 0);
  EXPECT_TRUE(r.open_contours.empty());

  const FillResult z = fill_even_odd(Grid2u8());
  EXPECT_TRUE(z.inside.empty());
  EXPECT_EQ(z.contour_components, 0);
}

TEST(ContourFill, ThickContours) {
  // Two-pixel-wide ring with a two-pixel-wide ring-shaped hole inside.
  const auto ring = [](int x, int y, double r) {
    const double d = std::hypot(x - 32.0, y - 32.0);
    return d <= r && d > r - 2.0;
  };
  const Grid2u8 c = make(kW, kH, [&](int x, int y) { return ring(x, y, 26) || ring(x, y, 12); });
  ASSERT_EQ(count_8_components(c), 2);
  const FillResult r = fill_even_odd(c);
  const Grid2u8 want = make(kW, kH, [&](int x, int y) {
    const double d = std::hypot(x - 32.0, y - 32.0);
    return d <= 26.0 && (d > 10.0);
  });
  expect_grid_eq(r.inside, want, "inside");
  EXPECT_EQ(r.max_depth, 2);
  EXPECT_TRUE(r.open_contours.empty());
}

TEST(ContourFill, SolidBlobAndDotAreContourOnly) {
  // Components with no background inside and no endpoints: not open, no interior.
  Grid2u8 c(kW, kH);
  c(5, 5) = 1;
  for (int y = 20; y < 24; ++y)
    for (int x = 20; x < 24; ++x) c(x, y) = 1;
  const FillResult r = fill_even_odd(c);
  expect_grid_eq(r.inside, c, "inside");
  EXPECT_TRUE(r.open_contours.empty());
}

// Square outline [10,40]^2 with pixels (40, 24..24+missing-1) removed: the
// endpoints are (40, 23) and (40, 24+missing), missing+1 px apart.
Grid2u8 square_with_gap(int missing) {
  Grid2u8 c = square(10, 10, 40, 40);
  for (int k = 0; k < missing; ++k) c(40, 24 + k) = 0;
  return c;
}

TEST(ContourFill, TwoPixelGapIsRepaired) {
  const FillResult r = fill_even_odd(square_with_gap(2));
  expect_grid_eq(r.contour, square(10, 10, 40, 40), "repaired contour");
  expect_grid_eq(r.inside, make(kW, kH, [](int x, int y) { return x >= 10 && x <= 40 && y >= 10 && y <= 40; }),
                 "inside");
  ASSERT_EQ(r.open_contours.size(), 1u);
  const OpenContour& o = r.open_contours[0];
  EXPECT_TRUE(o.repaired);
  EXPECT_EQ(o.ends, 2);
  EXPECT_EQ(o.gap, 3.0);
  EXPECT_EQ(o.x0, 40);
  EXPECT_EQ(o.y0, 23);
  EXPECT_EQ(o.x1, 40);
  EXPECT_EQ(o.y1, 26);
  EXPECT_EQ(r.max_depth, 1);
}

TEST(ContourFill, LargeGapIsReportedNotRepaired) {
  const Grid2u8 c = square_with_gap(10);
  const FillResult r = fill_even_odd(c);
  // Left open, the curve bounds nothing: it leaves the contour, and its
  // pixels take the outside around it (no surface may wrap the bare curve).
  const Grid2u8 none(c.width, c.height, 0);
  expect_grid_eq(r.contour, none, "contour (the open curve is no boundary)");
  expect_grid_eq(r.inside, none, "inside (an open curve has no inside)");
  ASSERT_EQ(r.open_contours.size(), 1u);
  const OpenContour& o = r.open_contours[0];
  EXPECT_FALSE(o.repaired);
  EXPECT_EQ(o.gap, 11.0);
  EXPECT_EQ(o.y0, 23);
  EXPECT_EQ(o.y1, 34);
}

TEST(ContourFill, AnOpenCurveInsideAClosedContourTakesItsInside) {
  // A closed square and, inside it, a straight 11 px stroke (two ends 10 px
  // apart, wider than max_gap): the stroke bounds nothing, so its pixels are
  // inside like the square's interior and are no contour.
  Grid2u8 c = square(10, 10, 40, 40);
  for (int x = 20; x <= 30; ++x) c(x, 25) = 1;
  const FillResult r = fill_even_odd(c);
  ASSERT_EQ(r.open_contours.size(), 1u);
  EXPECT_FALSE(r.open_contours[0].repaired);
  expect_grid_eq(r.contour, square(10, 10, 40, 40), "contour (the stroke is no boundary)");
  expect_grid_eq(r.inside, make(kW, kH, [](int x, int y) { return x >= 10 && x <= 40 && y >= 10 && y <= 40; }),
                 "inside");
}

TEST(ContourFill, GapNextToASpurIsRepaired) {
  // A spur (25, 8..9) on the top side adds a third end far from the gap.
  Grid2u8 c = square_with_gap(2);
  c(25, 9) = c(25, 8) = 1;
  const FillResult r = fill_even_odd(c);
  ASSERT_EQ(r.open_contours.size(), 1u);
  EXPECT_EQ(r.open_contours[0].ends, 3);
  EXPECT_TRUE(r.open_contours[0].repaired);
  EXPECT_EQ(r.open_contours[0].y0, 23);
  EXPECT_EQ(r.open_contours[0].y1, 26);
  Grid2u8 want = make(kW, kH, [](int x, int y) { return x >= 10 && x <= 40 && y >= 10 && y <= 40; });
  want(25, 9) = want(25, 8) = 1;
  expect_grid_eq(r.inside, want, "inside");
}

TEST(ContourFill, ErrorPolicyThrowsNamingThePixels) {
  FillParams p;
  p.open_policy = OpenContourPolicy::Error;
  EXPECT_NO_THROW(fill_even_odd(square_with_gap(2), p)) << "gaps within max_gap are repaired";
  try {
    fill_even_odd(square_with_gap(10), p);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("(40, 23)"), std::string::npos) << msg;
    EXPECT_NE(msg.find("(40, 34)"), std::string::npos) << msg;
  }
  p.max_gap = 0;
  EXPECT_THROW(fill_even_odd(square_with_gap(2), p), InputError) << "max_gap 0 rejects every open contour";
  // A curve whose other end is thick has a single end.
  Grid2u8 hook(kW, kH);
  for (int x = 10; x <= 30; ++x) hook(x, 20) = 1;
  for (int y = 18; y <= 22; ++y)
    for (int x = 30; x <= 34; ++x) hook(x, y) = 1;
  try {
    fill_even_odd(hook, p);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("single end, at pixel (10, 20)"), std::string::npos) << e.what();
  }
}

TEST(ContourFill, IgnorePolicyReportsButDoesNotRepair) {
  FillParams p;
  p.open_policy = OpenContourPolicy::Ignore;
  const Grid2u8 c = square_with_gap(2);
  const FillResult r = fill_even_odd(c, p);
  const Grid2u8 none(c.width, c.height, 0);
  expect_grid_eq(r.contour, none, "contour (the unrepaired curve is no boundary)");
  expect_grid_eq(r.inside, none, "inside");
  ASSERT_EQ(r.open_contours.size(), 1u);
  EXPECT_FALSE(r.open_contours[0].repaired);
}

TEST(ContourFill, NegativeMaxGapIsAParamError) {
  FillParams p;
  p.max_gap = -1;
  EXPECT_THROW(fill_even_odd(Grid2u8(4, 4), p), ParamError);
}

TEST(ContourFill, StaircaseCurveEndsAreFoundAndRepaired) {
  // 4-connected diamond outline r-1 <= |dx|+|dy| <= r; cutting away dx >= r-2
  // leaves ends (c+r-3, c-2) and (c+r-3, c+2), 4 px apart.
  constexpr int c = 32, r = 20;
  const auto l1 = [&](int x, int y) { return std::abs(x - c) + std::abs(y - c); };
  const Grid2u8 cut = make(kW, kH, [&](int x, int y) { return l1(x, y) >= r - 1 && l1(x, y) <= r && x - c < r - 2; });
  EXPECT_TRUE(detail::is_endpoint(cut, c + r - 3, c - 2)) << pixel_at(c + r - 3, c - 2);
  EXPECT_TRUE(detail::is_endpoint(cut, c + r - 3, c + 2)) << pixel_at(c + r - 3, c + 2);
  FillParams p;
  p.max_gap = 4;
  const FillResult res = fill_even_odd(cut, p);
  ASSERT_EQ(res.open_contours.size(), 1u);
  EXPECT_TRUE(res.open_contours[0].repaired);
  EXPECT_EQ(res.open_contours[0].gap, 4.0);
  expect_grid_eq(res.inside, make(kW, kH, [&](int x, int y) { return l1(x, y) <= r && x - c <= r - 3; }), "inside");
}

TEST(ContourFill, EndpointRule) {
  // Interior pixels of a 4-connected staircase are not endpoints; its ends are.
  Grid2u8 g(8, 8);
  const int path[][2] = {{1, 1}, {2, 1}, {2, 2}, {3, 2}, {3, 3}, {4, 3}};
  for (const auto& p : path) g(p[0], p[1]) = 1;
  for (const auto& p : path) {
    const bool end = (p[0] == 1 && p[1] == 1) || (p[0] == 4 && p[1] == 3);
    EXPECT_EQ(detail::is_endpoint(g, p[0], p[1]), end) << pixel_at(p[0], p[1]);
  }
}

TEST(ContourFill, LabelConnectivity) {
  Grid2u8 g(3, 3);
  g(0, 0) = g(1, 1) = 1;  // diagonal neighbours
  Grid2i labels;
  EXPECT_EQ(detail::label_components(g, true, true, labels), 1);
  EXPECT_EQ(detail::label_components(g, true, false, labels), 2);
  EXPECT_EQ(detail::label_components(g, false, false, labels), 1);
}

TEST(ContourFill, MaskBoundaryOfDiskIsClosedAndRefills) {
  const Grid2u8 d = disk(30, 28, 15);
  const Grid2u8 b = mask_boundary(d);
  EXPECT_EQ(count_8_components(b), 1);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      if (!b(x, y)) continue;
      int n = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          n += (dx || dy) && b.contains(x + dx, y + dy) && b(x + dx, y + dy);
      EXPECT_GE(n, 2) << "curve end at " << pixel_at(x, y);
      EXPECT_FALSE(detail::is_endpoint(b, x, y)) << pixel_at(x, y);
    }
  const FillResult r = fill_even_odd(b);
  expect_grid_eq(r.inside, d, "refilled disk");
  EXPECT_TRUE(r.open_contours.empty());
}

TEST(ContourFill, MaskBoundaryClosesAlongTheBorder) {
  // A disk cut by the image border: its boundary runs along the border.
  const Grid2u8 d = disk(3, 30, 15);
  const FillResult r = fill_even_odd(mask_boundary(d));
  expect_grid_eq(r.inside, d, "refilled clipped disk");
  // A full mask: the boundary is the image frame.
  const Grid2u8 full(kW, kH, 1);
  expect_grid_eq(fill_even_odd(mask_boundary(full)).inside, full, "refilled full mask");
}

TEST(ContourFill, Binarize) {
  Grid2u32 v(3, 1);
  v.data = {0, 127, 128};
  const Grid2u8 b = binarize(v, 127);
  EXPECT_EQ(b.data, (std::vector<std::uint8_t>{0, 0, 1}));
}

// remove_thin_features(mask, 2): what holds no 2x2 square goes (inside: a
// one-pixel spur, line and island; outside: a one-pixel notch, hole and gap),
// everything 2 px wide stays exactly, on either side.
TEST(RemoveThinFeatures, TwoByTwoOpeningThenClosing) {
  const auto box = [](int x, int y, int x0, int y0, int x1, int y1) { return x >= x0 && x <= x1 && y >= y0 && y <= y1; };
  // Two 10x10 blocks 1 px apart (a gap), the left one with a one-pixel spur, a
  // one-pixel notch and a one-pixel hole; a one-pixel line and island; a
  // 2 px wide bar and a 2x2 island; a 2 px wide notch in the right block.
  const auto blocks = [&](int x, int y) { return box(x, y, 5, 5, 14, 14) || box(x, y, 16, 5, 25, 14); };
  const auto thin_in = [&](int x, int y) {
    return box(x, y, 10, 2, 10, 4)            // spur above the left block
           || box(x, y, 30, 5, 30, 14)        // line
           || (x == 34 && y == 20);           // island
  };
  const auto thin_out = [&](int x, int y) {
    return (x == 5 && y == 9)                 // notch in the left block's left side
           || (x == 9 && y == 9)              // hole
           || box(x, y, 15, 5, 15, 14);       // the gap between the blocks (outside by construction)
  };
  const auto wide = [&](int x, int y) { return box(x, y, 40, 5, 41, 20) || box(x, y, 50, 30, 51, 31); };
  const auto wide_notch = [&](int x, int y) { return box(x, y, 20, 12, 21, 14); };
  const Grid2u8 mask = make(kW, kH, [&](int x, int y) {
    return ((blocks(x, y) || thin_in(x, y)) && !thin_out(x, y) && !wide_notch(x, y)) || wide(x, y);
  });
  const Grid2u8 want = make(kW, kH, [&](int x, int y) {
    return ((blocks(x, y) || box(x, y, 15, 5, 15, 14)) && !wide_notch(x, y)) || wide(x, y);
  });
  expect_grid_eq(remove_thin_features(mask, 2), want, "2x2 opening and closing");
  expect_grid_eq(remove_thin_features(mask, 1), mask, "width 1 keeps the mask");
  // A mask touching the border is not grown by the closing there, and a
  // full mask stays full.
  const Grid2u8 edge = make(kW, kH, [&](int x, int y) { return x <= 3; });
  expect_grid_eq(remove_thin_features(edge, 2), edge, "mask along the border");
  const Grid2u8 full(kW, kH, 1);
  expect_grid_eq(remove_thin_features(full, 3), full, "full mask");
}

}  // namespace
}  // namespace isoloft
