// @file field/filter.h
// @brief Distance-dependent Gaussian filter of a signed distance field (paper 2.3).
// Smooths medial-axis creases away from the curve: sigma (eq. 3) is 0 up to
// d_min, sigma_max from d_max, a cosine ramp from sigma_min between; each
// output averages the input over its (2r + 1)^2 stencil, r = ceil(3 sigma),
// renormalised at the border. Sign convention: positive inside; pixels with
// |d| <= d_min are copied, the others keep their sign at |out| >= d_min.
#pragma once

#include "isoloft/core/grid.h"
#include "isoloft/core/params.h"

namespace isoloft {

/// Sigma quantum of the kernel tables, px.
inline constexpr double kSigmaQuantum = 1.0 / 256.0;
/// Largest sigma_max accepted, px (a 385 x 385 stencil).
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

/// Equation 3: sigma at |d| = abs_d. \pre params valid.
double filter_sigma(double abs_d, const FilterParams& params);

/// The filter, parallel over rows; d itself if !params.enabled.
/// \param only if given (d's size): only its non-zero pixels are filtered,
///        each to the value of the whole run bit for bit; the others keep d.
/// \throw ParamError for parameters out of range or d_min >= d_max or
///        sigma_min > sigma_max, or `only` of another size; InputError if d
///        holds NaN.
/// @warning +-infinity passes only where the whole stencil shares it.
Grid2f distance_filter(const Grid2f& d, const FilterParams& params = {}, const Grid2u8* only = nullptr);

/// Stencil radius of the filter at its widest (sigma_max), px: a filtered
/// pixel reads d within this (Chebyshev) distance.
int filter_reach(const FilterParams& params);

namespace detail {

/// sigma rounded to a multiple of kSigmaQuantum.
double quantized_sigma(double sigma);

/// Serial twin for tests: 2D weights per stencil pixel, summed in double.
Grid2f distance_filter_naive(const Grid2f& d, const FilterParams& params);

}  // namespace detail
}  // namespace isoloft
