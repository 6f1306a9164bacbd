#include "cli/inputs.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <ostream>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/params.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/rtstruct.h"

namespace isoloft::cli {

namespace {

std::vector<double> parse_numbers(const std::string& text, const std::string& option) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw ParamError(option + ": '" + item + "' is not a number");
    }
    if (!std::isfinite(v.back())) throw ParamError(option + ": '" + item + "' is not a finite number");
  }
  return v;
}

}  // namespace

InputRequest input_request(const ReconstructArgs& a) {
  InputRequest r;
  r.paths = a.inputs;
  r.kind = a.input_kind;
  if (a.z_spacing_opt->count()) r.z_spacing = a.z_spacing;
  if (a.slice_z_opt->count()) r.slice_z = parse_numbers(a.slice_z, "--slice-z");
  if (a.pixel_size_opt->count()) r.pixel_size = a.pixel_size;
  r.axis = a.axis;
  r.rois = a.rois;
  if (a.voxel_size_opt->count()) r.voxel_size = a.voxel_size;
  r.space = a.space;
  r.allow_external_data = a.allow_external_data;
  r.label_names = a.label_names;
  r.annotated = a.annotated;
  r.annotated_mask = a.annotated_mask;
  return r;
}

void list_rois(const std::string& path, std::ostream& out) {
  const RtStructureSet set = read_rtstruct(path);
  out << std::left << std::setw(24) << "ROI" << std::right << std::setw(7) << "number" << std::setw(10) << "contours"
      << std::setw(24) << "z range (mm)" << "  types\n";
  for (const auto& r : set.rois) {
    double lo = INFINITY, hi = -INFINITY;
    std::vector<std::string> types;
    for (const auto& c : r.contours) {
      for (const Vec3d& p : c.points) lo = std::min(lo, p.z()), hi = std::max(hi, p.z());
      if (std::find(types.begin(), types.end(), c.type) == types.end()) types.push_back(c.type);
    }
    std::ostringstream range, kinds;
    if (r.contours.empty()) range << "-";
    else range << std::fixed << std::setprecision(1) << lo << " .. " << hi;
    for (std::size_t i = 0; i < types.size(); ++i) kinds << (i ? "," : "") << types[i];
    const auto same_name = std::count_if(set.rois.begin(), set.rois.end(), [&](const RtRoi& q) { return q.name == r.name; });
    out << std::left << std::setw(24) << ("'" + terminal_text(r.name) + "'") << std::right << std::setw(7) << r.number << std::setw(10)
        << r.contours.size() << std::setw(24) << range.str() << "  " << kinds.str()
        << (r.number_shared ? "  (number shared: contours ambiguous)" : "") << (same_name > 1 ? "  (name shared)" : "")
        << "\n";
  }
}

}  // namespace isoloft::cli
