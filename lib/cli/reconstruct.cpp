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

// A parameter flag given for a method or input that never reads it: an error
// naming the flag and where it applies.
void reject_unused_flags(const ParamFlags& flags, const ReconstructArgs& o, Method method, InputFormat format,
                         InputKind kind) {
  const bool fits = fits_curves(method);
  const bool images = format == InputFormat::Images;
  struct Use {
    const char* key;
    bool used;
    const char* where;
  };
  const Use uses[] = {
      {"polyline_raster_width", fits && kind == InputKind::Polylines,
       "only with a curve-fitting method (isoloft, marker2006) and a polyline input"},
      {"sign_guard", fits, "only with a curve-fitting method (isoloft, marker2006)"},
      {"mpu.n_min", fits, "only with a curve-fitting method (isoloft, marker2006: the MPU fit)"},
      {"mpu.tol", fits, "only with a curve-fitting method (isoloft, marker2006: the MPU fit)"},
      {"extend.method", fits, "only with a curve-fitting method (isoloft, marker2006: the distance extension)"},
      {"filter.enabled", fits, "only with a curve-fitting method (isoloft, marker2006: the filter)"},
      {"fill.max_gap", images && kind == InputKind::Contours, "only with contour images (--input contours)"},
      {"fill.open_contours", images && kind == InputKind::Contours, "only with contour images (--input contours)"},
      {"binarize", images && kind != InputKind::Labels, "only with contour or mask images"},
  };
  for (const Use& u : uses)
    if (!u.used)
      if (const std::string flag = flags.given(u.key); !flag.empty()) throw ParamError(flag + ": has no effect here, " + u.where);
  if (!o.dump_stages.empty() && !fits)
    throw ParamError("--dump-stages: has no effect here, only with a curve-fitting method (isoloft, marker2006)");
}

// Bytes per triangle of a mesh file: binary STL (50, the largest binary
// format) and ASCII STL (~250, the largest text one), upper bounds for PLY,
// OBJ and OFF.
constexpr double kMeshFileBytesPerTriangle = 50, kAsciiMeshFileBytesPerTriangle = 250;

}  // namespace

int Commands::reconstruct() {
  const auto t_start = Clock::now();
  r_.max_memory_bytes = parse_size(r_.max_memory, "--max-memory");
  r_.max_output_bytes = parse_size(r_.max_output, "--max-output");
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
  // -o OUT.dcm: the RT Structure Set is the output, no mesh.
  const bool dcm_output = fs::path(o.output).extension() == ".dcm";
  const std::string rtstruct_out = dcm_output ? o.output : o.rtstruct;
  if (dcm_output && !o.rtstruct.empty()) throw ParamError("give either -o OUT.dcm or --rtstruct OUT.dcm, not both");
  if (o.output.empty()) throw ParamError("reconstruct: no output given (-o OUT.ply)");
  if (!dcm_output) (void)mesh_format_from_path(o.output);  // unknown extension -> error before any work
  if (!o.rtstruct.empty() && fs::path(o.rtstruct).extension() != ".dcm")
    throw ParamError("--rtstruct: '" + o.rtstruct + "' must end in .dcm");
  const std::string volumes_ext = fs::path(o.volumes).extension().string();
  if (!o.volumes.empty() && volumes_ext != ".csv" && volumes_ext != ".json")
    throw ParamError("--volumes: '" + o.volumes + "' must end in .csv or .json");
  if (!o.volume.empty() && fs::path(o.volume).extension() != ".nrrd")
    throw ParamError("--volume: '" + o.volume + "' must end in .nrrd");
  if (!o.labelmap.empty() && !is_volume_path(o.labelmap))
    throw ParamError("--labelmap: '" + o.labelmap + "' must end in .nii.gz, .nii, .nrrd or .mha");

  std::unique_ptr<tbb::global_control> threads;
  if (o.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));
  const int thread_count = int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));

  auto t0 = Clock::now();
  activity_ = "reading " + o.inputs.front();
  InputRequest request = input_request(o);
  request.max_memory = o.max_memory_bytes;
  Inputs in = read_inputs(request);
  const double read_seconds = seconds_since(t0);
  reject_unused_flags(param_flags_, o, params.method, in.format, in.jobs.front().stack.kind);
  if (!rtstruct_out.empty() && in.format != InputFormat::RtStruct)
    throw ParamError(std::string(dcm_output ? "-o " : "--rtstruct ") + rtstruct_out +
                     ": an RT Structure Set out needs an RT Structure Set input (its patient, study and frame of "
                     "reference are written back)");
  // The input's own footprint through the contour stage, before the work.
  const double input_bytes = isoloft::input_bytes(in);
  {
    const SliceStack& st = in.jobs.front().stack;
    check_budget("--max-memory",
                 "the contour stage of " + std::to_string(st.slices.size()) + " slices of " + std::to_string(st.width) +
                     "x" + std::to_string(st.height) + " px",
                 input_bytes, o.max_memory_bytes);
  }
  const std::vector<std::uint32_t> labels = o.labels.empty() ? std::vector<std::uint32_t>{} : parse_labels(o.labels);
  check_labels(in, labels, "--labels");
  const bool labels_mode = in.jobs.front().stack.kind == InputKind::Labels;
  Progress progress(!o.quiet && isatty(2));
  OutputSet outputs;
  std::unique_ptr<LabelmapBuilder> labelmap;
  if (!o.labelmap.empty()) labelmap = std::make_unique<LabelmapBuilder>(*in.volume, *in.slicing);

  // Run the pipeline, one stack at a time, with the per-job outputs.
  std::vector<std::string> volume_files;
  std::mutex dump_mutex;
  std::unique_ptr<NrrdWriter> volume;
  RunResult run = run_jobs(in, params, labels, [&](const Job& job, ReconstructOptions& ropt) {
    const SliceStack& stack = job.stack;
    progress.finish();
    progress.set_object(job.name);
    ropt.progress = [&](const std::string& stage, long done, long total) { progress(stage, done, total); };
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
    ropt.on_estimate = [&](const WorkEstimate& e) {
      std::ostringstream what;
      what << (job.name.empty() ? "" : "ROI '" + job.name + "': ") << (e.label ? "label " + std::to_string(e.label) : "the object")
           << " (" << e.planes << " z planes of " << e.box.width() << "x" << e.box.height() << " px, ~" << e.triangles
           << " triangles)";
      check_budget("--max-memory", what.str(), input_bytes + e.field_bytes + e.mesh_bytes, o.max_memory_bytes);
      double files = e.triangles * (o.ascii ? kAsciiMeshFileBytesPerTriangle : kMeshFileBytesPerTriangle);
      if (!o.volume.empty()) files += e.planes * e.plane_bytes;
      if (!o.dump_stages.empty()) files += double(e.slices) * e.plane_bytes * 4;
      if (labelmap) files += double(in.volume->data.size()) * 4;
      check_budget("--max-output", what.str() + (o.volume.empty() ? "" : " with --volume"), files, o.max_output_bytes);
      activity_ = "reconstructing " + what.str();
    };
    if (labelmap) {
      ropt.sample_z = labelmap->sample_z();
      ropt.on_sample = [&](std::uint32_t label, const Grid2f& field, const PixelBox& box, double z) {
        labelmap->add(label, field, box, z);
      };
    }
  });
  progress.finish();
  run.threads = thread_count;
  if (!o.quiet)
    for (const auto& w : run.warnings) std::cerr << "isoloft: warning: " << w << "\n";
  check_surfaces(in, run, o.allow_empty, "--allow-empty");
  activity_ = "writing " + o.output;

  // Meshes: one object -> OUT; several -> OUT_<label or ROI> each and OUT with a colour per object.
  t0 = Clock::now();
  if (!dcm_output)
    write_run_meshes(o.output, in, run, run_mesh_options(in, o.ascii), [&](const std::string& p) { return outputs.stage(p); });
  if (!rtstruct_out.empty()) write_run_rtstruct(outputs.stage(rtstruct_out), in, run);
  const std::vector<VolumeRow> table = volume_table(in, run);
  if (!o.volumes.empty())
    write_text_atomic(outputs.stage(o.volumes),
                      volumes_ext == ".csv" ? volume_table_csv(table) : volume_table_json(table).dump(2) + "\n");
  if (labelmap) write_volume(outputs.stage(o.labelmap), labelmap->finish());
  const double write_seconds = seconds_since(t0);

  if (!o.report.empty()) {
    nlohmann::json report = run_report(ISOLOFT_GIT, command_line_, in, params, run,
                                       {read_seconds, write_seconds, seconds_since(t_start)}, volume_files);
    if (labelmap) report["labelmap"] = o.labelmap;
    write_text_atomic(outputs.stage(o.report), report.dump(2) + "\n");
  }
  outputs.commit();
  if (in.format == InputFormat::RtStruct) std::cout << volume_table_text(table, true) << std::flush;
  if (!o.quiet) {
    if (!rtstruct_out.empty()) std::cerr << "isoloft: wrote " << rtstruct_out << " (RT Structure Set)\n";
    for (const auto& ob : run.objects)
      if (!dcm_output) std::cerr << "isoloft: wrote " << ob.file << " (" << ob.object.mesh.triangles.size() << " triangles"
                << (ob.object.check.closed && ob.object.check.manifold ? ", closed manifold" : ", NOT closed manifold")
                << ")\n";
    if (!dcm_output && several_outputs(in, run)) std::cerr << "isoloft: wrote " << o.output << " (all objects, coloured)\n";
    if (labelmap) std::cerr << "isoloft: wrote " << o.labelmap << " (dense label map)\n";
  }
  return 0;
}

}  // namespace isoloft::cli
