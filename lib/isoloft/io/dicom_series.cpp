#include "isoloft/io/dicom_series.h"

// DCMTK's configuration header must come before its other headers.
#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcfilefo.h"
#include "dcmtk/oflog/oflog.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/io/rtstruct.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

// One file's Image Plane module and identity.
struct SliceHeader {
  std::string file, series, modality, description, frame, sop_class, sop_instance;
  Eigen::Vector3d position, row, column;  // ImagePositionPatient; ImageOrientationPatient's two directions
  double row_spacing = 0, column_spacing = 0;  // PixelSpacing: between rows (y), between columns (x)
  double thickness = 0;                        // SliceThickness (0 if absent)
  int rows = 0, columns = 0, frames = 1;
};

std::string text(DcmDataset& d, const DcmTagKey& tag) {
  OFString s;
  d.findAndGetOFStringArray(tag, s);
  std::string out = s.c_str();
  while (!out.empty() && (out.back() == ' ' || out.back() == '\0')) out.pop_back();
  return out;
}

bool numbers(DcmDataset& d, const DcmTagKey& tag, double* out, int n) {
  for (int i = 0; i < n; ++i) {
    Float64 v = 0;
    if (d.findAndGetFloat64(tag, v, unsigned(i)).bad() || !std::isfinite(v)) return false;
    out[i] = v;
  }
  return true;
}

// A DICOM image (it has Rows and Columns) whose image plane is incomplete.
struct Planeless {
  std::string file, series, missing;  // missing: the attributes' names
};

// The header of `file` if it is a DICOM image with an image plane; nullopt
// for a DICOM file without one (an RT Structure Set, a DICOMDIR), and then,
// if it is an image all the same, what it lacks in `planeless`.
std::optional<SliceHeader> read_header(const std::string& file, std::optional<Planeless>* planeless = nullptr) {
  DcmFileFormat ff;
  if (const OFCondition st = ff.loadFileUntilTag(file.c_str(), EXS_Unknown, EGL_noChange, DCM_MaxReadLength,
                                                 ERM_autoDetect, DCM_PixelData);
      st.bad())
    throw InputError(file, std::string("not a readable DICOM file (") + st.text() + ")");
  DcmDataset& d = *ff.getDataset();
  SliceHeader h;
  double pos[3], dir[6], spacing[2];
  Uint16 rows = 0, columns = 0;
  const bool image = d.findAndGetUint16(DCM_Rows, rows).good() && d.findAndGetUint16(DCM_Columns, columns).good();
  std::string missing;
  if (!numbers(d, DCM_ImagePositionPatient, pos, 3)) missing += "ImagePositionPatient";
  if (!numbers(d, DCM_ImageOrientationPatient, dir, 6)) missing += (missing.empty() ? "" : ", ") + std::string("ImageOrientationPatient");
  if (!numbers(d, DCM_PixelSpacing, spacing, 2)) missing += (missing.empty() ? "" : ", ") + std::string("PixelSpacing");
  if (!image || !missing.empty()) {
    if (image && planeless) *planeless = Planeless{file, text(d, DCM_SeriesInstanceUID), missing};
    return std::nullopt;
  }
  h.file = file;
  h.series = text(d, DCM_SeriesInstanceUID);
  h.modality = text(d, DCM_Modality);
  h.description = text(d, DCM_SeriesDescription);
  h.frame = text(d, DCM_FrameOfReferenceUID);
  h.sop_class = text(d, DCM_SOPClassUID);
  h.sop_instance = text(d, DCM_SOPInstanceUID);
  h.position = Eigen::Vector3d(pos[0], pos[1], pos[2]);
  h.row = Eigen::Vector3d(dir[0], dir[1], dir[2]);
  h.column = Eigen::Vector3d(dir[3], dir[4], dir[5]);
  h.row_spacing = spacing[0];
  h.column_spacing = spacing[1];
  numbers(d, DCM_SliceThickness, &h.thickness, 1);
  h.rows = rows;
  h.columns = columns;
  Sint32 frames = 1;
  if (d.findAndGetSint32(DCM_NumberOfFrames, frames).good()) h.frames = frames;
  return h;
}

std::string fmt(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

}  // namespace

DicomSeries read_dicom_series(const std::string& path) {
  static std::once_flag quiet;
  std::call_once(quiet, [] { OFLog::configure(OFLogger::FATAL_LOG_LEVEL); });  // we say what is wrong
  std::error_code ec;
  const bool folder = fs::is_directory(path, ec);
  if (!folder && !fs::is_regular_file(path, ec)) throw InputError(path, "no such file or folder");
  std::string wanted;  // one file given: its series
  if (!folder) {
    if (!is_dicom_file(path)) throw InputError(path, "not a DICOM file (no DICM preamble)");
    const auto h = read_header(path);
    if (!h) throw InputError(path, "a DICOM file without an image plane (ImagePositionPatient, ImageOrientationPatient, PixelSpacing)");
    wanted = h->series;
  }
  const fs::path dir = folder ? fs::path(path) : fs::path(path).parent_path();
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir.empty() ? fs::path(".") : dir, ec))
    if (e.is_regular_file(ec)) names.push_back(e.path().string());
  std::sort(names.begin(), names.end());
  std::map<std::string, std::vector<SliceHeader>> series;
  std::vector<Planeless> planeless;  // images that cannot be placed
  for (const std::string& f : names) {
    if (!is_dicom_file(f)) continue;
    std::optional<SliceHeader> h;
    std::optional<Planeless> lacks;
    try {
      h = read_header(f, &lacks);
    } catch (const InputError&) {
      continue;  // an unreadable file beside the series is not one of its slices
    }
    if (h && (wanted.empty() || h->series == wanted)) series[h->series].push_back(std::move(*h));
    if (lacks) planeless.push_back(std::move(*lacks));
  }
  // An image of the series without its plane: once dropped silently (18
  // slices for 19 images), a gap in the grid nobody saw.
  for (const Planeless& p : planeless)
    if (series.count(p.series))
      throw InputError(p.file, "an image of the series " + p.series + " without " + p.missing +
                                   ": its slice cannot be placed (" + std::to_string(series[p.series].size()) +
                                   " other images in " + dir.string() + "); fix or remove it");
  if (series.empty()) throw InputError(path, "no DICOM image with an image plane (ImagePositionPatient, ImageOrientationPatient, PixelSpacing) in " + dir.string());
  if (series.size() > 1) {
    std::ostringstream o;
    o << series.size() << " image series in " << dir.string() << ":";
    for (const auto& [uid, s] : series)
      o << " " << uid << " (" << s.front().modality << (s.front().description.empty() ? "" : " '" + s.front().description + "'")
        << ", " << s.size() << " slices);";
    o << " give one file of the series wanted";
    throw InputError(path, o.str());
  }
  std::vector<SliceHeader> s = std::move(series.begin()->second);
  const SliceHeader& a = s.front();
  if (a.frames > 1)
    throw InputError(a.file, "a multi-frame image (" + std::to_string(a.frames) +
                                 " frames): give a single-frame series, or the grid as NIfTI / NRRD / MetaImage");
  const Eigen::Vector3d normal = a.row.cross(a.column);
  if (!(a.row_spacing > 0 && a.column_spacing > 0) || std::abs(a.row.norm() - 1) > 1e-3 ||
      std::abs(a.column.norm() - 1) > 1e-3 || std::abs(a.row.dot(a.column)) > detail::kOrthogonalityTolerance * 10)
    throw InputError(a.file, "ImageOrientationPatient or PixelSpacing is not a valid image plane");
  for (const SliceHeader& h : s)
    if (h.rows != a.rows || h.columns != a.columns || std::abs(h.row_spacing - a.row_spacing) > 1e-4 ||
        std::abs(h.column_spacing - a.column_spacing) > 1e-4 || (h.row - a.row).norm() > 1e-4 ||
        (h.column - a.column).norm() > 1e-4 || h.frames > 1)
      throw InputError(h.file, "its size, pixel spacing or orientation differs from " + a.file + "'s: not one grid");
  std::sort(s.begin(), s.end(), [&](const SliceHeader& p, const SliceHeader& q) {
    return p.position.dot(normal) < q.position.dot(normal);
  });
  std::vector<double> steps;
  for (std::size_t k = 1; k < s.size(); ++k) steps.push_back((s[k].position - s[k - 1].position).dot(normal));
  double step = s.front().thickness > 0 ? s.front().thickness : 1.0;
  if (!steps.empty()) {
    std::vector<double> sorted = steps;
    std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2), sorted.end());
    step = sorted[sorted.size() / 2];
  }
  for (std::size_t k = 0; k < steps.size(); ++k) {
    if (steps[k] <= kSeriesPositionToleranceMm)
      throw InputError(s[k + 1].file, "at the position of " + s[k].file + ": two slices in one place");
    if (std::abs(steps[k] - step) > std::max(kSeriesPositionToleranceMm, kSeriesStepTolerance * step)) {
      std::ostringstream o;
      o << "the slices are not evenly spaced: " << fmt(steps[k]) << " mm after slice " << k << " (" << s[k].file
        << "), " << fmt(step) << " mm typically (a missing slice?); a grid needs one spacing";
      throw InputError(path, o.str());
    }
  }
  for (std::size_t k = 1; k < s.size(); ++k) {
    const Eigen::Vector3d off = s[k].position - s[0].position;
    if ((off - off.dot(normal) * normal).norm() > std::max(kSeriesPositionToleranceMm, kSeriesStepTolerance * step) * double(k))
      throw InputError(path, "slice positions drift sideways from the slice normal (" + s[k].file +
                                 "; a gantry tilt?): not a regular grid");
  }
  DicomSeries out;
  Volume& g = out.grid;
  g.nx = a.columns, g.ny = a.rows, g.nz = int(s.size());
  g.spacing = {a.column_spacing, a.row_spacing, step};
  g.origin = {s[0].position.x(), s[0].position.y(), s[0].position.z()};
  g.direction.col(0) = a.row.normalized();
  g.direction.col(1) = a.column.normalized();
  g.direction.col(2) = normal.normalized();
  g.integer = true;
  out.frame_of_reference = a.frame;
  out.series_uid = a.series;
  out.modality = a.modality;
  out.sop_class_uid = a.sop_class;
  for (const SliceHeader& h : s) out.sop_instance_uids.push_back(h.sop_instance), out.files.push_back(h.file);
  return out;
}

}  // namespace isoloft
