// `isoloft reconstruct` on label volumes and DICOM RT Structure Sets: the
// commands of the README, physical space in the outputs, the flags only some
// inputs take, and bad input (one line naming the file and the problem, exit
// status 1, no output left behind).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli/cli_test_util.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/volume.h"

using namespace isoloft;
using isoloft::test::Cli;
using isoloft::test::CliRun;
namespace fs = std::filesystem;

namespace {

using isoloft::test::kRtss;

// Two labels drawn on every other axial slice, 1 x 1 x 2 mm voxels, rotated.
Volume sparse_labels() {
  Volume v;
  v.nx = 40, v.ny = 36, v.nz = 11;
  v.spacing = {1.0, 1.0, 2.0};
  v.origin = {-20.0, 15.0, 40.0};
  v.direction = Eigen::Vector3d(-1, 1, 1).asDiagonal();
  v.integer = true;
  v.data.assign(std::size_t(v.nx) * v.ny * v.nz, 0.0f);
  for (int k = 1; k < v.nz - 1; k += 2)
    for (int j = 0; j < v.ny; ++j)
      for (int i = 0; i < v.nx; ++i) {
        if (std::hypot(i - 14.0, j - 17.0) < 8.0 - std::abs(k - 5.0)) v.data[v.index(i, j, k)] = 4;
        if (i > 26 && i < 33 && j > 10 && j < 26) v.data[v.index(i, j, k)] = 9;
      }
  return v;
}

std::string ply_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string h, line;
  while (std::getline(in, line) && line != "end_header") h += line + "\n";
  return h;
}

}  // namespace

TEST_F(Cli, RtStructListsItsRoisAndReconstructsOneInPatientSpace) {
  const CliRun list = run("reconstruct " + kRtss + " --list-rois");
  ASSERT_EQ(list.code, 0) << list.err;
  EXPECT_NE(list.out.find("'Heart'"), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("-98.4 .. -2.4"), std::string::npos) << list.out;
  const CliRun r = run("reconstruct " + kRtss + " --roi Heart --method levin -o " + p("heart.ply") + " --report " + p("r.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(ply_header(p("heart.ply")).find("comment SPACE=LPS"), std::string::npos);
  const TriMesh lps = read_mesh(p("heart.ply"));
  // Inside the Heart's contours' range (patient mm), not pixels.
  for (const auto& v : lps.vertices) ASSERT_TRUE(v.z() > -101 && v.z() < 1) << v.transpose();
  const CliRun ras = run("reconstruct " + kRtss + " --roi Heart --method levin --space ras -o " + p("heart_ras.ply"));
  ASSERT_EQ(ras.code, 0) << ras.err;
  EXPECT_NE(ply_header(p("heart_ras.ply")).find("comment SPACE=RAS"), std::string::npos);
  const TriMesh m = read_mesh(p("heart_ras.ply"));
  ASSERT_EQ(m.vertices.size(), lps.vertices.size());
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    ASSERT_EQ(m.vertices[i], Vec3f(-lps.vertices[i].x(), -lps.vertices[i].y(), lps.vertices[i].z())) << "vertex " << i;
  std::ifstream in(p("r.json"));
  const auto rep = nlohmann::json::parse(in);
  EXPECT_EQ(rep["input"]["format"], "rtstruct");
  EXPECT_EQ(rep["input"]["space"], "LPS");
  EXPECT_EQ(rep["objects"][0]["roi"], "Heart");
}

TEST_F(Cli, RtStructWithTwoRoisWritesEachAndACombinedMesh) {
  const CliRun r = run("reconstruct " + kRtss + " --roi Scar --roi \"Tumor Bed\" --method levin -o " + p("rt.ply"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(p("rt_Scar.ply")));
  EXPECT_TRUE(fs::exists(p("rt_Tumor_Bed.ply")));
  std::vector<Rgb> colours;
  const TriMesh all = read_mesh(p("rt.ply"), &colours);
  EXPECT_EQ(all.vertices.size(), read_mesh(p("rt_Scar.ply")).vertices.size() + read_mesh(p("rt_Tumor_Bed.ply")).vertices.size());
  EXPECT_EQ(colours.size(), all.vertices.size()) << "a colour per ROI (its DICOM display colour)";
}

TEST_F(Cli, SparseLabelVolumeGivesMeshesAndADenseLabelMap) {
  const Volume v = sparse_labels();
  write_volume(p("seg.nii.gz"), v);
  for (const char* out : {"fill.nii.gz", "fill.nrrd", "fill.mha"}) {
    const CliRun r = run("reconstruct " + p("seg.nii.gz") + " -o " + p("seg.ply") + " --labelmap " + p(out) + " --report " + p("r.json"));
    ASSERT_EQ(r.code, 0) << r.err;
    const Volume filled = read_volume(p(out));
    ASSERT_EQ(filled.nz, v.nz) << out;
    EXPECT_NEAR((filled.direction - v.direction).norm(), 0.0, 1e-6) << out;
    EXPECT_NEAR(filled.origin[0], v.origin[0], 1e-5) << out;
    // Slices 1, 3, ... as drawn; the ones between filled: the disk of label 4 at slice 4 (between 3 and 5).
    EXPECT_EQ(filled.at(14, 17, 3), 4.0f) << out;
    EXPECT_EQ(filled.at(14, 17, 4), 4.0f) << out;
    EXPECT_EQ(filled.at(30, 18, 4), 9.0f) << out;
    EXPECT_EQ(filled.at(2, 2, 4), 0.0f) << out;
  }
  EXPECT_TRUE(fs::exists(p("seg_label4.ply")));
  EXPECT_TRUE(fs::exists(p("seg_label9.ply")));
  std::ifstream in(p("r.json"));
  const auto rep = nlohmann::json::parse(in);
  EXPECT_EQ(rep["input"]["axis"], "k");
  EXPECT_EQ(rep["input"]["annotated_slices"].size(), 5u);
  // --input masks: one object from every non-zero voxel.
  const CliRun masks = run("reconstruct " + p("seg.nii.gz") + " --input masks -o " + p("mask.ply"));
  ASSERT_EQ(masks.code, 0) << masks.err;
  EXPECT_TRUE(fs::exists(p("mask.ply")));
}

TEST_F(Cli, FlagsTheInputCannotUseAreErrors) {
  write_circle(p("a.png"));
  write_circle(p("b.png"));
  const std::string pngs = p("a.png") + " " + p("b.png") + " -o " + p("o.ply");
  for (const std::string& flag : {std::string("--axis k"), std::string("--space ras"), std::string("--roi Heart"),
                                  std::string("--labelmap ") + p("l.nii.gz"), std::string("--voxel-size 1")}) {
    const CliRun r = run("reconstruct " + pngs + " " + flag);
    EXPECT_EQ(r.code, 1) << flag << ": " << r.err;
    EXPECT_NE(r.err.find(flag.substr(0, flag.find(' '))), std::string::npos) << r.err;
  }
  write_volume(p("seg.nii.gz"), sparse_labels());
  for (const std::string& flag : {std::string("--roi Heart"), std::string("--z-spacing 2"), std::string("--input contours")}) {
    const CliRun r = run("reconstruct " + p("seg.nii.gz") + " -o " + p("o.ply") + " " + flag);
    EXPECT_EQ(r.code, 1) << flag << ": " << r.err;
  }
  const CliRun r = run("reconstruct " + kRtss + " --roi Heart -o " + p("o.ply") + " --labelmap " + p("l.nii.gz"));
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_TRUE(leftovers("o").empty());
}

TEST_F(Cli, BadMedicalInputsAreOneLineErrorsWithNothingLeftBehind) {
  std::ifstream in(kRtss, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(p("trunc.dcm"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(p("random.dcm"), std::ios::binary) << "this is not DICOM";
  Volume empty = sparse_labels();
  std::fill(empty.data.begin(), empty.data.end(), 0.0f);
  write_volume(p("empty.nii.gz"), empty);
  Volume nan = sparse_labels();
  nan.integer = false;
  nan.data[5] = NAN;
  write_volume(p("nan.nrrd"), nan);
  const std::pair<std::string, std::string> cases[] = {
      {"trunc.dcm", "not a readable DICOM file"},
      {"random.dcm", "not a readable DICOM file"},
      {kRtss + " --roi Nowhere", "no ROI named or numbered 'Nowhere'"},
      {kRtss + " --roi Areola", "ROI 'Areola' has no closed planar contour"},
      {"empty.nii.gz", "0 annotated slice(s)"},
      {"nan.nrrd", "NaN voxel"},
  };
  for (const auto& [args, words] : cases) {
    const std::string in_arg = args.rfind('/', 0) == 0 ? args : p(args);
    const bool volume = args.find(".nii") != std::string::npos || args.find(".nrrd") != std::string::npos;
    const CliRun r = run("reconstruct " + in_arg + " -o " + p("out.ply") + " --report " + p("out.json") +
                         (volume ? " --labelmap " + p("out.nii.gz") : ""));
    EXPECT_EQ(r.code, 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_TRUE(leftovers("out").empty()) << args;
  }
}

// The README's Radiotherapy commands: the volume table on stdout and as CSV,
// the surfaces back as an RT Structure Set that reads back with the same
// ROIs and reconstructs to the same volumes (the round trip's measure is in
// io/test_rtstruct.cpp); an RT Structure Set out from other input is an error.
TEST_F(Cli, RtStructVolumesAndRtStructOut) {
  const CliRun r = run("reconstruct " + kRtss + " --roi Scar --roi 7 -o " + p("rt.dcm") + " --volumes " + p("v.csv"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("volume (cc)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'Scar'"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(p("rt_Scar.ply"))) << "-o OUT.dcm writes no mesh";
  std::ifstream csv(p("v.csv"));
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header, "name,number,volume_mm3,slab_volume_mm3,area_mm2,planes,closed,spacing,cap_share,warning");
  int rows = 0;
  while (std::getline(csv, line)) {
    ++rows;
    EXPECT_NE(line.find(",true"), std::string::npos) << line;
  }
  EXPECT_EQ(rows, 2);
  const CliRun back = run("reconstruct " + p("rt.dcm") + " --list-rois");
  ASSERT_EQ(back.code, 0) << back.err;
  EXPECT_NE(back.out.find("'Scar'"), std::string::npos) << back.out;
  EXPECT_EQ(back.out.find("'Heart'"), std::string::npos) << "only the ROIs reconstructed";
  write_circle(p("a.png"));
  write_circle(p("b.png"));
  const CliRun png = run("reconstruct " + p("a.png") + " " + p("b.png") + " -o " + p("x.dcm"));
  EXPECT_EQ(png.code, 1);
  EXPECT_NE(png.err.find("needs an RT Structure Set input"), std::string::npos) << png.err;
}
