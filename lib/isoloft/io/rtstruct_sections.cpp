// @file io/rtstruct_sections.cpp
// @brief An RT ROI's contours as sections on their own planes: fit each
// contour's plane, refuse the unflat, group the coplanar.
#include "isoloft/io/rtstruct_sections.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "isoloft/core/error.h"
#include "isoloft/io/plane_fit.h"
#include "isoloft/io/text.h"

namespace isoloft {

namespace {

struct Group {
  std::vector<Vec3d> points;  // all its contours' points, for the refit
  PlaneFit fit;
  std::vector<std::size_t> contours;  // indices into the ROI's contour sequence
};

// Largest distance of `pts` from the plane of `fit`.
double off_plane(const std::vector<Vec3d>& pts, const PlaneFit& fit) {
  double off = 0;
  for (const Vec3d& p : pts) off = std::max(off, std::abs((p - fit.centroid).dot(fit.normal)));
  return off;
}

double box_diagonal(const std::vector<Vec3d>& pts) {
  Vec3d lo = pts.front(), hi = pts.front();
  for (const Vec3d& p : pts) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  return (hi - lo).norm();
}

}  // namespace

std::vector<Section> roi_sections(const RtRoi& roi, const std::string& path, std::vector<std::string>& warnings) {
  const std::string what = "ROI '" + roi.name + "'";
  // Each usable contour's plane; the flat ones (no area, no plane) counted.
  std::vector<std::size_t> usable, small;  // small: too narrow to determine a plane
  std::vector<PlaneFit> fits(roi.contours.size());
  int skipped = 0, flat = 0;
  for (std::size_t k = 0; k < roi.contours.size(); ++k) {
    const RtContour& c = roi.contours[k];
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) {
      ++skipped;
      continue;
    }
    fits[k] = fit_plane(c.points);
    if (!(fits[k].line_spread > kRtCollinearToleranceMm)) {
      small.push_back(k);
      continue;
    }
    if (!(fits[k].max_residual <= kRtOffPlaneToleranceMm))
      throw InputError(path, what + " contour " + std::to_string(k) + ": not planar (its points are up to " +
                                 detail::shortest_text(fits[k].max_residual) + " mm off their best plane, tolerance " +
                                 detail::shortest_text(kRtOffPlaneToleranceMm) + " mm)");
    usable.push_back(k);
  }
  // Largest contours first: their planes are the best determined, so a small
  // contour (whose own fit tilts with rounding) joins the plane it lies on.
  std::stable_sort(usable.begin(), usable.end(), [&](std::size_t a, std::size_t b) {
    return box_diagonal(roi.contours[a].points) > box_diagonal(roi.contours[b].points);
  });
  std::vector<Group> groups;
  for (std::size_t k : usable) {
    const std::vector<Vec3d>& pts = roi.contours[k].points;
    // The first plane this contour lies on, refitted with it if all points
    // stay within the tolerance; else a plane of its own.
    bool placed = false;
    for (Group& g : groups) {
      if (off_plane(pts, g.fit) > kRtOffPlaneToleranceMm) continue;
      std::vector<Vec3d> merged = g.points;
      merged.insert(merged.end(), pts.begin(), pts.end());
      const PlaneFit refit = fit_plane(merged);
      if (refit.max_residual > kRtOffPlaneToleranceMm) continue;
      g.points = std::move(merged);
      g.fit = refit;
      g.contours.push_back(k);
      placed = true;
      break;
    }
    if (!placed) groups.push_back(Group{pts, fits[k], {k}});
  }
  // A contour too narrow to give its own plane (the breast set's 0.09 mm
  // specks) joins a plane it lies on; on none, it is skipped.
  for (std::size_t k : small) {
    const auto g = std::find_if(groups.begin(), groups.end(), [&](const Group& q) {
      return off_plane(roi.contours[k].points, q.fit) <= kRtOffPlaneToleranceMm;
    });
    if (g == groups.end()) {
      ++flat;
      continue;
    }
    g->contours.push_back(k);
  }
  if (skipped > 0)
    warnings.push_back(path + ": " + what + ": " + std::to_string(skipped) +
                       " contour(s) not CLOSED_PLANAR with 3 or more points skipped");
  if (flat > 0)
    warnings.push_back(path + ": " + what + ": " + std::to_string(flat) + " contour(s) too narrow to give a plane (within " +
                       detail::shortest_text(kRtCollinearToleranceMm) + " mm RMS of a line) and on no plane of the others skipped");
  if (groups.empty()) throw InputError(path, what + " has no closed planar contour that encloses an area");
  // Sections in the order their planes first appear, contours in file order.
  for (Group& g : groups) std::sort(g.contours.begin(), g.contours.end());
  std::sort(groups.begin(), groups.end(), [](const Group& a, const Group& b) { return a.contours[0] < b.contours[0]; });

  std::vector<Section> out;
  for (std::size_t i = 0; i < groups.size(); ++i) {
    const Group& g = groups[i];
    Section s;
    s.pose = plane_pose(g.fit.normal, g.fit.centroid.dot(g.fit.normal));
    s.source = std::filesystem::path(path).filename().string() + ", " + what + ", plane " + std::to_string(i + 1);
    for (std::size_t k : g.contours) {
      std::vector<Vec2d> ring;
      ring.reserve(roi.contours[k].points.size());
      for (const Vec3d& p : roi.contours[k].points) ring.push_back(s.pose.to_plane(p));
      if (ring.size() > 3 && (ring.back() - ring.front()).norm() <= kKeyholeTolerance) ring.pop_back();
      for (auto& loop : detail::split_keyholes(ring, kKeyholeTolerance)) {
        SectionContour sc;
        sc.points = std::move(loop);
        s.contours.push_back(std::move(sc));
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace isoloft
