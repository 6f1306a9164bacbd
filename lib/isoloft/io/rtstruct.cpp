// @file io/rtstruct.cpp
// @brief RT Structure Set ROIs: selection by name or number, the contour
// planes' spacing, keyhole splitting, and one ROI as a polyline slice stack.
#include "isoloft/io/rtstruct.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/text.h"

namespace isoloft {

namespace {

// A step between contour planes longer than this many typical steps is a gap
// with no contour, not a coarser sampling.
constexpr double kGapFactor = 1.5;


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

}  // namespace isoloft
