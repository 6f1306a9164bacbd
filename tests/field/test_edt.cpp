// Exact EDT (Felzenszwalb & Huttenlocher) against its O(N^2) twin, and the
// signed conventions of distance_to_contour_signed / distance_to_mask_edge_signed.
#include <gtest/gtest.h>
#include <rapidcheck.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "test_names.h"

namespace isoloft {
namespace {

constexpr int kMaxSide = 40;  // brute force is O(N^2): 40x40 keeps a property run well under a second


/// Exact float comparison: fast and brute force map the same integer squared
/// distance through the same float expression, so no tolerance is needed.
/// Returns "" if equal, else the first few differing pixels.
std::string grid_diff(const Grid2f& got, const Grid2f& want, const char* what) {
  if (got.width != want.width || got.height != want.height)
    return std::string(what) + ": size " + std::to_string(got.width) + "x" + std::to_string(got.height) +
           " vs " + std::to_string(want.width) + "x" + std::to_string(want.height);
  std::string msg;
  int failures = 0;
  for (int y = 0; y < got.height; ++y)
    for (int x = 0; x < got.width; ++x)
      if (!(got(x, y) == want(x, y)) && failures++ < 5)
        msg += std::string(what) + " at " + pixel_at(x, y) + ": got " + std::to_string(got(x, y)) + ", want " +
               std::to_string(want(x, y)) + "\n";
  return msg;
}

/// The mask as text ('#' = 1), shown with a failing property's counterexample.
std::string ascii(const Grid2u8& g) {
  std::string s = std::to_string(g.width) + "x" + std::to_string(g.height) + " mask:\n";
  for (int y = 0; y < g.height; ++y) {
    for (int x = 0; x < g.width; ++x) s += g(x, y) ? '#' : '.';
    s += '\n';
  }
  return s;
}

/// Random 0/1 masks up to kMaxSide square: empty, full, or random density.
rc::Gen<Grid2u8> gen_mask() {
  return rc::gen::exec([] {
    const int w = *rc::gen::inRange(1, kMaxSide + 1);
    const int h = *rc::gen::inRange(1, kMaxSide + 1);
    const int mode = *rc::gen::inRange(0, 6);  // 0 empty, 1 full, 2 a few points, 3..5 random density
    Grid2u8 g(w, h, mode == 1 ? 1 : 0);
    if (mode == 2) {
      // Sparse features give long distances, where envelope errors show.
      const int n = *rc::gen::inRange(1, 6);
      for (int k = 0; k < n; ++k) g(*rc::gen::inRange(0, w), *rc::gen::inRange(0, h)) = 1;
    } else if (mode >= 3) {
      const int percent = *rc::gen::inRange(1, 100);
      const auto bits = *rc::gen::container<std::vector<int>>(g.size(), rc::gen::inRange(0, 100));
      for (std::size_t i = 0; i < g.size(); ++i) g.data[i] = bits[i] < percent ? 1 : 0;
    }
    return g;
  });
}

RC_GTEST_PROP(FieldEdt, SquaredEdtEqualsBruteForce, ()) {
  const Grid2u8 mask = *gen_mask();
  const std::string diff = grid_diff(squared_edt(mask), detail::squared_edt_brute(mask), "squared_edt");
  if (!diff.empty()) RC_FAIL(diff + ascii(mask));
}

RC_GTEST_PROP(FieldEdt, SignedContourDistanceEqualsBruteForce, ()) {
  const Grid2u8 contour = *gen_mask();
  Grid2u8 inside(contour.width, contour.height);
  const auto bits = *rc::gen::container<std::vector<bool>>(inside.size(), rc::gen::arbitrary<bool>());
  for (std::size_t i = 0; i < inside.size(); ++i) inside.data[i] = bits[i] ? 1 : 0;
  const std::string diff = grid_diff(distance_to_contour_signed(contour, inside),
                                     detail::distance_to_contour_signed_brute(contour, inside),
                                     "distance_to_contour_signed");
  if (!diff.empty()) RC_FAIL(diff + ascii(contour));
}

// The nearest label's pixel lies at the brute-force nearest distance (ties
// may go either way, the distance may not).
RC_GTEST_PROP(FieldEdt, NearestLabelIsAtTheNearestDistance, ()) {
  const Grid2u8 mask = *gen_mask();
  Grid2i labels(mask.width, mask.height, -1);
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask.data[i]) labels.data[i] = int(i % 3);  // three labels, interleaved
  const Grid2i near = nearest_label(labels);
  const Grid2f want = detail::nearest_label_brute_sq(labels);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      const int l = near(x, y);
      if (std::isinf(want(x, y))) {
        if (l != -1) RC_FAIL("label without features at " + pixel_at(x, y) + "\n" + ascii(mask));
        continue;
      }
      double best = std::numeric_limits<double>::infinity();
      for (int fy = 0; fy < mask.height; ++fy)
        for (int fx = 0; fx < mask.width; ++fx)
          if (labels(fx, fy) == l) best = std::min(best, double((fx - x) * (fx - x) + (fy - y) * (fy - y)));
      if (best != double(want(x, y)))
        RC_FAIL("label " + std::to_string(l) + " at " + pixel_at(x, y) + " is " + std::to_string(best) + " px^2 away, the nearest " +
                std::to_string(want(x, y)) + "\n" + ascii(mask));
    }
}

RC_GTEST_PROP(FieldEdt, SignedMaskDistanceEqualsBruteForce, ()) {
  const Grid2u8 mask = *gen_mask();
  const std::string diff = grid_diff(distance_to_mask_edge_signed(mask),
                                     detail::distance_to_mask_edge_signed_brute(mask), "distance_to_mask_edge_signed");
  if (!diff.empty()) RC_FAIL(diff + ascii(mask));
}

TEST(FieldEdt, OneDimensionalLowerEnvelope) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> f = {inf, 0.0, inf, inf, 4.0, inf, inf};
  std::vector<double> d(f.size());
  std::vector<int> v;
  std::vector<double> z;
  detail::squared_dt_1d(f.data(), d.data(), int(f.size()), v, z);
  for (int q = 0; q < int(f.size()); ++q) {
    const double want = std::min((q - 1.0) * (q - 1.0), 4.0 + (q - 4.0) * (q - 4.0));
    EXPECT_EQ(d[std::size_t(q)], want) << "sample " << q;
  }
  const std::vector<double> none(5, inf);
  detail::squared_dt_1d(none.data(), d.data(), 5, v, z);
  for (int q = 0; q < 5; ++q) EXPECT_EQ(d[std::size_t(q)], inf) << "sample " << q;
}

TEST(FieldEdt, SingleFeatureGivesSquaredPixelDistances) {
  Grid2u8 f(10, 7);
  f(3, 4) = 1;
  const Grid2f d = squared_edt(f);
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 10; ++x)
      EXPECT_EQ(d(x, y), float((x - 3) * (x - 3) + (y - 4) * (y - 4))) << pixel_at(x, y);
}

TEST(FieldEdt, EmptyFeatureSetsAreDocumentedConstants) {
  const Grid2u8 empty(6, 5);
  const Grid2f sq = squared_edt(empty);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 6; ++x) EXPECT_TRUE(std::isinf(sq(x, y)) && sq(x, y) > 0) << pixel_at(x, y);

  // Empty contour: outside everywhere unless marked inside.
  Grid2u8 inside(6, 5);
  inside(2, 2) = 1;
  const Grid2f c = distance_to_contour_signed(empty, inside);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 6; ++x)
      EXPECT_EQ(c(x, y), (x == 2 && y == 2) ? kNoSurfaceDistance : -kNoSurfaceDistance) << pixel_at(x, y);

  const Grid2f m0 = distance_to_mask_edge_signed(empty);
  const Grid2f m1 = distance_to_mask_edge_signed(Grid2u8(6, 5, 1));
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 6; ++x) {
      EXPECT_EQ(m0(x, y), -kNoSurfaceDistance) << "empty mask at " << pixel_at(x, y);
      EXPECT_EQ(m1(x, y), kNoSurfaceDistance) << "full mask at " << pixel_at(x, y);
    }
}

TEST(FieldEdt, ZeroSizedGrids) {
  EXPECT_TRUE(squared_edt(Grid2u8()).empty());
  EXPECT_TRUE(distance_to_contour_signed(Grid2u8(), Grid2u8()).empty());
  EXPECT_TRUE(distance_to_mask_edge_signed(Grid2u8(0, 3)).empty());
}

TEST(FieldEdt, MaskEdgeLiesHalfwayBetweenPixelCentres) {
  // Half plane x <= 4: the surface is the line x = 4.5.
  Grid2u8 mask(12, 6);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x <= 4; ++x) mask(x, y) = 1;
  const Grid2f d = distance_to_mask_edge_signed(mask);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 12; ++x) EXPECT_EQ(d(x, y), float(4.5 - x)) << pixel_at(x, y);
}

TEST(FieldEdt, ContourDistanceSignConvention) {
  // Vertical contour line at x = 5, inside to its left.
  Grid2u8 contour(11, 4), inside(11, 4);
  for (int y = 0; y < 4; ++y) {
    contour(5, y) = 1;
    for (int x = 0; x <= 5; ++x) inside(x, y) = 1;
  }
  const Grid2f d = distance_to_contour_signed(contour, inside);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 11; ++x) EXPECT_EQ(d(x, y), float(5 - x)) << pixel_at(x, y);
}

TEST(FieldEdt, SizeMismatchThrows) {
  EXPECT_THROW(distance_to_contour_signed(Grid2u8(4, 4), Grid2u8(4, 5)), ParamError);
}

}  // namespace
}  // namespace isoloft
