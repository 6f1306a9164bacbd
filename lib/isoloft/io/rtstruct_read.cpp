// @file io/rtstruct_read.cpp
// @brief Reading an RT Structure Set with DCMTK: the file's bytes once, ROI
// numbers and names (decoded by the Specific Character Set), contours.
#include "isoloft/io/rtstruct.h"

#include "isoloft/io/rtstruct_dcmtk.h"

#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcitem.h"
#include "dcmtk/dcmdata/dcsequen.h"
#include "dcmtk/dcmdata/dcspchrs.h"
#include "dcmtk/dcmdata/dcuid.h"
#include "dcmtk/dcmdata/dcvrds.h"
#include "dcmtk/dcmdata/dcvris.h"
#include "dcmtk/dcmrt/drtstrct.h"
#include "dcmtk/oflog/appender.h"
#include "dcmtk/oflog/spi/logevent.h"
#include "dcmtk/oflog/oflog.h"

#include <iconv.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/text.h"

namespace isoloft {

namespace {

std::string rtrim(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return s;
}

// An ROINumber or ReferencedROINumber (DICOM IS: -2^31 .. 2^31-1): a
// larger one is refused, never wrapped onto another ROI's number.
Sint32 roi_number_of(const OFString& text, const std::string& path, const std::string& what) {
  const std::string t = rtrim(text.c_str());
  const std::size_t start = t.find_first_not_of(' ');
  if (start == std::string::npos) return -1;  // missing: no ROI refers to it
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(t.c_str() + start, &end, 10);
  if (end == t.c_str() + start || *end != '\0' || errno == ERANGE || v < std::numeric_limits<Sint32>::min() ||
      v > std::numeric_limits<Sint32>::max())
    throw InputError(path, what + " '" + t.substr(start) + "' is not a DICOM integer (IS: -2^31 .. 2^31-1)");
  return Sint32(v);
}


// Bytes in iconv encoding `from` as UTF-8; nullopt if iconv cannot.
std::optional<std::string> iconv_utf8(const std::string& in, const char* from) {
  const iconv_t cd = iconv_open("UTF-8", from);
  if (cd == iconv_t(-1)) return std::nullopt;
  std::string out(in.size() * 4 + 16, '\0');
  char* src = const_cast<char*>(in.data());
  char* dst = out.data();
  std::size_t left = in.size(), room = out.size();
  const bool ok = iconv(cd, &src, &left, &dst, &room) != std::size_t(-1) && iconv(cd, nullptr, nullptr, &dst, &room) != std::size_t(-1);
  iconv_close(cd);
  if (!ok) return std::nullopt;
  out.resize(out.size() - room);
  return out;
}

// Japanese by code extensions (first value ISO 2022 IR 6 or empty, then
// IR 87 / IR 159): glibc's iconv has no JIS X 0208 table on its own
// (DCMTK's "ISO-IR-87" fails to open), but these escapes are ISO-2022-JP-2's.
bool iso2022_japanese(const std::string& charset) {
  std::stringstream ss(charset);
  std::string v;
  bool japanese = false;
  while (std::getline(ss, v, '\\')) {
    while (!v.empty() && v.back() == ' ') v.pop_back();
    while (!v.empty() && v.front() == ' ') v.erase(0, 1);
    if (v == "ISO 2022 IR 87" || v == "ISO 2022 IR 159") japanese = true;
    else if (!v.empty() && v != "ISO 2022 IR 6") return false;
  }
  return japanese;
}

}  // namespace

namespace detail {

std::string decode_roi_name(const std::string& raw, std::string charset, int number, const std::string& path) {
  charset = rtrim(charset);
  while (!charset.empty() && charset.front() == ' ') charset.erase(0, 1);
  const std::string name = rtrim(raw);
  const std::string which = "ROI number " + std::to_string(number);
  if (name.find('\0') != std::string::npos)
    throw InputError(path, which + ": its name ('" + terminal_text(name) + "') holds a NUL byte");
  const bool ascii = std::all_of(name.begin(), name.end(), [](unsigned char c) { return c < 0x80 && c != 0x1B; });
  if (ascii) return name;
  // No character set declared (the default repertoire is ASCII): UTF-8, as
  // many systems write without saying, is taken; other bytes cannot be read.
  if (charset.empty() || charset == "ISO_IR 6" || charset == "ISO_IR 192") {
    if (is_utf8(name)) return name;
    throw InputError(path, which + ": its name ('" + terminal_text(name) + "') is not " +
                               (charset == "ISO_IR 192" ? std::string("UTF-8, its declared Specific Character Set (ISO_IR 192)")
                                                        : "ASCII and the file declares no Specific Character Set (0008,0005) to read it by"));
  }
  if (iso2022_japanese(charset)) {
    const std::optional<std::string> out = iconv_utf8(name, "ISO-2022-JP-2");
    if (!out || !is_utf8(*out) || out->find('\0') != std::string::npos)
      throw InputError(path, which + ": its name ('" + terminal_text(name) + "') is not valid in its Specific Character Set '" +
                                 terminal_text(charset) + "'");
    return *out;
  }
  DcmSpecificCharacterSet converter;
  OFCondition st = converter.selectCharacterSet(charset.c_str());
  if (st.bad())
    throw InputError(path, which + ": its name cannot be decoded: Specific Character Set '" + terminal_text(charset) +
                               "' (0008,0005) is unknown or not convertible (" + st.text() + ")");
  OFString utf8;
  st = converter.convertString(name.data(), name.size(), utf8, "\\");
  const std::string out(utf8.c_str(), utf8.length());
  if (st.bad() || !is_utf8(out) || out.find('\0') != std::string::npos)
    throw InputError(path, which + ": its name ('" + terminal_text(name) + "') is not valid in its Specific Character Set '" +
                               terminal_text(charset) + "'" + (st.bad() ? std::string(" (") + st.text() + ")" : ""));
  return out;
}

}  // namespace detail

bool is_dicom_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char buf[132];
  return in.read(buf, sizeof buf) && std::memcmp(buf + 128, "DICM", 4) == 0;
}

namespace {

// DCMTK's dcmrt names the attribute a structure set lacks only in its log
// (silenced, see read_rtstruct): caught while one is built, for the error.
class LogLines : public dcmtk::log4cplus::Appender {
 public:
  std::string text;
  void close() override {}

 protected:
  void append(const dcmtk::log4cplus::spi::InternalLoggingEvent& e) override {
    text += (text.empty() ? "" : "; ") + std::string(e.getMessage().c_str());
  }
};

}  // namespace

namespace detail {

std::string dcmrt_log(const std::function<void()>& build) {
  static std::mutex m;  // one logger for the process
  const std::lock_guard lock(m);
  dcmtk::log4cplus::Logger logger = dcmtk::log4cplus::Logger::getInstance("dcmtk.dcmrt");
  auto* lines = new LogLines;
  const dcmtk::log4cplus::SharedAppenderPtr appender(lines);
  const auto level = logger.getLogLevel();
  const bool additive = logger.getAdditivity();
  logger.setLogLevel(dcmtk::log4cplus::WARN_LOG_LEVEL);
  logger.setAdditivity(false);  // not on stderr as well
  logger.addAppender(appender);
  build();
  logger.removeAppender(appender);
  logger.setAdditivity(additive);
  logger.setLogLevel(level);
  return lines->text;
}

// A DICOM file parsed from its bytes (read once, never again from disk).
// Parsed as a file, not from a buffer stream: DCMTK checks an element's
// length against what a file holds, but from a buffer it allocates what a
// lying length asks first (the rtstruct fuzzer's 4 GiB value). The bytes go
// to an anonymous in-memory file (memfd), read through its /proc path.
OFCondition load_dicom(DcmFileFormat& ff, const std::vector<unsigned char>& bytes) {
  const int fd = ::memfd_create("isoloft-dicom", MFD_CLOEXEC);
  if (fd < 0) return makeOFCondition(OFM_dcmdata, 1, OF_error, std::strerror(errno));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const OFCondition st = makeOFCondition(OFM_dcmdata, 1, OF_error, std::strerror(errno));
      ::close(fd);
      return st;
    }
    done += std::size_t(n);
  }
  OFCondition st = ff.loadFile(("/proc/self/fd/" + std::to_string(fd)).c_str());
  if (st.good()) st = ff.loadAllDataIntoMemory();  // long values are loaded lazily, from the file about to close
  ::close(fd);
  return st;
}

}  // namespace detail

RtStructureSet read_rtstruct(const std::string& path) {
  std::vector<unsigned char> bytes = detail::read_file_bytes(path, 0);  // a missing or unreadable file named as such
  static std::once_flag quiet;
  std::call_once(quiet, [] { OFLog::configure(OFLogger::FATAL_LOG_LEVEL); });  // we say what is wrong
  DcmFileFormat ff;
  OFCondition st = detail::load_dicom(ff, bytes);
  if (st.bad()) throw InputError(path, std::string("not a readable DICOM file (") + st.text() + ")");
  OFString sop;
  ff.getDataset()->findAndGetOFString(DCM_SOPClassUID, sop);
  if (sop != UID_RTStructureSetStorage)
    throw InputError(path, std::string("not a DICOM RT Structure Set (SOP class ") +
                               (sop.empty() ? "missing" : dcmFindNameOfUID(sop.c_str(), sop.c_str())) + ")");
  // The contours are read from the dataset itself (below): the IOD's read
  // checks every ContourData value against its VR, most of the read's time.
  const std::unique_ptr<DcmElement> roi_contours(ff.getDataset()->remove(DCM_ROIContourSequence));
  auto rt = std::make_unique<DRTStructureSetIOD>();  // large: on the heap
  st = rt->read(*ff.getDataset());
  if (st.bad()) throw InputError(path, std::string("not a valid RT Structure Set (") + st.text() + ")");

  RtStructureSet out;
  out.bytes = std::move(bytes);
  std::map<Sint32, std::size_t> by_number;
  OFString charset;  // Specific Character Set (0008,0005): the names are decoded by it
  ff.getDataset()->findAndGetOFStringArray(DCM_SpecificCharacterSet, charset);
  // Sequences are read by index: DCMTK's gotoNextItem() loops visit one empty item too many.
  DRTStructureSetROISequence& rois = rt->getStructureSetROISequence();
  for (std::size_t i = 0; i < rois.getNumberOfItems(); ++i) {
    Sint32 number = -1;
    OFString name, frame;
    OFString number_text;
    rois.getItem(i).getROIName(name);
    rois.getItem(i).getROINumber(number_text);
    number = roi_number_of(number_text, path, "ROI '" + rtrim(name.c_str()) + "': ROINumber");
    rois.getItem(i).getReferencedFrameOfReferenceUID(frame);
    if (out.frame_of_reference.empty()) out.frame_of_reference = frame.c_str();
    const auto [it, added] = by_number.try_emplace(number, out.rois.size());
    // The name's bytes whole (NULs, backslashes), from the dataset's item i.
    DcmItem* item = nullptr;
    OFString raw;
    if (ff.getDataset()->findAndGetSequenceItem(DCM_StructureSetROISequence, item, int(i)).good() && item)
      item->findAndGetOFStringArray(DCM_ROIName, raw);
    else raw = name;
    out.rois.push_back({int(number), detail::decode_roi_name(std::string(raw.c_str(), raw.length()), charset.c_str(), int(number), path), std::nullopt, {}});
    out.rois.back().frame_of_reference = rtrim(frame.c_str());
    if (!added) out.rois[it->second].number_shared = out.rois.back().number_shared = true;
  }
  if (out.rois.empty()) throw InputError(path, "the RT Structure Set holds no ROI");
  // As the IOD reads them: an element of another VR than the standard's is
  // taken as absent (DcmElement::copyFrom refuses another class).
  auto typed = [](DcmItem* item, const DcmTagKey& tag, DcmEVR vr) -> DcmElement* {
    DcmElement* e = nullptr;
    return item && item->findAndGetElement(tag, e, OFFalse).good() && e && e->ident() == vr ? e : nullptr;
  };
  auto items = [](DcmItem* item, const DcmTagKey& tag) -> DcmSequenceOfItems* {
    DcmSequenceOfItems* seq = nullptr;
    return item && item->findAndGetSequence(tag, seq, OFFalse).good() ? seq : nullptr;
  };
  auto* contours = roi_contours && roi_contours->ident() == EVR_SQ ? static_cast<DcmSequenceOfItems*>(roi_contours.get()) : nullptr;
  for (unsigned long r = 0; contours && r < contours->card(); ++r) {
    DcmItem* item = contours->getItem(r);
    OFString ref_text;
    if (DcmElement* e = typed(item, DCM_ReferencedROINumber, EVR_IS)) e->getOFString(ref_text, 0);
    const Sint32 ref = roi_number_of(ref_text, path, "ROIContourSequence item " + std::to_string(r + 1) + ": ReferencedROINumber");
    DcmSequenceOfItems* seq = items(item, DCM_ContourSequence);
    const unsigned long count = seq ? seq->card() : 0;
    const auto it = by_number.find(ref);
    if (it == by_number.end()) {  // contours of no listed ROI: nobody's name, colour or number to give them
      out.unlisted_contours[int(ref)] += int(count);
      continue;
    }
    RtRoi& roi = out.rois[it->second];
    if (roi.number_shared) continue;  // whose? selecting either ROI is an error
    Sint32 c[3];
    if (auto* colour = static_cast<DcmIntegerString*>(typed(item, DCM_ROIDisplayColor, EVR_IS));
        colour && colour->getSint32(c[0], 0).good() && colour->getSint32(c[1], 1).good() && colour->getSint32(c[2], 2).good())
      roi.color = Rgb{std::uint8_t(std::clamp(c[0], 0, 255)), std::uint8_t(std::clamp(c[1], 0, 255)),
                      std::uint8_t(std::clamp(c[2], 0, 255))};
    for (unsigned long k = 0; k < count; ++k) {
      DcmItem* ct = seq->getItem(k);
      OFString type;
      if (DcmElement* e = typed(ct, DCM_ContourGeometricType, EVR_CS)) e->getOFString(type, 0);
      OFVector<Float64> xyz;
      if (auto* data = static_cast<DcmDecimalString*>(typed(ct, DCM_ContourData, EVR_DS))) data->getFloat64Vector(xyz);
      RtContour contour{rtrim(type.c_str()), {}};
      for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) contour.points.emplace_back(xyz[i], xyz[i + 1], xyz[i + 2]);
      for (const Vec3d& p : contour.points)
        if (!p.allFinite())
          throw InputError(path, "ROI '" + roi.name + "' contour " + std::to_string(k) + " has a non-finite point");
      roi.contours.push_back(std::move(contour));
    }
  }
  return out;
}

}  // namespace isoloft
