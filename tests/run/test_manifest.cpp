// A cohort's manifest (run/manifest.h): the CSV as Python's csv module reads
// it (the batch read it with csv before), the options as shlex.split splits
// them (expected words printed by Python 3.11's shlex), and every row that
// cannot run recorded with why while the others stay.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/run/manifest.h"

using namespace isoloft;

namespace {

std::vector<ManifestCase> cases_of(const std::string& text) {
  std::vector<ManifestRow> rows;
  for (const ManifestRecord& r : parse_manifest_csv(text, "m.csv")) rows.push_back(manifest_row(r));
  return check_manifest_rows(rows, "/base", "m.csv");
}

std::string error_of(const std::string& text) {
  try {
    (void)parse_manifest_csv(text, "m.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(Manifest, ReadsTheCsvAsPythonsCsvModule) {
  // A BOM, CR LF and bare CR line ends, a blank line, a quoted comma, a
  // doubled quote, a quote inside an unquoted field, a missing column.
  const auto recs = parse_manifest_csv(
      "\xEF\xBB\xBFinput,name,options\r\na.png,\"x,1\",\"--roi \"\"A B\"\"\"\r\n\r\nb\"c,y\rd\n", "m.csv");
  ASSERT_EQ(recs.size(), 3u);
  EXPECT_EQ(recs[0].row, 2u);
  EXPECT_EQ(*recs[0].fields.at("input"), "a.png");
  EXPECT_EQ(*recs[0].fields.at("name"), "x,1");
  EXPECT_EQ(*recs[0].fields.at("options"), "--roi \"A B\"");
  EXPECT_EQ(recs[1].row, 3u);
  EXPECT_EQ(recs[1].line, 4u);
  EXPECT_EQ(*recs[1].fields.at("input"), "b\"c");
  EXPECT_FALSE(recs[1].fields.at("options").has_value());
  EXPECT_EQ(*recs[2].fields.at("input"), "d");
}

TEST(Manifest, RefusesMergedRowsOpenQuotesAndNonUtf8NamingTheLine) {
  EXPECT_EQ(error_of("input,name,options\na,x,\"--z-spacing 8\nb,y,\nc,z,\"\n"),
            "m.csv: line 2: a field spans several lines (an unbalanced quote?)");
  EXPECT_EQ(error_of("input,name,options\na,x,\"--z-spacing 8\nb,y,\n"),
            "m.csv: line 4: unexpected end of data (an unbalanced quote?)");
  EXPECT_EQ(error_of("input,name\n\"a\"b,x\n"), "m.csv: line 2: ',' expected after '\"' (an unbalanced quote?)");
  EXPECT_NE(error_of("input,name\na\xFF,x\n").find("m.csv: not UTF-8 text (byte 12"), std::string::npos);
}

TEST(Manifest, SplitsOptionsAsShlex) {
  // shlex.split("a 'b c'd \"e\\\"f\\g\" h\\ i ''") == ['a', 'b cd', 'e"f\\g', 'h i', '']
  const std::vector<std::string> want{"a", "b cd", "e\"f\\g", "h i", ""};
  EXPECT_EQ(detail::shell_words("a 'b c'd \"e\\\"f\\g\" h\\ i ''"), want);
  EXPECT_THROW((void)detail::shell_words("x\\"), ParamError);
  try {
    (void)detail::shell_words("--roi \"Heart");
    ADD_FAILURE() << "no error";
  } catch (const ParamError& e) {
    EXPECT_STREQ(e.what(), "No closing quotation");
  }
}

TEST(Manifest, BadRowsCarryWhyAndTheOthersRun) {
  const std::string long_name(300, 'n');
  const auto c = cases_of(
      "input,name,options\n"
      "in/./a.png,good,--z-spacing 8 --volume v.nrrd\n"
      "a.png,abs,--volume /tmp/x.nrrd\n"
      "a.png,up,--volumes=sub/../../x.csv\n"
      "a.png,rt,--rt-contours ../c.csv\n"
      "a.png,summary.csv,\n"
      "a.png,.hidden,\n"
      "a.png," + long_name + ",\n"
      "a.png,quote,--roi \"Heart\n"
      ",noinput,\n"
      "a.png,own,-ox.ply\n"
      "a.png,thr,--threads=4\n"
      "a.png,esc\x1b]0;x\x07/y,\n"
      "/abs/c.nii.gz,,\n");
  ASSERT_EQ(c.size(), 13u);
  EXPECT_EQ(c[0].input, "/base/in/a.png");
  EXPECT_EQ(c[0].error, "");
  EXPECT_EQ(c[0].options, (std::vector<std::string>{"--z-spacing", "8", "--volume", "v.nrrd"}));
  const std::vector<std::string> want{
      "m.csv: row 3: --volume /tmp/x.nrrd: outputs stay in the case's folder (a relative path without '..')",
      "m.csv: row 4: --volumes sub/../../x.csv: outputs stay",
      "m.csv: row 5: --rt-contours ../c.csv: outputs stay",
      "m.csv: row 6: the name 'summary.csv' is reserved for the batch's summary.csv",
      "m.csv: row 7: the name '.hidden' starts with a dot",
      "m.csv: row 8: the name '" + long_name + "' is longer than 246 bytes",
      "m.csv: row 9: options: No closing quotation",
      "m.csv: row 10: no 'input'",
      "m.csv: row 11: -o is set by the batch",
      "m.csv: row 12: --threads is set by the batch",
      "m.csv: row 13: the name 'esc\\x1B]0;x\\x07/y' is not a folder name"};
  for (std::size_t i = 0; i < want.size(); ++i)
    EXPECT_EQ(c[i + 1].error.rfind(want[i], 0), 0u) << "case " << i + 1 << ": " << c[i + 1].error;
  EXPECT_EQ(c[12].name, "c") << "the input's name up to its first dot";
  EXPECT_EQ(c[12].input, "/abs/c.nii.gz");
  EXPECT_EQ(c[12].error, "");
}

// A bare CR ends a row as Python's csv reads it; what follows is a row of
// its own whose input (a dot file) gives no name: that row fails alone.
TEST(Manifest, ARowWhoseNameComesOutEmptyFailsAlone) {
  const auto c = cases_of("input,name,options\nb.png,up,\r.vc\n/d/.e,,\na.png,ok,\n");
  ASSERT_EQ(c.size(), 4u);
  EXPECT_EQ(c[0].error, "");
  for (const std::size_t i : {1u, 2u}) EXPECT_NE(c[i].error.find("the name '' is empty"), std::string::npos) << "case " << i << ": " << c[i].error;
  EXPECT_EQ(c[3].error, "");
}

TEST(Manifest, ANameUsedTwiceRefusesTheManifest) {
  try {
    (void)cases_of("input,name,options\na.png,x,\nb.png,x,\n");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "m.csv: row 3: the name 'x' is used twice");
  }
}

TEST(Manifest, AFifoOrAFolderIsNotAManifest) {
  EXPECT_THROW((void)read_manifest("/"), InputError);
  try {
    (void)read_manifest("/dev/null");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/dev/null: the manifest is not a regular file");
  }
}
