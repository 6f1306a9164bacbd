// isoloft reconstruct: the flags as an InputRequest and RunOptions for the
// library's run (isoloft/run.h: reading, budgets, pipeline, outputs staged
// and committed together, report), plus the terminal's progress, warnings
// and messages.
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
#include "cli/inputs.h"
#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/core/sanitize.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/methods/method.h"
#include "isoloft/pipeline.h"
#include "isoloft/run/reference_labelmap.h"
#include "isoloft/run/unused_params.h"

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

// "I/S", 1 <= I <= S: slab I - 1 of S.
ZSlab parse_z_slab(const std::string& text) {
  const std::size_t slash = text.find('/');
  unsigned long i = 0, s = 0;
  std::size_t used_i = 0, used_s = 0;
  try {
    if (slash == std::string::npos) throw std::invalid_argument(text);
    i = std::stoul(text.substr(0, slash), &used_i);
    s = std::stoul(text.substr(slash + 1), &used_s);
  } catch (const std::exception&) {
    used_i = 0;
  }
  if (used_i != slash || used_s != text.size() - slash - 1 || text[0] == '-' || text[slash + 1] == '-' || i < 1 ||
      i > s || s > kMaxZSlabs)
    throw ParamError(option_name("--z-slab") + ": '" + text + "' is not I/S with 1 <= I <= S <= " +
                     std::to_string(kMaxZSlabs));
  return ZSlab{i - 1, s};
}

// Terminal progress on stderr, redrawn at most ~10 times a second.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled) {}
  void operator()(const RunProgress& p) {
    if (!enabled_) return;
    std::lock_guard lock(m_);
    if (p.job != job_) {  // the next ROI: a fresh line
      std::fprintf(stderr, "\r\033[K");
      job_ = p.job;
    }
    const std::string object = terminal_text(p.roi);
    const std::string_view stage = p.stage;
    const long done = p.done, total = p.total;
    const auto now = Clock::now();
    if (done < total && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    std::fprintf(stderr, "\r\033[K%.*s %.*s %ld/%ld", int(object.size()), object.data(), int(stage.size()), stage.data(),
                 done, total);
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\r\033[K");
  }

 private:
  bool enabled_;
  std::size_t job_ = 0;
  std::mutex m_;
  Clock::time_point last_{};
};

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
  RunOptions run;
  run.budget = {parse_size(o.max_memory, "--max-memory"), parse_size(o.max_output, "--max-output"), o.max_files};

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
  // -o OUT.dcm: the RT Structure Set is the output, no mesh.
  const bool dcm_output = fs::path(o.output).extension() == ".dcm";
  if (dcm_output && !o.rtstruct.empty()) throw ParamError("give either -o OUT.dcm or --rtstruct OUT.dcm, not both");
  // Outputs in the order they are checked and written; each refuses a bad path before any work.
  const RtContourParams rt_params{o.rt_point_spacing, o.rt_min_area};
  if (!dcm_output && o.rtstruct.empty() && (o.rt_point_spacing > 0 || o.rt_min_area > 0 || !o.rt_contours.empty()))
    throw ParamError("--rt-point-spacing, --rt-min-area and --rt-contours: only with an RT Structure Set out (-o OUT.dcm or --rtstruct OUT.dcm)");
  if (dcm_output) run.outputs.push_back(std::make_unique<RtStructOutput>(o.output, "-o", rt_params, o.rt_contours));
  else run.outputs.push_back(std::make_unique<MeshOutput>(o.output, o.ascii));
  if (!o.rtstruct.empty())
    run.outputs.push_back(std::make_unique<RtStructOutput>(o.rtstruct, "--rtstruct", rt_params, o.rt_contours));
  if (!o.volumes.empty()) run.outputs.push_back(std::make_unique<VolumeTableOutput>(o.volumes));
  if (!o.volume.empty()) run.outputs.push_back(std::make_unique<VolumeOutput>(o.volume));
  if (!o.reference.empty() && o.labelmap.empty())
    throw ParamError(option_name("--reference") + " " + o.reference + ": gives the grid of a label map; give " +
                     option_name("--labelmap") + " OUT.nii.gz with it");
  LabelmapOutput* labelmap = nullptr;
  ReferenceLabelmapOutput* reference_labelmap = nullptr;
  if (!o.labelmap.empty() && !o.reference.empty()) {
    // The reference's headers (its voxels dropped), before the input is read.
    auto out = std::make_unique<ReferenceLabelmapOutput>(o.labelmap,
                                                        std::make_shared<const ReferenceGrid>(read_reference(o.reference)));
    reference_labelmap = out.get();
    run.outputs.push_back(std::move(out));
  } else if (!o.labelmap.empty()) {
    auto out = std::make_unique<LabelmapOutput>(o.labelmap);
    labelmap = out.get();
    run.outputs.push_back(std::move(out));
  }
  if (!o.dump_stages.empty()) run.outputs.push_back(std::make_unique<StageDumpOutput>(o.dump_stages));
  run.report_path = o.report;
  run.read_files = {{"--params", o.params_file}, {"--reference", o.reference}};
  run.allow_empty = o.allow_empty;
  if (!o.z_slab.empty()) run.z_slab = parse_z_slab(o.z_slab);
  run.free_meshes = true;  // nothing below reads a mesh, only its counts

  std::unique_ptr<tbb::global_control> threads;
  if (o.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(o.threads));

  auto t0 = Clock::now();
  activity_ = "reading " + o.inputs.front();
  InputRequest request = input_request(o);
  request.max_memory = run.budget.max_memory;
  const MethodSpec* spec = find_method(params.method.name());
  request.any_plane = spec && spec->reads_sections;
  check_outputs_format(run, detect_input(request.paths));
  const Inputs in = read_inputs(request);
  run.read_seconds = seconds_since(t0);
  refuse_unused_params([this](const std::string& key) { return param_flags_.given(key); }, params, in);
  if (!o.labels.empty()) run.labels = parse_labels(o.labels);

  Progress progress(!o.quiet && isatty(2));
  run.threads = o.threads;
  run.progress = [&](const RunProgress& p) { progress(p); };
  run.warn = [&](const std::string& w) {
    progress.finish();
    if (!o.quiet) std::cerr << "isoloft: warning: " << terminal_text(w) << "\n";
  };
  run.activity = [&](const std::string& what) { activity_ = what; };
  run.git = ISOLOFT_GIT;
  run.command = command_line_;
  run.heap = heap_;
  run.seconds_before = seconds_since(t_start);
  const RunResult result = isoloft::run(in, params, run);
  progress.finish();
  if (in.format == InputFormat::RtStruct) std::cout << volume_table_text(volume_table(in, result), true) << std::flush;
  if (!o.quiet) {
    const std::string rtstruct_out = dcm_output ? o.output : o.rtstruct;
    if (!rtstruct_out.empty()) std::cerr << "isoloft: wrote " << rtstruct_out << " (RT Structure Set)\n";
    for (const auto& ob : result.objects)
      if (!dcm_output)
        std::cerr << "isoloft: wrote " << terminal_text(ob.file) << " (" << ob.object.triangle_count() << " triangles"
                  << (ob.object.check.closed && ob.object.check.manifold ? ", closed manifold" : ", NOT closed manifold")
                  << ")\n";
    if (!dcm_output && several_outputs(in, result)) std::cerr << "isoloft: wrote " << o.output << " (all objects, coloured)\n";
    if (labelmap) std::cerr << "isoloft: wrote " << o.labelmap << " (dense label map)\n";
    if (reference_labelmap) {
      for (const auto& note : reference_labelmap->notes()) std::cerr << "isoloft: " << terminal_text(note) << "\n";
      std::cerr << "isoloft: wrote " << o.labelmap << " (label map on the grid of " << o.reference << ")\n";
    }
  }
  return 0;
}

}  // namespace isoloft::cli
