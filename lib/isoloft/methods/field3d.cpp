// field3d: one smooth 3D field constrained by every drawn section, in any
// orientation (field3d/field3d.h). It reads sections, not slices: the run
// (run.cpp, reconstruct_jobs) hands it a CSL file's sections, or a polygon
// stack's slices as parallel sections; it has no per-slice field.
#include "isoloft/core/error.h"
#include "isoloft/methods/method.h"
#include "isoloft/pipeline.h"

namespace isoloft {

MethodSpec field3d_method() {
  return {
      .name = "field3d",
      .doc = "one smooth 3D field from every drawn section in any orientation (bi-Laplacian energy, the in-plane "
             "distances on every plane; CSL, RT Structure Sets and polyline files; docs/decisions.md)",
      .defaults = [](ReconstructParams&) {},
      .rows = {"field3d."},
      .fits_curves = false,
      .slice_field = [](const SliceInput&, const ReconstructParams&) -> SliceField {
        throw ParamError("method field3d: reads sections through isoloft's run (CSL, RT Structure Set or polyline "
                         "input), not slice by slice");
      },
  };
}

}  // namespace isoloft
