// isoloft synth / isoloft eval.
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli/commands.h"
#include "isoloft/core/error.h"
#include "isoloft/eval/metrics.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/io/png.h"
#include "isoloft/io/polylines.h"
#include "isoloft/synth/tilted_tubes.h"
#include "isoloft/synth/synth.h"
#if ISOLOFT_HAVE_VALIDATION
#include "validation/hausdorff.h"
#endif

namespace fs = std::filesystem;

namespace isoloft::cli {

int Commands::synth() {
  if (s_.list) {
    for (const auto& n : shape_names()) std::cout << n << "\n";
    for (const auto& n : tilted_shape_names()) std::cout << n << "\n";
    for (const auto& n : tilted_kit_names()) std::cout << n << "\n";
    return 0;
  }
  if (s_.shape.empty()) throw ParamError("synth: no SHAPE given (see isoloft synth --list)");
  if (s_.out.empty()) throw ParamError("synth: no --out directory given");
  SynthParams p;
  p.z_spacing = s_.z_spacing;
  p.kind = enum_from_string<InputKind>(s_.kind, "--kind");
  const std::vector<std::string> tilted = tilted_shape_names(), kit = tilted_kit_names();
  const bool is_tilted = std::find(tilted.begin(), tilted.end(), s_.shape) != tilted.end();
  const bool is_kit = std::find(kit.begin(), kit.end(), s_.shape) != kit.end();
  SynthResult r;
  if (is_tilted || is_kit) {
    if (s_.size) throw ParamError("synth --size: the tilted-tube shapes size their images to fit");
    if (is_kit && (s_.tilt || s_.radius || s_.gap || s_.slices))
      throw ParamError("synth: a kit case (" + s_.shape + ") has its own tilt, radius, gap and slices");
    TiltedOptions o;
    o.spacing = s_.z_spacing;
    o.tilt = s_.tilt.value_or(o.tilt), o.radius = s_.radius.value_or(o.radius), o.gap = s_.gap.value_or(o.gap);
    o.slices = s_.slices.value_or(0);
    const TiltedCase c = is_kit ? tilted_kit_case(s_.shape) : make_tilted_shape(s_.shape, o);
    r = synthesize(c, p.kind, p.polyline_step);
  } else {
    for (const auto& [flag, given] : {std::pair{"--tilt", bool(s_.tilt)}, {"--radius", bool(s_.radius)},
                                      {"--gap", bool(s_.gap)}, {"--slices", bool(s_.slices)}})
      if (given) throw ParamError(std::string("synth ") + flag + ": only with the tilted-tube shapes (see isoloft synth --list)");
    p.size = s_.size.value_or(p.size);
    r = synthesize(*make_default_shape(s_.shape, p.size), p);
  }
  fs::create_directories(s_.out);
  if (p.kind == InputKind::Polylines) {
    const std::string path = (fs::path(s_.out) / "stack.txt").string();
    write_polylines(path, r.stack);
    r.description["stack"]["files"] = "stack.txt";
    r.description["reconstruct_hint"] = "isoloft reconstruct " + path + " -o out.ply";
    write_text_atomic((fs::path(s_.out) / "shape.json").string(), r.description.dump(2) + "\n");
    std::cerr << "isoloft: wrote " << r.stack.slices.size() << " slices of polygons (stack.txt) and shape.json to " << s_.out << "\n";
    return 0;
  }
  for (std::size_t k = 0; k < r.stack.slices.size(); ++k) {
    const auto& s = r.stack.slices[k];
    Grid2u8 img(s.image.width, s.image.height);
    for (std::size_t i = 0; i < img.size(); ++i) img.data[i] = std::uint8_t(s.image.data[i]);
    std::ostringstream name;
    name << "slice_" << std::setw(3) << std::setfill('0') << k << ".png";
    write_png((fs::path(s_.out) / name.str()).string(), img);
  }
  r.description["stack"]["files"] = "slice_000.png ...";
  // Slice k at k z_spacing (the analytic shapes), else the slices' own z (the tilted-tube shapes).
  bool uniform = true;
  std::string slice_z;
  for (std::size_t k = 0; k < r.stack.slices.size(); ++k) {
    uniform = uniform && r.stack.slices[k].z == double(k) * s_.z_spacing;
    std::ostringstream z;
    z << r.stack.slices[k].z;
    slice_z += (k ? "," : "") + z.str();
  }
  r.description["reconstruct_hint"] = "isoloft reconstruct " + s_.out +
                                      (uniform ? " --z-spacing " + std::to_string(s_.z_spacing) : " --slice-z " + slice_z) +
                                      (p.kind == InputKind::Masks ? " --input masks" : "") + " -o out.ply";
  write_text_atomic((fs::path(s_.out) / "shape.json").string(), r.description.dump(2) + "\n");
  std::cerr << "isoloft: wrote " << r.stack.slices.size() << " slices and shape.json to " << s_.out << "\n";
  return 0;
}

int Commands::eval() {
  TriMesh mesh = read_mesh(e_.mesh);
  if (e_.pixel_size != 1.0)
    for (auto& v : mesh.vertices) v /= float(e_.pixel_size);
  nlohmann::json out = {{"mesh", e_.mesh}, {"units", "pixels"}};
  if (!e_.reference.empty()) {
#if ISOLOFT_HAVE_VALIDATION
    TriMesh ref = read_mesh(e_.reference);
    if (e_.pixel_size != 1.0)
      for (auto& v : ref.vertices) v /= float(e_.pixel_size);
    const MeshDistanceReport r = mesh_distance(mesh, ref, e_.error_bound);
    out["reference"] = e_.reference;
    out["mesh_vs_reference"] = r.to_json();
    if (e_.threshold > 0) out["verdict"] = to_string(hausdorff_verdict(r.symmetric(), e_.threshold));
#else
    throw ParamError("eval --reference needs the validation oracles (build with ISOLOFT_BUILD_VALIDATION=ON)");
#endif
  }
  if (!e_.truth.empty()) {
    std::ifstream in(e_.truth);
    if (!in) throw InputError(e_.truth, "cannot open truth file");
    nlohmann::json truth;
    try {
      truth = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(e_.truth, std::string("not valid JSON: ") + e.what());
    }
    if (!truth.contains("shape") || !truth.contains("stack")) throw InputError(e_.truth, "expected 'shape' and 'stack' (from isoloft synth)");
    std::unique_ptr<Shape> shape;
    try {
      shape = shape_from_json(truth["shape"]);
    } catch (const ParamError& e) {
      throw InputError(e_.truth, e.what());
    }
    const double z0 = truth["stack"].value("z_first", 0.0), z1 = truth["stack"].value("z_last", 0.0);
    out["truth"] = e_.truth;
#if ISOLOFT_HAVE_VALIDATION
    const TruthDistanceReport r = mesh_to_truth(mesh, *shape, z0, z1);
    out["two_sided"] = r.to_json();
    if (e_.threshold > 0) out["verdict"] = to_string(hausdorff_verdict(r.hausdorff, e_.threshold));
#endif
    out["mesh_to_truth"] = mesh_to_shape_stats(mesh, *shape, z0, z1).to_json();
  }
  if (e_.truth.empty() && e_.reference.empty()) throw ParamError("eval: give --truth SHAPE.json or --reference MESH");
  std::cout << out.dump(2) << "\n";
  if (!e_.report.empty()) write_text_atomic(e_.report, out.dump(2) + "\n");
  return 0;
}

}  // namespace isoloft::cli
