#include "isoloft/run/inputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <tuple>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/csl.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/polylines.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/rtstruct_sections.h"
#include "isoloft/io/slice_images.h"
#include "isoloft/io/text.h"
#include "isoloft/io/volume_sections.h"
#include "isoloft/run/budget.h"
#include "isoloft/run/rtstruct_output.h"

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

// A CSL file: its sections (sections_input(): one job per label, a job's
// stack empty; a method that reads sections, MethodSpec::reads_sections, reads them).
Inputs read_csl_input(const InputRequest& r) {
  reject(r.z_spacing || r.slice_z, "--z-spacing/--slice-z", kCslInputOnly);
  reject(bool(r.pixel_size), "--pixel-size", kCslInputOnly);
  reject(!r.kind.empty(), "--input", "a CSL file holds polygons, not images");
  return sections_input(read_csl(r.paths[0]).sections, r.paths[0]);
}

// The slicing a volume request asks for (--axis, --input), checked before any voxel is read.
VolumeSlicing volume_slicing(const InputRequest& r) {
  reject(r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "a volume carries its own voxel spacing");
  reject(bool(r.pixel_size), "--pixel-size", "a volume carries its own voxel size");
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
  }
  return slicing;
}

// A volume read or given, sliced along its annotated axis; `path` names it in
// messages. `sliced`: the stack already read from the file's samples (then
// `volume` holds the geometry alone).
// 2^24: the first integer after which float32 skips integers.
constexpr float kFloatLabelLimit = 16777216.0f;

Inputs slice_volume(Volume volume, const std::string& path, const InputRequest& r,
                    std::optional<VolumeStack> sliced = std::nullopt) {
  Inputs in;
  const VolumeSlicing slicing = volume_slicing(r);
  in.volume = std::make_unique<Volume>(std::move(volume));
  for (auto& w : in.volume->warnings) in.warnings.push_back(w);
  detail::check_finite_voxels(*in.volume, path);
  if (r.kind.empty() && !in.volume->integer) {
    const bool whole = std::all_of(in.volume->data.begin(), in.volume->data.end(), [](float v) { return v == std::floor(v); });
    if (!whole)
      throw InputError(path, "a float volume with non-integer values is not a label map: give " +
                                 option_given("--input", "masks") + " to take every non-zero voxel as inside");
  }
  // Labels stored as floats: from 2^24 on a float32 steps by 2 or more
  // (16777217 is stored as 16777216), so labels there may already have merged.
  if (r.kind != "masks" && !in.volume->integer && in.volume->value_table.empty()) {
    const auto big = std::find_if(in.volume->data.begin(), in.volume->data.end(),
                                  [](float v) { return std::abs(v) >= kFloatLabelLimit; });
    if (big != in.volume->data.end())
      throw InputError(path, "float voxels hold label " + detail::shortest_text(*big) +
                                 ", at or above 2^24 where float32 cannot tell neighbouring integers apart (16777217 is "
                                 "stored as 16777216): store the labels as integers (int32), or give " +
                                 option_given("--input", "masks"));
  }
  in.slicing = std::make_unique<VolumeStack>(sliced ? std::move(*sliced) : volume_stack(*in.volume, slicing, path));
  for (auto& w : in.slicing->warnings) in.warnings.push_back(w);
  in.jobs.push_back({std::move(in.slicing->stack), "", std::nullopt});  // the slicing keeps its kind, axis and indices
  return in;
}

// The labels' names from `table` (if any) into `in`.
void read_names(Inputs& in, const std::optional<std::string>& table, const InputRequest& r) {
  if (table && in.labels()) in.label_names = read_label_names(*table);
  else if (!r.label_names.empty())
    throw ParamError(option_name("--label-names") + ": only with label input (" + option_given("--input", "labels") + ")");
}

// A label volume annotated along several axes: its annotated slices as
// sections in patient mm (io/volume_sections.h), one job per label drawn on
// some slice (as a CSL file's: the job's stack stays empty, a method that
// reads sections reads them; meshes come out in patient mm).
Inputs read_annotated_volume(const InputRequest& r) {
  const std::string& path = r.paths[0];
  reject(r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "a volume carries its own voxel spacing");
  reject(bool(r.pixel_size), "--pixel-size", "a volume carries its own voxel size");
  const std::string flag = !r.annotated.empty() ? "--annotated" : "--annotated-mask";
  reject(!r.annotated.empty() && !r.annotated_mask.empty(), "--annotated",
         "give either " + option_name("--annotated") + " or " + option_name("--annotated-mask") + ", not both");
  reject(!r.axis.empty(), "--axis", "not with " + option_name(flag) + " (the annotated slices may lie along every axis)");
  reject(!r.kind.empty() && r.kind != "labels", "--input", "a volume annotated along several axes holds labels");
  VolumeReadOptions ro;
  ro.allow_external_data = r.allow_external_data;
  std::vector<std::string> data_files;
  ro.on_header = [&](const VolumeHeader& h) {
    data_files = h.data_files;
    const double voxels = double(h.nx) * double(h.ny) * double(h.nz);
    check_budget(option_name("--max-memory"),
                 "reading the " + std::to_string(h.nx) + "x" + std::to_string(h.ny) + "x" + std::to_string(h.nz) + " volume",
                 voxels * double(h.sample_bytes + sizeof(float)), r.max_memory);
  };
  Inputs in;
  in.volume = std::make_unique<Volume>(read_volume(path, ro));
  in.data_files = std::move(data_files);
  for (auto& w : in.volume->warnings) in.warnings.push_back(w);
  detail::check_finite_voxels(*in.volume, path);
  AnnotatedSlices slices;
  if (!r.annotated.empty()) {
    try {
      slices = parse_annotated_slices(r.annotated, *in.volume);
    } catch (const ParamError& e) {
      throw ParamError(option_name("--annotated") + ": " + e.what());
    }
  } else {
    detail::check_regular_file(r.annotated_mask);
    // ro: the mask's read is budgeted like the volume's, and its header's data files collected.
    const Volume mask = read_volume(r.annotated_mask, ro);
    slices = annotated_slices_from_mask(mask, *in.volume, r.annotated_mask);
    // Read with the input, the mask and its data files: no output may replace them.
    in.data_files.push_back(r.annotated_mask);
    in.data_files.insert(in.data_files.end(), data_files.begin(), data_files.end());
  }
  std::vector<Section> sections = label_volume_sections(*in.volume, slices, path);
  std::vector<std::uint32_t> labels;
  for (const Section& s : sections) labels.insert(labels.end(), s.labels.data.begin(), s.labels.data.end());
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  labels.erase(std::remove(labels.begin(), labels.end(), 0u), labels.end());
  if (labels.empty()) throw InputError(path, "no annotated slice holds a label: nothing to reconstruct");
  for (const std::uint32_t l : labels) {
    Job job;
    job.stack.kind = InputKind::Polylines;
    job.stack.patient = PatientFrame{};  // the sections, and so the meshes, are in patient mm already
    job.name = labels.size() > 1 ? "label" + std::to_string(l) : "";
    job.sections = sections;
    job.section_label = l;
    in.jobs.push_back(std::move(job));
  }
  if (!r.label_names.empty()) in.label_names = read_label_names(r.label_names);
  return in;
}

Inputs read_volume_input(const InputRequest& r) {
  if (!r.annotated.empty() || !r.annotated_mask.empty()) return read_annotated_volume(r);
  const std::string& path = r.paths[0];
  const VolumeSlicing slicing = volume_slicing(r);
  VolumeReadOptions ro;
  ro.allow_external_data = r.allow_external_data;
  std::vector<std::string> data_files;
  ro.on_header = [&](const VolumeHeader& h) {  // before any voxel is read: the file's samples, and our floats
    data_files = h.data_files;
    const double voxels = double(h.nx) * double(h.ny) * double(h.nz);   // unless they are sliced as stored (below)
    const bool as_stored = h.sample_bytes <= 2;                         // the 8- and 16-bit types: slices_samples
    check_budget(option_name("--max-memory"),
                 "reading the " + std::to_string(h.nx) + "x" + std::to_string(h.ny) + "x" + std::to_string(h.nz) +
                     " volume",
                 voxels * double(h.sample_bytes + (as_stored ? 0 : sizeof(float))), r.max_memory);
  };
  // Label maps of 8- and 16-bit integers are sliced from the samples as stored:
  // the planes between the annotated ones are never decoded (docs/decisions.md).
  std::optional<VolumeStack> sliced;
  ro.take_samples = [&](const Volume& geometry, const VolumeSamples& samples) {
    if (!slices_samples(samples.type)) return false;
    sliced = volume_stack(geometry, samples, slicing, path);
    return true;
  };
  Volume v = read_volume(path, ro);
  Inputs in = slice_volume(std::move(v), path, r, std::move(sliced));
  in.data_files = std::move(data_files);
  // The labels' names: the table given, else the one beside the volume.
  read_names(in, !r.label_names.empty() ? std::optional(r.label_names) : label_names_beside(path), r);
  return in;
}

// RT working grid (docs/decisions.md: RT grid): a ROI's largest loop spans at
// least this many pixels of its thickness, the grid is at least this fine...
constexpr double kPixelsAcross = 16;
// ...but no finer than this (mm), and no more than this many pixels across the loop.
constexpr double kMinRoiVoxelMm = 0.05, kMaxRoiPixels = 4000;

// RT triangle budget (docs/decisions.md: RT triangle budget): without
// --voxel-size, a ROI whose mesh would exceed this many triangles gets the
// grid that keeps it within (the largest ROIs, e.g. a BODY, only).
constexpr double kRtMeshBudget = 1.5e6;
// Marching Cubes triangles per pixel of contour wall (perimeter x plane
// spacing, plus both end planes' areas, over the pixel area): on the shared
// structure set's ROIs the meshes have 2.6-2.9 triangles per pixel of their
// own area, and the contours' wall underestimates that area (walls slant in
// z); 3.6 keeps every ROI's mesh under the estimate (measured 1.22-1.75 times
// the 2-per-pixel count).
constexpr double kTrianglesPerWallPixel = 3.6;

// Drawn contours of kKeptDrawnMm2 or more keep their area within kShrinkShare
// (run/rtstruct_output.h, which checks it) when the narrowest one's thickness 2 area /
// perimeter spans this many pixels: measured (docs/decisions.md: narrow drawn
// contours), islands at 1 mm pixels keep 72 % at 0.98 px and 85 % at 1.13 px;
// on the shared set every contour >= 1 mm^2 keeps >= 75 % at 1.11 px and
// more (Lt Lung's narrowest, 0.58 mm at 0.5 mm), BODY's two of 0.67 mm keep
// 44-60 % at 0.71 px (its budget grid, 0.94 mm).
constexpr double kPixelsAcrossNarrowest = 1.1;
// A grid refined for a narrow drawn contour may pass kRtMeshBudget up to this
// many estimated triangles (measured, BODY alone: 2.9 M triangles and 400 MB
// peak at 0.6 mm, 4.2 M and 530 MB at 0.5 mm; --max-memory still bounds the
// run); beyond it the grid stops there and a warning says the contour may
// come out shrunk.
constexpr double kRtRefinedMeshBudget = 4e6;

// A closed contour's area and perimeter in its plane (mm^2, mm).
std::pair<double, double> area_perimeter(const RtContour& c) {
  double a = 0, perimeter = 0;
  for (std::size_t i = 0, j = c.points.size() - 1; i < c.points.size(); j = i++) {
    const Vec3d &p = c.points[i], &q = c.points[j];
    a += q.x() * p.y() - p.x() * q.y();
    perimeter += (p - q).head<2>().norm();
  }
  return {0.5 * std::abs(a), perimeter};
}

// A ROI's estimated mesh area from its contours (mm^2): each closed contour's
// perimeter times the plane spacing, plus the areas on its lowest and highest
// planes (the end caps).
double estimated_wall_area(const RtRoi& roi, double spacing) {
  double wall = 0, zlo = INFINITY, zhi = -INFINITY, end_lo = 0, end_hi = 0;
  const double tol = 0.2 * spacing;
  for (const RtContour& c : roi.contours) {
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) continue;
    const auto [area, perimeter] = area_perimeter(c);
    wall += perimeter * spacing;
    const double z = c.points.front().z();
    if (z < zlo - tol) zlo = z, end_lo = 0;
    if (std::abs(z - zlo) <= tol) end_lo += area;
    if (z > zhi + tol) zhi = z, end_hi = 0;
    if (std::abs(z - zhi) <= tol) end_hi += area;
  }
  return wall + end_lo + end_hi;
}

// The largest closed contour of a ROI (by area): its thickness 2 area /
// perimeter (a circle's radius) and its extent (longer bounding-box side), mm.
std::pair<double, double> largest_loop_size(const RtRoi& roi) {
  double best = 0, thickness = 0, extent = 0;
  for (const RtContour& c : roi.contours) {
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) continue;
    const auto [a, perimeter] = area_perimeter(c);
    if (!(a > best && perimeter > 0)) continue;
    double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
    for (const Vec3d& p : c.points)
      xlo = std::min(xlo, p.x()), xhi = std::max(xhi, p.x()), ylo = std::min(ylo, p.y()), yhi = std::max(yhi, p.y());
    best = a, thickness = 2 * a / perimeter, extent = std::max(xhi - xlo, yhi - ylo);
  }
  return {thickness, extent};
}

// The narrowest closed contour of at least kKeptDrawnMm2 (by thickness 2
// area / perimeter): its thickness, area and plane; thickness 0 if none.
std::tuple<double, double, double> narrowest_drawn(const RtRoi& roi) {
  std::tuple<double, double, double> best{0.0, 0.0, 0.0};
  for (const RtContour& c : roi.contours) {
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) continue;
    const auto [a, perimeter] = area_perimeter(c);
    if (a < kKeptDrawnMm2 || !(perimeter > 0)) continue;
    const double t = 2 * a / perimeter;
    if (std::get<0>(best) == 0 || t < std::get<0>(best)) best = {t, a, c.points.front().z()};
  }
  return best;
}

// A grid size for a message: 4 decimals.
std::string mm4(double mm) { return detail::shortest_text(std::round(mm * 1e4) / 1e4); }

// The grid a ROI's narrowest drawn contour asks for (kPixelsAcrossNarrowest
// pixels across its thickness), if finer than `grid`: no finer than
// `finest` (kMinRoiVoxelMm, kMaxRoiPixels) nor than keeps its estimated
// triangles (`wall_pixels` / voxel^2) within kRtRefinedMeshBudget.
std::optional<GridRefinement> refine_for_narrowest(const RtRoi& roi, double grid, double finest, double wall_pixels) {
  const auto [t, area, z] = narrowest_drawn(roi);
  const double wanted = t / kPixelsAcrossNarrowest;
  if (!(t > 0) || wanted >= grid) return std::nullopt;
  const double bound = std::max({finest, kMinRoiVoxelMm, std::sqrt(wall_pixels / kRtRefinedMeshBudget)});
  if (bound >= grid) return std::nullopt;
  std::ostringstream why;
  why << "its contour of " << detail::shortest_text(std::round(area * 100) / 100) << " mm^2 at z = "
      << detail::shortest_text(std::round(z * 100) / 100) << " mm is " << detail::shortest_text(std::round(t * 1000) / 1000)
      << " mm thick (2 area / perimeter), " << detail::shortest_text(std::round(t / grid * 100) / 100)
      << " pixels at " << mm4(grid) << " mm; " << kPixelsAcrossNarrowest << " pixels across keep its area within "
      << 100 * kShrinkShare << " %";
  return GridRefinement{grid, std::max(wanted, bound), why.str(), wanted < bound};
}

// ROIs on different frames of reference are in different patient spaces,
// and a structure set holds no registration between them: one mesh file, one
// label map or one RT output would put them in one space, silently wrong. An
// error (not a warning) naming each frame's ROIs; --roi picks one frame's.
void check_one_frame(const std::vector<const RtRoi*>& rois, const std::string& path) {
  std::map<std::string, std::vector<std::string>> by_frame;  // ROIs without a frame take the others'
  for (const RtRoi* roi : rois)
    if (!roi->frame_of_reference.empty()) by_frame[roi->frame_of_reference].push_back("'" + roi->name + "'");
  if (by_frame.size() < 2) return;
  std::string list;
  for (const auto& [frame, names] : by_frame) {
    list += list.empty() ? "" : "; ";
    for (std::size_t i = 0; i < names.size(); ++i) list += (i ? ", " : "") + names[i];
    list += " on " + frame;
  }
  throw InputError(path, "the ROIs are on different frames of reference (" + list +
                             "): their coordinates are in different patient spaces and the file holds no registration "
                             "between them; select the ROIs of one frame with " + option_name("--roi"));
}

// Whether every closed contour of the ROI lies on an axial plane (its
// points' z within kPlanarToleranceMm, as roi_stack() takes them).
bool axial_roi(const RtRoi& roi) {
  return std::all_of(roi.contours.begin(), roi.contours.end(), [](const RtContour& c) {
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) return true;
    const auto [lo, hi] = std::minmax_element(c.points.begin(), c.points.end(),
                                              [](const Vec3d& a, const Vec3d& b) { return a.z() < b.z(); });
    return hi->z() - lo->z() <= kPlanarToleranceMm;
  });
}

// A ROI with contours on oblique planes, for a method that reads sections:
// its sections in patient mm (io/rtstruct_sections.h), the working frame
// the patient's own (1 mm a unit), no slices.
Job roi_section_job(const RtRoi& roi, const std::string& path, std::vector<std::string>& warnings) {
  Job job;
  job.stack.kind = InputKind::Polylines;
  job.stack.patient = PatientFrame{};
  job.name = roi.name;
  job.color = roi.color;
  job.roi = &roi;
  job.sections = roi_sections(roi, path, warnings);
  job.section_label = 1;
  return job;
}

Inputs read_rtstruct_input(const InputRequest& r) {
  Inputs in;
  const std::string& path = r.paths[0];
  reject(r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "an RT Structure Set carries its contour planes");
  reject(r.pixel_size || !r.kind.empty(), "--pixel-size/--input",
         "an RT Structure Set holds polygons in mm (give " + option_name("--voxel-size") + " for the working grid)");
  in.rtstruct = std::make_unique<RtStructureSet>(read_rtstruct(path));
  const RtStructureSet& set = *in.rtstruct;
  for (const auto& [number, count] : set.unlisted_contours)
    in.warnings.push_back(path + ": " + std::to_string(count) + " contour(s) refer to ROI number " +
                          std::to_string(number) + ", which the StructureSetROISequence does not list: skipped");
  RoiGrid grid;
  if (r.voxel_size) grid.voxel_size = *r.voxel_size;
  grid.plane_spacing = typical_plane_spacing(set);
  const std::vector<const RtRoi*> chosen = r.rois.empty() ? set.with_contours(path, in.warnings) : set.select(r.rois, path);
  check_one_frame(chosen, path);
  std::vector<std::string> skipped;  // each ROI not reconstructed and why
  for (const RtRoi* roi : chosen) {
    std::vector<std::string> warnings;
    if (r.any_plane && !axial_roi(*roi)) {
      try {
        in.jobs.push_back(roi_section_job(*roi, path, warnings));
      } catch (const InputError& e) {
        if (!r.rois.empty()) throw;  // asked for by name: its problem is the run's
        in.warnings.push_back(std::string(e.what()) + ": skipped");
        skipped.push_back(e.problem);
      }
      for (auto& w : warnings) in.warnings.push_back(std::move(w));
      continue;
    }
    RoiGrid g = grid;
    // A grid fine enough for the ROI's own size (docs/decisions.md: RT grid):
    // its largest loop's thickness 2 area / perimeter across kPixelsAcross pixels.
    const auto [thickness, extent] = largest_loop_size(*roi);
    std::optional<GridRefinement> refined;
    if (thickness > 0) {
      const double fine = std::max({kMinRoiVoxelMm, thickness / kPixelsAcross, extent / kMaxRoiPixels});
      if (!r.voxel_size) {
        g.voxel_size = std::min(grid.voxel_size, fine);
        const double triangles = kTrianglesPerWallPixel * estimated_wall_area(*roi, grid.plane_spacing) /
                                 (g.voxel_size * g.voxel_size);
        if (grid.plane_spacing > 0 && triangles > kRtMeshBudget) {
          g.voxel_size *= std::sqrt(triangles / kRtMeshBudget);
          std::ostringstream o;
          o << path << ": ROI '" << roi->name << "': working grid " << g.voxel_size << " mm instead of "
            << grid.voxel_size << " mm, so that its mesh stays within " << long(kRtMeshBudget)
            << " triangles (about " << detail::shortest_text(std::round(triangles)) << " at " << grid.voxel_size << " mm; "
            << option_name("--voxel-size") << " sets the grid; the report's contour_vertex_distance is its error)";
          in.warnings.push_back(o.str());
        }
        refined = refine_for_narrowest(*roi, g.voxel_size, extent / kMaxRoiPixels,
                                       grid.plane_spacing > 0 ? kTrianglesPerWallPixel *
                                                                    estimated_wall_area(*roi, grid.plane_spacing)
                                                              : 0.0);
        if (refined) {
          g.voxel_size = refined->to_mm;
          in.warnings.push_back(path + ": ROI '" + roi->name + "': working grid refined from " +
                                mm4(refined->from_mm) + " to " + mm4(refined->to_mm) + " mm: " + refined->why);
          if (refined->limited)
            in.warnings.push_back(path + ": ROI '" + roi->name + "': " + refined->why + ", but the grid stops at " +
                                  mm4(refined->to_mm) + " mm (about " +
                                  detail::shortest_text(kRtRefinedMeshBudget) +
                                  " triangles): that contour may come out shrunk (the RT report flags it)");
        }
      } else if (fine < g.voxel_size) {
        std::ostringstream o;
        o << path << ": ROI '" << roi->name << "': its largest contour is " << thickness / g.voxel_size
          << " pixels thick (2 area / perimeter) at " << option_name("--voxel-size") << " " << g.voxel_size
          << " mm; its volume may come out several percent low (a 3 mm sphere on 1 mm slices: -13 % at 0.5 mm, "
          << "-4 % at 0.2 mm); " << fine << " mm or less keeps it (the default picks it)";
        in.warnings.push_back(o.str());
      }
    }
    try {
      in.jobs.push_back({roi_stack(*roi, g, path, warnings), roi->name, roi->color, roi});
      in.jobs.back().refined = refined;
    } catch (const InputError& e) {
      if (!r.rois.empty()) throw;  // asked for by name: its problem is the run's
      in.warnings.push_back(std::string(e.what()) + ": skipped");
      skipped.push_back(e.problem);  // names the ROI
    }
    for (auto& w : warnings) in.warnings.push_back(std::move(w));
  }
  if (in.jobs.empty()) {
    std::string why;
    for (const std::string& s : skipped) why += (why.empty() ? "" : "; ") + s;
    throw InputError(path, "no ROI could be reconstructed" + (why.empty() ? std::string() : " (" + why + ")"));
  }
  return in;
}

// The options the format cannot use, and the space's name.
void check_request(InputFormat format, const InputRequest& r) {
  if (format != InputFormat::Volume) reject(!r.axis.empty(), "--axis", kVolumeInputOnly);
  if (format != InputFormat::Volume) reject(!r.label_names.empty(), "--label-names", kVolumeInputOnly);
  if (format != InputFormat::Volume)
    reject(!r.annotated.empty() || !r.annotated_mask.empty(), "--annotated/--annotated-mask", kAnnotatedVolumeOnly);
  if (format != InputFormat::RtStruct)
    reject(r.voxel_size || !r.rois.empty(), "--roi/--voxel-size", "only with a DICOM RT Structure Set input");
  if ((format == InputFormat::Images || format == InputFormat::Polylines || format == InputFormat::Csl) && !r.space.empty())
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

Inputs sections_input(std::vector<Section> sections, const std::string& name) {
  Inputs in;
  std::vector<std::uint32_t> labels;
  for (const Section& s : sections) {
    for (const SectionContour& c : s.contours) labels.push_back(c.label);
    labels.insert(labels.end(), s.labels.data.begin(), s.labels.data.end());
  }
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  labels.erase(std::remove(labels.begin(), labels.end(), 0u), labels.end());  // an image's outside
  if (labels.empty()) throw InputError(name, "no plane has a contour or a labelled pixel: nothing to reconstruct");
  // Labels drawn on one input partition its space: touching ones share their boundary.
  const auto partition = std::make_shared<SharedPartition>(labels);
  for (const std::uint32_t l : labels) {
    Job job;
    job.stack.kind = InputKind::Polylines;
    job.name = labels.size() > 1 ? "label" + std::to_string(l) : "";
    job.sections = sections;
    job.section_label = l;
    job.partition = partition;
    in.jobs.push_back(std::move(job));
  }
  in.format = InputFormat::Sections;
  in.files = {name};
  return in;
}

Inputs volume_input(Volume volume, const std::string& name, const InputRequest& r) {
  check_request(InputFormat::Volume, r);
  Inputs in = slice_volume(std::move(volume), name, r);
  read_names(in, !r.label_names.empty() ? std::optional(r.label_names) : std::nullopt, r);  // an image has no file beside
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
  if (ext == ".csl") return InputFormat::Csl;
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
    case InputFormat::Csl: in = read_csl_input(r); break;
    case InputFormat::Arrays:
    case InputFormat::Sections: break;
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
  if (!in.label_names.file.empty()) input["label_names"] = in.label_names.file;
  if (in.format == InputFormat::Csl || in.format == InputFormat::Sections) {
    input["planes"] = in.jobs.front().sections.size();
    nlohmann::json labels = nlohmann::json::array();
    for (const auto& job : in.jobs) labels.push_back(job.section_label);
    input["labels"] = labels;
  }
  if (in.format == InputFormat::RtStruct) {
    nlohmann::json rois = nlohmann::json::array();
    for (const auto& job : in.jobs)
      rois.push_back(job.sections.empty()
                         ? nlohmann::json{{"name", job.name}, {"planes", job.stack.slices.size()}, {"pixel_size", job.stack.pixel_size}}
                         : nlohmann::json{{"name", job.name}, {"planes", job.sections.size()}, {"any_plane", true}});
    input["rois"] = rois;
  }
  return input;
}

}  // namespace isoloft
