// @file run/reference_labelmap.h
// @brief --reference GRID --labelmap OUT: every object of a run sampled on a
// reference image's grid (a CT: NIfTI, NRRD, MetaImage, or a DICOM series
// folder), one label per object (an RT Structure Set's ROI number, a label
// volume's label), written with the reference's size, spacing, origin and
// direction cosines in patient LPS (as 3D Slicer places it).
//
// Each object's interpolated field (positive inside) is evaluated at the
// reference's slice heights (JobHooks::on_sample, in the object's working
// pixels) and read bilinearly at every voxel centre of the slice; a voxel is
// inside where the field is above mc.iso, so the label map and the mesh
// agree. Sign convention: positive inside.
//
// Overlaps: a voxel inside several objects takes the label of the smallest
// of them (by surface volume; ties: the earlier object), so nested
// structures (a GTV inside its PTV inside the body) all stay visible; the
// report counts the voxels every pair shares ("labelmap_overlaps").
//
// The report gets "labelmap_reference" (the grid), "labelmap_labels" (per
// object: voxels inside, voxels labelled, their volumes and the surface's)
// and "labelmap_overlaps".
//
// @warning A DICOM reference must share the structure set's
// FrameOfReferenceUID; a NIfTI / NRRD / MetaImage reference has none to
// check, so it is taken to be in the input's patient space.
// @warning The reference's slices must be planes of constant working z (for
// an RT Structure Set: axial, perpendicular to the patient z axis; any
// in-plane rotation, flip or spacing is supported); a reference tilted
// against them (a gantry tilt, an oblique MR) is refused with the angle:
// resample it to the contours' planes first.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "isoloft/run/outputs.h"

namespace isoloft {

/// A reference image's grid: the volume's geometry (data empty) and where it came from.
struct ReferenceGrid {
  Volume grid;                     ///< geometry only
  std::string path;                ///< as given
  std::string format;              ///< "dicom" or the volume file's extension
  std::string frame_of_reference;  ///< DICOM FrameOfReferenceUID, "" if the format has none
  std::vector<std::string> data_files;  ///< a volume header's data files (VolumeHeader::data_files)
};

/// Reads the grid of `path`: a DICOM image series (a folder, or one of its
/// files: headers only) or a volume (.nii .nii.gz .nrrd .nhdr .mha .mhd:
/// its header alone, VolumeReadOptions::geometry_only). No voxel is read,
/// so what a label map on the grid holds (memory_bytes()) is all the
/// budget must count, checked before any work.
/// \throw InputError naming the path (io/dicom_series.h, io/volume.h).
ReferenceGrid read_reference(const std::string& path);

/// A reference slice may leave the plane of constant working z by this much
/// (mm) across its extent (direction cosines are rounded decimals; a tilt
/// of 0.01 degrees over 500 mm is 0.09 mm).
inline constexpr double kReferenceTiltMm = 0.05;

/// --labelmap with --reference (see the file comment).
class ReferenceLabelmapOutput final : public RunOutput {
 public:
  /// \throw ParamError unless `path` is a volume path (.nii.gz .nii .nrrd .mha).
  ReferenceLabelmapOutput(std::string path, std::shared_ptr<const ReferenceGrid> reference);
  ~ReferenceLabelmapOutput() override;
  [[nodiscard]] std::string option() const override { return "--labelmap"; }
  [[nodiscard]] std::string target() const override { return path_; }
  [[nodiscard]] bool reads_meshes() const override { return true; }  // an object beyond the grid: its vertices
  /// \throw ParamError unless the input has a patient frame (an RT Structure Set or a volume).
  void check_format(InputFormat format) const override;
  /// \throw InputError naming the reference if a DICOM reference's frame of
  ///        reference is not the structure set's or its slices are tilted
  ///        against a job's planes (the angle given); naming the input if a
  ///        ROI number cannot be a label (1 .. 2^24); ParamError if the label
  ///        map would overwrite the reference.
  void check(const Inputs& in, const ReconstructParams& params) const override;
  void start_job(const RunContext& ctx, std::size_t job, JobHooks& hooks) override;
  [[nodiscard]] double fixed_file_bytes(const Inputs& in) const override;
  [[nodiscard]] double memory_bytes(const Inputs& in) const override;
  /// The reference and its data files.
  [[nodiscard]] std::vector<ReadFile> read_files() const override;
  [[nodiscard]] std::vector<PlannedFile> planned_files(const Inputs&, const std::vector<PlannedObject>&) const override {
    return {{path_, option()}};
  }
  void finish(const RunContext& ctx, RunResult& r) override;
  void report(nlohmann::json& report) const override;
  [[nodiscard]] std::vector<std::string> files() const override;
  /// One line per overlapping pair and per object beyond the grid, for the
  /// front end to show (after finish()).
  [[nodiscard]] std::vector<std::string> notes() const;

 private:
  struct Object;  // one object's inside voxels, slice by slice
  Object& object(std::size_t job, std::uint32_t label);

  std::string path_;
  std::shared_ptr<const ReferenceGrid> ref_;
  std::mutex mutex_;
  std::map<std::pair<std::size_t, std::uint32_t>, std::unique_ptr<Object>> objects_;
  nlohmann::json labels_, overlaps_;
  std::vector<std::string> notes_;
  bool written_ = false;
};

namespace detail {

/// The voxel axis of `grid` along `normal` (a unit vector): the one whose
/// direction is most parallel to it; `tilt_mm` is how far a slice of the
/// other two axes leaves the plane perpendicular to `normal` over its extent.
int slice_axis(const Volume& grid, const Eigen::Vector3d& normal, double& tilt_mm);

}  // namespace detail

}  // namespace isoloft
