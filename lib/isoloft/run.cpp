#include "isoloft/run.h"

#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/io/polylines.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/io/slice_images.h"
#include "isoloft/mesh/plane_cut.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

// An option given with an input that cannot use it: an error naming both.
void reject(const InputRequest& r, bool given, const std::string& flag, const std::string& why) {
  if (given) throw ParamError(r.name(flag) + ": " + why);
}

// Slices decoded at once while the contour stage runs (one per worker thread).
double slices_in_flight(double slices) { return std::min(slices, double(tbb::this_task_arena::max_concurrency())); }

// Per pixel of a slice in flight in the contour stage: the decoded image
// (Grid2u32), the contour and inside masks, the fill's two int label grids
// and its binarized copy.
constexpr double kImageBytes = 4, kMaskBytes = 2, kFillBytes = 9;

double stack_bytes(const SliceStack& st) {
  const double n = double(st.slices.size()), pixels = double(st.width) * double(st.height);
  const bool held = !st.load_image && !st.has_polygons();  // every slice's image in memory (volumes)
  // Run-length masks of every slice: ~1 (begin, end) pair of uint32 a row in each of the two.
  const double packed = n * double(st.height) * 2 * 2 * sizeof(std::uint32_t);
  return pixels * ((held ? n * kImageBytes : 0) + slices_in_flight(n) * (kImageBytes + kMaskBytes + kFillBytes)) + packed;
}

Inputs read_images(const InputRequest& r) {
  Inputs in;
  SliceStack st = open_slice_images(list_slice_files(r.paths));  // decoded slice by slice as the pipeline goes
  // From the headers alone, before any decoding.
  check_budget(r.name("--max-memory"),
               "decoding " + std::to_string(st.slices.size()) + " slice image(s) of " + std::to_string(st.width) + "x" +
                   std::to_string(st.height) + " px (" + st.slices.front().source + ")",
               stack_bytes(st), r.max_memory);
  if (!r.kind.empty()) st.kind = enum_from_string<InputKind>(r.kind, r.name("--input"));
  if (r.slice_z) {
    if (r.z_spacing)
      throw ParamError("give either " + r.name("--z-spacing") + " or " + r.name("--slice-z") + ", not both");
    const auto& z = *r.slice_z;
    if (z.size() != st.slices.size())
      throw ParamError(r.name("--slice-z") + " has " + std::to_string(z.size()) + " values for " +
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
  reject(r, r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "a polyline file carries the z of its slices");
  reject(r, !r.kind.empty(), "--input", "a polyline file holds polygons, not images");
  SliceStack st = read_polylines(r.paths[0]);
  if (r.pixel_size) st.pixel_size = *r.pixel_size;
  in.jobs.push_back({std::move(st), "", std::nullopt});
  return in;
}

Inputs read_volume_input(const InputRequest& r) {
  Inputs in;
  const std::string& path = r.paths[0];
  reject(r, r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "a volume carries its own voxel spacing");
  reject(r, bool(r.pixel_size), "--pixel-size", "a volume carries its own voxel size");
  in.volume = std::make_unique<Volume>(read_volume(path));
  for (auto& w : in.volume->warnings) in.warnings.push_back(w);
  detail::check_finite_voxels(*in.volume, path);
  VolumeSlicing slicing;
  if (!r.axis.empty()) {
    if (r.axis != "i" && r.axis != "j" && r.axis != "k")
      throw ParamError(r.name("--axis") + ": unknown value '" + r.axis + "' (expected i, j or k)");
    slicing.axis = r.axis == "i" ? 0 : r.axis == "j" ? 1 : 2;
  }
  if (!r.kind.empty()) {
    slicing.kind = enum_from_string<InputKind>(r.kind, r.name("--input"));
    if (slicing.kind == InputKind::Contours)
      throw ParamError(r.name("--input") + " contours: a volume holds labels or masks (" + r.name("--input") +
                       " labels|masks)");
  } else {
    slicing.kind = InputKind::Labels;
    if (!in.volume->integer) {
      const bool whole = std::all_of(in.volume->data.begin(), in.volume->data.end(), [](float v) { return v == std::floor(v); });
      if (!whole)
        throw InputError(path, "a float volume with non-integer values is not a label map: give " + r.name("--input") +
                                   " masks to take every non-zero voxel as inside");
    }
  }
  in.slicing = std::make_unique<VolumeStack>(volume_stack(*in.volume, slicing, path));
  for (auto& w : in.slicing->warnings) in.warnings.push_back(w);
  in.jobs.push_back({std::move(in.slicing->stack), "", std::nullopt});  // the slicing keeps its kind, axis and indices
  return in;
}

// RT working grid (docs/decisions.md: RT grid): a ROI's largest loop spans at
// least this many pixels of its thickness, the grid is at least this fine...
constexpr double kPixelsAcross = 16;
// ...but no finer than this (mm), and no more than this many pixels across the loop.
constexpr double kMinRoiVoxelMm = 0.05, kMaxRoiPixels = 4000;

// The largest closed contour of a ROI (by area): its thickness 2 area /
// perimeter (a circle's radius) and its extent (longer bounding-box side), mm.
std::pair<double, double> largest_loop_size(const RtRoi& roi) {
  double best = 0, thickness = 0, extent = 0;
  for (const RtContour& c : roi.contours) {
    if (c.type != "CLOSED_PLANAR" || c.points.size() < 3) continue;
    double a = 0, perimeter = 0, xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
    for (std::size_t i = 0, j = c.points.size() - 1; i < c.points.size(); j = i++) {
      const Vec3d &p = c.points[i], &q = c.points[j];
      a += q.x() * p.y() - p.x() * q.y();
      perimeter += (p - q).head<2>().norm();
      xlo = std::min(xlo, p.x()), xhi = std::max(xhi, p.x()), ylo = std::min(ylo, p.y()), yhi = std::max(yhi, p.y());
    }
    a = 0.5 * std::abs(a);
    if (a > best && perimeter > 0) best = a, thickness = 2 * a / perimeter, extent = std::max(xhi - xlo, yhi - ylo);
  }
  return {thickness, extent};
}

Inputs read_rtstruct_input(const InputRequest& r) {
  Inputs in;
  const std::string& path = r.paths[0];
  reject(r, r.z_spacing || r.slice_z, "--z-spacing/--slice-z", "an RT Structure Set carries its contour planes");
  reject(r, r.pixel_size || !r.kind.empty(), "--pixel-size/--input",
         "an RT Structure Set holds polygons in mm (give " + r.name("--voxel-size") + " for the working grid)");
  in.rtstruct = std::make_unique<RtStructureSet>(read_rtstruct(path));
  const RtStructureSet& set = *in.rtstruct;
  RoiGrid grid;
  if (r.voxel_size) grid.voxel_size = *r.voxel_size;
  grid.plane_spacing = typical_plane_spacing(set);
  const std::vector<const RtRoi*> chosen = r.rois.empty() ? set.with_contours(path, in.warnings) : set.select(r.rois, path);
  for (const RtRoi* roi : chosen) {
    std::vector<std::string> warnings;
    RoiGrid g = grid;
    // A grid fine enough for the ROI's own size (docs/decisions.md: RT grid):
    // its largest loop's thickness 2 area / perimeter across kPixelsAcross pixels.
    const auto [thickness, extent] = largest_loop_size(*roi);
    if (thickness > 0) {
      const double fine = std::max({kMinRoiVoxelMm, thickness / kPixelsAcross, extent / kMaxRoiPixels});
      if (!r.voxel_size) {
        g.voxel_size = std::min(grid.voxel_size, fine);
      } else if (fine < g.voxel_size) {
        std::ostringstream o;
        o << path << ": ROI '" << roi->name << "': its largest contour is " << thickness / g.voxel_size
          << " pixels thick (2 area / perimeter) at --voxel-size " << g.voxel_size << " mm; its volume may come out "
          << "several percent low (a 3 mm sphere on 1 mm slices: -13 % at 0.5 mm, -4 % at 0.2 mm); " << fine
          << " mm or less keeps it (the default picks it)";
        in.warnings.push_back(o.str());
      }
    }
    try {
      in.jobs.push_back({roi_stack(*roi, g, path, warnings), roi->name, roi->color, roi});
    } catch (const InputError& e) {
      if (!r.rois.empty()) throw;  // asked for by name: its problem is the run's
      in.warnings.push_back(std::string(e.what()) + ": skipped");
    }
    for (auto& w : warnings) in.warnings.push_back(std::move(w));
  }
  if (in.jobs.empty()) throw InputError(path, "no ROI could be reconstructed");
  return in;
}

}  // namespace

std::string InputRequest::name(const std::string& flag) const {
  if (!keyword_names) return flag;
  std::string out;
  for (std::size_t i = 0; i < flag.size(); ++i) {
    if (flag.compare(i, 2, "--") == 0) {
      ++i;
      continue;
    }
    out += flag[i] == '-' ? '_' : flag[i];
  }
  return out;
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
  const InputFormat format = detect_input(r.paths);
  if (format != InputFormat::Volume) {
    reject(r, !r.axis.empty(), "--axis", "only with a volume input (NIfTI, NRRD, MetaImage)");
    reject(r, r.labelmap, "--labelmap", "only with a volume input (NIfTI, NRRD, MetaImage)");
  }
  if (format != InputFormat::RtStruct)
    reject(r, r.voxel_size || !r.rois.empty(), "--roi/--voxel-size", "only with a DICOM RT Structure Set input");
  if ((format == InputFormat::Images || format == InputFormat::Polylines) && !r.space.empty())
    throw ParamError(r.name("--space") + ": the input has no patient space (only volumes and RT Structure Sets do)");
  if (!r.space.empty() && r.space != "lps" && r.space != "ras")
    throw ParamError(r.name("--space") + ": unknown value '" + r.space + "' (expected lps or ras)");
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
  return in;
}

std::string roi_file_tag(const Inputs& in, std::size_t job) {
  const Job& j = in.jobs[job];
  const std::string tag = file_safe(j.name);
  for (std::size_t k = 0; k < in.jobs.size(); ++k)
    if (k != job && file_safe(in.jobs[k].name) == tag && j.roi) return tag + "_" + std::to_string(j.roi->number);
  return tag;
}

std::string file_safe(const std::string& name) {
  std::string s;
  for (unsigned char c : name) s += std::isalnum(c) || c == '-' || c == '_' ? char(c) : '_';
  return s.empty() ? "roi" : s;
}

double parse_size(const std::string& text, const std::string& option) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  double unit = 1;
  std::string suffix(end ? end : "");
  if (!suffix.empty() && (suffix.back() == 'B' || suffix.back() == 'b')) suffix.pop_back();
  if (suffix == "K" || suffix == "k") unit = 1024.0;
  else if (suffix == "M" || suffix == "m") unit = 1024.0 * 1024;
  else if (suffix == "G" || suffix == "g") unit = 1024.0 * 1024 * 1024;
  else if (suffix == "T" || suffix == "t") unit = 1024.0 * 1024 * 1024 * 1024;
  else if (!suffix.empty()) unit = -1;
  if (text.empty() || end == text.c_str() || unit < 0 || !std::isfinite(v) || v < 0)
    throw ParamError(option + ": '" + text + "' is not a size (e.g. 4G, 512M, 64K, bytes; 0 = no limit)");
  return v * unit;
}

std::string size_text(double bytes) {
  char buf[64];
  if (bytes >= 1024.0 * 1024 * 1024) std::snprintf(buf, sizeof buf, "%.3g GiB", bytes / (1024.0 * 1024 * 1024));
  else std::snprintf(buf, sizeof buf, "%.3g MiB", bytes / (1024.0 * 1024));
  return buf;
}

void check_budget(const std::string& option, const std::string& what, double need, double limit) {
  if (limit > 0 && need > limit)
    throw ParamError(option + ": " + what + " needs about " + size_text(need) + ", over the budget of " +
                     size_text(limit) + " (raise " + option + ", or 0 for no limit)");
}

double input_bytes(const Inputs& in) {
  double bytes = 0;
  for (const Job& job : in.jobs) bytes = std::max(bytes, stack_bytes(job.stack));  // jobs run one at a time
  if (in.volume) bytes += double(in.volume->data.size()) * sizeof(float);
  return bytes;
}

void check_surfaces(const Inputs& in, const RunResult& r, bool allow_empty, const std::string& allow_option) {
  const std::string path = in.files.empty() ? "slices" : in.files.front();
  if (r.objects.empty())
    throw InputError(path, "nothing to reconstruct: no slice has an inside (a closed contour, or mask pixels)");
  if (allow_empty) return;
  for (const RunObject& ob : r.objects) {
    if (!ob.object.mesh.triangles.empty()) continue;
    const std::string& roi = in.jobs[ob.job].name;
    throw InputError(path, (roi.empty() ? "" : "ROI '" + roi + "': ") +
                               (ob.object.label ? "label " + std::to_string(ob.object.label) : "the surface") +
                               " is empty (0 triangles): " + ob.object.empty_reason + " (" + allow_option +
                               " writes it anyway)");
  }
}

Rgb label_colour(std::size_t i) {
  const double h = std::fmod(0.13 + 0.618033988749895 * double(i), 1.0) * 6.0;
  const double x = 1.0 - std::abs(std::fmod(h, 2.0) - 1.0);
  double r = 0, g = 0, b = 0;
  switch (int(h)) {
    case 0: r = 1, g = x; break;
    case 1: r = x, g = 1; break;
    case 2: g = 1, b = x; break;
    case 3: g = x, b = 1; break;
    case 4: r = x, b = 1; break;
    default: r = 1, b = x; break;
  }
  auto c = [](double v) { return std::uint8_t(std::lround(40 + 215 * v)); };
  return {c(r), c(g), c(b)};
}

std::string with_suffix(const std::string& path, const std::string& suffix) {
  const fs::path p(path);
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

void check_labels(const Inputs& in, const std::vector<std::uint32_t>& labels, const std::string& option) {
  if (!labels.empty() && in.jobs.front().stack.kind != InputKind::Labels)
    throw ParamError(option + ": only with label input (--input labels, or an integer label volume)");
}

RunResult run_jobs(const Inputs& in, const ReconstructParams& params, const std::vector<std::uint32_t>& labels,
                   const std::function<void(const Job&, ReconstructOptions&)>& configure) {
  RunResult all;
  all.warnings = in.warnings;
  all.threads = int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  for (std::size_t j = 0; j < in.jobs.size(); ++j) {
    const Job& job = in.jobs[j];
    ReconstructOptions ropt;
    ropt.labels = labels;
    if (configure) configure(job, ropt);
    ReconstructResult r = reconstruct(job.stack, params, ropt);
    for (auto& w : r.warnings) all.warnings.push_back(job.name.empty() ? w : "ROI '" + job.name + "': " + w);
    all.times += r.times;
    for (auto& ob : r.objects) {
      RunObject out{j, std::move(ob), {}, job.color.value_or(label_colour(all.objects.size())), {}};
      out.mesh = job.stack.patient ? in_patient_space(out.object.mesh, *job.stack.patient) : out.object.mesh;
      all.objects.push_back(std::move(out));
    }
  }
  return all;
}

MeshWriteOptions run_mesh_options(const Inputs& in, bool ascii) {
  MeshWriteOptions mo;
  mo.ascii = ascii;
  if (in.jobs.front().stack.patient) {
    mo.frame = PatientFrame{};  // the meshes are in patient mm already: the identity names the space
    mo.ras = in.ras;
  } else {
    mo.scale = in.jobs.front().stack.pixel_size;
  }
  return mo;
}

bool several_outputs(const Inputs& in, const RunResult& r) {
  return in.jobs.front().stack.kind == InputKind::Labels || r.objects.size() > 1;
}

void write_run_meshes(const std::string& output, const Inputs& in, RunResult& r, const MeshWriteOptions& mo,
                      const std::function<std::string(const std::string&)>& stage) {
  auto staged = [&](const std::string& p) { return stage ? stage(p) : p; };
  const bool labels_mode = in.jobs.front().stack.kind == InputKind::Labels;
  const bool several = several_outputs(in, r);
  for (auto& o : r.objects) {
    o.file = !several ? output
             : labels_mode ? with_suffix(output, "_label" + std::to_string(o.object.label))
                           : with_suffix(output, "_" + roi_file_tag(in, o.job));
    write_mesh(staged(o.file), o.mesh, mo);
  }
  if (several) {
    std::vector<TriMesh> parts;
    std::vector<Rgb> colours;
    for (const auto& o : r.objects) parts.push_back(o.mesh), colours.push_back(o.colour);
    std::vector<Rgb> vertex_colours;
    const TriMesh combined = merge_meshes(parts, colours, &vertex_colours);
    MeshWriteOptions co = mo;
    co.colors = &vertex_colours;
    write_mesh(staged(output), combined, co);
  }
}

nlohmann::json objects_report(const Inputs& in, const RunResult& r, Method method) {
  nlohmann::json objects = nlohmann::json::array();
  for (const auto& o : r.objects) {
    const ObjectResult& ob = o.object;
    const Job& job = in.jobs[o.job];
    const double s = job.stack.pixel_size;
    nlohmann::json j = {{"label", ob.label}, {"file", o.file}};
    if (!job.name.empty()) j["roi"] = job.name;
    j["vertices"] = ob.mesh.vertices.size();
    j["triangles"] = ob.mesh.triangles.size();
    j["triangles_before_decimation"] = ob.triangles_before_decimation;
    j["slices_with_contours"] = ob.slices_with_contours;
    j["closed"] = ob.check.closed;
    j["manifold"] = ob.check.manifold;
    j["oriented"] = ob.check.oriented;
    j["components"] = ob.check.components;
    j["euler_characteristic"] = ob.check.euler;
    j["volume"] = ob.check.volume * s * s * s;
    j["area"] = ob.check.area * s * s;
    j["box_px"] = {ob.box.x0, ob.box.y0, ob.box.x1, ob.box.y1};
    if (fits_curves(method))
      j["mpu"] = {{"points", ob.fit.points},
                  {"leaves", ob.fit.leaves},
                  {"leaves_over_tol", ob.fit.leaves_over_tol},
                  {"max_depth_reached", ob.fit.max_depth_reached},
                  {"max_local_error_px", ob.fit.max_local_error},
                  {"fallback_slices", ob.fit.fallback_slices},
                  {"sign_guarded_pixels", ob.fit.sign_guarded_pixels},
                  {"sign_guarded_slices", ob.fit.sign_guarded_slices}};
    objects.push_back(std::move(j));
  }
  return objects;
}

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

}  // namespace

std::vector<VolumeRow> volume_table(const Inputs& in, const RunResult& r) {
  std::vector<VolumeRow> rows;
  for (const RunObject& o : r.objects) {
    const Job& job = in.jobs[o.job];
    const SliceStack& st = job.stack;
    const double s = st.pixel_size;
    VolumeRow row;
    row.name = !job.name.empty() ? job.name : o.object.label ? "label " + std::to_string(o.object.label) : "object";
    row.number = job.roi ? job.roi->number : int(o.object.label);
    row.volume = o.object.check.volume * s * s * s;
    row.area = o.object.check.area * s * s;
    row.planes = in.format == InputFormat::RtStruct ? int(rt_planes(st).size()) : o.object.slices_with_contours;
    row.closed = o.object.check.closed && o.object.check.manifold && o.object.check.oriented;
    if (st.has_polygons()) {
      double area = 0;
      for (const Slice& sl : st.slices) area += even_odd_area(sl.polygons);
      row.slab = area * typical_step(st) * s * s * s;
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

std::string volume_table_text(const std::vector<VolumeRow>& rows, bool patient_mm) {
  std::ostringstream o;
  const double v = patient_mm ? 1000.0 : 1.0, a = patient_mm ? 100.0 : 1.0;
  o << std::left << std::setw(24) << "ROI" << std::right << std::setw(7) << "number" << std::setw(14)
    << (patient_mm ? "volume (cc)" : "volume") << std::setw(12) << (patient_mm ? "slab (cc)" : "slab") << std::setw(16)
    << (patient_mm ? "area (cm^2)" : "area") << std::setw(8) << "planes" << std::setw(8) << "closed" << "\n";
  for (const VolumeRow& r : rows) {
    o << std::left << std::setw(24) << ("'" + r.name + "'") << std::right << std::setw(7) << r.number << std::fixed
      << std::setprecision(3) << std::setw(14) << r.volume / v << std::setw(12);
    if (r.slab > 0) o << r.slab / v;
    else o << "-";
    o << std::setw(16) << std::setprecision(2) << r.area / a << std::setw(8) << r.planes << std::setw(8)
      << (r.closed ? "yes" : "NO") << "\n";
  }
  return o.str();
}

std::string volume_table_csv(const std::vector<VolumeRow>& rows) {
  std::ostringstream o;
  o << "name,number,volume_mm3,slab_volume_mm3,area_mm2,planes,closed\n" << std::setprecision(10);
  for (const VolumeRow& r : rows) {
    std::string name = r.name;
    if (name.find_first_of(",\"\n") != std::string::npos) {
      std::string q = "\"";
      for (char c : name) q += c == '"' ? std::string("\"\"") : std::string(1, c);
      name = q + "\"";
    }
    o << name << "," << r.number << "," << r.volume << "," << r.slab << "," << r.area << "," << r.planes << ","
      << (r.closed ? "true" : "false") << "\n";
  }
  return o.str();
}

nlohmann::json volume_table_json(const std::vector<VolumeRow>& rows) {
  nlohmann::json a = nlohmann::json::array();
  for (const VolumeRow& r : rows)
    a.push_back({{"name", r.name}, {"number", r.number}, {"volume_mm3", r.volume}, {"slab_volume_mm3", r.slab},
                 {"area_mm2", r.area}, {"planes", r.planes}, {"closed", r.closed}});
  return a;
}

void write_run_rtstruct(const std::string& path, const Inputs& in, const RunResult& r) {
  if (in.format != InputFormat::RtStruct || !in.rtstruct)
    throw ParamError("an RT Structure Set out (" + path +
                     ") needs an RT Structure Set input: its patient, study and frame of reference are written back");
  std::vector<RtRoiContours> rois;
  for (const RunObject& o : r.objects) {
    const Job& job = in.jobs[o.job];
    const PatientFrame& f = *job.stack.patient;
    RtRoiContours out;
    out.roi = job.roi;
    for (const double z_mm : rt_planes(job.stack)) {  // the input's contour planes
      RtRoiContours::Plane plane;
      plane.z = z_mm;
      const double z = (z_mm - f.origin.z()) / f.axes(2, 2);  // working px (roi_stack: axis-aligned frame)
      for (const auto& loop : cut_mesh(o.object.mesh, z)) {
        std::vector<Vec2d> mm;
        for (const Vec2d& p : loop) {
          const Vec3d q = f.to_patient(Vec3d(p.x(), p.y(), z));
          mm.emplace_back(q.x(), q.y());
        }
        plane.loops.push_back(std::move(mm));
      }
      if (!plane.loops.empty()) out.planes.push_back(std::move(plane));
    }
    rois.push_back(std::move(out));
  }
  write_rtstruct(path, in.files.front(), rois, "isoloft");
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

nlohmann::json run_report(const std::string& git, const std::string& command, const Inputs& in,
                          const ReconstructParams& params, const RunResult& r, const RunSeconds& seconds,
                          const std::vector<std::string>& volume_files) {
  const auto& t = r.times;
  return {{"isoloft", {{"version", ISOLOFT_VERSION}, {"git", git}}},
          {"command", command},
          {"input", input_report(in)},
          {"params", params_to_json(params)},
          {"threads", r.threads},
          {"timings_s",
           {{"read", seconds.read},
            {"contour", t.contour},
            {"mpu", t.mpu},
            {"dist", t.dist},
            {"filter", t.filter},
            {"interp", t.interp},
            {"mesh", t.mesh},
            {"decimate", t.decimate},
            {"write", seconds.write},
            {"total", seconds.total}}},
          {"peak_memory_mib", peak_memory_mib()},
          {"objects", objects_report(in, r, params.method)},
          {"volumes", volume_table_json(volume_table(in, r))},
          {"volume_files", volume_files},
          {"warnings", r.warnings}};
}

double peak_memory_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

}  // namespace isoloft
