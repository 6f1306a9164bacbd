// @file field/fast_sweeping.h
// @brief Narrow band to the whole grid by fast sweeping (paper 2.2's future work).
// Zhao, Math. Comp. 2005: Gauss-Seidel sweeps in the 4 orderings until a cycle
// changes nothing, with the updates of field/marching.h (ClosestPoint then
// 1-Lipschitz up to rounding). Sign convention: positive inside.
#pragma once

#include "isoloft/core/grid.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"

namespace isoloft {

/// Fast sweeping; the contract of extend_distance (field/marching.h).
/// \throw ParamError if the band's grids differ in size or max_cycles < 1.
/// @warning At max_cycles the field is returned unconverged, without notice.
Grid2f extend_fast_sweeping(const NarrowBandResult& band, ExtendUpdate update = ExtendUpdate::ClosestPoint,
                            int max_cycles = ExtendParams{}.max_sweep_cycles);

namespace detail {

/// Sweeps s to convergence or max_cycles. \return the cycles run.
int fast_sweep(ExtendState& s, ExtendUpdate update, int max_cycles);

}  // namespace detail
}  // namespace isoloft
