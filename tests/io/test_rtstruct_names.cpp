// ROI names as read from an RT Structure Set (io/rtstruct.h): decoded from
// the file's Specific Character Set to UTF-8 once, at read (Latin-1, UTF-8,
// ISO 2022 Japanese), and a NUL or undecodable bytes refused naming the ROI.
#include <gtest/gtest.h>

#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcfilefo.h"
#include "dcmtk/dcmdata/dcitem.h"

#include <filesystem>
#include <string>
#include <unistd.h>
#include <vector>

#include "io/rtstruct_names_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/rtstruct.h"

using namespace isoloft;
namespace fs = std::filesystem;

namespace {

std::string scratch(const std::string& name) {
  return (fs::temp_directory_path() / ("isoloft_names_" + std::to_string(::getpid()) + "_" + name)).string();
}

std::string read_error(const std::string& path) {
  try {
    (void)read_rtstruct(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

}  // namespace

TEST(RtStructNames, DecodedFromTheirCharacterSetToUtf8) {
  struct Case {
    const char* charset;
    std::string raw, utf8;
  };
  const std::vector<Case> cases{
      {"ISO_IR 100", "R\xFC" "ckenmark", "R\xC3\xBC" "ckenmark"},            // Latin-1 u-umlaut
      {"ISO_IR 192", "R\xC3\xBC" "ckenmark", "R\xC3\xBC" "ckenmark"},        // UTF-8 as it is
      {"\\ISO 2022 IR 87", "\x1b$B;3ED\x1b(B", "\xE5\xB1\xB1\xE7\x94\xB0"},  // JIS X 0208 "Yamada" (PS3.5 H.3.1)
      {"", "Heart \x1b]0;x\x07", "Heart \x1b]0;x\x07"},  // ASCII control bytes: kept, escaped where shown
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const std::string path = scratch("case" + std::to_string(i) + ".dcm");
    test::write_rtss_names(path, cases[i].charset, {{"Scar", cases[i].raw}});
    const RtStructureSet set = read_rtstruct(path);
    fs::remove(path);
    ASSERT_NE(set.find(cases[i].utf8), nullptr) << "case " << i << " (" << cases[i].charset << ")";
    EXPECT_EQ(set.select({cases[i].utf8}, path).at(0)->name, cases[i].utf8) << "case " << i << ": --roi by the UTF-8 name";
  }
}

TEST(RtStructNames, NulAndUndecodableBytesAreRefusedNamingTheRoi) {
  const std::string path = scratch("bad.dcm");
  test::write_rtss_names(path, "ISO_IR 100", {{"Scar", std::string("AB\0CD", 5)}});
  std::string e = read_error(path);
  EXPECT_NE(e.find("ROI number"), std::string::npos) << e;
  EXPECT_NE(e.find("'AB\\x00CD') holds a NUL byte"), std::string::npos) << e;
  test::write_rtss_names(path, "ISO_IR 192", {{"Scar", "caf\xE9"}});
  e = read_error(path);
  EXPECT_NE(e.find("is not UTF-8, its declared Specific Character Set (ISO_IR 192)"), std::string::npos) << e;
  EXPECT_NE(e.find("'caf\\xE9'"), std::string::npos) << "the bytes shown escaped: " << e;
  test::write_rtss_names(path, "", {{"Scar", "caf\xE9"}});
  e = read_error(path);
  EXPECT_NE(e.find("declares no Specific Character Set (0008,0005)"), std::string::npos) << e;
  test::write_rtss_names(path, "ISO_IR 999", {{"Scar", "caf\xE9"}});
  e = read_error(path);
  EXPECT_NE(e.find("Specific Character Set 'ISO_IR 999' (0008,0005) is unknown"), std::string::npos) << e;
  fs::remove(path);
}
