// Analytic shapes and synthetic stacks: the truth every end-to-end test and
// the accuracy benchmark lean on, so it is checked against closed forms.
#include <gtest/gtest.h>

#include <cmath>

#include "isoloft/contour/fill.h"
#include "isoloft/core/error.h"
#include "isoloft/synth/synth.h"

using namespace isoloft;

namespace {
// Newton projection converges to ~1e-9 px; 1e-6 leaves room for the numeric gradient.
constexpr double kProjectionTol = 1e-6;
}  // namespace

TEST(Shapes, ClosestPointsLieOnTheSurfaceAndNormalsAreUnit) {
  for (const auto& name : shape_names()) {
    const auto s = make_default_shape(name, 100);
    const auto [lo, hi] = s->bounds();
    for (int i = 0; i < 50; ++i) {
      // Scattered points of the bounding box (offset so none is a centre, where the closest point is not unique).
      const Vec3d p = lo + (hi - lo).cwiseProduct(Vec3d((i * 37 % 50 + 0.31) / 50.0, (i * 11 % 50 + 0.17) / 50.0, (i * 23 % 50 + 0.23) / 50.0));
      const Vec3d q = s->closest_point(p);
      EXPECT_NEAR(s->value(q), 0.0, kProjectionTol) << name << " sample " << i;
      EXPECT_NEAR(s->normal(q).norm(), 1.0, kProjectionTol) << name << " sample " << i;
    }
  }
}

TEST(Shapes, ExactShapesMatchTheirClosedForm) {
  const auto sphere = make_default_shape("sphere", 100);
  const nlohmann::json j = sphere->to_json();
  const Vec3d c(j["center"][0], j["center"][1], j["center"][2]);
  const double r = j["radius"];
  const Vec3d p = c + Vec3d(3, 4, 12);  // |p - c| = 13
  EXPECT_NEAR(sphere->value(p), r - 13.0, 1e-12);
  EXPECT_NEAR(sphere->distance(p), std::abs(r - 13.0), 1e-12);
  // Round trip through JSON gives the same function.
  const auto again = shape_from_json(sphere->to_json());
  EXPECT_DOUBLE_EQ(again->value(p), sphere->value(p));
  EXPECT_THROW(shape_from_json({{"type", "cube"}}), ParamError);
  EXPECT_THROW(make_default_shape("cube", 64), ParamError);
}

TEST(Synth, ContourPixelsAreNearTheCurveAndFillRecoversTheInside) {
  SynthParams p;
  p.size = 96;
  p.z_spacing = 8;
  for (const auto& name : shape_names()) {
    const SynthResult r = synthesize(*make_default_shape(name, p.size), p);
    ASSERT_GE(r.stack.slices.size(), 2u) << name;
    for (std::size_t k = 0; k < r.stack.slices.size(); ++k) {
      const auto& s = r.stack.slices[k];
      EXPECT_DOUBLE_EQ(s.z, double(k) * p.z_spacing);
      Grid2u8 contour(s.image.width, s.image.height);
      for (std::size_t i = 0; i < contour.size(); ++i) contour.data[i] = s.image.data[i] ? 1 : 0;
      const FillResult fill = fill_even_odd(contour);
      for (int y = 0; y < contour.height; ++y)
        for (int x = 0; x < contour.width; ++x) {
          const double f = r.shape->value(Vec3d(x, y, s.z));
          if (contour(x, y)) {
            // A marked pixel is the closer end of a crossed pixel edge: its
            // in-plane distance to the curve is at most half a pixel diagonal.
            constexpr double kContourTol = 0.7072;
            EXPECT_LE(std::abs(f), kContourTol) << name << " slice " << k << " pixel (" << x << ", " << y << ")";
          } else {
            ASSERT_EQ(fill.inside(x, y) != 0, f > 0) << name << " slice " << k << " pixel (" << x << ", " << y << ")";
          }
        }
    }
  }
}

TEST(Synth, TiltedTorusSlicesSplitIntoTwoComponentsAndTorusSlicesNest) {
  SynthParams p;
  p.size = 128;
  p.z_spacing = 4;
  int max_components = 0, max_depth = 0;
  for (const std::string name : {"tilted-torus", "torus"}) {
    const SynthResult r = synthesize(*make_default_shape(name, p.size), p);
    for (const auto& s : r.stack.slices) {
      Grid2u8 contour(s.image.width, s.image.height);
      for (std::size_t i = 0; i < contour.size(); ++i) contour.data[i] = s.image.data[i] ? 1 : 0;
      const FillResult fill = fill_even_odd(contour);
      if (name == "tilted-torus") max_components = std::max(max_components, fill.contour_components);
      else max_depth = std::max(max_depth, fill.max_depth);
    }
  }
  EXPECT_GE(max_components, 2);
  EXPECT_GE(max_depth, 2);  // annulus: outside (0) | ring (1) | hole (2)
}

TEST(Synth, PolylinesTraceTheExactCutAsClosedLoops) {
  SynthParams p;
  p.size = 96;
  p.z_spacing = 6;
  p.kind = InputKind::Polylines;
  const SynthResult r = synthesize(*make_default_shape("torus", p.size), p);
  ASSERT_TRUE(r.stack.has_polygons());
  std::size_t max_loops = 0;
  for (std::size_t k = 0; k < r.stack.slices.size(); ++k) {
    const auto& s = r.stack.slices[k];
    max_loops = std::max(max_loops, s.polygons.size());
    for (std::size_t c = 0; c < s.polygons.size(); ++c)
      for (std::size_t i = 0; i < s.polygons[c].points.size(); ++i) {
        const Vec2d& q = s.polygons[c].points[i];
        // Vertices are refined onto the surface by 30 regula-falsi steps.
        constexpr double kVertexTol = 1e-6;
        ASSERT_NEAR(r.shape->value(Vec3d(q.x(), q.y(), s.z)), 0.0, kVertexTol) << "slice " << k << " loop " << c << " vertex " << i;
      }
  }
  EXPECT_EQ(max_loops, 2u) << "a horizontal torus cut through its hole gives an annulus";
}
