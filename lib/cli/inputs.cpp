#include "cli/inputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <ostream>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/params.h"
#include "isoloft/io/polylines.h"
#include "isoloft/io/slice_images.h"

namespace fs = std::filesystem;

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

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

// A flag given with an input that cannot use it: an error naming both.
void reject(const CLI::Option* opt, bool given, const std::string& flag, const std::string& why) {
  if ((opt && opt->count() > 0) || given) throw ParamError(flag + ": " + why);
}

Inputs read_images(const ReconstructArgs& a) {
  Inputs in;
  SliceStack st = open_slice_images(list_slice_files(a.inputs));  // decoded slice by slice as the pipeline goes
  if (!a.input_kind.empty()) st.kind = enum_from_string<InputKind>(a.input_kind, "--input");
  if (a.slice_z_opt->count()) {
    if (a.z_spacing_opt->count()) throw ParamError("give either --z-spacing or --slice-z, not both");
    const auto z = parse_numbers(a.slice_z, "--slice-z");
    if (z.size() != st.slices.size())
      throw ParamError("--slice-z has " + std::to_string(z.size()) + " values for " + std::to_string(st.slices.size()) +
                       " slices");
    for (std::size_t k = 0; k < z.size(); ++k) st.slices[k].z = z[k];
  } else {
    for (std::size_t k = 0; k < st.slices.size(); ++k) st.slices[k].z = double(k) * a.z_spacing;
  }
  if (a.pixel_size_opt->count()) st.pixel_size = a.pixel_size;
  in.jobs.push_back({std::move(st), "", std::nullopt});
  return in;
}

Inputs read_polyline_file(const ReconstructArgs& a) {
  Inputs in;
  reject(a.z_spacing_opt, a.slice_z_opt->count() > 0, "--z-spacing/--slice-z", "a polyline file carries the z of its slices");
  reject(nullptr, !a.input_kind.empty(), "--input", "a polyline file holds polygons, not images");
  SliceStack st = read_polylines(a.inputs[0]);
  if (a.pixel_size_opt->count()) st.pixel_size = a.pixel_size;
  in.jobs.push_back({std::move(st), "", std::nullopt});
  return in;
}

Inputs read_volume_input(const ReconstructArgs& a) {
  Inputs in;
  const std::string& path = a.inputs[0];
  reject(a.z_spacing_opt, a.slice_z_opt->count() > 0, "--z-spacing/--slice-z", "a volume carries its own voxel spacing");
  reject(a.pixel_size_opt, false, "--pixel-size", "a volume carries its own voxel size");
  in.volume = std::make_unique<Volume>(read_volume(path));
  for (auto& w : in.volume->warnings) in.warnings.push_back(w);
  detail::check_finite_voxels(*in.volume, path);
  VolumeSlicing slicing;
  if (!a.axis.empty()) slicing.axis = a.axis == "i" ? 0 : a.axis == "j" ? 1 : 2;
  if (!a.input_kind.empty()) {
    slicing.kind = enum_from_string<InputKind>(a.input_kind, "--input");
    if (slicing.kind == InputKind::Contours)
      throw ParamError("--input contours: a volume holds labels or masks (--input labels|masks)");
  } else {
    slicing.kind = InputKind::Labels;
    if (!in.volume->integer) {
      const bool whole = std::all_of(in.volume->data.begin(), in.volume->data.end(), [](float v) { return v == std::floor(v); });
      if (!whole)
        throw InputError(path, "a float volume with non-integer values is not a label map: give --input masks to take "
                               "every non-zero voxel as inside");
    }
  }
  in.slicing = std::make_unique<VolumeStack>(volume_stack(*in.volume, slicing, path));
  for (auto& w : in.slicing->warnings) in.warnings.push_back(w);
  in.jobs.push_back({std::move(in.slicing->stack), "", std::nullopt});  // the slicing keeps its kind, axis and indices
  return in;
}

Inputs read_rtstruct_input(const ReconstructArgs& a) {
  Inputs in;
  const std::string& path = a.inputs[0];
  reject(a.z_spacing_opt, a.slice_z_opt->count() > 0, "--z-spacing/--slice-z", "an RT Structure Set carries its contour planes");
  reject(a.pixel_size_opt, !a.input_kind.empty(), "--pixel-size/--input",
         "an RT Structure Set holds polygons in mm (give --voxel-size for the working grid)");
  const RtStructureSet set = read_rtstruct(path);
  RoiGrid grid;
  if (a.voxel_size_opt->count()) grid.voxel_size = a.voxel_size;
  std::vector<const RtRoi*> chosen;
  if (!a.rois.empty()) {
    for (const std::string& name : a.rois) {
      const RtRoi* roi = set.find(name);
      if (!roi) {
        std::string names;
        for (const auto& r : set.rois) names += (names.empty() ? "" : ", ") + ("'" + r.name + "'");
        throw InputError(path, "no ROI named '" + name + "' (ROIs: " + names + ")");
      }
      chosen.push_back(roi);
    }
  } else {
    for (const auto& r : set.rois) {
      if (r.closed_contours() == 0) {
        in.warnings.push_back(path + ": ROI '" + r.name + "' has no closed planar contour: skipped");
        continue;
      }
      chosen.push_back(&r);
    }
    if (chosen.empty()) throw InputError(path, "no ROI has closed planar contours");
  }
  for (const RtRoi* roi : chosen) {
    std::vector<std::string> warnings;
    try {
      in.jobs.push_back({roi_stack(*roi, grid, path, warnings), roi->name, roi->color});
    } catch (const InputError& e) {
      if (!a.rois.empty()) throw;  // asked for by name: its problem is the run's
      in.warnings.push_back(std::string(e.what()) + ": skipped");
    }
    for (auto& w : warnings) in.warnings.push_back(std::move(w));
  }
  if (in.jobs.empty()) throw InputError(path, "no ROI could be reconstructed");
  return in;
}

}  // namespace

InputFormat detect_input(const std::vector<std::string>& inputs) {
  if (inputs.size() != 1 || fs::is_directory(inputs[0])) return InputFormat::Images;
  const std::string& p = inputs[0];
  const std::string ext = lower_extension(p);
  if (ext == ".txt" || ext == ".poly" || ext == ".polylines") return InputFormat::Polylines;
  if (is_volume_path(p)) return InputFormat::Volume;
  if (ext == ".dcm" || is_dicom_file(p)) return InputFormat::RtStruct;
  return InputFormat::Images;
}

Inputs read_inputs(const ReconstructArgs& a) {
  const InputFormat format = detect_input(a.inputs);
  if (format != InputFormat::Volume) {
    reject(nullptr, !a.axis.empty(), "--axis", "only with a volume input (NIfTI, NRRD, MetaImage)");
    reject(nullptr, !a.labelmap.empty(), "--labelmap", "only with a volume input (NIfTI, NRRD, MetaImage)");
  }
  if (format != InputFormat::RtStruct) {
    reject(a.voxel_size_opt, !a.rois.empty(), "--roi/--voxel-size", "only with a DICOM RT Structure Set input");
  }
  if ((format == InputFormat::Images || format == InputFormat::Polylines) && !a.space.empty())
    throw ParamError("--space: the input has no patient space (only volumes and RT Structure Sets do)");
  Inputs in;
  switch (format) {
    case InputFormat::Images: in = read_images(a); break;
    case InputFormat::Polylines: in = read_polyline_file(a); break;
    case InputFormat::Volume: in = read_volume_input(a); break;
    case InputFormat::RtStruct: in = read_rtstruct_input(a); break;
  }
  in.format = format;
  return in;
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
    out << std::left << std::setw(24) << ("'" + r.name + "'") << std::right << std::setw(7) << r.number << std::setw(10)
        << r.contours.size() << std::setw(24) << range.str() << "  " << kinds.str() << "\n";
  }
}

std::string file_safe(const std::string& name) {
  std::string s;
  for (unsigned char c : name) s += std::isalnum(c) || c == '-' || c == '_' ? char(c) : '_';
  return s.empty() ? "roi" : s;
}

}  // namespace isoloft::cli
