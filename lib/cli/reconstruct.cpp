// isoloft reconstruct: read slices, run the pipeline, write meshes, volume, report.
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

#include "cli/commands.h"
#include "isoloft/core/error.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/nrrd.h"
#include "isoloft/io/polylines.h"
#include "isoloft/io/slice_images.h"
#include "isoloft/pipeline.h"

namespace fs = std::filesystem;

namespace isoloft::cli {

namespace {

std::vector<double> parse_list(const std::string& text, const std::string& option) {
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
  }
  return v;
}

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

bool is_polyline_file(const std::vector<std::string>& inputs) {
  if (inputs.size() != 1 || fs::is_directory(inputs[0])) return false;
  const std::string ext = fs::path(inputs[0]).extension().string();
  return ext == ".txt" || ext == ".poly" || ext == ".polylines";
}

// Terminal progress on stderr, redrawn at most ~10 times a second.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled) {}
  void set_object(const std::string& what) { object_ = what; }
  void operator()(const std::string& stage, long done, long total) {
    if (!enabled_) return;
    std::lock_guard lock(m_);
    const auto now = std::chrono::steady_clock::now();
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
  std::chrono::steady_clock::time_point last_{};
};

}  // namespace

int Commands::reconstruct() {
  const auto t_start = std::chrono::steady_clock::now();
  const ReconstructArgs& o = r_;

  // Parameters: defaults < --params file < flags.
  ReconstructParams params;
  if (!o.params_file.empty()) {
    std::ifstream in(o.params_file);
    if (!in) throw InputError(o.params_file, "cannot open parameter file");
    nlohmann::json file_json;
    try {
      file_json = nlohmann::json::parse(in, nullptr, true, /*ignore_comments=*/true);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(o.params_file, std::string("not valid JSON: ") + e.what());
    }
    try {
      params = params_from_json(file_json, params);
    } catch (const ParamError& e) {
      throw InputError(o.params_file, e.what());
    }
  }
  param_flags_.apply(params);
  params_table<ReconstructParams>().validate(params);
  if (o.print_params) {
    std::cout << commented_json(params_table<ReconstructParams>(), params);
    return 0;
  }
  if (o.inputs.empty()) throw ParamError("reconstruct: no INPUT given (PNG files, a directory, or a polyline file)");
  if (o.output.empty()) throw ParamError("reconstruct: no output given (-o OUT.ply)");
  (void)mesh_format_from_path(o.output);  // unknown extension -> error before any work
  if (!o.volume.empty() && fs::path(o.volume).extension() != ".nrrd")
    throw ParamError("--volume: '" + o.volume + "' must end in .nrrd");

  std::unique_ptr<tbb::global_control> threads;
  if (o.threads > 0) threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));
  const int thread_count = int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));

  // Read the stack.
  auto t0 = std::chrono::steady_clock::now();
  SliceStack stack;
  const bool polylines = is_polyline_file(o.inputs);
  if (polylines) {
    stack = read_polylines(o.inputs[0]);
    if (o.z_spacing_opt->count() || o.slice_z_opt->count())
      throw ParamError("--z-spacing/--slice-z: a polyline file carries the z of its slices");
    if (!o.input_kind.empty()) throw ParamError("--input: a polyline file holds polygons, not images");
  } else {
    stack = read_slice_images(list_slice_files(o.inputs));
    if (!o.input_kind.empty()) stack.kind = enum_from_string<InputKind>(o.input_kind, "--input");
    if (o.slice_z_opt->count()) {
      if (o.z_spacing_opt->count()) throw ParamError("give either --z-spacing or --slice-z, not both");
      const auto z = parse_list(o.slice_z, "--slice-z");
      if (z.size() != stack.slices.size())
        throw ParamError("--slice-z has " + std::to_string(z.size()) + " values for " + std::to_string(stack.slices.size()) + " slices");
      for (std::size_t k = 0; k < z.size(); ++k) stack.slices[k].z = z[k];
    } else {
      for (std::size_t k = 0; k < stack.slices.size(); ++k) stack.slices[k].z = double(k) * o.z_spacing;
    }
  }
  if (o.pixel_size_opt->count()) stack.pixel_size = o.pixel_size;
  const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  isoloft::ReconstructOptions ropt;
  if (!o.labels.empty())
    for (double v : parse_list(o.labels, "--labels")) {
      if (v < 1 || v != std::floor(v)) throw ParamError("--labels: " + std::to_string(v) + " is not a positive integer label");
      if (v > double(std::numeric_limits<std::uint32_t>::max())) throw ParamError("--labels: " + std::to_string(v) + " is too large for a label");
      ropt.labels.push_back(std::uint32_t(v));
    }
  if (!o.labels.empty() && stack.kind != InputKind::Labels) throw ParamError("--labels: only with --input labels");
  const bool show_progress = !o.quiet && isatty(2);
  Progress progress(show_progress);
  ropt.progress = [&](const std::string& stage, long done, long total) { progress(stage, done, total); };

  // Volume: one NRRD per object, streamed plane by plane.
  const bool labels_mode = stack.kind == InputKind::Labels;
  std::unique_ptr<NrrdWriter> volume;
  std::vector<std::string> volume_files;
  if (!o.volume.empty()) {
    ropt.on_plane = [&](std::uint32_t label, const Grid2f& plane, double x0, double y0, double z, int index, int count) {
      if (index == 0) {
        const std::string path = labels_mode ? with_suffix(o.volume, "_label" + std::to_string(label)) : o.volume;
        const double s = stack.pixel_size;
        // The z step is uniform except possibly the last plane (snapped to the cap); record the nominal step.
        volume = std::make_unique<NrrdWriter>(path, plane.width, plane.height, count,
                                              std::array<double, 3>{s, s, s * params.interp.z_step},
                                              std::array<double, 3>{x0 * s, y0 * s, z * s});
        volume_files.push_back(path);
      }
      volume->write_plane(plane);
      if (index == count - 1) {
        volume->finish();
        volume.reset();
      }
    };
  }

  // Intermediate fields per slice (paper Figs. 3-5), as float NRRD + CSV.
  std::mutex dump_mutex;
  if (!o.dump_stages.empty()) {
    fs::create_directories(o.dump_stages);
    ropt.on_slice_fields = [&](const SliceStageFields& sf) {
      char stem[64];
      std::snprintf(stem, sizeof stem, "label%u_slice%03d_", sf.label, sf.slice);
      const std::string base = (fs::path(o.dump_stages) / stem).string();
      const double s = stack.pixel_size;
      const std::array<double, 3> spacing{s, s, s}, origin{sf.box.x0 * s, sf.box.y0 * s, stack.slices[std::size_t(sf.slice)].z * s};
      auto write2d = [&](const std::string& name, const Grid2f& g) {
        NrrdWriter w(base + name + ".nrrd", g.width, g.height, 1, spacing, origin);
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
        csv << sf.points.points[i].x() + sf.box.x0 << "," << sf.points.points[i].y() + sf.box.y0 << "," << sf.points.normals[i].x() << ","
            << sf.points.normals[i].y() << "\n";
      std::lock_guard lock(dump_mutex);
      write_text_atomic(base + "points.csv", csv.str());
    };
  }

  ReconstructResult result = isoloft::reconstruct(stack, params, ropt);
  progress.finish();
  if (!o.quiet)
    for (const auto& w : result.warnings) std::cerr << "isoloft: warning: " << w << "\n";
  if (result.objects.empty()) throw InputError(o.inputs.front(), "nothing to reconstruct: no slice contains a contour");

  // Write meshes (each atomically).
  t0 = std::chrono::steady_clock::now();
  nlohmann::json objects = nlohmann::json::array();
  if (labels_mode) {
    std::vector<TriMesh> parts;
    std::vector<Rgb> colours;
    for (std::size_t i = 0; i < result.objects.size(); ++i) {
      const auto& ob = result.objects[i];
      const std::string path = with_suffix(o.output, "_label" + std::to_string(ob.label));
      write_mesh(path, ob.mesh, stack.pixel_size, nullptr, o.ascii);
      parts.push_back(ob.mesh);
      colours.push_back(label_colour(i));
      objects.push_back({{"label", ob.label}, {"file", path}});
    }
    std::vector<Rgb> vertex_colours;
    const TriMesh combined = merge_meshes(parts, colours, &vertex_colours);
    write_mesh(o.output, combined, stack.pixel_size, &vertex_colours, o.ascii);
  } else {
    write_mesh(o.output, result.objects.front().mesh, stack.pixel_size, nullptr, o.ascii);
    objects.push_back({{"label", 0}, {"file", o.output}});
  }
  const double write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  for (std::size_t i = 0; i < result.objects.size(); ++i) {
    const auto& ob = result.objects[i];
    objects[i]["vertices"] = ob.mesh.vertices.size();
    objects[i]["triangles"] = ob.mesh.triangles.size();
    objects[i]["triangles_before_decimation"] = ob.triangles_before_decimation;
    objects[i]["slices_with_contours"] = ob.slices_with_contours;
    objects[i]["closed"] = ob.check.closed;
    objects[i]["manifold"] = ob.check.manifold;
    objects[i]["oriented"] = ob.check.oriented;
    objects[i]["components"] = ob.check.components;
    objects[i]["euler_characteristic"] = ob.check.euler;
    const double s3 = std::pow(stack.pixel_size, 3), s2 = stack.pixel_size * stack.pixel_size;
    objects[i]["volume"] = ob.check.volume * s3;
    objects[i]["area"] = ob.check.area * s2;
    objects[i]["box_px"] = {ob.box.x0, ob.box.y0, ob.box.x1, ob.box.y1};
    if (params.method == Method::Marker2006)
      objects[i]["mpu"] = {{"points", ob.fit.points},
                           {"leaves", ob.fit.leaves},
                           {"leaves_over_tol", ob.fit.leaves_over_tol},
                           {"max_depth_reached", ob.fit.max_depth_reached},
                           {"max_local_error_px", ob.fit.max_local_error},
                           {"fallback_slices", ob.fit.fallback_slices},
                           {"sign_guarded_pixels", ob.fit.sign_guarded_pixels},
                           {"sign_guarded_slices", ob.fit.sign_guarded_slices}};
  }
  if (!o.quiet) {
    for (const auto& ob : objects)
      std::cerr << "isoloft: wrote " << ob["file"].get<std::string>() << " (" << ob["triangles"] << " triangles"
                << (ob["closed"].get<bool>() && ob["manifold"].get<bool>() ? ", closed manifold" : ", NOT closed manifold") << ")\n";
    if (labels_mode) std::cerr << "isoloft: wrote " << o.output << " (all labels, coloured)\n";
  }

  if (!o.report.empty()) {
    const auto& t = result.times;
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    nlohmann::json report = {
        {"isoloft", {{"version", ISOLOFT_VERSION}, {"git", ISOLOFT_GIT}}},
        {"command", command_line_},
        {"input",
         {{"files", o.inputs},
          {"kind", to_string(stack.kind)},
          {"slices", stack.slices.size()},
          {"width", stack.width},
          {"height", stack.height},
          {"slice_z_px", [&] {
             std::vector<double> z;
             for (const auto& s : stack.slices) z.push_back(s.z);
             return z;
           }()},
          {"pixel_size", stack.pixel_size}}},
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
        {"warnings", result.warnings}};
    write_text_atomic(o.report, report.dump(2) + "\n");
  }
  return 0;
}

}  // namespace isoloft::cli
