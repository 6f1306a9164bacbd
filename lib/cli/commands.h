// Options and actions of the isoloft subcommands.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace isoloft::cli {

struct ReconstructOptions {
  std::vector<std::string> inputs;
  std::string output, volume, params_file, report, input_kind = "contours", method, spline, open_contours, labels;
  double z_spacing = 1.0, pixel_size = 1.0, decimate_error = -1.0;
  std::string slice_z;
  std::string dump_stages, extend;
  int threads = 0, max_gap = -1, n_min = -1, raster_resolution = -1;
  double sign_guard = -1;
  double tol = -1.0;
  bool print_params = false, quiet = false, binarize = false, ascii = false, no_filter = false;
  CLI::Option *z_spacing_opt = nullptr, *pixel_size_opt = nullptr, *slice_z_opt = nullptr;
};

struct SynthOptions {
  std::string shape, out, kind = "contours";
  int size = 128;
  double z_spacing = 8.0;
  bool list = false;
};

struct EvalOptions {
  std::string mesh, truth, reference, report;
  double pixel_size = 1.0, error_bound = 0.05, threshold = 0;
};

class Commands {
 public:
  Commands(CLI::App& app, int argc, char** argv);
  int run();

 private:
  int reconstruct();
  int synth();
  int eval();
  CLI::App *reconstruct_ = nullptr, *synth_ = nullptr, *eval_ = nullptr;
  ReconstructOptions r_;
  SynthOptions s_;
  EvalOptions e_;
  std::string command_line_;
};

/// Writes text to `path` atomically (temp file + rename).
void write_text_atomic(const std::string& path, const std::string& text);
/// Peak resident memory of this process in MiB.
double peak_memory_mib();

}  // namespace isoloft::cli
