// The z-spline to Marching Cubes streaming unit (mesh/stream_mesher.h): its
// contract is that skipping the cells whose corners keep one side of iso
// changes no byte of the mesh. The oracle is the same unit visiting every
// cell, itself checked against plain Marching Cubes on the padded planes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/interp/spline.h"
#include "isoloft/mesh/marching_cubes.h"
#include "isoloft/mesh/mesh_check.h"
#include "isoloft/mesh/stream_mesher.h"

using namespace isoloft;

namespace {

using Field = std::function<double(const Vec3d&)>;

// Slice fields of f at the knots, with the pipeline's end caps.
ZInterpolator slices_of(const Field& f, int nx, int ny, std::vector<double> z, SplineKind kind) {
  std::vector<Grid2f> slices;
  for (double zk : z) {
    Grid2f g(nx, ny);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) g(i, j) = float(f(Vec3d(i, j, zk)));
    slices.push_back(std::move(g));
  }
  add_end_caps(slices, z, InterpParams{});
  return ZInterpolator(std::move(slices), std::move(z), kind);
}

struct Case {
  std::string name;
  Field f;
  std::vector<double> knots;
  double step;  // plane spacing
};

std::vector<Case> cases() {
  const Vec3d c(11.3, 9.7, 10.4);
  const Field sphere = [c](const Vec3d& p) { return 7.5 - (p - c).norm(); };
  const Field torus = [](const Vec3d& p) {
    const double q = std::hypot(p.x() - 12.2, p.y() - 11.6) - 6.0;
    return 2.5 - std::hypot(q, p.z() - 9.0);
  };
  return {
      {"sphere, planes every 0.5 between knots 4 apart", sphere, {2, 6, 10, 14, 18}, 0.5},
      {"torus, non-uniform knots", torus, {4.5, 6, 8.5, 9.25, 12, 13.5}, 0.25},
      // Slices denser than the plane step: layers span several intervals and visit every cell.
      {"sphere, knots denser than the planes", sphere, {3, 3.4, 3.8, 4.2, 6, 9, 12, 15, 18}, 1.0},
  };
}

}  // namespace

TEST(StreamMesher, SkippingCellsGivesTheSameMeshAsVisitingEvery) {
  for (const SplineKind kind : {SplineKind::Monotone, SplineKind::ExtremumPreserving, SplineKind::Linear,
                                SplineKind::CatmullRom, SplineKind::Natural}) {
    for (const Case& c : cases()) {
      const std::string what = c.name + ", " + to_string(kind);
      const ZInterpolator field = slices_of(c.f, 24, 23, c.knots, kind);
      const std::vector<double> planes = sample_planes(field.z().front(), field.z().back(), c.step);
      StreamMeshOptions all;
      all.skip_cells = false;
      const StreamMeshResult full = mesh_interpolated_field(field, planes, 0, 0, {}, all);
      const StreamMeshResult skipping = mesh_interpolated_field(field, planes, 0, 0, {});
      ASSERT_FALSE(full.mesh.empty()) << what;
      EXPECT_EQ(full.mesh.vertices, skipping.mesh.vertices) << what;
      EXPECT_EQ(full.mesh.triangles, skipping.mesh.triangles) << what;
      const MeshCheck check = check_mesh(skipping.mesh);
      EXPECT_TRUE(check.closed && check.manifold && check.oriented) << what;
      EXPECT_EQ(full.cells_visited, full.cells) << what;
      EXPECT_EQ(full.pixels_evaluated, full.pixels) << what;
      EXPECT_EQ(skipping.pixels, full.pixels) << what;
      if (c.step < 1.0) {
        EXPECT_LT(skipping.cells_visited, skipping.cells / 2) << what << ": most cells should be skipped";
        EXPECT_LT(skipping.pixels_evaluated, skipping.pixels / 2) << what << ": most pixels should be left out";
      }
    }
  }
}

// The oracle itself: visiting every cell is Marching Cubes on the padded planes.
TEST(StreamMesher, VisitingEveryCellIsMarchingCubesOfThePaddedPlanes) {
  const Case c = cases().front();
  const ZInterpolator field = slices_of(c.f, 24, 23, c.knots, SplineKind::Monotone);
  const std::vector<double> planes = sample_planes(field.z().front(), field.z().back(), c.step);
  std::vector<Grid2f> padded;
  StreamMeshOptions o;
  o.skip_cells = false;
  o.outside = -1.0f;
  o.on_plane = [&](const Grid2f& plane, double x0, double y0, double, int index, int count) {
    EXPECT_EQ(x0, 2.0 - 1.0);
    EXPECT_EQ(y0, 3.0 - 1.0);
    EXPECT_EQ(index, int(padded.size()));
    EXPECT_EQ(count, int(planes.size()));
    padded.push_back(plane);
  };
  const StreamMeshResult r = mesh_interpolated_field(field, planes, 2.0, 3.0, {}, o);
  ASSERT_EQ(padded.size(), planes.size());
  for (const Grid2f& p : padded) {
    ASSERT_EQ(p.width, 26);
    ASSERT_EQ(p.height, 25);
    for (int x = 0; x < p.width; ++x) EXPECT_EQ(p(x, 0), -1.0f) << "pad at column " << x;
  }
  const TriMesh direct = marching_cubes(padded, planes, 1.0, 2.0);
  EXPECT_EQ(direct.vertices, r.mesh.vertices);
  EXPECT_EQ(direct.triangles, r.mesh.triangles);
}

TEST(StreamMesher, RejectsBadPlanesAndAnInsidePad) {
  const Case c = cases().front();
  const ZInterpolator field = slices_of(c.f, 24, 23, c.knots, SplineKind::Monotone);
  EXPECT_THROW(mesh_interpolated_field(field, {3.0}, 0, 0, {}), ParamError);
  StreamMeshOptions inside;
  inside.outside = 0.5f;  // above iso 0: the pad would be inside
  EXPECT_THROW(mesh_interpolated_field(field, {3.0, 4.0}, 0, 0, {}, inside), ParamError);
  EXPECT_THROW(sample_planes(0, 1, 0.0), ParamError);
  EXPECT_THROW(sample_planes(1, 1, 0.5), ParamError);
  EXPECT_EQ(sample_planes(0, 1, 0.4), (std::vector<double>{0, 0.4, 0.8, 1.0}));
}

// Planes through every slice: knots 3.19 px apart (3 mm planes on a 0.94 mm
// grid) get one step dividing the spacing (3.19 / 4), uneven knots each
// interval split into equal steps; every slice on a plane (within
// kOnPlanePx: the step's rounding), no step above z_step, the caps inside the
// planes' span; knots a whole number of steps apart keep the z_step grid.
constexpr double kOnPlanePx = 1e-9;

TEST(MeshPlanes, RunThroughEverySliceOffTheStepGrid) {
  InterpParams interp;
  interp.planes_on_slices = true;
  interp.z_step = 1.0;
  for (const std::vector<double>& knots : {std::vector<double>{-1.0, 0.0, 3.19, 6.38, 9.57, 10.57},
                                           std::vector<double>{-1.0, 0.0, 3.19, 5.0, 6.0}}) {
    const std::vector<double> planes = mesh_planes(knots, interp);
    for (std::size_t k = 1; k + 1 < knots.size(); ++k) {
      double nearest = 1e9;
      for (double p : planes) nearest = std::min(nearest, std::abs(p - knots[k]));
      EXPECT_LE(nearest, kOnPlanePx) << "knots " << knots.size() << ", slice " << k << " z " << knots[k];
    }
    EXPECT_LE(planes.front(), knots.front());
    EXPECT_GE(planes.back(), knots.back());
    for (std::size_t i = 1; i < planes.size(); ++i) {
      EXPECT_GT(planes[i], planes[i - 1]) << "plane " << i;
      EXPECT_LE(planes[i] - planes[i - 1], interp.z_step + kOnPlanePx) << "plane " << i;
    }
  }
  const std::vector<double> even = mesh_planes({-1.0, 0.0, 3.19, 6.38, 9.57, 10.57}, interp);
  EXPECT_NEAR(even[1] - even[0], 3.19 / 4, kOnPlanePx) << "one step dividing the spacing";
  const std::vector<double> grid = mesh_planes({-1.0, 0.0, 3.0, 6.0, 7.0}, interp);
  ASSERT_EQ(grid.size(), 9u);
  for (std::size_t i = 0; i < grid.size(); ++i) EXPECT_EQ(grid[i], -1.0 + double(i)) << "plane " << i;
}
