// isoloft reconstruct: read the input, run the pipeline per stack, write
// meshes, volumes, label map and report; all outputs appear together at the
// end, or none (OutputSet).
#include <Eigen/Dense>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>

#include "cli/commands.h"
#include "cli/inputs.h"
#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/nrrd.h"
#include "isoloft/pipeline.h"

namespace fs = std::filesystem;

namespace isoloft::cli {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Distinct colours per label: golden-ratio hue steps at full saturation.
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

std::vector<std::uint32_t> parse_labels(const std::string& text) {
  std::vector<std::uint32_t> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    double v = 0;
    try {
      std::size_t used = 0;
      v = std::stod(item, &used);
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw ParamError("--labels: '" + item + "' is not a number");
    }
    if (!(v >= 1) || v != std::floor(v) || v > double(std::numeric_limits<std::uint32_t>::max()))
      throw ParamError("--labels: " + item + " is not a positive integer label");
    out.push_back(std::uint32_t(v));
  }
  return out;
}

// Terminal progress on stderr, redrawn at most ~10 times a second.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled) {}
  void set_object(const std::string& what) { object_ = what; }
  void operator()(const std::string& stage, long done, long total) {
    if (!enabled_) return;
    std::lock_guard lock(m_);
    const auto now = Clock::now();
    if (done < total && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    std::fprintf(stderr, "\r\033[K%s %s %ld/%ld", object_.c_str(), stage.c_str(), done, total);
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\r\033[K");
  }

 private:
  bool enabled_;
  std::string object_;
  std::mutex m_;
  Clock::time_point last_{};
};

// The vertices in patient mm (LPS), triangles kept counter-clockwise seen from
// outside where the frame mirrors.
TriMesh in_patient_space(const TriMesh& m, const PatientFrame& frame) {
  TriMesh out;
  out.vertices.reserve(m.vertices.size());
  for (const Vec3f& v : m.vertices) out.vertices.push_back(frame.to_patient(v.cast<double>()).cast<float>());
  out.triangles = m.triangles;
  if (frame.axes.determinant() < 0)
    for (auto& t : out.triangles) std::swap(t[1], t[2]);
  return out;
}

// One reconstructed object and where it goes.
struct Output {
  const Job* job;
  ObjectResult object;
  TriMesh mesh;  // in output units: patient mm, or pixels times pixel_size when written
  std::string file;
  Rgb colour;
};

// Intermediate fields per slice (paper Figs. 3-5), as float NRRD + CSV.
std::function<void(const SliceStageFields&)> stage_dumper(const std::string& dir, const SliceStack& stack, OutputSet& out,
                                                          std::mutex& m) {
  fs::create_directories(dir);
  return [&, dir](const SliceStageFields& sf) {
    char stem[64];
    std::snprintf(stem, sizeof stem, "label%u_slice%03d_", sf.label, sf.slice);
    const std::string base = (fs::path(dir) / stem).string();
    const double s = stack.pixel_size;
    const std::array<double, 3> spacing{s, s, s}, origin{sf.box.x0 * s, sf.box.y0 * s, stack.slices[std::size_t(sf.slice)].z * s};
    auto write2d = [&](const std::string& name, const Grid2f& g) {
      std::string path;
      {
        std::lock_guard lock(m);
        path = out.stage(base + name + ".nrrd");
      }
      NrrdWriter w(path, g.width, g.height, 1, spacing, origin);
      w.write_plane(g);
      w.finish();
    };
    write2d("mpu", sf.mpu);
    write2d("distance", sf.distance);
    write2d("filtered", sf.filtered);
    Grid2f diff = sf.filtered;
    for (std::size_t i = 0; i < diff.size(); ++i) diff.data[i] -= sf.distance.data[i];
    write2d("difference", diff);
    std::ostringstream csv;
    csv << "x,y,nx,ny\n";
    for (std::size_t i = 0; i < sf.points.size(); ++i)
      csv << sf.points.points[i].x() + sf.box.x0 << "," << sf.points.points[i].y() + sf.box.y0 << ","
          << sf.points.normals[i].x() << "," << sf.points.normals[i].y() << "\n";
    std::lock_guard lock(m);
    write_text_atomic(out.stage(base + "points.csv"), csv.str());
  };
}

// The parameters of a --params file, on the defaults of `method` if given
// (a flag), else of the file's own "method".
ReconstructParams read_params_file(const std::string& path, std::optional<Method> method) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot open parameter file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in, nullptr, true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, std::string("not valid JSON: ") + e.what());
  }
  try {
    return params_from_json(j, method);
  } catch (const ParamError& e) {
    throw InputError(path, e.what());
  }
}

}  // namespace

int Commands::reconstruct() {
  const auto t_start = Clock::now();
  const ReconstructArgs& o = r_;

  // Parameters: the method's defaults < --params file < flags; the method
  // from --method, else the file's, else the default.
  const std::optional<Method> method_flag = param_flags_.method();
  ReconstructParams params = o.params_file.empty() ? method_defaults(method_flag.value_or(ReconstructParams{}.method))
                                                   : read_params_file(o.params_file, method_flag);
  param_flags_.apply(params);
  params_table<ReconstructParams>().validate(params);
  if (o.print_params) {
    std::cout << commented_json(params_table<ReconstructParams>(), params);
    return 0;
  }
  if (o.inputs.empty())
    throw ParamError("reconstruct: no INPUT given (PNG files, a directory, a polyline file, a volume or an RT Structure Set)");
  if (o.list_rois) {
    if (detect_input(o.inputs) != InputFormat::RtStruct) throw ParamError("--list-rois: needs a DICOM RT Structure Set");
    list_rois(o.inputs[0], std::cout);
    return 0;
  }
  if (o.output.empty()) throw ParamError("reconstruct: no output given (-o OUT.ply)");
  (void)mesh_format_from_path(o.output);  // unknown extension -> error before any work
  if (!o.volume.empty() && fs::path(o.volume).extension() != ".nrrd")
    throw ParamError("--volume: '" + o.volume + "' must end in .nrrd");
  if (!o.labelmap.empty() && !is_volume_path(o.labelmap))
    throw ParamError("--labelmap: '" + o.labelmap + "' must end in .nii.gz, .nii, .nrrd or .mha");

  std::unique_ptr<tbb::global_control> threads;
  if (o.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));
  const int thread_count = int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));

  auto t0 = Clock::now();
  Inputs in = read_inputs(o);
  const double read_seconds = seconds_since(t0);
  const std::vector<std::uint32_t> labels = o.labels.empty() ? std::vector<std::uint32_t>{} : parse_labels(o.labels);
  if (!labels.empty() && in.jobs.front().stack.kind != InputKind::Labels)
    throw ParamError("--labels: only with label input (--input labels, or an integer label volume)");
  const bool ras = o.space == "ras";
  const bool labels_mode = in.jobs.front().stack.kind == InputKind::Labels;
  Progress progress(!o.quiet && isatty(2));
  OutputSet outputs;
  std::unique_ptr<LabelmapBuilder> labelmap;
  if (!o.labelmap.empty()) labelmap = std::make_unique<LabelmapBuilder>(*in.volume, *in.slicing);

  // Run the pipeline, one stack at a time.
  ReconstructResult all;  // times and warnings summed over the jobs
  all.warnings = in.warnings;
  std::vector<Output> results;
  std::vector<std::string> volume_files;
  std::mutex dump_mutex;
  for (const Job& job : in.jobs) {
    const SliceStack& stack = job.stack;
    isoloft::ReconstructOptions ropt;
    ropt.labels = labels;
    progress.set_object(job.name);
    ropt.progress = [&](const std::string& stage, long done, long total) { progress(stage, done, total); };
    std::unique_ptr<NrrdWriter> volume;
    if (!o.volume.empty()) {
      ropt.on_plane = [&](std::uint32_t label, const Grid2f& plane, double x0, double y0, double z, int index, int count) {
        if (index == 0) {
          const std::string suffix = labels_mode ? "_label" + std::to_string(label)
                                     : in.jobs.size() > 1 ? "_" + file_safe(job.name) : "";
          const std::string path = with_suffix(o.volume, suffix);
          // The z step is uniform except possibly the last plane (snapped to the cap); record the nominal step.
          NrrdGeometry g;
          if (stack.patient) {
            g.axes = stack.patient->axes * Eigen::Vector3d(1, 1, params.interp.z_step).asDiagonal();
            const Vec3d p0 = stack.patient->to_patient(Vec3d(x0, y0, z));
            g.origin = {p0.x(), p0.y(), p0.z()};
            g.patient = true;
          } else {
            const double s = stack.pixel_size;
            g.axes = Eigen::Vector3d(s, s, s * params.interp.z_step).asDiagonal();
            g.origin = {x0 * s, y0 * s, z * s};
          }
          volume = std::make_unique<NrrdWriter>(outputs.stage(path), plane.width, plane.height, count, g);
          volume_files.push_back(path);
        }
        volume->write_plane(plane);
        if (index == count - 1) {
          volume->finish();
          volume.reset();
        }
      };
    }
    if (!o.dump_stages.empty()) ropt.on_slice_fields = stage_dumper(o.dump_stages, stack, outputs, dump_mutex);
    if (labelmap) {
      ropt.sample_z = labelmap->sample_z();
      ropt.on_sample = [&](std::uint32_t label, const Grid2f& field, const PixelBox& box, double z) {
        labelmap->add(label, field, box, z);
      };
    }
    ReconstructResult r = isoloft::reconstruct(stack, params, ropt);
    progress.finish();
    for (auto& w : r.warnings) all.warnings.push_back(job.name.empty() ? w : "ROI '" + job.name + "': " + w);
    const StageTimes& t = r.times;
    all.times.contour += t.contour, all.times.mpu += t.mpu, all.times.dist += t.dist, all.times.filter += t.filter;
    all.times.interp += t.interp, all.times.mesh += t.mesh, all.times.decimate += t.decimate;
    for (auto& ob : r.objects) {
      Output out{&job, std::move(ob), {}, {}, job.color.value_or(label_colour(results.size()))};
      out.mesh = stack.patient ? in_patient_space(out.object.mesh, *stack.patient) : out.object.mesh;
      results.push_back(std::move(out));
    }
  }
  if (!o.quiet)
    for (const auto& w : all.warnings) std::cerr << "isoloft: warning: " << w << "\n";
  if (results.empty()) throw InputError(o.inputs.front(), "nothing to reconstruct: no slice contains a contour");

  // Meshes: one object -> OUT; several -> OUT_<label or ROI> each and OUT with a colour per object.
  t0 = Clock::now();
  const bool physical = bool(in.jobs.front().stack.patient);
  MeshWriteOptions mo;
  mo.ascii = o.ascii;
  if (physical) {
    mo.frame = PatientFrame{};  // the meshes are in patient mm already: the identity names the space
    mo.ras = ras;
  } else {
    mo.scale = in.jobs.front().stack.pixel_size;
  }
  const bool several = labels_mode || results.size() > 1;
  for (auto& r : results) {
    r.file = !several ? o.output
             : labels_mode ? with_suffix(o.output, "_label" + std::to_string(r.object.label))
                           : with_suffix(o.output, "_" + file_safe(r.job->name));
    write_mesh(outputs.stage(r.file), r.mesh, mo);
  }
  if (several) {
    std::vector<TriMesh> parts;
    std::vector<Rgb> colours;
    for (const auto& r : results) parts.push_back(r.mesh), colours.push_back(r.colour);
    std::vector<Rgb> vertex_colours;
    const TriMesh combined = merge_meshes(parts, colours, &vertex_colours);
    MeshWriteOptions co = mo;
    co.colors = &vertex_colours;
    write_mesh(outputs.stage(o.output), combined, co);
  }
  if (labelmap) write_volume(outputs.stage(o.labelmap), labelmap->finish());
  const double write_seconds = seconds_since(t0);

  nlohmann::json objects = nlohmann::json::array();
  for (const auto& r : results) {
    const ObjectResult& ob = r.object;
    const double s = r.job->stack.pixel_size;
    nlohmann::json j = {{"label", ob.label}, {"file", r.file}};
    if (!r.job->name.empty()) j["roi"] = r.job->name;
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
    if (fits_curves(params.method))
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

  if (!o.report.empty()) {
    const auto& t = all.times;
    const double total = seconds_since(t_start);
    const SliceStack& first = in.jobs.front().stack;
    nlohmann::json input = {{"files", o.inputs},
                            {"format", in.format == InputFormat::Images      ? "png"
                                       : in.format == InputFormat::Polylines ? "polylines"
                                       : in.format == InputFormat::Volume    ? "volume"
                                                                             : "rtstruct"},
                            {"kind", to_string(first.kind)},
                            {"slices", first.slices.size()},
                            {"width", first.width},
                            {"height", first.height},
                            {"slice_z_px", [&] {
                               std::vector<double> z;
                               for (const auto& s : first.slices) z.push_back(s.z);
                               return z;
                             }()},
                            {"pixel_size", first.pixel_size}};
    if (physical) input["space"] = ras ? "RAS" : "LPS";
    if (in.slicing) {
      input["axis"] = std::string(1, "ijk"[in.slicing->axis]);
      input["annotated_slices"] = in.slicing->annotated;
    }
    if (in.format == InputFormat::RtStruct) {
      nlohmann::json rois = nlohmann::json::array();
      for (const auto& job : in.jobs) rois.push_back({{"name", job.name}, {"planes", job.stack.slices.size()}});
      input["rois"] = rois;
    }
    nlohmann::json report = {{"isoloft", {{"version", ISOLOFT_VERSION}, {"git", ISOLOFT_GIT}}},
                             {"command", command_line_},
                             {"input", input},
                             {"params", params_to_json(params)},
                             {"threads", thread_count},
                             {"timings_s",
                              {{"read", read_seconds},
                               {"contour", t.contour},
                               {"mpu", t.mpu},
                               {"dist", t.dist},
                               {"filter", t.filter},
                               {"interp", t.interp},
                               {"mesh", t.mesh},
                               {"decimate", t.decimate},
                               {"write", write_seconds},
                               {"total", total}}},
                             {"peak_memory_mib", peak_memory_mib()},
                             {"objects", objects},
                             {"volume_files", volume_files},
                             {"warnings", all.warnings}};
    if (labelmap) report["labelmap"] = o.labelmap;
    write_text_atomic(outputs.stage(o.report), report.dump(2) + "\n");
  }
  outputs.commit();
  if (!o.quiet) {
    for (const auto& ob : objects)
      std::cerr << "isoloft: wrote " << ob["file"].get<std::string>() << " (" << ob["triangles"] << " triangles"
                << (ob["closed"].get<bool>() && ob["manifold"].get<bool>() ? ", closed manifold" : ", NOT closed manifold")
                << ")\n";
    if (several) std::cerr << "isoloft: wrote " << o.output << " (all objects, coloured)\n";
    if (labelmap) std::cerr << "isoloft: wrote " << o.labelmap << " (dense label map)\n";
  }
  return 0;
}

}  // namespace isoloft::cli
