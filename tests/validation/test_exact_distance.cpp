// Tests of validation/exact_distance.h: the CGAL exact signed-distance oracle
// against its brute-force twin (bit for bit), against the analytic distance
// to a circle, against field/edt.h on contours where both are exact, and the
// marching-squares zero set.
#if defined(ISOLOFT_HAVE_VALIDATION)

#include <gtest/gtest.h>
#include <rapidcheck.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/field/narrow_band.h"
#include "validation/exact_distance.h"
#include "test_names.h"

namespace isoloft {
namespace {


// Bitwise equality (NaN == NaN, +0 != -0): the two versions take the minimum
// of the same exact squared distances and round it once, identically.
std::string bitwise_diff(const Grid2d& got, const Grid2d& want) {
  if (got.width != want.width || got.height != want.height) return "sizes differ";
  for (int y = 0; y < got.height; ++y)
    for (int x = 0; x < got.width; ++x)
      if (std::memcmp(&got(x, y), &want(x, y), sizeof(double)) != 0)
        return pixel_at(x, y) + ": fast " + std::to_string(got(x, y)) + ", brute " + std::to_string(want(x, y));
  return "";
}

Polygon regular_polygon(const Vec2d& c, double r, int n, double phase = 0.0) {
  Polygon p;
  for (int i = 0; i < n; ++i) {
    const double t = phase + 2.0 * M_PI * i / n;
    p.points.emplace_back(c.x() + r * std::cos(t), c.y() + r * std::sin(t));
  }
  return p;
}

// Star-shaped polygon with radii r[i] at equal angles: always simple.
Polygon star(const Vec2d& c, const std::vector<double>& r) {
  Polygon p;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const double t = 2.0 * M_PI * double(i) / double(r.size());
    p.points.emplace_back(c.x() + r[i] * std::cos(t), c.y() + r[i] * std::sin(t));
  }
  return p;
}

TEST(ExactDistance, FastEqualsBruteBitForBit) {
  // Two nested polygons with shared-vertex ties, some pixel centres exactly on
  // edges (the axis-aligned square), and a grid offset.
  const std::vector<Polygon> polys = {
      star(Vec2d(11.3, 12.6), {9.0, 7.5, 10.2, 6.0, 9.9, 8.1, 10.5, 5.5, 9.0, 7.0, 10.0, 6.5}),
      {{{Vec2d(8, 9), Vec2d(14, 9), Vec2d(14, 15), Vec2d(8, 15)}}}};
  const auto segs = polygon_segments(polys);
  for (const double band : {std::numeric_limits<double>::infinity(), 2.5}) {
    const Grid2d fast = detail::exact_unsigned_distance(segs, 24, 26, -0.5, 0.25, band);
    const Grid2d brute = detail::exact_unsigned_distance_brute(segs, 24, 26, -0.5, 0.25, band);
    EXPECT_EQ(bitwise_diff(fast, brute), "") << "band " << band;
  }
  // A small polygon in a corner of a larger grid: most pixels lie outside the
  // bucket grid, where the ring search starts from a clamped cell.
  const auto small = polygon_segments({regular_polygon(Vec2d(3.2, 4.1), 2.5, 9)});
  const Grid2d fast = detail::exact_unsigned_distance(small, 40, 30, 0.0, 0.0, std::numeric_limits<double>::infinity());
  const Grid2d brute = detail::exact_unsigned_distance_brute(small, 40, 30, 0.0, 0.0, std::numeric_limits<double>::infinity());
  EXPECT_EQ(bitwise_diff(fast, brute), "") << "corner polygon";
}

RC_GTEST_PROP(ExactDistance, FastEqualsBruteOnRandomStars, ()) {
  const int n = *rc::gen::inRange(3, 24);
  const auto radii = *rc::gen::container<std::vector<double>>(
      std::size_t(n), rc::gen::map(rc::gen::inRange(10, 80), [](int v) { return v / 10.0; }));
  const Vec2d c(*rc::gen::inRange(40, 120) / 10.0, *rc::gen::inRange(40, 120) / 10.0);
  const auto segs = polygon_segments({star(c, radii)});
  const double band = *rc::gen::element(std::numeric_limits<double>::infinity(), 1.0, 3.0);
  const Grid2d fast = detail::exact_unsigned_distance(segs, 16, 16, 0.0, 0.0, band);
  const Grid2d brute = detail::exact_unsigned_distance_brute(segs, 16, 16, 0.0, 0.0, band);
  RC_ASSERT(bitwise_diff(fast, brute) == "");
}

TEST(ExactDistance, MatchesAnalyticCircle) {
  // 1000-gon inscribed in a circle: its distance field differs from the
  // circle's by at most the Hausdorff distance between them, the sagitta.
  constexpr int kN = 200, kSides = 1000;
  constexpr double kR = 80.0;
  const Vec2d c(99.7, 100.2);
  const double sagitta = kR * (1.0 - std::cos(M_PI / kSides));
  constexpr double kRounding = 1e-12;  // sqrt of a correctly rounded square: ~1 ulp at 100 px
  const Grid2d d = exact_signed_distance({regular_polygon(c, kR, kSides)}, kN, kN);
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) {
      const double a = kR - (Vec2d(x, y) - c).norm();
      ASSERT_NEAR(d(x, y), a, sagitta + kRounding) << pixel_at(x, y);
    }
}

TEST(ExactDistance, BandLeavesFarPixelsUnset) {
  constexpr double kBand = 3.0;
  const Vec2d c(20.2, 19.9);
  const Grid2d d = exact_signed_distance({regular_polygon(c, 10.0, 64)}, 40, 40, 0, 0, kBand);
  const Grid2d full = exact_signed_distance({regular_polygon(c, 10.0, 64)}, 40, 40);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) {
      if (std::abs(full(x, y)) <= kBand) {
        ASSERT_EQ(d(x, y), full(x, y)) << pixel_at(x, y);
      } else {
        ASSERT_TRUE(std::isnan(d(x, y))) << pixel_at(x, y);
      }
    }
}

TEST(ExactDistance, EvenOddNesting) {
  // An annulus (outer and inner square): the hole is outside.
  const std::vector<Polygon> polys = {{{Vec2d(2.5, 2.5), Vec2d(17.5, 2.5), Vec2d(17.5, 17.5), Vec2d(2.5, 17.5)}},
                                      {{Vec2d(7.5, 7.5), Vec2d(12.5, 7.5), Vec2d(12.5, 12.5), Vec2d(7.5, 12.5)}}};
  const Grid2d d = exact_signed_distance(polys, 20, 20);
  EXPECT_EQ(d(10, 10), -2.5) << "centre of the hole";
  EXPECT_EQ(d(5, 5), 2.5) << "inside the ring";
  EXPECT_EQ(d(0, 10), -2.5) << "outside";
}

// A contour image of axis-aligned rectangles whose corners are pixel centres:
// the nearest point of such a polygon to a pixel centre is a pixel centre of
// the contour, so the EDT to the contour pixels is the exact polygon distance.
struct RectScene {
  Grid2u8 contour, inside;
  std::vector<Polygon> polygons;
};
RectScene rect_scene(int w, int h, const std::vector<std::array<int, 4>>& rects) {
  RectScene s{Grid2u8(w, h, 0), Grid2u8(w, h, 0), {}};
  for (const auto& [x0, y0, x1, y1] : rects) {
    s.polygons.push_back({{Vec2d(x0, y0), Vec2d(x1, y0), Vec2d(x1, y1), Vec2d(x0, y1)}});
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        if (x == x0 || x == x1 || y == y0 || y == y1) s.contour(x, y) = 1;
        else s.inside(x, y) ^= 1;  // even-odd
      }
  }
  return s;
}

TEST(ExactDistance, AgreesWithEdtOnPixelRectangles) {
  // float storage of the EDT: half an ulp at 64 px.
  constexpr double kFloatTol = 4e-6;
  const RectScene s = rect_scene(64, 48, {{5, 4, 58, 43}, {20, 15, 40, 30}});
  const Grid2f field = distance_to_contour_signed(s.contour, s.inside);
  const FieldErrorReport r = compare_field(field, s.polygons);
  EXPECT_EQ(r.pixels_checked, 64 * 48);
  EXPECT_LE(r.max_abs_error, kFloatTol) << "worst " << pixel_at(r.worst_x, r.worst_y);
  EXPECT_EQ(r.sign_errors, 0) << "first at " << pixel_at(r.first_sign_error_x, r.first_sign_error_y);
}

TEST(ExactDistance, CompareFieldFindsInjectedErrors) {
  constexpr double kFloatTol = 4e-6;     // as above
  constexpr float kInjected = 0.25f;     // well above kFloatTol, well below a pixel
  constexpr int kBadX = 37, kBadY = 21;  // inside the inner rectangle's ring
  constexpr int kFlipX = 50, kFlipY = 10;
  const RectScene s = rect_scene(64, 48, {{5, 4, 58, 43}, {20, 15, 40, 30}});
  Grid2f field = distance_to_contour_signed(s.contour, s.inside);
  field(kBadX, kBadY) += kInjected;
  field(kFlipX, kFlipY) = -field(kFlipX, kFlipY);
  const FieldErrorReport r = compare_field(field, s.polygons);
  ASSERT_GT(std::abs(field(kFlipX, kFlipY)), 2 * kInjected) << "the flipped pixel must dominate";
  EXPECT_EQ(r.worst_x, kFlipX);
  EXPECT_EQ(r.worst_y, kFlipY);
  EXPECT_EQ(r.sign_errors, 1);
  EXPECT_EQ(r.first_sign_error_x, kFlipX);
  EXPECT_EQ(r.first_sign_error_y, kFlipY);

  // Without the flip, the injected error is the worst.
  field(kFlipX, kFlipY) = -field(kFlipX, kFlipY);
  const FieldErrorReport r2 = compare_field(field, s.polygons);
  EXPECT_EQ(r2.worst_x, kBadX);
  EXPECT_EQ(r2.worst_y, kBadY);
  EXPECT_NEAR(r2.max_abs_error, kInjected, kFloatTol);
  EXPECT_EQ(r2.sign_errors, 0);
  EXPECT_NEAR(r2.mean_abs_error, kInjected / (64.0 * 48.0), kFloatTol);
}

TEST(ExactDistance, CompareFieldBandSkipsFarPixels) {
  constexpr double kBand = 4.0;
  const RectScene s = rect_scene(64, 48, {{5, 4, 58, 43}});
  Grid2f field = distance_to_contour_signed(s.contour, s.inside);
  field(31, 24) = 0.0f;  // 19 px from the contour: outside the band, not checked
  const FieldErrorReport r = compare_field(field, s.polygons, 0, 0, kBand);
  EXPECT_LT(r.max_abs_error, 1e-5) << "worst " << pixel_at(r.worst_x, r.worst_y);
  EXPECT_LT(r.pixels_checked, 64 * 48);
}

Grid2f sample_circle(int n, const Vec2d& c, double r) {
  Grid2f g(n, n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) g(x, y) = float(r - (Vec2d(x, y) - c).norm());
  return g;
}

TEST(ExactDistance, ZeroSetPolygonsOfAnnulus) {
  constexpr int kN = 64;
  const Vec2d c(31.4, 32.3);
  constexpr double kOuter = 25.0, kInner = 9.0;
  auto annulus = [&](const Vec2d& p) {
    const double rho = (p - c).norm();
    return std::min(kOuter - rho, rho - kInner);
  };
  Grid2f f(kN, kN);
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) f(x, y) = float(annulus(Vec2d(x, y)));
  // Bisection on the function puts every vertex on a circle to ~1e-13 px.
  constexpr double kVertexTol = 1e-9;
  const auto polys = zero_set_polygons(f, 0, 0, annulus);
  ASSERT_EQ(polys.size(), 2u);
  for (std::size_t k = 0; k < polys.size(); ++k)
    for (std::size_t i = 0; i < polys[k].points.size(); ++i) {
      const double rho = (polys[k].points[i] - c).norm();
      ASSERT_LT(std::min(std::abs(rho - kOuter), std::abs(rho - kInner)), kVertexTol)
          << "polygon " << k << " vertex " << i;
    }
  // The exact field of the polygons is the annulus distance up to the chord
  // sagitta: a cell chord L <= sqrt(2) on radius R is at most L^2 / (8 R) off.
  const double sagitta = 2.0 / (8.0 * kInner);
  const Grid2d d = exact_signed_distance(polys, kN, kN);
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) ASSERT_NEAR(d(x, y), annulus(Vec2d(x, y)), sagitta) << pixel_at(x, y);
}

TEST(ExactDistance, ZeroSetPolygonsWithoutRefinementAndSaddles) {
  // Linear interpolation of a circle's samples: vertices within 1/(8 r) px
  // (|f''| <= 1/r along an edge, |grad f| = 1) of the circle.
  constexpr double kR = 12.0;
  const Vec2d c(15.5, 15.5);
  const auto polys = zero_set_polygons(sample_circle(32, c, kR));
  ASSERT_EQ(polys.size(), 1u);
  for (std::size_t i = 0; i < polys[0].points.size(); ++i)
    ASSERT_NEAR((polys[0].points[i] - c).norm(), kR, 1.0 / (8.0 * kR) + 1e-6) << "vertex " << i;
  // A checkerboard saddle: two diagonal inside pixels; the mean of the cell is
  // > 0, so they are joined into one loop.
  Grid2f g(4, 4, -1.0f);
  g(1, 1) = 2.0f;
  g(2, 2) = 2.0f;
  EXPECT_EQ(zero_set_polygons(g).size(), 1u);
  g(1, 1) = 0.5f;
  g(2, 2) = 0.5f;  // mean < 0: two separate loops
  EXPECT_EQ(zero_set_polygons(g).size(), 2u);
}

TEST(ExactDistance, SegmentOverloadMatchesPolygonOverload) {
  const Vec2d c(15.2, 16.1);
  const Polygon p = regular_polygon(c, 9.0, 40);
  const Grid2d by_poly = exact_signed_distance({p}, 32, 32);
  const Grid2u8 inside = detail::exact_inside({p}, 32, 32, 0, 0);
  const Grid2d by_segs = exact_signed_distance(polygon_segments({p}), inside);
  EXPECT_EQ(bitwise_diff(by_segs, by_poly), "");
}

TEST(ExactDistance, NarrowBandOfCircleIsExact) {
  // The oracle's intended use (paper 2.2): the narrow band's distances to its
  // own zero-set segments, and to an independent marching-squares zero set
  // refined on the same f, must be exact up to float storage.
  constexpr int kN = 128;
  const Vec2d c(63.3, 64.7);
  constexpr double kR = 40.0;
  const ImplicitFn f = [&](const Vec2d& p) { return kR * kR - (p - c).squaredNorm(); };
  Grid2f samples(kN, kN);
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x) samples(x, y) = float(f(Vec2d(x, y)));
  const NarrowBandParams params;
  const NarrowBandResult nb = narrow_band_distance(samples, f, params);
  // Float storage: half an ulp at the band's 4 px is 2.4e-7 px.
  constexpr double kFloatTol = 1e-6;
  // Pixels at exactly band_width may fall either side of the band's test.
  constexpr double kBandEdge = 1e-3;
  const double band = params.band_width - kBandEdge;
  const FieldErrorReport own = compare_field(nb.distance, nb.segments, nb.inside, 0, 0, band);
  EXPECT_GT(own.pixels_checked, 1000);
  EXPECT_LE(own.max_abs_error, kFloatTol) << "worst " << pixel_at(own.worst_x, own.worst_y);
  EXPECT_EQ(own.sign_errors, 0) << "first at " << pixel_at(own.first_sign_error_x, own.first_sign_error_y);
  // Independent vertices (bisection) differ from the band's (Illinois) by ~1e-9 px.
  const FieldErrorReport indep = compare_field(nb.distance, zero_set_polygons(samples, 0, 0, f), 0, 0, band);
  EXPECT_LE(indep.max_abs_error, kFloatTol) << "worst " << pixel_at(indep.worst_x, indep.worst_y);
  EXPECT_EQ(indep.sign_errors, 0) << "first at " << pixel_at(indep.first_sign_error_x, indep.first_sign_error_y);
}

TEST(ExactDistance, BadInputThrows) {
  EXPECT_THROW(exact_signed_distance({{{Vec2d(0, 0), Vec2d(1, 0)}}}, 4, 4), InputError);
  EXPECT_THROW(exact_signed_distance({regular_polygon(Vec2d(2, 2), 1, 5)}, -1, 4), ParamError);
  EXPECT_THROW(exact_signed_distance({regular_polygon(Vec2d(2, 2), 1, 5)}, 4, 4, 0, 0, -1.0), ParamError);
  Grid2f f = sample_circle(16, Vec2d(7.5, 7.5), 9.0);  // corners outside, edge midpoints inside: leaves the grid
  EXPECT_THROW(zero_set_polygons(f), InputError);
  f(3, 3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(zero_set_polygons(f), InputError);
  const std::vector<Polygon> tri = {regular_polygon(Vec2d(2, 2), 1, 5)};
  EXPECT_THROW(compare_field(Grid2f(3, 3), polygon_segments(tri), Grid2u8(4, 4)), ParamError);
  Grid2f nan_field(4, 4, 0.0f);
  nan_field(1, 2) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(compare_field(nan_field, tri), InputError);
}

}  // namespace
}  // namespace isoloft

#endif  // ISOLOFT_HAVE_VALIDATION
