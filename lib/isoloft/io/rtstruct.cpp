#include "isoloft/io/rtstruct.h"

// DCMTK's configuration header must come before its other headers.
#include "dcmtk/config/osconfig.h"
#include "dcmtk/dcmdata/dcdeftag.h"
#include "dcmtk/dcmdata/dcfilefo.h"
#include "dcmtk/dcmdata/dcuid.h"
#include "dcmtk/dcmrt/drtstrct.h"
#include "dcmtk/oflog/oflog.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/file_util.h"

namespace isoloft {

namespace {

// Points of one contour whose z differ by more than this (mm) are not on one
// axial plane: DICOM stores them as decimal strings, equal on an axial contour.
constexpr double kPlanarTolerance = 0.01;
// Contours whose planes are closer than this (mm) share a slice.
constexpr double kPlaneTolerance = 0.01;
// Keyhole cut ends closer than this (mm) are the same point (a cut is written
// twice with the same decimal strings).
constexpr double kKeyholeTolerance = 1e-3;
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

bool is_dicom_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char buf[132];
  return in.read(buf, sizeof buf) && std::memcmp(buf + 128, "DICM", 4) == 0;
}

RtStructureSet read_rtstruct(const std::string& path) {
  (void)detail::read_file_bytes(path, 0);  // a missing or unreadable file named as such
  static std::once_flag quiet;
  std::call_once(quiet, [] { OFLog::configure(OFLogger::FATAL_LOG_LEVEL); });  // we say what is wrong
  DcmFileFormat ff;
  OFCondition st = ff.loadFile(path.c_str());
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
  std::map<Sint32, std::size_t> by_number;
  // Sequences are read by index: DCMTK's gotoNextItem() loops visit one empty item too many.
  DRTStructureSetROISequence& rois = rt->getStructureSetROISequence();
  for (std::size_t i = 0; i < rois.getNumberOfItems(); ++i) {
    Sint32 number = -1;
    OFString name;
    rois.getItem(i).getROINumber(number);
    rois.getItem(i).getROIName(name);
    by_number[number] = out.rois.size();
    out.rois.push_back({int(number), rtrim(name.c_str()), std::nullopt, {}});
  }
  if (out.rois.empty()) throw InputError(path, "the RT Structure Set holds no ROI");
  DRTROIContourSequence& contours = rt->getROIContourSequence();
  for (std::size_t r = 0; r < contours.getNumberOfItems(); ++r) {
    auto& item = contours.getItem(r);
    Sint32 ref = -1;
    item.getReferencedROINumber(ref);
    const auto it = by_number.find(ref);
    if (it == by_number.end()) continue;  // contours of no listed ROI
    RtRoi& roi = out.rois[it->second];
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
  struct Plane {
    double z;
    std::vector<std::vector<Vec2d>> loops;  // patient x, y
  };
  std::vector<Plane> planes;
  int skipped = 0, specks = 0;
  for (std::size_t k = 0; k < roi.contours.size(); ++k) {
    const RtContour& c = roi.contours[k];
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) {
      ++skipped;
      continue;
    }
    double zlo = c.points.front().z(), zhi = zlo;
    for (const Vec3d& p : c.points) zlo = std::min(zlo, p.z()), zhi = std::max(zhi, p.z());
    if (zhi - zlo > kPlanarTolerance) {
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
                                 (off <= kPlanarTolerance
                                      ? " lies on an oblique plane (not perpendicular to the patient z axis; z from " +
                                            std::to_string(zlo) + " to " + std::to_string(zhi) + " mm)"
                                      : " is not planar (its points are up to " + std::to_string(off) +
                                            " mm off their best plane)"));
    }
    std::vector<Vec2d> ring;
    for (const Vec3d& p : c.points) ring.emplace_back(p.x(), p.y());
    if (ring.size() > 3 && (ring.back() - ring.front()).norm() <= kKeyholeTolerance) ring.pop_back();
    const double z = c.points.front().z();
    std::vector<std::vector<Vec2d>> loops;
    for (auto& loop : detail::split_keyholes(ring, kKeyholeTolerance)) {
      // A loop smaller than one pixel of the working grid has no pixel to be
      // represented by: dropped, with a warning below.
      if (std::abs(signed_area(loop)) < grid.voxel_size * grid.voxel_size) {
        ++specks;
        continue;
      }
      loops.push_back(std::move(loop));
    }
    if (loops.empty()) continue;
    auto plane = std::find_if(planes.begin(), planes.end(), [&](const Plane& q) { return std::abs(q.z - z) <= kPlaneTolerance; });
    if (plane == planes.end()) plane = planes.insert(planes.end(), Plane{z, {}});
    for (auto& loop : loops) plane->loops.push_back(std::move(loop));
  }
  if (skipped > 0)
    warnings.push_back(path + ": " + what + ": " + std::to_string(skipped) +
                       " contour(s) not CLOSED_PLANAR with 3 or more points skipped");
  if (specks > 0)
    warnings.push_back(path + ": " + what + ": " + std::to_string(specks) + " contour loop(s) smaller than one pixel of the " +
                       std::to_string(grid.voxel_size) + " mm working grid dropped (give a smaller " + option_name("--voxel-size") + " to keep them)");
  if (planes.empty()) throw InputError(path, what + " has no closed planar contour");
  if (planes.size() < 2)
    throw InputError(path, what + " has contours on one plane only (z = " + std::to_string(planes.front().z) +
                               " mm); a surface needs at least 2");
  std::sort(planes.begin(), planes.end(), [](const Plane& a, const Plane& b) { return a.z < b.z; });

  // The working grid: the contours' box plus the margin, voxel_size pixels.
  double xlo = INFINITY, ylo = INFINITY, xhi = -INFINITY, yhi = -INFINITY;
  for (const Plane& q : planes)
    for (const auto& loop : q.loops)
      for (const Vec2d& p : loop) xlo = std::min(xlo, p.x()), xhi = std::max(xhi, p.x()), ylo = std::min(ylo, p.y()), yhi = std::max(yhi, p.y());
  const double s = grid.voxel_size;
  const double wx = std::ceil((xhi - xlo) / s) + 2.0 * grid.margin + 1, wy = std::ceil((yhi - ylo) / s) + 2.0 * grid.margin + 1;
  constexpr double kMaxGrid = 1 << 15;  // pixels across: a 32768^2 working grid is surely a wrong voxel size
  if (wx > kMaxGrid || wy > kMaxGrid)
    throw ParamError(option_name("--voxel-size") + " " + std::to_string(s) + " mm: " + what + " would need a " + std::to_string(long(wx)) +
                     " x " + std::to_string(long(wy)) + " pixel grid");
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

  std::vector<double> steps;
  for (std::size_t k = 1; k < planes.size(); ++k) steps.push_back(planes[k].z - planes[k - 1].z);
  std::nth_element(steps.begin(), steps.begin() + std::ptrdiff_t(steps.size() / 2), steps.end());
  const double typical = steps[steps.size() / 2];
  for (std::size_t k = 0; k < planes.size(); ++k) {
    if (k > 0) {
      const double gap = planes[k].z - planes[k - 1].z;
      if (gap > kGapFactor * typical) {
        const long parts = std::max(2L, std::lround(gap / typical));
        for (long m = 1; m < parts; ++m) {
          Slice e;
          e.z = (planes[k - 1].z + gap * double(m) / double(parts) - origin.z()) / s;
          e.source = path + " " + what + " (no contour at z = " + std::to_string(planes[k - 1].z + gap * double(m) / double(parts)) + " mm)";
          st.slices.push_back(std::move(e));
        }
      }
    }
    Slice sl;
    sl.z = (planes[k].z - origin.z()) / s;
    sl.source = path + " " + what + " z = " + std::to_string(planes[k].z) + " mm";
    for (const auto& loop : planes[k].loops) {
      Polygon poly;
      for (const Vec2d& p : loop) poly.points.emplace_back((p.x() - origin.x()) / s, (p.y() - origin.y()) / s);
      sl.polygons.push_back(std::move(poly));
    }
    st.slices.push_back(std::move(sl));
  }
  return st;
}

}  // namespace isoloft
