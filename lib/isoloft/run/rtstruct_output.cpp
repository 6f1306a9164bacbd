#include "isoloft/run/rtstruct_output.h"

#include <filesystem>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/rtstruct.h"
#include "isoloft/mesh/plane_cut.h"
#include "isoloft/run.h"

namespace fs = std::filesystem;

namespace isoloft {

namespace {

constexpr const char* kNeedsRtInput =
    ": an RT Structure Set out needs an RT Structure Set input (its patient, study and frame of reference are written "
    "back)";

}  // namespace

void write_run_rtstruct(const std::string& path, const Inputs& in, const RunResult& r) {
  if (in.format != InputFormat::RtStruct || !in.rtstruct) throw ParamError(path + kNeedsRtInput);
  std::vector<RtRoiContours> rois;
  for (const RunObject& o : r.objects) {
    const Job& job = in.jobs[o.job];
    const PatientFrame& f = *job.stack.patient;
    RtRoiContours out;
    out.roi = job.roi;
    for (const double z_mm : rt_planes(job.stack)) {  // the input's contour planes
      RtRoiContours::Plane plane;
      plane.z = z_mm;
      const double z = (z_mm - f.origin.z()) / f.axes(2, 2);  // working px (roi_stack: axis-aligned frame)
      for (const auto& loop : cut_mesh(o.object.mesh, z)) {
        std::vector<Vec2d> mm;
        for (const Vec2d& p : loop) {
          const Vec3d q = f.to_patient(Vec3d(p.x(), p.y(), z));
          mm.emplace_back(q.x(), q.y());
        }
        plane.loops.push_back(std::move(mm));
      }
      if (!plane.loops.empty()) out.planes.push_back(std::move(plane));
    }
    rois.push_back(std::move(out));
  }
  write_rtstruct(path, in.files.front(), rois, "isoloft", &in.rtstruct->bytes);  // the input as read, not read again
}

RtStructOutput::RtStructOutput(std::string path, std::string option) : path_(std::move(path)), option_(std::move(option)) {
  if (fs::path(path_).extension() != ".dcm")
    throw ParamError(option_name(option_) + ": '" + path_ + "' must end in .dcm");
}

void RtStructOutput::check_format(InputFormat format) const {
  if (format != InputFormat::RtStruct) throw ParamError(option_name(option_) + " " + path_ + kNeedsRtInput);
}

void RtStructOutput::finish(const RunContext& ctx, RunResult& r) { write_run_rtstruct(ctx.files.stage(path_), ctx.in, r); }

}  // namespace isoloft
