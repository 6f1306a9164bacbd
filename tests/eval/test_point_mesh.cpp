// eval/point_mesh.h: distances from points to a mesh over its triangle grid
// and its rounds near the points' planes equal the brute-force minimum over
// every triangle (the same point-triangle distance, the decimator's, whose own
// tests cover it: what is tested here is which triangles the search visits),
// and the summary's percentile is a nearest-rank one.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "isoloft/eval/point_mesh.h"
#include "isoloft/mesh/decimate_bound.h"
#include "isoloft/mesh/marching_cubes.h"

using namespace isoloft;

namespace {

// Both take the same point-triangle distance in double from the same float
// corners: a visited set that misses the nearest triangle shows as far more
// than this.
constexpr double kRounding = 1e-9;

// A Marching Cubes sphere of radius 9 in a 24^3 grid: ~2k small triangles.
TriMesh sphere_mesh() {
  std::vector<Grid2f> planes;
  std::vector<double> z;
  for (int k = 0; k < 24; ++k) {
    Grid2f g(24, 24);
    for (int y = 0; y < 24; ++y)
      for (int x = 0; x < 24; ++x) g(x, y) = float(9.0 - std::sqrt((x - 11.5) * (x - 11.5) + (y - 12.0) * (y - 12.0) + (k - 11.7) * (k - 11.7)));
    planes.push_back(std::move(g));
    z.push_back(k);
  }
  return marching_cubes(planes, z);
}

TEST(PointMesh, GridDistancesEqualTheBruteForceMinimum) {
  const TriMesh mesh = sphere_mesh();
  ASSERT_GT(mesh.triangles.size(), 1000u);
  std::vector<detail::PreparedTriangle> tris;
  for (const auto& t : mesh.triangles)
    tris.emplace_back(mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(), mesh.vertices[t[2]].cast<double>());
  std::mt19937 rng(24);
  std::uniform_real_distribution<double> u(-10.0, 34.0);  // inside, near and well beyond the mesh's box
  std::vector<Vec3d> points;
  for (int i = 0; i < 400; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  const std::vector<double> got = point_mesh_distances(mesh, points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : tris) best = std::min(best, t.distance_sq(points[i]));
    EXPECT_NEAR(got[i], std::sqrt(best), kRounding) << "point " << i;
  }
  EXPECT_TRUE(std::isinf(point_mesh_distances(TriMesh{}, {Vec3d(0, 0, 0)}).front()));
}

// Points on three planes, as contour vertices are: the first rounds search
// only the triangles near those planes, later rounds farther (points up to
// 22 px off the mesh), and every distance is still the brute-force minimum.
TEST(PointMesh, PointsOnAFewPlanesEqualTheBruteForceMinimum) {
  const TriMesh mesh = sphere_mesh();
  std::vector<detail::PreparedTriangle> tris;
  for (const auto& t : mesh.triangles)
    tris.emplace_back(mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(), mesh.vertices[t[2]].cast<double>());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-10.0, 34.0);
  std::vector<Vec3d> points;
  for (const double z : {5.0, 11.7, 16.25})
    for (int i = 0; i < 150; ++i) points.emplace_back(u(rng), u(rng), z);
  const std::vector<double> got = point_mesh_distances(mesh, points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : tris) best = std::min(best, t.distance_sq(points[i]));
    EXPECT_NEAR(got[i], std::sqrt(best), kRounding) << "point " << i;
  }
}

// Points as contour vertices are: on planes, on or near the surface (most
// within the first round's reach, some a round or two farther, a few beyond
// the rounds from the triangles to the points), some on a large flat triangle
// (offered to its planes' points, not cell by cell): each distance is the
// brute-force minimum, bit for bit (the same expression, least of the same set).
TEST(PointMesh, PointsNearTheSurfaceEqualTheBruteForceMinimumExactly) {
  TriMesh mesh = sphere_mesh();
  const auto v = std::int32_t(mesh.vertices.size());
  for (const Vec3f& c : {Vec3f(-6, -6, 3), Vec3f(30, -6, 3), Vec3f(12, 30, 3)}) mesh.vertices.push_back(c);
  mesh.triangles.push_back({v, v + 1, v + 2});
  std::vector<detail::PreparedTriangle> tris;
  for (const auto& t : mesh.triangles)
    tris.emplace_back(mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(), mesh.vertices[t[2]].cast<double>());
  std::mt19937 rng(54);
  std::uniform_real_distribution<double> angle(0.0, 6.283185307179586), off(-0.3, 0.3), far(-6.0, 6.0);
  std::vector<Vec3d> points;
  for (const double z : {5.0, 11.7, 16.25}) {
    const double r = std::sqrt(81.0 - (z - 11.7) * (z - 11.7));
    for (int i = 0; i < 200; ++i) {
      const double a = angle(rng), rr = r + (i % 10 == 0 ? far(rng) : off(rng));
      points.emplace_back(11.5 + rr * std::cos(a), 12.0 + rr * std::sin(a), z);
    }
  }
  for (int i = 0; i < 20; ++i) points.emplace_back(far(rng) + 8.0, far(rng) - 2.0, 3.0);  // on the flat triangle
  const std::vector<double> got = point_mesh_distances(mesh, points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : tris) best = std::min(best, t.distance_sq(points[i]));
    EXPECT_EQ(got[i], std::sqrt(best)) << "point " << i;
  }
}

// A few points far from the mesh (as specks a grid drops): searched by their
// own boxes, round after round, until the nearest triangle is in reach.
TEST(PointMesh, AFewFarPointsEqualTheBruteForceMinimum) {
  const TriMesh mesh = sphere_mesh();
  std::vector<detail::PreparedTriangle> tris;
  for (const auto& t : mesh.triangles)
    tris.emplace_back(mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(), mesh.vertices[t[2]].cast<double>());
  const std::vector<Vec3d> points{{-8.0, 12.0, 11.7}, {40.0, 30.0, 5.0}, {11.5, 12.0, 11.7}, {30.0, -6.0, 20.0}};
  const std::vector<double> got = point_mesh_distances(mesh, points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& t : tris) best = std::min(best, t.distance_sq(points[i]));
    EXPECT_GT(std::sqrt(best), 5.0) << "point " << i << " should be far from the mesh";
    EXPECT_NEAR(got[i], std::sqrt(best), kRounding) << "point " << i;
  }
}

// Small triangles (the sphere's, bucketed by their box centres) with a few
// large ones (bucketed in every cell their boxes meet, as a decimated or
// capped mesh has): points whose nearest triangle is of either kind still get
// the brute-force minimum.
TEST(PointMesh, LargeTrianglesAmongSmallOnesEqualTheBruteForceMinimum) {
  TriMesh mesh = sphere_mesh();
  const std::size_t small = mesh.triangles.size();
  // A wide flat triangle under the sphere, a long sliver beside it, a tall one across z.
  const std::vector<std::array<Vec3f, 3>> large{{Vec3f(-6, -6, -3), Vec3f(30, -6, -3), Vec3f(12, 30, -3)},
                                                {Vec3f(-4, 26, 2), Vec3f(28, 26.5f, 2.5f), Vec3f(28, 26, 3)},
                                                {Vec3f(27, -2, -2), Vec3f(27.5f, 25, 12), Vec3f(27, 0, 27)}};
  for (const auto& t : large) {
    const auto v = std::int32_t(mesh.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), t.begin(), t.end());
    mesh.triangles.push_back({v, v + 1, v + 2});
  }
  std::vector<detail::PreparedTriangle> tris;
  for (const auto& t : mesh.triangles)
    tris.emplace_back(mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(), mesh.vertices[t[2]].cast<double>());
  std::mt19937 rng(37);
  std::uniform_real_distribution<double> u(-10.0, 34.0);
  std::vector<Vec3d> points;
  for (int i = 0; i < 300; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  for (const double z : {-3.0, 2.0, 11.7})  // on planes too (the rounds near the points' z)
    for (int i = 0; i < 100; ++i) points.emplace_back(u(rng), u(rng), z);
  const std::vector<double> got = point_mesh_distances(mesh, points);
  std::size_t nearest_large = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    std::size_t arg = 0;
    for (std::size_t t = 0; t < tris.size(); ++t)
      if (const double d2 = tris[t].distance_sq(points[i]); d2 < best) best = d2, arg = t;
    nearest_large += arg >= small;
    EXPECT_NEAR(got[i], std::sqrt(best), kRounding) << "point " << i;
  }
  EXPECT_GT(nearest_large, 50u) << "too few points nearest a large triangle to test their bucketing";
}

TEST(PointMesh, SummaryUsesNearestRank) {
  std::vector<double> d;
  for (int i = 1; i <= 40; ++i) d.push_back(double(i));
  const DistanceSummary s = summarize_distances(d);
  EXPECT_EQ(s.count, 40);
  EXPECT_DOUBLE_EQ(s.mean, 20.5);
  EXPECT_DOUBLE_EQ(s.p95, 38.0);  // the 38th of 40 values: 95 % at or below it
  EXPECT_DOUBLE_EQ(s.max, 40.0);
}

}  // namespace
