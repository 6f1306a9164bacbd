// ZStream (interp/z_stream.h): the values of a whole ZInterpolator, bit for
// bit, for every spline kind, while holding a window of knots whose size does
// not grow with the knot count (the natural spline, which couples all knots,
// shows that the count would catch a stream holding everything).
#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/interp/spline.h"
#include "isoloft/interp/z_stream.h"
#include "isoloft/mesh/stream_mesher.h"

using namespace isoloft;

namespace {

constexpr int kW = 7, kH = 5;

// Non-uniform knots and fields that rise, fall and turn, so that tangents are
// clamped, zero and free somewhere.
std::vector<double> knot_z(std::size_t n) {
  std::vector<double> z;
  for (std::size_t i = 0; i < n; ++i) z.push_back(1.5 * double(i) + 0.6 * std::sin(1.7 * double(i)));
  return z;
}
std::vector<Grid2f> knot_fields(std::size_t n) {
  std::vector<Grid2f> f;
  for (std::size_t i = 0; i < n; ++i) {
    Grid2f g(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) g(x, y) = float(3.0 * std::sin(0.9 * double(i) + 0.7 * x) + 0.5 * y - 1.0);
    f.push_back(std::move(g));
  }
  return f;
}

// A stream pulling copies of `fields` in order.
ZStream stream_of(const std::vector<Grid2f>& fields, SplineKind kind, ResidentCount* count, std::size_t block) {
  auto next = [&fields, i = std::size_t(0)]() mutable { return fields.at(i++); };
  return ZStream(knot_z(fields.size()), kind, kW, kH, next, count, block);
}

// Planes every 0.37 plus every knot exactly (where an interval begins).
std::vector<double> planes_of(const std::vector<double>& z) {
  std::vector<double> q = sample_planes(z.front(), z.back(), 0.37);
  q.insert(q.end(), z.begin(), z.end());
  std::sort(q.begin(), q.end());
  q.erase(std::unique(q.begin(), q.end()), q.end());
  return q;
}

// Reads every plane of n knots in order; returns the peak count.
long read_all(ZStream& s, std::size_t n, const ResidentCount& count) {
  Grid2f out;
  for (const double q : planes_of(knot_z(n))) {
    s.reach(s.interval(q));
    s.evaluate(q, out);
  }
  return count.peak;
}

}  // namespace

TEST(ZStream, GivesTheWholeInterpolatorsValuesBitForBit) {
  for (const auto& [kind, name] : kSplineKindNames) {
    for (const std::size_t n : {2, 3, 4, 5, 9, 23}) {
      for (const std::size_t block : {1, 2, 8}) {
        const std::string what = std::string(name) + ", " + std::to_string(n) + " knots, block " + std::to_string(block);
        const std::vector<Grid2f> fields = knot_fields(n);
        const ZInterpolator whole(fields, knot_z(n), kind);
        ZStream stream = stream_of(fields, kind, nullptr, block);
        Grid2f a, b;
        Grid2<std::int8_t> sa, sb;
        for (const double q : planes_of(knot_z(n))) {
          const std::size_t k = whole.interval(q);
          ASSERT_EQ(stream.interval(q), k) << what << " at z " << q;
          stream.reach(k);
          stream.evaluate(q, a);
          whole.evaluate(q, b);
          ASSERT_EQ(a.data, b.data) << what << " at z " << q;
          for (const std::size_t i : {k, k - 1}) {  // the mesher reads this layer's and the previous one's
            if (i > k) continue;                     // k - 1 wrapped
            stream.sides(i, 0.0f, kSideMargin, sa);
            whole.sides(i, 0.0f, kSideMargin, sb);
            ASSERT_EQ(sa.data, sb.data) << what << " sides of interval " << i;
          }
        }
      }
    }
  }
}

TEST(ZStream, RejectsReadingOutsideTheReachedInterval) {
  const std::vector<Grid2f> fields = knot_fields(30);
  ZStream s = stream_of(fields, SplineKind::Monotone, nullptr, 2);
  Grid2f out;
  EXPECT_THROW(s.evaluate(knot_z(30)[1], out), ParamError);  // nothing reached yet
  s.reach(10);
  EXPECT_THROW(s.reach(3), ParamError);  // passed already
  EXPECT_THROW(s.evaluate(knot_z(30)[25], out), ParamError);
}

// The knots held at once: Monotone's window, 2 (block + 1 + reach above +
// reach + 1 below, for the sides of the interval before it) knots and
// tangents plus the 2 reach + 2 knots shared with the next block.
constexpr std::size_t kMonotoneReach = 2;
constexpr long kMonotoneBound = long(2 * (kZStreamBlock + 2 + 2 * kMonotoneReach) + 2 * kMonotoneReach + 2);

TEST(ZStream, HoldsAWindowOfKnotsThatDoesNotGrowWithTheKnotsUnlessNatural) {
  ASSERT_EQ(tangent_reach(SplineKind::Monotone), kMonotoneReach);
  long monotone_peak = 0;
  for (const std::size_t n : {40, 160}) {
    const std::vector<Grid2f> fields = knot_fields(n);
    ResidentCount count;
    {
      ZStream s = stream_of(fields, SplineKind::Monotone, &count, kZStreamBlock);
      const long peak = read_all(s, n, count);
      EXPECT_LE(peak, kMonotoneBound) << n << " knots";
      if (monotone_peak) {
        EXPECT_EQ(peak, monotone_peak) << "the peak grew from 40 to 160 knots";
      }
      monotone_peak = peak;
    }
    EXPECT_EQ(count.now, 0) << "all released";
    // The natural spline's fallback holds every knot and its tangent: the
    // count exceeds the bound, as it would for any stream holding everything.
    ResidentCount natural;
    {
      ZStream s = stream_of(fields, SplineKind::Natural, &natural, kZStreamBlock);
      EXPECT_EQ(read_all(s, n, natural), long(2 * n)) << n << " knots";
    }
    EXPECT_GT(natural.peak, kMonotoneBound);
  }
}

// Random columns (values in 0.1 px steps around iso, random spacing), every
// kind and block length: the stream, whose windows take over the tangents of
// the knots they share with the window before, gives the whole
// interpolator's values and sides bit for bit.
RC_GTEST_PROP(ZStreamProperty, CarriedTangentsAreTheWholeColumns, ()) {
  const auto kind = *rc::gen::elementOf(std::vector<SplineKind>{SplineKind::Monotone, SplineKind::ExtremumPreserving,
                                                                SplineKind::CatmullRom, SplineKind::Natural,
                                                                SplineKind::Linear});
  const int n = *rc::gen::inRange(2, 16), w = *rc::gen::inRange(1, 6), h = *rc::gen::inRange(1, 4);
  const std::size_t block = *rc::gen::element<std::size_t>(1, 2, 3, 8);
  std::vector<double> z{0.0};
  for (int k = 1; k < n; ++k) z.push_back(z.back() + *rc::gen::inRange(1, 100) / 10.0);
  std::vector<Grid2f> fields;
  for (int k = 0; k < n; ++k) {
    Grid2f g(w, h);
    for (float& v : g.data) v = float(*rc::gen::inRange(-30, 30)) / 10.0f;
    fields.push_back(std::move(g));
  }
  const ZInterpolator whole(fields, z, kind);
  auto next = [&fields, i = std::size_t(0)]() mutable { return fields.at(i++); };
  ZStream stream(z, kind, w, h, next, nullptr, block);
  Grid2f a, b;
  Grid2<std::int8_t> sa, sb;
  for (const double q : sample_planes(z.front(), z.back(), 0.37)) {
    const std::size_t k = whole.interval(q);
    stream.reach(k);
    stream.evaluate(q, a);
    whole.evaluate(q, b);
    RC_ASSERT(a.data == b.data);
    for (const std::size_t i : {k, k - 1}) {
      if (i > k) continue;  // k - 1 wrapped
      stream.sides(i, 0.0f, kSideMargin, sa);
      whole.sides(i, 0.0f, kSideMargin, sb);
      RC_ASSERT(sa.data == sb.data);
    }
  }
}

// A window's interpolator holds the tangents of knots lo..hi only: reading an
// interval beside them throws instead of using tangents never computed.
TEST(ZStream, WindowsReadOnlyTheIntervalsOfTheirTangents) {
  const std::vector<Grid2f> fields = knot_fields(8);
  const ZInterpolator part(fields, knot_z(8), SplineKind::ExtremumPreserving, 2, 4);
  const ZInterpolator whole(fields, knot_z(8), SplineKind::ExtremumPreserving);
  Grid2f a, b;
  Grid2<std::int8_t> s;
  EXPECT_THROW(part.evaluate(knot_z(8)[1], a), ParamError);
  EXPECT_THROW(part.sides(4, 0.0f, kSideMargin, s), ParamError);
  const double q = 0.5 * (knot_z(8)[2] + knot_z(8)[3]);
  part.evaluate(q, a);
  whole.evaluate(q, b);
  EXPECT_EQ(a.data, b.data);
  const ZInterpolator linear(fields, knot_z(8), SplineKind::Linear, 2, 4);
  EXPECT_NO_THROW(linear.evaluate(knot_z(8)[1], a)) << "linear splines read no tangents";
}
