// @file pipeline.h
// @brief reconstruct(): one closed surface per object of a slice stack.
// Marker, Braude, Museth & Breen 2006, or the Levin 1986-style baseline:
// contour and inside (paper 2.1), [marker2006] normals and MPU (2.1), signed
// distance (2.2), [marker2006] filter (2.3), z splines (2.4), Marching Cubes
// and decimation (2.5); per-slice ones in methods/columns/slice_methods.h. A first
// pass makes every slice's masks (kept packed, O(contour length) bytes) and
// the crop box; then the slices are streamed: a window of them computed in
// parallel, the z splines through a window of knots (interp/z_stream.h), each
// plane meshed and dropped, so the fields held do not grow with the slice
// count (lazy images: SliceStack::load_image). Stage times split the streamed
// wall time by CPU shares. Each object runs in its
// crop box; pixel (i, j) of slice k is at (i, j, z_k). Sign convention:
// positive inside.
#pragma once

#include "isoloft/core/slice_stack.h"
#include "isoloft/field/marching.h"
#include "isoloft/methods/method.h"
#include "isoloft/methods/params.h"
#include "isoloft/objects/params.h"
#include "isoloft/objects/result.h"

namespace isoloft {

/// Reconstructs one object, or one per label with InputKind::Labels.
/// \throw InputError for < 2 slices, z not increasing, slices (end caps
///        included) thinner than one interp.z_step, an empty image size,
///        non-binary contour/mask values or a rejected open contour (naming the
///        slice file); ParamError naming a parameter, or for labels without labels input.
/// @warning An object without inside, or a selected label found nowhere, is
/// skipped with a warning; empty slices close the object like end caps.
/// @warning marker2006: a slice of < kMinMpuPoints points keeps its pixel
/// distances, with a warning.
ReconstructResult reconstruct(const SliceStack& stack, const ReconstructParams& params, const ReconstructOptions& options = {});

/// The same for one input as its method reads it (the stack alone above): a
/// method with a family of its own (MethodSpec::reconstruct) runs it, and the
/// options' hooks see nothing; any other streams in.stack.
ReconstructResult reconstruct(const MethodInput& in, const ReconstructParams& params, const ReconstructOptions& options = {});

}  // namespace isoloft
