// Label names from the table beside a label volume or --label-names (issue
// 38 item 4): in the mesh file names (safe characters), the report and the
// volume table; numbers stay the fallback.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli/cli_test_util.h"
#include "isoloft/io/volume.h"

using namespace isoloft;
using isoloft::test::Cli;
using isoloft::test::CliRun;
namespace fs = std::filesystem;

using isoloft::test::write_two_labels;

TEST_F(Cli, LabelNamesBesideTheVolumeNameFilesReportAndTable) {
  write_two_labels(p("atlas.nii.gz"));
  std::ofstream(p("atlas.nii.txt")) << "4 Left_Lung 2001\n9 =Heart/../x 2002\n";  // AAL's layout
  const CliRun r = run("reconstruct " + p("atlas.nii.gz") + " --method levin -q -o " + p("m.ply") + " --report " +
                       p("r.json") + " --volumes " + p("v.csv"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(p("m_label4_Left_Lung.ply")));
  EXPECT_TRUE(fs::exists(p("m_label9__Heart____x.ply"))) << "unsafe characters become '_'";
  const auto rep = nlohmann::json::parse(isoloft::test::read_text(p("r.json")));
  EXPECT_EQ(rep["input"]["label_names"], p("atlas.nii.txt"));
  EXPECT_EQ(rep["objects"][0]["name"], "Left_Lung");
  EXPECT_EQ(rep["objects"][1]["name"], "=Heart/../x");
  const std::string csv = isoloft::test::read_text(p("v.csv"));
  EXPECT_NE(csv.find("\nLeft_Lung,4,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\n\"'=Heart/../x\",9,"), std::string::npos) << "a formula name neutralised: " << csv;
}

TEST_F(Cli, LabelNamesFlagTakesAnyTableAndIsRefusedWhereItCannotApply) {
  write_two_labels(p("seg.nrrd"));
  std::ofstream(p("snap.txt")) << "    0     0    0    0        0  0  0    \"Clear Label\"\n"
                                  "    4   255    0    0        1  1  1    \"Left lung\"\n";
  const CliRun r = run("reconstruct " + p("seg.nrrd") + " --label-names " + p("snap.txt") + " --method levin -q -o " +
                       p("m.ply") + " --report " + p("r.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(p("m_label4_Left_lung.ply")));
  EXPECT_TRUE(fs::exists(p("m_label9.ply"))) << "a label the table does not name keeps its number";
  std::ofstream(p("bad.txt")) << "4 a\nfour b\n";
  const CliRun bad = run("reconstruct " + p("seg.nrrd") + " --label-names " + p("bad.txt") + " -q -o " + p("b.ply"));
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.err.find(p("bad.txt") + ": line 2: expected a label number"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(p("b.ply")));
  write_circle(p("a.png"));
  write_circle(p("b.png"));
  const CliRun png = run("reconstruct " + p("a.png") + " " + p("b.png") + " --label-names " + p("snap.txt") + " -o " + p("x.ply"));
  EXPECT_EQ(png.code, 1);
  EXPECT_NE(png.err.find("--label-names"), std::string::npos) << png.err;
}
