// Tests of mesh/mesh_check.h on small hand-built meshes whose defects are
// known: a hole, a flipped triangle, a non-manifold edge and vertex.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/mesh/mesh_check.h"

namespace isoloft {
namespace {

// Volumes and areas of these meshes are sums of a few exact products of
// small integers in double: only rounding in the last bits.
constexpr double kExactTol = 1e-12;

// Unit cube [0,1]^3, 12 triangles counter-clockwise seen from outside.
TriMesh unit_cube(Vec3f offset = Vec3f::Zero()) {
  TriMesh m;
  for (int c = 0; c < 8; ++c) m.vertices.push_back(Vec3f(float(c & 1), float((c >> 1) & 1), float((c >> 2) & 1)) + offset);
  // Each face as a quad (a, b, c, d) counter-clockwise from outside.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({q[0], q[1], q[2]});
    m.triangles.push_back({q[0], q[2], q[3]});
  }
  return m;
}

TriMesh tetrahedron(Vec3f offset = Vec3f::Zero()) {
  TriMesh m;
  m.vertices = {Vec3f(0, 0, 0) + offset, Vec3f(1, 0, 0) + offset, Vec3f(0, 1, 0) + offset, Vec3f(0, 0, 1) + offset};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

TriMesh merged(const TriMesh& a, const TriMesh& b) {
  TriMesh m = a;
  const auto n = std::int32_t(a.vertices.size());
  m.vertices.insert(m.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (auto t : b.triangles) m.triangles.push_back({t[0] + n, t[1] + n, t[2] + n});
  return m;
}

void expect_good_closed(const MeshCheck& m, const std::string& what) {
  EXPECT_TRUE(m.closed) << what;
  EXPECT_TRUE(m.manifold) << what;
  EXPECT_TRUE(m.oriented) << what;
  EXPECT_EQ(m.boundary_edges, 0) << what;
  EXPECT_EQ(m.nonmanifold_edges, 0) << what;
  EXPECT_EQ(m.nonmanifold_vertices, 0) << what;
  EXPECT_EQ(m.inconsistent_edges, 0) << what;
  EXPECT_EQ(m.degenerate_triangles, 0) << what;
}

TEST(MeshCheck, CubeAndTetrahedron) {
  const MeshCheck c = check_mesh(unit_cube());
  expect_good_closed(c, "cube");
  EXPECT_EQ(c.components, 1);
  EXPECT_EQ(c.euler, 2);
  EXPECT_NEAR(c.volume, 1.0, kExactTol);
  EXPECT_NEAR(c.area, 6.0, kExactTol);

  const MeshCheck t = check_mesh(tetrahedron(Vec3f(3, -2, 5)));  // volume independent of position
  expect_good_closed(t, "tetrahedron");
  EXPECT_EQ(t.euler, 2);
  EXPECT_NEAR(t.volume, 1.0 / 6.0, kExactTol);
  EXPECT_NEAR(t.area, 1.5 + std::sqrt(3.0) / 2.0, kExactTol);
}

TEST(MeshCheck, InsideOutMeshHasNegativeVolume) {
  TriMesh m = unit_cube();
  for (auto& t : m.triangles) std::swap(t[1], t[2]);
  const MeshCheck c = check_mesh(m);
  expect_good_closed(c, "inverted cube");
  EXPECT_NEAR(c.volume, -1.0, kExactTol);
}

TEST(MeshCheck, DetectsHole) {
  TriMesh m = unit_cube();
  m.triangles.pop_back();
  const MeshCheck c = check_mesh(m);
  EXPECT_FALSE(c.closed);
  EXPECT_EQ(c.boundary_edges, 3);
  EXPECT_TRUE(c.manifold);  // a disk-like boundary fan is still manifold
  EXPECT_TRUE(c.oriented);
  EXPECT_EQ(c.euler, 1);
}

TEST(MeshCheck, DetectsFlippedTriangle) {
  TriMesh m = unit_cube();
  std::swap(m.triangles[4][1], m.triangles[4][2]);
  const MeshCheck c = check_mesh(m);
  EXPECT_TRUE(c.closed);
  EXPECT_TRUE(c.manifold);
  EXPECT_FALSE(c.oriented);
  EXPECT_EQ(c.inconsistent_edges, 3);
}

TEST(MeshCheck, DetectsNonManifoldEdge) {
  TriMesh m = unit_cube();
  m.vertices.push_back(Vec3f(0.5f, 0.5f, 2.0f));  // a fin on the top edge (4, 5)
  m.triangles.push_back({4, 5, 8});
  const MeshCheck c = check_mesh(m);
  EXPECT_FALSE(c.manifold);
  EXPECT_EQ(c.nonmanifold_edges, 1);
  EXPECT_EQ(c.boundary_edges, 2);
  EXPECT_FALSE(c.closed);
}

TEST(MeshCheck, DetectsNonManifoldVertex) {
  // Two tetrahedra touching at vertex 0: every edge is fine, vertex 0 is not.
  TriMesh m = tetrahedron();
  m.vertices.insert(m.vertices.end(), {Vec3f(-1, 0, 0), Vec3f(0, -1, 0), Vec3f(0, 0, -1)});
  const std::int32_t mirror[4] = {0, 4, 5, 6};  // point reflection: reverse the triangles
  for (std::size_t f = 0; f < 4; ++f) {
    const auto t = m.triangles[f];
    m.triangles.push_back({mirror[t[0]], mirror[t[2]], mirror[t[1]]});
  }
  const MeshCheck c = check_mesh(m);
  EXPECT_TRUE(c.closed);
  EXPECT_TRUE(c.oriented);
  EXPECT_EQ(c.nonmanifold_edges, 0);
  EXPECT_EQ(c.nonmanifold_vertices, 1);
  EXPECT_FALSE(c.manifold);
  EXPECT_EQ(c.components, 1);
}

TEST(MeshCheck, VertexStarsCountedOverManyVertexBlocks) {
  // 12,000 tetrahedra (48,000 vertices: several of the star pass's blocks),
  // pairs touching at one vertex every 1,000th: those vertices non-manifold,
  // and a vertex no triangle uses after each pair.
  TriMesh m;
  long touching = 0;
  for (int i = 0; i < 12000; ++i) {
    TriMesh t = tetrahedron(Vec3f(float(3 * i), 0, 0));
    if (i % 1000 == 999) {  // the last vertex of the one before, shared
      t.vertices[0] = m.vertices.back();
      ++touching;
    }
    const auto n = std::int32_t(m.vertices.size());
    for (const auto& v : t.vertices) m.vertices.push_back(v);
    for (auto f : t.triangles) {
      for (auto& v : f) v = v == 0 && i % 1000 == 999 ? n - 1 : v + n;
      m.triangles.push_back(f);
    }
  }
  const MeshCheck c = check_mesh(m);
  EXPECT_EQ(c.nonmanifold_vertices, touching);
  EXPECT_EQ(c.nonmanifold_edges, 0);
  EXPECT_EQ(c.components, 12000 - touching);
  EXPECT_EQ(c.euler, 2 * (12000 - touching) + touching);  // a touching pair: V - E + F = 7 - 12 + 8 = 3
}

TEST(MeshCheck, CountsComponentsAndDegenerateTriangles) {
  TriMesh m = merged(unit_cube(), unit_cube(Vec3f(3, 0, 0)));
  const MeshCheck two = check_mesh(m);
  expect_good_closed(two, "two cubes");
  EXPECT_EQ(two.components, 2);
  EXPECT_EQ(two.euler, 4);
  EXPECT_NEAR(two.volume, 2.0, kExactTol);

  m.vertices.push_back(Vec3f(9, 9, 9));  // unused vertices are ignored
  EXPECT_EQ(check_mesh(m).euler, 4);

  TriMesh d;
  d.vertices = {Vec3f(0, 0, 0), Vec3f(1, 1, 1), Vec3f(2, 2, 2), Vec3f(0, 1, 0)};
  d.triangles = {{0, 1, 2}, {0, 0, 3}, {0, 1, 3}};  // collinear, repeated index, fine
  EXPECT_EQ(check_mesh(d).degenerate_triangles, 2);
}

// The counts by brute force: edges from the half-edges of all triangles
// grouped by their vertex pair; a vertex's fans from its triangles (one
// entry per time it holds the vertex) joined when they share another vertex.
MeshCheck brute_force_counts(const TriMesh& m) {
  std::map<std::pair<std::int32_t, std::int32_t>, std::pair<int, int>> half;  // (min, max) -> (forward, backward)
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = t[k], b = t[(k + 1) % 3];
      if (a == b) continue;
      auto& h = half[{std::min(a, b), std::max(a, b)}];
      (a < b ? h.first : h.second) += 1;
    }
  MeshCheck r;
  for (const auto& [key, h] : half) {
    const int n = h.first + h.second;
    if (n == 1) ++r.boundary_edges;
    else if (n > 2) ++r.nonmanifold_edges;
    else if (h.first != 1) ++r.inconsistent_edges;
  }
  std::vector<std::vector<std::size_t>> star(m.vertices.size());
  for (std::size_t f = 0; f < m.triangles.size(); ++f)
    for (const std::int32_t v : m.triangles[f]) star[std::size_t(v)].push_back(f);
  long n_used = 0;
  for (std::size_t v = 0; v < star.size(); ++v) {
    const auto& s = star[v];
    if (s.empty()) continue;
    ++n_used;
    std::vector<std::size_t> fan(s.size());
    std::iota(fan.begin(), fan.end(), std::size_t(0));
    const auto root = [&](std::size_t i) {
      while (fan[i] != i) i = fan[i];
      return i;
    };
    for (std::size_t i = 0; i < s.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        for (const std::int32_t w : m.triangles[s[i]])
          if (std::size_t(w) != v && std::count(m.triangles[s[j]].begin(), m.triangles[s[j]].end(), w) > 0)
            fan[root(i)] = root(j);
    std::size_t fans = 0;
    for (std::size_t i = 0; i < s.size(); ++i) fans += root(i) == i;
    r.nonmanifold_vertices += fans > 1;
  }
  r.euler = n_used - long(half.size()) + long(m.triangles.size());
  return r;
}

void expect_brute_force_counts(const TriMesh& m, const std::string& what) {
  const MeshCheck want = brute_force_counts(m), c = check_mesh(m);
  EXPECT_EQ(c.boundary_edges, want.boundary_edges) << what;
  EXPECT_EQ(c.nonmanifold_edges, want.nonmanifold_edges) << what;
  EXPECT_EQ(c.inconsistent_edges, want.inconsistent_edges) << what;
  EXPECT_EQ(c.nonmanifold_vertices, want.nonmanifold_vertices) << what;
  EXPECT_EQ(c.euler, want.euler) << what;
}

TEST(MeshCheck, EdgeCountsEqualThoseOfEveryHalfEdgeGrouped) {
  // Triangle soups on few vertices (shared, repeated and degenerate
  // triangles; every kind of edge and star).
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::int32_t> vertex(0, 11);
    TriMesh m;
    for (int v = 0; v < 13; ++v) m.vertices.push_back(Vec3f(float(v), float(v * v % 7), float(v % 3)));
    for (int f = 0; f < 40; ++f) m.triangles.push_back({vertex(rng), vertex(rng), vertex(rng)});
    m.triangles.push_back(m.triangles[5]);  // a repeated triangle
    m.triangles.push_back({3, 3, 3});
    expect_brute_force_counts(m, "soup, seed " + std::to_string(seed));
  }
}

TEST(MeshCheck, StarsOfClosedMeshesGluedAndFlippedEqualTheBruteForce) {
  // Mostly closed oriented stars (the star pass's fast path) among vertices
  // glued together (pinched stars, fans of two cycles, repeated and
  // degenerate triangles), flipped and dropped triangles (boundary and
  // inconsistent edges): the counts of the general ones.
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    TriMesh m;
    for (int i = 0; i < 12; ++i) m = merged(m, i % 2 ? unit_cube(Vec3f(float(2 * i), 0, 0)) : tetrahedron(Vec3f(float(2 * i), 0, 0)));
    std::uniform_int_distribution<std::int32_t> vertex(0, std::int32_t(m.vertices.size()) - 1);
    std::uniform_int_distribution<std::size_t> triangle(0, m.triangles.size() - 1);
    for (int g = 0; g < 3; ++g) {  // vertex b glued onto a
      const std::int32_t a = vertex(rng), b = vertex(rng);
      for (auto& t : m.triangles)
        for (auto& v : t) v = v == b ? a : v;
    }
    auto& flip = m.triangles[triangle(rng)];
    std::swap(flip[1], flip[2]);
    if (seed % 2) m.triangles.erase(m.triangles.begin() + std::ptrdiff_t(triangle(rng)));
    expect_brute_force_counts(m, "glued, seed " + std::to_string(seed));
  }
  // Every star on the fast path: a tetrahedron and a cube touching at a vertex.
  TriMesh t = merged(tetrahedron(), unit_cube(Vec3f(0, 0, -1)));
  for (auto& f : t.triangles)
    for (auto& v : f) v = v == 4 + 7 ? 0 : v;  // the cube's corner (1, 1, 0) onto the tetrahedron's (0, 0, 0)
  expect_brute_force_counts(t, "touching");
  EXPECT_EQ(check_mesh(t).nonmanifold_vertices, 1);
}

TEST(MeshCheck, EmptyMeshAndBadIndices) {
  const MeshCheck e = check_mesh(TriMesh{});
  EXPECT_EQ(e.components, 0);
  EXPECT_EQ(e.euler, 0);
  EXPECT_EQ(e.volume, 0.0);
  TriMesh bad = tetrahedron();
  bad.triangles[2][1] = 4;
  try {
    check_mesh(bad);
    ADD_FAILURE() << "out-of-range index accepted";
  } catch (const InputError& err) {
    EXPECT_NE(std::string(err.what()).find("triangle 2"), std::string::npos) << err.what();
  }
}

}  // namespace
}  // namespace isoloft
