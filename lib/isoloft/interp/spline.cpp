#include "isoloft/interp/spline.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {

namespace {

// Three-point (parabolic) derivative estimate at interior knot i; one-sided
// three-point at the ends (exact for quadratics, any spacing). f(k): knot k's
// value (a column's span, or one pixel of each knot's plane); slope(k): the
// secant (f(k + 1) - f(k)) / (z[k + 1] - z[k]) (computed, or held).
template <class S>
double parabolic_tangent_at(std::span<const double> z, const S& slope, std::size_t i) {
  const std::size_t n = z.size();
  if (n == 2) return slope(0);
  if (i == 0) {
    const double h0 = z[1] - z[0], h1 = z[2] - z[1];
    return ((2 * h0 + h1) * slope(0) - h0 * slope(1)) / (h0 + h1);
  }
  if (i == n - 1) {
    const double h0 = z[n - 2] - z[n - 3], h1 = z[n - 1] - z[n - 2];
    return ((2 * h1 + h0) * slope(n - 2) - h1 * slope(n - 3)) / (h0 + h1);
  }
  const double hl = z[i] - z[i - 1], hr = z[i + 1] - z[i];
  return (hr * slope(i - 1) + hl * slope(i)) / (hl + hr);
}

// Hyman's filter: clamp m into the monotone region given the neighbouring secants.
double hyman_clamp(double m, double dl, double dr, bool has_l, bool has_r) {
  if (!has_l) dl = dr;
  if (!has_r) dr = dl;
  if (dl * dr <= 0.0) return 0.0;  // local extremum (or flat): Hyman sets the tangent to zero
  const double bound = 3.0 * std::min(std::abs(dl), std::abs(dr));
  const double s = dl > 0 ? 1.0 : -1.0;
  return s * std::clamp(s * m, 0.0, bound);
}

// Both kinds' tangent at an interior knot (hl, hr: its intervals) where the
// secants dl, dr beside it share a sign: Hyman's clamp of the parabolic
// tangent (hyman_clamp(parabolic_tangent_at), the same expressions); 0 where
// they do not (right where both are 0, e.g. a plateau of kNoSurfaceDistance;
// the others, appended to `redo`, are for the caller to redo). Two pixels at
// a time in vector registers: each lane the scalar arithmetic, so the same
// floats (GCC's vectoriser leaves the scalar loop's selects as branches).
void interior_tangents(const double* dl, const double* dr, float* out, std::size_t np, double hl, double hr,
                       std::vector<std::uint32_t>& redo) {
  auto one = [&](std::size_t q) {
    const double l = dl[q], r = dr[q];
    if (!(l * r > 0.0) && (l != 0.0 || r != 0.0)) redo.push_back(std::uint32_t(q));
    const double m = (hr * l + hl * r) / (hl + hr);
    const double bound = 3.0 * std::min(std::abs(l), std::abs(r));
    const double s = l > 0 ? 1.0 : -1.0;
    return l * r > 0.0 ? s * std::clamp(s * m, 0.0, bound) : 0.0;
  };
  std::size_t q = 0;
#if defined(__GNUC__)
  using V2d = double __attribute__((vector_size(16)));
  using V2l = long long __attribute__((vector_size(16)));
  using V2f = float __attribute__((vector_size(8)));
  const V2d vhl = {hl, hl}, vhr = {hr, hr}, vhs = {hl + hr, hl + hr}, zero = {0.0, 0.0}, plus = {1.0, 1.0},
            three = {3.0, 3.0};
  const V2l magnitude = {0x7fffffffffffffffLL, 0x7fffffffffffffffLL};  // std::abs
  for (; q + 2 <= np; q += 2) {
    V2d l, r;
    std::memcpy(&l, dl + q, sizeof l);
    std::memcpy(&r, dr + q, sizeof r);
    const V2d m = (vhr * l + vhl * r) / vhs;
    const V2d al = V2d(V2l(l) & magnitude), ar = V2d(V2l(r) & magnitude);
    const V2d bound = three * (ar < al ? ar : al);  // std::min(al, ar)
    const V2d s = l > zero ? plus : -plus;
    const V2d v = s * m, above = v < zero ? zero : v;  // std::clamp: min(max(v, 0), bound)
    const V2l shared = l * r > zero;
    const V2d t = shared ? s * (bound < above ? bound : above) : zero;
    const V2f f = __builtin_convertvector(t, V2f);
    std::memcpy(out + q, &f, sizeof f);
    const V2l other = ~shared & ((l != zero) | (r != zero));
    if (other[0] | other[1]) {
      if (other[0]) redo.push_back(std::uint32_t(q));
      if (other[1]) redo.push_back(std::uint32_t(q + 1));
    }
  }
#endif
  for (; q < np; ++q) out[q] = float(one(q));
}

// The monotone (Hyman) tangent at knot i; slope as parabolic_tangent_at's.
template <class S>
double monotone_tangent(std::span<const double> z, const S& slope, std::size_t i) {
  const std::size_t n = z.size();
  const bool has_l = i > 0, has_r = i + 1 < n;
  return hyman_clamp(parabolic_tangent_at(z, slope, i), has_l ? slope(i - 1) : 0.0, has_r ? slope(i) : 0.0, has_l, has_r);
}

// Derivative at z[i] of the parabola through knots a < b < c (one of them i).
template <class S>
double parabola_slope(std::span<const double> z, const S& slope, std::size_t a, std::size_t i) {
  const double za = z[a], zb = z[a + 1], zc = z[a + 2], x = z[i];
  const double d1 = slope(a), d2 = slope(a + 1);
  const double c2 = (d2 - d1) / (zc - za);  // second divided difference
  return d1 + c2 * ((x - za) + (x - zb));
}

// Extremum-preserving tangent (Dougherty, Edelman, Hyman 1989, section 4):
// Hyman's where the data are monotone at i; at a data extremum, instead of 0,
// the centred parabola's slope when the neighbouring parabolas agree with it
// in sign and the second differences keep one sign (a smooth extremum, not
// noise), limited to 1.5x the smallest of them, and to 3 |f_i| / h on the side
// it moves toward 0, so no interval whose knots share a sign crosses 0 (DEH's
// nonnegativity condition).
template <class F, class S>
double extremum_tangent(std::span<const double> z, const F& f, const S& slope, std::size_t i) {
  const std::size_t n = z.size();
  const double p0 = parabolic_tangent_at(z, slope, i);
  if (i == 0 || i + 1 == n) return hyman_clamp(p0, i > 0 ? slope(i - 1) : 0.0, i + 1 < n ? slope(i) : 0.0, i > 0, i + 1 < n);
  const double dl = slope(i - 1), dr = slope(i);
  if (dl * dr > 0.0) return hyman_clamp(p0, dl, dr, true, true);
  // A flat interval beside i: the extremum is the plateau's if the secant
  // beyond it turns back (a peak spanning two knots), else the data run on
  // monotone past a plateau and Hyman's 0 keeps it.
  const double el = dl == 0.0 && i >= 2 ? slope(i - 2) : dl, er = dr == 0.0 && i + 2 < n ? slope(i + 1) : dr;
  if (el * er >= 0.0 || p0 == 0.0) return 0.0;
  const double curvature = dr - dl;  // sign of the second difference at i
  double bound = std::abs(p0);
  bool smooth = false;
  if (i >= 2) {  // left parabola (i-2, i-1, i)
    const double pl = parabola_slope(z, slope, i - 2, i);
    if (pl * p0 <= 0.0 || (dl - slope(i - 2)) * curvature <= 0.0) return 0.0;
    bound = std::min(bound, 1.5 * std::abs(pl));
    smooth = true;
  }
  if (i + 2 < n) {  // right parabola (i, i+1, i+2)
    const double pr = parabola_slope(z, slope, i, i);
    if (pr * p0 <= 0.0 || (slope(i + 1) - dr) * curvature <= 0.0) return 0.0;
    bound = std::min(bound, 1.5 * std::abs(pr));
    smooth = true;
  }
  if (!smooth) return 0.0;  // three knots: nothing tells a smooth extremum from a kink
  // Moving toward 0: into the right interval if p0 and f_i differ in sign.
  const double fi = f(i);
  const double h = p0 * fi < 0.0 ? z[i + 1] - z[i] : z[i] - z[i - 1];
  bound = std::min(bound, 3.0 * std::abs(fi) / h);
  return p0 > 0.0 ? bound : -bound;
}

}  // namespace

void spline_tangents(SplineKind kind, std::span<const double> z, std::span<const double> f, std::span<double> m) {
  spline_tangents(kind, z, f, m, 0, z.size() - 1);
}

void spline_tangents(SplineKind kind, std::span<const double> z, std::span<const double> f, std::span<double> m,
                     std::size_t lo, std::size_t hi) {
  const std::size_t n = z.size();
  auto slope = [&](std::size_t k) { return (f[k + 1] - f[k]) / (z[k + 1] - z[k]); };
  switch (kind) {
    case SplineKind::Linear:
      for (std::size_t i = lo; i <= hi; ++i) m[i] = 0.0;
      return;
    case SplineKind::CatmullRom:
      for (std::size_t i = lo; i <= hi; ++i) {
        if (i == 0) m[i] = slope(0);
        else if (i == n - 1) m[i] = slope(n - 2);
        else m[i] = (f[i + 1] - f[i - 1]) / (z[i + 1] - z[i - 1]);
      }
      return;
    case SplineKind::Monotone:
      for (std::size_t i = lo; i <= hi; ++i) m[i] = monotone_tangent(z, slope, i);
      return;
    case SplineKind::ExtremumPreserving:
      for (std::size_t i = lo; i <= hi; ++i) m[i] = extremum_tangent(z, [&](std::size_t k) { return f[k]; }, slope, i);
      return;
    case SplineKind::Natural: {
      // Second derivatives M with M_0 = M_{n-1} = 0 (Thomas algorithm), then
      // Hermite tangents m_i = D_i - h_i (2 M_i + M_{i+1}) / 6.
      std::vector<double> M(n, 0.0), c(n, 0.0), d(n, 0.0);
      for (std::size_t i = 1; i + 1 < n; ++i) {
        const double hl = z[i] - z[i - 1], hr = z[i + 1] - z[i];
        const double a = hl / 6, b = (hl + hr) / 3, cc = hr / 6;
        const double rhs = slope(i) - slope(i - 1);
        const double denom = b - a * c[i - 1];
        c[i] = cc / denom;
        d[i] = (rhs - a * d[i - 1]) / denom;
      }
      for (std::size_t i = n - 1; i-- > 1;) M[i] = d[i] - c[i] * M[i + 1];
      for (std::size_t i = lo; i <= hi && i + 1 < n; ++i) m[i] = slope(i) - (z[i + 1] - z[i]) * (2 * M[i] + M[i + 1]) / 6;
      if (hi == n - 1) m[n - 1] = slope(n - 2) + (z[n - 1] - z[n - 2]) * (M[n - 2] + 2 * M[n - 1]) / 6;
      return;
    }
  }
}

double hermite(SplineKind kind, double z0, double z1, double f0, double f1, double m0, double m1, double z) {
  return HermiteBasis(kind, z0, z1, z).value(f0, f1, m0, m1);
}

std::size_t knot_interval(const std::vector<double>& z, double q) {
  q = std::clamp(q, z.front(), z.back());
  const auto it = std::upper_bound(z.begin(), z.end(), q);
  const std::size_t k = it == z.begin() ? 0 : std::size_t(it - z.begin()) - 1;
  return std::min(k, z.size() - 2);
}

namespace {
void check_knots(const std::vector<double>& z) {
  if (z.size() < 2) throw ParamError("spline needs at least 2 knots");
  for (std::size_t i = 1; i < z.size(); ++i)
    if (!(z[i] > z[i - 1])) throw ParamError("spline knots must be strictly increasing (z[" + std::to_string(i) + "])");
}
}  // namespace

Spline1D::Spline1D(std::vector<double> z, std::vector<double> f, SplineKind kind)
    : z_(std::move(z)), f_(std::move(f)), m_(z_.size()), kind_(kind) {
  check_knots(z_);
  if (f_.size() != z_.size()) throw ParamError("spline: z and f differ in length");
  spline_tangents(kind_, z_, f_, m_);
}

double Spline1D::operator()(double q) const {
  if (q <= z_.front()) return f_.front();
  if (q >= z_.back()) return f_.back();
  const std::size_t k = knot_interval(z_, q);
  return hermite(kind_, z_[k], z_[k + 1], f_[k], f_[k + 1], m_[k], m_[k + 1], q);
}

ZInterpolator::ZInterpolator(std::vector<Grid2f> slices, std::vector<double> z, SplineKind kind)
    : ZInterpolator(std::move(slices), z, kind, 0, z.empty() ? 0 : z.size() - 1) {}

ZInterpolator::ZInterpolator(std::vector<Grid2f> slices, std::vector<double> z, SplineKind kind, std::size_t lo,
                             std::size_t hi)
    : ZInterpolator(std::move(slices), std::move(z), kind, lo, hi, {}) {}

std::vector<Grid2f> ZInterpolator::take_tangents(std::size_t lo, std::size_t hi) {
  if (lo > hi || hi >= tangents_.size()) throw ParamError("interpolator: tangent knots out of range");
  return {std::make_move_iterator(tangents_.begin() + long(lo)), std::make_move_iterator(tangents_.begin() + long(hi) + 1)};
}

ZInterpolator::ZInterpolator(std::vector<Grid2f> slices, std::vector<double> z, SplineKind kind, std::size_t lo,
                             std::size_t hi, std::vector<Grid2f> given)
    : slices_(std::move(slices)), z_(std::move(z)), kind_(kind) {
  check_knots(z_);
  if (slices_.size() != z_.size()) throw ParamError("interpolator: slice count differs from z count");
  const int w = slices_.front().width, h = slices_.front().height;
  for (const auto& s : slices_)
    if (s.width != w || s.height != h) throw ParamError("interpolator: slices differ in size");
  const std::size_t n = z_.size();
  if (lo > hi || hi >= n || given.size() > hi - lo + 1) throw ParamError("interpolator: tangent knots out of range");
  for (const Grid2f& g : given)
    if (!g.empty() && (g.width != w || g.height != h)) throw ParamError("interpolator: given tangents differ in size");
  // Planes only for the tangents asked for (a window's others are never
  // read); linear splines read none.
  tangents_.resize(n);
  for (std::size_t i = lo; i <= hi; ++i)
    tangents_[i] = i - lo < given.size() ? std::move(given[i - lo])
                   : kind_ == SplineKind::Linear ? Grid2f()
                                                 : Grid2f(w, h, 0.0f);
  lo += given.size();  // the knots left to compute: lo..hi
  if (kind_ == SplineKind::Linear || lo > hi) return;
  // Monotone and extremum-preserving (the default) tangents read knots
  // i-2..i+2 only: knot by knot over contiguous pixels, not column by
  // column, each secant of the intervals they read divided once per pixel.
  const std::size_t s0 = lo - std::min<std::size_t>(lo, 2), s1 = std::min(n - 2, hi + 1);  // secants s0..s1
  auto knot_by_knot = [&](const auto& tangent) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, std::size_t(w) * h, 4096), [&](const auto& r) {
      const std::size_t np = r.size();
      std::vector<double> secant((s1 - s0 + 1) * np);
      std::vector<std::uint32_t> redo;  // an interior knot's pixels for the whole rule
      for (std::size_t k = s0; k <= s1; ++k) {
        const float *a = slices_[k].data.data() + r.begin(), *b = slices_[k + 1].data.data() + r.begin();
        const double dz = z_[k + 1] - z_[k];
        double* sk = secant.data() + (k - s0) * np;
        for (std::size_t q = 0; q < np; ++q) sk[q] = (double(b[q]) - double(a[q])) / dz;
      }
      for (std::size_t k = lo; k <= hi; ++k) {
        float* out = tangents_[k].data.data();
        auto exact = [&](std::size_t p) {
          const std::size_t q = p - r.begin();
          out[p] = float(tangent([&](std::size_t j) { return double(slices_[j].data[p]); },
                                 [&](std::size_t j) { return secant[(j - s0) * np + q]; }, k));
        };
        if (k == 0 || k + 1 == n) {
          for (std::size_t p = r.begin(); p != r.end(); ++p) exact(p);
          continue;
        }
        // An interior knot: interior_tangents, then the whole rule where the
        // secants differ in sign (an extremum) or one of them is 0.
        const double* dl = secant.data() + (k - 1 - s0) * np;
        const double* dr = secant.data() + (k - s0) * np;
        redo.clear();
        interior_tangents(dl, dr, out + r.begin(), np, z_[k] - z_[k - 1], z_[k + 1] - z_[k], redo);
        for (const std::uint32_t q : redo) exact(r.begin() + q);
      }
    });
  };
  const std::span<const double> zs(z_);
  if (kind_ == SplineKind::Monotone) {
    knot_by_knot([&](const auto&, const auto& slope, std::size_t i) { return monotone_tangent(zs, slope, i); });
    return;
  }
  if (kind_ == SplineKind::ExtremumPreserving) {
    knot_by_knot([&](const auto& f, const auto& slope, std::size_t i) { return extremum_tangent(zs, f, slope, i); });
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, std::size_t(w) * h, 4096), [&](const auto& r) {
    std::vector<double> f(n), m(n);
    for (std::size_t p = r.begin(); p != r.end(); ++p) {
      for (std::size_t k = 0; k < n; ++k) f[k] = slices_[k].data[p];
      spline_tangents(kind_, z_, f, m, lo, hi);
      for (std::size_t k = lo; k <= hi; ++k) tangents_[k].data[p] = float(m[k]);
    }
  });
}

std::size_t ZInterpolator::interval(double q) const { return knot_interval(z_, q); }

void ZInterpolator::sides(std::size_t k, float iso, float margin, Grid2<std::int8_t>& out) const {
  const int w = width(), h = height();
  if (out.width != w || out.height != h) out = Grid2<std::int8_t>(w, h);
  const Grid2f &f0 = slices_.at(k), &f1 = slices_.at(k + 1);
  // Monotone and linear intervals stay between their knots; any other cubic
  // Hermite piece within h (|m0| + |m1|) 4/27 of them (the largest |h10|, |h11|).
  const bool between = kind_ == SplineKind::Monotone || kind_ == SplineKind::Linear;
  const Grid2f &m0 = tangents_.at(k), &m1 = tangents_.at(k + 1);
  if (!between && (m0.empty() || m1.empty())) throw ParamError("spline: sides() of an interval without tangents");
  const float reach = float((z_[k + 1] - z_[k]) * 4.0 / 27.0);
  const float above = iso + margin, below = iso - margin;
  const float *a = f0.data.data(), *b = f1.data.data();
  const float *ma = between ? nullptr : m0.data.data(), *mb = between ? nullptr : m1.data.data();
  std::int8_t* o = out.data.data();
  const std::size_t n = out.data.size();
  std::size_t p = 0;
#if defined(__GNUC__)
  // Four pixels at a time in vector registers, each lane the scalar rule
  // below (the same result; GCC leaves its nested select a branch).
  using V4f = float __attribute__((vector_size(16)));
  using V4i = std::int32_t __attribute__((vector_size(16)));
  using V4c = std::int8_t __attribute__((vector_size(4)));
  const V4i magnitude = V4i{} + 0x7fffffff, plus = V4i{} + 1, minus = V4i{} - 1, none = V4i{};  // std::abs
  const V4f vreach = V4f{} + reach, vabove = V4f{} + above, vbelow = V4f{} + below;
  for (; p + 4 <= n; p += 4) {
    V4f va, vb, slack = V4f{};
    std::memcpy(&va, a + p, sizeof va);
    std::memcpy(&vb, b + p, sizeof vb);
    if (!between) {
      V4f m0p, m1p;
      std::memcpy(&m0p, ma + p, sizeof m0p);
      std::memcpy(&m1p, mb + p, sizeof m1p);
      slack = vreach * (V4f(V4i(m0p) & magnitude) + V4f(V4i(m1p) & magnitude));
    }
    const V4f lo = (vb < va ? vb : va) - slack, hi = (va < vb ? vb : va) + slack;  // std::min, std::max
    const V4i r = lo > vabove ? plus : (hi < vbelow ? minus : none);
    const V4c c = __builtin_convertvector(r, V4c);
    std::memcpy(o + p, &c, sizeof c);
  }
#endif
  for (; p < n; ++p) {
    const float slack = between ? 0.0f : reach * (std::abs(ma[p]) + std::abs(mb[p]));
    const float lo = std::min(a[p], b[p]) - slack, hi = std::max(a[p], b[p]) + slack;
    o[p] = lo > above ? 1 : hi < below ? -1 : 0;
  }
}

long PixelRuns::pixels() const {
  long n = 0;
  for (const auto& r : runs) n += long(r[1] - r[0]);
  return n;
}

void ZInterpolator::evaluate(double q, Grid2f& out, const PixelRuns* only) const {
  const int w = width(), h = height();
  if (only && (out.width != w || out.height != h || only->first.size() != std::size_t(h) + 1))
    throw ParamError("spline: pixel runs for a " + std::to_string(w) + "x" + std::to_string(h) + " plane expected");
  if (out.width != w || out.height != h) out = Grid2f(w, h);
  const std::size_t k = interval(q);
  q = std::clamp(q, z_.front(), z_.back());
  const Grid2f &f0 = slices_[k], &f1 = slices_[k + 1], &m0 = tangents_[k], &m1 = tangents_[k + 1];
  if (kind_ != SplineKind::Linear && (m0.empty() || m1.empty()))
    throw ParamError("spline: evaluate() in an interval without tangents");
  const HermiteBasis basis(kind_, z_[k], z_[k + 1], q);
  const float *a = f0.data.data(), *b = f1.data.data(), *ma = m0.data.data(), *mb = m1.data.data();
  float* o = out.data.data();
  auto span = [&](std::size_t p0, std::size_t p1) {  // pixels [p0, p1)
    if (basis.linear) {
      for (std::size_t p = p0; p < p1; ++p) o[p] = float(double(a[p]) + basis.t * (double(b[p]) - double(a[p])));
      return;
    }
    const double h00 = basis.h00, h10h = basis.h10h, h01 = basis.h01, h11h = basis.h11h;
    for (std::size_t p = p0; p < p1; ++p)  // HermiteBasis::value, vectorised
      o[p] = float(h00 * double(a[p]) + h10h * double(ma[p]) + h01 * double(b[p]) + h11h * double(mb[p]));
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const tbb::blocked_range<int>& rows) {
    if (!only) {
      span(f0.index(0, rows.begin()), f0.index(0, rows.end() - 1) + std::size_t(w));
      return;
    }
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (std::int32_t r = only->first[std::size_t(y)]; r < only->first[std::size_t(y) + 1]; ++r) {
        const auto& run = only->runs[std::size_t(r)];
        span(f0.index(run[0], y), f0.index(run[1] - 1, y) + 1);
      }
  });
}

Grid2f cap_slice(const Grid2f& end, const InterpParams& params, double reach, const Grid2f* next, double spacing) {
  Grid2f c = end;
  // Round and slab: never above the end slice's own trend continued over the reach.
  const bool trend = next && !next->empty() && next->size() == end.size() && spacing > 0;
  auto follow_trend = [&] {
    if (!trend) return;
    const double k = reach / spacing;
    for (std::size_t i = 0; i < c.size(); ++i)
      c.data[i] = std::min(c.data[i], float(end.data[i] + (double(end.data[i]) - next->data[i]) * k));
  };
  const float depth = float(params.cap_depth);
  float top = 0.0f;
  for (float v : end.data) top = std::max(top, v);
  switch (params.cap_shape) {
    case CapShape::Flat:
      for (float& v : c.data) v = std::min(v, 0.0f) - depth;
      return c;
    case CapShape::Dome:
      for (float& v : c.data) v -= top + depth;
      return c;
    case CapShape::Slab:
      for (float& v : c.data) v = std::min(v, 0.0f) - kLidDepth;
      follow_trend();
      return c;
    case CapShape::Round: {
      // A line from f (end slice) to c (reach beyond) crosses 0 at t = f / (f - c);
      // c = f - f / (lambda g) puts it at t = lambda g(f / top), g(s) = sqrt(1 - (1 - s)^2).
      const double lambda = top > 0 && reach > 0 ? std::min(1.0, double(top) / reach) : 1.0;
      for (float& v : c.data) {
        if (v > 0) {
          const double s = std::min(1.0, double(v) / top), g = std::sqrt(1.0 - (1.0 - s) * (1.0 - s));
          v = float(double(v) - double(v) / (lambda * g));
        }
        v -= kLidDepth;
      }
      follow_trend();
      return c;
    }
  }
  return c;
}

void add_end_caps(std::vector<Grid2f>& slices, std::vector<double>& z, const InterpParams& params) {
  if (slices.size() < 2 || slices.size() != z.size()) throw ParamError("end caps need at least 2 slices");
  params_table<InterpParams>().validate(params);
  const double h0 = z[1] - z[0], hn = z[z.size() - 1] - z[z.size() - 2];
  const std::size_t n = slices.size();
  Grid2f first = cap_slice(slices.front(), params, params.cap_extent * h0, &slices[1], h0),
         last = cap_slice(slices.back(), params, params.cap_extent * hn, &slices[n - 2], hn);
  slices.insert(slices.begin(), std::move(first));
  z.insert(z.begin(), z.front() - params.cap_extent * h0);
  slices.push_back(std::move(last));
  z.push_back(z.back() + params.cap_extent * hn);
}

}  // namespace isoloft
