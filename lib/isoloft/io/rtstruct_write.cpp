// @file io/rtstruct_write.cpp
// @brief Writing an RT Structure Set with DCMTK: DS values within 16
// characters, Implicit VR Little Endian, written to a temp file and renamed.
#include "isoloft/io/rtstruct.h"

#include "isoloft/io/rtstruct_dcmtk.h"

#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcuid.h"
#include "dcmtk/dcmrt/drtstrct.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <memory>

#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/file_util.h"

namespace isoloft {

namespace {

// The longest value a DS (decimal string) may hold (PS3.5 table 6.2-1).
constexpr std::size_t kDsMaxChars = 16;

// A DS value within its 16 characters: 4 decimals of a mm (0.1 um) for any
// patient coordinate below 10^10 mm, fewer decimals beyond (never reached by
// a body), and "0" for a non-finite value (never written: points are finite).
std::string ds(double v) {
  if (!std::isfinite(v)) return "0";
  std::string t;
  for (int decimals = 4; decimals >= 0; --decimals) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    t = buf;
    if (t.size() <= kDsMaxChars) break;
  }
  if (t.size() > kDsMaxChars) {  // |v| >= 10^16: exponent form, as DS allows
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.9e", v);
    t = buf;
  }
  if (t.find('.') != std::string::npos && t.find('e') == std::string::npos) {
    while (t.back() == '0') t.pop_back();
    if (t.back() == '.') t.pop_back();
  }
  if (t == "-0") t = "0";
  return t;
}

std::string new_uid(const char* root) {
  char buf[100];
  dcmGenerateUniqueIdentifier(buf, root);
  return buf;
}

}  // namespace

void write_rtstruct(const std::string& path, const std::string& source, const std::vector<RtRoiContours>& rois,
                    const std::string& label, const std::vector<unsigned char>* source_bytes) {
  DcmFileFormat ff;
  if (detail::load_dicom(ff, source_bytes ? *source_bytes : detail::read_file_bytes(source)).bad())
    throw InputError(source, "not a readable DICOM file");
  auto rt = std::make_unique<DRTStructureSetIOD>();
  if (rt->read(*ff.getDataset()).bad()) throw InputError(source, "not a valid RT Structure Set");
  std::map<Sint32, const RtRoiContours*> keep;
  for (const auto& r : rois) keep[r.roi->number] = &r;
  auto kept = [&](Sint32 n) { return keep.count(n) > 0; };

  // Identity of the new instance: a derived series of the same study.
  char date[16], time[16];
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  std::strftime(date, sizeof date, "%Y%m%d", &tm);
  std::strftime(time, sizeof time, "%H%M%S", &tm);
  const std::string sop = new_uid(SITE_INSTANCE_UID_ROOT);
  rt->setSOPInstanceUID(sop.c_str());
  rt->setSeriesInstanceUID(new_uid(SITE_SERIES_UID_ROOT).c_str());
  rt->setSeriesDescription("isoloft surfaces");
  rt->setSeriesNumber("");
  rt->setInstanceNumber("1");
  rt->setInstanceCreationDate(date);
  rt->setInstanceCreationTime(time);
  rt->setStructureSetLabel(label.substr(0, 16).c_str());
  rt->setStructureSetDate(date);
  rt->setStructureSetTime(time);
  rt->setManufacturer("isoloft");
  rt->setSoftwareVersions(ISOLOFT_VERSION);
  // Frame of Reference module (required of a structure set since DICOM 2021).
  OFString frame;
  if (rt->getStructureSetROISequence().getNumberOfItems() > 0)
    rt->getStructureSetROISequence().getItem(0).getReferencedFrameOfReferenceUID(frame);
  OFString have;
  rt->getFrameOfReferenceUID(have);
  if (have.empty() && !frame.empty()) rt->setFrameOfReferenceUID(frame);

  DRTStructureSetROISequence& ss = rt->getStructureSetROISequence();
  for (std::size_t i = ss.getNumberOfItems(); i-- > 0;) {
    Sint32 n = -1;
    ss.getItem(i).getROINumber(n);
    if (!kept(n)) ss.removeItem(i);
  }
  DRTRTROIObservationsSequence& obs = rt->getRTROIObservationsSequence();
  for (std::size_t i = obs.getNumberOfItems(); i-- > 0;) {
    Sint32 n = -1;
    obs.getItem(i).getReferencedROINumber(n);
    if (!kept(n)) obs.removeItem(i);
  }
  DRTROIContourSequence& rcs = rt->getROIContourSequence();
  for (std::size_t i = rcs.getNumberOfItems(); i-- > 0;) {
    DRTROIContourSequence::Item& item = rcs.getItem(i);
    Sint32 n = -1;
    item.getReferencedROINumber(n);
    if (!kept(n)) {
      rcs.removeItem(i);
      continue;
    }
    const RtRoiContours& out = *keep[n];
    // The source's contours of this ROI by plane, for their image references.
    DRTContourSequence& cs = item.getContourSequence();
    std::vector<std::pair<double, DRTContourImageSequence>> images;
    for (std::size_t k = 0; k < cs.getNumberOfItems(); ++k) {
      Float64 z = 0;
      if (cs.getItem(k).getContourData(z, 2).good() && cs.getItem(k).getContourImageSequence().getNumberOfItems() > 0)
        images.emplace_back(z, cs.getItem(k).getContourImageSequence());
    }
    cs.clear();
    int number = 0;
    for (const auto& plane : out.planes) {
      const DRTContourImageSequence* image = nullptr;
      const std::string zs = ds(plane.z);
      for (const auto& [z, seq] : images)
        if (std::abs(z - plane.z) <= kPlanarToleranceMm) image = &seq;
      for (const auto& loop : plane.loops) {
        // Points as written: consecutive points (and the last and the first)
        // equal after rounding to DS merged, so the count is of distinct points.
        std::vector<std::string> points;
        for (const Vec2d& p : loop) {
          std::string q = ds(p.x()) + "\\" + ds(p.y()) + "\\" + zs;
          if (points.empty() || q != points.back()) points.push_back(std::move(q));
        }
        while (points.size() > 1 && points.front() == points.back()) points.pop_back();
        if (points.size() < 3) continue;  // not a polygon once rounded to 0.1 um
        DRTContourSequence::Item* c = nullptr;
        if (cs.addItem(c).bad()) throw InputError(path, "cannot add a contour (DCMTK)");
        if (image) c->getContourImageSequence() = *image;
        std::string data;
        for (const std::string& q : points) data += (data.empty() ? "" : "\\") + q;
        c->setContourNumber(std::to_string(++number).c_str());
        c->setContourGeometricType("CLOSED_PLANAR");
        c->setNumberOfContourPoints(std::to_string(points.size()).c_str());
        c->setContourData(data.c_str());
      }
    }
  }
  DcmFileFormat outf;
  OFCondition built;
  const std::string why = detail::dcmrt_log([&] { built = rt->write(*outf.getDataset()); });
  if (built.bad())
    throw InputError(path, "cannot build the RT Structure Set from " + source + " (" + (why.empty() ? built.text() : why) + ")");
  outf.getDataset()->putAndInsertString(DCM_PositionReferenceIndicator, "", OFFalse);
  outf.getDataset()->putAndInsertString(DCM_OperatorsName, "", OFFalse);
  AtomicFile f(path);
  // Implicit VR Little Endian, as planning systems write: every element keeps
  // its VR (Explicit VR's 16-bit length would turn a DS over 65,534 bytes,
  // a long contour's data, into UN).
  errno = 0;
  if (const OFCondition st = outf.saveFile(f.temp_path().c_str(), EXS_LittleEndianImplicit); st.bad())
    throw InputError(path, std::string("cannot write file (") + (errno ? std::strerror(errno) : st.text()) + ")");
  f.commit();
}

}  // namespace isoloft
