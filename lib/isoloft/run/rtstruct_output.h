// @file run/rtstruct_output.h
// @brief --rtstruct OUT.dcm (or -o OUT.dcm): the run's surfaces back as an
// RT Structure Set (io/rtstruct.h, write_rtstruct): each ROI's mesh cut at
// its input contour planes (mesh/plane_cut.h; planes of any orientation for a
// ROI read as sections, --method field3d), resampled to the density the
// contours were drawn at (or --rt-point-spacing), its number, name and
// colour and the input's patient, study and frame of reference kept. From a
// label map: a standalone set, each label's mesh cut at the slices' planes.
//
// Every drawn contour is accounted for (the per-contour report, JSON and
// --rt-contours CSV): matched to the written section on its plane, with both
// areas and the distances between them, and flagged when the surface lost
// it, merged it with another, split it or shrank it beyond kShrinkShare;
// sections on an input plane that nobody drew are listed too. A drawn contour the
// surface lost is written back as drawn (a small closed piece), unless it is
// smaller than --rt-min-area, when it is dropped and named in a warning.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/run/outputs.h"

namespace isoloft {

/// How the surfaces become contours again.
struct RtContourParams {
  /// Step between written points along a section, mm; 0 = the mean step of
  /// the contours drawn on that plane for that ROI (the whole ROI's for a
  /// plane without one).
  double point_spacing = 0;
  /// mm^2: a drawn contour the surface lost and smaller than this is dropped
  /// (named in a warning); 0 = every lost contour is written back as drawn.
  double min_area = 0;
};

/// A drawn contour and its section are one when the drawn contour's points
/// lie this close (mean, mm) to it: two working pixels at the default 0.5
/// mm grid, far above the round trip's 0.1 mm and below any island's
/// distance to its neighbours on the shared set.
inline constexpr double kMatchMm = 1.0;
/// A section smaller than its drawn contour by more than this share of the
/// drawn area is "shrunk" (the target: areas within 25 %).
inline constexpr double kShrinkShare = 0.25;
/// Drawn contours of at least this area (mm^2) must keep their area within
/// kShrinkShare (the target); a run that leaves one shrunk warns.
inline constexpr double kKeptDrawnMm2 = 1.0;

/// One row of the per-contour report: a drawn contour (contour > 0) and
/// the section matched to it, or a section nobody drew (contour == 0).
struct ContourRecord {
  std::string roi;
  int roi_number = 0;
  double z = 0;     ///< the plane, patient mm
  int contour = 0;  ///< the drawn contour's place in the ROI's contours, 1-based (a keyhole's loops share it); 0: undrawn
  int section = 0;  ///< the written section on the plane, 1-based; 0: none
  double area_drawn = 0, area_section = 0;     ///< mm^2, absolute (a hole's too)
  double mean_distance = 0, max_distance = 0;  ///< mm: mean of the two directed mean vertex distances; largest of both
  int points_drawn = 0, points_written = 0;
  bool lost = false, merged = false, shrunk = false, undrawn = false;
  /// The surface split the drawn contour: on its row, it has pieces beyond
  /// its section (area_section is their sum); on a piece's row (contour set,
  /// points_drawn 0), that section, which lies on the drawn contour (every
  /// vertex within kMatchMm): drawn, so not undrawn.
  bool split = false;
  /// "section" (the surface's), "drawn" (lost: written back as drawn),
  /// "dropped" (lost, under RtContourParams::min_area).
  std::string written;
};

/// Per ROI: the contours and points in and out, flag counts and distances.
struct RoiContourSummary {
  std::string roi;
  int roi_number = 0;
  int contours_in = 0, contours_out = 0;
  long points_in = 0, points_out = 0;
  int lost = 0, merged = 0, shrunk = 0, undrawn = 0, undrawn_over_1mm2 = 0, dropped = 0;
  int split = 0;  ///< drawn contours the surface split (ContourRecord::split)
  double mean_distance = 0;  ///< mean over its matched drawn contours, mm
  double max_distance = 0;   ///< mm
  /// The resampling's departure from the exact section (mesh/plane_cut.h, resample_loop), mm.
  double resample_max_deviation = 0, resample_mean_deviation = 0;
  double point_spacing = 0;  ///< mean written step, mm
  int shrunk_over_1mm2 = 0;  ///< shrunk drawn contours of kKeptDrawnMm2 or more (warned: the target not met)
  double voxel_size = 0;     ///< the ROI's working grid, mm
  std::optional<GridRefinement> refined;  ///< the grid refined for its narrowest drawn contour (run/inputs.h)
};

struct RtWriteReport {
  std::vector<ContourRecord> contours;
  std::vector<RoiContourSummary> rois;
};

/// Writes the run's surfaces as an RT Structure Set (see the file comment);
/// warnings (dropped contours) go to r.warnings. From a volume (a label map:
/// no drawn contours, no CT series): a standalone set (write_rtstruct_new),
/// one ROI per object, numbered by its label and named as the report names
/// it, its sections on every slice plane of the volume, resampled at a
/// pixel (or --rt-point-spacing); the report lists the ROIs' written
/// contours, with no drawn ones to account for.
/// \throw ParamError unless the input is an RT Structure Set or a volume;
///        InputError naming the volume if its slices are not axial or a
///        label exceeds a ROI number (2^31 - 1).
RtWriteReport write_run_rtstruct(const std::string& path, const Inputs& in, RunResult& r,
                                 const RtContourParams& params = {});

/// The per-contour report as CSV (one row per ContourRecord) and JSON.
std::string contour_report_csv(const RtWriteReport& report);
nlohmann::json contour_report_json(const RtWriteReport& report);

class RtStructOutput final : public RunOutput {
 public:
  /// `option`: the flag that asked for it ("--rtstruct" or "-o");
  /// `contours_csv`: the per-contour report's CSV ("" = none).
  /// \throw ParamError unless `path` ends in .dcm and `contours_csv` (if
  ///        given) in .csv, or for a negative spacing or area.
  explicit RtStructOutput(std::string path, std::string option = "--rtstruct", RtContourParams params = {},
                          std::string contours_csv = "");
  [[nodiscard]] std::string option() const override { return option_; }
  [[nodiscard]] std::string target() const override { return path_; }
  [[nodiscard]] bool reads_meshes() const override { return true; }  // its contours are the meshes' sections
  /// \throw ParamError unless the input is an RT Structure Set or a volume.
  void check_format(InputFormat format) const override;
  /// \throw InputError naming the volume and the option if its slices are
  ///        not axial (the hint: the voxel axis to slice along, or an
  ///        oblique volume to resample).
  void check(const Inputs& in, const ReconstructParams& params) const override;
  void finish(const RunContext& ctx, RunResult& r) override;
  void report(nlohmann::json& report) const override;
  [[nodiscard]] std::vector<PlannedFile> planned_files(const Inputs&, const std::vector<PlannedObject>&) const override;
  [[nodiscard]] std::vector<std::string> files() const override;

 private:
  std::string path_, option_;
  RtContourParams params_;
  std::string contours_csv_;
  RtWriteReport written_;
};

}  // namespace isoloft
