// @file field/edt.h
// @brief Exact Euclidean distance transforms of binary images in linear time.
// Felzenszwalb & Huttenlocher, ToC 8(19), 2012 (separable, lower envelopes of
// parabolas; TBB-parallel); for the Levin baseline, marker2006's fallback and
// sign guard. Pixel-centre distances in pixels, exact below 4096 px.
// Sign convention: positive inside, negative outside.
#pragma once

#include <limits>
#include <vector>

#include "isoloft/core/grid.h"

namespace isoloft {

/// |d| where there is no surface to measure to (finite: no inf - inf = NaN
/// later; docs/decisions.md: undefined distances).
inline constexpr float kNoSurfaceDistance = 1.0e6f;

/// Squared distance to the nearest non-zero pixel; +infinity everywhere if none.
Grid2f squared_edt(const Grid2u8& features);

/// Signed distance to the nearest contour pixel (0 on it), signed by `inside`.
/// \throw ParamError if the sizes differ.
/// @warning No contour pixel: +-kNoSurfaceDistance (an empty slice is outside).
Grid2f distance_to_contour_signed(const Grid2u8& contour, const Grid2u8& inside);

/// The label of the nearest pixel with a label >= 0 (Euclidean, pixel
/// centres), for every pixel: a Voronoi partition of the grid by labelled
/// regions; -1 everywhere if none. Ties go to one of the nearest labels.
Grid2i nearest_label(const Grid2i& labels);

/// Signed distance to a mask's edge halfway between pixel centres.
/// @warning The border is no edge: pad the grid to close a mask touching it.
/// @warning An empty mask is -kNoSurfaceDistance everywhere, a full one +.
Grid2f distance_to_mask_edge_signed(const Grid2u8& mask);

namespace detail {

/// 1D d[q] = min_p f[p] + (q - p)^2 (their Algorithm 1); +inf samples absent.
void squared_dt_1d(const double* f, double* d, int n, std::vector<int>& v, std::vector<double>& z);

/// squared_dt_1d that also gives, per sample, the index p of its minimum.
void squared_dt_1d_arg(const double* f, double* d, int* arg, int n, std::vector<int>& v, std::vector<double>& z);

/// Brute-force twins of the transforms (nearest_label_brute: the squared
/// distance to the nearest labelled pixel, which ties do not change).
Grid2f squared_edt_brute(const Grid2u8& features);
Grid2f distance_to_contour_signed_brute(const Grid2u8& contour, const Grid2u8& inside);
Grid2f distance_to_mask_edge_signed_brute(const Grid2u8& mask);
Grid2f nearest_label_brute_sq(const Grid2i& labels);

}  // namespace detail
}  // namespace isoloft
