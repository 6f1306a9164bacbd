// Stage 4 (paper 2.3, equation 3): distance-dependent Gaussian filter of a
// signed distance field. It smooths the creases of the distance field along
// the medial axis (where |grad d| jumps) far from the curve, and leaves the
// field near the curve untouched so the reconstructed surface still passes
// through the contours.
//
// sigma(|d|) = 0                                          for |d| <= d_min
//            = sigma_min + (sigma_max - sigma_min)
//              * (1 - cos(pi (|d| - d_min) / (d_max - d_min))) / 2   for d_min < |d| < d_max
//            = sigma_max                                  for |d| >= d_max
// Each pixel's output is the normalized Gaussian-weighted average of the INPUT
// field over its own (2r+1)^2 stencil, r = ceil(3 sigma), clipped at the image
// border (weights renormalized over the pixels inside). The 2D stencil is
// evaluated per pixel (no separable passes: sigma varies per pixel); its
// weights g(dx) g(dy) come from 1D tables precomputed per quantized sigma:
// sigma is rounded to a multiple of kSigmaQuantum = 1/256 px (|error| <=
// 1/512 px, <= 0.4% of sigma for sigma >= 0.5). Pixels at
// |d| >= d_max share sigma_max; for them the same clipped 2D average is
// computed as a row pass then a column pass, an exact identity for a fixed
// sigma (2 (2r + 1) instead of (2r + 1)^2 products).
//
// Sign rule: a pixel with |d| > d_min is farther than d_min from the curve, so
// its output keeps the input's sign and is clamped to |out| >= d_min (to the
// smallest positive normal float if d_min = 0): the filter never flips a sign
// and never moves a pixel into the unfiltered band. Pixels with |d| <= d_min
// are copied bit for bit. Units: pixels of the working grid.
#pragma once

#include "isoloft/core/grid.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// Sigma quantum of the precomputed kernels, pixels.
inline constexpr double kSigmaQuantum = 1.0 / 256.0;
/// Largest accepted sigma_max, pixels (a 385 x 385 stencil per pixel).
inline constexpr double kMaxFilterSigma = 64.0;

struct FilterParams {
  double d_min = 4.0;
  double d_max = 15.0;
  double sigma_min = 0.5;
  double sigma_max = 3.0;
  bool enabled = true;
};

template <>
inline const ParamTable<FilterParams>& params_table<FilterParams>() {
  static const ParamTable<FilterParams> t(
      {
          field("enabled", &FilterParams::enabled, "", "apply the distance-dependent Gaussian filter (paper 2.3)")
              .cli("--no-filter", false),
          field("d_min", &FilterParams::d_min, "px", "no filtering within d_min of the curve (paper 2.3, eq. 3)", at_least(0)),
          field("d_max", &FilterParams::d_max, "px", "sigma_max from this distance on (paper 2.3, eq. 3)", at_least(0)),
          field("sigma_min", &FilterParams::sigma_min, "px", "sigma just beyond d_min (paper 2.3, eq. 3)", at_least(0)),
          field("sigma_max", &FilterParams::sigma_max, "px", "sigma far from the curve (paper 2.3, eq. 3)",
                between(0, kMaxFilterSigma)),
      },
      {[](const FilterParams& p, const std::string& at) {
         if (!(p.d_max > p.d_min))
           throw ParamError(at + "d_max: must exceed d_min (" + std::to_string(p.d_min) + "), got " + std::to_string(p.d_max));
         if (!(p.sigma_max >= p.sigma_min))
           throw ParamError(at + "sigma_max: must be >= sigma_min (" + std::to_string(p.sigma_min) + "), got " +
                            std::to_string(p.sigma_max));
       }});
  return t;
}

/// Equation 3 of the paper: the Gaussian's standard deviation at |d| = abs_d.
/// \pre params valid (see distance_filter).
double filter_sigma(double abs_d, const FilterParams& params);

/// Distance-dependent Gaussian filter (TBB-parallel over rows).
/// \pre d holds no NaN (+-infinity passes through where all stencil values share it).
/// \return a grid of d's size; d itself if !params.enabled.
/// \throw ParamError unless 0 <= d_min < d_max and 0 <= sigma_min <= sigma_max
///        <= kMaxFilterSigma, all finite.
/// \throw InputError if d contains NaN.
Grid2f distance_filter(const Grid2f& d, const FilterParams& params = {});

namespace detail {

/// sigma rounded to the nearest multiple of kSigmaQuantum.
double quantized_sigma(double sigma);

/// Direct twin of distance_filter: the same quantized sigma and radius, but
/// 2D weights exp(-(dx^2 + dy^2) / (2 sigma^2)) computed per stencil pixel and
/// summed in double; same sign rule. Serial, for tests.
Grid2f distance_filter_naive(const Grid2f& d, const FilterParams& params);

}  // namespace detail
}  // namespace isoloft
