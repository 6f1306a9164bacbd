// The repository's breast RT Structure Set with some ROIs renamed to given
// bytes and its Specific Character Set replaced: hostile and international
// ROI names on a real header (reader, CLI and fuzz-free tests share it).
#pragma once

#include <gtest/gtest.h>

#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcfilefo.h"
#include "dcmtk/dcmdata/dcitem.h"

#include <map>
#include <string>

namespace isoloft::test {

inline const std::string kBreastRtss = std::string(ISOLOFT_SOURCE_DIR) + "/data/rtstruct/rtss.dcm";

/// Writes the breast set to `out` with ROI names replaced (old name -> new
/// bytes, NULs kept) and Specific Character Set `charset` ("" removes it).
inline void write_rtss_names(const std::string& out, const std::string& charset,
                             const std::map<std::string, std::string>& renamed) {
  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(kBreastRtss.c_str()).good());
  DcmDataset& ds = *ff.getDataset();
  if (charset.empty()) ds.findAndDeleteElement(DCM_SpecificCharacterSet);
  else ASSERT_TRUE(ds.putAndInsertString(DCM_SpecificCharacterSet, charset.c_str()).good());
  std::size_t done = 0;
  DcmItem* item = nullptr;
  for (int i = 0; ds.findAndGetSequenceItem(DCM_StructureSetROISequence, item, i).good() && item; ++i) {
    OFString name;
    item->findAndGetOFString(DCM_ROIName, name);
    const auto it = renamed.find(name.c_str());
    if (it == renamed.end()) continue;
    ASSERT_TRUE(item->putAndInsertString(DCM_ROIName, it->second.data(), Uint32(it->second.size())).good());
    ++done;
  }
  ASSERT_EQ(done, renamed.size()) << "a ROI to rename is not in " << kBreastRtss;
  ASSERT_TRUE(ff.saveFile(out.c_str(), EXS_LittleEndianExplicit).good());
}

}  // namespace isoloft::test
