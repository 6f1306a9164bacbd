// Label tables beside label maps (io/label_names.h): the AAL atlas's own
// aal.nii.txt (Debian mricron-data) when installed, and each format's lines
// written by hand; bad tables are errors naming the line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "isoloft/core/error.h"
#include "isoloft/io/label_names.h"

using namespace isoloft;
namespace fs = std::filesystem;

namespace {

class LabelNamesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("isoloft_labelnames_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = (dir_ / name).string();
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  std::string error(const std::string& text) {
    try {
      (void)read_label_names(write("bad.txt", text));
    } catch (const InputError& e) {
      return e.what();
    }
    return "accepted";
  }
  fs::path dir_;
};

}  // namespace

TEST_F(LabelNamesTest, ReadsTheAalTableOfMricronData) {
  const std::string aal = "/usr/share/mricron/templates/aal.nii.txt";
  if (!fs::exists(aal)) GTEST_SKIP() << aal << " not installed (Debian mricron-data)";
  const LabelNames t = read_label_names(aal);
  EXPECT_EQ(t.names.size(), 116u) << "AAL's 116 structures";
  EXPECT_EQ(t.name(1), "Precentral_L");
  EXPECT_EQ(t.name(116), "Vermis_10");
  EXPECT_EQ(label_names_beside("/usr/share/mricron/templates/aal.nii.gz"), aal);
}

TEST_F(LabelNamesTest, ReadsEachFormatsLines) {
  const LabelNames fs_lut = read_label_names(write("FreeSurferColorLUT.txt",
                                                   "#No. Label Name:  R G B A\n\n0   Unknown  0 0 0 0\n"
                                                   "17  Left-Hippocampus  220 216 20 0\n"));
  EXPECT_EQ(fs_lut.names.size(), 1u) << "label 0 is the background";
  EXPECT_EQ(fs_lut.name(17), "Left-Hippocampus");
  const LabelNames slicer = read_label_names(write("a.ctbl", "# Color table file a.ctbl\n1 liver 221 130 101 255\r\n"));
  EXPECT_EQ(slicer.name(1), "liver") << "CRLF lines";
  const LabelNames snap = read_label_names(write("snap.txt",
                                                 "################################################\n"
                                                 "    0     0    0    0        0  0  0    \"Clear Label\"\n"
                                                 "    1   255    0    0        1  1  1    \"Left lung\"\n"
                                                 "    2     0  255    0        1  1  1    \"=cmd|' /C calc'!A0\"\n"));
  EXPECT_EQ(snap.name(1), "Left lung") << "quoted names keep their blanks";
  EXPECT_EQ(snap.name(2), "=cmd|' /C calc'!A0") << "kept as written: sanitised where shown";
  EXPECT_EQ(read_label_names(write("bom.txt", "\xEF\xBB\xBF" "3 R\xC3\xBC" "cken\n")).name(3), "R\xC3\xBC" "cken");
}

TEST_F(LabelNamesTest, BadTablesAreErrorsNamingTheLine) {
  EXPECT_NE(error("1 a\nx b\n").find("line 2: expected a label number (0 .. 2^32 - 1) first, got 'x'"), std::string::npos)
      << error("1 a\nx b\n");
  EXPECT_NE(error("-1 a\n").find("line 1: expected a label number"), std::string::npos);
  EXPECT_NE(error("4294967296 a\n").find("line 1: expected a label number"), std::string::npos);
  EXPECT_NE(error("5\n").find("line 1: label 5 has no name"), std::string::npos);
  EXPECT_NE(error("1 1 1 1 \"open\n").find("line 1: a quote is not closed"), std::string::npos);
  EXPECT_NE(error(std::string("1 a\0b\n", 6)).find("line 1: a NUL byte"), std::string::npos);
  EXPECT_NE(error("1 caf\xE9\n").find("line 1: not UTF-8 text ('1 caf\\xE9')"), std::string::npos) << error("1 caf\xE9\n");
  EXPECT_NE(error("1 a\n2 b\n1 c\n").find("line 3: label 1 is named 'c' here and 'a' on line 1"), std::string::npos)
      << error("1 a\n2 b\n1 c\n");
  EXPECT_NE(error("# only comments\n0 Unknown\n").find("no label is named"), std::string::npos);
  EXPECT_EQ(read_label_names(write("dup.txt", "1 a\n1 a\n")).names.size(), 1u) << "the same line twice is one label";
  fs::create_directories(dir_ / "fifo_dir");
  EXPECT_THROW((void)read_label_names((dir_ / "fifo_dir").string()), InputError) << "not a regular file";
}
