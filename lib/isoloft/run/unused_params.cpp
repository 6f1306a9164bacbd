// @file run/unused_params.cpp
// @brief refuse_unused_params(): the rows' readers, then what the input can use.
#include "isoloft/run/unused_params.h"

#include "isoloft/core/error.h"
#include "isoloft/methods/method.h"
#include "isoloft/methods/params.h"

namespace isoloft {

void refuse_unused_params(const GivenParam& given, const ReconstructParams& params, const Inputs& in) {
  for (const auto& row : params_table<ReconstructParams>().rows())
    if (const std::string name = given(row.key); !name.empty())
      if (const std::string where = unused_param(row.key, params.method.name(), params.z_scheme); !where.empty())
        throw ParamError(name + ": has no effect here, " + where);
  const InputKind kind = in.first().kind;
  const bool images = in.format == InputFormat::Images || in.format == InputFormat::Arrays;  // arrays: images in memory
  struct Use {
    const char* key;
    bool used;
    const char* where;
  };
  const Use uses[] = {
      {"polyline_raster_width", kind == InputKind::Polylines, "only with a polyline input"},
      {"fill.max_gap", images && kind == InputKind::Contours, "only with contour images (--input contours)"},
      {"fill.open_contours", images && kind == InputKind::Contours, "only with contour images (--input contours)"},
      {"binarize", images && kind != InputKind::Labels, "only with contour or mask images"},
      {"label_partition", kind == InputKind::Labels, "only with label input (--input labels, or an integer label volume)"},
  };
  for (const Use& u : uses)
    if (!u.used)
      if (const std::string name = given(u.key); !name.empty()) throw ParamError(name + ": has no effect here, " + u.where);
}

}  // namespace isoloft
