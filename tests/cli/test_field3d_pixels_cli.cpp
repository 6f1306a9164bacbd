// `isoloft reconstruct --method field3d` on pixel input: a label volume
// annotated along several axes (--annotated, --annotated-mask), a mask
// stack, and what it refuses (naming the flag, nothing written).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli/cli_test_util.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/png.h"
#include "isoloft/io/volume.h"

using namespace isoloft;
using isoloft::test::Cli;
using isoloft::test::CliRun;
namespace fs = std::filesystem;

namespace {

constexpr double kBallRadius = 10.0;  // mm (1 mm voxels)
const Vec3d kOrigin(-20.0, 15.0, 40.0);
const Vec3d kCentreVoxel(15.3, 15.6, 16.2);

/// The sphere's label 3 in a 32^3 volume of 1 mm voxels (every slice filled;
/// only the annotated ones are read).
Volume sphere_labels() {
  Volume v;
  v.nx = v.ny = v.nz = 32;
  v.spacing = {1.0, 1.0, 1.0};
  v.origin = {kOrigin.x(), kOrigin.y(), kOrigin.z()};
  v.direction = Eigen::Matrix3d::Identity();
  v.integer = true;
  v.data.assign(std::size_t(v.nx) * v.ny * v.nz, 0.0f);
  for (int k = 0; k < v.nz; ++k)
    for (int j = 0; j < v.ny; ++j)
      for (int i = 0; i < v.nx; ++i)
        if ((Vec3d(i, j, k) - kCentreVoxel).norm() < kBallRadius) v.data[v.index(i, j, k)] = 3;
  return v;
}

/// Five annotated slices (three axial, one sagittal, one coronal) pin the
/// sphere: measured largest |r - R| 0.67 mm (0.35 with field3d.band 32).
/// The drawn voxels alone place the boundary up to half a voxel off the
/// sphere and between the planes the fill flattens, so a voxel: 1 mm.
constexpr double kRadialSlack = 1.0;

void expect_sphere(const TriMesh& m) {
  ASSERT_GT(m.triangles.size(), 500u);
  const Vec3d c = kOrigin + kCentreVoxel;
  double worst = 0;
  std::size_t at = 0;
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const double d = std::abs((m.vertices[i].cast<double>() - c).norm() - kBallRadius);
    if (d > worst) worst = d, at = i;
  }
  EXPECT_LE(worst, kRadialSlack) << "vertex " << at;
}

}  // namespace

// Slices along k, i and j of one label volume: one closed surface in patient
// mm, from the slice list or from a mask volume marking the same slices.
TEST_F(Cli, Field3dReadsALabelVolumeAnnotatedAlongSeveralAxes) {
  write_volume(p("seg.nrrd"), sphere_labels());
  // The defaults: one cell per voxel (~26 over the sphere's box; pixel_resolution()).
  const CliRun r = run("reconstruct " + p("seg.nrrd") + " --method field3d --annotated 'k:10,16,22;i:15;j:16' -o " +
                       p("a.ply") + " --report " + p("a.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  expect_sphere(read_mesh(p("a.ply")));
  std::ifstream in(p("a.json"));
  const auto rep = nlohmann::json::parse(in);
  EXPECT_EQ(rep["objects"][0]["label"], 3);
  EXPECT_TRUE(rep["objects"][0]["closed"].get<bool>());
  EXPECT_EQ(rep["objects"][0]["components"], 1);
  EXPECT_EQ(rep["objects"][0]["slices_with_contours"], 5);

  Volume mask = sphere_labels();
  std::fill(mask.data.begin(), mask.data.end(), 0.0f);
  for (int k = 0; k < mask.nz; ++k)
    for (int j = 0; j < mask.ny; ++j)
      for (int i = 0; i < mask.nx; ++i)
        if (k == 10 || k == 16 || k == 22 || i == 15 || j == 16) mask.data[mask.index(i, j, k)] = 1;
  write_volume(p("annotated.nrrd"), mask);
  const CliRun m = run("reconstruct " + p("seg.nrrd") + " --method field3d --annotated-mask " + p("annotated.nrrd") +
                       " -o " + p("b.ply"));
  ASSERT_EQ(m.code, 0) << m.err;
  expect_sphere(read_mesh(p("b.ply")));
}

// Pixel input's grid (field3d.pixel_resolution, up to 1024 cells per axis)
// is estimated before it is made, and one over the budget stops naming the
// label and the file; exit 1, nothing written.
TEST_F(Cli, Field3dPixelGridOverTheMemoryBudgetIsRefused) {
  write_volume(p("seg.nrrd"), sphere_labels());
  std::ofstream(p("fine.json")) << R"({"field3d": {"pixel_resolution": 1024}})";
  const CliRun r = run("reconstruct " + p("seg.nrrd") + " --method field3d --annotated 'k:10,16,22;i:15;j:16' -o " +
                       p("a.ply") + " --params " + p("fine.json"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("--max-memory: label 3 of " + p("seg.nrrd") + " (field3d: a "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("over the budget of 4 GiB"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(p("a.ply")));
}

// Masks as PNG slices through field3d: one closed surface.
TEST_F(Cli, Field3dReadsAMaskStack) {
  fs::create_directories(p("masks"));
  for (int k = 0; k < 6; ++k) {
    Grid2u8 g(32, 32, 0);
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 32; ++x) g(x, y) = std::hypot(x - 15.5, y - 15.2) < 10 - std::abs(k - 2.5) ? 255 : 0;
    write_png(p("masks/s" + std::to_string(k) + ".png"), g);
  }
  const CliRun r = run("reconstruct " + p("masks") + " --input masks --z-spacing 2 --method field3d -o " + p("m.ply") +
                       " --report " + p("m.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(p("m.json"));
  const auto rep = nlohmann::json::parse(in);
  EXPECT_TRUE(rep["objects"][0]["closed"].get<bool>());
  EXPECT_EQ(rep["objects"][0]["components"], 1);
  // Pixel input's sign constraints in the report: pixel centres checked,
  // those made penalties among them, none left on the wrong side.
  const auto& f = rep["objects"][0]["field3d"];
  EXPECT_EQ(f["planes"].get<int>(), 6);
  EXPECT_GT(f["sign_points"].get<long>(), 0);
  EXPECT_LE(f["sign_active"].get<long>(), f["sign_points"].get<long>());
  EXPECT_EQ(f["sign_violated"].get<long>(), 0) << f.dump();
}

// The flags refused where they cannot apply, naming them; nothing written.
TEST_F(Cli, AnnotatedFlagsRefusedWhereTheyCannotApply) {
  write_volume(p("seg.nrrd"), sphere_labels());
  write_circle(p("c.png"));
  const CliRun png = run("reconstruct " + p("c.png") + " --method field3d --annotated 'k:1' -o " + p("a.ply"));
  EXPECT_EQ(png.code, 1);
  EXPECT_NE(png.err.find("--annotated"), std::string::npos) << png.err;
  const CliRun axis = run("reconstruct " + p("seg.nrrd") + " --method field3d --annotated 'q:3' -o " + p("a.ply"));
  EXPECT_EQ(axis.code, 1);
  EXPECT_NE(axis.err.find("--annotated"), std::string::npos) << axis.err;
  EXPECT_NE(axis.err.find("q:3"), std::string::npos) << axis.err;
  const CliRun method = run("reconstruct " + p("seg.nrrd") + " --annotated 'k:10;i:15' -o " + p("a.ply"));
  EXPECT_EQ(method.code, 1);
  EXPECT_NE(method.err.find("--method field3d"), std::string::npos) << method.err;
  const CliRun both = run("reconstruct " + p("seg.nrrd") + " --method field3d --annotated 'k:10' --axis k -o " + p("a.ply"));
  EXPECT_EQ(both.code, 1);
  EXPECT_NE(both.err.find("--axis"), std::string::npos) << both.err;
  EXPECT_FALSE(fs::exists(p("a.ply")));
}

// The annotation mask's own data file (a MetaImage header and its .raw) is
// read with the input: an output naming it is refused and it is left as it was.
TEST_F(Cli, AnnotationMaskDataFileIsNeverAnOutput) {
  write_volume(p("seg.nrrd"), sphere_labels());
  const Volume v = sphere_labels();
  std::string bytes(std::size_t(v.nx) * v.ny * v.nz, '\0');
  for (int k = 0; k < v.nz; ++k)
    for (int j = 0; j < v.ny; ++j)
      for (int i = 0; i < v.nx; ++i)
        if (k == 10 || k == 16 || k == 22 || i == 15 || j == 16) bytes[v.index(i, j, k)] = 1;
  std::ofstream(p("mask.raw"), std::ios::binary) << bytes;
  std::ofstream(p("mask.mhd")) << "ObjectType = Image\nNDims = 3\nDimSize = 32 32 32\nElementType = MET_UCHAR\n"
                               << "ElementSpacing = 1 1 1\nOffset = " << kOrigin.x() << " " << kOrigin.y() << " "
                               << kOrigin.z() << "\nElementDataFile = mask.raw\n";
  const std::string cmd = "reconstruct " + p("seg.nrrd") + " --method field3d --annotated-mask " + p("mask.mhd") +
                          " -o " + p("m.ply") + " --report ";
  const CliRun ok = run(cmd + p("ok.json"));
  ASSERT_EQ(ok.code, 0) << ok.err;
  const CliRun r = run(cmd + p("mask.raw"));
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("--report " + p("mask.raw")), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("an output never replaces a file the run reads"), std::string::npos) << r.err;
  EXPECT_EQ(fs::file_size(p("mask.raw")), bytes.size());
}
