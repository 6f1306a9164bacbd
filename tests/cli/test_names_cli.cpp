// Hostile and international ROI names through `isoloft reconstruct` (issue
// 39, names): no raw control byte on the terminal (volume table, --list-rois,
// warnings, errors), no formula cell in the --volumes CSV, Latin-1 names
// decoded (not a JSON library error), a NUL refused naming the ROI.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli/cli_test_util.h"
#include "io/rtstruct_names_util.h"

using isoloft::test::Cli;
using isoloft::test::CliRun;
namespace fs = std::filesystem;

namespace {

// The first byte below 0x20 (or DEL) other than the newline and the progress
// line's own "\r\033[K" (absent with -q), or npos.
std::size_t raw_control(const std::string& s) {
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if ((c < 0x20 && c != '\n') || c == 0x7F) return i;
  }
  return std::string::npos;
}

}  // namespace

TEST_F(Cli, RoiNamesWithEscapeSequencesReachNoTerminalRaw) {
  const std::string rt = p("esc.dcm");
  isoloft::test::write_rtss_names(rt, "ISO_IR 100", {{"Scar", "Scar\x1b]0;owned\x07\x1b[2J"}, {"Tumor Bed", "ok\rHeart"}});
  const CliRun list = run("reconstruct " + rt + " --list-rois");
  ASSERT_EQ(list.code, 0) << list.err;
  EXPECT_EQ(raw_control(list.out), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("'Scar\\x1B]0;owned\\x07\\x1B[2J'"), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("'ok\\x0DHeart'"), std::string::npos) << list.out;
  const CliRun r = run("reconstruct " + rt + " --roi 8 --roi 9 --method levin -q -o " + p("rt.ply"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(raw_control(r.out), std::string::npos) << "volume table: " << r.out;
  EXPECT_NE(r.out.find("'ok\\x0DHeart'"), std::string::npos) << r.out;
  // An error carrying the name: escaped too.
  const CliRun bad = run("reconstruct " + rt + " --roi 'Scar' -q -o " + p("x.ply"));
  EXPECT_EQ(bad.code, 1);
  EXPECT_EQ(raw_control(bad.err), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("'Scar\\x1B]0;owned\\x07\\x1B[2J' (number"), std::string::npos) << bad.err;
}

TEST_F(Cli, FormulaRoiNamesAreTextInTheVolumesCsv) {
  const std::string rt = p("formula.dcm");
  isoloft::test::write_rtss_names(rt, "ISO_IR 100",
                                  {{"Scar", "=HYPERLINK(\"http://evil\",\"x\")"}, {"Tumor Bed", "@SUM(1+1)"}});
  const CliRun r = run("reconstruct " + rt + " --roi 8 --roi 9 --method levin -q -o " + p("rt.ply") + " --volumes " + p("v.csv"));
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string csv = isoloft::test::read_text(p("v.csv"));
  EXPECT_NE(csv.find("\n\"'=HYPERLINK(\"\"http://evil\"\",\"\"x\"\")\","), std::string::npos) << csv;
  EXPECT_NE(csv.find("\n\"'@SUM(1+1)\","), std::string::npos) << csv;
  std::istringstream lines(csv);
  for (std::string line; std::getline(lines, line);)
    EXPECT_EQ(std::string("=+-@\t\r").find(line.front()), std::string::npos) << "a row starts a formula: " << line;
}

TEST_F(Cli, Latin1RoiNamesAreDecodedIntoTheReportAndNulIsRefused) {
  const std::string rt = p("latin1.dcm");
  isoloft::test::write_rtss_names(rt, "ISO_IR 100", {{"Scar", "R\xFC" "ckenmark"}});
  const CliRun r = run("reconstruct " + rt + " --roi R\xC3\xBC" "ckenmark --method levin -q -o " + p("rt.ply") + " --report " +
                       p("r.json") + " --volumes " + p("v.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto rep = nlohmann::json::parse(isoloft::test::read_text(p("r.json")));
  EXPECT_EQ(rep["objects"][0]["roi"], "R\xC3\xBC" "ckenmark");
  EXPECT_EQ(nlohmann::json::parse(isoloft::test::read_text(p("v.json")))[0]["name"], "R\xC3\xBC" "ckenmark");
  const std::string nul = p("nul.dcm");
  isoloft::test::write_rtss_names(nul, "ISO_IR 100", {{"Scar", std::string("AB\0CD", 5)}});
  const CliRun n = run("reconstruct " + nul + " -q -o " + p("n.ply") + " --report " + p("n.json"));
  EXPECT_EQ(n.code, 1);
  EXPECT_NE(n.err.find("ROI number 8: its name ('AB\\x00CD') holds a NUL byte"), std::string::npos) << n.err;
  EXPECT_FALSE(fs::exists(p("n.ply")));
  EXPECT_FALSE(fs::exists(p("n.json")));
}
