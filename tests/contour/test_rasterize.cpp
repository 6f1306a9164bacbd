// Polygon rasterisation: exact even-odd inside at pixel centres, closed
// 8-connected contour curves, and agreement with fill_even_odd.
#include <gtest/gtest.h>
#include <rapidcheck.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/rasterize.h"
#include "isoloft/core/error.h"
#include "test_names.h"

namespace isoloft {
namespace {

/// Polygons kept this far apart (px) rasterise to separate curves: DDA pixels
/// lie within sqrt(2)/2 of their edge and two curves merge when their pixels
/// are 8-adjacent (centres <= sqrt(2) apart): 2 * 0.71 + 1.41 < 3.
constexpr double kSeparation = 3.0;


/// Crossing-number point-in-polygon test (W. R. Franklin's PNPOLY), the
/// naive twin of the scanline fill, over all polygons (even-odd).
bool pnpoly(const std::vector<Polygon>& polys, double px, double py) {
  bool c = false;
  for (const Polygon& poly : polys) {
    const auto& v = poly.points;
    for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++)
      if ((v[i].y() > py) != (v[j].y() > py) &&
          px < (v[j].x() - v[i].x()) * (py - v[i].y()) / (v[j].y() - v[i].y()) + v[i].x())
        c = !c;
  }
  return c;
}

/// Returns "" if the rasterisation is consistent, else the first problems:
/// inside == PNPOLY off the contour, inside == 1 on it, each polygon's edge
/// pixel runs 8-connected and chained into a closed loop, and (if
/// `check_fill`) fill_even_odd(contour) == inside.
std::string check(const std::vector<Polygon>& polys, int w, int h, bool check_fill) {
  Grid2u8 contour, inside;
  rasterize_polygons(polys, w, h, contour, inside);
  std::string msg;
  int failures = 0;
  auto fail = [&](const std::string& m) {
    if (failures++ < 8) msg += m + "\n";
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool want = contour(x, y) || pnpoly(polys, x, y);
      if (bool(inside(x, y)) != want)
        fail("inside at " + pixel_at(x, y) + " is " + std::to_string(inside(x, y)) + (contour(x, y) ? " on" : " off") +
             " the contour");
    }
  for (std::size_t k = 0; k < polys.size(); ++k) {
    const auto& v = polys[k].points;
    std::vector<std::array<int, 2>> loop;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const auto run = detail::segment_pixels(v[i], v[(i + 1) % v.size()], w, h);
      if (!loop.empty() && loop.back() != run.front())
        fail("polygon " + std::to_string(k) + " edge " + std::to_string(i) + " does not start at the previous end " +
             pixel_at(loop.back()[0], loop.back()[1]));
      loop.insert(loop.end(), run.begin(), run.end());
    }
    if (loop.front() != loop.back()) fail("polygon " + std::to_string(k) + " loop is not closed");
    for (std::size_t i = 0; i + 1 < loop.size(); ++i) {
      const auto& a = loop[i];
      const auto& b = loop[i + 1];
      if (std::abs(a[0] - b[0]) > 1 || std::abs(a[1] - b[1]) > 1)
        fail("polygon " + std::to_string(k) + ": " + pixel_at(a[0], a[1]) + " and " + pixel_at(b[0], b[1]) +
             " are consecutive but not 8-adjacent");
      if (!contour(a[0], a[1])) fail("loop " + pixel_at(a[0], a[1]) + " not marked in the contour");
    }
  }
  if (check_fill) {
    const FillResult f = fill_even_odd(contour);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (f.inside(x, y) != inside(x, y))
          fail("fill_even_odd(contour) disagrees with the rasterised inside at " + pixel_at(x, y));
    Grid2i labels;
    const int comps = detail::label_components(contour, true, true, labels);
    if (comps != int(polys.size()))
      fail(std::to_string(comps) + " contour components for " + std::to_string(polys.size()) + " polygons");
  }
  return msg;
}

Polygon regular(double cx, double cy, double r, int n, double phase) {
  Polygon p;
  for (int i = 0; i < n; ++i) {
    const double a = phase + 2.0 * std::numbers::pi * i / n;
    p.points.emplace_back(cx + r * std::cos(a), cy + r * std::sin(a));
  }
  return p;
}

TEST(ContourRasterize, PolygonWithHole) {
  // Concave outer outline with non-integer vertices, a hole inside.
  Polygon outer;
  outer.points = {{5.3, 6.7}, {50.2, 4.1}, {57.6, 30.5}, {31.4, 24.9}, {44.8, 55.2}, {8.9, 51.3}};
  const Polygon hole = regular(18.2, 33.6, 8.3, 7, 0.4);
  const std::vector<Polygon> polys = {outer, hole};
  EXPECT_EQ(check(polys, 64, 64, true), "");

  Grid2u8 contour, inside;
  rasterize_polygons(polys, 64, 64, contour, inside);
  const FillResult f = fill_even_odd(contour);
  EXPECT_EQ(f.max_depth, 2);
  EXPECT_FALSE(inside(18, 34)) << "hole centre " << pixel_at(18, 34);
  EXPECT_TRUE(inside(40, 12)) << pixel_at(40, 12);
}

// even_odd_inside is rasterize_polygons' inside without the contour pixels: a
// pixel an edge crosses whose centre lies outside is outside.
TEST(ContourRasterize, EvenOddInsideLeavesOutContourPixelsWhoseCentreIsOutside) {
  Polygon tri;
  tri.points = {{3.4, 3.2}, {20.6, 5.1}, {9.3, 18.7}};
  const std::vector<Polygon> polys{tri};
  Grid2u8 contour, inside;
  rasterize_polygons(polys, 24, 24, contour, inside);
  const Grid2u8 centres = even_odd_inside(polys, 24, 24);
  int contour_outside = 0;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      ASSERT_EQ(inside(x, y), centres(x, y) | contour(x, y)) << pixel_at(x, y);
      contour_outside += contour(x, y) && !centres(x, y);
    }
  EXPECT_GT(contour_outside, 0) << "no contour pixel with its centre outside: the case is not exercised";
  EXPECT_TRUE(centres(10, 8)) << pixel_at(10, 8);
  EXPECT_FALSE(centres(3, 3)) << pixel_at(3, 3);
}

TEST(ContourRasterize, NestedIslandAndAxisAlignedEdges) {
  // Integer vertices put pixel centres exactly on edges and vertices.
  Polygon a, b, c;
  a.points = {{4, 4}, {60, 4}, {60, 60}, {4, 60}};
  b.points = {{14, 14}, {50, 14}, {50, 50}, {14, 50}};
  c.points = {{24, 24}, {40, 24}, {32, 40}};
  EXPECT_EQ(check({a, b, c}, 64, 64, true), "");
}

TEST(ContourRasterize, PolygonBeyondTheBorderIsClipped) {
  Polygon p;
  p.points = {{-10.5, -3.2}, {30.4, 5.5}, {12.2, 70.1}};
  Grid2u8 contour, inside;
  rasterize_polygons({p}, 32, 48, contour, inside);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 32; ++x)
      if (!contour(x, y)) {
        EXPECT_EQ(bool(inside(x, y)), pnpoly({p}, x, y)) << pixel_at(x, y);
      }
  EXPECT_TRUE(contour(0, 0) || inside(0, 0)) << "the corner lies inside the triangle";
}

TEST(ContourRasterize, DegenerateInput) {
  Grid2u8 contour, inside;
  rasterize_polygons({}, 5, 4, contour, inside);
  EXPECT_EQ(contour, Grid2u8(5, 4));
  EXPECT_EQ(inside, Grid2u8(5, 4));

  Polygon dot;
  dot.points = {{2.4, 1.6}};
  rasterize_polygons({dot, Polygon{}}, 5, 4, contour, inside);
  Grid2u8 want(5, 4);
  want(2, 2) = 1;
  EXPECT_EQ(contour, want);
  EXPECT_EQ(inside, want);

  Polygon bad;
  bad.points = {{1, 1}, {std::numeric_limits<double>::quiet_NaN(), 2}, {3, 1}};
  EXPECT_THROW(rasterize_polygons({bad}, 5, 4, contour, inside), InputError);
  EXPECT_THROW(rasterize_polygons({}, -1, 4, contour, inside), ParamError);
}

TEST(ContourRasterize, SegmentPixelsRunFromEndToEnd) {
  const auto run = detail::segment_pixels({0.4, 0.45}, {10.6, 3.2}, 20, 20);
  ASSERT_FALSE(run.empty());
  EXPECT_EQ(run.front(), (std::array<int, 2>{0, 0}));
  EXPECT_EQ(run.back(), (std::array<int, 2>{11, 3}));
  EXPECT_EQ(run.size(), 12u) << "one pixel per column of an x-major segment";
}

TEST(ContourRasterize, ContourPointsAreRowMajorCentres) {
  Grid2u8 g(4, 3);
  g(3, 0) = g(1, 2) = g(0, 1) = 1;
  const auto pts = contour_points(g);
  ASSERT_EQ(pts.size(), 3u);
  EXPECT_EQ(pts[0], Vec2d(3, 0));
  EXPECT_EQ(pts[1], Vec2d(0, 1));
  EXPECT_EQ(pts[2], Vec2d(1, 2));
}

/// Random convex polygons (vertices on a circle at jittered angles) with, if
/// there is room, a smaller one inside kSeparation away from it.
RC_GTEST_PROP(ContourRasterize, RandomPolygonsAgreeWithPointInPolygonAndFill, ()) {
  constexpr int kSize = 48;
  const double cx = *rc::gen::inRange(2000, 2800) / 100.0;
  const double cy = *rc::gen::inRange(2000, 2800) / 100.0;
  const double r_outer = *rc::gen::inRange(600, 1800) / 100.0;
  auto polygon = [](double x, double y, double r) {
    const int n = *rc::gen::inRange(5, 13);
    Polygon p;
    for (int i = 0; i < n; ++i) {
      const double jitter = *rc::gen::inRange(-20, 21) / 100.0;  // fraction of the angular step
      const double a = 2.0 * std::numbers::pi * (i + jitter) / n;
      p.points.emplace_back(x + r * std::cos(a), y + r * std::sin(a));
    }
    return p;
  };
  std::vector<Polygon> polys = {polygon(cx, cy, r_outer)};
  // Inradius of the outer polygon about (cx, cy): distance to its nearest edge line.
  double inradius = std::numeric_limits<double>::infinity();
  const auto& v = polys[0].points;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Vec2d e = v[(i + 1) % v.size()] - v[i];
    const Vec2d n(-e.y(), e.x());
    inradius = std::min(inradius, std::abs(n.dot(Vec2d(cx, cy) - v[i])) / n.norm());
  }
  const double r_inner_max = inradius - kSeparation - 1.0;
  if (r_inner_max >= 2.0 && *rc::gen::arbitrary<bool>()) {
    const double r_inner = 2.0 + (r_inner_max - 2.0) * *rc::gen::inRange(0, 101) / 100.0;
    polys.push_back(polygon(cx, cy, r_inner));
  }
  const std::string problems = check(polys, kSize, kSize, true);
  if (!problems.empty()) RC_FAIL(problems);
}

}  // namespace
}  // namespace isoloft
