// Fields computed only where they reach the mesh (methods/columns/field_band.h):
// the extension stopped at its required pixels and the filter run on its
// needed pixels give those pixels the whole run's values bit for bit, the
// known sides match a brute-force scan, and reconstruct() gives the mesh of
// whole fields bit for bit on traced masks and drawn polygons whose contours
// move far between slices, with empty slices, polygons cut by the image edge,
// for each spline that keeps its knots' side; no band where it could change
// the mesh. A label partition with the band gives every label the mesh of
// whole fields bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "isoloft/field/filter.h"
#include "isoloft/field/marching.h"
#include "isoloft/field/narrow_band.h"
#include "isoloft/pipeline.h"
#include "isoloft/methods/columns/field_band.h"
#include "isoloft/objects/slice_fields.h"
#include "isoloft/synth/tilted_tubes.h"
#include "isoloft/synth/synth.h"

using namespace isoloft;

namespace {

std::string px(std::size_t i, int w) {
  return "pixel (" + std::to_string(i % std::size_t(w)) + ", " + std::to_string(i / std::size_t(w)) + ")";
}

// Two circles' union as samples of a signed distance-like f, and a mask of
// pixels near the first circle only (a band that stops before the far side).
struct TwoCircles {
  static constexpr int n = 96;
  Grid2f f = Grid2f(n, n);
  Grid2u8 near = Grid2u8(n, n, 0);
  TwoCircles() {
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double a = 14.0 - std::hypot(x - 30.0, y - 40.0), b = 9.0 - std::hypot(x - 70.0, y - 60.0);
        f(x, y) = float(std::max(a, b));
        near(x, y) = std::abs(a) < 20.0;
      }
  }
};

TEST(FieldBand, ExtensionStoppedAtRequiredPixelsKeepsTheirValues) {
  const TwoCircles c;
  const NarrowBandResult nb = narrow_band_distance(c.f, {});
  for (const ExtendMethod m : {ExtendMethod::MarchingCorrectness, ExtendMethod::FastMarching}) {
    ExtendParams p;
    p.method = m;
    const Grid2f whole = extend_distance(nb, p);
    const Grid2f part = extend_distance(nb, p, &c.near);
    long differ = 0;
    for (std::size_t i = 0; i < whole.size(); ++i) {
      if (c.near.data[i]) EXPECT_EQ(part.data[i], whole.data[i]) << to_string(m) << " " << px(i, whole.width);
      EXPECT_EQ(part.data[i] > 0, whole.data[i] > 0) << to_string(m) << " sign at " << px(i, whole.width);
      differ += part.data[i] != whole.data[i];
    }
    EXPECT_GT(differ, 0) << to_string(m) << ": the march did not stop early";
  }
}

TEST(FieldBand, FilterOnNeededPixelsKeepsTheirValues) {
  const TwoCircles c;
  const Grid2f d = extend_distance(narrow_band_distance(c.f, {}));
  const FilterParams p;
  const Grid2f whole = distance_filter(d, p);
  const Grid2f part = distance_filter(d, p, &c.near);
  for (std::size_t i = 0; i < whole.size(); ++i)
    EXPECT_EQ(part.data[i], c.near.data[i] ? whole.data[i] : d.data[i]) << px(i, whole.width);
}

TEST(FieldBand, DilateSquareMatchesABruteForceScan) {
  Grid2u8 g(23, 17, 0);
  for (const auto [x, y] : {std::pair{0, 0}, {11, 8}, {22, 3}, {5, 16}}) g(x, y) = 1;
  for (const int r : {0, 1, 3, 30}) {
    const Grid2u8 got = detail::dilate_square(g, r);
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        bool want = false;
        for (int yy = std::max(0, y - r); yy <= std::min(g.height - 1, y + r); ++yy)
          for (int xx = std::max(0, x - r); xx <= std::min(g.width - 1, x + r); ++xx) want = want || g(xx, yy);
        ASSERT_EQ(bool(got(x, y)), want) << "r " << r << " pixel (" << x << ", " << y << ")";
      }
  }
}

TEST(FieldBand, KnownSidesMatchABruteForceScan) {
  SynthParams sp;
  sp.size = 64;
  sp.kind = InputKind::Masks;
  const SliceStack st = synthesize(*make_default_shape("sphere", 64), sp).stack;
  const ReconstructParams p;
  // A box cutting through the sphere (centre 31.5): its ring holds inside pixels.
  const PixelBox box{5, 3, 30, 58};
  constexpr int u = 2;
  for (std::size_t k = 0; k < st.slices.size(); k += 3) {
    const detail::SliceMasks m = detail::slice_masks(st, st.slices[k], p, 0);
    const Grid2<std::int8_t> got = detail::known_sides(detail::pack_masks(m), box, u);
    for (int y = box.y0; y < box.y1; ++y)
      for (int x = box.x0; x < box.x1; ++x) {
        bool near = false;
        for (int yy = std::max(0, y - u); yy <= std::min(st.height - 1, y + u) && !near; ++yy)
          for (int xx = std::max(0, x - u); xx <= std::min(st.width - 1, x + u) && !near; ++xx) near = m.contour(xx, yy);
        const bool ring = x == box.x0 || y == box.y0 || x + 1 == box.x1 || y + 1 == box.y1;
        const int want = m.empty ? -1 : near ? 0 : m.inside(x, y) ? (ring ? 0 : 1) : -1;
        ASSERT_EQ(int(got(x - box.x0, y - box.y0)), want) << "slice " << k << " pixel (" << x << ", " << y << ")";
      }
  }
}

// Slices of a shape cut `dz` apart, size x size, as `kind`; the slices in
// `emptied` made empty.
SliceStack cut(const char* shape, int size, double dz, InputKind kind, std::vector<std::size_t> emptied = {}) {
  SynthParams sp;
  sp.size = size;
  sp.z_spacing = dz;
  sp.kind = kind;
  SliceStack st = synthesize(*make_default_shape(shape, size), sp).stack;
  for (const std::size_t k : emptied) {
    std::fill(st.slices[k].image.data.begin(), st.slices[k].image.data.end(), 0u);
    st.slices[k].polygons.clear();
  }
  return st;
}

// Polygon slices moved `dx` px in x, past the image's left edge: the crop
// box's ring then holds inside pixels that are no contour pixel (the edges
// beyond the image are not rasterised), where the mesher's outside pad meets
// the field.
SliceStack moved_past_the_edge(SliceStack st, double dx) {
  for (Slice& s : st.slices)
    for (auto& poly : s.polygons)
      for (auto& q : poly.points) q.x() += dx;
  return st;
}

// A square prism drawn as polygons, `n` slices `dz` apart, half-size `half`
// px in a size x size image: its end slices' interiors lie far from every
// contour, where only the caps' trend reads the second and second to last
// slice.
SliceStack prism(int size, double half, int n, double dz) {
  SliceStack st;
  st.width = st.height = size;
  st.kind = InputKind::Polylines;
  const double c = (size - 1) / 2.0;
  for (int k = 0; k < n; ++k) {
    Slice s;
    s.z = k * dz;
    s.source = "prism slice " + std::to_string(k);
    s.polygons.push_back({{{c - half, c - half}, {c + half, c - half}, {c + half, c + half}, {c - half, c + half}}});
    st.slices.push_back(std::move(s));
  }
  return st;
}

// The object's packed masks and crop box, as reconstruct() makes them.
struct Packed {
  std::vector<detail::PackedMasks> masks;
  PixelBox box;
};
Packed packed(const SliceStack& st, const ReconstructParams& p) {
  Packed out;
  std::vector<PixelBox> bounds;
  for (const Slice& s : st.slices) {
    const detail::SliceMasks m = detail::slice_masks(st, s, p, 0);
    bounds.push_back(detail::mask_bounds(m));
    out.masks.push_back(detail::pack_masks(m));
  }
  out.box = detail::object_box(bounds, st.width, st.height, p.crop_margin);
  return out;
}

// The share of the non-full slices' pixels the band leaves out (else the mesh
// comparison below tells nothing); -1 if the run gets no band.
double band_left_out(const SliceStack& st, const ReconstructParams& p) {
  const Packed pk = packed(st, p);
  const auto setup = detail::field_band_setup(p, st.kind, pk.masks);
  if (!setup) return -1;
  detail::FieldBand band(pk.masks, pk.box, *setup);
  band.prepare(0, pk.masks.size());
  double out = 0, all = 0;
  for (std::size_t k = 0; k < pk.masks.size(); ++k)
    if (const auto b = band.band(k)) {
      out += double(std::count(b->required.data.begin(), b->required.data.end(), 0));
      all += double(b->required.size());
    }
  return all > 0 ? out / all : 0;
}

// reconstruct() with the band gives the one object's mesh of whole fields, bit for bit.
void expect_whole_field_mesh(const SliceStack& st, const ReconstructParams& p, const std::string& name) {
  ReconstructOptions whole;
  whole.whole_fields = true;
  const ReconstructResult want = reconstruct(st, p, whole);
  const ReconstructResult got = reconstruct(st, p);
  ASSERT_EQ(want.objects.size(), 1u) << name;
  ASSERT_EQ(got.objects.size(), 1u) << name;
  ASSERT_FALSE(want.objects[0].mesh.triangles.empty()) << name;
  EXPECT_EQ(got.objects[0].mesh.vertices, want.objects[0].mesh.vertices) << name;
  EXPECT_EQ(got.objects[0].mesh.triangles, want.objects[0].mesh.triangles) << name;
}

TEST(FieldBand, ReconstructGivesTheMeshOfWholeFields) {
  struct Case {
    std::string name;
    SliceStack stack;
    SplineKind spline;
    IsolatedEmpty isolated = InterpParams{}.isolated_empty;
  };
  const TiltedCase tube = tilted_kit_case("tube80_r3_s8");
  const std::vector<Case> cases{
      {"two blobs, traced masks", cut("two-blobs", 80, 10.0, InputKind::Masks), SplineKind::ExtremumPreserving},
      {"branching cylinders, traced masks, monotone", cut("branching-cylinders", 72, 9.0, InputKind::Masks),
       SplineKind::Monotone},
      {"branching cylinders, traced masks, linear", cut("branching-cylinders", 72, 9.0, InputKind::Masks),
       SplineKind::Linear},
      {"sphere, drawn polygons past the image edge", moved_past_the_edge(cut("sphere", 64, 4.0, InputKind::Polylines), -20),
       SplineKind::ExtremumPreserving},
      {"sphere, drawn polygons, an empty slice and an empty pair",
       cut("sphere", 96, 3.0, InputKind::Polylines, {6, 12, 13}), SplineKind::ExtremumPreserving},
      {"sphere, drawn polygons, isolated empty slices (box)", cut("sphere", 96, 3.0, InputKind::Polylines, {6, 7, 8, 12, 13, 14, 15}),
       SplineKind::ExtremumPreserving, IsolatedEmpty::Box},
      {"sphere, drawn polygons, isolated empty slices, secant, monotone",
       cut("sphere", 96, 3.0, InputKind::Polylines, {6, 7, 8, 12, 13, 14, 15}), SplineKind::Monotone, IsolatedEmpty::Secant},
      {"tilted torus, drawn polygons", cut("tilted-torus", 72, 8.0, InputKind::Polylines), SplineKind::ExtremumPreserving},
      {"square prism, drawn polygons, linear (the caps' trend)", prism(96, 30.5, 6, 5.0), SplineKind::Linear},
      {"tilted tube (80 deg), drawn polygons", synthesize(tube, InputKind::Polylines).stack, SplineKind::ExtremumPreserving},
  };
  for (const Case& c : cases) {
    ReconstructParams p;
    p.interp.spline = c.spline;
    p.interp.isolated_empty = c.isolated;
    const double left_out = band_left_out(c.stack, p);
    ASSERT_GT(left_out, 0) << c.name << ": no band, or one that leaves no pixel out";
    expect_whole_field_mesh(c.stack, p, c.name);
  }
}

// Slab and flat caps and closings read their slices pixel by pixel: end
// slices, the caps' trend slices and slices next to an empty one take the
// union of their readers' bands; dome and round caps read their end slices'
// maximum, so end slices and slices next to an empty one stay whole (the
// default slab caps: ReconstructGivesTheMeshOfWholeFields).
TEST(FieldBand, CapsReadingPixelByPixelBandTheirEndAndEmptyNeighbourSlices) {
  struct Case {
    std::string name;
    SliceStack stack;
    SplineKind spline;
    CapShape cap;
    IsolatedEmpty isolated = InterpParams{}.isolated_empty;
  };
  const std::vector<Case> cases{
      {"sphere, drawn polygons, isolated empty slices, secant, monotone, flat caps",
       cut("sphere", 96, 3.0, InputKind::Polylines, {6, 7, 8, 12, 13, 14, 15}), SplineKind::Monotone, CapShape::Flat,
       IsolatedEmpty::Secant},
      {"square prism, drawn polygons, linear, round caps (the trend slices banded, the ends whole)",
       prism(96, 30.5, 6, 5.0), SplineKind::Linear, CapShape::Round},
  };
  for (const Case& c : cases) {
    ReconstructParams p;
    p.interp.spline = c.spline;
    p.interp.isolated_empty = c.isolated;
    p.interp.cap_shape = c.cap;
    const Packed pk = packed(c.stack, p);
    const auto setup = detail::field_band_setup(p, c.stack.kind, pk.masks);
    ASSERT_TRUE(setup) << c.name;
    detail::FieldBand band(pk.masks, pk.box, *setup);
    band.prepare(0, pk.masks.size());
    const std::size_t n = pk.masks.size();
    for (std::size_t k = 0; k < n; ++k) {
      if (pk.masks[k].empty) continue;
      const bool empty_next = (k > 0 && pk.masks[k - 1].empty) || (k + 1 < n && pk.masks[k + 1].empty);
      const bool whole = c.cap == CapShape::Round && (k == 0 || k + 1 == n || empty_next);
      ASSERT_EQ(!band.band(k), whole) << c.name << ": slice " << k;
    }
    expect_whole_field_mesh(c.stack, p, c.name);
  }
}

// A label partition whose competition reads labels far from their own
// contours, size 96, 9 slices 5 px apart: a disc whose right half is label 3
// on every slice but the first, whose left half is label 1 on even slices and
// label 2 on odd ones (so between slices, deep in the left half, label 3's
// value competes with the background's 8+ px from label 3's contour); a ring
// (label 4) with a disc (label 5) in its hole, touching it on some slices,
// label 5 absent from slice 3 (one empty slice) and 5-7 (slice 6 isolated).
SliceStack competing_labels() {
  constexpr int n = 96, slices = 9;
  SliceStack st;
  st.width = st.height = n;
  st.kind = InputKind::Labels;
  for (int k = 0; k < slices; ++k) {
    Slice s;
    s.z = 5.0 * k;
    s.source = "competing slice " + std::to_string(k);
    s.image = Grid2u32(n, n, 0);
    const bool inner = k != 3 && (k < 5 || k > 7);
    const double inner_r = 5.0 + k % 5;  // 9: touches the ring
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const double d = std::hypot(x - 32.0, y - 40.0), r = std::hypot(x - 70.5, y - 72.5);
        std::uint32_t& v = s.image(x, y);
        if (d < 24.0) v = x >= 33 ? (k > 0 ? 3u : 0u) : (k % 2 == 0 ? 1u : 2u);
        if (r >= 9.0 && r < 17.0) v = 4;
        if (inner && r < inner_r) v = 5;
      }
    st.slices.push_back(std::move(s));
  }
  return st;
}

TEST(FieldBand, LabelPartitionGivesTheMeshesOfWholeFields) {
  const SliceStack st = competing_labels();
  ReconstructParams p;
  ASSERT_TRUE(p.label_partition);
  // The band leaves pixels out of some label's non-full slices (else the
  // comparison tells nothing), and its rule reads every label's crossings.
  std::vector<std::vector<detail::PackedMasks>> masks(5, std::vector<detail::PackedMasks>(st.slices.size()));
  std::vector<std::vector<PixelBox>> bounds(5, std::vector<PixelBox>(st.slices.size()));
  std::vector<PixelBox> all;
  for (std::size_t k = 0; k < st.slices.size(); ++k)
    for (detail::LabelMasks& m : detail::label_masks(st.slices[k].image)) {
      masks[m.label - 1][k] = std::move(m.masks);
      bounds[m.label - 1][k] = m.bounds;
      all.push_back(m.bounds);
    }
  for (auto& ms : masks)
    for (auto& m : ms)
      if (m.width == 0) m = detail::PackedMasks{st.width, st.height, true, {}, {}};
  std::vector<PixelBox> boxes;
  for (const auto& b : bounds) boxes.push_back(detail::object_box(b, st.width, st.height, p.crop_margin));
  const PixelBox ubox = detail::object_box(all, st.width, st.height, p.crop_margin);
  std::optional<detail::FieldBand::Setup> setup = detail::field_band_setup(p, st.kind, masks[2]);
  ASSERT_TRUE(setup);
  setup->partition = std::make_shared<detail::PartitionCrossings>(masks, boxes, ubox, *setup);
  long left_out = 0, widened = 0;
  for (std::size_t l = 0; l < masks.size(); ++l) {
    detail::FieldBand::Setup own = *setup;
    own.label = l;
    detail::FieldBand shared(masks[l], boxes[l], own), alone(masks[l], boxes[l], *detail::field_band_setup(p, st.kind, masks[l]));
    shared.prepare(0, st.slices.size());
    alone.prepare(0, st.slices.size());
    for (std::size_t k = 0; k < st.slices.size(); ++k)
      if (const auto b = shared.band(k)) {
        const Grid2u8 a = alone.band(k)->needed;
        left_out += std::count(b->required.data.begin(), b->required.data.end(), 0);
        for (std::size_t q = 0; q < a.size(); ++q) {
          ASSERT_LE(a.data[q], b->needed.data[q]) << "label " << l + 1 << " slice " << k << ": its own band is in the shared one";
          widened += b->needed.data[q] > a.data[q];
        }
      }
  }
  EXPECT_GT(left_out, 0) << "no pixel left out";
  EXPECT_GT(widened, 0) << "no label needed where another crosses";

  ReconstructOptions whole;
  whole.whole_fields = true;
  const ReconstructResult want = reconstruct(st, p, whole);
  const ReconstructResult got = reconstruct(st, p);
  ASSERT_EQ(want.objects.size(), 5u);
  ASSERT_EQ(got.objects.size(), 5u);
  for (std::size_t l = 0; l < 5; ++l) {
    ASSERT_FALSE(want.objects[l].mesh.triangles.empty()) << "label " << l + 1;
    EXPECT_EQ(got.objects[l].mesh.vertices, want.objects[l].mesh.vertices) << "label " << l + 1;
    EXPECT_EQ(got.objects[l].mesh.triangles, want.objects[l].mesh.triangles) << "label " << l + 1;
  }
}

TEST(FieldBand, NoBandWhereItCouldChangeTheMesh) {
  const SliceStack st = cut("sphere", 48, 4.0, InputKind::Polylines);
  const std::vector<detail::PackedMasks> masks = packed(st, ReconstructParams{}).masks;
  ASSERT_TRUE(detail::field_band_setup(ReconstructParams{}, st.kind, masks)) << "the default run has a band";
  const auto no_band = [&](const ReconstructParams& p, const std::vector<detail::PackedMasks>& m, const std::string& why) {
    EXPECT_FALSE(detail::field_band_setup(p, st.kind, m)) << why;
  };
  for (const SplineKind k : {SplineKind::CatmullRom, SplineKind::Natural}) {
    ReconstructParams p;
    p.interp.spline = k;
    no_band(p, masks, "spline " + to_string(k) + " can leave its knots' side");
  }
  no_band(method_defaults(Method::Levin), masks, "levin");
  no_band(method_defaults(Method::Marker2006), masks, "marker2006: the MPU fit's sign is not the masks'");
  ReconstructParams fit;
  fit.polyline_boundary = PolylineBoundary::Fit;
  no_band(fit, masks, "polygons fitted");
  ReconstructParams iso;
  iso.mc.iso = 0.5f;
  no_band(iso, masks, "mc.iso != 0");
  ReconstructParams track;
  track.z_scheme = "track";
  no_band(track, masks, "z scheme track");
  std::vector<detail::PackedMasks> isolated = masks;
  isolated[3].empty = isolated[4].empty = isolated[5].empty = true;
  isolated[3].inside.clear(), isolated[4].inside.clear(), isolated[5].inside.clear();
  for (const IsolatedEmpty rule : {IsolatedEmpty::Lowest, IsolatedEmpty::Neighbours}) {
    ReconstructParams minima;
    minima.interp.isolated_empty = rule;
    no_band(minima, isolated, "an empty slice without a non-empty neighbour (isolated_empty " + to_string(rule) + ")");
  }
  for (const IsolatedEmpty rule : {IsolatedEmpty::Depth, IsolatedEmpty::Secant, IsolatedEmpty::Box}) {
    ReconstructParams local;
    local.interp.isolated_empty = rule;
    EXPECT_TRUE(detail::field_band_setup(local, st.kind, isolated)) << "isolated_empty " << to_string(rule) << " reads no minimum";
  }
  std::vector<detail::PackedMasks> one_gap = masks;
  one_gap[4].empty = true;
  one_gap[4].inside.clear();
  ASSERT_TRUE(detail::field_band_setup(ReconstructParams{}, st.kind, one_gap)) << "one empty slice between two";
  ReconstructParams far_cap;
  far_cap.interp.cap_extent = 1.5;
  no_band(far_cap, one_gap, "an empty slice with cap_extent > 1");
}

}  // namespace
