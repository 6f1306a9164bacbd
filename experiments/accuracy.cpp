// Question: how close to the truth is each method, per analytic shape and z
// ratio? Every shape of synth/shapes.h is cut at z ratios 4, 8, 16 into 1-pixel
// contour images and reconstructed by marker2006 (default; without filter;
// with each spline kind), by the Levin-style baseline and by the default
// method with the track z scheme (interp/track.h), and by field3d (one 3D
// field from every slice, field3d/field3d.h; masks traced,
// field3d/image_sections.h). With --kind masks the cuts are filled masks,
// and each mesh's section on every input slice is compared with the drawn
// mask (input-slice Dice, the least over the slices). Each mesh is
// compared with the analytic surface by the validation oracles (two-sided
// distances, Hausdorff interval, normal angle), inside the slice range (caps
// are reported apart).
//
// usage: accuracy [--out DIR] [--size N] [--ratios 4,8,16] [--shapes a,b] [--configs a,b] [--threads N]
//                 [--kind contours|masks]
// writes DIR/accuracy.csv, DIR/accuracy.json, DIR/accuracy.md
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "isoloft/field3d/image_sections.h"
#include "isoloft/pipeline.h"
#include "isoloft/synth/synth.h"
#include "experiment_util.h"
#include "validation/hausdorff.h"

using namespace isoloft;
namespace fs = std::filesystem;

namespace {

struct Config {
  std::string name;
  Method method;
  SplineKind spline;
  bool filter;
  std::string z_scheme = "columns";
  std::function<void(ReconstructParams&)> tweak = {};  ///< changes to the method's defaults
};


}  // namespace

int main(int argc, char** argv) {
  std::string out = "experiments/out/accuracy";
  int size = 128, threads = 0;
  std::vector<double> ratios{4, 8, 16};
  std::vector<std::string> shapes = shape_names(), config_names;
  InputKind kind = InputKind::Contours;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--out") out = v;
    else if (a == "--size") size = std::stoi(v);
    else if (a == "--threads") threads = std::stoi(v);
    else if (a == "--ratios") {
      ratios.clear();
      for (const auto& r : experiments::split(v)) ratios.push_back(std::stod(r));
    } else if (a == "--shapes") shapes = experiments::split(v);
    else if (a == "--configs") config_names = experiments::split(v);
    else if (a == "--kind") kind = enum_from_string<InputKind>(v, "--kind");
    else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  std::unique_ptr<tbb::global_control> gc;
  if (threads > 0) gc = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  const std::vector<Config> all_configs = {
      {"isoloft", Method::Isoloft, SplineKind::ExtremumPreserving, true},
      {"marker2006", Method::Marker2006, SplineKind::Monotone, true},
      {"marker2006 no-filter", Method::Marker2006, SplineKind::Monotone, false},
      {"marker2006 extremum-preserving", Method::Marker2006, SplineKind::ExtremumPreserving, true},
      {"marker2006 catmull-rom", Method::Marker2006, SplineKind::CatmullRom, true},
      {"marker2006 natural", Method::Marker2006, SplineKind::Natural, true},
      {"marker2006 linear", Method::Marker2006, SplineKind::Linear, true},
      {"levin", Method::Levin, SplineKind::Monotone, false},
      {"isoloft track", Method::Isoloft, SplineKind::ExtremumPreserving, true, "track"},
      {"field3d", Method::Field3d, SplineKind::ExtremumPreserving, false},
      // Dropped (docs/decisions.md: label-image sections in field3d): a smoother
      // traced boundary (mask_curve sigma 1.5, margin 0.02) lost input-slice Dice.
  };
  std::vector<Config> configs;
  for (const Config& c : all_configs)
    if (config_names.empty() || std::find(config_names.begin(), config_names.end(), c.name) != config_names.end())
      configs.push_back(c);
  // "field3d:row=value:row=value": field3d with its rows changed (pixel input variants, docs/decisions.md:
  // field3d pixel input: sign constraints at pixel centres), e.g. field3d:pixel_signs=0:pixel_sigma=0.
  for (const std::string& n : config_names) {
    if (n.rfind("field3d:", 0) != 0) continue;
    std::vector<std::pair<std::string, std::string>> rows;
    std::stringstream ss(n.substr(8));
    for (std::string kv; std::getline(ss, kv, ':');) {
      const auto eq = kv.find('=');
      if (eq == std::string::npos) {
        std::cerr << "config " << n << ": expected row=value, got " << kv << "\n";
        return 2;
      }
      rows.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
    }
    configs.push_back({n, Method::Field3d, SplineKind::ExtremumPreserving, false, "columns", [rows](ReconstructParams& p) {
                         for (const auto& [row, value] : rows) params_table<Field3dParams>().set(p.field3d, row, nlohmann::json::parse(value));
                       }});
  }
  fs::create_directories(out);
  std::ofstream csv(fs::path(out) / "accuracy.csv");
  csv << "shape,ratio,method,mean_two_sided_px,mean_mesh_to_truth_px,mean_truth_to_mesh_px,p99_mesh_to_truth_px,"
         "hausdorff_lower_px,hausdorff_upper_px,normal_angle_deg,caps_mean_mesh_to_truth_px,triangles,seconds,"
         "input_slice_dice_min,input_slice_dice_mean\n";
  nlohmann::json rows = nlohmann::json::array();
  std::map<std::string, std::map<std::string, std::string>> cells;  // row key -> method -> cell
  std::vector<std::string> row_keys;
  for (const auto& shape_name : shapes) {
    for (double ratio : ratios) {
      SynthParams sp;
      sp.size = size;
      sp.z_spacing = ratio;
      sp.kind = kind;
      std::optional<SynthResult> made;
      try {
        made = synthesize(*make_default_shape(shape_name, size), sp);
      } catch (const ParamError& e) {  // e.g. the 64 px torus at 16:1 meets fewer than 2 slices: the row is left out
        std::cerr << shape_name << " " << ratio << ":1 skipped: " << e.what() << "\n";
        continue;
      }
      const SynthResult& syn = *made;
      const double z0 = syn.stack.slices.front().z, z1 = syn.stack.slices.back().z;
      std::ostringstream key;
      key << shape_name << " " << ratio << ":1";
      row_keys.push_back(key.str());
      for (const auto& c : configs) {
        ReconstructParams p = method_defaults(c.method);
        p.interp.spline = c.spline;
        p.filter.enabled = c.filter;
        p.z_scheme = c.z_scheme;
        if (c.tweak) c.tweak(p);
        const auto t0 = std::chrono::steady_clock::now();
        const ReconstructResult r = reconstruct(syn.stack, p);
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const TriMesh& mesh = r.objects.front().mesh;
        const TruthDistanceReport t = mesh_to_truth(mesh, *syn.shape, z0, z1);
        // ISOLOFT_PHASES set: the mesh vertices' signed distance to the truth (> 0 outside: a bulge) by
        // phase between input slices (bin 0 at a slice, bin 3 midway), to see where the error is.
        if (std::getenv("ISOLOFT_PHASES")) {
          constexpr int kBins = 4;
          std::array<double, kBins> sum{}, abs_sum{};
          std::array<int, kBins> n{};
          for (const auto& vf : mesh.vertices) {
            const Vec3d v = vf.template cast<double>();
            if (v.z() < z0 || v.z() > z1) continue;
            const double ph = std::fmod((v.z() - z0) / ratio, 1.0);
            const int b = int(std::floor(std::min(ph, 1.0 - ph) * 2 * kBins)) % kBins;
            const double d = syn.shape->distance(v) * (syn.shape->value(v) > 0 ? -1 : 1);
            sum[std::size_t(b)] += d;
            abs_sum[std::size_t(b)] += std::abs(d);
            ++n[std::size_t(b)];
          }
          // and the area-weighted normal angle (deg) of the faces by their centroid's phase
          std::array<double, kBins> ang{}, area{};
          for (const auto& t : mesh.triangles) {
            const Vec3d a = mesh.vertices[std::size_t(t[0])].template cast<double>(),
                        b = mesh.vertices[std::size_t(t[1])].template cast<double>(),
                        c3 = mesh.vertices[std::size_t(t[2])].template cast<double>();
            const Vec3d m = (a + b + c3) / 3, cr = (b - a).cross(c3 - a);
            if (m.z() < z0 || m.z() > z1 || cr.norm() == 0) continue;
            const double ph = std::fmod((m.z() - z0) / ratio, 1.0);
            const std::size_t bin = std::size_t(int(std::floor(std::min(ph, 1.0 - ph) * 2 * kBins)) % kBins);
            const double cosang = std::clamp(cr.normalized().dot(syn.shape->normal(syn.shape->closest_point(m))), -1.0, 1.0);
            ang[bin] += 0.5 * cr.norm() * std::acos(cosang) * 180 / M_PI;
            area[bin] += 0.5 * cr.norm();
          }
          std::cerr << "angles " << shape_name << " " << ratio << " " << c.name << ":";
          for (int b = 0; b < kBins; ++b) std::cerr << " [" << b << "] " << ang[std::size_t(b)] / std::max(1e-12, area[std::size_t(b)]);
          std::cerr << "\n";
          std::cerr << "phases " << shape_name << " " << ratio << " " << c.name << ":";
          for (int b = 0; b < kBins; ++b)
            std::cerr << " [" << b << "] " << sum[std::size_t(b)] / std::max(1, n[std::size_t(b)]) << " / "
                      << abs_sum[std::size_t(b)] / std::max(1, n[std::size_t(b)]);
          std::cerr << "\n";
        }
        // Masks: the mesh's section on every input slice against the drawn mask.
        double dice_min = 1, dice_sum = 0;
        if (kind == InputKind::Masks) {
          for (const Slice& s : syn.stack.slices) {
            PlanePose pose;
            pose.origin = Vec3d(0, 0, s.z);
            Grid2u8 drawn(s.image.width, s.image.height, 0);
            for (std::size_t i = 0; i < drawn.size(); ++i) drawn.data[i] = s.image.data[i] > syn.stack.max_value / 2;
            const double d = dice(section_pixels(mesh, pose, 1.0, drawn.width, drawn.height), drawn);
            dice_min = std::min(dice_min, d);
            dice_sum += d;
          }
        }
        const double dice_mean = dice_sum / double(std::max<std::size_t>(1, syn.stack.slices.size()));
        const auto& in = t.in_range;
        const double two_sided = 0.5 * (in.mesh_to_truth.mean + in.truth_to_mesh.mean);
        const HausdorffInterval hin{std::max(in.mesh_to_truth.max.lower, in.truth_to_mesh.max.lower),
                                    std::max(in.mesh_to_truth.max.upper, in.truth_to_mesh.max.upper)};
        csv << shape_name << "," << ratio << "," << c.name << "," << two_sided << "," << in.mesh_to_truth.mean << ","
            << in.truth_to_mesh.mean << "," << in.mesh_to_truth.p99 << "," << hin.lower << "," << hin.upper << ","
            << in.mean_normal_angle_deg << "," << t.caps.mesh_to_truth.mean << "," << mesh.triangles.size() << "," << secs
            << "," << (kind == InputKind::Masks ? dice_min : NAN) << "," << (kind == InputKind::Masks ? dice_mean : NAN)
            << "\n";
        rows.push_back({{"shape", shape_name}, {"ratio", ratio}, {"method", c.name}, {"seconds", secs}, {"report", t.to_json()}});
        if (kind == InputKind::Masks) rows.back()["input_slice_dice_min"] = dice_min;
        std::ostringstream cell;
        cell << std::fixed << std::setprecision(3) << two_sided << " / " << std::setprecision(2) << hin.lower << " / "
             << std::setprecision(1) << in.mean_normal_angle_deg;
        if (kind == InputKind::Masks) cell << " / " << std::setprecision(4) << dice_min;
        cells[key.str()][c.name] = cell.str();
        std::cerr << key.str() << " " << c.name << ": " << cell.str() << "\n";
      }
    }
  }
  std::ofstream(fs::path(out) / "accuracy.json") << nlohmann::json{{"size", size}, {"rows", rows}}.dump(1) << "\n";
  std::ofstream md(fs::path(out) / "accuracy.md");
  md << "Cells: mean two-sided distance (px) / Hausdorff distance, lower end of its interval (px) / area-weighted mean normal "
        "angle (deg), inside the slice range"
     << (kind == InputKind::Masks ? " / input-slice Dice, the least over the input slices" : "") << ". Input: " << size
     << "x" << size << (kind == InputKind::Masks ? " filled masks" : " 1-pixel contour images")
     << ", slices every `ratio` px.\n\n| shape, ratio |";
  for (const auto& c : configs) md << " " << c.name << " |";
  md << "\n|---|";
  for (std::size_t i = 0; i < configs.size(); ++i) md << "---|";
  md << "\n";
  for (const auto& k : row_keys) {
    md << "| " << k << " |";
    for (const auto& c : configs) md << " " << cells[k][c.name] << " |";
    md << "\n";
  }
  std::cerr << "wrote " << out << "/accuracy.{csv,json,md}\n";
  return 0;
}
