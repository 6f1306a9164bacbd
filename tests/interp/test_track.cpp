// The track z scheme (interp/track.h): the knots come back bit for bit at
// their z; along a trajectory whose values are monotone the field does not
// overshoot; Marching Cubes skipping cells by its sides() gives the mesh of
// visiting every cell; the knots held do not grow with the knot count; the
// bridging rule (interp/track_graph.h) on parts with known answers. Fields:
// exact distances of the tilted-tube kit's masks (synth/tilted_tubes.h), end caps as
// the pipeline's.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/interp/track.h"
#include "isoloft/interp/track_graph.h"
#include "isoloft/methods/method.h"
#include "isoloft/mesh/mesh_check.h"
#include "isoloft/mesh/stream_mesher.h"
#include "isoloft/synth/tilted_tubes.h"

using namespace isoloft;

namespace {

struct Knots {
  std::vector<double> z;
  std::vector<Grid2f> fields;
  int width = 0, height = 0;
};

// The masks' signed distances at their slices, with the pipeline's end caps.
Knots knots_of(const TiltedCase& c) {
  const SynthResult s = synthesize(c, InputKind::Masks);
  Knots k;
  k.width = s.stack.width, k.height = s.stack.height;
  for (const Slice& sl : s.stack.slices) {
    Grid2u8 mask(sl.image.width, sl.image.height);
    for (std::size_t i = 0; i < mask.size(); ++i) mask.data[i] = sl.image.data[i] != 0;
    k.fields.push_back(distance_to_mask_edge_signed(mask));
    k.z.push_back(sl.z);
  }
  add_end_caps(k.fields, k.z, InterpParams{});
  return k;
}

TrackStream stream_of(const Knots& k, const TrackParams& p, SplineKind kind, ResidentCount* count = nullptr) {
  auto next = [&k, i = std::size_t(0)]() mutable { return k.fields.at(i++); };
  return TrackStream(k.z, p, kind, 0.0f, k.width, k.height, next, count);
}

TrackParams with_motion(TrackMotion m) {
  TrackParams p;
  p.motion = m;
  return p;
}

// Cases where parts travel (bridges, screws), fork and stay apart.
std::vector<std::string> kit_cases() { return {"tube80_r3_s8", "fork60_r3_s8", "helix_r3_s8", "two_spheres_R6_s8"}; }

}  // namespace

TEST(Track, GivesBackEveryKnotAtItsZBitForBit) {
  for (const std::string& name : kit_cases()) {
    const Knots k = knots_of(tilted_kit_case(name));
    for (const TrackMotion motion : {TrackMotion::Gated, TrackMotion::RuleOnly, TrackMotion::Auto})
      for (const SplineKind kind : {SplineKind::ExtremumPreserving, SplineKind::Monotone, SplineKind::CatmullRom}) {
        const std::string what = name + ", " + to_string(motion) + ", " + to_string(kind);
        TrackStream s = stream_of(k, with_motion(motion), kind);
        Grid2f out;
        for (std::size_t j = 0; j < k.z.size(); ++j) {
          s.reach(s.interval(k.z[j]));
          s.evaluate(k.z[j], out);
          for (std::size_t p = 0; p < out.size(); ++p)
            ASSERT_EQ(out.data[p], k.fields[j].data[p]) << what << ": knot " << j << ", pixel " << p;
        }
        if (name != "two_spheres_R6_s8")
          EXPECT_GT(s.stats().moving_pieces, 0) << what << ": nothing moved, the test proves less than it says";
      }
  }
}

// A disc moving 6 px per knot (overlap IoU 0.17: gated, it moves) whose
// radius grows: along its centre's trajectory the values rise monotonically,
// and the monotone and extremum-preserving rules keep them between the knots.
TEST(Track, DoesNotOvershootAlongAMonotoneTrajectory) {
  constexpr int kKnots = 6, kW = 60, kH = 24;
  constexpr double kH_z = 8, kStep = 6;  // knot spacing and shift per knot, px
  Knots k;
  k.width = kW, k.height = kH;
  auto centre = [&](std::size_t j) { return Vec2d(10 + kStep * double(j), 12); };
  auto radius = [](std::size_t j) { return 4.0 + 0.5 * double(j); };
  for (std::size_t j = 0; j < kKnots; ++j) {
    Grid2f f(kW, kH);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) f(x, y) = float(radius(j) - (Vec2d(x, y) - centre(j)).norm());
    k.fields.push_back(std::move(f));
    k.z.push_back(kH_z * double(j));
  }
  add_end_caps(k.fields, k.z, InterpParams{});
  for (const SplineKind kind : {SplineKind::Monotone, SplineKind::ExtremumPreserving}) {
    TrackStream s = stream_of(k, TrackParams{}, kind);
    Grid2f out;
    // Knot j of the disc is knot j + 1 of the stream (the cap below comes first).
    for (std::size_t j = 0; j + 1 < kKnots; ++j)
      for (int q = 1; q < 6; ++q) {  // the centre is on a whole pixel at shifts of 1 .. 5 px
        const double t = q / kStep, zq = kH_z * (double(j) + t);
        s.reach(s.interval(zq));
        s.evaluate(zq, out);
        const float v = out(int(10 + kStep * double(j)) + q, 12);
        // Float rounding of the Hermite sum: a few ulps of values near 5 px.
        constexpr float kRounding = 1e-5f;
        EXPECT_GE(v, float(radius(j)) - kRounding) << to_string(kind) << " knot " << j << " + " << t;
        EXPECT_LE(v, float(radius(j + 1)) + kRounding) << to_string(kind) << " knot " << j << " + " << t;
      }
    EXPECT_GT(s.stats().moving_pieces, 0) << to_string(kind) << ": the disc should move";
  }
}

TEST(Track, SkippingCellsGivesTheSameMeshAsVisitingEvery) {
  for (const std::string& name : kit_cases()) {
    const Knots k = knots_of(tilted_kit_case(name));
    for (const SplineKind kind : {SplineKind::ExtremumPreserving, SplineKind::Monotone}) {
      const std::string what = name + ", " + to_string(kind);
      const std::vector<double> planes = sample_planes(k.z.front(), k.z.back(), 1.0);
      TrackStream a = stream_of(k, TrackParams{}, kind), b = stream_of(k, TrackParams{}, kind);
      StreamMeshOptions every;
      every.skip_cells = false;
      const StreamMeshResult full = mesh_interpolated_field(a, planes, 0, 0, {}, every);
      const StreamMeshResult skipping = mesh_interpolated_field(b, planes, 0, 0, {});
      ASSERT_FALSE(full.mesh.empty()) << what;
      EXPECT_EQ(full.mesh.vertices, skipping.mesh.vertices) << what;
      EXPECT_EQ(full.mesh.triangles, skipping.mesh.triangles) << what;
      EXPECT_LT(skipping.cells_visited, skipping.cells / 2) << what << ": most cells should be skipped";
      const MeshCheck check = check_mesh(skipping.mesh);
      EXPECT_TRUE(check.closed && check.manifold && check.oriented) << what;
    }
  }
}

// A disc circling (so every pair moves), 60 and 150 knots: the fields held
// at once are the same few.
TEST(Track, HoldsAWindowOfKnotsThatDoesNotGrowWithTheKnots) {
  // The window's knots, each with its labels until the next arrives (part
  // fields: one part, none), and four grids of the pieces of two intervals.
  constexpr long kBound = 2 * long(kTrackWindow) + 2 * 4;
  long peak_at_fewer = 0;
  for (const std::size_t n : {std::size_t(60), std::size_t(150)}) {
    Knots k;
    k.width = k.height = 40;
    for (std::size_t j = 0; j < n; ++j) {
      const Vec2d c(20 + 10 * std::cos(0.4 * double(j)), 20 + 10 * std::sin(0.4 * double(j)));
      Grid2f f(40, 40);
      for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 40; ++x) f(x, y) = float(4.0 - (Vec2d(x, y) - c).norm());
      k.fields.push_back(std::move(f));
      k.z.push_back(4.0 * double(j));
    }
    add_end_caps(k.fields, k.z, InterpParams{});
    ResidentCount count;
    {
      TrackStream s = stream_of(k, TrackParams{}, SplineKind::ExtremumPreserving, &count);
      Grid2f out;
      for (const double q : sample_planes(k.z.front(), k.z.back(), 1.0)) {
        s.reach(s.interval(q));
        s.evaluate(q, out);
      }
      EXPECT_GT(s.stats().moving_pieces, long(n) / 2) << n << " knots";
    }
    EXPECT_EQ(count.now, 0) << n << " knots: fields still counted after the stream";
    ASSERT_GT(long(n), 2 * kBound) << "too few knots to tell a bound from holding them all";
    EXPECT_LE(count.peak, kBound) << n << " knots";
    if (peak_at_fewer) EXPECT_EQ(count.peak, peak_at_fewer) << n << " knots";
    peak_at_fewer = count.peak;
  }
}

TEST(Track, RejectsReadingOutOfOrderAndBadKnots) {
  const Knots k = knots_of(tilted_kit_case("tube80_r3_s8"));
  TrackStream s = stream_of(k, TrackParams{}, SplineKind::ExtremumPreserving);
  Grid2f out;
  Grid2<std::int8_t> sides;
  EXPECT_THROW(s.evaluate(k.z[2], out), ParamError);  // nothing reached yet
  s.reach(3);
  EXPECT_THROW(s.evaluate(k.z[1], out), ParamError);
  EXPECT_THROW(s.sides(1, 0, kSideMargin, sides), ParamError);
  EXPECT_THROW(s.reach(2), ParamError);
  EXPECT_THROW(s.reach(k.z.size() - 1), ParamError);
  EXPECT_NO_THROW(s.sides(3, 0, kSideMargin, sides));
  auto wrong_size = []() { return Grid2f(3, 3, -1.0f); };
  TrackStream bad(k.z, TrackParams{}, SplineKind::Monotone, 0.0f, k.width, k.height, wrong_size);
  EXPECT_THROW(bad.reach(0), ParamError);
  EXPECT_THROW(TrackStream({1.0}, TrackParams{}, SplineKind::Monotone, 0.0f, 4, 4, wrong_size), ParamError);
  TrackParams p;
  p.c_tilt = -1;
  EXPECT_THROW(TrackStream(k.z, p, SplineKind::Monotone, 0.0f, 4, 4, wrong_size), ParamError);
}

// The scheme's parameter rows apply only with --z-scheme track; the z
// spline's with both schemes.
TEST(Track, ItsParametersApplyOnlyToIt) {
  EXPECT_NE(unused_param("track.motion", "isoloft", "columns").find("--z-scheme track"), std::string::npos);
  EXPECT_EQ(unused_param("track.c_tilt", "isoloft", "track"), "");
  EXPECT_EQ(unused_param("interp.spline", "marker2006", "track"), "");
  EXPECT_EQ(unused_param("interp.spline", "marker2006", "columns"), "");
  EXPECT_EQ(z_scheme_spec("track").name, "track");
}

namespace {

// A filled ellipse of semi-axes a (along the angle) and b at c, as a field's parts.
detail::TrackParts ellipse_parts(const std::vector<std::array<double, 5>>& ellipses, int w, int h) {
  Grid2f f(w, h, -1.0f);
  for (const auto& [cx, cy, a, b, angle] : ellipses)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double u = (x - cx) * std::cos(angle) + (y - cy) * std::sin(angle);
        const double v = -(x - cx) * std::sin(angle) + (y - cy) * std::cos(angle);
        if (u * u / (a * a) + v * v / (b * b) <= 1) f(x, y) = 1.0f;
      }
  return detail::track_parts(f, 0.0f);
}

}  // namespace

TEST(TrackGraph, ExtentsOfAFilledEllipseAreItsSemiAxes) {
  const detail::TrackParts p = ellipse_parts({{40, 30, 20, 6, 0.3}}, 80, 60);
  ASSERT_EQ(p.parts.size(), 1u);
  const auto [along, across] = detail::part_extents(p.parts[0], Vec2d(std::cos(0.3), std::sin(0.3)));
  // Pixelisation of a 6 px semi-axis: a fraction of a pixel.
  constexpr double kPixelised = 0.3;
  EXPECT_NEAR(along, 20, kPixelised);
  EXPECT_NEAR(across, 6, kPixelised);
  EXPECT_NEAR(p.parts[0].angle, 0.3, 0.01);
  EXPECT_NEAR(p.parts[0].anisotropy, 20.0 / 6.0, 0.1);
}

// An 80 deg tube of radius 3 seen every 8 px: ellipses 3 x 17.3 px, 45 px
// apart along their long axis (allowed: 17.3 + 1.5 x 8 x 5.7 = 85 px). Discs
// of radius 6 at the same distance predict no motion (allowed 6 px).
TEST(TrackGraph, BridgesPartsStretchedAlongTheirShiftOnly) {
  TrackParams params;
  const double a = 3 / std::cos(80 * M_PI / 180), shift = 8 * std::tan(80 * M_PI / 180);
  const detail::TrackParts lo = ellipse_parts({{30, 20, a, 3, 0}}, 140, 40);
  const detail::TrackParts hi = ellipse_parts({{30 + shift, 20, a, 3, 0}}, 140, 40);
  const detail::BridgeTest tube = detail::bridge_test(lo.parts[0], hi.parts[0], 8, params);
  EXPECT_TRUE(tube.ok) << tube.distance << " > " << tube.allowed;
  const detail::TrackParts across_lo = ellipse_parts({{30, 20, 3, a, 0}}, 140, 40);
  const detail::TrackParts across_hi = ellipse_parts({{30 + shift, 20, 3, a, 0}}, 140, 40);
  EXPECT_FALSE(detail::bridge_test(across_lo.parts[0], across_hi.parts[0], 8, params).ok)
      << "bars side by side, shifted across their length";
  const detail::TrackParts disc_lo = ellipse_parts({{30, 20, 6, 6, 0}}, 140, 40);
  const detail::TrackParts disc_hi = ellipse_parts({{30 + 14, 20, 6, 6, 0}}, 140, 40);
  EXPECT_FALSE(detail::bridge_test(disc_lo.parts[0], disc_hi.parts[0], 8, params).ok) << "discs 2 px apart";
  const std::vector<detail::TrackEdge> edges = detail::candidate_edges(lo, hi, 8, params);
  ASSERT_EQ(edges.size(), 1u);
  EXPECT_TRUE(edges[0].bridge);
  EXPECT_NEAR(edges[0].shift.x(), shift, 0.5);
}

TEST(TrackGraph, ABridgeNeedsAMatchThatShiftsAlike) {
  const detail::TrackEdge bridge{0, 0, Vec2d(45, 0), true, 0};
  const detail::TrackEdge alike{0, 0, Vec2d(40, 10), true, 0}, turned{0, 0, Vec2d(-45, 0), true, 0};
  const detail::TrackEdge elsewhere{1, 1, Vec2d(45, 0), true, 0};
  const double c_vel = TrackParams{}.c_vel;
  auto kept = [&](const std::vector<detail::TrackEdge>* below, const std::vector<detail::TrackEdge>* above) {
    std::vector<detail::TrackEdge> e{bridge};
    detail::drop_unsupported_bridges(e, below, above, c_vel);
    return e.size() == 1;
  };
  const std::vector<detail::TrackEdge> b_alike{alike}, b_turned{turned}, b_elsewhere{elsewhere};
  EXPECT_FALSE(kept(nullptr, nullptr)) << "seen on two slices only";
  EXPECT_TRUE(kept(&b_alike, nullptr));
  EXPECT_TRUE(kept(nullptr, &b_alike));
  EXPECT_FALSE(kept(&b_turned, &b_turned)) << "a reversal is not a continuation";
  EXPECT_FALSE(kept(&b_elsewhere, &b_elsewhere)) << "a match of other parts";
  std::vector<detail::TrackEdge> overlap{{0, 0, Vec2d(1, 0), false, 10}};
  EXPECT_EQ(detail::drop_unsupported_bridges(overlap, nullptr, nullptr, c_vel), 0) << "overlaps need no support";
}

// One part below, two above that both pass the rule: each is the best of its
// upper part, so a fork keeps both; gated motion moves a one-to-one
// barely-overlapping pair and keeps a well-overlapping one still.
TEST(TrackGraph, AForkKeepsBothBranchesAndGatedMotionMovesThinPairsOnly) {
  TrackParams params;
  const detail::TrackParts lo = ellipse_parts({{70, 20, 10, 3, 0}}, 140, 40);
  const detail::TrackParts hi = ellipse_parts({{40, 20, 10, 3, 0}, {100, 20, 10, 3, 0}}, 140, 40);
  const std::vector<detail::TrackEdge> fork = detail::candidate_edges(lo, hi, 8, params);
  ASSERT_EQ(fork.size(), 2u);
  EXPECT_TRUE(fork[0].bridge && fork[1].bridge);

  const detail::TrackParts a = ellipse_parts({{40, 20, 10, 3, 0}}, 140, 40);
  const detail::TrackParts thin = ellipse_parts({{56, 20, 10, 3, 0}}, 140, 40);  // overlap 4 of 20 px along x
  const detail::TrackParts wide = ellipse_parts({{42, 20, 10, 3, 0}}, 140, 40);
  const std::vector<detail::TrackEdge> et = detail::candidate_edges(a, thin, 8, params), ew = detail::candidate_edges(a, wide, 8, params);
  ASSERT_EQ(et.size(), 1u);
  ASSERT_EQ(ew.size(), 1u);
  EXPECT_FALSE(et[0].bridge);
  EXPECT_NEAR(detail::edge_motion(et[0], et, a.parts[0], thin.parts[0], params).dx, 16, 0.5);
  EXPECT_EQ(detail::edge_motion(ew[0], ew, a.parts[0], wide.parts[0], params).dx, 0);
  params.motion = TrackMotion::RuleOnly;
  EXPECT_EQ(detail::edge_motion(et[0], et, a.parts[0], thin.parts[0], params).dx, 0);
  params.motion = TrackMotion::Auto;
  EXPECT_NEAR(detail::edge_motion(ew[0], ew, a.parts[0], wide.parts[0], params).dx, 2, 0.5);
}
