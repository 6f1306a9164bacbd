// @file tests/field3d/test_field3d.cpp
// @brief The field3d stage on analytic shapes cut by planes in any
// orientation: a closed oriented surface of the right topology whose section
// on every input plane follows the drawn contour, near the analytic surface;
// the fast solver against its direct twin; conflicts at crossings; bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "isoloft/core/error.h"
#include "isoloft/eval/point_mesh.h"
#include "isoloft/field3d/field3d.h"
#include "isoloft/synth/sections.h"

namespace isoloft {
namespace {

/// Polygonisation of the drawn sections, mm: chord error r (1 - cos(pi s / 2 pi r))
/// ~ s^2 / 8r = 1e-4 mm for s = 0.1 mm and r >= 12 mm, far below every tolerance.
constexpr double kSectionPixel = 0.1;

std::unique_ptr<Shape> sphere() {
  return shape_from_json({{"type", "sphere"}, {"center", {0, 0, 0}}, {"radius", 30}});
}
std::unique_ptr<Shape> torus() {
  return shape_from_json(
      {{"type", "torus"}, {"center", {0, 0, 0}}, {"major_radius", 30}, {"minor_radius", 12}, {"tilt_deg", 30}});
}

double bbox_diagonal(const Shape& s) {
  const auto [lo, hi] = s.bounds();
  return (hi - lo).norm();
}

/// Two-sided Hausdorff distance between the mesh and the analytic surface:
/// vertices' exact distances one way, surface points' distances to the mesh the other.
double hausdorff_to_shape(const TriMesh& mesh, const Shape& shape) {
  double d = 0;
  for (const Vec3f& v : mesh.vertices) d = std::max(d, std::abs(shape.value(v.cast<double>())));
  const auto [lo, hi] = shape.bounds();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3d> pts;
  for (int i = 0; i < 3000; ++i)
    pts.push_back(shape.closest_point(lo + (hi - lo).cwiseProduct(Vec3d(u(rng), u(rng), u(rng)))));
  for (double x : point_mesh_distances(mesh, pts)) d = std::max(d, x);
  return d;
}

struct Expect {
  long genus = 0;
  /// Largest per-plane distance between the mesh's section and the drawn contour, share of the diagonal.
  double plane_tol = 0;
  /// Largest two-sided distance to the analytic surface, share of the diagonal.
  double hausdorff_tol = 0;
};

void check_reconstruction(const Shape& shape, const std::vector<PlanePose>& poses, const Expect& e) {
  const std::vector<Section> sections = analytic_sections(shape, poses, kSectionPixel);
  const Field3dResult r = reconstruct_sections(sections, 1);
  const double diag = bbox_diagonal(shape);
  EXPECT_TRUE(r.check.closed);
  EXPECT_TRUE(r.check.oriented);
  EXPECT_TRUE(r.check.manifold);
  EXPECT_EQ(r.check.components, 1);
  EXPECT_EQ((2 - r.check.euler) / 2, e.genus);
  EXPECT_GT(r.check.volume, 0);
  for (std::size_t i = 0; i < r.planes.size(); ++i)
    EXPECT_LE(r.planes[i].max(), e.plane_tol * diag) << "plane " << i;
  EXPECT_LE(hausdorff_to_shape(r.mesh, shape), e.hausdorff_tol * diag);
  EXPECT_LE(r.residual, Field3dParams{}.tolerance);
}

// Tolerances, shares of the bounding-box diagonal (docs/decisions.md: the
// field3d method).
/// On the input planes: issue 35's target, 0.1 % of the diagonal (a sixth of
/// a grid cell at the default 96 cells). Measured at the defaults
/// (plane_weight 0.03) on the synthetic kit: 0.004-0.066 % (worst: torus, 40
/// random planes); at plane_weight 1 the torus reached 0.31 % (docs/decisions.md:
/// the field3d method, plane weight).
constexpr double kPlaneTol = 1e-3;
/// To the analytic surface: what the planes leave undetermined between them
/// (a cap no plane cuts is extrapolated); measured 2.7 % with 5 random planes
/// on the sphere, 1.2 % with 10.
constexpr double kShapeTol = 0.05;

TEST(Field3d, SphereEightRandomPlanes) {
  const auto s = sphere();
  check_reconstruction(*s, random_poses(*s, 8, 11), {0, kPlaneTol, kShapeTol});
}

TEST(Field3d, TorusTenRandomPlanes) {
  const auto s = torus();
  check_reconstruction(*s, random_poses(*s, 10, 12), {1, kPlaneTol, kShapeTol});
}

TEST(Field3d, OrthogonalTriple) {
  const auto s = sphere();
  check_reconstruction(*s, orthogonal_poses(*s), {0, kPlaneTol, kShapeTol});
}

TEST(Field3d, ParallelControl) {
  const auto s = torus();
  check_reconstruction(*s, parallel_poses(*s, 8), {1, kPlaneTol, kShapeTol});
}

/// A circle of `radius` about the pose's origin, 720 vertices (one on each axis).
Section circle_section(const PlanePose& pose, double radius) {
  Section s;
  s.pose = pose;
  SectionContour c;
  for (int k = 0; k < 720; ++k) {
    const double a = 2 * M_PI * k / 720;
    c.points.emplace_back(radius * std::cos(a), radius * std::sin(a));
  }
  s.contours.push_back(c);
  return s;
}

PlanePose axis_pose(const Vec3d& u, const Vec3d& v) {
  PlanePose p;
  p.u = u;
  p.v = v;
  return p;
}

/// A small twin case: a sphere cut by 6 random planes, and parameters for one
/// system (no re-weighting) solved to CG tolerance 1e-12 on a 16-cell grid.
std::vector<Section> twin_sections() {
  const auto s = sphere();
  return analytic_sections(*s, random_poses(*s, 6, 5), kSectionPixel);
}
/// Two grid levels, no re-weighting: the small grids of the band and model tests.
Field3dParams two_level_params(int resolution) {
  Field3dParams p;
  p.levels = 2;
  p.reweight_passes = 0;
  p.resolution = resolution;
  return p;
}
Field3dParams twin_params(int refinement) {
  Field3dParams p;
  p.resolution = 16;
  p.levels = 2;
  p.tolerance = 1e-12;
  p.refinement = refinement;
  p.reweight_passes = 0;
  return p;
}

/// The matrix-free coarse-to-fine conjugate gradients against the direct
/// LDLT twin on one small system (the same operator assembled).
TEST(Field3d, ConjugateGradientsMatchDirectTwin) {
  const std::vector<Section> sections = twin_sections();
  Field3dParams p = twin_params(1);  // the base grid's solve itself
  const Field3dResult cg = reconstruct_sections(sections, 1, p);
  p.direct = true;
  const Field3dResult direct = reconstruct_sections(sections, 1, p);
  ASSERT_EQ(cg.field.size(), direct.field.size());
  ASSERT_LE(direct.residual, 1e-9);
  /// Both solve one SPD system; CG stopped at 1e-12 relative residual, so
  /// the fields agree far below a grid cell (the field's unit).
  constexpr double kTwinTol = 1e-6;
  for (std::size_t i = 0; i < cg.field.size(); ++i) ASSERT_NEAR(cg.field[i], direct.field[i], kTwinTol) << "node " << i;
  EXPECT_GT(cg.iterations, 0);
}

/// The band rows end at kMaxGridCells: 1e308 ran without end. The refusal
/// names the row; the bound itself passes (and runs: these sections are
/// polylines, so `band` is the one used).
TEST(Field3d, BandRowsRefuseUnboundedBands) {
  const std::vector<Section> sections = twin_sections();
  for (const char* row : {"band", "pixel_band"}) {
    Field3dParams p = twin_params(1);
    double& band = std::string(row) == "band" ? p.band : p.pixel_band;
    band = 1e308;
    try {
      (void)reconstruct_sections(sections, 1, p);
      ADD_FAILURE() << row << " 1e308 accepted";
    } catch (const ParamError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(std::string(row) + ":", 0), 0u) << e.what();  // the message starts with the row
    }
    band = kMaxGridCells;
    EXPECT_FALSE(reconstruct_sections(sections, 1, p).mesh.empty()) << row;
  }
}

/// The per-gap plane weight rows: out of range refused naming the row; on
/// polylines the pixel row is not read (the field keeps its bytes) and the
/// general one, off by default, acts when set.
TEST(Field3d, PlaneWeightPerGapRowsBoundedAndPolylinesKeepTheirField) {
  const auto s = sphere();
  const std::vector<Section> sections = analytic_sections(*s, parallel_poses(*s, 6), kSectionPixel);
  for (const char* row : {"plane_weight_per_gap", "pixel_plane_weight_per_gap"})
    for (double bad : {-1.0, 1e308}) {
      Field3dParams p = twin_params(1);
      (std::string(row) == "plane_weight_per_gap" ? p.plane_weight_per_gap : p.pixel_plane_weight_per_gap) = bad;
      try {
        (void)reconstruct_sections(sections, 1, p);
        ADD_FAILURE() << row << " " << bad << " accepted";
      } catch (const ParamError& e) {
        EXPECT_EQ(std::string(e.what()).rfind(std::string(row) + ":", 0), 0u) << e.what();
      }
    }
  const Field3dParams base = twin_params(1);
  const Field3dResult plain = reconstruct_sections(sections, 1, base);
  Field3dParams pixel_row = base;
  pixel_row.pixel_plane_weight_per_gap = 1;
  EXPECT_EQ(reconstruct_sections(sections, 1, pixel_row).field, plain.field);
  Field3dParams general_row = base;
  general_row.plane_weight_per_gap = 1;
  EXPECT_NE(reconstruct_sections(sections, 1, general_row).field, plain.field);
}

/// Largest distance from a vertex of `a` to the surface of `b`, mm.
double one_sided_max(const TriMesh& a, const TriMesh& b) {
  std::vector<Vec3d> pts;
  for (const Vec3f& v : a.vertices) pts.push_back(v.cast<double>());
  double d = 0;
  for (double x : point_mesh_distances(b, pts)) d = std::max(d, x);
  return d;
}

/// The narrow band's matrix-free conjugate gradients against its direct LDLT
/// twin (A_UU assembled, the fixed ring in the right-hand side), and the band
/// against the dense solve of the same fine grid.
TEST(Field3d, BandMatchesDirectTwinAndDenseFineGrid) {
  const std::vector<Section> sections = twin_sections();
  // The direct twin factors the band's system, whose fill grows fast with
  // its unknowns: with a 12-cell base and a 1-cell band (7,488 unknowns, the
  // sphere's core left out) this test runs 1.9 s on the quiet machine, with
  // the 16-cell base and the default 2-cell band (21,368) 26 s. The band
  // keeps a hole and a fixed ring.
  Field3dParams p = twin_params(2);
  p.resolution = 12;
  p.refine_width = 1;
  const Field3dResult cg = reconstruct_sections(sections, 1, p);
  p.direct = true;
  const Field3dResult direct = reconstruct_sections(sections, 1, p);
  ASSERT_GT(cg.band_unknowns, 0u);
  ASSERT_LT(cg.band_unknowns, cg.band_nodes);  // a fixed ring exists
  ASSERT_LE(direct.residual, 1e-9);
  ASSERT_EQ(cg.mesh.vertices.size(), direct.mesh.vertices.size());
  /// Both solve one SPD system to 1e-12: the fields, and so Marching Cubes'
  /// vertices on the same fine edges, agree far below a fine cell.
  const double kTwinTol = 1e-6 * cg.spacing;
  for (std::size_t i = 0; i < cg.mesh.vertices.size(); ++i)
    ASSERT_LE((cg.mesh.vertices[i] - direct.mesh.vertices[i]).cast<double>().norm(), kTwinTol) << "vertex " << i;
  // The dense solve on the fine grid everywhere (twice the resolution, no band).
  Field3dParams d = p;
  d.direct = false;
  d.resolution = 2 * p.resolution;
  d.refinement = 1;
  const Field3dResult dense = reconstruct_sections(sections, 1, d);
  ASSERT_NEAR(dense.spacing, cg.spacing / 2, 1e-9 * cg.spacing);
  /// The band differs from the dense solve only through its fixed ring (the
  /// coarse field, a coarse cell from the surface) and the coarse grid's box
  /// term: measured 0.06 of a fine cell here (0.15 with the 2-cell band on
  /// the 16-cell base); a quarter cell bounds it.
  const double kBandVsDense = 0.25 * dense.spacing;
  EXPECT_LE(std::max(one_sided_max(cg.mesh, dense.mesh), one_sided_max(dense.mesh, cg.mesh)), kBandVsDense);
}

/// The sparse field (base_resolution): the dense solve at resolution / 2 and
/// the band around its surface twice finer. Its stored band nodes grow with
/// the surface (4x per doubling of the resolution), not the box (8x); its
/// zero set matches the dense grid's at the same resolution; the estimate
/// counts the band, not a dense grid at the requested resolution.
TEST(Field3d, SparseFieldGrowsWithTheSurfaceAndMatchesTheDenseZeroSet) {
  const std::vector<Section> sections = twin_sections();
  Field3dParams p = two_level_params(32);
  p.refine_width = 1;
  p.base_resolution = 16;
  const Field3dResult sparse = reconstruct_sections(sections, 1, p);
  ASSERT_GT(sparse.band_nodes, 0u);
  const double h_fine = sparse.spacing / 2;  // the base at 16 cells, the band at 32
  Field3dParams d = p;
  d.base_resolution = 0;
  const Field3dResult dense = reconstruct_sections(sections, 1, d);
  ASSERT_NEAR(dense.spacing, h_fine, 1e-9 * h_fine);
  ASSERT_EQ(dense.nx, 2 * sparse.nx - 1);  // the field is the base grid's
  /// The sparse field solves the base's energy (band and weights in base
  /// cells) on the fine grid near the surface, the dense one the fine cells'
  /// (docs/decisions.md: the sparse field): measured 0.15 of a fine cell
  /// apart here; half a fine cell bounds it.
  const double kSparseVsDense = 0.5 * h_fine;
  const double apart = std::max(one_sided_max(sparse.mesh, dense.mesh), one_sided_max(dense.mesh, sparse.mesh));
  EXPECT_LE(apart, kSparseVsDense);
  RecordProperty("sparse_vs_dense_fine_cells", std::to_string(apart / h_fine));
  p.resolution = 64;
  p.base_resolution = 32;
  const Field3dResult twice = reconstruct_sections(sections, 1, p);
  /// A band a fixed number of base cells wide around a surface: nodes ~
  /// area, 4x per doubling (measured 3.9 on a sphere at these grids); a box
  /// would grow 8x.
  constexpr double kSurfaceGrowth = 5;
  const double growth = double(twice.band_nodes) / double(sparse.band_nodes);
  RecordProperty("band_growth", std::to_string(growth));
  EXPECT_LT(growth, kSurfaceGrowth);
  EXPECT_GT(growth, 3.0);
  // The estimate counts the band and the base, not a dense grid at the
  // resolution asked (at 32 cells the band is most of the box; at 384 not).
  p.resolution = 384;
  p.base_resolution = 96;
  d.resolution = 384;
  EXPECT_LT(4 * estimate_sections(sections, 1, p).solve_bytes, estimate_sections(sections, 1, d).solve_bytes);
}

/// model_resolution: a grid twice as fine discretises the energy of the
/// coarse one (band, smoothness against the data and contour weight
/// converted), so its surface stays near the coarse grid's; without it the
/// cell-unit rows make the finer grid another model (the data weighs 8x more
/// against the smoothness).
TEST(Field3d, ModelResolutionKeepsTheEnergyOnAFinerGrid) {
  const std::vector<Section> sections = twin_sections();
  Field3dParams p = two_level_params(24);
  const Field3dResult coarse = reconstruct_sections(sections, 1, p);
  Field3dParams q = p;
  q.resolution = 48;
  const Field3dResult other_model = reconstruct_sections(sections, 1, q);
  q.model_resolution = 24;
  const Field3dResult same_model = reconstruct_sections(sections, 1, q);
  p.model_resolution = 24;  // at its own resolution the conversion is the identity
  EXPECT_EQ(reconstruct_sections(sections, 1, p).mesh.vertices, coarse.mesh.vertices);
  const auto apart = [&](const Field3dResult& fine) {
    return std::max(one_sided_max(fine.mesh, coarse.mesh), one_sided_max(coarse.mesh, fine.mesh)) / coarse.spacing;
  };
  const double same = apart(same_model), other = apart(other_model);
  RecordProperty("same_model_coarse_cells", std::to_string(same));
  RecordProperty("other_model_coarse_cells", std::to_string(other));
  /// Measured 0.063 coarse cells against 0.31 without the conversion: what
  /// is left is the coarse grid's own discretisation error.
  constexpr double kSameModelApart = 0.15;
  EXPECT_LE(same, kSameModelApart);
  EXPECT_LT(same, other);
}

// The band margin (box_margins): the margin everywhere without it; with it at
// least band_margin x the band in the planes' directions and beyond an open end
// of a parallel stack, the margin alone beyond a closed one (an empty outermost
// plane); the grid's box then reaches that far (the cell's fixed point).
TEST(Field3d, BandMarginWidensTheBoxExceptAtClosedEnds) {
  constexpr double kTol = 1e-9;  // mm: the margins are sums and products of exact inputs
  std::vector<Section> secs;
  for (const double z : {0.0, 10.0, 20.0}) {
    PlanePose pose = axis_pose(Vec3d::UnitX(), Vec3d::UnitY());
    pose.origin = Vec3d(0, 0, z);
    secs.push_back(z > 0 ? circle_section(pose, 20) : Section{pose, {}});
  }
  const std::array<Vec3d, 2> box{Vec3d(-20, -20, 10), Vec3d(20, 20, 20)};
  Field3dParams p;
  p.band = 16;
  const double m0 = p.margin * (box[1] - box[0]).norm();
  for (const auto& m : box_margins(p, secs, box, 1.0, 10.0))
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(m[a], m0, kTol) << "without the band margin, axis " << a;
  p.band_margin = 1.5;
  const double band = 1.5 * 16;  // band x 1 mm cells; band_per_gap (0) adds nothing
  const auto [below, above] = box_margins(p, secs, box, 1.0, 10.0);
  for (int a = 0; a < 2; ++a) {
    EXPECT_NEAR(below[a], band, kTol) << "in-plane axis " << a;
    EXPECT_NEAR(above[a], band, kTol) << "in-plane axis " << a;
  }
  EXPECT_NEAR(below.z(), m0, kTol) << "the empty plane at z = 0 closes the low end";
  EXPECT_NEAR(above.z(), band, kTol) << "the high end is open";
  // The grid: the box reaches band_margin x band cells beyond the open end.
  p.resolution = 96;
  p.levels = 2;
  const Field3dResult r = reconstruct_sections(secs, 1, p);
  const double top = r.origin.z() + r.spacing * (r.nz - 1);
  EXPECT_GE(top - 20, 1.5 * p.band * r.spacing - kTol) << "cell " << r.spacing << " mm";
  p.resolution = 48;  // 2 x 1.5 x 16 = 48 cells of margin: none left for the contours
  EXPECT_THROW(reconstruct_sections(secs, 1, p), ParamError);
}

/// Components no inside sample supports are dropped; cavities are kept.
TEST(Field3d, PruneUnsupportedComponents) {
  const auto s = sphere();
  Field3dParams p;
  p.resolution = 32;  // any closed sphere serves; the default 96 took 6 s
  const Field3dResult r = reconstruct_sections(analytic_sections(*s, orthogonal_poses(*s), kSectionPixel), 1, p);
  ASSERT_EQ(r.check.components, 1);
  TriMesh m = r.mesh;
  const auto add_copy = [&](const Vec3f& shift, float scale, bool flip) {
    const auto base = std::int32_t(m.vertices.size());
    for (const Vec3f& v : r.mesh.vertices) m.vertices.push_back(v * scale + shift);
    for (auto t : r.mesh.triangles) {
      if (flip) std::swap(t[1], t[2]);
      m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    }
  };
  add_copy(Vec3f(100, 0, 0), 1, false);   // a blob with nothing drawn inside
  add_copy(Vec3f(0, 0, 0), 0.5f, true);   // a cavity inside the sphere
  const std::vector<Vec3d> inside{Vec3d(20, 0, 0)};  // in the sphere, outside the cavity
  EXPECT_EQ(detail::prune_unsupported(m, inside), 1u);
  EXPECT_EQ(m.triangles.size(), 2 * r.mesh.triangles.size());
  const MeshCheck c = check_mesh(m);
  EXPECT_EQ(c.components, 2);
  EXPECT_TRUE(c.closed);
  EXPECT_GT(c.volume, 0);
  EXPECT_EQ(detail::prune_unsupported(m, inside), 0u);  // nothing more to drop
}

/// Two circles 12 mm apart and, midway, a plane where nothing was drawn (all
/// outside): the smooth field alone bridges it (its plane samples weigh
/// plane_weight), plane_signs keeps the surface off that plane.
TEST(Field3d, PlaneSignsKeepTheSurfaceOffAnEmptyPlane) {
  const auto at_z = [](double z) {
    PlanePose p = axis_pose(Vec3d::UnitX(), Vec3d::UnitY());
    p.origin = Vec3d(0, 0, z);
    return p;
  };
  Section empty;
  empty.pose = at_z(0);
  const std::vector<Section> sections{circle_section(at_z(-6), 20), empty, circle_section(at_z(6), 20)};
  // Triangles whose vertices lie on both sides of z = 0: the mesh crosses the empty plane.
  const auto crossing = [](const TriMesh& m) {
    int n = 0;
    for (const auto& t : m.triangles) {
      bool below = false, above = false;
      for (int c = 0; c < 3; ++c) (m.vertices[std::size_t(t[c])].z() < 0 ? below : above) = true;
      n += below && above;
    }
    return n;
  };
  Field3dParams p;
  p.resolution = 32;  // the default 96 would take seconds; any grid shows the bridge
  p.plane_signs = false;
  const Field3dResult off = reconstruct_sections(sections, 1, p);
  ASSERT_GT(crossing(off.mesh), 0) << "the case no longer needs the sign constraints";
  EXPECT_EQ(off.check.components, 1);
  p.plane_signs = true;
  const Field3dResult on = reconstruct_sections(sections, 1, p);
  EXPECT_EQ(on.sign_violated, 0u);
  EXPECT_GT(on.sign_active, 0u);
  EXPECT_EQ(crossing(on.mesh), 0);
  EXPECT_EQ(on.check.components, 2);
  EXPECT_TRUE(on.check.closed);
  EXPECT_TRUE(on.check.manifold);
}

/// Two orthogonal circles through the z axis disagreeing by 3 mm at both
/// ends of their common line: two conflicts of 3 mm, named in warnings.
TEST(Field3d, ConflictsAtCrossingsReported) {
  std::vector<Section> sections{circle_section(axis_pose(Vec3d::UnitY(), Vec3d::UnitZ()), 30),
                                circle_section(axis_pose(Vec3d::UnitX(), Vec3d::UnitZ()), 33)};
  sections[0].source = "a.csl, plane 1";
  sections[1].source = "a.csl, plane 2";
  const Field3dResult r = reconstruct_sections(sections, 1);
  ASSERT_EQ(r.conflicts.size(), 2u);
  ASSERT_EQ(r.warnings.size(), 2u);
  /// Crossings fall on polygon vertices (one on each axis): exact to rounding.
  constexpr double kConflictTol = 1e-9;
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_NEAR(r.conflicts[i].size, 3.0, kConflictTol) << "conflict " << i;
    EXPECT_NEAR(std::abs(r.conflicts[i].where.z()), 31.5, kConflictTol) << "conflict " << i;
    EXPECT_NE(r.warnings[i].find("a.csl, plane 1"), std::string::npos) << "warning " << i;
  }
  // Least squares averages: the surface on the common line lies between 30 and 33.
  EXPECT_TRUE(r.check.closed);
  EXPECT_EQ(r.check.components, 1);
}

TEST(Field3d, BadInputNamesTheSection) {
  const auto s = sphere();
  const std::vector<Section> good = analytic_sections(*s, orthogonal_poses(*s), kSectionPixel);
  auto expect_input_error = [](const std::vector<Section>& secs, std::uint32_t label, const std::string& what) {
    try {
      (void)reconstruct_sections(secs, label);
      ADD_FAILURE() << "no error for " << what;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  auto skewed = good;
  skewed[1].pose.v = Vec3d(1, 1, 0);
  expect_input_error(skewed, 1, "analytic plane 1");
  auto few = good;
  few[2].contours[0].points.resize(2);
  expect_input_error(few, 1, "analytic plane 2");
  auto image = good;  // a label image (pixel input) is accepted, with a positive, finite pixel size only
  image[0].labels = Grid2u32(4, 4, 1);
  image[0].pixel_size = 0;
  expect_input_error(image, 1, "analytic plane 0");
  expect_input_error(good, 7, "label 7");
  Field3dParams p;
  p.direct = true;  // the default 96 cells: far above the twin's limit
  EXPECT_THROW((void)reconstruct_sections(good, 1, p), ParamError);
}

/// The work estimate counts the grid and the samples reconstruct_sections()
/// makes (random tilted planes: rows crossing the box obliquely), without a
/// solve; the bytes grow with the grid.
TEST(Field3d, EstimateCountsTheGridAndSamplesOfTheSolve) {
  const auto s = torus();
  const std::vector<Section> sections = analytic_sections(*s, random_poses(*s, 7, 3), kSectionPixel);
  Field3dParams p;
  p.resolution = 24;
  const Field3dWork w = estimate_sections(sections, 1, p);
  const Field3dResult r = reconstruct_sections(sections, 1, p);
  EXPECT_EQ(w.nx, r.nx);
  EXPECT_EQ(w.ny, r.ny);
  EXPECT_EQ(w.nz, r.nz);
  /// Raster points on the box's faces: the estimate's per-row interval and
  /// the solver's per-point test round alike up to a point per row end.
  constexpr double kSampleSlack = 1e-3;
  EXPECT_NEAR(w.samples, double(r.samples), kSampleSlack * double(r.samples));
  EXPECT_GT(w.triangles, 0);
  // Twice the cells per side: ~8x the nodes (6.8x here: the small grid's
  // cells are rounded up to multiples of 4 per axis), the bytes at least 2x
  // (contour samples grow as the cells per side, plane samples as their square).
  p.resolution = 48;
  const Field3dWork w2 = estimate_sections(sections, 1, p);
  EXPECT_GT(w2.nodes(), 6 * w.nodes());
  EXPECT_GT(w2.solve_bytes, 2 * w.solve_bytes);
  EXPECT_THROW((void)estimate_sections(sections, 2, p), InputError);  // no contour of label 2
}

/// A sphere from 5 parallel planes 12 mm apart (14 cells at the default 96
/// cells): solved with one node every 6 mm along z (stack_spacing 8) and on
/// the grid of one cell along every axis (stack_spacing 1, the default).
/// The wide solve, splined back to one cell along z, gives the same surface
/// up to a share of a cell, with no crease at the planes.
TEST(Field3d, ParallelStackAtWideSpacingMatchesOneCellGrid) {
  const auto s = sphere();
  const std::vector<Section> sections = analytic_sections(*s, parallel_poses(*s, 5), kSectionPixel);
  Field3dParams stacked;
  stacked.stack_spacing = 8;
  const Field3dResult wide = reconstruct_sections(sections, 1, stacked);
  const Field3dResult dense = reconstruct_sections(sections, 1);
  ASSERT_GT(wide.solve_spacing.z(), 5 * wide.spacing);
  ASSERT_DOUBLE_EQ(dense.solve_spacing.z(), dense.spacing);
  EXPECT_LT(wide.solve_nodes[2] * 5, dense.solve_nodes[2]);
  EXPECT_EQ(wide.nx, dense.nx);  // the field and the mesh at one cell along every axis either way
  ASSERT_DOUBLE_EQ(wide.spacing, dense.spacing);
  EXPECT_TRUE(wide.check.closed);
  EXPECT_TRUE(wide.check.manifold);
  EXPECT_EQ(wide.check.components, 1);
  EXPECT_EQ(wide.check.euler, 2);
  const double diag = bbox_diagonal(*s);
  for (std::size_t i = 0; i < wide.planes.size(); ++i)
    EXPECT_LE(wide.planes[i].max(), kPlaneTol * diag) << "plane " << i;
  const double apart = std::max(one_sided_max(wide.mesh, dense.mesh), one_sided_max(dense.mesh, wide.mesh));
  /// Two discretisations of one energy, 7 cells against 1 along z: measured
  /// 0.70 cells apart (the caps beyond the outermost planes, resolved by a
  /// node every 7 cells); a cell bounds it with room for the solver's tolerance.
  constexpr double kStackTol = 1.0;
  EXPECT_LE(apart, kStackTol * wide.spacing);
  /// Farther from the sphere by at most half a cell: measured 1.39 against
  /// 1.04 mm (0.42 cells at h = 0.83 mm).
  constexpr double kStackShapeSlack = 0.5;
  EXPECT_LE(hausdorff_to_shape(wide.mesh, *s), hausdorff_to_shape(dense.mesh, *s) + kStackShapeSlack * wide.spacing);
}

}  // namespace
}  // namespace isoloft
