#include "isoloft/run/inputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/polylines.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/slice_images.h"
#include "isoloft/run/budget.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

// An option given with an input that cannot use it: an error naming both.
void reject(bool given, const std::string& flag, const std::string& why) {
  if (given) throw ParamError(option_name(flag) + ": " + why);
}

Inputs read_images(const InputRequest& r) {
  Inputs in;
  SliceStack st = open_slice_images(list_slice_files(r.paths));  // decoded slice by slice as the pipeline goes
  // From the headers alone, before any decoding.
  check_budget(option_name("--max-memory"),
               "decoding " + std::to_string(st.slices.size()) + " slice image(s) of " + std::to_string(st.width) + "x" +
                   std::to_string(st.height) + " px (" + st.slices.front().source + ")",
               stack_bytes(st), r.max_memory);
  if (!r.kind.empty()) st.kind = enum_from_string<InputKind>(r.kind, option_name("--input"));
  if (r.slice_z) {
    if (r.z_spacing)
      throw ParamError("give either " + option_name("--z-spacing") + " or " + option_name("--slice-z") + ", not both");
    const auto& z = *r.slice_z;
    if (z.size() != st.slices.size())
      throw ParamError(option_name("--slice-z") + " has " + std::to_string(z.size()) + " values for " +
                       std::to_string(st.slices.size()) + " slices");
    for (std::size_t k = 0; k < z.size(); ++k) st.slices[k].z = z[k];
  } else {
    const double dz = r.z_spacing.value_or(1.0);
    for (std::size_t k = 0; k < st.slices.size(); ++k) st.slices[k].z = double(k) * dz;
  }
  if (r.pixel_size) st.pixel_size = *r.pixel_size;
  in.jobs.push_back({std::move(st), "", std::nullopt});
  return in;
}

Inputs read_polyline_file(const InputRequest& r) {
  Inputs in;
  reject(r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "a polyline file carries the z of its slices");
  reject(!r.kind.empty(), "--input", "a polyline file holds polygons, not images");
  SliceStack st = read_polylines(r.paths[0]);
  if (r.pixel_size) st.pixel_size = *r.pixel_size;
  in.jobs.push_back({std::move(st), "", std::nullopt});
  return in;
}

// A volume read or given, sliced along its annotated axis; `path` names it in messages.
Inputs slice_volume(Volume volume, const std::string& path, const InputRequest& r) {
  Inputs in;
  reject(r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "a volume carries its own voxel spacing");
  reject(bool(r.pixel_size), "--pixel-size", "a volume carries its own voxel size");
  in.volume = std::make_unique<Volume>(std::move(volume));
  for (auto& w : in.volume->warnings) in.warnings.push_back(w);
  detail::check_finite_voxels(*in.volume, path);
  VolumeSlicing slicing;
  if (!r.axis.empty()) {
    if (r.axis != "i" && r.axis != "j" && r.axis != "k")
      throw ParamError(option_name("--axis") + ": unknown value '" + r.axis + "' (expected i, j or k)");
    slicing.axis = r.axis == "i" ? 0 : r.axis == "j" ? 1 : 2;
  }
  if (!r.kind.empty()) {
    slicing.kind = enum_from_string<InputKind>(r.kind, option_name("--input"));
    if (slicing.kind == InputKind::Contours)
      throw ParamError(option_name("--input") + " contours: a volume holds labels or masks (" + option_name("--input") +
                       " labels|masks)");
  } else {
    slicing.kind = InputKind::Labels;
    if (!in.volume->integer) {
      const bool whole = std::all_of(in.volume->data.begin(), in.volume->data.end(), [](float v) { return v == std::floor(v); });
      if (!whole)
        throw InputError(path, "a float volume with non-integer values is not a label map: give " +
                                   option_given("--input", "masks") + " to take every non-zero voxel as inside");
    }
  }
  in.slicing = std::make_unique<VolumeStack>(volume_stack(*in.volume, slicing, path));
  for (auto& w : in.slicing->warnings) in.warnings.push_back(w);
  in.jobs.push_back({std::move(in.slicing->stack), "", std::nullopt});  // the slicing keeps its kind, axis and indices
  return in;
}

Inputs read_volume_input(const InputRequest& r) {
  VolumeReadOptions ro;
  ro.allow_external_data = r.allow_external_data;
  ro.on_header = [&](const VolumeHeader& h) {  // before any voxel is read: the file's samples and our floats
    const double voxels = double(h.nx) * double(h.ny) * double(h.nz);
    check_budget(option_name("--max-memory"),
                 "reading the " + std::to_string(h.nx) + "x" + std::to_string(h.ny) + "x" + std::to_string(h.nz) +
                     " volume",
                 voxels * double(h.sample_bytes + sizeof(float)), r.max_memory);
  };
  return slice_volume(read_volume(r.paths[0], ro), r.paths[0], r);
}

Inputs read_rtstruct_input(const InputRequest& r) {
  Inputs in;
  const std::string& path = r.paths[0];
  reject(r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "an RT Structure Set carries its contour planes");
  reject(r.pixel_size || !r.kind.empty(), "--pixel-size/--input",
         "an RT Structure Set holds polygons in mm (give " + option_name("--voxel-size") + " for the working grid)");
  const RtStructureSet set = read_rtstruct(path);
  RoiGrid grid;
  if (r.voxel_size) grid.voxel_size = *r.voxel_size;
  std::vector<const RtRoi*> chosen;
  if (!r.rois.empty()) {
    for (const std::string& name : r.rois) {
      const RtRoi* roi = set.find(name);
      if (!roi) {
        std::string names;
        for (const auto& x : set.rois) names += (names.empty() ? "" : ", ") + ("'" + x.name + "'");
        throw InputError(path, "no ROI named '" + name + "' (ROIs: " + names + ")");
      }
      chosen.push_back(roi);
    }
  } else {
    for (const auto& x : set.rois) {
      if (x.closed_contours() == 0) {
        in.warnings.push_back(path + ": ROI '" + x.name + "' has no closed planar contour: skipped");
        continue;
      }
      chosen.push_back(&x);
    }
    if (chosen.empty()) throw InputError(path, "no ROI has closed planar contours");
  }
  for (const RtRoi* roi : chosen) {
    std::vector<std::string> warnings;
    try {
      in.jobs.push_back({roi_stack(*roi, grid, path, warnings), roi->name, roi->color});
    } catch (const InputError& e) {
      if (!r.rois.empty()) throw;  // asked for by name: its problem is the run's
      in.warnings.push_back(std::string(e.what()) + ": skipped");
    }
    for (auto& w : warnings) in.warnings.push_back(std::move(w));
  }
  if (in.jobs.empty()) throw InputError(path, "no ROI could be reconstructed");
  return in;
}

// The options the format cannot use, and the space's name.
void check_request(InputFormat format, const InputRequest& r) {
  if (format != InputFormat::Volume) reject(!r.axis.empty(), "--axis", kVolumeInputOnly);
  if (format != InputFormat::RtStruct)
    reject(r.voxel_size || !r.rois.empty(), "--roi/--voxel-size", "only with a DICOM RT Structure Set input");
  if ((format == InputFormat::Images || format == InputFormat::Polylines) && !r.space.empty())
    throw ParamError(option_name("--space") + ": the input has no patient space (only volumes and RT Structure Sets do)");
  if (!r.space.empty() && r.space != "lps" && r.space != "ras")
    throw ParamError(option_name("--space") + ": unknown value '" + r.space + "' (expected lps or ras)");
}

// The meshes are written in 32-bit floats in patient mm: far from the origin
// a float's step passes the pixel and every vertex snaps to a few values
// (at x = 1e9 mm all get one x, and the mesh still checks "closed manifold",
// its check being in working pixels).
void check_float_precision(const Inputs& in) {
  for (const Job& job : in.jobs) {
    const SliceStack& st = job.stack;
    if (!st.patient || st.slices.empty()) continue;
    double reach = 0;
    for (const double x : {0.0, double(st.width)})
      for (const double y : {0.0, double(st.height)})
        for (const double z : {st.slices.front().z, st.slices.back().z})
          reach = std::max(reach, st.patient->to_patient(Vec3d(x, y, z)).cwiseAbs().maxCoeff());
    const double pixel = st.patient->axes.col(0).norm();
    const double step = reach > 0 ? std::ldexp(1.0, std::ilogb(reach) - 23) : 0;  // float32 spacing at `reach`
    if (step > kFloatPrecisionFraction * pixel) {
      std::ostringstream o;
      o << (job.name.empty() ? "" : "ROI '" + job.name + "': ") << "patient coordinates reach " << reach
        << " mm, where the meshes' 32-bit floats step by " << step << " mm, more than 1/"
        << 1 / kFloatPrecisionFraction << " of the " << pixel
        << " mm pixel: the surface would lose its shape (move the origin nearer 0, e.g. in the file's header)";
      throw InputError(in.files.empty() ? "input" : in.files.front(), o.str());
    }
  }
}

}  // namespace

Inputs volume_input(Volume volume, const std::string& name, const InputRequest& r) {
  check_request(InputFormat::Volume, r);
  Inputs in = slice_volume(std::move(volume), name, r);
  in.format = InputFormat::Volume;
  in.files = {name};
  in.ras = r.space == "ras";
  check_float_precision(in);
  return in;
}

InputFormat detect_input(const std::vector<std::string>& paths) {
  if (paths.size() != 1 || fs::is_directory(paths[0])) return InputFormat::Images;
  const std::string& p = paths[0];
  const std::string ext = lower_extension(p);
  if (ext == ".txt" || ext == ".poly" || ext == ".polylines") return InputFormat::Polylines;
  if (is_volume_path(p)) return InputFormat::Volume;
  if (ext == ".dcm" || is_dicom_file(p)) return InputFormat::RtStruct;
  return InputFormat::Images;
}

Inputs read_inputs(const InputRequest& r) {
  // Opening a FIFO blocks until a writer comes, and detecting the format opens the file.
  for (const std::string& p : r.paths)
    if (std::error_code ec; !fs::is_directory(p, ec)) detail::check_regular_file(p);
  const InputFormat format = detect_input(r.paths);
  check_request(format, r);
  Inputs in;
  switch (format) {
    case InputFormat::Images: in = read_images(r); break;
    case InputFormat::Polylines: in = read_polyline_file(r); break;
    case InputFormat::Volume: in = read_volume_input(r); break;
    case InputFormat::RtStruct: in = read_rtstruct_input(r); break;
    case InputFormat::Arrays: break;
  }
  in.format = format;
  in.files = r.paths;
  in.ras = r.space == "ras";
  check_float_precision(in);
  return in;
}

void check_labels(const Inputs& in, const std::vector<std::uint32_t>& labels, const std::string& option) {
  if (!labels.empty() && in.jobs.front().stack.kind != InputKind::Labels)
    throw ParamError(option + ": only with label input (" + option_given("--input", "labels") +
                     ", or an integer label volume)");
}

nlohmann::json input_report(const Inputs& in) {
  const SliceStack& first = in.jobs.front().stack;
  std::vector<double> z;
  for (const auto& s : first.slices) z.push_back(s.z);
  nlohmann::json input = {{"files", in.files},
                          {"format", to_string(in.format)},
                          {"kind", to_string(first.kind)},
                          {"slices", first.slices.size()},
                          {"width", first.width},
                          {"height", first.height},
                          {"slice_z_px", z},
                          {"pixel_size", first.pixel_size}};
  if (first.patient) input["space"] = in.ras ? "RAS" : "LPS";
  if (in.slicing) {
    input["axis"] = std::string(1, "ijk"[in.slicing->axis]);
    input["annotated_slices"] = in.slicing->annotated;
  }
  if (in.format == InputFormat::RtStruct) {
    nlohmann::json rois = nlohmann::json::array();
    for (const auto& job : in.jobs) rois.push_back({{"name", job.name}, {"planes", job.stack.slices.size()}});
    input["rois"] = rois;
  }
  return input;
}

}  // namespace isoloft
