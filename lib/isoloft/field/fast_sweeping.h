// Stage 3b, the faster next step named by the paper (2.2): extend a narrow
// band to the whole grid by fast sweeping (H. Zhao, "A fast sweeping method
// for Eikonal equations", Math. Comp. 74(250), 2005, online 2004):
// Gauss-Seidel passes over the grid in the 4 alternating orderings
// (x+ y+, x- y+, x- y-, x+ y-), so every direction of the characteristics is
// followed by one of them; a cycle of 4 sweeps is repeated until it changes no
// value. Same update rules as the marching methods (field/marching.h):
// closest-segment propagation (Tsai 2002; each sweep tries the 4 neighbours
// it has already visited, and a pixel that improves walks along the curve)
// or the first-order adjacent-diagonal upwind update (Gauss-Seidel on all 8
// neighbours). Band pixels keep their values. At convergence every pixel
// has tried each neighbour's segment, so the ClosestPoint field is exactly
// 1-Lipschitz (up to float rounding).
#pragma once

#include "isoloft/core/grid.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"

namespace isoloft {

/// Fast sweeping. Same contract as extend_distance (field/marching.h).
/// \param max_cycles cap on 4-sweep cycles (ExtendParams::max_sweep_cycles).
/// \throw ParamError if the band's grids differ in size or max_cycles < 1.
Grid2f extend_fast_sweeping(const NarrowBandResult& band, ExtendUpdate update = ExtendUpdate::ClosestPoint,
                            int max_cycles = ExtendParams{}.max_sweep_cycles);

namespace detail {

/// Sweeps `s` in place until a cycle changes nothing or max_cycles ran;
/// returns the number of cycles run (the last one changes nothing unless the
/// cap was hit).
int fast_sweep(ExtendState& s, ExtendUpdate update, int max_cycles);

}  // namespace detail
}  // namespace isoloft
