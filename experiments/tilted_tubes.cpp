// Question (issue 23): do thin structures that travel sideways between
// slices stay whole and in place, and do separate objects on neighbouring
// slices stay separate? Every case of the tilted-tube kit (synth/tilted_tubes.h) is
// cut into masks and reconstructed by the default method with each z scheme
// (columns: the per-column spline; track and its motion choices), scored
// against its analytic truth inside the slice range: components of the mesh,
// volume ratio (eval/volume.h, samples 0.5 px apart) and the mean two-sided
// distance (validation/hausdorff.h, as experiments/accuracy.cpp). A peer's
// meshes (ITK MorphologicalContourInterpolator, experiments/tilted_tubes_mci.py)
// are scored the same way. And what the scheme costs: reconstruct() of a real
// input with columns and with track, alternately, --runs times each
// (median wall seconds, reading excluded).
//
// usage: tilted_tubes [--out DIR] [--cases a,b] [--configs a,b] [--peer NAME=DIR] [--threads N]
//        tilted_tubes --write-masks DIR [--cases a,b]    (DIR/<case>/slice_NNN.png and z.txt, for the peers)
//        tilted_tubes --time INPUT --kind labels [--z-spacing S] [--runs N] [--name NAME] [--out DIR]
// writes DIR/tilted_tubes.{csv,json,md}, or DIR/timing_<NAME>.json
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "experiment_util.h"
#include "isoloft/eval/volume.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/png.h"
#include "isoloft/mesh/mesh_check.h"
#include "isoloft/pipeline.h"
#include "isoloft/run.h"
#include "isoloft/synth/tilted_tubes.h"
#include "validation/hausdorff.h"

using namespace isoloft;
namespace fs = std::filesystem;
using experiments::median;
using experiments::split;

namespace {

constexpr int kDefaultRuns = 5;

struct Config {
  std::string name;
  std::function<void(ReconstructParams&)> set;
};

const std::vector<Config>& all_configs() {
  static const std::vector<Config> c{
      {"columns", [](ReconstructParams&) {}},
      {"track", [](ReconstructParams& p) { p.z_scheme = "track"; }},
      {"track rule-only",
       [](ReconstructParams& p) {
         p.z_scheme = "track";
         p.track.motion = TrackMotion::RuleOnly;
       }},
      {"track auto",
       [](ReconstructParams& p) {
         p.z_scheme = "track";
         p.track.motion = TrackMotion::Auto;
       }},
      // No turn between slices (the principal axes of small masks are noisy).
      {"track no-turn",
       [](ReconstructParams& p) {
         p.z_scheme = "track";
         p.track.rotate_min_anisotropy = 1e9;
       }},
      // The baseline's exact per-slice distances: what the slice fields add.
      {"levin columns", [](ReconstructParams& p) { p = method_defaults(Method::Levin); }},
      {"levin track",
       [](ReconstructParams& p) {
         p = method_defaults(Method::Levin);
         p.z_scheme = "track";
       }},
      // Marching Cubes' plane spacing halved: what a part moving many pixels per plane needs.
      {"track z_step 0.5",
       [](ReconstructParams& p) {
         p.z_scheme = "track";
         p.interp.z_step = 0.5;
       }},
  };
  return c;
}

struct Score {
  int components = 0;
  bool closed = false;
  double volume_ratio = 0, mean = 0, seconds = 0;
  long triangles = 0;
};

Score score(const TriMesh& mesh, const TiltedCase& c) {
  Score s;
  const MeshCheck check = check_mesh(mesh);
  s.components = check.components;
  s.closed = check.closed && check.manifold && check.oriented;
  s.triangles = long(mesh.triangles.size());
  if (mesh.triangles.empty()) return s;
  s.volume_ratio = volume_ratio(mesh, *c.shape, c.width, c.height, c.slice_z.front(), c.slice_z.back());
  const TruthDistanceReport t = mesh_to_truth(mesh, *c.shape, c.slice_z.front(), c.slice_z.back());
  s.mean = 0.5 * (t.in_range.mesh_to_truth.mean + t.in_range.truth_to_mesh.mean);
  return s;
}

std::string cell(const Score& s, int true_components) {
  std::ostringstream o;
  const bool wrong = s.components != true_components;
  o << (wrong ? "**" : "") << s.components << (wrong ? "**" : "") << " / " << std::fixed << std::setprecision(2)
    << s.volume_ratio << " / " << std::setprecision(3) << s.mean;
  return o.str();
}

int write_masks(const std::string& dir, const std::vector<std::string>& cases) {
  for (const std::string& name : cases) {
    const TiltedCase c = tilted_kit_case(name);
    const SynthResult s = synthesize(c, InputKind::Masks);
    const fs::path d = fs::path(dir) / name;
    fs::create_directories(d);
    std::ofstream z(d / "z.txt");
    for (std::size_t k = 0; k < s.stack.slices.size(); ++k) {
      const Slice& sl = s.stack.slices[k];
      Grid2u8 img(sl.image.width, sl.image.height);
      for (std::size_t i = 0; i < img.size(); ++i) img.data[i] = std::uint8_t(sl.image.data[i]);
      std::ostringstream f;
      f << "slice_" << std::setw(3) << std::setfill('0') << k << ".png";
      write_png((d / f.str()).string(), img);
      z << (k ? "," : "") << sl.z;
    }
    z << "\n";
  }
  std::cerr << "wrote " << cases.size() << " cases' masks to " << dir << "\n";
  return 0;
}

// reconstruct() of every job of `input` with columns and with track,
// alternating, `runs` times each.
int time_schemes(const std::string& input, const std::string& kind, double z_spacing, int runs, const std::string& name,
                 const std::string& out) {
  InputRequest req;
  req.paths = {input};
  req.kind = kind;
  if (z_spacing > 0) req.z_spacing = z_spacing;
  const Inputs in = read_inputs(req);
  nlohmann::json j = {{"input", input}, {"runs", runs}, {"threads", tbb::global_control::active_value(
                                                                         tbb::global_control::max_allowed_parallelism)}};
  std::map<std::string, std::vector<double>> seconds, interp;
  const std::vector<std::string> schemes{"columns", "track"};
  for (int r = 0; r < runs; ++r)
    for (const std::string& scheme : schemes) {
      ReconstructParams p;
      p.z_scheme = scheme;
      const auto t0 = std::chrono::steady_clock::now();
      const RunResult rr = run_jobs(in, p, {});
      seconds[scheme].push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      interp[scheme].push_back(rr.times.interp);
      std::cerr << name << " run " << r << " " << scheme << ": " << seconds[scheme].back() << " s\n";
    }
  for (const std::string& scheme : schemes)
    j[scheme] = {{"median_s", median(seconds[scheme])}, {"runs_s", seconds[scheme]},
                 {"interp_median_s", median(interp[scheme])}};
  j["ratio_track_over_columns"] = median(seconds["track"]) / median(seconds["columns"]);
  fs::create_directories(out);
  std::ofstream(fs::path(out) / ("timing_" + name + ".json")) << j.dump(1) << "\n";
  std::cerr << name << ": track / columns = " << j["ratio_track_over_columns"] << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = "experiments/out/tilted_tubes", masks_dir, time_input, kind = "labels", name = "input";
  std::vector<std::string> cases = tilted_kit_names(), config_names{"columns", "track", "track rule-only", "track auto",
                                                                     "track z_step 0.5"};
  std::vector<std::pair<std::string, std::string>> peers;
  int threads = 0, runs = kDefaultRuns;
  double z_spacing = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--out") out = v;
    else if (a == "--cases") cases = split(v);
    else if (a == "--configs") config_names = split(v);
    else if (a == "--peer") peers.emplace_back(v.substr(0, v.find('=')), v.substr(v.find('=') + 1));
    else if (a == "--threads") threads = std::stoi(v);
    else if (a == "--write-masks") masks_dir = v;
    else if (a == "--time") time_input = v;
    else if (a == "--kind") kind = v;
    else if (a == "--z-spacing") z_spacing = std::stod(v);
    else if (a == "--runs") runs = std::stoi(v);
    else if (a == "--name") name = v;
    else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  std::unique_ptr<tbb::global_control> gc;
  if (threads > 0) gc = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  if (!masks_dir.empty()) return write_masks(masks_dir, cases);
  if (!time_input.empty()) return time_schemes(time_input, kind, z_spacing, runs, name, out);

  std::vector<Config> configs;
  for (const std::string& n : config_names) {
    const auto it = std::find_if(all_configs().begin(), all_configs().end(), [&](const Config& c) { return c.name == n; });
    if (it == all_configs().end()) {
      std::cerr << "unknown config " << n << "\n";
      return 2;
    }
    configs.push_back(*it);
  }
  std::vector<std::string> columns;
  for (const Config& c : configs) columns.push_back(c.name);
  for (const auto& [peer, dir] : peers) columns.push_back(peer);

  fs::create_directories(out);
  std::ofstream csv(fs::path(out) / "tilted_tubes.csv");
  csv << "case,true_components,system,components,closed,volume_ratio,mean_two_sided_px,triangles,seconds\n";
  nlohmann::json rows = nlohmann::json::array();
  std::map<std::string, std::map<std::string, std::string>> cells;
  std::map<std::string, int> wrong_components, volume_off, distance_over;  // per system, over the kit
  for (const std::string& name_ : cases) {
    const TiltedCase c = tilted_kit_case(name_);
    const SynthResult s = synthesize(c, InputKind::Masks);
    auto record = [&](const std::string& system, const Score& sc) {
      csv << c.name << "," << c.components << "," << system << "," << sc.components << "," << sc.closed << ","
          << sc.volume_ratio << "," << sc.mean << "," << sc.triangles << "," << sc.seconds << "\n";
      rows.push_back({{"case", c.name}, {"true_components", c.components}, {"system", system},
                      {"components", sc.components}, {"closed", sc.closed}, {"volume_ratio", sc.volume_ratio},
                      {"mean_two_sided_px", sc.mean}, {"seconds", sc.seconds}});
      cells[c.name][system] = cell(sc, c.components);
      wrong_components[system] += sc.components != c.components;
      // The targets apply to the connected structures (one component).
      if (c.components == 1) {
        volume_off[system] += std::abs(sc.volume_ratio - 1) > 0.05;
        distance_over[system] += sc.mean > 0.25;
      }
      std::cerr << c.name << " " << system << ": " << cells[c.name][system] << "\n";
    };
    for (const Config& cfg : configs) {
      ReconstructParams p;
      cfg.set(p);
      const auto t0 = std::chrono::steady_clock::now();
      ReconstructResult r = reconstruct(s.stack, p);
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      Score sc = score(r.objects.empty() ? TriMesh{} : r.objects.front().mesh, c);
      sc.seconds = secs;
      record(cfg.name, sc);
    }
    for (const auto& [peer, dir] : peers) {
      const fs::path mesh = fs::path(dir) / c.name / "mci.ply";
      if (!fs::exists(mesh)) {
        cells[c.name][peer] = "-";
        continue;
      }
      record(peer, score(read_mesh(mesh.string()), c));
    }
  }
  std::ofstream(fs::path(out) / "tilted_tubes.json") << nlohmann::json{{"rows", rows}}.dump(1) << "\n";
  std::ofstream md(fs::path(out) / "tilted_tubes.md");
  md << "Cells: components (**bold**: not the true count) / volume ratio / mean two-sided distance (px), inside the "
        "slice range. Input: masks. Default method (isoloft) unless the column says otherwise.\n\n| case (true "
        "components) |";
  for (const std::string& col : columns) md << " " << col << " |";
  md << "\n|---|";
  for (std::size_t i = 0; i < columns.size(); ++i) md << "---|";
  md << "\n";
  for (const std::string& name_ : cases) {
    const TiltedCase c = tilted_kit_case(name_);
    md << "| " << c.name << " (" << c.components << ") |";
    for (const std::string& col : columns) md << " " << (cells[c.name].count(col) ? cells[c.name][col] : "-") << " |";
    md << "\n";
  }
  md << "| wrong components / volume off by > 5 % / mean > 0.25 px (connected cases) |";
  for (const std::string& col : columns)
    md << " " << wrong_components[col] << " / " << volume_off[col] << " / " << distance_over[col] << " |";
  md << "\n";
  std::cerr << "wrote " << out << "/tilted_tubes.{csv,json,md}\n";
  return 0;
}
