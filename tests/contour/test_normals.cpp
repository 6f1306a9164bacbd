// Contour points and outward normals (paper 2.1): normals of digitised circles
// and ellipses against the analytic normal, orientation of holes, the even-odd
// orientation of polygon samples, and the errors.
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <rapidcheck.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "isoloft/contour/fill.h"
#include "isoloft/contour/normals.h"
#include "isoloft/core/error.h"
#include "test_names.h"

namespace isoloft {
namespace {

/// Normals of a digitised smooth curve with the default sigma (1.5 px) stay
/// within this angle of the true normal. The worst case is a lone one-pixel
/// step in a nearly axis-parallel edge: 14.4 degrees measured over straight
/// edges at 0.1..45 degrees; circles of radius 10, 30, 100 px: max 6.2, 8.4,
/// 10.7 degrees.
constexpr double kMaxNormalAngleDeg = 15.0;
/// ... and on average within this angle (measured 2.4 degrees).
constexpr double kMeanNormalAngleDeg = 3.0;
/// Unit length up to rounding.
constexpr double kUnitTol = 1e-12;

using Sdf = std::function<double(const Vec2d&)>;  // > 0 inside


/// The region sdf > 0 sampled at pixel centres, and its boundary: mask pixels
/// with a 4-neighbour outside the mask (an 8-connected closed curve).
void digitise(const Sdf& sdf, int w, int h, Grid2u8& mask, Grid2u8& contour) {
  mask = Grid2u8(w, h);
  contour = Grid2u8(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) mask(x, y) = sdf(Vec2d(x, y)) > 0.0 ? 1 : 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!mask(x, y)) continue;
      bool edge = x == 0 || y == 0 || x == w - 1 || y == h - 1;
      edge = edge || !mask(x - 1, y) || !mask(x + 1, y) || !mask(x, y - 1) || !mask(x, y + 1);
      contour(x, y) = edge ? 1 : 0;
    }
}

double angle_deg(const Vec2d& a, const Vec2d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

TEST(ContourNormals, CircleNormalsAreRadial) {
  for (double r : {10.0, 30.0, 100.0}) {
    const Vec2d c(130.3, 129.6);  // off the pixel grid: no symmetric staircase
    Grid2u8 mask, contour;
    digitise([&](const Vec2d& p) { return r - (p - c).norm(); }, 260, 260, mask, contour);
    const OrientedPoints op = contour_normals(contour, mask);
    std::size_t pixels = 0;
    for (auto v : contour.data) pixels += v ? 1 : 0;
    ASSERT_EQ(op.size(), pixels) << "radius " << r << ": one point per contour pixel";
    ASSERT_EQ(op.normals.size(), pixels);
    EXPECT_EQ(op.dropped, 0u);
    double sum = 0.0;
    for (std::size_t i = 0; i < op.size(); ++i) {
      const Vec2d& p = op.points[i];
      EXPECT_EQ(contour(static_cast<int>(p.x()), static_cast<int>(p.y())), 1) << point_at(p) << " is not a contour pixel";
      EXPECT_NEAR(op.normals[i].norm(), 1.0, kUnitTol) << point_at(p);
      const double a = angle_deg(op.normals[i], p - c);
      sum += a;
      EXPECT_LE(a, kMaxNormalAngleDeg) << "radius " << r << ", " << point_at(p);
    }
    EXPECT_LE(sum / static_cast<double>(op.size()), kMeanNormalAngleDeg) << "radius " << r;
  }
}

TEST(ContourNormals, EllipseNormalsFollowTheImplicitGradient) {
  const Vec2d c(150.4, 100.7);
  const double a = 120.0, b = 60.0;
  auto implicit = [&](const Vec2d& p) {
    const Vec2d d = p - c;
    return 1.0 - d.x() * d.x() / (a * a) - d.y() * d.y() / (b * b);
  };
  Grid2u8 mask, contour;
  digitise(implicit, 300, 200, mask, contour);
  const OrientedPoints op = contour_normals(contour, mask);
  ASSERT_GT(op.size(), 500u);
  for (std::size_t i = 0; i < op.size(); ++i) {
    const Vec2d d = op.points[i] - c;
    const Vec2d outward(d.x() / (a * a), d.y() / (b * b));  // -grad of the implicit
    EXPECT_LE(angle_deg(op.normals[i], outward), kMaxNormalAngleDeg) << point_at(op.points[i]);
  }
}

TEST(ContourNormals, HoleNormalsPointIntoTheHole) {
  const Vec2d c(80.2, 79.7);
  Grid2u8 mask, contour;
  digitise(
      [&](const Vec2d& p) {
        const double r = (p - c).norm();
        return std::min(60.0 - r, r - 25.0);
      },
      160, 160, mask, contour);
  const OrientedPoints op = contour_normals(contour, mask);
  int inner = 0, outer = 0;
  for (std::size_t i = 0; i < op.size(); ++i) {
    const Vec2d radial = op.points[i] - c;
    const bool is_inner = radial.norm() < 42.5;
    // Inner contour: outward = out of the material = towards the centre.
    const Vec2d want = is_inner ? Vec2d(-radial) : radial;
    EXPECT_LE(angle_deg(op.normals[i], want), kMaxNormalAngleDeg)
        << (is_inner ? "hole " : "outer ") << point_at(op.points[i]);
    (is_inner ? inner : outer)++;
  }
  EXPECT_GT(inner, 100);
  EXPECT_GT(outer, 300);
}

TEST(ContourNormals, WorksWithEvenOddFillOfTheContour) {
  // The pipeline's way: the filled mask comes from fill_even_odd(contour).
  const Vec2d c(60.3, 59.8);
  Grid2u8 mask, contour;
  digitise(
      [&](const Vec2d& p) {
        const double r = (p - c).norm();
        return std::min(45.0 - r, r - 15.0);
      },
      120, 120, mask, contour);
  const FillResult fill = fill_even_odd(contour);
  const OrientedPoints op = contour_normals(contour, fill.inside);
  ASSERT_GT(op.size(), 300u);
  for (std::size_t i = 0; i < op.size(); ++i) {
    const Vec2d radial = op.points[i] - c;
    const Vec2d want = radial.norm() < 30.0 ? Vec2d(-radial) : radial;
    EXPECT_LE(angle_deg(op.normals[i], want), kMaxNormalAngleDeg) << point_at(op.points[i]);
  }
}

TEST(ContourNormals, LineWithoutInsideHasNoNormal) {
  // A one-pixel line x = 5..34 filled as itself: the smoothed mask is
  // symmetric across it, and also along it farther than the kernel radius
  // (ceil(3 sigma) = 5 px) from its ends, where the gradient is 0: those 20
  // pixels are dropped; the 5 at each end get normals along the line, outward.
  Grid2u8 contour(40, 20);
  for (int x = 5; x < 35; ++x) contour(x, 10) = 1;
  const OrientedPoints op = contour_normals(contour, contour);
  EXPECT_EQ(op.dropped, 20u);
  ASSERT_EQ(op.size(), 10u);
  for (std::size_t i = 0; i < op.size(); ++i) {
    const Vec2d want = op.points[i].x() < 20 ? Vec2d(-1.0, 0.0) : Vec2d(1.0, 0.0);
    EXPECT_LE(angle_deg(op.normals[i], want), 1e-6) << point_at(op.points[i]);
  }
}

TEST(ContourNormals, EmptyContourGivesNoPoints) {
  const OrientedPoints op = contour_normals(Grid2u8(10, 10), Grid2u8(10, 10));
  EXPECT_EQ(op.size(), 0u);
  EXPECT_EQ(op.dropped, 0u);
}

TEST(ContourNormals, RejectsBadInput) {
  Grid2u8 g(10, 10);
  EXPECT_THROW(contour_normals(g, Grid2u8(10, 11)), ParamError);
  NormalsParams p;
  p.sigma = 0.0;
  EXPECT_THROW(contour_normals(g, g, p), ParamError);
  p.sigma = std::nan("");
  EXPECT_THROW(contour_normals(g, g, p), ParamError);
}

TEST(ContourNormals, GradientIsAntisymmetricAcrossAStraightEdge) {
  // Left half filled: the gradient at the edge points in +x... of the mask
  // rising to the left, i.e. along -x, with no y component.
  Grid2u8 mask(21, 21);
  for (int y = 0; y < 21; ++y)
    for (int x = 0; x <= 10; ++x) mask(x, y) = 1;
  const Vec2d g = detail::smoothed_mask_gradient(mask, 10, 10, 1.5);
  EXPECT_LT(g.x(), 0.0);
  EXPECT_NEAR(g.y(), 0.0, 1e-15);
}

// ------------------------------------------------------------ polygons

Polygon square(double x0, double y0, double x1, double y1, bool ccw) {
  Polygon p;
  p.points = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  if (!ccw) std::reverse(p.points.begin(), p.points.end());
  return p;
}

/// Outward normal of an axis-aligned box boundary point (not at a corner).
Vec2d box_outward(const Vec2d& p, double x0, double y0, double x1) {
  if (std::abs(p.x() - x0) < 1e-9) return {-1, 0};
  if (std::abs(p.x() - x1) < 1e-9) return {1, 0};
  if (std::abs(p.y() - y0) < 1e-9) return {0, -1};
  return {0, 1};  // y == y1
}

TEST(PolygonPoints, NestedSquaresAreOrientedByEvenOdd) {
  // Outer square, a hole, an island in the hole; orientations deliberately mixed.
  for (bool ccw : {true, false}) {
    const std::vector<Polygon> polys{square(0, 0, 100, 100, ccw), square(20, 20, 80, 80, ccw),
                                     square(40, 40, 60, 60, !ccw)};
    const OrientedPoints op = polygon_points(polys, 0.5);
    ASSERT_EQ(op.size(), static_cast<std::size_t>((400 + 240 + 80) * 2));
    for (std::size_t i = 0; i < op.size(); ++i) {
      const Vec2d& p = op.points[i];
      const bool outer = p.x() == 0 || p.y() == 0 || p.x() == 100 || p.y() == 100;
      const bool island = p.x() >= 40 && p.x() <= 60 && p.y() >= 40 && p.y() <= 60;
      Vec2d want = outer    ? box_outward(p, 0, 0, 100)
                   : island ? box_outward(p, 40, 40, 60)
                            : Vec2d(-box_outward(p, 20, 20, 80));  // hole: into the hole
      // Corner samples take the normal of their edge: check only edge interiors.
      const bool corner = (std::fmod(p.x(), 20.0) == 0.0) && (std::fmod(p.y(), 20.0) == 0.0);
      if (corner) continue;
      EXPECT_LE(angle_deg(op.normals[i], want), 1e-9) << (ccw ? "ccw " : "cw ") << point_at(p);
    }
  }
}

TEST(PolygonPoints, SamplesAreDenseAndIncludeVertices) {
  Polygon tri;
  tri.points = {{0, 0}, {10.3, 0}, {0, 7.1}};
  const double spacing = 0.5;
  const OrientedPoints op = polygon_points({tri}, spacing);
  for (const Vec2d& v : tri.points) {
    bool found = false;
    for (const Vec2d& p : op.points) found = found || (p - v).norm() < 1e-12;
    EXPECT_TRUE(found) << "vertex " << point_at(v) << " is not a sample";
  }
  for (std::size_t i = 0; i < op.size(); ++i) {
    const Vec2d& next = op.points[(i + 1) % op.size()];
    EXPECT_LE((next - op.points[i]).norm(), spacing + 1e-12) << "gap after sample " << i << " " << point_at(op.points[i]);
  }
}

TEST(PolygonPoints, RejectsBadInput) {
  Polygon two;
  two.points = {{0, 0}, {1, 1}};
  EXPECT_THROW(polygon_points({two}), InputError);
  Polygon flat;
  flat.points = {{0, 0}, {1, 1}, {2, 2}};
  EXPECT_THROW(polygon_points({flat}), InputError);
  Polygon nan;
  nan.points = {{0, 0}, {1, std::nan("")}, {2, 0}};
  EXPECT_THROW(polygon_points({nan}), InputError);
  EXPECT_THROW(polygon_points({square(0, 0, 1, 1, true)}, 0.0), ParamError);
  EXPECT_THROW(polygon_points({square(0, 0, 1, 1, true)}, -1.0), ParamError);
  EXPECT_EQ(polygon_points({}).size(), 0u);
}

// The quadratic definition polygon_points() must match bit for bit: every
// edge's two side points tested against every polygon whose box holds them.
OrientedPoints polygon_points_reference(const std::vector<Polygon>& polygons, double spacing) {
  Eigen::AlignedBox2d all;
  std::vector<Eigen::AlignedBox2d> boxes;
  for (const Polygon& poly : polygons) {
    Eigen::AlignedBox2d b;
    for (const Vec2d& v : poly.points) b.extend(v);
    boxes.push_back(b);
    all.extend(b);
  }
  const double eps = 1e-7 * (1.0 + all.diagonal().norm());
  auto inside = [&](const Vec2d& p) {
    bool in = false;
    for (std::size_t k = 0; k < polygons.size(); ++k)
      if (boxes[k].contains(p)) in ^= detail::crossing_parity(polygons[k].points, p);
    return in;
  };
  OrientedPoints out;
  for (const Polygon& poly : polygons) {
    const auto& v = poly.points;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const Vec2d a = v[i], b = v[(i + 1) % v.size()], d = b - a;
      const double len = d.norm();
      if (len == 0.0) continue;
      const Vec2d m(d.y() / len, -d.x() / len), mid = 0.5 * (a + b);
      const bool in_plus = inside(mid + eps * m), in_minus = inside(mid - eps * m);
      const int count = static_cast<int>(std::ceil(len / spacing));
      if (in_plus == in_minus) {
        out.dropped += static_cast<std::size_t>(count);
        continue;
      }
      for (int s = 0; s < count; ++s) {
        out.points.push_back(a + d * (static_cast<double>(s) / count));
        out.normals.push_back(in_plus ? Vec2d(-m) : m);
      }
    }
  }
  return out;
}

// Random polygons, self-intersecting, overlapping, with shared (doubled)
// edges and vertices on a coarse lattice (many exact ties in y): the
// row-bucketed inside test gives the same samples as the definition.
RC_GTEST_PROP(PolygonPoints, MatchesTheQuadraticDefinitionExactly, ()) {
  const int polys = *rc::gen::inRange(1, 5);
  std::vector<Polygon> in;
  for (int k = 0; k < polys; ++k) {
    const int n = *rc::gen::inRange(3, 40);
    Polygon poly;
    for (int i = 0; i < n; ++i) {
      const bool lattice = *rc::gen::arbitrary<bool>();
      const double x = lattice ? *rc::gen::inRange(0, 8) * 10.0 : *rc::gen::inRange(0, 8000) / 100.0;
      const double y = lattice ? *rc::gen::inRange(0, 8) * 10.0 : *rc::gen::inRange(0, 8000) / 100.0;
      poly.points.emplace_back(x, y);
    }
    double area2 = 0.0;
    for (std::size_t i = 0; i < poly.points.size(); ++i) {
      const Vec2d& a = poly.points[i];
      const Vec2d& b = poly.points[(i + 1) % poly.points.size()];
      area2 += a.x() * b.y() - b.x() * a.y();
    }
    RC_PRE(area2 != 0.0);
    in.push_back(std::move(poly));
  }
  if (*rc::gen::arbitrary<bool>()) in.push_back(in.front());  // every edge doubled
  const OrientedPoints got = polygon_points(in, 2.0), want = polygon_points_reference(in, 2.0);
  RC_ASSERT(got.dropped == want.dropped);
  RC_ASSERT(got.points == want.points);
  RC_ASSERT(got.normals == want.normals);
}

// A random convex polygon, any orientation: every normal points away from the
// centroid, and every sample lies on an edge.
RC_GTEST_PROP(PolygonPoints, ConvexPolygonNormalsPointAwayFromCentroid, ()) {
  const int n = *rc::gen::inRange(3, 12);
  std::vector<double> ang;
  for (int k = 0; k < n; ++k) ang.push_back(*rc::gen::inRange(0, 3600) / 10.0 * M_PI / 180.0);
  std::sort(ang.begin(), ang.end());
  ang.erase(std::unique(ang.begin(), ang.end()), ang.end());
  RC_PRE(ang.size() >= 3u);
  const double r = *rc::gen::inRange(5, 200);
  Polygon poly;
  for (double a : ang) poly.points.emplace_back(100 + r * std::cos(a), 100 + r * std::sin(a));
  double area2 = 0.0;
  for (std::size_t i = 0; i < poly.points.size(); ++i) {
    const Vec2d& a = poly.points[i];
    const Vec2d& b = poly.points[(i + 1) % poly.points.size()];
    area2 += a.x() * b.y() - b.x() * a.y();
  }
  RC_PRE(std::abs(area2) > 1.0);  // not degenerate
  if (*rc::gen::arbitrary<bool>()) std::reverse(poly.points.begin(), poly.points.end());
  Vec2d centroid(0, 0);
  for (const Vec2d& p : poly.points) centroid += p;
  centroid /= static_cast<double>(poly.points.size());
  const OrientedPoints op = polygon_points({poly}, 1.0);
  RC_ASSERT(op.size() >= poly.points.size());
  for (std::size_t i = 0; i < op.size(); ++i) {
    RC_ASSERT(std::abs(op.normals[i].norm() - 1.0) < kUnitTol);
    // Strictly positive for a convex polygon containing its vertex centroid.
    if (!(op.normals[i].dot(op.points[i] - centroid) > 0.0))
      RC_FAIL("inward normal at sample " + std::to_string(i) + " " + point_at(op.points[i]));
  }
}

}  // namespace
}  // namespace isoloft
