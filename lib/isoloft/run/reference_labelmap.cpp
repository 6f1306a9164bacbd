#include "isoloft/run/reference_labelmap.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/atomic_file.h"
#include "isoloft/io/dicom_series.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/run.h"
#include "isoloft/run/budget.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

// Labels a float voxel holds exactly; beyond, the volume keeps a value table.
constexpr double kExactFloatLabel = double(1 << 24);

std::array<int, 2> in_plane(int a) {
  return a == 0 ? std::array<int, 2>{1, 2} : a == 1 ? std::array<int, 2>{0, 2} : std::array<int, 2>{0, 1};
}

int size_along(const Volume& g, int a) { return a == 0 ? g.nx : a == 1 ? g.ny : g.nz; }

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

std::string volume_extension(const std::string& path) {
  const std::string name = lower(fs::path(path).filename().string());
  if (name.size() > 7 && name.ends_with(".nii.gz")) return "nii.gz";
  const std::string ext = fs::path(name).extension().string();
  return ext.empty() ? "" : ext.substr(1);
}

// Bilinear read of `f` at pixel-centre coordinates (x, y); false outside the
// grid's pixel centres (beyond the crop box the field is outside anyway).
bool bilinear(const Grid2f& f, double x, double y, float& out) {
  if (f.width < 2 || f.height < 2 || !(x >= 0 && y >= 0 && x <= double(f.width - 1) && y <= double(f.height - 1)))
    return false;
  const int x0 = std::min(int(x), f.width - 2), y0 = std::min(int(y), f.height - 2);
  const double tx = x - x0, ty = y - y0;
  const double a = f(x0, y0) + tx * (f(x0 + 1, y0) - f(x0, y0)), b = f(x0, y0 + 1) + tx * (f(x0 + 1, y0 + 1) - f(x0, y0 + 1));
  out = float(a + ty * (b - a));
  return true;
}

std::string object_name(const Inputs& in, std::size_t job, std::uint32_t label) {
  const Job& j = in.jobs[job];
  if (j.roi) return "ROI '" + j.name + "' (" + std::to_string(j.roi->number) + ")";
  return label ? "label " + std::to_string(label) : "the object";
}

// The label an object gets: its ROI number, its label value, or 1 (a mask).
std::int64_t object_label(const Inputs& in, std::size_t job, std::uint32_t label) {
  if (in.jobs[job].roi) return in.jobs[job].roi->number;
  return label ? std::int64_t(label) : 1;
}

// Where a job's working pixels sit on the reference grid: working w = w0 + M ijk.
struct JobMap {
  Eigen::Vector3d w0;
  Eigen::Matrix3d m;
  int axis = 2, u = 0, v = 1;
};

JobMap job_map(const PatientFrame& f, const Volume& g) {
  JobMap jm;
  const Eigen::Matrix3d inv = f.axes.inverse();
  jm.w0 = inv * (Eigen::Map<const Eigen::Vector3d>(g.origin.data()) - f.origin);
  jm.m = inv * g.direction * Eigen::Map<const Eigen::Vector3d>(g.spacing.data()).asDiagonal();
  double tilt = 0;
  jm.axis = detail::slice_axis(g, f.axes.col(2).normalized(), tilt);
  jm.u = in_plane(jm.axis)[0], jm.v = in_plane(jm.axis)[1];
  return jm;
}

}  // namespace

// ---------------------------------------------------------------- the grid

ReferenceGrid read_reference(const std::string& path) {
  ReferenceGrid r;
  r.path = path;
  std::error_code ec;
  if (fs::is_directory(path, ec) || (fs::is_regular_file(path, ec) && is_dicom_file(path))) {
    DicomSeries s = read_dicom_series(path);
    r.grid = std::move(s.grid);
    r.format = "dicom";
    r.frame_of_reference = s.frame_of_reference;
    return r;
  }
  if (!fs::exists(path, ec)) throw InputError(path, "no such file or folder (the reference grid)");
  if (!is_volume_path(path))
    throw InputError(path, "not a reference grid: give a DICOM image series (a folder, or one of its files) or a volume "
                           "(.nii, .nii.gz, .nrrd, .nhdr, .mha, .mhd)");
  detail::check_regular_file(path);
  // The header alone: the voxels were once read (a scaled CT NIfTI decoded
  // to floats besides its bytes, 6+ bytes a voxel) before the label map's
  // budget was checked (docs/decisions.md, issue 39: --max-memory on a reference).
  VolumeReadOptions options;
  options.geometry_only = true;
  options.on_header = [&](const VolumeHeader& h) { r.data_files = h.data_files; };
  r.grid = read_volume(path, options);
  r.format = volume_extension(path);
  return r;
}

namespace detail {

int slice_axis(const Volume& grid, const Eigen::Vector3d& normal, double& tilt_mm) {
  int a = 0;
  for (int b = 1; b < 3; ++b)
    if (std::abs(grid.direction.col(b).dot(normal)) > std::abs(grid.direction.col(a).dot(normal))) a = b;
  tilt_mm = 0;
  for (const int b : in_plane(a))
    tilt_mm += std::abs(grid.direction.col(b).dot(normal)) * double(std::max(size_along(grid, b) - 1, 0)) *
               grid.spacing[std::size_t(b)];
  return a;
}

}  // namespace detail

// ---------------------------------------------------------------- the output

// One object's inside voxels on each reference slice it reaches: a
// rectangle [u0, u1) x [v0, v1) of the slice and its bits.
struct ReferenceLabelmapOutput::Object {
  struct Slice {
    int u0 = 0, v0 = 0, u1 = 0, v1 = 0;
    std::vector<bool> inside;  // a bit a voxel: every object's are held until the map is written
    [[nodiscard]] bool at(int u, int v) const {
      return u >= u0 && u < u1 && v >= v0 && v < v1 && inside[std::size_t(v - v0) * std::size_t(u1 - u0) + std::size_t(u - u0)];
    }
  };
  std::map<int, Slice> slices;  // by index along the slice axis
  std::int64_t label = 0;
  std::size_t voxels = 0;
};

ReferenceLabelmapOutput::ReferenceLabelmapOutput(std::string path, std::shared_ptr<const ReferenceGrid> reference)
    : path_(std::move(path)), ref_(std::move(reference)) {
  if (!is_volume_path(path_))
    throw ParamError(option_name("--labelmap") + ": '" + path_ + "' must end in .nii.gz, .nii, .nrrd or .mha");
  if (!ref_) throw ParamError(option_name("--labelmap") + ": no reference grid");
}

ReferenceLabelmapOutput::~ReferenceLabelmapOutput() = default;

void ReferenceLabelmapOutput::check_format(InputFormat format) const {
  if (format != InputFormat::RtStruct && format != InputFormat::Volume)
    throw ParamError(option_name("--labelmap") + " with " + option_name("--reference") +
                     ": only with an RT Structure Set or a volume input (the inputs with a patient space)");
}

void ReferenceLabelmapOutput::check(const Inputs& in, const ReconstructParams&) const {
  const std::string& ref = ref_->path;
  if (output_key(ref) == output_key(path_))
    throw ParamError(option_name("--labelmap") + " " + path_ + ": is the reference grid itself; give another file");
  if (in.rtstruct && !ref_->frame_of_reference.empty() && !in.rtstruct->frame_of_reference.empty() &&
      ref_->frame_of_reference != in.rtstruct->frame_of_reference)
    throw InputError(ref, "its FrameOfReferenceUID " + ref_->frame_of_reference + " is not the structure set's (" +
                              in.rtstruct->frame_of_reference + " in " + in.files.front() +
                              "): another patient space; give the CT the structures were drawn on");
  for (std::size_t j = 0; j < in.jobs.size(); ++j) {
    const Job& job = in.jobs[j];
    if (job.roi && (job.roi->number < 1 || double(job.roi->number) > kExactFloatLabel))
      throw InputError(in.files.front(), object_name(in, j, 0) + ": its number cannot be a label (1 .. 2^24; 0 is the background)");
    if (!job.stack.patient)
      throw ParamError(option_name("--labelmap") + " with " + option_name("--reference") + ": the input has no patient space");
    const Eigen::Vector3d normal = job.stack.patient->axes.col(2).normalized();
    double tilt = 0;
    const int a = detail::slice_axis(ref_->grid, normal, tilt);
    if (tilt > kReferenceTiltMm) {
      const auto [u, v] = in_plane(a);
      const Eigen::Vector3d plane_normal =
          ref_->grid.direction.col(u).cross(ref_->grid.direction.col(v)).normalized();
      const double degrees = std::acos(std::min(1.0, std::abs(plane_normal.dot(normal)))) * 180.0 / std::numbers::pi;
      std::ostringstream o;
      o << "its slices are tilted by " << degrees << " degrees against " << (job.roi ? object_name(in, j, 0) + "'s" : "the input's")
        << " contour planes (they leave a plane by " << tilt << " mm across the image, " << kReferenceTiltMm
        << " mm allowed): resample it to the contours' planes first";
      throw InputError(ref, o.str());
    }
  }
}

ReferenceLabelmapOutput::Object& ReferenceLabelmapOutput::object(std::size_t job, std::uint32_t label) {
  std::lock_guard lock(mutex_);
  auto& p = objects_[{job, label}];
  if (!p) p = std::make_unique<Object>();
  return *p;
}

void ReferenceLabelmapOutput::start_job(const RunContext& ctx, std::size_t job, JobHooks& hooks) {
  const Volume& g = ref_->grid;
  const JobMap jm = job_map(*ctx.in.jobs[job].stack.patient, g);
  const int n_a = size_along(g, jm.axis), n_u = size_along(g, jm.u), n_v = size_along(g, jm.v);
  // Each reference slice's working z, at its centre (the tilt across it is checked).
  auto centre = [&](int t) -> Eigen::Vector3d {
    Eigen::Vector3d ijk = Eigen::Vector3d::Zero();
    ijk[jm.axis] = t, ijk[jm.u] = 0.5 * (n_u - 1), ijk[jm.v] = 0.5 * (n_v - 1);
    return jm.w0 + jm.m * ijk;
  };
  std::vector<double> z;
  auto index = std::make_shared<std::map<double, int>>();
  for (int t = 0; t < n_a; ++t) {
    const double zt = centre(t).z();
    z.push_back(zt);
    index->emplace(zt, t);
  }
  const float iso = float(ctx.params.mc.iso);
  const Eigen::Matrix2d in_plane_map = (Eigen::Matrix2d() << jm.m(0, jm.u), jm.m(0, jm.v), jm.m(1, jm.u), jm.m(1, jm.v)).finished();
  const Eigen::Matrix2d to_voxel = in_plane_map.inverse();
  hooks.on_sample(std::move(z), [this, &ctx, job, jm, index, iso, to_voxel, n_u, n_v](std::uint32_t label, const Grid2f& field,
                                                                                    const PixelBox& box, double zw) {
    const auto it = index->find(zw);
    if (it == index->end()) return;
    const int t = it->second;
    // Working (x, y) of voxel (cu, cv) of slice t: base + in-plane map (cu, cv).
    Eigen::Vector3d ijk0 = Eigen::Vector3d::Zero();
    ijk0[jm.axis] = t;
    const Eigen::Vector2d base = (jm.w0 + jm.m * ijk0).head<2>();
    const Eigen::Vector2d du = jm.m.col(jm.u).head<2>(), dv = jm.m.col(jm.v).head<2>();
    // The voxels whose centres fall in the box.
    double ulo = INFINITY, uhi = -INFINITY, vlo = INFINITY, vhi = -INFINITY;
    for (const double x : {double(box.x0), double(box.x1 - 1)})
      for (const double y : {double(box.y0), double(box.y1 - 1)}) {
        const Eigen::Vector2d c = to_voxel * (Eigen::Vector2d(x, y) - base);
        ulo = std::min(ulo, c.x()), uhi = std::max(uhi, c.x()), vlo = std::min(vlo, c.y()), vhi = std::max(vhi, c.y());
      }
    const int u0 = std::max(0, int(std::floor(ulo))), u1 = std::min(n_u, int(std::ceil(uhi)) + 1);
    const int v0 = std::max(0, int(std::floor(vlo))), v1 = std::min(n_v, int(std::ceil(vhi)) + 1);
    if (u1 <= u0 || v1 <= v0) return;
    Object::Slice s;
    s.u0 = u0, s.u1 = u1, s.v0 = v0, s.v1 = v1;
    s.inside.assign(std::size_t(u1 - u0) * std::size_t(v1 - v0), false);
    std::size_t count = 0;
    for (int cv = v0; cv < v1; ++cv)
      for (int cu = u0; cu < u1; ++cu) {
        const Eigen::Vector2d w = base + du * cu + dv * cv;
        float f = 0;
        if (bilinear(field, w.x() - box.x0, w.y() - box.y0, f) && f > iso) {
          s.inside[std::size_t(cv - v0) * std::size_t(u1 - u0) + std::size_t(cu - u0)] = true;
          ++count;
        }
      }
    if (count == 0) return;
    Object& o = object(job, label);
    o.label = object_label(ctx.in, job, label);
    o.voxels += count;
    o.slices[t] = std::move(s);
  });
}

double ReferenceLabelmapOutput::fixed_file_bytes(const Inputs&) const {
  const Volume& g = ref_->grid;
  return double(g.nx) * double(g.ny) * double(g.nz) * 4;
}

// kLabelmapBytesPerVoxel's byte for the objects' inside voxels: held as
// bits, it covers eight objects that each span the whole grid.
double ReferenceLabelmapOutput::memory_bytes(const Inputs&) const {
  const Volume& g = ref_->grid;
  return double(g.nx) * double(g.ny) * double(g.nz) * kLabelmapBytesPerVoxel;
}

std::vector<ReadFile> ReferenceLabelmapOutput::read_files() const {
  std::vector<ReadFile> out{{"--reference", ref_->path}};
  for (const std::string& f : ref_->data_files) out.push_back({"--reference", f, true});
  return out;
}

void ReferenceLabelmapOutput::finish(const RunContext& ctx, RunResult& r) {
  const Volume& g = ref_->grid;
  const double voxel_mm3 = g.spacing[0] * g.spacing[1] * g.spacing[2];
  // The objects, smallest surface volume first (ties: in run order).
  struct Entry {
    const RunObject* run;
    const Object* object;
    double volume;
  };
  std::vector<Entry> entries;
  for (const RunObject& o : r.objects) {
    const double s = ctx.in.jobs[o.job].stack.pixel_size;
    const auto it = objects_.find({o.job, o.object.label});
    entries.push_back({&o, it == objects_.end() ? nullptr : it->second.get(), o.object.check.volume * s * s * s});
  }
  std::stable_sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.volume < b.volume; });

  Volume out = g;
  out.integer = true;
  out.warnings.clear();
  out.value_table.clear();
  out.data.assign(std::size_t(g.nx) * std::size_t(g.ny) * std::size_t(g.nz), 0.0f);
  std::vector<std::int64_t> labels;
  for (const Entry& e : entries) labels.push_back(object_label(ctx.in, e.run->job, e.run->object.label));
  const bool table = std::any_of(labels.begin(), labels.end(), [](std::int64_t l) { return double(l) > kExactFloatLabel; });
  if (table) {
    out.value_table = labels;
    out.value_table.push_back(0);
    std::sort(out.value_table.begin(), out.value_table.end());
    out.value_table.erase(std::unique(out.value_table.begin(), out.value_table.end()), out.value_table.end());
  }
  auto stored = [&](std::int64_t l) {
    return table ? float(std::lower_bound(out.value_table.begin(), out.value_table.end(), l) - out.value_table.begin())
                 : float(l);
  };
  auto voxel = [&](int axis, int t, int u, int v) {
    std::array<int, 3> ijk{};
    ijk[std::size_t(axis)] = t, ijk[std::size_t(in_plane(axis)[0])] = u, ijk[std::size_t(in_plane(axis)[1])] = v;
    return out.index(ijk[0], ijk[1], ijk[2]);
  };
  // Every job shares one slice axis unless their frames differ; each object keeps its own.
  std::vector<int> axes(entries.size(), 2);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    double tilt = 0;
    axes[i] = detail::slice_axis(g, ctx.in.jobs[entries[i].run->job].stack.patient->axes.col(2).normalized(), tilt);
  }
  // f(voxel index) for every inside voxel of entry i.
  auto each_inside = [&](std::size_t i, const auto& f) {
    if (const Object* o = entries[i].object)
      for (const auto& [t, s] : o->slices)
        for (int v = s.v0; v < s.v1; ++v)
          for (int u = s.u0; u < s.u1; ++u)
            if (s.at(u, v)) f(voxel(axes[i], t, u, v));
  };
  // Paint the largest first, so the smallest is on top; then count what each kept.
  for (std::size_t i = entries.size(); i-- > 0;) each_inside(i, [&, value = stored(labels[i])](std::size_t x) { out.data[x] = value; });
  std::vector<std::size_t> labelled(entries.size(), 0);
  for (std::size_t i = 0; i < entries.size(); ++i)
    each_inside(i, [&, value = stored(labels[i])](std::size_t x) { labelled[i] += out.data[x] == value; });
  // Overlaps: the voxels each pair shares (same slice axis: one frame).
  labels_ = nlohmann::json::array();
  overlaps_ = nlohmann::json::array();
  notes_.clear();
  for (std::size_t i = 0; i < entries.size(); ++i)
    for (std::size_t k = i + 1; k < entries.size(); ++k) {
      const Object *a = entries[i].object, *b = entries[k].object;
      if (!a || !b || axes[i] != axes[k]) continue;
      std::size_t shared = 0;
      for (const auto& [t, sa] : a->slices) {
        const auto it = b->slices.find(t);
        if (it == b->slices.end()) continue;
        const auto& sb = it->second;
        for (int v = std::max(sa.v0, sb.v0); v < std::min(sa.v1, sb.v1); ++v)
          for (int u = std::max(sa.u0, sb.u0); u < std::min(sa.u1, sb.u1); ++u) shared += sa.at(u, v) && sb.at(u, v);
      }
      if (shared == 0) continue;
      const std::string small = object_name(ctx.in, entries[i].run->job, entries[i].run->object.label),
                        large = object_name(ctx.in, entries[k].run->job, entries[k].run->object.label);
      overlaps_.push_back({{"smaller", small}, {"larger", large}, {"label", labels[i]}, {"voxels", shared},
                           {"volume_mm3", double(shared) * voxel_mm3}});
      std::ostringstream o;
      o << path_ << ": " << small << " and " << large << " share " << shared << " voxels (" << double(shared) * voxel_mm3 / 1000
        << " cc): labelled " << labels[i] << " (the smaller)";
      notes_.push_back(o.str());
    }
  // Objects reaching beyond the grid: their surface's voxel extent.
  const Eigen::Matrix3d to_ijk =
      (g.direction * Eigen::Map<const Eigen::Vector3d>(g.spacing.data()).asDiagonal()).inverse();
  const Eigen::Vector3d origin = Eigen::Map<const Eigen::Vector3d>(g.origin.data());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const RunObject& ro = *entries[i].run;
    const std::string name = object_name(ctx.in, ro.job, ro.object.label);
    bool beyond = false;
    const PatientFrame& frame = *ctx.in.jobs[ro.job].stack.patient;
    for (const auto& v : ro.object.mesh.vertices) {  // placed as the mesh writers place them
      const Eigen::Vector3d ijk = to_ijk * (patient_point(frame, false, v).cast<double>() - origin);
      for (int a = 0; a < 3; ++a) beyond |= ijk[a] < -0.5 || ijk[a] > size_along(g, a) - 0.5;
      if (beyond) break;
    }
    if (beyond) notes_.push_back(path_ + ": " + name + " reaches beyond the reference grid: cut at its edge");
    const std::size_t inside = entries[i].object ? entries[i].object->voxels : 0;
    if (inside == 0) notes_.push_back(path_ + ": " + name + " covers no voxel centre of the reference grid");
    labels_.push_back({{"object", name},
                       {"label", labels[i]},
                       {"inside_voxels", inside},
                       {"labelled_voxels", labelled[i]},
                       {"labelled_volume_mm3", double(labelled[i]) * voxel_mm3},
                       {"inside_volume_mm3", double(inside) * voxel_mm3},
                       {"surface_volume_mm3", entries[i].volume},
                       {"beyond_grid", beyond}});
  }
  write_volume(ctx.files.stage(path_), out);
  written_ = true;
}

void ReferenceLabelmapOutput::report(nlohmann::json& report) const {
  const Volume& g = ref_->grid;
  nlohmann::json direction = nlohmann::json::array();
  for (int a = 0; a < 3; ++a) direction.push_back({g.direction(0, a), g.direction(1, a), g.direction(2, a)});
  report["labelmap"] = path_;
  report["labelmap_reference"] = {{"path", ref_->path},
                                  {"format", ref_->format},
                                  {"frame_of_reference", ref_->frame_of_reference},
                                  {"size", {g.nx, g.ny, g.nz}},
                                  {"spacing", g.spacing},
                                  {"origin", g.origin},
                                  {"direction", direction}};
  report["labelmap_labels"] = labels_;
  report["labelmap_overlaps"] = overlaps_;
}

std::vector<std::string> ReferenceLabelmapOutput::files() const {
  return written_ ? std::vector<std::string>{path_} : std::vector<std::string>{};
}

std::vector<std::string> ReferenceLabelmapOutput::notes() const { return notes_; }

}  // namespace isoloft
