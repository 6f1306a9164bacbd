#include "isoloft/run/rtstruct_output.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>
#include <tuple>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/field3d/field3d.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/mesh/plane_cut.h"
#include "isoloft/run.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

constexpr const char* kNeedsRtInput =
    ": an RT Structure Set out needs an RT Structure Set input (its patient, study and frame of reference are written "
    "back) or a volume (NIfTI, NRRD, MetaImage: a standalone set on its slices' planes)";

// Keyhole cut ends closer than this (mm) are one point, as roi_stack splits
// them (io/rtstruct.h): a cut is written twice with the same decimal strings.
constexpr double kKeyholeMm = 1e-3;

// Sections of at most this area (mm^2) nobody drew are tolerated by the
// issue's target (flagged all the same).
constexpr double kUndrawnToleratedMm2 = 1.0;

using Loop = std::vector<Vec2d>;

struct DrawnLoop {
  int contour = 0;  // 1-based place in the ROI's contours
  Loop points;      // patient x, y mm
};

struct Box {
  Vec2d lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  Vec2d hi = -lo;
};

Box box_of(const Loop& l) {
  Box b;
  for (const Vec2d& p : l) b.lo = b.lo.cwiseMin(p), b.hi = b.hi.cwiseMax(p);
  return b;
}

bool boxes_near(const Box& a, const Box& b, double margin) {
  return a.lo.x() <= b.hi.x() + margin && b.lo.x() <= a.hi.x() + margin && a.lo.y() <= b.hi.y() + margin &&
         b.lo.y() <= a.hi.y() + margin;
}

// Mean and largest distance from the vertices of `from` to the nearest of `to`.
std::pair<double, double> directed_distance(const Loop& from, const std::vector<const Loop*>& to) {
  double sum = 0, most = 0;
  for (const Vec2d& p : from) {
    double d = std::numeric_limits<double>::infinity();
    for (const Loop* l : to) d = std::min(d, distance_to_loop(p, *l));
    sum += d;
    most = std::max(most, d);
  }
  return {from.empty() ? 0.0 : sum / double(from.size()), most};
}

// The ROI's closed planar contours on each plane of `planes` (the nearest),
// keyholes split into their loops.
std::vector<std::vector<DrawnLoop>> drawn_by_plane(const RtRoi& roi, const std::vector<double>& planes) {
  std::vector<std::vector<DrawnLoop>> out(planes.size());
  if (planes.empty()) return out;
  for (std::size_t c = 0; c < roi.contours.size(); ++c) {
    const RtContour& contour = roi.contours[c];
    if (contour.type != "CLOSED_PLANAR" || contour.points.size() < 3) continue;
    const double z = contour.points.front().z();
    std::size_t k = 0;
    for (std::size_t j = 1; j < planes.size(); ++j)
      if (std::abs(planes[j] - z) < std::abs(planes[k] - z)) k = j;
    Loop flat;
    for (const Vec3d& p : contour.points) flat.emplace_back(p.x(), p.y());
    for (Loop& l : detail::split_keyholes(flat, kKeyholeMm)) out[k].push_back({int(c) + 1, std::move(l)});
  }
  return out;
}

// Per section no drawn loop matched (match: per drawn loop, its section or
// -1): the matched drawn loop every vertex of it lies within kMatchMm of, the
// nearest by their largest distance, or -1. Such a section is a piece of that
// drawn contour the surface split off, where a neck of it is narrower than
// the working grid resolves (BODY's lobes on the shared set: necks of 0.3
// mm at a 0.94 mm grid).
std::vector<int> pieces_of_drawn(const std::vector<DrawnLoop>& drawn, const std::vector<Loop>& written,
                                 const std::vector<int>& match) {
  std::vector<int> piece_of(written.size(), -1);
  std::vector<bool> matched(written.size(), false);
  for (int j : match)
    if (j >= 0) matched[std::size_t(j)] = true;
  for (std::size_t j = 0; j < written.size(); ++j) {
    if (matched[j]) continue;
    const Box b = box_of(written[j]);
    double best = kMatchMm;
    for (std::size_t i = 0; i < drawn.size(); ++i) {
      if (match[i] < 0 || !boxes_near(b, box_of(drawn[i].points), kMatchMm)) continue;
      const double most = directed_distance(written[j], {&drawn[i].points}).second;
      if (most <= best) best = most, piece_of[j] = int(i);
    }
  }
  return piece_of;
}

// One plane: matches the drawn loops with the written sections, fills the
// records, and appends the lost drawn loops to `written` (as drawn) unless
// under `min_area`.
void account_plane(const std::vector<DrawnLoop>& drawn, std::vector<Loop>& written, const RtRoi& roi, double z,
                   const RtContourParams& params, RtWriteReport& report, std::vector<std::string>& warnings) {
  const std::size_t sections = written.size();
  std::vector<Box> section_box(sections);
  for (std::size_t j = 0; j < sections; ++j) section_box[j] = box_of(written[j]);
  std::vector<int> match(drawn.size(), -1);
  std::vector<std::pair<double, double>> to_section(drawn.size());
  for (std::size_t i = 0; i < drawn.size(); ++i) {
    const Box b = box_of(drawn[i].points);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < sections; ++j) {
      if (!boxes_near(b, section_box[j], kMatchMm)) continue;
      const auto d = directed_distance(drawn[i].points, {&written[j]});
      if (d.first < best) best = d.first, match[i] = int(j), to_section[i] = d;
    }
    if (best > kMatchMm) match[i] = -1;
  }
  const std::vector<int> piece_of = pieces_of_drawn(drawn, written, match);
  for (std::size_t i = 0; i < drawn.size(); ++i) {  // a split contour: its distance to all its sections
    if (match[i] < 0) continue;
    std::vector<const Loop*> parts{&written[std::size_t(match[i])]};
    for (std::size_t j = 0; j < sections; ++j)
      if (piece_of[j] == int(i)) parts.push_back(&written[j]);
    if (parts.size() > 1) to_section[i] = directed_distance(drawn[i].points, parts);
  }
  // Per section: the drawn loops matched to it, their area, and how far its
  // own vertices lie from them.
  std::vector<std::vector<const Loop*>> matched(sections);
  std::vector<double> drawn_area(sections, 0.0);
  for (std::size_t i = 0; i < drawn.size(); ++i)
    if (match[i] >= 0) {
      matched[std::size_t(match[i])].push_back(&drawn[i].points);
      drawn_area[std::size_t(match[i])] += std::abs(loop_area(drawn[i].points));
    }
  std::vector<std::pair<double, double>> from_section(sections);
  for (std::size_t j = 0; j < sections; ++j)
    if (!matched[j].empty()) from_section[j] = directed_distance(written[j], matched[j]);
  std::vector<double> piece_area(sections, 0.0);  // per matched section: the area of its drawn loops' pieces
  for (std::size_t j = 0; j < sections; ++j)
    if (piece_of[j] >= 0) piece_area[std::size_t(match[std::size_t(piece_of[j])])] += std::abs(loop_area(written[j]));

  for (std::size_t i = 0; i < drawn.size(); ++i) {
    ContourRecord rec;
    rec.roi = roi.name;
    rec.roi_number = roi.number;
    rec.z = z;
    rec.contour = drawn[i].contour;
    rec.area_drawn = std::abs(loop_area(drawn[i].points));
    rec.points_drawn = int(drawn[i].points.size());
    if (match[i] >= 0) {
      const auto j = std::size_t(match[i]);
      rec.section = int(j) + 1;
      rec.area_section = std::abs(loop_area(written[j])) + piece_area[j];
      rec.points_written = int(written[j].size());
      rec.mean_distance = 0.5 * (to_section[i].first + from_section[j].first);
      rec.max_distance = std::max(to_section[i].second, from_section[j].second);
      rec.merged = matched[j].size() > 1;
      rec.split = std::count(piece_of.begin(), piece_of.end(), int(i)) > 0;
      rec.shrunk = rec.area_section < (1 - kShrinkShare) * drawn_area[j];
      rec.written = "section";
    } else {
      rec.lost = true;
      std::ostringstream name;
      name << "ROI '" << roi.name << "' contour " << rec.contour << " at z = " << z << " mm (" << rec.area_drawn
           << " mm^2)";
      if (rec.area_drawn < params.min_area) {
        rec.written = "dropped";
        warnings.push_back(name.str() + ": not on the surface and under " + option_name("--rt-min-area") + " " +
                           std::to_string(params.min_area) + " mm^2: dropped");
      } else {
        rec.written = "drawn";
        written.push_back(drawn[i].points);
        rec.section = int(written.size());
        rec.area_section = rec.area_drawn;
        rec.points_written = rec.points_drawn;
      }
    }
    report.contours.push_back(std::move(rec));
  }
  for (std::size_t j = 0; j < sections; ++j) {
    if (!matched[j].empty()) continue;
    ContourRecord rec;
    rec.roi = roi.name;
    rec.roi_number = roi.number;
    rec.z = z;
    rec.section = int(j) + 1;
    rec.area_section = std::abs(loop_area(written[j]));
    rec.points_written = int(written[j].size());
    if (piece_of[j] >= 0) {  // a piece of a drawn contour the surface split off
      const DrawnLoop& d = drawn[std::size_t(piece_of[j])];
      rec.contour = d.contour;
      rec.split = true;
      std::tie(rec.mean_distance, rec.max_distance) = directed_distance(written[j], {&d.points});
    } else {
      rec.undrawn = true;
    }
    rec.written = "section";
    report.contours.push_back(std::move(rec));
  }
}

// Running sums of one ROI's resampling deviation and written steps.
struct WrittenStats {
  double deviation_sum = 0, length_sum = 0;
  long deviation_n = 0;
};

// The mesh's sections at working z, in patient x, y mm (an axial frame),
// resampled at `spacing`; their deviation from the exact cut into sum and stats.
std::vector<Loop> resampled_sections(const TriMesh& mesh, const PatientFrame& f, double z, double spacing,
                                     RoiContourSummary& sum, WrittenStats& stats) {
  std::vector<Loop> out;
  for (const Loop& loop : cut_mesh(mesh, z)) {
    Loop mm;
    for (const Vec2d& p : loop) {
      const Vec3d q = f.to_patient(Vec3d(p.x(), p.y(), z));
      mm.emplace_back(q.x(), q.y());
    }
    ResampledLoop rs = resample_loop(mm, spacing);
    sum.resample_max_deviation = std::max(sum.resample_max_deviation, rs.max_deviation);
    stats.deviation_sum += rs.mean_deviation * double(mm.size());
    stats.deviation_n += long(mm.size());
    out.push_back(std::move(rs.points));
  }
  return out;
}

// The loops written on plane `z` (counted into sum and stats), the plane
// appended to `out` unless it has none.
void add_plane(RtRoiContours& out, double z, std::vector<Loop>& loops, RoiContourSummary& sum, WrittenStats& stats) {
  RtRoiContours::Plane plane;
  plane.z = z;
  for (Loop& l : loops) {
    sum.points_out += long(l.size());
    ++sum.contours_out;
    for (std::size_t i = 0; i < l.size(); ++i) stats.length_sum += (l[(i + 1) % l.size()] - l[i]).norm();
    plane.loops.push_back(std::move(l));
  }
  if (!plane.loops.empty()) out.planes.push_back(std::move(plane));
}

void finish_summary(RoiContourSummary& sum, const WrittenStats& stats) {
  sum.resample_mean_deviation = stats.deviation_n ? stats.deviation_sum / double(stats.deviation_n) : 0.0;
  sum.point_spacing = sum.points_out ? stats.length_sum / double(sum.points_out) : 0.0;
}

// The target's certificate: the drawn contours of kKeptDrawnMm2 or more the
// surface shrank (from `first`, one ROI's records), counted and named in a
// warning with the grid, which is what a finer --voxel-size changes.
void certify_kept(const RtWriteReport& report, std::size_t first, const std::string& roi, RoiContourSummary& sum,
                  std::vector<std::string>& warnings) {
  std::ostringstream where;
  for (std::size_t i = first; i < report.contours.size(); ++i) {
    const ContourRecord& c = report.contours[i];
    if (!c.shrunk || c.area_drawn < kKeptDrawnMm2) continue;
    where << (sum.shrunk_over_1mm2++ ? "; " : "") << "contour " << c.contour << " at z = " << c.z << " mm ("
          << c.area_drawn << " -> " << c.area_section << " mm^2)";
  }
  if (sum.shrunk_over_1mm2 == 0) return;
  std::ostringstream o;
  o << "ROI '" << roi << "': " << sum.shrunk_over_1mm2 << " drawn contour(s) of " << kKeptDrawnMm2
    << " mm^2 or more keep less than " << 100 * (1 - kShrinkShare) << " % of their area at its " << sum.voxel_size
    << " mm working grid (" << where.str() << "); a smaller " << option_name("--voxel-size") << " keeps them";
  warnings.push_back(o.str());
}

std::string csv_cell(const std::string& s) {
  // Quoted when it holds a separator or quote, and a leading = + - @ (a
  // spreadsheet formula) neutralised by a leading apostrophe.
  std::string t = !s.empty() && std::string("=+-@\t\r").find(s.front()) != std::string::npos ? "'" + s : s;
  if (t.find_first_of(",\"\n\r") == std::string::npos) return t;
  std::string q = "\"";
  for (char c : t) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// ---------------------------------------------------------------- from a volume

// A voxel axis whose direction's z component is within this of +-1 runs
// along the patient z axis (NIfTI's float32 affines: 1e-7 rounding).
constexpr double kAxisAlignedCosine = 1e-6;

// Why a volume's slices cannot be written as RT contours, or "" if they can:
// the contours of one plane must share one patient z (RT Structure Sets are
// drawn on axial planes), so the slices' in-plane axes may rise across the
// slice by at most kPlanarToleranceMm (io/rtstruct.h).
std::string not_axial(const Inputs& in) {
  const SliceStack& st = in.first();
  if (!st.patient) return "it has no patient geometry";
  const PatientFrame& f = *st.patient;
  const double rise = std::abs(f.axes(2, 0)) * st.width + std::abs(f.axes(2, 1)) * st.height;
  if (rise <= kPlanarToleranceMm) return "";
  const Vec3d n = f.axes.col(2).normalized();
  std::ostringstream o;
  o << std::setprecision(4) << "its slices are not axial (perpendicular to the patient z axis): their normal is ("
    << n.x() << ", " << n.y() << ", " << n.z() << ") in LPS, and a slice's points differ in z by up to " << rise
    << " mm; RT Structure Set contours lie on axial planes";
  if (in.volume && in.slicing)
    for (int a = 0; a < 3; ++a)  // a voxel axis along patient z: slicing along it would do
      if (a != in.slicing->axis && std::abs(std::abs(in.volume->direction(2, a)) - 1.0) <= kAxisAlignedCosine)
        return o.str() + " (its voxel axis " + "ijk"[a] + " is: " + option_given("--axis", std::string(1, "ijk"[a])) + ")";
  return o.str() + " (an oblique volume: resample it to axial slices first)";
}

// A volume's objects as RT contours on its slices' planes, in a standalone set.
RtWriteReport write_volume_rtstruct(const std::string& path, const Inputs& in, const RunResult& r,
                                    const RtContourParams& params) {
  if (const std::string why = not_axial(in); !why.empty()) throw InputError(in.files.front(), why);
  const SliceStack& st = in.first();
  const PatientFrame& f = *st.patient;
  // Without drawn contours the step is a pixel of the label map: the finest
  // detail its outlines hold.
  const double pixel_mm = std::min(f.axes.col(0).norm(), f.axes.col(1).norm());
  const double spacing = params.point_spacing > 0 ? params.point_spacing : pixel_mm;
  RtWriteReport report;
  std::vector<RtRoi> identities;
  identities.reserve(r.objects.size());  // RtRoiContours point into it
  std::vector<RtRoiContours> rois;
  for (const RunObject& o : r.objects) {
    const std::uint32_t number = object_cell_label(o);
    if (number > std::uint32_t(std::numeric_limits<std::int32_t>::max()))
      throw InputError(in.files.front(), "label " + std::to_string(number) +
                                             " is beyond the largest ROI number a DICOM IS holds (2^31 - 1)");
    identities.push_back(RtRoi{int(number), object_display_name(in, o), o.colour, {}});
    RtRoiContours out{&identities.back(), {}};
    RoiContourSummary sum;
    sum.roi = out.roi->name;
    sum.roi_number = out.roi->number;
    WrittenStats stats;
    for (const Slice& s : st.slices) {
      std::vector<Loop> here = resampled_sections(o.object.mesh, f, s.z, spacing, sum, stats);
      // The plane's patient z (the same across it: not_axial).
      add_plane(out, f.to_patient(Vec3d(0.5 * st.width, 0.5 * st.height, s.z)).z(), here, sum, stats);
    }
    finish_summary(sum, stats);
    report.rois.push_back(sum);
    rois.push_back(std::move(out));
  }
  write_rtstruct_new(path, rois, "isoloft");
  return report;
}

// A ROI read as sections (contours off the axial planes, io/rtstruct_sections.h;
// its mesh in patient mm): the mesh cut by each input plane in that plane's
// frame (a rotation: loops keep their turn), resampled at the step drawn
// there, written on the plane's pose. The per-contour accounting matches
// loops on axial planes and is not made here; max_distance is the largest
// distance between a plane's drawn contours and the mesh's section on it.
RtRoiContours section_contours(const Job& job, const TriMesh& mesh, const RtContourParams& params,
                               RoiContourSummary& sum) {
  RtRoiContours out;
  out.roi = job.roi;
  WrittenStats stats;
  for (const Section& sec : job.sections) {
    TriMesh local = mesh;
    for (Vec3f& v : local.vertices) {
      const Vec3d w = v.cast<double>();
      const Vec2d q = sec.pose.to_plane(w);
      v = Vec3f(float(q.x()), float(q.y()), float(sec.pose.height(w)));
    }
    std::vector<Loop> drawn;
    for (const SectionContour& c : sec.contours) drawn.push_back(c.points);
    const double spacing = params.point_spacing > 0 ? params.point_spacing : mean_point_spacing(drawn);
    std::vector<Loop> here = resampled_sections(local, PatientFrame{}, 0.0, spacing, sum, stats);
    const std::size_t before = out.planes.size();
    add_plane(out, 0.0, here, sum, stats);
    if (out.planes.size() > before) out.planes.back().pose = sec.pose;
    sum.max_distance = std::max(sum.max_distance, detail::plane_section_distance(mesh, sec.pose, drawn).max());
  }
  finish_summary(sum, stats);
  return out;
}

}  // namespace

RtWriteReport write_run_rtstruct(const std::string& path, const Inputs& in, RunResult& r,
                                 const RtContourParams& params) {
  if (in.format == InputFormat::Volume) return write_volume_rtstruct(path, in, r, params);
  if (in.format != InputFormat::RtStruct || !in.rtstruct) throw ParamError(path + kNeedsRtInput);
  RtWriteReport report;
  std::vector<RtRoiContours> rois;
  for (const RunObject& o : r.objects) {
    const Job& job = in.jobs[o.job];
    if (!job.sections.empty()) {
      RoiContourSummary sum;
      sum.roi = job.roi->name;
      sum.roi_number = job.roi->number;
      for (const RtContour& c : job.roi->contours)
        if (c.type == "CLOSED_PLANAR") ++sum.contours_in, sum.points_in += long(c.points.size());
      rois.push_back(section_contours(job, o.object.mesh, params, sum));  // working = patient mm (roi_section_job)
      report.rois.push_back(sum);
      continue;
    }
    const PatientFrame& f = *job.stack.patient;
    const RtRoi& roi = *job.roi;
    RtRoiContours out;
    out.roi = job.roi;
    const std::vector<double> planes = rt_planes(job.stack);  // the input's contour planes
    const auto drawn = drawn_by_plane(roi, planes);
    std::vector<Loop> all_drawn;
    for (const auto& plane : drawn)
      for (const auto& d : plane) all_drawn.push_back(d.points);
    const double roi_spacing = mean_point_spacing(all_drawn);
    RoiContourSummary sum;
    sum.roi = roi.name;
    sum.roi_number = roi.number;
    for (const RtContour& c : roi.contours)
      if (c.type == "CLOSED_PLANAR") ++sum.contours_in, sum.points_in += long(c.points.size());
    WrittenStats stats;
    const std::size_t first_record = report.contours.size();
    for (std::size_t k = 0; k < planes.size(); ++k) {
      const double z_mm = planes[k];
      const double z = (z_mm - f.origin.z()) / f.axes(2, 2);  // working px (roi_stack: axis-aligned frame)
      std::vector<Loop> drawn_loops;
      for (const auto& d : drawn[k]) drawn_loops.push_back(d.points);
      const double spacing = params.point_spacing > 0 ? params.point_spacing
                             : !drawn_loops.empty()   ? mean_point_spacing(drawn_loops)
                                                      : roi_spacing;
      std::vector<Loop> here = resampled_sections(o.object.mesh, f, z, spacing, sum, stats);
      account_plane(drawn[k], here, roi, z_mm, params, report, r.warnings);
      add_plane(out, z_mm, here, sum, stats);
    }
    finish_summary(sum, stats);
    double weighted = 0;
    long weight = 0;
    for (std::size_t i = first_record; i < report.contours.size(); ++i) {
      const ContourRecord& c = report.contours[i];
      sum.lost += c.lost, sum.merged += c.merged, sum.shrunk += c.shrunk, sum.undrawn += c.undrawn;
      sum.undrawn_over_1mm2 += c.undrawn && c.area_section > kUndrawnToleratedMm2;
      sum.dropped += c.written == "dropped";
      sum.split += c.split && c.points_drawn > 0;
      if (c.contour > 0 && !c.lost) {
        weighted += c.mean_distance * c.points_drawn, weight += c.points_drawn;
        sum.max_distance = std::max(sum.max_distance, c.max_distance);
      }
    }
    sum.mean_distance = weight ? weighted / double(weight) : 0.0;
    sum.voxel_size = f.axes.col(0).norm();
    sum.refined = job.refined;
    certify_kept(report, first_record, roi.name, sum, r.warnings);
    report.rois.push_back(sum);
    rois.push_back(std::move(out));
  }
  write_rtstruct(path, in.files.front(), rois, "isoloft", &in.rtstruct->bytes);  // the input as read, not read again
  return report;
}

std::string contour_report_csv(const RtWriteReport& report) {
  std::ostringstream o;
  o << "roi,roi_number,z_mm,contour,section,area_drawn_mm2,area_section_mm2,mean_distance_mm,max_distance_mm,"
       "points_drawn,points_written,lost,merged,shrunk,undrawn,written,split\n"
    << std::setprecision(8);
  auto b = [](bool v) { return v ? "true" : "false"; };
  for (const ContourRecord& c : report.contours)
    o << csv_cell(c.roi) << "," << c.roi_number << "," << c.z << "," << c.contour << "," << c.section << ","
      << c.area_drawn << "," << c.area_section << "," << c.mean_distance << "," << c.max_distance << ","
      << c.points_drawn << "," << c.points_written << "," << b(c.lost) << "," << b(c.merged) << "," << b(c.shrunk)
      << "," << b(c.undrawn) << "," << c.written << "," << b(c.split) << "\n";
  return o.str();
}

nlohmann::json contour_report_json(const RtWriteReport& report) {
  nlohmann::json rois = nlohmann::json::array(), contours = nlohmann::json::array();
  for (const RoiContourSummary& s : report.rois) {
    rois.push_back({{"roi", s.roi},
                    {"roi_number", s.roi_number},
                    {"contours_in", s.contours_in},
                    {"contours_out", s.contours_out},
                    {"points_in", s.points_in},
                    {"points_out", s.points_out},
                    {"point_spacing_mm", s.point_spacing},
                    {"lost", s.lost},
                    {"merged", s.merged},
                    {"shrunk", s.shrunk},
                    {"undrawn", s.undrawn},
                    {"undrawn_over_1mm2", s.undrawn_over_1mm2},
                    {"split", s.split},
                    {"dropped", s.dropped},
                    {"mean_distance_mm", s.mean_distance},
                    {"max_distance_mm", s.max_distance},
                    {"resample_max_deviation_mm", s.resample_max_deviation},
                    {"resample_mean_deviation_mm", s.resample_mean_deviation},
                    {"shrunk_over_1mm2", s.shrunk_over_1mm2},
                    {"voxel_size_mm", s.voxel_size}});
    if (s.refined)
      rois.back()["grid_refined"] = {{"from_mm", s.refined->from_mm},
                                     {"to_mm", s.refined->to_mm},
                                     {"why", s.refined->why},
                                     {"limited", s.refined->limited}};
  }
  for (const ContourRecord& c : report.contours)
    contours.push_back({{"roi", c.roi},
                        {"roi_number", c.roi_number},
                        {"z_mm", c.z},
                        {"contour", c.contour},
                        {"section", c.section},
                        {"area_drawn_mm2", c.area_drawn},
                        {"area_section_mm2", c.area_section},
                        {"mean_distance_mm", c.mean_distance},
                        {"max_distance_mm", c.max_distance},
                        {"points_drawn", c.points_drawn},
                        {"points_written", c.points_written},
                        {"lost", c.lost},
                        {"merged", c.merged},
                        {"shrunk", c.shrunk},
                        {"undrawn", c.undrawn},
                        {"written", c.written},
                        {"split", c.split}});
  return {{"shrink_tolerance", kShrinkShare}, {"match_mm", kMatchMm}, {"rois", rois}, {"contours", contours}};
}

RtStructOutput::RtStructOutput(std::string path, std::string option, RtContourParams params, std::string contours_csv)
    : path_(std::move(path)), option_(std::move(option)), params_(params), contours_csv_(std::move(contours_csv)) {
  if (fs::path(path_).extension() != ".dcm")
    throw ParamError(option_name(option_) + ": '" + path_ + "' must end in .dcm");
  if (!contours_csv_.empty() && fs::path(contours_csv_).extension() != ".csv")
    throw ParamError(option_name("--rt-contours") + ": '" + contours_csv_ + "' must end in .csv");
  if (!(params_.point_spacing >= 0) || !std::isfinite(params_.point_spacing))
    throw ParamError(option_name("--rt-point-spacing") + ": must be a finite number >= 0 (0 = as drawn), got " +
                     std::to_string(params_.point_spacing));
  if (!(params_.min_area >= 0) || !std::isfinite(params_.min_area))
    throw ParamError(option_name("--rt-min-area") + ": must be a finite number >= 0, got " +
                     std::to_string(params_.min_area));
}

void RtStructOutput::check_format(InputFormat format) const {
  if (format != InputFormat::RtStruct && format != InputFormat::Volume)
    throw ParamError(option_name(option_) + " " + path_ + kNeedsRtInput);
}

void RtStructOutput::check(const Inputs& in, const ReconstructParams&) const {
  if (in.format != InputFormat::Volume) return;
  if (const std::string why = not_axial(in); !why.empty())
    throw InputError(in.files.front(), option_name(option_) + " " + path_ + ": " + why);
}

void RtStructOutput::finish(const RunContext& ctx, RunResult& r) {
  written_ = write_run_rtstruct(ctx.files.stage(path_), ctx.in, r, params_);
  if (!contours_csv_.empty()) write_text_atomic(ctx.files.stage(contours_csv_), contour_report_csv(written_));
}

void RtStructOutput::report(nlohmann::json& report) const {
  report["rtstruct"] = path_;
  report["rtstruct_contours"] = contour_report_json(written_);
  if (!contours_csv_.empty()) report["rtstruct_contours_file"] = contours_csv_;
}

std::vector<PlannedFile> RtStructOutput::planned_files(const Inputs&, const std::vector<PlannedObject>&) const {
  std::vector<PlannedFile> f{{path_, option()}};
  if (!contours_csv_.empty()) f.push_back({contours_csv_, "--rt-contours"});
  return f;
}

std::vector<std::string> RtStructOutput::files() const {
  std::vector<std::string> f{path_};
  if (!contours_csv_.empty()) f.push_back(contours_csv_);
  return f;
}

}  // namespace isoloft
