// The isoloft executable: its contract (issue: foundation) and its handling
// of bad input: a one-line error naming the file, exit != 0, no output left.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli/cli_test_util.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/png.h"
#include "isoloft/pipeline.h"

using namespace isoloft;
using isoloft::test::Cli;
using isoloft::test::CliRun;
namespace fs = std::filesystem;


TEST_F(Cli, ReconstructsASynthesizedSphereWithAReport) {
  ASSERT_EQ(run("synth sphere --size 64 --z-spacing 8 --out " + p("sphere")).code, 0);
  ASSERT_TRUE(fs::exists(p("sphere/shape.json")));
  const CliRun r = run("reconstruct " + p("sphere") + " --method levin --z-spacing 8 -o " + p("out.ply") + " --report " + p("report.json") +
                    " --volume " + p("vol.nrrd"));
  ASSERT_EQ(r.code, 0) << r.err;
  const TriMesh m = read_mesh(p("out.ply"));
  EXPECT_GT(m.triangles.size(), 100u);
  std::ifstream in(p("report.json"));
  const auto rep = nlohmann::json::parse(in);
  for (const char* key : {"contour", "mpu", "dist", "filter", "interp", "mesh", "decimate", "total"})
    EXPECT_TRUE(rep["timings_s"].contains(key)) << key;
  EXPECT_EQ(rep["params"]["method"], "levin");
  EXPECT_TRUE(rep["objects"][0]["closed"].get<bool>());
  EXPECT_TRUE(rep["isoloft"].contains("version"));
  EXPECT_TRUE(fs::exists(p("vol.nrrd")));
  const CliRun e = run("eval --mesh " + p("out.ply") + " --truth " + p("sphere/shape.json"));
  ASSERT_EQ(e.code, 0) << e.err;
  const auto ev = nlohmann::json::parse(e.out);
  EXPECT_LT(ev["mesh_to_truth"]["in_range"]["mean_distance_px"].get<double>(), 1.0);
}

// The CLI runs itself once more on a heap of transparent huge pages with
// one arena (lib/cli/main.cpp; docs/decisions.md: the CLI's heap) and says
// so in the report; ISOLOFT_HUGE_PAGES=0 or the caller's own glibc tunables
// keep the process as called. Every setting gives the same mesh.
TEST_F(Cli, TheReportSaysHowTheHeapWasSetUp) {
  ASSERT_EQ(run("synth sphere --size 48 --z-spacing 6 --out " + p("sphere")).code, 0);
  auto heap_of = [&](const std::string& name) {
    const CliRun r = run("reconstruct " + p("sphere") + " --z-spacing 6 -o " + p(name + ".ply") + " --report " + p(name + ".json"));
    EXPECT_EQ(r.code, 0) << name << ": " << r.err;
    std::ifstream in(p(name + ".json"));
    return nlohmann::json::parse(in).value("heap", std::string("(none)"));
  };
  EXPECT_EQ(heap_of("default"), "huge pages, one arena (GLIBC_TUNABLES glibc.malloc.hugetlb=1:glibc.malloc.arena_max=1)");
  ::setenv("ISOLOFT_HUGE_PAGES", "0", 1);
  EXPECT_EQ(heap_of("off"), "as called (ISOLOFT_HUGE_PAGES=0)");
  ::unsetenv("ISOLOFT_HUGE_PAGES");
  ::setenv("GLIBC_TUNABLES", "glibc.malloc.arena_max=4", 1);
  EXPECT_EQ(heap_of("callers"), "as called (GLIBC_TUNABLES glibc.malloc.arena_max=4)");
  ::unsetenv("GLIBC_TUNABLES");
  const TriMesh a = read_mesh(p("default.ply")), b = read_mesh(p("off.ply")), c = read_mesh(p("callers.ply"));
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.vertices, c.vertices);
  EXPECT_EQ(a.triangles, c.triangles);
}

// The tilted-tube kit from the command line, reconstructed by the track z scheme
// (one piece, where the default spline gives one per slice); its flags are
// errors with another scheme, and the shape flags with another shape.
TEST_F(Cli, SynthesizesATiltedTubeThatTheTrackSchemeKeepsWhole) {
  const CliRun s = run("synth tube --tilt 80 --radius 3 --kind masks --out " + p("tube"));
  ASSERT_EQ(s.code, 0) << s.err;
  std::ifstream in(p("tube/shape.json"));
  const auto truth = nlohmann::json::parse(in);
  EXPECT_EQ(truth["components"], 1);
  EXPECT_EQ(truth["shape"]["type"], "tubes");
  const std::string hint = truth["reconstruct_hint"];
  const std::string args = hint.substr(hint.find(' ', hint.find("reconstruct")) + 1);
  const CliRun r = run("reconstruct " + args.substr(0, args.find(" -o ")) + " -o " + p("t.ply") + " --z-scheme track --report " +
                       p("r.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream rep_in(p("r.json"));
  const auto rep = nlohmann::json::parse(rep_in);
  EXPECT_EQ(rep["objects"][0]["components"], 1);
  EXPECT_EQ(rep["params"]["z_scheme"], "track");
  const CliRun e = run("eval --mesh " + p("t.ply") + " --truth " + p("tube/shape.json"));
  ASSERT_EQ(e.code, 0) << e.err;
  const CliRun wrong = run("reconstruct " + p("tube") + " --input masks -o " + p("c.ply") + " --track-motion auto");
  EXPECT_NE(wrong.code, 0);
  EXPECT_NE(wrong.err.find("--z-scheme track"), std::string::npos) << wrong.err;
  const CliRun tilt = run("synth sphere --tilt 80 --out " + p("sphere"));
  EXPECT_NE(tilt.code, 0);
  EXPECT_NE(tilt.err.find("tilted-tube"), std::string::npos) << tilt.err;
}

TEST_F(Cli, PrintParamsRoundTripsThroughParamsFile) {
  const CliRun r = run("reconstruct --print-params --spline natural");
  ASSERT_EQ(r.code, 0) << r.err;
  // JSON with a // comment (unit, valid values, doc) above every value.
  const auto j = nlohmann::json::parse(r.out, nullptr, true, /*ignore_comments=*/true);
  EXPECT_EQ(j["interp"]["spline"], "natural");
  EXPECT_NE(r.out.find("// points, integer >= 1: N_min"), std::string::npos) << r.out;
  std::ofstream(p("params.json")) << r.out;  // the commented text itself is a params file
  const CliRun again = run("reconstruct --print-params --params " + p("params.json"));
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_EQ(nlohmann::json::parse(again.out, nullptr, true, true), j);
  EXPECT_EQ(again.out, r.out);
  std::ofstream(p("bad.json")) << R"({"interp": {"splin": "linear"}})";
  const CliRun bad = run("reconstruct --print-params --params " + p("bad.json"));
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("bad.json"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("interp.splin"), std::string::npos) << bad.err;
}

// The method picks the defaults (isoloft: extremum-preserving z spline;
// marker2006: the paper's Hyman spline); a params file and flags override them,
// and --method overrides the file's method.
TEST_F(Cli, MethodPicksTheDefaultsThatFileAndFlagsOverride) {
  auto spline_of = [&](const std::string& args) {
    const CliRun r = run("reconstruct --print-params " + args);
    EXPECT_EQ(r.code, 0) << args << ": " << r.err;
    const auto j = nlohmann::json::parse(r.out, nullptr, true, true);
    return j["method"].get<std::string>() + " " + j["interp"]["spline"].get<std::string>();
  };
  EXPECT_EQ(spline_of(""), "isoloft extremum-preserving");
  EXPECT_EQ(spline_of("--method marker2006"), "marker2006 monotone");
  EXPECT_EQ(spline_of("--method marker2006 --spline linear"), "marker2006 linear");
  std::ofstream(p("m.json")) << R"({"method": "marker2006"})";
  EXPECT_EQ(spline_of("--params " + p("m.json")), "marker2006 monotone");
  EXPECT_EQ(spline_of("--params " + p("m.json") + " --method isoloft"), "isoloft extremum-preserving");
  std::ofstream(p("ms.json")) << R"({"method": "marker2006", "interp": {"spline": "natural"}})";
  EXPECT_EQ(spline_of("--params " + p("ms.json")), "marker2006 natural");
  EXPECT_EQ(params_to_json(ReconstructParams{}), params_to_json(method_defaults(Method::Isoloft)));
}

TEST_F(Cli, MissingFileIsNamed) {
  const CliRun r = run("reconstruct " + p("nope.png") + " " + p("nope2.png") + " -o " + p("out.ply"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("nope.png"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers("out").empty());
}

TEST_F(Cli, CorruptPngIsNamed) {
  write_circle(p("a.png"));
  std::ofstream(p("b.png")) << "\x89PNG\r\n\x1a\nthis is not a png";
  const CliRun r = run("reconstruct " + p("a.png") + " " + p("b.png") + " -o " + p("out.ply"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("b.png"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
  EXPECT_TRUE(leftovers("out").empty());
}

TEST_F(Cli, DifferentSizesAreNamed) {
  write_circle(p("a.png"), 24);
  write_circle(p("b.png"), 32);
  const CliRun r = run("reconstruct " + p("a.png") + " " + p("b.png") + " -o " + p("out.ply"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("b.png"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers("out").empty());
}

TEST_F(Cli, ZeroAndOneSliceAreRejected) {
  fs::create_directories(p("empty"));
  CliRun r = run("reconstruct " + p("empty") + " -o " + p("out.ply"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("empty"), std::string::npos) << r.err;
  write_circle(p("a.png"));
  r = run("reconstruct " + p("a.png") + " -o " + p("out.ply"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("a.png"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers("out").empty());
}

TEST_F(Cli, NonBinaryImageIsRejectedUnlessBinarized) {
  write_circle(p("a.png"));
  write_circle(p("b.png"), 24, 200);
  CliRun r = run("reconstruct " + p("a.png") + " " + p("b.png") + " --method levin -o " + p("out.ply"));
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("b.png"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("binary"), std::string::npos) << r.err;
  EXPECT_TRUE(leftovers("out").empty());
  r = run("reconstruct " + p("a.png") + " " + p("b.png") + " --method levin --binarize -o " + p("out.ply"));
  EXPECT_EQ(r.code, 0) << r.err;
}

TEST_F(Cli, UnknownOptionValueIsAUsageError) {
  write_circle(p("a.png"));
  write_circle(p("b.png"));
  const CliRun r = run("reconstruct " + p("a.png") + " " + p("b.png") + " --spline cubic -o " + p("out.ply"));
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.err.find("cubic"), std::string::npos) << r.err;
  const CliRun ext = run("reconstruct " + p("a.png") + " " + p("b.png") + " -o " + p("out.xyz"));
  EXPECT_NE(ext.code, 0);
  EXPECT_NE(ext.err.find("out.xyz"), std::string::npos) << ext.err;
}

TEST_F(Cli, LabelsWriteOneMeshPerLabelAndACombinedOne) {
  for (int k = 0; k < 3; ++k) {
    Grid2u8 g(40, 40, 0);
    for (int y = 0; y < 40; ++y)
      for (int x = 0; x < 40; ++x) {
        if (std::hypot(x - 12, y - 20) < 7) g(x, y) = 3;
        if (std::hypot(x - 28, y - 20) < 6) g(x, y) = 5;
      }
    write_png(p("l" + std::to_string(k) + ".png"), g);
  }
  const CliRun r = run("reconstruct " + p("l0.png") + " " + p("l1.png") + " " + p("l2.png") +
                    " --method levin --input labels --z-spacing 4 -o " + p("lab.ply"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(p("lab_label3.ply")));
  EXPECT_TRUE(fs::exists(p("lab_label5.ply")));
  std::vector<Rgb> colours;
  const TriMesh all = read_mesh(p("lab.ply"), &colours);
  EXPECT_EQ(colours.size(), all.vertices.size());
}

TEST_F(Cli, DumpStagesWritesEachSlicesFields) {
  ASSERT_EQ(run("synth sphere --size 48 --z-spacing 8 --out " + p("s")).code, 0);
  const CliRun r = run("reconstruct " + p("s") + " --z-spacing 8 -o " + p("m.ply") + " --dump-stages " + p("dump"));
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"mpu", "distance", "filtered", "difference"})
    EXPECT_TRUE(fs::exists(p(std::string("dump/label0_slice000_") + f + ".nrrd"))) << f;
  EXPECT_TRUE(fs::exists(p("dump/label0_slice000_points.csv")));
}

TEST_F(Cli, EvalAgainstAReferenceMeshGivesAVerdict) {
  ASSERT_EQ(run("synth sphere --size 48 --z-spacing 4 --out " + p("s")).code, 0);
  ASSERT_EQ(run("reconstruct " + p("s") + " --z-spacing 4 -o " + p("a.ply")).code, 0);
  ASSERT_EQ(run("reconstruct " + p("s") + " --z-spacing 4 --method levin -o " + p("b.ply")).code, 0);
  const CliRun same = run("eval --mesh " + p("a.ply") + " --reference " + p("a.ply") + " --threshold 0.5");
  ASSERT_EQ(same.code, 0) << same.err;
  EXPECT_EQ(nlohmann::json::parse(same.out)["verdict"], "pass");
  const CliRun other = run("eval --mesh " + p("a.ply") + " --reference " + p("b.ply"));
  ASSERT_EQ(other.code, 0) << other.err;
  const auto j = nlohmann::json::parse(other.out);
  EXPECT_TRUE(j["mesh_vs_reference"].contains("a_to_b")) << j.dump();
}
