// @file tests/field3d/test_field3d_multigrid.cpp
// @brief field3d's multigrid-preconditioned conjugate gradients: the same
// field as the direct LDLT twin on a small grid, and an iteration count that
// does not grow with the grid (what the Jacobi preconditioner could not do).
#include <gtest/gtest.h>

#include <random>

#include "isoloft/field3d/field3d.h"
#include "isoloft/synth/sections.h"

namespace isoloft {
namespace {

std::vector<Section> sphere_sections(int planes) {
  const auto s = shape_from_json({{"type", "sphere"}, {"center", {0, 0, 0}}, {"radius", 30}});
  /// 0.1 mm polygonisation: far below a grid cell (2 mm at 32 cells).
  constexpr double kSectionPixel = 0.1;
  return analytic_sections(*s, random_poses(*s, planes, 5), kSectionPixel);
}

/// One level (no warm start, no re-weighting): the multigrid-preconditioned
/// solve of the finest system alone, at a CG tolerance far below the twin's.
Field3dParams one_system(int resolution) {
  Field3dParams p;
  p.resolution = resolution;
  p.levels = 1;
  p.tolerance = 1e-12;
  p.reweight_passes = 0;
  return p;
}

/// The V-cycle (two grids here: 16 cells, ~4.9k nodes, coarsened once to
/// below kCoarsestNodes, 1000) preconditions the same SPD system the twin
/// factorises (16 cells: the twin's LDLT in ~1 s; 24 took 8 s).
TEST(Field3dMultigrid, MatchesDirectTwin) {
  const std::vector<Section> sections = sphere_sections(6);
  Field3dParams p = one_system(16);
  const Field3dResult mg = reconstruct_sections(sections, 1, p);
  p.direct = true;
  const Field3dResult direct = reconstruct_sections(sections, 1, p);
  ASSERT_EQ(mg.field.size(), direct.field.size());
  EXPECT_GE(mg.multigrid_levels, 2);
  /// CG stopped at 1e-12 relative residual on a system whose condition is
  /// about 1e6 (a 16- to 24-cell bi-Laplacian): fields agree far below a grid cell.
  constexpr double kTwinTol = 1e-5;
  for (std::size_t i = 0; i < mg.field.size(); ++i) ASSERT_NEAR(mg.field[i], direct.field[i], kTwinTol) << "node " << i;
}

/// Twice the cells per axis (8x the nodes of a 32-cell grid, four
/// multigrid levels against three): the iterations to 1e-8 stay flat,
/// where Jacobi-preconditioned CG needed O(h^-2) of them.
TEST(Field3dMultigrid, IterationsDoNotGrowWithTheGrid) {
  const std::vector<Section> sections = sphere_sections(8);
  std::vector<int> its;
  for (const int n : {32, 64}) {
    Field3dParams p = one_system(n);
    p.tolerance = 1e-8;
    const Field3dResult r = reconstruct_sections(sections, 1, p);
    EXPECT_LE(r.residual, p.tolerance) << "resolution " << n;
    EXPECT_TRUE(r.check.closed) << "resolution " << n;
    its.push_back(r.finest_iterations);
    if (n == 64) EXPECT_GE(r.multigrid_levels, 3);
  }
  /// Grid-independent convergence up to the coarse operators' approximation
  /// of P^T A P: at most twice the small grid's iterations, plus a few for
  /// the small grid's count being small.
  constexpr double kGrowth = 2.0;
  constexpr int kSlack = 5;
  EXPECT_LE(its[1], kGrowth * its[0] + kSlack) << "32 cells: " << its[0] << ", 64 cells: " << its[1];
}

/// A parallel stack at a wide spacing: 5 planes 12 mm apart (3.6 cells at
/// 24 cells), solved on the anisotropic grid (one node per plane along z, the
/// per-axis bi-Laplacian, semi-coarsening) by the multigrid and by the twin.
TEST(Field3dMultigrid, AnisotropicMatchesDirectTwin) {
  const auto s = shape_from_json({{"type", "sphere"}, {"center", {0, 0, 0}}, {"radius", 30}});
  constexpr double kSectionPixel = 0.1;  // as sphere_sections()
  const std::vector<Section> sections = analytic_sections(*s, parallel_poses(*s, 5), kSectionPixel);
  Field3dParams p = one_system(24);
  p.stack_spacing = 8;
  const Field3dResult mg = reconstruct_sections(sections, 1, p);
  ASSERT_GT(mg.solve_spacing.z(), 3 * mg.spacing);  // the stack's spacing along z, not one cell
  EXPECT_LT(mg.solve_nodes[2], mg.nz);
  EXPECT_EQ(mg.solve_nodes[0], mg.nx);
  EXPECT_GE(mg.multigrid_levels, 2);
  p.direct = true;
  const Field3dResult direct = reconstruct_sections(sections, 1, p);
  ASSERT_EQ(mg.field.size(), direct.field.size());
  constexpr double kTwinTol = 1e-5;  // as MatchesDirectTwin: CG at 1e-12 on a condition of ~1e6
  for (std::size_t i = 0; i < mg.field.size(); ++i) ASSERT_NEAR(mg.field[i], direct.field[i], kTwinTol) << "node " << i;
}

/// The active-set passes' coarse operators, updated additively (penalty
/// samples added, existing ones re-weighted, some in cells that had none)
/// equal the operator rebuilt from all samples: 300 samples on a 9^3-node
/// grid, ~2 per cell and 8 cells per sample's block sums.
TEST(Field3dMultigrid, CoarseUpdateEqualsRebuild) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(0.0, 8.0), wt(0.5, 2.0);
  std::vector<Vec3d> g;
  std::vector<double> before, after;
  for (int k = 0; k < 300; ++k) {
    g.emplace_back(pos(rng), pos(rng), pos(rng));
    before.push_back(k < 200 ? wt(rng) : 0.0);                           // the last 100: added
    after.push_back(k < 100 ? before.back() : k < 200 ? 4 * before.back() : wt(rng));  // 100..199: x4
  }
  /// The blocks are float sums in another order: a few float epsilons
  /// (1.2e-7) of the largest entry per summand, far below the V-cycle's
  /// own approximation of P^T A P.
  constexpr double kFloatSumTol = 1e-5;
  EXPECT_LT(detail::coarse_update_mismatch(9, 9, 9, g, before, after), kFloatSumTol);
  EXPECT_EQ(detail::coarse_update_mismatch(9, 9, 9, g, before, before), 0.0);  // no change: the same sums
}

}  // namespace
}  // namespace isoloft
