#include "isoloft/run/volume_table.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/mesh/plane_cut.h"
#include "isoloft/run.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

// Area of polygons combined by the even-odd rule (a loop inside an odd
// number of others is a hole), px^2.
double even_odd_area(const std::vector<Polygon>& polys) {
  auto area = [](const std::vector<Vec2d>& p) {
    double a = 0;
    for (std::size_t i = 0, j = p.size() - 1; i < p.size(); j = i++) a += p[j].x() * p[i].y() - p[i].x() * p[j].y();
    return 0.5 * std::abs(a);
  };
  auto inside = [](const std::vector<Vec2d>& p, const Vec2d& q) {
    bool in = false;
    for (std::size_t i = 0, j = p.size() - 1; i < p.size(); j = i++)
      if ((p[i].y() > q.y()) != (p[j].y() > q.y()) &&
          q.x() < p[j].x() + (q.y() - p[j].y()) * (p[i].x() - p[j].x()) / (p[i].y() - p[j].y()))
        in = !in;
    return in;
  };
  double total = 0;
  for (std::size_t a = 0; a < polys.size(); ++a) {
    int depth = 0;
    for (std::size_t b = 0; b < polys.size(); ++b)
      if (b != a && !polys[a].points.empty() && inside(polys[b].points, polys[a].points.front())) ++depth;
    total += (depth % 2 ? -1.0 : 1.0) * area(polys[a].points);
  }
  return total;
}

// The stack's typical step between slices (median), px.
double typical_step(const SliceStack& st) {
  std::vector<double> steps;
  for (std::size_t k = 1; k < st.slices.size(); ++k) steps.push_back(st.slices[k].z - st.slices[k - 1].z);
  if (steps.empty()) return 0;
  std::nth_element(steps.begin(), steps.begin() + std::ptrdiff_t(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

// The object's contour planes: the RT set's own for an RT Structure Set.
int contour_planes(const Inputs& in, const Job& job, const ObjectResult& ob) {
  return in.format == InputFormat::RtStruct && job.sections.empty() ? int(rt_planes(job.stack).size())
                                                                    : ob.slices_with_contours;
}

}  // namespace

std::vector<double> clipped_volumes(const Inputs& in, const Job& job, const ObjectResult& ob) {
  const SliceStack& st = job.stack;
  if (!st.has_polygons()) return {};
  // The end caps: beyond the first and last slices with contours (working
  // px); known for polygon stacks (an image stack's object may leave its
  // end slices blank, and a label's slices are not kept).
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Slice& sl : st.slices)
    if (!sl.polygons.empty()) lo = std::min(lo, sl.z), hi = std::max(hi, sl.z);
  const bool capped = hi >= lo;
  if (capped && in.format == InputFormat::RtStruct && contour_planes(in, job, ob) == 1)
    lo = hi = 0.5 * (lo + hi);  // one plane: two slices round it
  // The whole volume, above the last slice, above the first: one pass.
  return volumes_above(ob.mesh, {-std::numeric_limits<double>::infinity(), capped ? hi : 0.0, capped ? lo : 0.0});
}

std::vector<VolumeRow> volume_table(const Inputs& in, const RunResult& r) {
  std::vector<VolumeRow> rows(r.objects.size());
  // Objects side by side (each row on its own: the serial rows).
  tbb::parallel_for(std::size_t(0), r.objects.size(), [&](std::size_t index) {
    const RunObject& o = r.objects[index];
    VolumeRow& row = rows[index];
    const Job& job = in.jobs[o.job];
    const SliceStack& st = job.stack;
    const double s = st.pixel_size;
    row.name = object_display_name(in, o);
    row.number = job.roi ? job.roi->number : int(o.object.label);
    row.volume = o.object.check.volume * s * s * s;
    row.area = o.object.check.area * s * s;
    row.planes = contour_planes(in, job, o.object);
    row.closed = o.object.check.closed && o.object.check.manifold && o.object.check.oriented;
    if (st.has_polygons()) {
      double area = 0;
      for (const Slice& sl : st.slices) area += even_odd_area(sl.polygons);
      row.slab = area * typical_step(st) * s * s * s;
    }
    row.cap_share = std::numeric_limits<double>::quiet_NaN();
    if (st.has_polygons()) {
      // Computed beside the object's mesh check (run_jobs), else here.
      const std::vector<double> above =
          o.object.clipped_volumes.empty() ? clipped_volumes(in, job, o.object) : o.object.clipped_volumes;
      const bool capped = std::any_of(st.slices.begin(), st.slices.end(), [](const Slice& sl) { return !sl.polygons.empty(); });
      const double whole = above[0];
      if (capped && whole > 0) row.cap_share = std::clamp((above[1] + whole - above[2]) / whole, 0.0, 1.0);
    }
    row.spacing = row.planes > 1 ? typical_step(st) * s : 0.0;
    if (row.planes < kTrustedPlanes && job.sections.empty())  // crossing sections have no end caps
      row.warning = "on " + std::to_string(row.planes) + " plane" + (row.planes == 1 ? "" : "s") +
                    ": its volume is mostly end caps" +
                    (std::isnan(row.cap_share) ? std::string()
                                               : " (" + std::to_string(int(std::lround(100 * row.cap_share))) + " %)") +
                    ", where no contour bounds it";
  });
  return rows;
}

std::string volume_table_text(const std::vector<VolumeRow>& rows, bool patient_mm) {
  std::ostringstream o;
  const double v = patient_mm ? 1000.0 : 1.0, a = patient_mm ? 100.0 : 1.0;
  o << std::left << std::setw(24) << "ROI" << std::right << std::setw(7) << "number" << std::setw(14)
    << (patient_mm ? "volume (cc)" : "volume") << std::setw(12) << (patient_mm ? "slab (cc)" : "slab") << std::setw(16)
    << (patient_mm ? "area (cm^2)" : "area") << std::setw(8) << "planes" << std::setw(14)
    << (patient_mm ? "spacing (mm)" : "spacing") << std::setw(8) << "caps" << std::setw(8) << "closed" << "\n";
  for (const VolumeRow& r : rows) {
    o << std::left << std::setw(24) << ("'" + terminal_text(r.name) + "'") << std::right << std::setw(7) << r.number << std::fixed
      << std::setprecision(3) << std::setw(14) << r.volume / v << std::setw(12);
    if (r.slab > 0) o << r.slab / v;
    else o << "-";
    o << std::setw(16) << std::setprecision(2) << r.area / a << std::setw(8) << r.planes << std::setw(14);
    if (r.spacing > 0) o << r.spacing;
    else o << "-";
    o << std::setw(8);
    if (std::isnan(r.cap_share)) o << "-";
    else o << std::to_string(int(std::lround(100 * r.cap_share))) + " %";
    o << std::setw(8) << (r.closed ? "yes" : "NO") << "\n";
  }
  for (const VolumeRow& r : rows)
    if (!r.warning.empty()) o << "warning: '" << r.name << "' " << r.warning << "\n";
  return o.str();
}

std::string volume_table_csv(const std::vector<VolumeRow>& rows) {
  std::ostringstream o;
  o << "name,number,volume_mm3,slab_volume_mm3,area_mm2,planes,closed,spacing,cap_share,warning\n"
    << std::setprecision(10);
  for (const VolumeRow& r : rows) {
    o << csv_cell(r.name) << "," << r.number << "," << r.volume << "," << r.slab << "," << r.area << "," << r.planes << ","
      << (r.closed ? "true" : "false") << "," << r.spacing << ",";
    if (!std::isnan(r.cap_share)) o << r.cap_share;
    o << "," << csv_cell(r.warning) << "\n";
  }
  return o.str();
}

nlohmann::json volume_table_json(const std::vector<VolumeRow>& rows) {
  nlohmann::json a = nlohmann::json::array();
  for (const VolumeRow& r : rows)
    a.push_back({{"name", r.name}, {"number", r.number}, {"volume_mm3", r.volume}, {"slab_volume_mm3", r.slab},
                 {"area_mm2", r.area}, {"planes", r.planes}, {"closed", r.closed}, {"spacing", r.spacing},
                 {"cap_share", std::isnan(r.cap_share) ? nlohmann::json(nullptr) : nlohmann::json(r.cap_share)},
                 {"warning", r.warning}});
  return a;
}

VolumeTableOutput::VolumeTableOutput(std::string path) : path_(std::move(path)) {
  const std::string ext = fs::path(path_).extension().string();
  if (ext != ".csv" && ext != ".json")
    throw ParamError(option_name("--volumes") + ": '" + path_ + "' must end in .csv or .json");
}

void VolumeTableOutput::finish(const RunContext& ctx, RunResult& r) {
  const std::vector<VolumeRow> rows = volume_table(ctx.in, r);
  write_text_atomic(ctx.files.stage(path_), fs::path(path_).extension() == ".csv"
                                                ? volume_table_csv(rows)
                                                : volume_table_json(rows).dump(2) + "\n");
}

void VolumeTableOutput::report(nlohmann::json& report) const { report["volumes_file"] = path_; }

}  // namespace isoloft
