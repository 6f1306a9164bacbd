#include "isoloft/io/rtstruct.h"

// DCMTK's configuration header must come before its other headers.
#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcfilefo.h"
#include "dcmtk/dcmdata/dcistrmb.h"
#include "dcmtk/dcmdata/dcspchrs.h"
#include "dcmtk/dcmdata/dcuid.h"
#include "dcmtk/dcmrt/drtstrct.h"
#include "dcmtk/oflog/appender.h"
#include "dcmtk/oflog/spi/logevent.h"
#include "dcmtk/oflog/oflog.h"

#include <iconv.h>
#include <sys/mman.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/text.h"

namespace isoloft {

namespace {

// A step between contour planes longer than this many typical steps is a gap
// with no contour, not a coarser sampling.
constexpr double kGapFactor = 1.5;

std::string rtrim(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return s;
}

double signed_area(const std::vector<Vec2d>& p) {
  double a = 0;
  for (std::size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) a += p[j].x() * p[i].y() - p[i].x() * p[j].y();
  return 0.5 * a;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

}  // namespace

int RtRoi::closed_contours() const {
  return int(std::count_if(contours.begin(), contours.end(), [](const RtContour& c) { return c.type == "CLOSED_PLANAR"; }));
}

const RtRoi* RtStructureSet::find(const std::string& name) const {
  for (const auto& r : rois)
    if (r.name == name) return &r;
  for (const auto& r : rois)
    if (lower(r.name) == lower(name)) return &r;
  return nullptr;
}

namespace {

std::string quoted_names(const std::vector<const RtRoi*>& rois, bool numbers) {
  std::string s;
  for (const RtRoi* r : rois)
    s += (s.empty() ? "" : ", ") + ("'" + r->name + "'") + (numbers ? " (number " + std::to_string(r->number) + ")" : "");
  return s;
}

std::string shared_number_error(const RtStructureSet& set, const RtRoi& roi) {
  std::vector<const RtRoi*> same;
  for (const auto& r : set.rois)
    if (r.number == roi.number) same.push_back(&r);
  return "ROI number " + std::to_string(roi.number) + " is used by " + std::to_string(same.size()) + " ROIs (" +
         quoted_names(same, false) + "): their contours cannot be told apart";
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

// A whole decimal number, as ROINumber is written.
std::optional<int> as_number(const std::string& text) {
  if (text.empty() || text.size() > 9 || !std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); }))
    return std::nullopt;
  return std::stoi(text);
}

}  // namespace

std::vector<const RtRoi*> RtStructureSet::select(const std::vector<std::string>& wanted, const std::string& path) const {
  std::vector<const RtRoi*> out;
  for (const std::string& w : wanted) {
    std::vector<const RtRoi*> named, numbered;
    for (const auto& r : rois)
      if (r.name == w) named.push_back(&r);
    if (named.empty())
      for (const auto& r : rois)
        if (lower(r.name) == lower(w)) named.push_back(&r);
    if (const auto n = as_number(w))
      for (const auto& r : rois)
        if (r.number == *n) numbered.push_back(&r);
    if (named.size() > 1)
      throw InputError(path, std::to_string(named.size()) + " ROIs are named '" + w + "': " + quoted_names(named, true) +
                                 "; select one by its number (" + option_given("--roi", "NUMBER") + ")");
    if (named.size() == 1 && !numbered.empty() && numbered.front() != named.front())
      throw InputError(path, "'" + w + "' is the name of ROI number " + std::to_string(named.front()->number) +
                                 " and the number of ROI '" + numbered.front()->name + "'; rename one of them");
    const RtRoi* roi = !named.empty() ? named.front() : numbered.size() == 1 ? numbered.front() : nullptr;
    if (numbered.size() > 1 && named.empty()) roi = numbered.front();  // reported as shared below
    if (!roi) throw InputError(path, "no ROI named or numbered '" + w + "' (ROIs: " + [&] {
                                 std::vector<const RtRoi*> all;
                                 for (const auto& r : rois) all.push_back(&r);
                                 return quoted_names(all, true);
                               }() + ")");
    if (roi->number_shared) throw InputError(path, "ROI '" + roi->name + "': " + shared_number_error(*this, *roi));
    if (std::find(out.begin(), out.end(), roi) == out.end()) out.push_back(roi);
  }
  return out;
}

std::vector<const RtRoi*> RtStructureSet::with_contours(const std::string& path, std::vector<std::string>& warnings) const {
  std::vector<const RtRoi*> out;
  for (const auto& r : rois) {
    if (r.number_shared) throw InputError(path, shared_number_error(*this, r) + " (select the others with " + option_name("--roi") + ")");
    if (r.closed_contours() == 0) {
      warnings.push_back(path + ": ROI '" + r.name + "' has no closed planar contour: skipped");
      continue;
    }
    out.push_back(&r);
  }
  if (out.empty()) throw InputError(path, "no ROI has closed planar contours");
  for (const RtRoi* r : out) {
    std::vector<const RtRoi*> same;
    for (const RtRoi* q : out)
      if (lower(q->name) == lower(r->name)) same.push_back(q);
    if (same.size() > 1)
      throw InputError(path, std::to_string(same.size()) + " ROIs are named '" + r->name + "': " + quoted_names(same, true) +
                                 "; select them by number (" + option_given("--roi", "NUMBER") + ", repeatable)");
  }
  return out;
}

namespace {

// The median step between sorted contour z, steps of kPlaneJitterMm or less
// not counted; 0 if there is none.
double own_spacing(const std::vector<double>& z) {
  std::vector<double> steps;
  for (std::size_t k = 1; k < z.size(); ++k)
    if (z[k] - z[k - 1] > kPlaneJitterMm) steps.push_back(z[k] - z[k - 1]);
  if (steps.empty()) return 0;
  std::nth_element(steps.begin(), steps.begin() + std::ptrdiff_t(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

}  // namespace

double typical_plane_spacing(const RtStructureSet& set) {
  std::vector<double> z;
  for (const auto& r : set.rois)
    for (const auto& c : r.contours)
      if (c.type == "CLOSED_PLANAR" && !c.points.empty()) z.push_back(c.points.front().z());
  std::sort(z.begin(), z.end());
  return own_spacing(z);
}

namespace {

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

// Runs `build`; returns dcmrt's warnings and errors logged meanwhile.
template <class F>
std::string dcmrt_log(F&& build) {
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

}  // namespace

RtStructureSet read_rtstruct(const std::string& path) {
  std::vector<unsigned char> bytes = detail::read_file_bytes(path, 0);  // a missing or unreadable file named as such
  static std::once_flag quiet;
  std::call_once(quiet, [] { OFLog::configure(OFLogger::FATAL_LOG_LEVEL); });  // we say what is wrong
  DcmFileFormat ff;
  OFCondition st = load_dicom(ff, bytes);
  if (st.bad()) throw InputError(path, std::string("not a readable DICOM file (") + st.text() + ")");
  OFString sop;
  ff.getDataset()->findAndGetOFString(DCM_SOPClassUID, sop);
  if (sop != UID_RTStructureSetStorage)
    throw InputError(path, std::string("not a DICOM RT Structure Set (SOP class ") +
                               (sop.empty() ? "missing" : dcmFindNameOfUID(sop.c_str(), sop.c_str())) + ")");
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
  DRTROIContourSequence& contours = rt->getROIContourSequence();
  for (std::size_t r = 0; r < contours.getNumberOfItems(); ++r) {
    auto& item = contours.getItem(r);
    OFString ref_text;
    item.getReferencedROINumber(ref_text);
    const Sint32 ref = roi_number_of(ref_text, path, "ROIContourSequence item " + std::to_string(r + 1) + ": ReferencedROINumber");
    const auto it = by_number.find(ref);
    if (it == by_number.end()) {  // contours of no listed ROI: nobody's name, colour or number to give them
      out.unlisted_contours[int(ref)] += int(item.getContourSequence().getNumberOfItems());
      continue;
    }
    RtRoi& roi = out.rois[it->second];
    if (roi.number_shared) continue;  // whose? selecting either ROI is an error
    Sint32 c[3];
    if (item.getROIDisplayColor(c[0], 0).good() && item.getROIDisplayColor(c[1], 1).good() &&
        item.getROIDisplayColor(c[2], 2).good())
      roi.color = Rgb{std::uint8_t(std::clamp(c[0], 0, 255)), std::uint8_t(std::clamp(c[1], 0, 255)),
                      std::uint8_t(std::clamp(c[2], 0, 255))};
    DRTContourSequence& seq = item.getContourSequence();
    for (std::size_t k = 0; k < seq.getNumberOfItems(); ++k) {
      auto& ct = seq.getItem(k);
      OFString type;
      ct.getContourGeometricType(type);
      OFVector<Float64> xyz;
      ct.getContourData(xyz);
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

namespace detail {

std::vector<std::vector<Vec2d>> split_keyholes(const std::vector<Vec2d>& polygon, double tol) {
  std::vector<std::vector<Vec2d>> done, todo{polygon};
  auto key = [tol](const Vec2d& p) { return std::pair{std::llround(p.x() / tol), std::llround(p.y() / tol)}; };
  while (!todo.empty()) {
    std::vector<Vec2d> p = std::move(todo.back());
    todo.pop_back();
    const std::size_t n = p.size();
    if (n < 3) continue;
    // Each directed edge by its quantised ends; a cut is an edge met again reversed.
    std::map<std::pair<std::pair<long long, long long>, std::pair<long long, long long>>, std::size_t> edges;
    std::size_t cut_i = n, cut_j = n;
    for (std::size_t j = 0; j < n && cut_i == n; ++j) {
      const auto a = key(p[j]), b = key(p[(j + 1) % n]);
      if (a == b) continue;
      const auto back = edges.find({b, a});
      if (back != edges.end()) cut_i = back->second, cut_j = j;
      else edges.emplace(std::pair{a, b}, j);
    }
    if (cut_i == n) {
      done.push_back(std::move(p));
      continue;
    }
    // p[i] -> p[i+1] and later p[j] -> p[j+1] (= p[i+1] -> p[i]): the loop
    // p[i+1] .. p[j-1] and the rest p[j+1] .. p[i] (both without the cut).
    std::vector<Vec2d> inner(p.begin() + std::ptrdiff_t(cut_i + 1), p.begin() + std::ptrdiff_t(cut_j));
    std::vector<Vec2d> outer;
    for (std::size_t k = (cut_j + 2) % n; k != (cut_i + 1) % n; k = (k + 1) % n) outer.push_back(p[k]);
    todo.push_back(std::move(inner));
    todo.push_back(std::move(outer));
  }
  return done;
}

}  // namespace detail

SliceStack roi_stack(const RtRoi& roi, const RoiGrid& grid, const std::string& path, std::vector<std::string>& warnings) {
  if (!(grid.voxel_size > 0 && std::isfinite(grid.voxel_size)))
    throw ParamError(option_name("--voxel-size") + ": must be finite and > 0, got " + std::to_string(grid.voxel_size));
  const std::string what = "ROI '" + roi.name + "'";
  // Each closed contour's plane (mean z of its points), to find the spacing first.
  std::vector<double> contour_z;
  for (const RtContour& c : roi.contours) {
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) continue;
    double sum = 0;
    for (const Vec3d& p : c.points) sum += p.z();
    contour_z.push_back(sum / double(c.points.size()));
  }
  std::vector<double> sorted_z = contour_z;
  std::sort(sorted_z.begin(), sorted_z.end());
  const double spacing = grid.plane_spacing > 0 ? grid.plane_spacing : own_spacing(sorted_z);
  if (!std::isfinite(spacing))
    throw InputError(path, what + ": its contour planes are too far apart to have a slice spacing");
  // Contours this close share a plane; a contour's points this close are planar.
  const double tolerance = std::max(kPlanarToleranceMm, kPlaneGroupFraction * spacing);

  struct Plane {
    double z = 0;   // mean of its contours' z
    int contours = 0;
    double zlo = INFINITY, zhi = -INFINITY;
    std::vector<std::vector<Vec2d>> loops;  // patient x, y
  };
  std::vector<Plane> planes;
  int skipped = 0, specks = 0, flat = 0;  // flat: loops with no area at all (collinear points)
  for (std::size_t k = 0, kz = 0; k < roi.contours.size(); ++k) {
    const RtContour& c = roi.contours[k];
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) {
      ++skipped;
      continue;
    }
    const double z = contour_z[kz++];
    double zlo = c.points.front().z(), zhi = zlo;
    for (const Vec3d& p : c.points) zlo = std::min(zlo, p.z()), zhi = std::max(zhi, p.z());
    if (zhi - zlo > tolerance) {
      // On a tilted plane, or on none: the smallest spread about the best plane tells.
      Vec3d mean = Vec3d::Zero();
      for (const Vec3d& p : c.points) mean += p;
      mean /= double(c.points.size());
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (const Vec3d& p : c.points) cov += (p - mean) * (p - mean).transpose();
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
      const Vec3d normal = eig.eigenvectors().col(0);
      double off = 0;
      for (const Vec3d& p : c.points) off = std::max(off, std::abs((p - mean).dot(normal)));
      throw InputError(path, what + " contour " + std::to_string(k) +
                                 (off <= kPlanarToleranceMm
                                      ? " lies on an oblique plane (not perpendicular to the patient z axis; z from " +
                                            std::to_string(zlo) + " to " + std::to_string(zhi) + " mm)"
                                      : " is not planar (its points are up to " + std::to_string(off) +
                                            " mm off their best plane)"));
    }
    std::vector<Vec2d> ring;
    for (const Vec3d& p : c.points) ring.emplace_back(p.x(), p.y());
    if (ring.size() > 3 && (ring.back() - ring.front()).norm() <= kKeyholeTolerance) ring.pop_back();
    std::vector<std::vector<Vec2d>> loops;
    for (auto& loop : detail::split_keyholes(ring, kKeyholeTolerance)) {
      // A loop smaller than one pixel of the working grid has no pixel to be
      // represented by: dropped, with a warning below.
      const double area = std::abs(signed_area(loop));
      if (area < grid.voxel_size * grid.voxel_size) {
        ++specks;
        flat += area == 0.0;
        continue;
      }
      loops.push_back(std::move(loop));
    }
    if (loops.empty()) continue;
    // The plane whose mean z lies within the tolerance (planes are a spacing,
    // five tolerances, apart).
    auto plane = std::find_if(planes.begin(), planes.end(), [&](const Plane& q) { return std::abs(q.z - z) <= tolerance; });
    if (plane == planes.end()) plane = planes.insert(planes.end(), Plane{});
    plane->z = (plane->z * plane->contours + z) / (plane->contours + 1);
    ++plane->contours;
    plane->zlo = std::min(plane->zlo, z), plane->zhi = std::max(plane->zhi, z);
    for (auto& loop : loops) plane->loops.push_back(std::move(loop));
  }
  if (skipped > 0)
    warnings.push_back(path + ": " + what + ": " + std::to_string(skipped) +
                       " contour(s) not CLOSED_PLANAR with 3 or more points skipped");
  if (specks > 0)
    warnings.push_back(path + ": " + what + ": " + std::to_string(specks) + " contour loop(s) smaller than one pixel of the " +
                       std::to_string(grid.voxel_size) + " mm working grid dropped (give a smaller " + option_name("--voxel-size") + " to keep them)");
  if (planes.empty()) {
    std::string why;
    if (specks > 0)
      why = ": its " + std::to_string(specks) + " contour loop(s) each enclose less than one pixel of the " +
            std::to_string(grid.voxel_size) + " mm working grid" +
            (flat > 0 ? " (" + std::to_string(flat) + " of them no area at all: zero net area, e.g. collinear points)"
                      : "");
    else if (skipped > 0)
      why = ": its " + std::to_string(skipped) + " contour(s) are not CLOSED_PLANAR with 3 or more points";
    throw InputError(path, what + " has no closed planar contour that encloses an area" + why);
  }
  std::sort(planes.begin(), planes.end(), [](const Plane& a, const Plane& b) { return a.z < b.z; });
  int joined = 0;
  double worst = 0;
  for (const Plane& q : planes)
    if (q.zhi - q.zlo > kPlanarToleranceMm) ++joined, worst = std::max(worst, q.zhi - q.zlo);
  if (joined > 0) {
    std::ostringstream o;
    o << path << ": " << what << ": on " << joined << " plane(s) the contours' z differ by up to " << worst
      << " mm (rounding?); each such plane taken at their mean z (contours within " << tolerance
      << " mm, a fifth of the " << spacing << " mm slice spacing, share a plane)";
    warnings.push_back(o.str());
  }
  if (planes.size() == 1 && !(spacing > 0))
    throw InputError(path, what + " has contours on one plane only (z = " + std::to_string(planes.front().z) +
                               " mm) and the structure set gives no slice spacing to make it a slab");

  // The working grid: the contours' box plus the margin, voxel_size pixels.
  double xlo = INFINITY, ylo = INFINITY, xhi = -INFINITY, yhi = -INFINITY;
  for (const Plane& q : planes)
    for (const auto& loop : q.loops)
      for (const Vec2d& p : loop) xlo = std::min(xlo, p.x()), xhi = std::max(xhi, p.x()), ylo = std::min(ylo, p.y()), yhi = std::max(yhi, p.y());
  const double s = grid.voxel_size;
  const double wx = std::ceil((xhi - xlo) / s) + 2.0 * grid.margin + 1, wy = std::ceil((yhi - ylo) / s) + 2.0 * grid.margin + 1;
  constexpr double kMaxGrid = 1 << 15;  // pixels across: a 32768^2 working grid is surely a wrong voxel size
  if (!(wx <= kMaxGrid && wy <= kMaxGrid)) {  // as doubles: a long cast of 1e300 printed -9223372036854775808
    char size[64];
    std::snprintf(size, sizeof size, "%.4g x %.4g", wx, wy);
    throw ParamError(option_name("--voxel-size") + " " + detail::shortest_text(s) + " mm: " + what + " would need a " +
                     size + " pixel grid");
  }
  SliceStack st;
  st.kind = InputKind::Polylines;
  st.width = int(wx);
  st.height = int(wy);
  st.pixel_size = s;
  const Vec3d origin(xlo - grid.margin * s, ylo - grid.margin * s, planes.front().z);
  PatientFrame frame;
  frame.axes = Eigen::Matrix3d::Identity() * s;
  frame.origin = origin;
  st.patient = frame;

  auto empty_slice = [&](double z_mm) {
    Slice e;
    e.z = (z_mm - origin.z()) / s;
    e.source = path + " " + what + " (no contour at z = " + std::to_string(z_mm) + " mm)";
    st.slices.push_back(std::move(e));
  };
  std::vector<double> steps;
  for (std::size_t k = 1; k < planes.size(); ++k) steps.push_back(planes[k].z - planes[k - 1].z);
  double typical = spacing;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + std::ptrdiff_t(steps.size() / 2), steps.end());
    typical = steps[steps.size() / 2];
  }
  auto contour_slice = [&](const Plane& q, double z_mm) {
    Slice sl;
    sl.z = (z_mm - origin.z()) / s;
    sl.source = path + " " + what + " z = " + std::to_string(q.z) + " mm";
    for (const auto& loop : q.loops) {
      Polygon poly;
      for (const Vec2d& p : loop) poly.points.emplace_back((p.x() - origin.x()) / s, (p.y() - origin.y()) / s);
      sl.polygons.push_back(std::move(poly));
    }
    st.slices.push_back(std::move(sl));
  };
  // One plane: its contours on two slices half a spacing apart around it, so
  // the end caps (cap_extent of that half spacing beyond each) close it as a
  // slab of about one spacing, the field between the two constant.
  if (planes.size() == 1) {
    contour_slice(planes.front(), planes.front().z - 0.25 * spacing);
    contour_slice(planes.front(), planes.front().z + 0.25 * spacing);
    return st;
  }
  for (std::size_t k = 0; k < planes.size(); ++k) {
    if (k > 0) {
      const double gap = planes[k].z - planes[k - 1].z;
      if (gap > kGapFactor * typical) {
        const long parts = std::max(2L, std::lround(gap / typical));
        for (long m = 1; m < parts; ++m) empty_slice(planes[k - 1].z + gap * double(m) / double(parts));
      }
    }
    contour_slice(planes[k], planes[k].z);
  }
  return st;
}

std::vector<double> rt_planes(const SliceStack& st) {
  std::vector<double> z;
  for (const Slice& s : st.slices)
    if (!s.polygons.empty()) z.push_back(st.patient ? st.patient->to_patient(Vec3d(0, 0, s.z)).z() : s.z);
  // A one-plane ROI's two slices hold the same contours.
  if (z.size() == 2 && st.slices.size() == 2 && st.slices[0].source == st.slices[1].source) return {0.5 * (z[0] + z[1])};
  return z;
}

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
  if (load_dicom(ff, source_bytes ? *source_bytes : detail::read_file_bytes(source)).bad())
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
  const std::string why = dcmrt_log([&] { built = rt->write(*outf.getDataset()); });
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
