// Tests of field/narrow_band.h: exact signed distance to the zero set of an
// implicit curve in a band around it (paper 2.2).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "isoloft/contour/rasterize.h"
#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/field/narrow_band.h"
#include "test_names.h"

namespace isoloft {
namespace {

constexpr int kN = 128;
constexpr double kR = 40.0;
const Vec2d kC(63.3, 64.7);  // off the pixel lattice, so no pixel sits on a symmetry tie
// Distances are stored as float; below 128 px half an ulp is 3.8e-6 px.
constexpr double kFloatTol = 1e-5;
// Longest marching-squares chord: the diagonal of a cell.
constexpr double kCellChord = 1.41421356237309504880;
// Largest gap between an arc of radius r and its chord of length L.
constexpr double sagitta(double chord, double r) { return chord * chord / (8.0 * r); }
// Linear interpolation of f = r^2 - |p - c|^2 along a unit edge misses f by
// at most |f''| / 8 = 1/4; with |grad f| = 2r that moves the zero by <= 1/(8r).
constexpr double kLinearVertexTol = 1.0 / (8.0 * kR);

double analytic(const Vec2d& p) { return kR - (p - kC).norm(); }

Grid2f sample(const ImplicitFn& f, int w, int h) {
  Grid2f g(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) g(x, y) = float(f(Vec2d(x, y)));
  return g;
}


// Every known pixel within `tol` of the analytic circle distance, every pixel
// clearly inside the band known, signs those of f.
void expect_circle_band(const NarrowBandResult& r, double band_width, double tol) {
  for (int y = 0; y < kN; ++y) {
    for (int x = 0; x < kN; ++x) {
      const double a = analytic(Vec2d(x, y));
      ASSERT_EQ(r.inside(x, y), a > 0.0 ? 1 : 0) << pixel_at(x, y);
      if (r.known(x, y)) {
        ASSERT_NEAR(r.distance(x, y), a, tol) << pixel_at(x, y);
      } else {
        ASSERT_GT(std::abs(a), band_width - tol) << pixel_at(x, y) << " should be in the band";
        ASSERT_EQ(std::abs(r.distance(x, y)), kNoSurfaceDistance) << pixel_at(x, y);
        ASSERT_EQ(r.distance(x, y) > 0.0f, a > 0.0) << pixel_at(x, y);
      }
    }
  }
}

TEST(NarrowBand, DistanceImplicitMatchesAnalyticCircle) {
  const ImplicitFn f = [](const Vec2d& p) { return kR - (p - kC).norm(); };
  const NarrowBandResult r = narrow_band_distance(sample(f, kN, kN), f);
  expect_circle_band(r, NarrowBandParams{}.band_width, sagitta(kCellChord, kR) + kFloatTol);
}

TEST(NarrowBand, NonDistanceImplicitGivesTheSameDistance) {
  // Same zero set, |f| / |grad f| would be off by up to band^2 / (2r) = 0.2 px.
  const ImplicitFn f = [](const Vec2d& p) { return kR * kR - (p - kC).squaredNorm(); };
  const NarrowBandResult r = narrow_band_distance(sample(f, kN, kN), f);
  expect_circle_band(r, NarrowBandParams{}.band_width, sagitta(kCellChord, kR) + kFloatTol);
}

TEST(NarrowBand, SamplesOnlyUseLinearVertices) {
  const ImplicitFn f = [](const Vec2d& p) { return kR * kR - (p - kC).squaredNorm(); };
  const NarrowBandResult r = narrow_band_distance(sample(f, kN, kN), ImplicitFn{});
  expect_circle_band(r, NarrowBandParams{}.band_width, sagitta(kCellChord, kR) + kLinearVertexTol + kFloatTol);
}

TEST(NarrowBand, SegmentSplitsFollowATightCircle) {
  constexpr double r = 5.0;
  constexpr int kSplits = 4;
  // Pieces are about chord / kSplits long; the radial projection stretches the
  // middle ones by R / (R - sagitta) < 1.05 at R = 5.
  constexpr double kTol = sagitta(1.05 * kCellChord / kSplits, r) + kFloatTol;
  const ImplicitFn f = [](const Vec2d& p) { return r * r - (p - kC).squaredNorm(); };
  NarrowBandParams params;
  params.segment_splits = kSplits;
  const NarrowBandResult res = narrow_band_distance(sample(f, kN, kN), f, params);
  int known = 0;
  for (int y = 0; y < kN; ++y)
    for (int x = 0; x < kN; ++x)
      if (res.known(x, y)) {
        ++known;
        ASSERT_NEAR(res.distance(x, y), r - (Vec2d(x, y) - kC).norm(), kTol) << pixel_at(x, y);
      }
  EXPECT_GT(known, 100);
}

TEST(NarrowBand, EdgeZeroLandsOnTheCurve) {
  constexpr double kRootTol = 1e-9;  // px; Illinois converges superlinearly, 8 steps suffice
  const ImplicitFn f = [](const Vec2d& p) { return kR * kR - (p - kC).squaredNorm(); };
  int tested = 0;
  for (int y = 0; y + 1 < kN; ++y) {
    for (int x = 0; x + 1 < kN; ++x) {
      const Vec2d a(x, y), b(x + 1, y);
      const double fa = f(a), fb = f(b);
      if ((fa > 0.0) == (fb > 0.0)) continue;
      const Vec2d v = detail::edge_zero(a, fa, b, fb, f, NarrowBandParams{}.refine_iterations);
      ASSERT_NEAR((v - kC).norm(), kR, kRootTol) << "edge from " << pixel_at(x, y);
      ASSERT_GE(v.x(), a.x()) << "edge from " << pixel_at(x, y);
      ASSERT_LE(v.x(), b.x()) << "edge from " << pixel_at(x, y);
      ++tested;
    }
  }
  EXPECT_GT(tested, 100);
}

TEST(NarrowBand, LinksCloseTheCurve) {
  const ImplicitFn f = [](const Vec2d& p) { return kR - (p - kC).norm(); };
  const NarrowBandResult r = narrow_band_distance(sample(f, kN, kN), f);
  ASSERT_EQ(r.links.size(), r.segments.size());
  for (std::size_t k = 0; k < r.segments.size(); ++k) {
    for (int e = 0; e < 2; ++e) {
      const std::int32_t n = r.links[k][e];
      ASSERT_GE(n, 0) << "segment " << k << " end " << e << " is open on a closed circle";
      // The neighbour links back and shares this end point exactly.
      const auto& back = r.links[std::size_t(n)];
      const int be = back[0] == std::int32_t(k) ? 0 : 1;
      ASSERT_EQ(back[be], std::int32_t(k)) << "segment " << k << " end " << e;
      ASSERT_EQ(r.segments[std::size_t(n)][be], r.segments[k][e]) << "segment " << k << " end " << e;
    }
  }
}

// polygon_narrow_band (drawn polygons): a concave outline with a triangular
// hole, one vertex repeated and the first repeated at the end. The band is the
// exact distance to the edges (a brute-force twin over the edges listed by
// hand), signed by the even-odd rule; repeats add no edge; links go around.
TEST(NarrowBand, PolygonBandIsTheExactDistanceToTheDrawnEdges) {
  constexpr int kSize = 64;
  Polygon outer, hole;
  outer.points = {{5.3, 6.7}, {50.2, 4.1}, {50.2, 4.1}, {57.6, 30.5}, {31.4, 24.9}, {44.8, 55.2}, {8.9, 51.3}, {5.3, 6.7}};
  hole.points = {{15.2, 30.1}, {22.7, 29.4}, {21.9, 38.8}};
  const std::vector<Polygon> polys{outer, hole};
  const std::vector<Vec2d> o{{5.3, 6.7}, {50.2, 4.1}, {57.6, 30.5}, {31.4, 24.9}, {44.8, 55.2}, {8.9, 51.3}};
  std::vector<Segment2d> edges;
  const std::vector<Vec2d>& h = hole.points;
  for (const std::vector<Vec2d>* loop : {&o, &h})
    for (std::size_t i = 0; i < loop->size(); ++i) edges.push_back(Segment2d{(*loop)[i], (*loop)[(i + 1) % loop->size()]});
  const Grid2u8 inside = even_odd_inside(polys, kSize, kSize);
  const NarrowBandParams params;
  const NarrowBandResult r = polygon_narrow_band(polys, inside, params);
  ASSERT_EQ(r.segments.size(), edges.size());
  const Grid2d brute = detail::distance_to_segments_brute(edges, kSize, kSize);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      ASSERT_EQ(r.inside(x, y), inside(x, y)) << pixel_at(x, y);
      if (r.known(x, y)) {
        ASSERT_NEAR(std::abs(r.distance(x, y)), brute(x, y), kFloatTol) << pixel_at(x, y);
        ASSERT_EQ(r.distance(x, y) > 0.0f, inside(x, y) == 1) << pixel_at(x, y);
      } else {
        ASSERT_GT(brute(x, y), params.band_width) << pixel_at(x, y) << " should be in the band";
      }
    }
  for (std::size_t k = 0; k < r.segments.size(); ++k)
    for (int e = 0; e < 2; ++e) {
      const std::int32_t n = r.links[k][e];
      ASSERT_GE(n, 0) << "segment " << k << " end " << e << " is open on a closed polygon";
      ASSERT_EQ(r.links[std::size_t(n)][1 - e], std::int32_t(k)) << "segment " << k << " end " << e;
      ASSERT_EQ(r.segments[std::size_t(n)][1 - e], r.segments[k][e]) << "segment " << k << " end " << e;
    }
  EXPECT_THROW(polygon_narrow_band(polys, Grid2u8{}), InputError);
}

TEST(NarrowBand, SaddleFollowsTheCentreValue) {
  // Case 5: (0,0) and (1,1) inside, (1,0) and (0,1) outside.
  Grid2f s(2, 2);
  s(0, 0) = 1.0f;
  s(1, 0) = -1.0f;
  s(1, 1) = 1.0f;
  s(0, 1) = -1.0f;
  for (const double centre : {+0.5, -0.5}) {
    const ImplicitFn f = [&](const Vec2d& p) {
      // Bilinear through the corners, plus a bump that sets the centre value.
      const double bilinear = (1 - p.x()) * (1 - p.y()) * s(0, 0) + p.x() * (1 - p.y()) * s(1, 0) +
                              p.x() * p.y() * s(1, 1) + (1 - p.x()) * p.y() * s(0, 1);
      return bilinear + centre * 16.0 * p.x() * (1 - p.x()) * p.y() * (1 - p.y());
    };
    const NarrowBandResult r = narrow_band_distance(s, f);
    ASSERT_EQ(r.segments.size(), 2u);
    // Centre inside: the two outside corners are cut off, else the inside ones.
    const std::vector<Vec2d> cut = centre > 0 ? std::vector<Vec2d>{Vec2d(1, 0), Vec2d(0, 1)}
                                              : std::vector<Vec2d>{Vec2d(0, 0), Vec2d(1, 1)};
    for (const auto& sg : r.segments) {
      bool around = false;
      for (const Vec2d& c : cut) around |= (sg[0] - c).norm() < 1.0 && (sg[1] - c).norm() < 1.0;
      EXPECT_TRUE(around) << "centre " << centre << ": segment (" << sg[0].transpose() << ") - ("
                          << sg[1].transpose() << ") cuts off no expected corner";
    }
  }
}

TEST(NarrowBand, NoZeroCrossingLeavesOnlySigns) {
  const Grid2f all_in(8, 6, 2.0f), all_out(8, 6, -2.0f);
  for (const Grid2f* g : {&all_in, &all_out}) {
    const NarrowBandResult r = narrow_band_distance(*g, ImplicitFn{});
    EXPECT_TRUE(r.segments.empty());
    const float expected = g->data[0] > 0 ? kNoSurfaceDistance : -kNoSurfaceDistance;
    for (int y = 0; y < g->height; ++y)
      for (int x = 0; x < g->width; ++x) {
        ASSERT_EQ(r.known(x, y), 0) << pixel_at(x, y);
        ASSERT_EQ(r.distance(x, y), expected) << pixel_at(x, y);
      }
  }
}

TEST(NarrowBand, RejectsBadInput) {
  EXPECT_THROW(narrow_band_distance(Grid2f(), ImplicitFn{}), InputError);
  Grid2f nan(4, 4, 1.0f);
  nan(2, 3) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(narrow_band_distance(nan, ImplicitFn{}), InputError);
  const Grid2f ok(4, 4, 1.0f);
  NarrowBandParams p;
  p.band_width = 1.0;
  EXPECT_THROW(narrow_band_distance(ok, ImplicitFn{}, p), ParamError);
  p = {};
  p.refine_iterations = -1;
  EXPECT_THROW(narrow_band_distance(ok, ImplicitFn{}, p), ParamError);
  p = {};
  p.segment_splits = 0;
  EXPECT_THROW(narrow_band_distance(ok, ImplicitFn{}, p), ParamError);
}

// Random unions of circles: the band equals the naive twin (distance to all
// segments) at every known pixel, and holds every pixel within band_width.
RC_GTEST_PROP(NarrowBand, BandIsExactDistanceToAllSegments, ()) {
  constexpr int n = 40;
  constexpr double kTieTol = 1e-9;  // px; pixels at band_width up to rounding may go either way
  const int count = *rc::gen::inRange(1, 5);
  std::vector<std::pair<Vec2d, double>> circles;
  for (int k = 0; k < count; ++k)
    circles.push_back({Vec2d(*rc::gen::inRange(0, 100 * n) / 100.0, *rc::gen::inRange(0, 100 * n) / 100.0),
                       *rc::gen::inRange(100, 1500) / 100.0});
  const ImplicitFn f = [&](const Vec2d& p) {
    double m = -std::numeric_limits<double>::infinity();
    for (const auto& [c, r] : circles) m = std::max(m, r - (p - c).norm());
    return m;
  };
  NarrowBandParams params;
  params.band_width = *rc::gen::inRange(142, 800) / 100.0;
  const bool use_f = *rc::gen::arbitrary<bool>();
  const Grid2f s = sample(f, n, n);
  const NarrowBandResult r = narrow_band_distance(s, use_f ? f : ImplicitFn{}, params);
  const Grid2d brute = detail::distance_to_segments_brute(r.segments, n, n);
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      if (r.inside(x, y) != (s(x, y) > 0.0f)) RC_FAIL("inside flag differs from f at " + pixel_at(x, y));
      if (r.known(x, y)) {
        if (std::abs(std::abs(double(r.distance(x, y))) - brute(x, y)) > kFloatTol)
          RC_FAIL("band " + std::to_string(r.distance(x, y)) + " vs brute " + std::to_string(brute(x, y)) + " at " +
                  pixel_at(x, y));
        if ((r.distance(x, y) < 0.0f) == bool(r.inside(x, y)) && r.distance(x, y) != 0.0f)
          RC_FAIL("sign differs from f at " + pixel_at(x, y));
        const std::int32_t k = r.nearest_segment(x, y);
        if (k < 0 || std::size_t(k) >= r.segments.size()) RC_FAIL("no nearest segment at " + pixel_at(x, y));
      } else if (brute(x, y) <= params.band_width - kTieTol) {
        RC_FAIL("pixel at distance " + std::to_string(brute(x, y)) + " missing from the band at " + pixel_at(x, y));
      }
    }
  }
}

}  // namespace
}  // namespace isoloft
