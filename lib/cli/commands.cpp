#include "cli/commands.h"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "cli/heap_tunables.h"
#include "isoloft/core/error.h"
#include "isoloft/io/atomic_file.h"

namespace fs = std::filesystem;

namespace isoloft::cli {

Commands::Commands(CLI::App& app, int argc, char** argv) {
  for (int i = 0; i < argc; ++i) command_line_ += (i ? " " : "") + std::string(argv[i]);

  reconstruct_ = app.add_subcommand("reconstruct", "Reconstruct closed surfaces from a slice stack");
  auto* R = reconstruct_;
  R->add_option("inputs", r_.inputs,
                "PNG slices in stack order, one directory of PNGs, one polyline text file, one label volume "
                "(.nii .nii.gz .nrrd .nhdr .mha .mhd) or one DICOM RT Structure Set (.dcm)");
  R->add_option("-o,--output", r_.output, "Output mesh: .ply (binary), .obj, .stl, .off, .vtp or .vtk (VTK: normals and labels as cell data); with labels also one file per label; .dcm: an RT Structure Set (as --rtstruct)");
  R->add_option("--input", r_.input_kind, "How to read pixels: contours (white curves), masks (filled), labels (each value an object)")
      ->check(CLI::IsMember({"contours", "masks", "labels"}));
  // PositiveNumber lets NaN through (every comparison with it is false).
  const CLI::Validator positive_finite(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || *end != '\0' || !std::isfinite(v) || !(v > 0)) return "'" + text + "' is not a finite number > 0";
        return {};
      },
      "POSITIVE", "");
  r_.z_spacing_opt = R->add_option("--z-spacing", r_.z_spacing, "Slice spacing in pixel units (default 1)")->check(positive_finite);
  r_.slice_z_opt = R->add_option("--slice-z", r_.slice_z, "Comma-separated z of every slice, pixel units (non-uniform spacing)");
  r_.pixel_size_opt = R->add_option("--pixel-size", r_.pixel_size, "Physical size of a pixel; scales x, y and z of the outputs")->check(positive_finite);
  R->add_option("--volume", r_.volume, "Write the interpolated signed distance volume (.nrrd, float, positive inside)");
  R->add_option("--labels", r_.labels, "With label input: comma-separated labels to reconstruct (default all)");
  R->add_option("--axis", r_.axis, "Volumes: the voxel axis whose slices are annotated (default: the sparse one)")
      ->check(CLI::IsMember({"i", "j", "k"}));
  R->add_option("--roi", r_.rois, "RT Structure Sets: a ROI to reconstruct, by name (repeatable; default every ROI with closed planar contours)");
  R->add_flag("--list-rois", r_.list_rois, "RT Structure Sets: print each ROI's name, number, contour count and z range, and exit");
  r_.voxel_size_opt = R->add_option("--voxel-size", r_.voxel_size, "RT Structure Sets: in-plane pixel of the working grid, mm (default 0.5)")
                          ->check(positive_finite);
  R->add_option("--space", r_.space, "Volumes and RT Structure Sets: patient space of the outputs, lps (default; DICOM, ITK, 3D Slicer files) or ras")
      ->check(CLI::IsMember({"lps", "ras"}));
  R->add_option("--labelmap", r_.labelmap, "Volumes: write the dense label map on the input's grid (.nii.gz, .nii, .nrrd, .mha): annotated slices as given, the others from the interpolated fields; with --reference, on the reference's grid");
  R->add_option("--reference", r_.reference, "With --labelmap: the grid of the label map, a reference image (a DICOM CT/MR series folder or one of its files, or .nii .nii.gz .nrrd .nhdr .mha .mhd): its size, spacing, origin and directions, one label per ROI number (RT) or label, the smallest object on top where they overlap");
  R->add_option("--rtstruct", r_.rtstruct, "RT Structure Sets: write the surfaces back as an RT Structure Set (.dcm), cut at the input's contour planes, the input's patient, study, frame of reference and ROI numbers, names and colours kept (also -o OUT.dcm); label volumes: a standalone RT Structure Set, one ROI per label (named from the label table), cut at the slices' planes (axial slices only)");
  R->add_option("--rt-point-spacing", r_.rt_point_spacing, "RT Structure Set out: step between written contour points, mm (default 0: each plane's drawn contours' mean step)")
      ->check(CLI::NonNegativeNumber);
  R->add_option("--rt-min-area", r_.rt_min_area, "RT Structure Set out: a drawn contour the surface lost is written back as drawn unless smaller than this, mm^2 (then dropped and named in a warning; default 0: none dropped)")
      ->check(CLI::NonNegativeNumber);
  R->add_option("--rt-contours", r_.rt_contours, "RT Structure Set out: write the per-contour report as .csv (each drawn contour: plane, areas drawn and written, distances, lost/merged/shrunk; sections nobody drew)");
  R->add_option("--volumes", r_.volumes, "Write the volume table (per object: name, number, volume, slab volume = contour area x spacing, area, planes, closed) as .csv or .json; RT Structure Sets also print it on stdout");
  R->add_option("--dump-stages", r_.dump_stages, "marker2006: write each slice's MPU field, distance, filtered distance, difference (NRRD) and points (CSV) here");
  R->add_option("--annotated", r_.annotated, "Label volumes annotated along several axes (--method field3d): the annotated slices per voxel axis, e.g. 'k:10,20;i:50' (every voxel of those slices drawn; 0 = outside)");
  R->add_option("--annotated-mask", r_.annotated_mask, "Label volumes annotated along several axes (--method field3d): a mask volume on the label volume's grid whose non-zero voxels mark the annotated slices (whole slices, any axis)");
  R->add_option("--label-names", r_.label_names, "Label volumes: the table naming the labels (AAL .nii.txt, FreeSurfer LUT, 3D Slicer .ctbl, ITK-SNAP label descriptions); default: such a table beside the volume (aal.nii.txt for aal.nii.gz)");
  R->add_option("--params", r_.params_file, "JSON file of parameters (see --print-params); flags override it");
  R->add_flag("--print-params", r_.print_params, "Print every parameter (defaults, --params and flags applied) as JSON with its unit, range and doc, and exit");
  R->add_option("--report", r_.report, "Write a JSON report: per-stage wall times, counts, parameters, version");
  R->add_option("--threads", r_.threads, "Worker threads (default: all cores)")->check(CLI::NonNegativeNumber);
  R->add_flag("--ascii", r_.ascii, "ASCII instead of binary PLY/STL");
  R->add_option("--max-memory", r_.max_memory,
                "Memory budget (e.g. 4G, 512M; 0 = no limit): the run stops before the work if its estimate (decoded "
                "images, fields, mesh) is larger (default 4G)");
  R->add_option("--max-output", r_.max_output,
                "Output budget (e.g. 4G; 0 = no limit): the run stops before the work if the estimated files (mesh, "
                "--volume, --labelmap, --dump-stages) are larger (default 4G)");
  R->add_option("--max-files", r_.max_files,
                "Most files a run may write (0 = no limit): one mesh per label or ROI, volumes, label map, report; "
                "the run stops before the work if it would write more")
      ->check(CLI::NonNegativeNumber);
  R->add_flag("--allow-external-data", r_.allow_external_data,
              "Volumes: read a data file that a NRRD or MetaImage header names outside the header's folder (refused "
              "by default: a header must not reach files you did not name)");
  R->add_flag("--allow-empty", r_.allow_empty, "Write a surface with no triangles instead of failing on it");
  R->add_option("--z-slab", r_.z_slab,
                "I/S: only z slab I of S (1-based, bottom up): the Marching Cubes planes between two cuts, open there "
                "and computed with a halo, so `isoloft join-slabs` welds the S parts into the one-piece surface "
                "(column methods; the mesh output only, no decimation)");
  R->add_flag("-q,--quiet", r_.quiet, "No progress display and no warnings on stderr");
  param_flags_.add_to(*R);

  synth_ = app.add_subcommand("synth", "Write an analytic test stack (contour PNGs + truth JSON)");
  synth_->add_option("shape", s_.shape,
                     "sphere, ellipsoid, torus, tilted-torus, branching-cylinders, two-blobs; oblique: tube, fork, helix, "
                     "two-spheres, two-columns, two-bars-side, two-bars-end, or an oblique kit case (--list)");
  synth_->add_option("--out", s_.out, "Output directory (slice_000.png ... and shape.json)");
  synth_->add_option("--size", s_.size, "Image width and height in pixels (default 128; not for the oblique shapes)")
      ->check(CLI::Range(8, 20000));
  synth_->add_option("--z-spacing", s_.z_spacing, "Slice spacing in pixels (the z ratio)")->check(positive_finite);
  synth_->add_option("--tilt", s_.tilt, "Oblique shapes: tube tilt, fork branch angle from the slice normal, deg (default 80)")
      ->check(CLI::Range(0.0, 89.0));
  synth_->add_option("--radius", s_.radius, "Oblique shapes: tube radius (two-spheres: sphere radius), px (default 3)")
      ->check(positive_finite);
  synth_->add_option("--gap", s_.gap, "Oblique shapes: gap between the separate objects' cross-sections, px (default 4)")
      ->check(CLI::NonNegativeNumber);
  synth_->add_option("--slices", s_.slices, "Oblique shapes: slices cut (default: the shape's)")->check(CLI::Range(2, 1000));
  synth_->add_option("--kind", s_.kind, "contours or masks (PNG images), or polylines (stack.txt)")->check(CLI::IsMember({"contours", "masks", "polylines"}));
  synth_->add_flag("--list", s_.list, "List the shapes and exit");

  batch_ = app.add_subcommand("batch", "Reconstruct a cohort: one case per manifest row on Dask distributed "
                                       "(python3 -m isoloft.cohort; `isoloft batch --help` for its options)");
  batch_->prefix_command();  // every argument goes to the Python runner, --help too
  batch_->allow_extras();
  batch_->set_help_flag();

  join_ = app.add_subcommand("join-slabs", "Join one object's z slab meshes (reconstruct --z-slab I/S, I = 1..S) into "
                                          "its surface: the cut vertices welded, the result checked closed");
  join_->add_option("parts", j_.parts, "The slab meshes, bottom up (slab 1 first)")->required();
  join_->add_option("-o,--output", j_.output, "The joined mesh (.ply, .stl, .obj, .off, .vtk, .vtp)")->required();
  join_->add_option("--report", j_.report, "Write the join's counts and checks as JSON");
  join_->add_option("--decimate-error", j_.decimate_error,
                    "Decimate the joined mesh keeping every point of it within this of the result, in the parts' "
                    "units (mm for patient-space meshes, px x --pixel-size for stacks; default 0: not decimated)")
      ->check(CLI::NonNegativeNumber);
  join_->add_flag("--allow-empty", j_.allow_empty, "Write a joined surface with no triangles instead of failing on it");

  eval_ = app.add_subcommand("eval", "Compare a mesh with an analytic truth (from isoloft synth)");
  eval_->add_option("--mesh", e_.mesh, "Mesh to evaluate")->required();
  eval_->add_option("--truth", e_.truth, "shape.json written by isoloft synth (analytic truth)");
  eval_->add_option("--reference", e_.reference, "A reference mesh: two-sided distances and CGAL's bounded-error Hausdorff distance");
  eval_->add_option("--error-bound", e_.error_bound, "Error bound of the Hausdorff computation, pixels")->check(positive_finite);
  eval_->add_option("--threshold", e_.threshold, "Hausdorff threshold for a pass/fail/undecided verdict, pixels")->check(positive_finite);
  eval_->add_option("--pixel-size", e_.pixel_size, "Pixel size the mesh was written with")->check(positive_finite);
  eval_->add_option("--report", e_.report, "Write the metrics as JSON");
}

void ParamFlags::add_to(CLI::App& app) {
  for (const auto& row : params_table<ReconstructParams>().rows()) {
    if (row.flag.empty()) continue;
    auto f = std::make_unique<Flag>();
    f->key = row.key;
    if (row.type == ParamType::Bool) {
      f->option = app.add_flag(row.flag, f->set,
                               "Sets " + row.key + " = " + (row.flag_sets ? "true" : "false") + " (" + row.doc + ")");
    } else {
      f->option = app.add_option(row.flag, f->text, describe(row) + " [" + row.key + "]");
      f->option->type_name(row.type == ParamType::Int ? "INT" : row.type == ParamType::Number ? "FLOAT" : "TEXT");
      // Checked at parse time (a usage error) by the same rule as a params file.
      const std::string key = row.key, flag = row.flag;
      f->option->check(CLI::Validator(
          [key, flag](std::string& text) -> std::string {
            const auto& r = *params_table<ReconstructParams>().find(key);
            try {
              ReconstructParams scratch;
              r.set(scratch, parse_value(r.type, text, flag), flag);
            } catch (const ParamError& e) {
              // CLI11 puts the flag in front of the message already.
              std::string m = e.what();
              if (m.rfind(flag + ": ", 0) == 0) m.erase(0, flag.size() + 2);
              return m;
            }
            return {};
          },
          row.type == ParamType::Enum ? "{" + CLI::detail::join(row.choices, ",") + "}" : "", ""));
    }
    flags_.push_back(std::move(f));
  }
}

void ParamFlags::apply(ReconstructParams& params) const {
  const auto& table = params_table<ReconstructParams>();
  for (const auto& f : flags_) {
    if (f->option->count() == 0) continue;
    const auto& row = *table.find(f->key);
    row.set(params, row.type == ParamType::Bool ? nlohmann::json(row.flag_sets) : parse_value(row.type, f->text, row.flag),
            row.flag);
  }
}

std::string ParamFlags::given(const std::string& key) const {
  for (const auto& f : flags_)
    if (f->key == key && f->option->count() > 0) return f->option->get_name(false, true);
  return {};
}

std::optional<Method> ParamFlags::method() const {
  for (const auto& f : flags_)
    if (f->key == "method" && f->option->count() > 0) {
      ReconstructParams p;
      const auto& row = *params_table<ReconstructParams>().find("method");
      row.set(p, parse_value(row.type, f->text, row.flag), row.flag);
      return p.method;
    }
  return std::nullopt;
}

int Commands::run() {
  if (reconstruct_->parsed()) return reconstruct();
  if (synth_->parsed()) return synth();
  if (eval_->parsed()) return eval();
  if (batch_->parsed()) return batch();
  if (join_->parsed()) return join_slabs();
  return 2;
}

// `isoloft batch ARGS` is `python3 -m isoloft.cohort --cli THIS ARGS` (Dask
// lives in Python): the build's package first on the path when this is the
// build tree's binary, the interpreter it was built for unless ISOLOFT_PYTHON
// names another.
int Commands::batch() {
#ifdef ISOLOFT_PYTHON_EXE
  const std::string built = ISOLOFT_PYTHON_EXE, package_dir = ISOLOFT_PYTHON_PACKAGE_DIR;
#else
  const std::string built = "python3", package_dir;
#endif
  const char* env = std::getenv("ISOLOFT_PYTHON");
  const std::string python = env && *env ? env : built;
  std::error_code ec;
  std::string self = fs::read_symlink("/proc/self/exe", ec).string();
  // The cohort's runs start through the launcher beside this binary (one start each, its heap set).
  if (!ec && fs::path(self).filename() == kCliName && fs::exists(fs::path(self).parent_path() / kLauncherName))
    self = (fs::path(self).parent_path() / kLauncherName).string();
  // The build tree's package goes first only for the binary beside it (build/isoloft,
  // build/python/isoloft): an installed copy uses the user's path as it is.
  if (!ec && !package_dir.empty() && fs::exists(fs::path(package_dir) / "isoloft" / "cohort.py") &&
      fs::equivalent(fs::path(self).parent_path(), fs::path(package_dir).parent_path(), ec)) {
    const char* old = std::getenv("PYTHONPATH");
    const std::string path = package_dir + (old && *old ? ":" + std::string(old) : "");
    setenv("PYTHONPATH", path.c_str(), 1);
  }
  ec.clear();
  std::vector<std::string> args{python, "-m", "isoloft.cohort"};
  if (!ec) args.insert(args.end(), {"--cli", self});
  for (const auto& a : batch_->remaining()) args.push_back(a);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  execvp(python.c_str(), argv.data());
  throw Error("batch: cannot run " + python + " (" + std::strerror(errno) + "); set ISOLOFT_PYTHON to a Python with isoloft");
}

}  // namespace isoloft::cli
