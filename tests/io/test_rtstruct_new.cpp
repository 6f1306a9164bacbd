// A standalone RT Structure Set (io/rtstruct.h, write_rtstruct_new): no
// source series, so its own study and frame of reference; read back with
// DCMTK (dcmrt) and with isoloft's own reader.
#include <gtest/gtest.h>

#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcfilefo.h"
#include "dcmtk/dcmdata/dcuid.h"
#include "dcmtk/dcmrt/drtstrct.h"

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "io/io_test_util.h"
#include "isoloft/core/error.h"
#include "isoloft/io/rtstruct.h"

using namespace isoloft;

namespace {

// DS values are written with 4 decimals (0.1 um): a point read back is within
// half of that of the one written.
constexpr double kDsResolutionMm = 0.5e-4;

// Two ROIs: a square on two planes (ASCII name) and a triangle whose name is
// not ASCII, holds a backslash and is longer than LO's 64 characters.
struct Fixture {
  std::vector<RtRoi> identities{{7, "Precentral_L", Rgb{255, 0, 0}, {}}, {116, "", Rgb{0, 0, 255}, {}}};
  std::vector<RtRoiContours> rois;
  Fixture() {
    identities[1].name = "Vermis \xC3\xA9\\" + std::string(60, 'x');  // "Vermis é\xxx..."
    RtRoiContours a{&identities[0], {}};
    a.planes.push_back({-12.5, {{{10.25, -20.5}, {30.125, -20.5}, {30.125, 5.0}, {10.25, 5.0}}}});
    a.planes.push_back({-9.5, {{{11, -19}, {29, -19}, {29, 4}, {11, 4}}}});
    RtRoiContours b{&identities[1], {}};
    b.planes.push_back({42.0, {{{0, 0}, {5, 0}, {0, 5}}}});
    rois = {a, b};
  }
};

bool empty_present(DcmDataset& ds, const DcmTagKey& tag) {
  DcmElement* e = nullptr;
  return ds.findAndGetElement(tag, e).good() && e && e->getLength() == 0;
}

}  // namespace

TEST(RtStructNew, DicomLoReplacesSeparatorsAndCutsAtACharacter) {
  EXPECT_EQ(detail::dicom_lo("Left\\Right\tx"), "Left_Right_x");
  const std::string long_name = std::string(63, 'a') + "\xC3\xA9" + "b";  // the 2-byte é across byte 64
  EXPECT_EQ(detail::dicom_lo(long_name), std::string(63, 'a')) << "a UTF-8 character is never cut in two";
  EXPECT_EQ(detail::dicom_lo(std::string(64, 'a')), std::string(64, 'a'));
}

TEST(RtStructNew, StandaloneSetHasItsOwnStudyAndFrameAndEmptyPatient) {
  isoloft::test::TempDir dir;
  const Fixture f;
  const std::string path = dir.file("new.dcm");
  const RtNewSet ids = write_rtstruct_new(path, f.rois, "isoloft test");
  EXPECT_FALSE(ids.study.empty());
  EXPECT_FALSE(ids.frame_of_reference.empty());

  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(path.c_str()).good());
  OFString syntax;
  ASSERT_TRUE(ff.getMetaInfo()->findAndGetOFString(DCM_TransferSyntaxUID, syntax).good());
  EXPECT_EQ(syntax, UID_LittleEndianImplicitTransferSyntax);
  DcmDataset& ds = *ff.getDataset();
  // The patient module: type 2, present and empty (a label map names no patient).
  for (const DcmTagKey& tag : {DCM_PatientName, DCM_PatientID, DCM_PatientBirthDate, DCM_PatientSex, DCM_StudyID,
                               DCM_ReferringPhysicianName, DCM_AccessionNumber, DCM_PositionReferenceIndicator})
    EXPECT_TRUE(empty_present(ds, tag)) << "tag " << DcmTag(tag).getTagName();
  OFString v;
  ds.findAndGetOFString(DCM_Modality, v);
  EXPECT_EQ(v, "RTSTRUCT");
  ds.findAndGetOFString(DCM_SOPClassUID, v);
  EXPECT_EQ(v, UID_RTStructureSetStorage);
  ds.findAndGetOFString(DCM_StudyInstanceUID, v);
  EXPECT_EQ(v.c_str(), ids.study);
  ds.findAndGetOFString(DCM_FrameOfReferenceUID, v);
  EXPECT_EQ(v.c_str(), ids.frame_of_reference);
  ds.findAndGetOFStringArray(DCM_SpecificCharacterSet, v);
  EXPECT_EQ(v, "ISO_IR 192") << "a name is not ASCII: UTF-8 declared";

  DRTStructureSetIOD rt;
  ASSERT_TRUE(rt.read(ds).good());
  ASSERT_EQ(rt.getReferencedFrameOfReferenceSequence().getNumberOfItems(), 1u);
  rt.getReferencedFrameOfReferenceSequence().getItem(0).getFrameOfReferenceUID(v);
  EXPECT_EQ(v.c_str(), ids.frame_of_reference);
  ASSERT_EQ(rt.getStructureSetROISequence().getNumberOfItems(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    rt.getStructureSetROISequence().getItem(i).getReferencedFrameOfReferenceUID(v);
    EXPECT_EQ(v.c_str(), ids.frame_of_reference) << "ROI " << i;
  }
  ASSERT_EQ(rt.getRTROIObservationsSequence().getNumberOfItems(), 2u);

  // isoloft's reader: numbers, names (decoded by ISO_IR 192), colours and points.
  const RtStructureSet back = read_rtstruct(path);
  ASSERT_EQ(back.rois.size(), 2u);
  EXPECT_EQ(back.frame_of_reference, ids.frame_of_reference);
  for (std::size_t r = 0; r < 2; ++r) {
    const RtRoi& got = back.rois[r];
    const RtRoiContours& want = f.rois[r];
    EXPECT_EQ(got.number, want.roi->number) << "ROI " << r;
    EXPECT_EQ(got.name, detail::dicom_lo(want.roi->name)) << "ROI " << r;
    ASSERT_TRUE(got.color.has_value()) << "ROI " << r;
    EXPECT_EQ(got.color->r, want.roi->color->r) << "ROI " << r;
    EXPECT_EQ(got.color->b, want.roi->color->b) << "ROI " << r;
    ASSERT_EQ(got.contours.size(), want.planes.size()) << "ROI " << r;
    for (std::size_t k = 0; k < got.contours.size(); ++k) {
      const auto& loop = want.planes[k].loops.front();
      ASSERT_EQ(got.contours[k].type, "CLOSED_PLANAR");
      ASSERT_EQ(got.contours[k].points.size(), loop.size()) << "ROI " << r << " contour " << k;
      for (std::size_t i = 0; i < loop.size(); ++i) {
        const Vec3d& p = got.contours[k].points[i];
        EXPECT_NEAR(p.x(), loop[i].x(), kDsResolutionMm) << "ROI " << r << " contour " << k << " point " << i;
        EXPECT_NEAR(p.y(), loop[i].y(), kDsResolutionMm) << "ROI " << r << " contour " << k << " point " << i;
        EXPECT_NEAR(p.z(), want.planes[k].z, kDsResolutionMm) << "ROI " << r << " contour " << k << " point " << i;
      }
    }
  }
  EXPECT_EQ(back.rois[1].name.substr(0, 10), "Vermis \xC3\xA9_");
}

TEST(RtStructNew, AnAsciiSetDeclaresNoCharacterSetAndAnUnwritablePathIsNamed) {
  isoloft::test::TempDir dir;
  Fixture f;
  f.rois.pop_back();
  const std::string path = dir.file("ascii.dcm");
  write_rtstruct_new(path, f.rois, "isoloft test");
  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(path.c_str()).good());
  EXPECT_FALSE(ff.getDataset()->tagExists(DCM_SpecificCharacterSet));
  // A folder that cannot be made (a file is in its way): an error naming it, nothing written.
  { std::ofstream(dir.file("plain")) << "a file"; }
  const std::string bad = dir.file("plain/x.dcm");
  try {
    write_rtstruct_new(bad, f.rois, "isoloft test");
    FAIL() << "wrote below a regular file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(dir.file("plain")), std::string::npos) << e.what();
  }
  EXPECT_EQ(dir.entries().size(), 2u) << "no half-written file left";
}
