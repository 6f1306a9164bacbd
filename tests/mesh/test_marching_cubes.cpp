// Tests of mesh/marching_cubes.h: Marching Cubes (Lorensen & Cline 1987,
// paper 2.5) with a generated, face-consistent case table. The promise under
// test: with all outermost samples outside, the mesh is a closed, consistently
// outward-oriented 2-manifold, welded to one vertex per crossed grid edge.
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/interp/spline.h"
#include "isoloft/mesh/marching_cubes.h"
#include "isoloft/mesh/mesh_check.h"
#include "isoloft/mesh/mesh_spill.h"
#include "io/io_test_util.h"

namespace isoloft {
namespace {

using Field = std::function<double(const Vec3d&)>;

// Samples f on planes of nx x ny pixels at x = x0 + i, y = y0 + j and the given z.
std::vector<Grid2f> sample(const Field& f, int nx, int ny, const std::vector<double>& z, double x0 = 0, double y0 = 0) {
  std::vector<Grid2f> planes;
  for (double zk : z) {
    Grid2f g(nx, ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) g(i, j) = float(f(Vec3d(x0 + i, y0 + j, zk)));
    planes.push_back(std::move(g));
  }
  return planes;
}

std::vector<double> iota_z(int n) {
  std::vector<double> z(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) z[std::size_t(k)] = k;
  return z;
}

double sphere_volume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

// Field values and vertex coordinates are floats below 64 px: half an ulp is
// under 4e-6 px, so 1e-5 px covers both roundings.
constexpr double kFloatTol = 1e-5;
// The clamp to [kMinEdgeFraction, 1 - kMinEdgeFraction] moves a vertex by at
// most this fraction of an edge, and a distance field by as much.
constexpr double kClampTol = kMinEdgeFraction;
// Along a grid edge of length h, the sphere SDF r - |p - c| is concave with
// |f''| <= 1/(r - h) (the edge stays outside radius r - h), so it exceeds its
// chord by at most h^2 / (8 (r - h)): the vertex (the chord's root) is inside
// the sphere by at most that much, and never outside.
constexpr double interpolation_gap(double h, double r) { return h * h / (8.0 * (r - h)); }
// Largest gap between a sphere of radius r and a chord of length L: triangle
// sides join points on edges of one cube, so L <= the cube diagonal sqrt(3) h.
constexpr double sagitta(double chord, double r) { return chord * chord / (8.0 * r); }

struct SphereCase {
  double r;
  Vec3d c;
};

// Checks the promised topology and that every vertex lies in the shell
// [r - gap, r] (plus clamp and float slack) around the sphere.
void expect_sphere_mesh(const TriMesh& mesh, const SphereCase& s, double max_edge) {
  const MeshCheck m = check_mesh(mesh);
  EXPECT_TRUE(m.closed) << m.boundary_edges << " boundary edges";
  EXPECT_TRUE(m.manifold) << m.nonmanifold_edges << " edges, " << m.nonmanifold_vertices << " vertices non-manifold";
  EXPECT_TRUE(m.oriented) << m.inconsistent_edges << " inconsistent edges";
  EXPECT_EQ(m.degenerate_triangles, 0);
  EXPECT_EQ(m.components, 1);
  EXPECT_EQ(m.euler, 2);
  const double inner = interpolation_gap(max_edge, s.r) + kClampTol + kFloatTol;
  const double outer = kClampTol + kFloatTol;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const double d = (mesh.vertices[v].cast<double>() - s.c).norm() - s.r;
    ASSERT_LE(d, outer) << "vertex " << v << " outside the sphere";
    ASSERT_GE(d, -inner) << "vertex " << v << " too far inside the sphere";
  }
  // The polyhedron lies in the ball of radius r + outer and contains the ball
  // of radius r - inner - sagitta (relative volume error <= 3 x that / r).
  const double volume_tol = 3.0 * (inner + sagitta(std::sqrt(3.0) * max_edge, s.r)) / s.r;
  EXPECT_LE(m.volume, sphere_volume(s.r + outer));
  EXPECT_NEAR(m.volume / sphere_volume(s.r), 1.0, volume_tol);
}

TEST(MarchingCubes, SphereOffLattice) {
  const SphereCase s{10.3, Vec3d(12.37, 11.81, 12.53)};
  const auto z = iota_z(26);
  const TriMesh mesh = marching_cubes(sample([&](const Vec3d& p) { return s.r - (p - s.c).norm(); }, 26, 26, z), z);
  expect_sphere_mesh(mesh, s, 1.0);
}

// A spilled builder's mesh, read back, is the held one bit for bit: pieces
// of 200 triangles (about 20 here) and the rest at finish(), the vertex ids
// counting on across pieces.
TEST(MarchingCubes, SpilledMeshReadsBackAsBuilt) {
  const SphereCase s{10.3, Vec3d(12.37, 11.81, 12.53)};
  const auto z = iota_z(26);
  const auto planes = sample([&](const Vec3d& p) { return s.r - (p - s.c).norm(); }, 26, 26, z);
  constexpr std::size_t kPiece = 200;
  const auto build = [&](MeshSpill* spill) {
    MarchingCubes mc(26, 26);
    mc.spill_into(spill, kPiece);
    for (std::size_t k = 0; k < planes.size(); ++k) mc.add_plane(planes[k], z[k]);
    return mc.finish();
  };
  const TriMesh held = build(nullptr);
  ASSERT_GT(held.triangles.size(), 10 * kPiece) << "the sphere no longer spills in several pieces";
  const test::TempDir dir;
  MeshSpill spill(dir.path().string());
  EXPECT_TRUE(build(&spill).triangles.empty());
  EXPECT_EQ(spill.triangles(), held.triangles.size());
  const TriMesh back = spill.load();
  ASSERT_EQ(back.vertices.size(), held.vertices.size());
  ASSERT_EQ(back.triangles.size(), held.triangles.size());
  for (std::size_t i = 0; i < held.vertices.size(); ++i) ASSERT_EQ(back.vertices[i], held.vertices[i]) << "vertex " << i;
  for (std::size_t i = 0; i < held.triangles.size(); ++i) ASSERT_EQ(back.triangles[i], held.triangles[i]) << "triangle " << i;
  EXPECT_EQ(dir.entries().size(), 0u) << "the scratch files have no name";
}

// Centre on a sample and integer radius: samples such as (c + (6, 8, 0)) are
// exactly on the sphere, i.e. exact zeros, which count as outside.
TEST(MarchingCubes, SphereWithExactZeroSamples) {
  const SphereCase s{10.0, Vec3d(13, 13, 13)};
  const auto z = iota_z(27);
  const auto planes = sample([&](const Vec3d& p) { return s.r - (p - s.c).norm(); }, 27, 27, z);
  long zeros = 0;
  for (const auto& g : planes) zeros += std::count(g.data.begin(), g.data.end(), 0.0f);
  ASSERT_GT(zeros, 0) << "the test needs samples exactly on the surface";
  expect_sphere_mesh(marching_cubes(planes, z), s, 1.0);
}

TEST(MarchingCubes, SphereOnNonUniformPlanes) {
  const SphereCase s{9.6, Vec3d(11.2, 10.7, 0.0)};
  std::vector<double> z;
  double max_step = 0;
  for (double zk = -11.9, step = 0.3; zk < 12.5; zk += step, step = step > 1.2 ? 0.3 : step + 0.35) {
    z.push_back(zk);
    max_step = std::max(max_step, step);
  }
  ASSERT_GT(z.size(), 3u);
  const auto planes = sample([&](const Vec3d& p) { return s.r - (p - s.c).norm(); }, 23, 22, z);
  expect_sphere_mesh(marching_cubes(planes, z), s, std::max(1.0, max_step));
}

TEST(MarchingCubes, OriginShiftsVertices) {
  const SphereCase s{5.2, Vec3d(107.1, -42.3, 5.6)};
  const auto z = iota_z(12);
  const double x0 = 100, y0 = -49;
  const auto planes = sample([&](const Vec3d& p) { return s.r - (p - s.c).norm(); }, 15, 14, z, x0, y0);
  const TriMesh mesh = marching_cubes(planes, z, x0, y0);
  ASSERT_FALSE(mesh.empty());
  expect_sphere_mesh(mesh, s, 1.0);
}

TEST(MarchingCubes, TorusHasGenusOne) {
  const double R = 7.0, r = 2.6;
  const Vec3d c(12.2, 11.7, 8.4);
  const auto z = iota_z(18);
  const auto planes = sample(
      [&](const Vec3d& p) {
        const Vec3d q = p - c;
        return r - std::hypot(std::hypot(q.x(), q.y()) - R, q.z());
      },
      26, 25, z);
  const MeshCheck m = check_mesh(marching_cubes(planes, z));
  EXPECT_TRUE(m.closed);
  EXPECT_TRUE(m.manifold);
  EXPECT_TRUE(m.oriented);
  EXPECT_EQ(m.components, 1);
  EXPECT_EQ(m.euler, 0);
  EXPECT_GT(m.volume, 0.0);
}

// Fills the interior samples of an nx x ny x nz grid from the bits of `mask`
// (bit set = inside value 1; clear = -1 or an exact 0, both outside) and
// checks the promised properties.
void expect_valid_for_mask(int nx, int ny, int nz, unsigned mask) {
  std::vector<Grid2f> planes(std::size_t(nz), Grid2f(nx, ny, -1.0f));
  int bit = 0;
  for (int k = 1; k + 1 < nz; ++k)
    for (int j = 1; j + 1 < ny; ++j)
      for (int i = 1; i + 1 < nx; ++i, ++bit)
        planes[std::size_t(k)](i, j) = (mask >> bit) & 1u ? 1.0f : (bit % 3 == 0 ? 0.0f : -1.0f);
  const TriMesh mesh = marching_cubes(planes, iota_z(nz));
  const MeshCheck m = check_mesh(mesh);
  const std::string what = std::to_string(nx) + "x" + std::to_string(ny) + "x" + std::to_string(nz) + " mask " +
                           std::to_string(mask);
  ASSERT_TRUE(m.closed && m.manifold && m.oriented) << what << ": boundary " << m.boundary_edges << ", non-manifold "
                                                    << m.nonmanifold_edges << "/" << m.nonmanifold_vertices
                                                    << ", inconsistent " << m.inconsistent_edges;
  ASSERT_EQ(m.degenerate_triangles, 0) << what;
  ASSERT_EQ(mesh.empty(), mask == 0) << what;
  if (!mesh.empty()) {
    ASSERT_GT(m.volume, 0.0) << what;
  }
}

// Every corner configuration of one cube, alone in the volume.
TEST(MarchingCubes, AllSingleCubeCases) {
  for (unsigned mask = 0; mask < 256; ++mask) expect_valid_for_mask(4, 4, 4, mask);
}

// Every configuration of two face-adjacent cubes, along each axis: each
// shared face, ambiguous or not, must be split the same way from both sides.
TEST(MarchingCubes, AllTwoCubeCases) {
  for (unsigned mask = 0; mask < 4096; ++mask) {
    expect_valid_for_mask(5, 4, 4, mask);
    expect_valid_for_mask(4, 5, 4, mask);
    expect_valid_for_mask(4, 4, 5, mask);
  }
}

TEST(MarchingCubes, CaseTableUsesOnlyCrossedEdges) {
  for (int mask = 0; mask < 256; ++mask) {
    for (const auto& t : detail::mc_case_triangles(mask)) {
      for (std::int8_t e : t) {
        const auto [a, b] = detail::kCubeEdgeCorners[std::size_t(e)];
        ASSERT_NE((mask >> a) & 1, (mask >> b) & 1) << "case " << mask << " uses uncrossed edge " << int(e);
      }
    }
    EXPECT_EQ(detail::mc_case_triangles(mask).empty(), mask == 0 || mask == 255) << "case " << mask;
  }
}

TEST(MarchingCubes, StreamingBuilderIsReusable) {
  const SphereCase s{4.3, Vec3d(6.1, 5.8, 6.4)};
  const auto z = iota_z(13);
  const auto planes = sample([&](const Vec3d& p) { return s.r - (p - s.c).norm(); }, 13, 12, z);
  MarchingCubes mc(13, 12);
  for (std::size_t k = 0; k < planes.size(); ++k) mc.add_plane(planes[k], z[k]);
  const TriMesh first = mc.finish();
  EXPECT_EQ(mc.planes_added(), 0);
  for (std::size_t k = 0; k < planes.size(); ++k) mc.add_plane(planes[k], z[k]);
  const TriMesh second = mc.finish();
  ASSERT_FALSE(first.empty());
  ASSERT_EQ(first.triangles, second.triangles);
  ASSERT_EQ(first.vertices, second.vertices);
}

TEST(MarchingCubes, IsoSelectsLevelSet) {
  // Level set 2 of the SDF of a sphere of radius 7 is the sphere of radius 5.
  const Vec3d c(8.3, 8.6, 8.1);
  const auto z = iota_z(17);
  const auto planes = sample([&](const Vec3d& p) { return 7.0 - (p - c).norm(); }, 17, 17, z);
  expect_sphere_mesh(marching_cubes(planes, z, 0, 0, MarchingCubesParams{2.0f}), {5.0, c}, 1.0);
}

TEST(MarchingCubes, RejectsBadInput) {
  EXPECT_THROW(MarchingCubes(0, 5), ParamError);
  EXPECT_THROW(MarchingCubes(5, 5, 0, 0, MarchingCubesParams{std::nanf("")}), ParamError);
  MarchingCubes mc(4, 3);
  EXPECT_THROW(mc.add_plane(Grid2f(3, 4), 0.0), ParamError);
  mc.add_plane(Grid2f(4, 3, -1.0f), 1.0);
  EXPECT_THROW(mc.add_plane(Grid2f(4, 3, -1.0f), 1.0), ParamError);  // z not increasing
  EXPECT_THROW(mc.add_plane(Grid2f(4, 3, -1.0f), std::nan("")), ParamError);
  Grid2f bad(4, 3, -1.0f);
  bad(2, 1) = std::numeric_limits<float>::infinity();
  try {
    mc.add_plane(bad, 2.0);
    ADD_FAILURE() << "non-finite value accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("(2, 1)"), std::string::npos) << e.what();
  }
  std::vector<std::uint8_t> visit(5, 1);  // a 4 x 3 plane has 3 x 2 cells
  EXPECT_THROW(mc.add_plane(Grid2f(4, 3, -1.0f), 3.0, &visit), ParamError);
  EXPECT_THROW(layer_cells_to_visit(Grid2<std::int8_t>(4, 3), Grid2<std::int8_t>(3, 3), visit), ParamError);
  EXPECT_THROW(marching_cubes({Grid2f(4, 3)}, {0.0, 1.0}), ParamError);
  EXPECT_THROW(marching_cubes({Grid2f(4, 3), Grid2f(3, 3)}, {0.0, 1.0}), ParamError);
  EXPECT_TRUE(marching_cubes({}, {}).empty());
}

// Skipping the cells whose corners keep one side of iso (known from the
// monotone spline's knots, as the pipeline does) changes no byte of the mesh:
// the full builder is the oracle. Planes every 0.5 px between slices 4 px
// apart, so most layers share their knot interval and some straddle two.
TEST(MarchingCubes, VisitingOnlyCellsThatMayHoldTheSurfaceGivesTheSameMesh) {
  constexpr float kMargin = 1e-2f;  // pixels; far above the float rounding of a spline value here
  const Vec3d c(11.3, 9.7, 10.4);
  const auto sdf = [&](const Vec3d& p) { return 7.5 - (p - c).norm(); };
  const std::vector<double> knots{0, 4, 8, 12, 16, 20};
  const ZInterpolator interp(sample(sdf, 23, 21, knots), knots, SplineKind::Monotone);
  MarchingCubes full(23, 21), skipping(23, 21), any_byte(23, 21);  // any_byte: active bytes other than 1 too
  Grid2f plane;
  Grid2<std::int8_t> below, above;
  std::vector<std::uint8_t> visit;
  std::size_t cells = 0, visited = 0;
  for (int j = 0; j <= 40; ++j) {
    const double z = 0.5 * j;
    interp.evaluate(z, plane);
    full.add_plane(plane, z);
    if (j == 0) {
      skipping.add_plane(plane, z);
      any_byte.add_plane(plane, z);
      continue;
    }
    interp.sides(interp.interval(z - 0.5), 0.0f, kMargin, below);
    interp.sides(interp.interval(z), 0.0f, kMargin, above);
    layer_cells_to_visit(below, above, visit);
    cells += visit.size();
    visited += std::size_t(std::count(visit.begin(), visit.end(), std::uint8_t(1)));
    skipping.add_plane(plane, z, &visit);
    for (std::size_t c = 0; c < visit.size(); ++c) visit[c] = visit[c] ? std::uint8_t(c % 2 ? 255 : 3) : 0;
    any_byte.add_plane(plane, z, &visit);
  }
  const TriMesh a = full.finish(), b = skipping.finish(), d = any_byte.finish();
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.vertices, d.vertices);
  EXPECT_EQ(a.triangles, d.triangles);
  EXPECT_LT(visited, cells / 2) << "the test should skip most cells";
}

// Random fields on small grids, border samples outside: many exact zeros (at
// iso) and ambiguous faces from values in {-1, 0, 1}, random plane spacing.
RC_GTEST_PROP(MarchingCubes, RandomFieldsGiveClosedOrientedManifolds, ()) {
  const int nx = *rc::gen::inRange(3, 9), ny = *rc::gen::inRange(3, 9), nz = *rc::gen::inRange(3, 9);
  const float iso = *rc::gen::element(0.0f, 0.25f, -0.5f);
  const bool discrete = *rc::gen::arbitrary<bool>();
  std::vector<double> z{*rc::gen::inRange(-20, 20) / 4.0};
  for (int k = 1; k < nz; ++k) z.push_back(z.back() + *rc::gen::inRange(1, 31) / 10.0);
  const double x0 = *rc::gen::inRange(-40, 40) / 4.0, y0 = *rc::gen::inRange(-40, 40) / 4.0;

  std::vector<Grid2f> planes;
  for (int k = 0; k < nz; ++k) {
    Grid2f g(nx, ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        float e = discrete ? float(*rc::gen::inRange(-1, 2)) : float(*rc::gen::inRange(-1000, 1001)) / 1000.0f;
        if (i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1) e = -std::abs(e);
        g(i, j) = iso + e;
      }
    planes.push_back(std::move(g));
  }
  const TriMesh mesh = marching_cubes(planes, z, x0, y0, {iso});
  const MeshCheck m = check_mesh(mesh);
  RC_ASSERT(m.closed);
  RC_ASSERT(m.manifold);
  RC_ASSERT(m.oriented);
  RC_ASSERT(m.degenerate_triangles == 0);
  if (!mesh.empty()) RC_ASSERT(m.volume > 0.0);

  // Welded: exactly one vertex per crossed grid edge, all at distinct points.
  long crossed = 0;
  auto in = [&](int i, int j, int k) { return planes[std::size_t(k)](i, j) > iso; };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (i + 1 < nx) crossed += in(i, j, k) != in(i + 1, j, k);
        if (j + 1 < ny) crossed += in(i, j, k) != in(i, j + 1, k);
        if (k + 1 < nz) crossed += in(i, j, k) != in(i, j, k + 1);
      }
  RC_ASSERT(long(mesh.vertices.size()) == crossed);
  std::vector<std::array<float, 3>> pts;
  for (const Vec3f& p : mesh.vertices) pts.push_back({p.x(), p.y(), p.z()});
  std::sort(pts.begin(), pts.end());
  RC_ASSERT(std::adjacent_find(pts.begin(), pts.end()) == pts.end());
}

}  // namespace
}  // namespace isoloft
