// `isoloft reconstruct FILE.csl --method field3d`: sections at any angle
// through the CLI's one run path (run.cpp), and what it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli/cli_test_util.h"
#include "isoloft/field3d/field3d.h"
#include "isoloft/io/mesh_io.h"

using namespace isoloft;
using isoloft::test::Cli;
using isoloft::test::CliRun;
namespace fs = std::filesystem;

namespace {

constexpr double kRadius = 1.0;
constexpr int kLoopPoints = 64;

// The unit sphere cut by five planes, two of them tilted: (unit normal, offset
// along it); each section is the circle of radius sqrt(1 - d^2), CSL's format.
void write_sphere_csl(const std::string& path) {
  const std::vector<std::pair<Eigen::Vector3d, double>> planes{
      {Eigen::Vector3d(0, 0, 1), 0.0},
      {Eigen::Vector3d(0, 0, 1), 0.6},
      {Eigen::Vector3d(1, 0, 0), -0.3},
      {Eigen::Vector3d(1, 1, 0).normalized(), 0.2},
      {Eigen::Vector3d(0, 1, 1).normalized(), -0.5}};
  std::ofstream out(path);
  out << "CSLC\n" << planes.size() << " 2\n\n";
  for (std::size_t i = 0; i < planes.size(); ++i) {
    const auto& [n, d] = planes[i];
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    const double r = std::sqrt(kRadius * kRadius - d * d);
    out << i + 1 << " " << kLoopPoints << " 1 " << n.x() << " " << n.y() << " " << n.z() << " " << -d << "\n\n";
    for (int k = 0; k < kLoopPoints; ++k) {
      const double a = 2 * M_PI * k / kLoopPoints;
      const Eigen::Vector3d p = n * d + r * (std::cos(a) * u + std::sin(a) * v);
      out << p.x() << " " << p.y() << " " << p.z() << "\n";
    }
    out << "\n" << kLoopPoints << " 1";
    for (int k = 0; k < kLoopPoints; ++k) out << " " << k;
    out << "\n\n";
  }
}

}  // namespace

// Five sections of a sphere, two tilted: one closed surface through every
// drawn circle, its vertices near the sphere (between the planes the field is
// the smoothest the sections allow, not the sphere itself).
TEST_F(Cli, ReconstructsACslFileWithTheField3dMethod) {
  write_sphere_csl(p("sphere.csl"));
  const CliRun r = run("reconstruct " + p("sphere.csl") + " --method field3d -o " + p("out.ply") + " --report " +
                       p("report.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const TriMesh m = read_mesh(p("out.ply"));
  ASSERT_GT(m.triangles.size(), 1000u);
  // Five circles pin the sphere on five planes; between them the
  // bi-Laplacian fill flattens or bulges: measured at most 0.082 of the
  // radius (95th percentile 0.051) at the defaults, so a tenth of the radius.
  constexpr double kRadialSlack = 0.1;
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    ASSERT_NEAR(m.vertices[i].cast<double>().norm(), kRadius, kRadialSlack) << "vertex " << i;
  std::ifstream in(p("report.json"));
  const auto rep = nlohmann::json::parse(in);
  EXPECT_EQ(rep["input"]["format"], "csl");
  EXPECT_EQ(rep["input"]["planes"], 5);
  EXPECT_EQ(rep["params"]["method"], "field3d");
  EXPECT_TRUE(rep["objects"][0]["closed"].get<bool>());
  // The solve's figures (objects[i].field3d): every plane checked, exact
  // circles of one sphere never conflict, the solver stopped at its tolerance.
  const auto& f = rep["objects"][0]["field3d"];
  for (int a = 0; a < 3; ++a) EXPECT_GT(f["grid_nodes"][a].get<int>(), 1) << "axis " << a;
  EXPECT_GT(f["samples"].get<long>(), 0);
  EXPECT_GT(f["finest_iterations"].get<int>(), 0);
  EXPECT_LE(f["finest_iterations"].get<int>(), f["iterations"].get<int>());
  EXPECT_LE(f["relative_residual"].get<double>(), Field3dParams{}.tolerance);
  EXPECT_EQ(f["conflicts"].get<int>(), 0);
  EXPECT_EQ(f["planes"].get<int>(), 5);
  // The mesh's section on each plane against the drawn circle: measured
  // 0.001 mm (circles of radius 0.8-1 mm), so a hundredth of the radius.
  constexpr double kPlaneResidual = 0.01 * kRadius;
  EXPECT_LT(f["plane_mesh_to_drawn_max_mm"].get<double>(), kPlaneResidual);
  EXPECT_LT(f["plane_drawn_to_mesh_max_mm"].get<double>(), kPlaneResidual);
  EXPECT_GT(f["seconds"].get<double>(), 0);
}

// A CSL file's planes are not parallel slices: another method is refused,
// naming the one that reads them; outputs made of slice fields are refused
// with field3d; nothing is written.
TEST_F(Cli, RefusesWhatTheField3dMethodCannotDo) {
  write_sphere_csl(p("sphere.csl"));
  const CliRun other = run("reconstruct " + p("sphere.csl") + " -o " + p("a.ply"));
  EXPECT_EQ(other.code, 1);
  EXPECT_NE(other.err.find("--method field3d"), std::string::npos) << other.err;
  EXPECT_FALSE(fs::exists(p("a.ply")));
  const CliRun volume = run("reconstruct " + p("sphere.csl") + " --method field3d -o " + p("b.ply") + " --volume " +
                            p("v.nrrd"));
  EXPECT_EQ(volume.code, 1);
  EXPECT_NE(volume.err.find("--volume"), std::string::npos) << volume.err;
  EXPECT_FALSE(fs::exists(p("b.ply")));
  EXPECT_FALSE(fs::exists(p("v.nrrd")));
  const CliRun z = run("reconstruct " + p("sphere.csl") + " --method field3d --z-spacing 2 -o " + p("c.ply"));
  EXPECT_EQ(z.code, 1);
  EXPECT_NE(z.err.find("--z-spacing"), std::string::npos) << z.err;
}

// field3d's grid is estimated before it is made (issue 35 hostile input): a
// grid over the budget stops with an error naming the flag, the label, the
// file, the grid and both sizes; exit 1, nothing written.
TEST_F(Cli, Field3dOverTheMemoryBudgetIsRefusedBeforeTheSolve) {
  write_sphere_csl(p("sphere.csl"));
  // 1024 cells along the longest side: ~1.1e9 nodes, ~100 GiB estimated, over the default 4 GiB.
  std::ofstream(p("fine.json")) << R"({"field3d": {"resolution": 1024}})";
  const CliRun fine = run("reconstruct " + p("sphere.csl") + " --method field3d --params " + p("fine.json") + " -o " +
                          p("a.ply") + " --report " + p("a.json"));
  EXPECT_EQ(fine.code, 1);
  EXPECT_NE(fine.err.find("--max-memory: label 1 of " + p("sphere.csl") + " (field3d: a 1025x"), std::string::npos)
      << fine.err;
  EXPECT_NE(fine.err.find("over the budget of 4 GiB"), std::string::npos) << fine.err;
  EXPECT_FALSE(fs::exists(p("a.ply")));
  EXPECT_FALSE(fs::exists(p("a.json")));
  // The default grid (96 cells, ~0.1 GiB estimated) under a 1 MiB budget.
  const CliRun small = run("reconstruct " + p("sphere.csl") + " --method field3d --max-memory 1M -o " + p("b.ply"));
  EXPECT_EQ(small.code, 1);
  EXPECT_NE(small.err.find("--max-memory: label 1 of"), std::string::npos) << small.err;
  EXPECT_NE(small.err.find("over the budget of 1 MiB"), std::string::npos) << small.err;
  EXPECT_FALSE(fs::exists(p("b.ply")));
}
