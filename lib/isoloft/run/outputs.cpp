#include "isoloft/run/outputs.h"

#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <optional>
#include <filesystem>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/nrrd.h"
#include "isoloft/run.h"
#include "isoloft/run/budget.h"

namespace fs = std::filesystem;

namespace isoloft {

// ---------------------------------------------------------------- naming and meshes

// A label's name in its file name: at most this many bytes (names are for
// people; the label number before it keeps files apart).
constexpr std::size_t kMaxLabelFilePart = 64;

std::string file_safe(const std::string& name) {
  std::string s;
  for (unsigned char c : name) s += std::isalnum(c) || c == '-' || c == '_' ? char(c) : '_';
  return s.empty() ? "roi" : s;
}

std::string with_suffix(const std::string& path, const std::string& suffix) {
  const fs::path p(path);
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

std::string roi_file_tag(const Inputs& in, std::size_t job) {
  const Job& j = in.jobs[job];
  const std::string tag = file_safe(j.name);
  for (std::size_t k = 0; k < in.jobs.size(); ++k)
    if (k != job && file_safe(in.jobs[k].name) == tag && j.roi) return tag + "_" + std::to_string(j.roi->number);
  return tag;
}

std::string object_suffix(const Inputs& in, std::size_t job, std::uint32_t label) {
  if (in.labels()) {
    const std::string name = in.label_name(label);  // "_label5_Precentral_L" (the number keeps names apart)
    return std::string("_label") + std::to_string(label) + (name.empty() ? "" : "_" + file_safe(name).substr(0, kMaxLabelFilePart));
  }
  return in.jobs.size() > 1 ? "_" + roi_file_tag(in, job) : "";
}

std::string object_text(const Inputs& in, const PlannedObject& o) {
  if (in.labels())
    return "label " + std::to_string(o.label) + (in.label_name(o.label).empty() ? "" : " ('" + in.label_name(o.label) + "')");
  return in.jobs[o.job].name.empty() ? "the object" : "ROI '" + in.jobs[o.job].name + "'";
}

MeshWriteOptions run_mesh_options(const Inputs& in, bool ascii) {
  MeshWriteOptions mo;
  mo.ascii = ascii;
  if (in.first().patient) {
    mo.frame = PatientFrame{};  // the meshes are in patient mm already: the identity names the space
    mo.ras = in.ras;
  } else {
    mo.scale = in.first().pixel_size;
  }
  return mo;
}

std::uint32_t object_cell_label(const RunObject& o) { return o.object.label ? o.object.label : std::uint32_t(o.job + 1); }

bool several_outputs(const Inputs& in, const RunResult& r) { return in.labels() || r.objects.size() > 1; }

namespace {

// An object's entry in the VTK files' label table: its cell label and its
// name (the ROI's, or the label's from the table); none for an input without names.
std::optional<LabelName> object_label_name(const Inputs& in, const RunObject& o) {
  const Job& job = in.jobs[o.job];
  if (job.roi) return LabelName{object_cell_label(o), job.name};
  if (in.labels() && !in.label_names.names.empty()) return LabelName{object_cell_label(o), in.label_name(o.object.label)};
  return std::nullopt;
}

}  // namespace

std::string object_display_name(const Inputs& in, const RunObject& o) {
  const Job& job = in.jobs[o.job];
  const std::string label_name = o.object.label ? in.label_name(o.object.label) : "";
  return !job.name.empty() ? job.name : !label_name.empty() ? label_name
         : o.object.label ? "label " + std::to_string(o.object.label) : "object";
}

PatientFrame placing_frame(const PatientFrame& f) {
  PatientFrame out = f;
  out.origin = f.origin + Vec3d::Zero();  // -0 + 0 = +0: a vertex at exactly 0 mm is +0 whatever its sum's sign
  return out;
}

MeshWriteOptions object_mesh_options(const Inputs& in, const RunObject& o, MeshWriteOptions mo) {
  if (mo.frame && in.jobs[o.job].stack.patient) mo.frame = placing_frame(*in.jobs[o.job].stack.patient);
  mo.label = object_cell_label(o);
  if (const auto named = object_label_name(in, o)) mo.label_names = {*named};
  return mo;
}

namespace {

// The run's objects merged in order (merge_meshes) and placed in patient mm,
// each part through its job's frame, as its own file is (object_mesh_options()):
// patient_point(), the triangles reversed where the frame mirrors.
// One object as a part of the combined PLY (write_ply_parts(),
// PlyPartWriter): placed as place_parts() places it in the merged mesh, then
// as write_mesh() writes that with `mo`.
PlyPart combined_part(const Inputs& in, std::size_t job, const MeshWriteOptions& mo, const TriMesh& mesh, Rgb colour) {
  const std::optional<PatientFrame>& patient = in.jobs[job].stack.patient;
  const std::optional<PatientFrame> part = mo.frame && patient ? std::optional(placing_frame(*patient)) : std::nullopt;
  PlyPart p{&mesh, {}, part && part->axes.determinant() < 0, colour};
  p.place = [frame = mo.frame, ras = mo.ras, scale = mo.scale, part](const Vec3f& v) -> Vec3f {
    if (frame) return patient_point(*frame, ras, part ? patient_point(*part, false, v) : v);
    return scale == 1.0 ? v : Vec3f((v.cast<double>() * scale).cast<float>());
  };
  return p;
}

void place_parts(const Inputs& in, const RunResult& r, TriMesh& combined) {
  std::vector<std::size_t> v0{0}, t0{0};
  for (const RunObject& o : r.objects)
    v0.push_back(v0.back() + o.object.mesh.vertices.size()), t0.push_back(t0.back() + o.object.mesh.triangles.size());
  tbb::parallel_for(std::size_t(0), r.objects.size(), [&](std::size_t i) {
    const std::optional<PatientFrame>& patient = in.jobs[r.objects[i].job].stack.patient;
    if (!patient) return;
    const PatientFrame f = placing_frame(*patient);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(v0[i], v0[i + 1]), [&](const tbb::blocked_range<std::size_t>& b) {
      for (std::size_t k = b.begin(); k < b.end(); ++k) combined.vertices[k] = patient_point(f, false, combined.vertices[k]);
    });
    if (f.axes.determinant() < 0)
      for (std::size_t t = t0[i]; t < t0[i + 1]; ++t) std::swap(combined.triangles[t][1], combined.triangles[t][2]);
  });
}

}  // namespace

void write_run_meshes(const std::string& output, const Inputs& in, RunResult& r, const MeshWriteOptions& mo,
                      const std::function<std::string(const std::string&)>& stage) {
  auto staged = [&](const std::string& p) { return stage ? stage(p) : p; };
  const bool several = several_outputs(in, r);
  // Paths first (staging is not thread-safe), then the files side by side.
  std::vector<std::string> paths;
  for (auto& o : r.objects) {
    o.file = several ? with_suffix(output, object_suffix(in, o.job, o.object.label)) : output;
    paths.push_back(staged(o.file));
  }
  const std::string combined_path = several ? staged(output) : std::string();
  auto write_objects = [&] {
    tbb::parallel_for(std::size_t(0), r.objects.size(), [&](std::size_t i) {
      write_mesh(paths[i], r.objects[i].object.mesh, object_mesh_options(in, r.objects[i], mo));
    });
  };
  auto write_combined = [&] {
    if (!several) return;
    if (!mo.ascii && mesh_format_from_path(output) == MeshFormat::Ply) {  // from the parts, no merged copy
      std::vector<PlyPart> parts;
      for (const auto& o : r.objects) parts.push_back(combined_part(in, o.job, mo, o.object.mesh, o.colour));
      write_ply_parts(combined_path, parts, mo.frame ? (mo.ras ? "RAS" : "LPS") : "");
      return;
    }
    std::vector<const TriMesh*> parts;
    std::vector<Rgb> colours;
    std::vector<std::uint32_t> triangle_labels;
    for (const auto& o : r.objects) {
      parts.push_back(&o.object.mesh), colours.push_back(o.colour);
      triangle_labels.insert(triangle_labels.end(), o.object.mesh.triangles.size(), object_cell_label(o));
    }
    std::vector<Rgb> vertex_colours;
    TriMesh combined = merge_meshes(parts, colours, &vertex_colours);
    if (mo.frame) place_parts(in, r, combined);  // each part through its own job's frame; `mo`'s names the space
    MeshWriteOptions co = mo;
    co.colors = &vertex_colours;
    co.triangle_labels = &triangle_labels;
    for (const auto& o : r.objects)
      if (const auto named = object_label_name(in, o)) co.label_names.push_back(*named);
    write_mesh(combined_path, combined, co);
  };
  tbb::parallel_invoke(write_objects, write_combined);
}

std::vector<std::string> save_run_meshes(const std::string& path, const std::string& option, const Inputs& in,
                                         RunResult& r, const MeshWriteOptions& mo, const std::vector<ReadFile>& reads,
                                         std::optional<std::size_t> object) {
  // The path given first (an input is named as such whatever its extension), then every file.
  check_output_paths(in, reads, {{path, "the mesh", option}}, {});
  (void)mesh_format_from_path(path);  // an unknown extension, before anything is written
  if (!object) {
    std::vector<PlannedObject> objects;
    for (const RunObject& o : r.objects) objects.push_back({o.job, o.object.label});
    std::vector<PlannedFile> planned = MeshOutput(path).planned_files(in, objects);
    for (PlannedFile& f : planned) f.option = option;
    check_output_paths(in, reads, planned, {});
  }
  OutputSet files;
  std::vector<std::string> written;
  try {
    if (object) {
      write_mesh(files.stage(path), r.objects.at(*object).object.mesh, object_mesh_options(in, r.objects[*object], mo));
      written.push_back(path);
    } else {
      write_run_meshes(path, in, r, mo, [&](const std::string& p) { return files.stage(p); });
      for (const RunObject& o : r.objects) written.push_back(o.file);
      if (several_outputs(in, r)) written.push_back(path);
    }
    files.commit();
  } catch (const ParamError& e) {
    throw ParamError(option_name(option) + " " + files.final_names(e.what()));
  } catch (const InputError& e) {
    throw InputError("", option_name(option) + " " + files.final_names(e.what()));
  } catch (const Error& e) {
    throw Error(option_name(option) + " " + files.final_names(e.what()));
  }
  return written;
}

// ---------------------------------------------------------------- output paths

namespace {

// One file on disk: device and inode (what hard and symbolic links share).
using FileId = std::pair<dev_t, ino_t>;

std::optional<FileId> file_id(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return std::nullopt;
  return FileId{st.st_dev, st.st_ino};
}

// A file the run reads, as the message names it ("the input file a.dcm").
struct ReadEntry {
  std::string text, key;
  std::optional<FileId> id;
};

void add_read(std::vector<ReadEntry>& out, const std::string& text, const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {  // a folder of slices or a DICOM series: every file in it
    for (const auto& e : fs::directory_iterator(path, ec))
      if (std::error_code rc; e.is_regular_file(rc)) add_read(out, text + " (" + path + ")", e.path().string());
    return;
  }
  out.push_back({text + " " + path, output_key(path), file_id(path)});
}

// Why a file cannot be written at `path` before any work, or "": the
// nearest existing folder above it must be writable (rename needs it too).
std::string unwritable(const std::string& path) {
  fs::path dir = fs::absolute(path).parent_path();
  std::error_code ec;
  while (!fs::exists(dir, ec) && dir.has_parent_path() && dir != dir.parent_path()) dir = dir.parent_path();
  if (!fs::is_directory(dir, ec)) return dir.string() + " is not a folder";
  if (::access(dir.c_str(), W_OK | X_OK) != 0) return "cannot write in " + dir.string() + " (" + std::strerror(errno) + ")";
  return {};
}

}  // namespace

void check_output_paths(const Inputs& in, const std::vector<ReadFile>& reads, const std::vector<PlannedFile>& files,
                        const std::vector<PlannedFile>& dirs) {
  std::vector<ReadEntry> read;
  for (const std::string& f : in.files) add_read(read, "the input", f);
  for (const std::string& f : in.data_files) add_read(read, "the input's data file", f);
  for (const ReadFile& r : reads)
    if (!r.path.empty()) add_read(read, "the " + option_name(r.option) + (r.data_file ? " file's data file" : " file"), r.path);
  auto refuse = [](const PlannedFile& f, const std::string& why) {
    return ParamError(option_name(f.option) + " " + f.path + ": " + why);
  };
  auto check_not_read = [&](const PlannedFile& f, const std::string& key, const std::optional<FileId>& id) {
    for (const ReadEntry& r : read)
      if (key == r.key || (id && id == r.id))
        throw refuse(f, "is " + r.text + "; an output never replaces a file the run reads: give another path");
  };
  for (const PlannedFile& d : dirs) {
    const OutputNode node = output_node(d.path);
    if (node != OutputNode::Missing && node != OutputNode::Directory)
      throw refuse(d, "is " + node_kind(d.path) + ", not a folder; give a folder path");
    if (node == OutputNode::Missing)
      if (const std::string why = unwritable(d.path + "/x"); !why.empty()) throw refuse(d, why);
  }
  std::map<std::string, const PlannedFile*> by_key;
  std::map<FileId, const PlannedFile*> by_id;
  for (const PlannedFile& f : files) {
    const OutputNode node = output_node(f.path);
    if (node == OutputNode::Directory || node == OutputNode::Other)
      throw refuse(f, "is " + node_kind(f.path) +
                          ", not a regular file; give a file path (a character device or FIFO, such as /dev/null, is "
                          "written in place)");
    const std::string key = output_key(f.path);
    const std::optional<FileId> id = node == OutputNode::Missing ? std::nullopt : file_id(f.path);
    check_not_read(f, key, id);
    const auto [it, fresh] = by_key.emplace(key, &f);
    const PlannedFile* other = !fresh ? it->second : nullptr;
    if (id && !other) {
      const auto [jt, new_id] = by_id.emplace(*id, &f);
      if (!new_id) other = jt->second;
    }
    if (other)
      throw ParamError(f.path + ": " + other->what + " and " + f.what +
                       " would both be written to this file; give them different names");
    if (node == OutputNode::Stream) {
      if (::access(f.path.c_str(), W_OK) != 0) throw refuse(f, std::string("cannot write (") + std::strerror(errno) + ")");
    } else if (const std::string why = unwritable(f.path); !why.empty()) {
      throw refuse(f, why);
    }
  }
}

// ---------------------------------------------------------------- hooks

void JobHooks::on_sample(std::vector<double> z, SampleHook hook) {
  std::sort(z.begin(), z.end());
  samplers_.push_back({std::move(z), std::move(hook)});
}

void JobHooks::apply(ReconstructOptions& o) const {
  if (!fields_.empty())
    o.on_slice_fields = [this](const SliceStageFields& f) {
      for (const auto& h : fields_) h(f);
    };
  if (!planes_.empty())
    o.on_plane = [this](std::uint32_t label, const Grid2f& plane, double x0, double y0, double z, int index, int count) {
      for (const auto& h : planes_) h(label, plane, x0, y0, z, index, count);
    };
  if (samplers_.empty()) return;
  o.sample_z.clear();
  for (const auto& s : samplers_) o.sample_z.insert(o.sample_z.end(), s.z.begin(), s.z.end());
  std::sort(o.sample_z.begin(), o.sample_z.end());
  o.sample_z.erase(std::unique(o.sample_z.begin(), o.sample_z.end()), o.sample_z.end());
  // The pipeline hands back the heights it was given, so each sampler finds its own exactly.
  o.on_sample = [this](std::uint32_t label, const Grid2f& field, const PixelBox& box, double z) {
    for (const auto& s : samplers_)
      if (std::binary_search(s.z.begin(), s.z.end(), z)) s.hook(label, field, box, z);
  };
}

// ---------------------------------------------------------------- -o

MeshOutput::MeshOutput(std::string path, bool ascii) : path_(std::move(path)), ascii_(ascii) {
  (void)mesh_format_from_path(path_);  // unknown extension -> error before any work
}

double MeshOutput::file_bytes(const Inputs&, const WorkEstimate& e) const {
  return e.triangles * (ascii_ ? kAsciiMeshFileBytesPerTriangle : kMeshFileBytesPerTriangle);
}

std::vector<PlannedFile> MeshOutput::planned_files(const Inputs& in, const std::vector<PlannedObject>& objects) const {
  if (!in.labels() && objects.size() <= 1) return {{path_, option()}};
  std::vector<PlannedFile> out;
  for (const PlannedObject& o : objects)
    out.push_back({with_suffix(path_, object_suffix(in, o.job, o.label)), "the mesh of " + object_text(in, o)});
  out.push_back({path_, option() + " (all objects)"});
  return out;
}

MeshOutput::~MeshOutput() = default;

bool MeshOutput::streams_objects(const Inputs& in) const {
  // Labels of an image stack: several files whatever the count, and the
  // volume table reads no mesh (its end caps are measured on polygon stacks).
  // A device or FIFO is written in place: no folder for the scratch file.
  return in.labels() && !in.first().has_polygons() && !ascii_ && mesh_format_from_path(path_) == MeshFormat::Ply &&
         output_node(path_) != OutputNode::Stream;
}

void MeshOutput::stream_object(const RunContext& ctx, std::size_t job, const ObjectResult& ob) {
  const MeshWriteOptions mo = run_mesh_options(ctx.in, ascii_);
  RunObject named{job, {}, {}, {}};
  named.object.label = ob.label;
  const std::string staged = ctx.files.stage(with_suffix(path_, object_suffix(ctx.in, job, ob.label)));
  write_mesh(staged, ob.mesh, object_mesh_options(ctx.in, named, mo));
  if (!parts_) parts_ = std::make_unique<PlyPartWriter>(fs::path(staged).parent_path().string());  // its folder exists now
  const PlyPart part = combined_part(ctx.in, job, mo, ob.mesh, {});
  spilled_[{job, ob.label}] = parts_->add(ob.mesh, part.place, part.flip);
}

void MeshOutput::object_done(const RunContext& ctx, std::size_t job, ObjectResult& ob) {
  const std::lock_guard lock(mutex_);
  if (spilled_.count({job, ob.label})) return;  // a label asked twice: written once
  stream_object(ctx, job, ob);  // the run frees the mesh after
}

void MeshOutput::finish(const RunContext& ctx, RunResult& r) {
  if (parts_) {  // streamed: the objects not yet written (methods that call no object_done()), then the join
    std::vector<std::size_t> order;
    std::vector<Rgb> colours;
    for (RunObject& o : r.objects) {
      if (!spilled_.count({o.job, o.object.label})) stream_object(ctx, o.job, o.object);
      o.file = with_suffix(path_, object_suffix(ctx.in, o.job, o.object.label));
      order.push_back(spilled_.at({o.job, o.object.label}));
      colours.push_back(o.colour);
    }
    const MeshWriteOptions mo = run_mesh_options(ctx.in, ascii_);
    parts_->write(ctx.files.stage(path_), order, colours, mo.frame ? (mo.ras ? "RAS" : "LPS") : "");
    parts_.reset();
  } else {
    write_run_meshes(path_, ctx.in, r, run_mesh_options(ctx.in, ascii_), [&](const std::string& p) { return ctx.files.stage(p); });
  }
  files_.clear();
  for (const auto& o : r.objects) files_.push_back(o.file);
  if (several_outputs(ctx.in, r)) files_.push_back(path_);
}

// ---------------------------------------------------------------- --volume

VolumeOutput::VolumeOutput(std::string path) : path_(std::move(path)) {
  if (fs::path(path_).extension() != ".nrrd")
    throw ParamError(option_name("--volume") + ": '" + path_ + "' must end in .nrrd");
}

VolumeOutput::~VolumeOutput() = default;

void VolumeOutput::start_job(const RunContext& ctx, std::size_t job, JobHooks& hooks) {
  const SliceStack& stack = ctx.in.jobs[job].stack;
  const double z_step = ctx.params.interp.z_step;
  hooks.on_plane([this, &ctx, &stack, job, z_step](std::uint32_t label, const Grid2f& plane, double x0, double y0, double z,
                                                   int index, int count) {
    // The file opens at the second plane, its step the first two planes'
    // (z_step, or a divisor of an off-grid slice spacing: mesh_planes()); the
    // step is uniform except possibly the last plane (snapped to the cap).
    if (index == 0 && count > 1) {
      first_[label] = {plane, z};
      return;
    }
    if (index <= 1) {
      const auto held = first_.find(label);
      const double z0 = index == 0 ? z : held->second.second;
      double step = index == 0 ? z_step : z - z0;
      if (std::abs(step - z_step) <= 1e-9 * z_step) step = z_step;  // the grid's own step, exactly
      const std::string path = with_suffix(path_, object_suffix(ctx.in, job, label));
      NrrdGeometry g;
      if (stack.patient) {
        g.axes = stack.patient->axes * Eigen::Vector3d(1, 1, step).asDiagonal();
        const Vec3d p0 = stack.patient->to_patient(Vec3d(x0, y0, z0));
        g.origin = {p0.x(), p0.y(), p0.z()};
        g.patient = true;
      } else {
        const double s = stack.pixel_size;
        g.axes = Eigen::Vector3d(s, s, s * step).asDiagonal();
        g.origin = {x0 * s, y0 * s, z0 * s};
      }
      writers_[label] = std::make_unique<NrrdWriter>(ctx.files.stage(path), plane.width, plane.height, count, g);
      files_.push_back(path);
      if (index == 1) {
        writers_.at(label)->write_plane(held->second.first);
        first_.erase(held);
      }
    }
    NrrdWriter& writer = *writers_.at(label);
    writer.write_plane(plane);
    if (index == count - 1) {
      writer.finish();
      writers_.erase(label);
    }
  });
}

double VolumeOutput::file_bytes(const Inputs&, const WorkEstimate& e) const { return e.planes * e.plane_bytes; }

std::vector<PlannedFile> VolumeOutput::planned_files(const Inputs& in, const std::vector<PlannedObject>& objects) const {
  std::vector<PlannedFile> out;
  for (const PlannedObject& o : objects)
    out.push_back({with_suffix(path_, object_suffix(in, o.job, o.label)), option() + " of " + object_text(in, o)});
  return out;
}

std::string VolumeOutput::budget_note() const { return " with " + option_name("--volume"); }

void VolumeOutput::report(nlohmann::json& report) const { report["volume_files"] = files_; }

// ---------------------------------------------------------------- --labelmap

LabelmapOutput::LabelmapOutput(std::string path) : path_(std::move(path)) {
  if (!is_volume_path(path_))
    throw ParamError(option_name("--labelmap") + ": '" + path_ + "' must end in .nii.gz, .nii, .nrrd or .mha");
}

LabelmapOutput::~LabelmapOutput() = default;

void LabelmapOutput::check_format(InputFormat format) const {
  if (format != InputFormat::Volume) throw ParamError(option_name("--labelmap") + ": " + kVolumeInputOnly);
}

void LabelmapOutput::start_job(const RunContext& ctx, std::size_t, JobHooks& hooks) {
  if (!builder_) builder_ = std::make_unique<LabelmapBuilder>(*ctx.in.volume, *ctx.in.slicing, ctx.in.first());
  hooks.on_sample(builder_->sample_z(), [this](std::uint32_t label, const Grid2f& field, const PixelBox& box, double z) {
    builder_->add(label, field, box, z);
  });
}

double LabelmapOutput::fixed_file_bytes(const Inputs& in) const {
  const Volume& v = *in.volume;  // its voxels may not be held (read as stored)
  return double(v.nx) * double(v.ny) * double(v.nz) * 4;
}

double LabelmapOutput::memory_bytes(const Inputs& in) const {
  const Volume& v = *in.volume;
  return double(v.nx) * double(v.ny) * double(v.nz) * kLabelmapBytesPerVoxel;
}

void LabelmapOutput::finish(const RunContext& ctx, RunResult&) {
  write_volume(ctx.files.stage(path_), builder_->finish());
  written_ = true;
}

void LabelmapOutput::report(nlohmann::json& report) const { report["labelmap"] = path_; }

std::vector<std::string> LabelmapOutput::files() const {
  return written_ ? std::vector<std::string>{path_} : std::vector<std::string>{};
}

// ---------------------------------------------------------------- --dump-stages

void StageDumpOutput::check(const Inputs&, const ReconstructParams& params) const {
  if (!fits_curves(params.method))
    throw ParamError(option_name("--dump-stages") +
                     ": has no effect here, only with a curve-fitting method (isoloft, marker2006)");
}

void StageDumpOutput::start_job(const RunContext& ctx, std::size_t job, JobHooks& hooks) {
  ctx.files.create_directories(dir_);  // taken back if the run fails
  const SliceStack& stack = ctx.in.jobs[job].stack;
  hooks.on_slice_fields([this, &ctx, &stack](const SliceStageFields& sf) {
    char stem[64];
    std::snprintf(stem, sizeof stem, "label%u_slice%03d_", sf.label, sf.slice);
    const std::string base = (fs::path(dir_) / stem).string();
    const double s = stack.pixel_size;
    const std::array<double, 3> spacing{s, s, s},
        origin{sf.box.x0 * s, sf.box.y0 * s, stack.slices[std::size_t(sf.slice)].z * s};
    auto staged = [&](const std::string& path) {
      std::lock_guard lock(mutex_);
      files_.push_back(path);
      return ctx.files.stage(path);
    };
    auto write2d = [&](const std::string& name, const Grid2f& g) {
      NrrdWriter w(staged(base + name + ".nrrd"), g.width, g.height, 1, spacing, origin);
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
    write_text_atomic(staged(base + "points.csv"), csv.str());
  });
}

double StageDumpOutput::file_bytes(const Inputs&, const WorkEstimate& e) const {
  return double(e.slices) * e.plane_bytes * 4;
}

std::vector<std::string> StageDumpOutput::files() const {
  std::vector<std::string> f = files_;
  std::sort(f.begin(), f.end());
  return f;
}

}  // namespace isoloft
