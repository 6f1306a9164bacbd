// Exact Euclidean distance transforms of binary images, in linear time.
//
// Reference: P. F. Felzenszwalb, D. P. Huttenlocher, "Distance Transforms of
// Sampled Functions", Theory of Computing 8(19), 2012: the squared EDT is
// separable, each 1D pass is the lower envelope of parabolas rooted at the
// samples. Pass 1 (columns) has 0/inf input, so it reduces to two linear
// sweeps; pass 2 (rows) is their Algorithm 1. Both parallel (TBB), O(N).
//
// Distances are between pixel centres (core/grid.h convention), in pixels.
// Squared distances are integers and are computed exactly (integer-valued
// doubles); they are exact in the float result while below 2^24, i.e. for
// distances under 4096 px. Signed fields are positive inside, negative
// outside (the MPU convention of Marker et al. 2006, paper 2.2).
#pragma once

#include <limits>
#include <vector>

#include "isoloft/core/grid.h"

namespace isoloft {

/// Magnitude returned by the signed transforms where the distance is
/// undefined because the feature set is empty (no contour pixel, or no pixel
/// on the other side of the mask edge). Finite so that later interpolation
/// and filtering never produce inf - inf = NaN; larger than any distance on a
/// realistic grid (grids are far below 10^6 px across).
inline constexpr float kNoSurfaceDistance = 1.0e6f;

/// Squared Euclidean distance from every pixel centre to the nearest
/// feature pixel centre (features = non-zero pixels).
/// \return a grid of the same size; +infinity everywhere if there is no
///         feature pixel; 0 on feature pixels.
Grid2f squared_edt(const Grid2u8& features);

/// Signed distance to a contour image: |d| = distance to the nearest contour
/// pixel centre, positive where `inside` is non-zero, negative elsewhere, 0
/// on contour pixels.
/// \pre `inside` has the size of `contour`.
/// \return where `contour` is empty: +kNoSurfaceDistance on inside pixels,
///         -kNoSurfaceDistance elsewhere (an empty slice is all outside).
/// \throw ParamError if the two grids differ in size.
Grid2f distance_to_contour_signed(const Grid2u8& contour, const Grid2u8& inside);

/// Signed distance to the edge of a mask, the surface lying halfway between
/// pixel centres: inside pixels get +(distance to the nearest outside pixel
/// centre - 0.5), outside pixels -(distance to the nearest inside pixel
/// centre - 0.5). Pixels beyond the image are not considered (a mask touching
/// the border has no surface there; pad the grid to close it).
/// \return an empty mask gives -kNoSurfaceDistance everywhere, a full mask
///         +kNoSurfaceDistance everywhere.
Grid2f distance_to_mask_edge_signed(const Grid2u8& mask);

namespace detail {

/// 1D squared distance transform of sampled function f (Felzenszwalb &
/// Huttenlocher, Algorithm 1): d[q] = min_p f[p] + (q - p)^2. Samples equal
/// to +infinity are absent; if all are absent, d is all +infinity.
/// `v` and `z` are scratch buffers (resized as needed).
void squared_dt_1d(const double* f, double* d, int n, std::vector<int>& v, std::vector<double>& z);

/// O(N^2) twin of squared_edt: minimum over all feature pixels.
Grid2f squared_edt_brute(const Grid2u8& features);
/// O(N^2) twin of distance_to_contour_signed.
Grid2f distance_to_contour_signed_brute(const Grid2u8& contour, const Grid2u8& inside);
/// O(N^2) twin of distance_to_mask_edge_signed.
Grid2f distance_to_mask_edge_signed_brute(const Grid2u8& mask);

}  // namespace detail
}  // namespace isoloft
