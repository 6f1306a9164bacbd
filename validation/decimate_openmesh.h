// @file validation/decimate_openmesh.h
// @brief The reference decimator: decimate()'s contract on OpenMesh, greedily.
// One heap of collapses (OpenMesh's Decimater); a test oracle and benchmark
// baseline only: the product library does not link OpenMesh.
#pragma once

#include "isoloft/core/mesh.h"
#include "isoloft/mesh/decimate.h"

namespace isoloft::detail {

/// Decimates `mesh` in place with the same bound and topology rules as
/// decimate(), greedily in quadric-error order.
/// \throw as decimate().
DecimateResult decimate_openmesh(TriMesh& mesh, const DecimateParams& params);

}  // namespace isoloft::detail
