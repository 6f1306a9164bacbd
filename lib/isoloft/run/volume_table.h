// @file run/volume_table.h
// @brief The volume table: per object its closed surface's volume beside the
// slab volume (contour area x slice spacing, the planning systems' and
// dicompyler's convention), area, planes and whether it is closed, and how
// far the volume can be trusted: the slice spacing, the share of the volume
// in the end caps (beyond the first and last contour planes, where no
// contour says where the surface ends) and a warning for a structure on
// fewer than kTrustedPlanes planes; as text (stdout), CSV or JSON
// (--volumes, the report's "volumes").
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "isoloft/run/outputs.h"

namespace isoloft {

/// One row of the volume table, in output units (patient mm for RT
/// Structure Sets and volumes, else working pixels).
struct VolumeRow {
  std::string name;     ///< ROI name, "label <L>", or "object"
  int number = 0;       ///< ROI number, or the label
  double volume = 0;    ///< of the closed surface, output units^3
  double area = 0;      ///< surface area, output units^2
  double slab = 0;      ///< sum over contour planes of the contour area (even-odd) x the ROI's typical plane step; 0 if the input has no polygons
  int planes = 0;       ///< slices with contours
  bool closed = false;  ///< closed oriented 2-manifold
  double spacing = 0;   ///< typical step between its contour planes, output units; 0 on one plane
  /// Share of `volume` beyond its first and last contour planes (the end
  /// caps), 0..1: the part no contour bounds; NaN where the slices holding
  /// the object are not known (image and label inputs).
  double cap_share = 0;
  std::string warning;  ///< "" or why the volume is not to be trusted (fewer than kTrustedPlanes planes)
};

/// A structure on fewer contour planes than this is mostly end caps: at 3 mm
/// spacing a 3 mm sphere comes back +41 % and a 5 mm one -13 % (issue 38).
inline constexpr int kTrustedPlanes = 3;

/// Rows of every object; an object's clipped volumes are computed here
/// unless run_jobs() already did (ObjectResult::clipped_volumes).
std::vector<VolumeRow> volume_table(const Inputs& in, const RunResult& r);
/// The object's volume above -infinity, its last and its first contour
/// plane (one RT plane: its middle; 0 without contours), px^3: what its row's
/// end-cap share reads; {} unless the job's stack has polygons.
std::vector<double> clipped_volumes(const Inputs& in, const Job& job, const ObjectResult& ob);
/// The table as aligned text (cc and cm^2 for patient mm), CSV, or JSON (mm^3, mm^2).
std::string volume_table_text(const std::vector<VolumeRow>& rows, bool patient_mm);
std::string volume_table_csv(const std::vector<VolumeRow>& rows);
nlohmann::json volume_table_json(const std::vector<VolumeRow>& rows);

/// --volumes: the volume table as .csv or .json (the report always has it
/// as "volumes").
class VolumeTableOutput final : public RunOutput {
 public:
  /// \throw ParamError unless `path` ends in .csv or .json.
  explicit VolumeTableOutput(std::string path);
  [[nodiscard]] std::string option() const override { return "--volumes"; }
  [[nodiscard]] std::string target() const override { return path_; }
  void finish(const RunContext& ctx, RunResult& r) override;
  void report(nlohmann::json& report) const override;
  [[nodiscard]] std::vector<PlannedFile> planned_files(const Inputs&, const std::vector<PlannedObject>&) const override {
    return {{path_, option()}};
  }
  [[nodiscard]] std::vector<std::string> files() const override { return {path_}; }

 private:
  std::string path_;
};

}  // namespace isoloft
