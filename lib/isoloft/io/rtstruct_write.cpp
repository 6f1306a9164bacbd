// @file io/rtstruct_write.cpp
// @brief Writing an RT Structure Set with DCMTK, derived from the one read or
// standalone: DS values within 16 characters, Implicit VR Little Endian,
// written to a temp file and renamed.
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

// A new instance's identity (both writers): new series and SOP instance
// UIDs, the label, today's date and time, isoloft as the equipment.
void stamp_instance(DRTStructureSetIOD& rt, const std::string& label) {
  char date[16], time[16];
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  std::strftime(date, sizeof date, "%Y%m%d", &tm);
  std::strftime(time, sizeof time, "%H%M%S", &tm);
  rt.setSOPInstanceUID(new_uid(SITE_INSTANCE_UID_ROOT).c_str());
  rt.setSeriesInstanceUID(new_uid(SITE_SERIES_UID_ROOT).c_str());
  rt.setSeriesDescription("isoloft surfaces");
  rt.setSeriesNumber("");
  rt.setInstanceNumber("1");
  rt.setInstanceCreationDate(date);
  rt.setInstanceCreationTime(time);
  rt.setStructureSetLabel(label.substr(0, 16).c_str());
  rt.setStructureSetDate(date);
  rt.setStructureSetTime(time);
  rt.setManufacturer("isoloft");
  rt.setSoftwareVersions(ISOLOFT_VERSION);
}

// One ROI's planes as CLOSED_PLANAR contours appended to `cs`; on a plane
// within kPlanarToleranceMm of one in `images`, its Contour Image Sequence.
// Points as written: consecutive points (and the last and the first) equal
// after rounding to DS merged, so the count is of distinct points; a loop
// left under 3 points (not a polygon once rounded to 0.1 um) is not written.
void add_contours(DRTContourSequence& cs, const RtRoiContours& out,
                  const std::vector<std::pair<double, DRTContourImageSequence>>& images, const std::string& path) {
  int number = int(cs.getNumberOfItems());
  for (const auto& plane : out.planes) {
    const DRTContourImageSequence* image = nullptr;
    const std::string zs = ds(plane.z);
    for (const auto& [z, seq] : images)
      if (!plane.pose && std::abs(z - plane.z) <= kPlanarToleranceMm) image = &seq;
    for (const auto& loop : plane.loops) {
      std::vector<std::string> points;
      for (const Vec2d& p : loop) {
        const Vec3d w = plane.pose ? plane.pose->to_world(p) : Vec3d(p.x(), p.y(), plane.z);
        std::string q = ds(w.x()) + "\\" + ds(w.y()) + "\\" + (plane.pose ? ds(w.z()) : zs);
        if (points.empty() || q != points.back()) points.push_back(std::move(q));
      }
      while (points.size() > 1 && points.front() == points.back()) points.pop_back();
      if (points.size() < 3) continue;
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

// Builds the dataset (dcmrt checks every type 1 and 2 attribute), adds the
// Frame of Reference module's type 2 attributes a structure set may lack,
// and saves it atomically in Implicit VR Little Endian, as planning systems
// write: every element keeps its VR (Explicit VR's 16-bit length would turn a
// DS over 65,534 bytes, a long contour's data, into UN).
void save_rtstruct(DRTStructureSetIOD& rt, const std::string& path, const std::string& from) {
  DcmFileFormat outf;
  OFCondition built;
  const std::string why = detail::dcmrt_log([&] { built = rt.write(*outf.getDataset()); });
  if (built.bad())
    throw InputError(path, "cannot build the RT Structure Set" + from + " (" + (why.empty() ? built.text() : why) + ")");
  outf.getDataset()->putAndInsertString(DCM_PositionReferenceIndicator, "", OFFalse);
  outf.getDataset()->putAndInsertString(DCM_OperatorsName, "", OFFalse);
  AtomicFile f(path);
  errno = 0;
  if (const OFCondition st = outf.saveFile(f.temp_path().c_str(), EXS_LittleEndianImplicit); st.bad())
    throw InputError(path, std::string("cannot write file (") + (errno ? std::strerror(errno) : st.text()) + ")");
  f.commit();
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
  stamp_instance(*rt, label);
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
    // The source's contours of this ROI by plane, for their image references.
    DRTContourSequence& cs = item.getContourSequence();
    std::vector<std::pair<double, DRTContourImageSequence>> images;
    for (std::size_t k = 0; k < cs.getNumberOfItems(); ++k) {
      Float64 z = 0;
      if (cs.getItem(k).getContourData(z, 2).good() && cs.getItem(k).getContourImageSequence().getNumberOfItems() > 0)
        images.emplace_back(z, cs.getItem(k).getContourImageSequence());
    }
    cs.clear();
    add_contours(cs, *keep[n], images, path);
  }
  save_rtstruct(*rt, path, " from " + source);
}

namespace detail {

std::string dicom_lo(const std::string& text) {
  std::string out;
  for (const char c : text) out += (static_cast<unsigned char>(c) < 0x20 || c == 0x7F || c == '\\') ? '_' : c;
  if (out.size() <= kLoMaxChars) return out;
  std::size_t n = kLoMaxChars;
  while (n > 0 && (static_cast<unsigned char>(out[n]) & 0xC0) == 0x80) --n;  // not inside a UTF-8 character
  return out.substr(0, n);
}

}  // namespace detail

RtNewSet write_rtstruct_new(const std::string& path, const std::vector<RtRoiContours>& rois, const std::string& label) {
  auto rt = std::make_unique<DRTStructureSetIOD>();  // large: on the heap
  RtNewSet ids;
  ids.study = new_uid(SITE_STUDY_UID_ROOT);
  ids.frame_of_reference = new_uid(SITE_UID_ROOT);
  stamp_instance(*rt, label);
  // Patient and study: type 2 attributes present but empty (dcmrt writes
  // them so), the study new, dated today.
  OFString date, time;
  rt->getStructureSetDate(date);
  rt->getStructureSetTime(time);
  rt->setStudyInstanceUID(ids.study.c_str());
  rt->setStudyDate(date);
  rt->setStudyTime(time);
  rt->setModality("RTSTRUCT");
  rt->setFrameOfReferenceUID(ids.frame_of_reference.c_str());
  bool ascii = true;
  for (const auto& r : rois)
    for (const unsigned char c : r.roi->name) ascii = ascii && c < 0x80;
  if (!ascii) rt->setSpecificCharacterSet("ISO_IR 192");  // the names' UTF-8

  DRTReferencedFrameOfReferenceSequence::Item* frame = nullptr;
  if (rt->getReferencedFrameOfReferenceSequence().addItem(frame).bad()) throw InputError(path, "cannot add the frame of reference (DCMTK)");
  frame->setFrameOfReferenceUID(ids.frame_of_reference.c_str());
  int observation = 0;
  for (const RtRoiContours& r : rois) {
    const std::string number = std::to_string(r.roi->number);
    DRTStructureSetROISequence::Item* roi = nullptr;
    DRTROIContourSequence::Item* contours = nullptr;
    DRTRTROIObservationsSequence::Item* obs = nullptr;
    if (rt->getStructureSetROISequence().addItem(roi).bad() || rt->getROIContourSequence().addItem(contours).bad() ||
        rt->getRTROIObservationsSequence().addItem(obs).bad())
      throw InputError(path, "cannot add ROI " + number + " (DCMTK)");
    roi->setROINumber(number.c_str());
    roi->setReferencedFrameOfReferenceUID(ids.frame_of_reference.c_str());
    // Checked by dicom_lo (DCMTK's own check takes any byte over 127 for a
    // character outside the default repertoire, whatever the Specific Character Set).
    if (const OFCondition st = roi->setROIName(detail::dicom_lo(r.roi->name).c_str(), OFFalse); st.bad())
      throw InputError(path, "ROI " + number + ": its name cannot be written (" + st.text() + ")");
    roi->setROIGenerationAlgorithm("AUTOMATIC");
    contours->setReferencedROINumber(number.c_str());
    if (r.roi->color) {
      const Rgb c = *r.roi->color;
      contours->setROIDisplayColor((std::to_string(c.r) + "\\" + std::to_string(c.g) + "\\" + std::to_string(c.b)).c_str());
    }
    add_contours(contours->getContourSequence(), r, {}, path);
    obs->setObservationNumber(std::to_string(++observation).c_str());
    obs->setReferencedROINumber(number.c_str());
    obs->setRTROIInterpretedType("ORGAN");
    obs->setROIInterpreter("");
  }
  save_rtstruct(*rt, path, "");
  return ids;
}

}  // namespace isoloft
