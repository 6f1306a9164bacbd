// @file run/outputs.h
// @brief What a run writes, one output kind per class: the meshes (-o), the
// signed distance volumes (--volume), the dense label map (--labelmap), the
// per-slice stage fields (--dump-stages). Every file is staged in the run's
// OutputSet (io/atomic_file.h), so all appear together at the end or none.
//
// A new kind (an RT Structure Set writer, a label map on a reference grid) is
// one RunOutput subclass, added to RunOptions::outputs by the front end:
//  - check_format(), check(): refuse early, naming option(), what it cannot
//    give (before reading; after reading, before any work);
//  - start_job(): add per-job pipeline hooks (JobHooks: several outputs may
//    ask for stage fields, planes or samples at once);
//  - file_bytes(): its bytes per object, for the --max-output check;
//  - finish(): write what it holds, through RunContext::files.stage();
//  - report(), files(): what it wrote, for the report and the front end.
// The run calls them in RunOptions::outputs order.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "isoloft/io/atomic_file.h"
#include "isoloft/io/mesh_io.h"
#include "isoloft/pipeline.h"
#include "isoloft/run/inputs.h"

namespace isoloft {

struct RunResult;
struct RunObject;
class NrrdWriter;

/// `name` made safe as a file name part (letters, digits, '-', '_'; others '_').
std::string file_safe(const std::string& name);

/// `path` with `suffix` before its extension ("a/b.ply", "_label2" -> "a/b_label2.ply").
std::string with_suffix(const std::string& path, const std::string& suffix);

/// The file name part of job `job`'s ROI: file_safe(name), with "_<number>"
/// if another job's name gives the same (ROIs selected by number).
std::string roi_file_tag(const Inputs& in, std::size_t job);

/// The per-object suffix of a run's files: "_label<L>" (labels), "_<ROI>"
/// (several ROIs: roi_file_tag()), else "".
std::string object_suffix(const Inputs& in, std::size_t job, std::uint32_t label);

/// One object a run will make, known before the work: a volume's label, an
/// RT Structure Set's ROI (its job), or a single object's job.
struct PlannedObject {
  std::size_t job = 0;
  std::uint32_t label = 0;
};

/// "label 3", "ROI 'Heart'" or "the object": how messages name it.
std::string object_text(const Inputs& in, const PlannedObject& o);

/// A file a run will write and what writes it ("the mesh of label 3");
/// `option`: the flag that asks for it (the run fills it in).
struct PlannedFile {
  std::string path, what;
  std::string option = {};
};

/// A file a run reads besides its input (the --params file, a --reference):
/// the flag that names it and its path (a folder: every file in it).
struct ReadFile {
  std::string option, path;
  bool data_file = false;  ///< the samples a volume header names (VolumeHeader::data_files)
};

/// Every output of a run resolved before any work, in one place, for every
/// front end. Refuses with a ParamError naming the flag and the path:
///  - an output that is a file the run reads: the input (a file of an input
///    folder, a volume header's data files: Inputs::data_files) or one of `reads`, compared by device and inode (hard and
///    symbolic links) and by resolved path;
///  - two outputs on one file (resolved path, or device and inode);
///  - a directory, block device or socket where a file goes (a character
///    device or FIFO, e.g. /dev/null or /dev/stdout, is written in place);
///  - a file in a folder the run cannot write (the errno text: "Read-only
///    file system", "Permission denied"), or under a path that is a file.
/// `dirs`: output folders (--dump-stages): each must be a folder or missing.
void check_output_paths(const Inputs& in, const std::vector<ReadFile>& reads, const std::vector<PlannedFile>& files,
                        const std::vector<PlannedFile>& dirs);

/// How the run's meshes are written: patient mm with the space named, or
/// pixels times the stack's pixel size.
MeshWriteOptions run_mesh_options(const Inputs& in, bool ascii = false);

/// The object's "Label" cell data in VTK files: its label, else (ROIs) its
/// job's place in the input, 1, 2, ...
std::uint32_t object_cell_label(const RunObject& o);

/// The object's name in the volume table and the RT Structure Set written:
/// its ROI's, its label's (the label table's), else "label N", else "object".
std::string object_display_name(const Inputs& in, const RunObject& o);

/// Job frame `f` as the writers place a mesh through it (patient_point()):
/// its origin's -0 made +0, so an exact 0 mm is written +0.
PatientFrame placing_frame(const PatientFrame& f);

/// `mo` for object `o`'s own file: its mesh (working pixels) placed through
/// its job's frame when `mo` has one (placing_frame(); `mo`'s names the space),
/// its cell label, and in the VTK formats' field data its label and name (the
/// ROI's, or the label table's) when the input names its objects.
MeshWriteOptions object_mesh_options(const Inputs& in, const RunObject& o, MeshWriteOptions mo);

/// Whether the run writes one file per object plus a combined one.
bool several_outputs(const Inputs& in, const RunResult& r);

/// Writes the meshes: one object -> `output`; several -> OUT_label<L>.ext
/// (labels) or OUT_<ROI>.ext each, and `output` with a colour per object.
/// Each file goes to stage(path) (identity if empty); sets RunObject::file.
void write_run_meshes(const std::string& output, const Inputs& in, RunResult& r, const MeshWriteOptions& options,
                      const std::function<std::string(const std::string&)>& stage = {});

/// Writes a finished run's meshes outside run() (the Python API's save()),
/// with run()'s checks: the files resolved by check_output_paths() (never
/// the input, its data files or one of `reads`; a device or FIFO written in
/// place), staged and renamed into place together. `object`: that object's
/// mesh alone to `path`; none: every mesh as write_run_meshes() names them.
/// Errors name `option` (the argument that gave the path) and final paths.
/// \return The files written. \throw ParamError, InputError, Error.
std::vector<std::string> save_run_meshes(const std::string& path, const std::string& option, const Inputs& in,
                                         RunResult& r, const MeshWriteOptions& options,
                                         const std::vector<ReadFile>& reads, std::optional<std::size_t> object = {});

/// What every output sees during a run.
struct RunContext {
  const Inputs& in;
  const ReconstructParams& params;
  OutputSet& files;  ///< stage() every path written
};

/// One job's pipeline hooks, gathered from every output and combined into
/// its ReconstructOptions (each hook called in the order added).
class JobHooks {
 public:
  using FieldsHook = std::function<void(const SliceStageFields&)>;
  using PlaneHook = std::function<void(std::uint32_t label, const Grid2f& plane, double x0, double y0, double z,
                                       int plane_index, int plane_count)>;
  using SampleHook = std::function<void(std::uint32_t label, const Grid2f& field, const PixelBox& box, double z)>;

  /// Each slice's stage fields (marker2006), from worker threads.
  void on_slice_fields(FieldsHook hook) { fields_.push_back(std::move(hook)); }
  /// Every sampled plane of each object's field (objects then run one at a time).
  void on_plane(PlaneHook hook) { planes_.push_back(std::move(hook)); }
  /// Each object's whole field at these working heights (pixels); `hook`
  /// sees only its own heights.
  void on_sample(std::vector<double> z, SampleHook hook);
  /// Sets the hooks of `options` (its other fields kept).
  void apply(ReconstructOptions& options) const;

 private:
  struct Sampler {
    std::vector<double> z;  // sorted
    SampleHook hook;
  };
  std::vector<FieldsHook> fields_;
  std::vector<PlaneHook> planes_;
  std::vector<Sampler> samplers_;
};

/// One kind of output of a run (see the file comment).
class RunOutput {
 public:
  virtual ~RunOutput() = default;
  /// The option that asks for it, as a flag ("--volume"); errors show it as
  /// core/option_names.h says.
  [[nodiscard]] virtual std::string option() const = 0;
  /// The path or directory given.
  [[nodiscard]] virtual std::string target() const = 0;
  /// Before the input is read. \throw ParamError naming option() if this
  /// input format cannot give it.
  virtual void check_format(InputFormat) const {}
  /// After reading, before any work. \throw ParamError naming option() if the
  /// input or the method cannot give it.
  virtual void check(const Inputs&, const ReconstructParams&) const {}
  /// Before job `job`'s reconstruct(): its hooks.
  virtual void start_job(const RunContext&, std::size_t /*job*/, JobHooks&) {}
  /// Bytes this output writes for one object (the --max-output check; the
  /// run adds them up over the objects).
  [[nodiscard]] virtual double file_bytes(const Inputs&, const WorkEstimate&) const { return 0; }
  /// Bytes it writes once, whatever the objects (a label map): checked before any work.
  [[nodiscard]] virtual double fixed_file_bytes(const Inputs&) const { return 0; }
  /// Bytes it holds at its end, however small the objects (a label map's
  /// volume and its encoded copy): checked before any work against
  /// --max-memory, and without a limit against the machine's memory.
  [[nodiscard]] virtual double memory_bytes(const Inputs&) const { return 0; }
  /// The files it will write for these objects, before any work (the
  /// --max-files count; no two outputs may share a file). Per-slice dumps
  /// are not listed.
  [[nodiscard]] virtual std::vector<PlannedFile> planned_files(const Inputs&, const std::vector<PlannedObject>&) const {
    return {};
  }
  /// Files it reads (a --reference and its data files): no output may replace them.
  [[nodiscard]] virtual std::vector<ReadFile> read_files() const { return {}; }
  /// A folder it writes into (--dump-stages), "" if none: checked like the files.
  [[nodiscard]] virtual std::string output_directory() const { return {}; }
  /// Said after the object in a --max-output error (" with --volume").
  [[nodiscard]] virtual std::string budget_note() const { return {}; }
  /// Whether finish() reads the objects' meshes (then none is freed before it).
  [[nodiscard]] virtual bool reads_meshes() const { return false; }
  /// Whether it writes each object once final (object_done()) and frees its
  /// mesh, when the run allows (RunOptions::free_meshes). At most one output does.
  [[nodiscard]] virtual bool streams_objects(const Inputs&) const { return false; }
  /// An object final (decimated), from worker threads beside its mesh check:
  /// written now (staged); the run frees its mesh after.
  virtual void object_done(const RunContext&, std::size_t /*job*/, ObjectResult&) {}
  /// After every job, the surfaces checked: writes what it holds (staged).
  virtual void finish(const RunContext&, RunResult&) {}
  /// Adds to the run's report.
  virtual void report(nlohmann::json&) const {}
  /// The files written (final paths, in order).
  [[nodiscard]] virtual std::vector<std::string> files() const = 0;
};

/// -o: the meshes, written at the end (write_run_meshes); or, streamed
/// (labels of an image stack to binary PLY), each label's file written once
/// it is final and its mesh freed, its part of the combined file spilled
/// (PlyPartWriter) and the combined file joined at the end: the same bytes.
class MeshOutput final : public RunOutput {
 public:
  /// \throw ParamError for an unknown mesh extension.
  explicit MeshOutput(std::string path, bool ascii = false);
  ~MeshOutput() override;
  [[nodiscard]] std::string option() const override { return "-o"; }
  [[nodiscard]] std::string target() const override { return path_; }
  [[nodiscard]] double file_bytes(const Inputs&, const WorkEstimate& e) const override;
  [[nodiscard]] std::vector<PlannedFile> planned_files(const Inputs& in, const std::vector<PlannedObject>& objects) const override;
  [[nodiscard]] bool streams_objects(const Inputs& in) const override;
  void object_done(const RunContext& ctx, std::size_t job, ObjectResult& ob) override;
  void finish(const RunContext& ctx, RunResult& r) override;
  [[nodiscard]] std::vector<std::string> files() const override { return files_; }

 private:
  // Writes object (job, ob)'s own file and spills its part (mutex_ held).
  void stream_object(const RunContext& ctx, std::size_t job, const ObjectResult& ob);
  std::string path_;
  bool ascii_;
  std::vector<std::string> files_;
  std::mutex mutex_;                                         // object_done() runs on worker threads
  std::unique_ptr<PlyPartWriter> parts_;                     // the combined file's parts, once one is streamed
  std::map<std::pair<std::size_t, std::uint32_t>, std::size_t> spilled_;  // (job, label) -> its part
};

/// --volume: each object's interpolated signed distance volume (float NRRD,
/// positive inside), streamed plane by plane; OUT<suffix>.nrrd per object.
class VolumeOutput final : public RunOutput {
 public:
  /// \throw ParamError unless `path` ends in .nrrd.
  explicit VolumeOutput(std::string path);
  ~VolumeOutput() override;
  [[nodiscard]] std::string option() const override { return "--volume"; }
  [[nodiscard]] std::string target() const override { return path_; }
  void start_job(const RunContext& ctx, std::size_t job, JobHooks& hooks) override;
  [[nodiscard]] double file_bytes(const Inputs&, const WorkEstimate& e) const override;
  [[nodiscard]] std::vector<PlannedFile> planned_files(const Inputs& in, const std::vector<PlannedObject>& objects) const override;
  [[nodiscard]] std::string budget_note() const override;
  void report(nlohmann::json& report) const override;
  [[nodiscard]] std::vector<std::string> files() const override { return files_; }

 private:
  std::string path_;
  std::vector<std::string> files_;
  std::map<std::uint32_t, std::unique_ptr<NrrdWriter>> writers_;  // per object streamed (a label partition interleaves them)
  std::map<std::uint32_t, std::pair<Grid2f, double>> first_;       // per object its first plane and z, until the second gives the step
};

/// --labelmap: the dense label map on a volume input's grid and geometry
/// (the annotated slices as given, every other voxel from the fields).
class LabelmapOutput final : public RunOutput {
 public:
  /// \throw ParamError unless `path` is a volume path (.nii.gz .nii .nrrd .mha).
  explicit LabelmapOutput(std::string path);
  ~LabelmapOutput() override;
  [[nodiscard]] std::string option() const override { return "--labelmap"; }
  [[nodiscard]] std::string target() const override { return path_; }
  void check_format(InputFormat format) const override;
  void start_job(const RunContext& ctx, std::size_t job, JobHooks& hooks) override;
  [[nodiscard]] double fixed_file_bytes(const Inputs& in) const override;
  [[nodiscard]] double memory_bytes(const Inputs& in) const override;
  [[nodiscard]] std::vector<PlannedFile> planned_files(const Inputs&, const std::vector<PlannedObject>&) const override {
    return {{path_, option()}};
  }
  void finish(const RunContext& ctx, RunResult& r) override;
  void report(nlohmann::json& report) const override;
  [[nodiscard]] std::vector<std::string> files() const override;

 private:
  std::string path_;
  std::unique_ptr<LabelmapBuilder> builder_;
  bool written_ = false;
};

/// --dump-stages: each slice's MPU field, distance, filtered distance and
/// their difference (float NRRD) and contour points + normals (CSV), for the
/// paper's Figs. 3-5; curve-fitting methods only.
class StageDumpOutput final : public RunOutput {
 public:
  explicit StageDumpOutput(std::string dir) : dir_(std::move(dir)) {}
  [[nodiscard]] std::string option() const override { return "--dump-stages"; }
  [[nodiscard]] std::string target() const override { return dir_; }
  [[nodiscard]] std::string output_directory() const override { return dir_; }
  void check(const Inputs&, const ReconstructParams& params) const override;
  void start_job(const RunContext& ctx, std::size_t job, JobHooks& hooks) override;
  [[nodiscard]] double file_bytes(const Inputs&, const WorkEstimate& e) const override;
  [[nodiscard]] std::vector<std::string> files() const override;

 private:
  std::string dir_;
  std::mutex mutex_;  // hooks run on worker threads
  std::vector<std::string> files_;
};

}  // namespace isoloft
