// @file run/rtstruct_output.h
// @brief --rtstruct OUT.dcm (or -o OUT.dcm): the run's surfaces back as an
// RT Structure Set (io/rtstruct.h, write_rtstruct): each ROI's mesh cut at
// its input contour planes (mesh/plane_cut.h), its number, name and colour
// and the input's patient, study and frame of reference kept.
#pragma once

#include <string>
#include <vector>

#include "isoloft/run/outputs.h"

namespace isoloft {

/// Writes the run's surfaces as an RT Structure Set (see the file comment).
/// \throw ParamError unless the input is an RT Structure Set.
void write_run_rtstruct(const std::string& path, const Inputs& in, const RunResult& r);

class RtStructOutput final : public RunOutput {
 public:
  /// `option`: the flag that asked for it ("--rtstruct" or "-o").
  /// \throw ParamError unless `path` ends in .dcm.
  explicit RtStructOutput(std::string path, std::string option = "--rtstruct");
  [[nodiscard]] std::string option() const override { return option_; }
  [[nodiscard]] std::string target() const override { return path_; }
  /// \throw ParamError unless the input is an RT Structure Set.
  void check_format(InputFormat format) const override;
  void finish(const RunContext& ctx, RunResult& r) override;
  void report(nlohmann::json& report) const override { report["rtstruct"] = path_; }
  [[nodiscard]] std::vector<PlannedFile> planned_files(const Inputs&, const std::vector<PlannedObject>&) const override {
    return {{path_, option()}};
  }
  [[nodiscard]] std::vector<std::string> files() const override { return {path_}; }

 private:
  std::string path_, option_;
};

}  // namespace isoloft
