// End to end through the library: a synthesized sphere at 8:1 is
// reconstructed and compared with the analytic sphere.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "isoloft/eval/metrics.h"
#include "isoloft/field/edt.h"
#include "isoloft/io/slice_images.h"
#include "isoloft/pipeline.h"
#include "isoloft/objects/slice_fields.h"
#include "isoloft/methods/columns/slice_methods.h"
#include "isoloft/synth/synth.h"

using namespace isoloft;

namespace {

struct EndToEndCase {
  SynthResult synth;
  ReconstructResult result;
};

EndToEndCase run(const std::string& shape, Method method, int size, double ratio) {
  SynthParams sp;
  sp.size = size;
  sp.z_spacing = ratio;
  EndToEndCase c{synthesize(*make_default_shape(shape, size), sp), {}};
  const ReconstructParams p = method_defaults(method);
  c.result = reconstruct(c.synth.stack, p);
  return c;
}

// A stack of `n` label images, size x size, slice k at z = dz * k; label(x, y, k) gives each pixel's value.
template <class F>
SliceStack label_stack(int n, int size, double dz, F&& label) {
  SliceStack st;
  st.width = st.height = size;
  for (int k = 0; k < n; ++k) {
    Slice s;
    s.z = dz * k;
    s.source = "slice" + std::to_string(k);
    s.image = Grid2u32(size, size, 0);
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) s.image(x, y) = label(x, y, k);
    st.slices.push_back(std::move(s));
  }
  return st;
}

}  // namespace

// Levin baseline on a sphere of radius 44.8 px cut every 8 px. The contour
// pixels themselves sit up to ~0.5 px off the circle (mean ~0.25 px), and the
// z spline of r(z) = sqrt(R^2 - z^2) errs most near the end slices, so:
constexpr double kLevinSphereMeanTol = 0.5;  // px, in the slice range
constexpr double kLevinSphereMaxTol = 2.5;   // px, in the slice range (worst at the last slices, where r(z) bends fastest)

TEST(EndToEnd, LevinSphereAt8To1IsClosedAndNearTheTrueSphere) {
  const EndToEndCase c = run("sphere", Method::Levin, 128, 8.0);
  ASSERT_EQ(c.result.objects.size(), 1u);
  const auto& obj = c.result.objects.front();
  EXPECT_TRUE(obj.check.closed);
  EXPECT_TRUE(obj.check.manifold);
  EXPECT_TRUE(obj.check.oriented);
  EXPECT_EQ(obj.check.euler, 2);
  EXPECT_GT(obj.check.volume, 0.0) << "outward orientation gives a positive volume";
  const auto& st = c.synth.stack;
  const auto stats = mesh_to_shape_stats(obj.mesh, *c.synth.shape, st.slices.front().z, st.slices.back().z);
  RecordProperty("mean_distance_px", std::to_string(stats.in_range.mean_distance));
  RecordProperty("max_distance_px", std::to_string(stats.in_range.max_distance));
  std::cout << "levin sphere 8:1 in range: mean " << stats.in_range.mean_distance << " px, max " << stats.in_range.max_distance
            << " px, normal angle " << stats.in_range.mean_normal_angle_deg << " deg; caps mean " << stats.caps.mean_distance << " px\n";
  EXPECT_LT(stats.in_range.mean_distance, kLevinSphereMeanTol);
  EXPECT_LT(stats.in_range.max_distance, kLevinSphereMaxTol);
}

TEST(EndToEnd, LabelsGiveOneClosedMeshPerLabel) {
  SliceStack st = label_stack(4, 40, 3.0, [](int x, int y, int k) -> std::uint32_t {
    if ((x - 12) * (x - 12) + (y - 20) * (y - 20) < 64) return 7;
    if ((x - 28) * (x - 28) + (y - 20) * (y - 20) < 36 + 4 * k) return 9;
    return 0;
  });
  ReconstructParams p;
  p.method = Method::Levin;
  st.kind = InputKind::Labels;
  const auto r = reconstruct(st, p);
  ASSERT_EQ(r.objects.size(), 2u);
  EXPECT_EQ(r.objects[0].label, 7u);
  EXPECT_EQ(r.objects[1].label, 9u);
  for (const auto& o : r.objects) {
    EXPECT_TRUE(o.check.closed && o.check.manifold && o.check.oriented) << "label " << o.label;
    EXPECT_EQ(o.check.components, 1) << "label " << o.label;
  }
}

TEST(EndToEnd, EmptyMiddleSliceSplitsTheObject) {
  SliceStack st = label_stack(5, 32, 4.0, [](int x, int y, int k) -> std::uint32_t {
    return k != 2 && (x - 16) * (x - 16) + (y - 16) * (y - 16) < 81 ? 255 : 0;
  });
  ReconstructParams p;
  p.method = Method::Levin;
  st.kind = InputKind::Masks;
  const auto r = reconstruct(st, p);
  ASSERT_EQ(r.objects.size(), 1u);
  EXPECT_TRUE(r.objects[0].check.closed);
  EXPECT_EQ(r.objects[0].check.components, 2) << "an all-outside slice separates the two halves";
}

// The paper's claim against the baseline (issue: the paper's method): on a
// tilted torus at 8:1 (slices split into two components) the marker2006
// surface is closer to the truth, in distance and in normal direction, than
// the Levin-style reconstruction of the same contour images.
TEST(EndToEnd, Marker2006BeatsLevinOnATiltedTorusAt8To1) {
  const EndToEndCase marker = run("tilted-torus", Method::Marker2006, 128, 8.0);
  const EndToEndCase levin = run("tilted-torus", Method::Levin, 128, 8.0);
  ASSERT_EQ(marker.result.objects.size(), 1u);
  ASSERT_EQ(levin.result.objects.size(), 1u);
  const auto& st = marker.synth.stack;
  const double z0 = st.slices.front().z, z1 = st.slices.back().z;
  const auto m = mesh_to_shape_stats(marker.result.objects[0].mesh, *marker.synth.shape, z0, z1).in_range;
  const auto l = mesh_to_shape_stats(levin.result.objects[0].mesh, *levin.synth.shape, z0, z1).in_range;
  std::cout << "tilted torus 8:1 in range: marker2006 mean " << m.mean_distance << " px, angle " << m.mean_normal_angle_deg
            << " deg; levin mean " << l.mean_distance << " px, angle " << l.mean_normal_angle_deg << " deg\n";
  EXPECT_TRUE(marker.result.objects[0].check.closed && marker.result.objects[0].check.manifold);
  EXPECT_EQ(marker.result.objects[0].check.euler, 0) << "a torus";
  EXPECT_LT(m.mean_distance, l.mean_distance);
  EXPECT_LT(m.mean_normal_angle_deg, l.mean_normal_angle_deg);
  // Issue targets inside the slice range at 8:1: mean <= 0.15 px, angle <= 4 deg.
  constexpr double kTargetMeanPx = 0.15, kTargetAngleDeg = 4.0;
  EXPECT_LE(m.mean_distance, kTargetMeanPx);
  EXPECT_LE(m.mean_normal_angle_deg, kTargetAngleDeg);
}

// Polyline input (issue: the paper's method, item 3): the exact cuts of a
// sphere as polygons, fitted directly and rasterized at 4x the working grid
// as the paper did for its pelvis. At 2:1, where the z spline adds little,
// both must land closer to the sphere than 1-pixel contour images of the
// same cuts (measured: images 0.028 px, polygons 0.011 px, 4x raster 0.013 px).
TEST(EndToEnd, PolylinesFitDirectlyAndRasterizedAtAFinerGrid) {
  SynthParams sp;
  sp.size = 96;
  sp.z_spacing = 2;
  const SynthResult images = synthesize(*make_default_shape("sphere", sp.size), sp);
  sp.kind = InputKind::Polylines;
  const SynthResult syn = synthesize(*make_default_shape("sphere", sp.size), sp);
  ASSERT_TRUE(syn.stack.has_polygons());
  const double z0 = syn.stack.slices.front().z, z1 = syn.stack.slices.back().z;
  const auto ri = reconstruct(images.stack, ReconstructParams{});
  const double image_mean = mesh_to_shape_stats(ri.objects.at(0).mesh, *images.shape, z0, z1).in_range.mean_distance;
  for (int raster : {0, 4 * sp.size}) {
    ReconstructParams p;
    p.polyline_raster_width = raster;
    const auto r = reconstruct(syn.stack, p);
    ASSERT_EQ(r.objects.size(), 1u);
    EXPECT_TRUE(r.objects[0].check.closed && r.objects[0].check.manifold) << "raster " << raster;
    const auto st = mesh_to_shape_stats(r.objects[0].mesh, *syn.shape, z0, z1).in_range;
    std::cout << "sphere 2:1, raster " << raster << ": polygons mean " << st.mean_distance << " px, contour images " << image_mean << " px\n";
    // Exact contours leave Marching Cubes' chord error and the small z
    // spline error: 0.02 px is about twice what was measured.
    constexpr double kPolylineMeanTol = 0.02;  // px
    EXPECT_LT(st.mean_distance, kPolylineMeanTol) << "raster " << raster;
    EXPECT_LT(st.mean_distance, image_mean) << "raster " << raster;
  }
}

// A slice whose object is a single pixel has no normal to fit; marker2006
// falls back to exact pixel distances there (and says so) instead of failing.
TEST(EndToEnd, OnePixelSliceFallsBackToPixelDistances) {
  SliceStack st = label_stack(3, 40, 4.0, [](int x, int y, int k) -> std::uint32_t {
    if (k == 1) return x == 20 && y == 20 ? 3 : 0;
    return (x - 20) * (x - 20) + (y - 20) * (y - 20) < 100 ? 3 : 0;
  });
  const ReconstructParams p = method_defaults(Method::Marker2006);
  st.kind = InputKind::Labels;
  const auto r = reconstruct(st, p);
  ASSERT_EQ(r.objects.size(), 1u);
  EXPECT_EQ(r.objects[0].fit.fallback_slices, 1);
  EXPECT_TRUE(r.objects[0].check.closed && r.objects[0].check.manifold);
  EXPECT_FALSE(r.warnings.empty());
}

// The traced boundary needs no points to fit: a one-pixel slice is a small
// loop around its pixel, and the object stays closed.
TEST(EndToEnd, OnePixelSliceIsTracedAroundItsPixel) {
  SliceStack st = label_stack(3, 40, 4.0, [](int x, int y, int k) -> std::uint32_t {
    if (k == 1) return x == 20 && y == 20 ? 3 : 0;
    return (x - 20) * (x - 20) + (y - 20) * (y - 20) < 100 ? 3 : 0;
  });
  st.kind = InputKind::Labels;
  ReconstructOptions o;
  o.sample_z = {4.0};
  float centre = 0;
  o.on_sample = [&](std::uint32_t, const Grid2f& f, const PixelBox& b, double) { centre = f(20 - b.x0, 20 - b.y0); };
  const auto r = reconstruct(st, ReconstructParams{}, o);
  ASSERT_EQ(r.objects.size(), 1u);
  EXPECT_EQ(r.objects[0].fit.fallback_slices, 0);
  EXPECT_GT(centre, 0.0f) << "the drawn pixel is inside at its slice";
  EXPECT_TRUE(r.objects[0].check.closed && r.objects[0].check.manifold);
}

// An empty slice next to an object closes it like an end cap: the surface
// reaches cap_extent (half) of the gap at the contour's deepest point.
TEST(EmptySlices, CloseLikeAnEndCap) {
  const InterpParams ip;
  std::vector<Grid2f> fields{Grid2f(3, 1, -2.0f), Grid2f(), Grid2f(), Grid2f(3, 1, -1.0f)};
  fields[0](1, 0) = 5.0f;  // deepest point
  detail::fill_empty_slices(fields, {0.0, 1.0, 2.0, 3.0}, PixelBox{0, 0, 3, 1}, ip);
  const float drop = float((5.0 + ip.cap_depth) / ip.cap_extent);
  EXPECT_FLOAT_EQ(fields[1](1, 0), 5.0f - drop);
  EXPECT_FLOAT_EQ(fields[1](0, 0), -2.0f - drop);
  // Slice 2's neighbours are slice 1 (empty) and slice 3, whose max is below 0:
  EXPECT_FLOAT_EQ(fields[2](0, 0), -1.0f - float(ip.cap_depth / ip.cap_extent));
  // Linear interpolation between slices 0 and 1 crosses zero at the deepest
  // point at t = 5 / drop = cap_extent * M / (M + cap_depth): just under half the gap.
  constexpr double kFloatTol = 1e-6;
  EXPECT_NEAR(5.0 / drop, ip.cap_extent * 5.0 / (5.0 + ip.cap_depth), kFloatTol);
}

// An isolated empty slice (no non-empty neighbour) under a local rule reads
// no field beyond kIsolatedNeighbourSlices: a z slab with that halo gives it
// the whole stack's value. Under Lowest a far field moves it.
TEST(EmptySlices, IsolatedValueIsLocalUnderTheLocalRules) {
  const PixelBox box{0, 0, 3, 1};
  const std::size_t n = 10, isolated = 2, far = isolated + kIsolatedNeighbourSlices + 1;
  std::vector<double> z(n);
  for (std::size_t k = 0; k < n; ++k) z[k] = double(k);
  std::vector<Grid2f> fields(n);
  fields[0] = Grid2f(3, 1, -2.0f);  // slice 1 closes it, slice 2 is isolated
  fields[0](1, 0) = 3.0f;
  for (std::size_t k = 4; k < n; ++k) fields[k] = Grid2f(3, 1, -3.0f);  // slice 3 closes them
  const auto value = [&](IsolatedEmpty rule, float far_value) {
    InterpParams ip;
    ip.isolated_empty = rule;
    std::vector<Grid2f> f = fields;
    f[far](0, 0) = far_value;
    detail::fill_empty_slices(f, z, box, ip);
    return f[isolated].data;
  };
  for (const IsolatedEmpty rule : {IsolatedEmpty::Depth, IsolatedEmpty::Neighbours, IsolatedEmpty::Secant, IsolatedEmpty::Box})
    EXPECT_EQ(value(rule, -3.0f), value(rule, -500.0f)) << to_string(rule);
  EXPECT_NE(value(IsolatedEmpty::Lowest, -3.0f), value(IsolatedEmpty::Lowest, -500.0f));
  // Every rule leaves it outside everywhere.
  for (const auto& [rule, name] : kIsolatedEmptyNames)
    for (const float v : value(rule, -3.0f)) EXPECT_LT(v, 0.0f) << name;
}

// A 3-pixel-thick sliver beside a disc: MPU's strip-shaped local conic used
// to stay positive far beyond the sliver's tip (13 px of spurious surface
// without the sign guard, which then overruled those pixels). The fit's ring
// checks (fit/mpu.h) now keep it on the data by itself, fitted over the whole
// crop box or only in the band: the guard overrules nothing and every surface
// vertex lies next to the mask either way.
TEST(EndToEnd, NoSpuriousSurfaceBesideAThinSliver) {
  constexpr int kSize = 200;
  const auto inside = [](int x, int y) {
    const double ex = (x - 100) / 25.0, ey = (y - 100) / 1.2;  // the sliver: semi-axes 25 x 1.2 px
    return ex * ex + ey * ey <= 1.0 || (x - 150) * (x - 150) + (y - 150) * (y - 150) < 225;
  };
  SliceStack st = label_stack(3, kSize, 4.0, [&](int x, int y, int) -> std::uint32_t { return inside(x, y) ? 1 : 0; });
  Grid2u8 mask(kSize, kSize, 0);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) mask(x, y) = inside(x, y);
  const Grid2f d2 = squared_edt(mask);
  // Largest xy distance from a surface vertex to the nearest mask pixel centre.
  const auto off_mask = [&](const TriMesh& m) {
    double worst = 0;
    for (const auto& v : m.vertices) {
      const int x = std::clamp(int(std::lround(v.x())), 0, kSize - 1), y = std::clamp(int(std::lround(v.y())), 0, kSize - 1);
      worst = std::max(worst, std::sqrt(double(d2(x, y))));
    }
    return worst;
  };
  // The surface sits on the mask edge, half a pixel beyond the outermost
  // pixel centres, within MPU's tol (0.75 px); vertices are rounded to pixels.
  constexpr double kMaxOffMaskPx = 2.0;
  st.kind = InputKind::Labels;
  for (const double band : {0.0, 4.0}) {
    ReconstructParams p;
    p.mpu_band = band;
    const auto guarded = reconstruct(st, p);
    p.sign_guard = 0;
    const auto raw = reconstruct(st, p);
    ASSERT_EQ(guarded.objects.size(), 1u);
    ASSERT_EQ(raw.objects.size(), 1u);
    EXPECT_EQ(guarded.objects[0].fit.sign_guarded_pixels, 0) << "band " << band;
    EXPECT_LE(off_mask(raw.objects[0].mesh), kMaxOffMaskPx) << "band " << band;
    EXPECT_LE(off_mask(guarded.objects[0].mesh), kMaxOffMaskPx) << "band " << band;
    EXPECT_TRUE(raw.objects[0].check.closed && raw.objects[0].check.manifold) << "band " << band;
  }
}

// End caps (interp.cap_shape): a cylinder of two disk slices 8 px apart
// closes half a spacing (cap_extent) beyond each end. The dome's top follows
// the disk's distance field (highest over the centre), the flat cap's top is
// one plane over the whole interior.
TEST(EndToEnd, FlatCapsCloseWithALidAndDomesWithACrown) {
  constexpr double kR = 14.0, kDz = 8.0;
  SliceStack st = label_stack(2, 48, kDz, [&](int x, int y, int) -> std::uint32_t {
    return (x - 24) * (x - 24) + (y - 24) * (y - 24) < kR * kR ? 255 : 0;
  });
  st.kind = InputKind::Masks;
  // Vertices above the interior (6 px in from the rim), beyond the last slice.
  auto lid_heights = [&](const TriMesh& m) {
    std::vector<double> z;
    for (const auto& v : m.vertices)
      if (v.z() > kDz && std::hypot(v.x() - 24.0, v.y() - 24.0) < kR - 6.0) z.push_back(v.z());
    return z;
  };
  const double top = kDz + ReconstructParams{}.interp.cap_extent * kDz;  // the virtual cap slice
  for (const CapShape shape : {CapShape::Dome, CapShape::Flat}) {
    ReconstructParams p;
    p.method = Method::Levin;
    p.interp.cap_shape = shape;
    const auto r = reconstruct(st, p);
    ASSERT_EQ(r.objects.size(), 1u);
    const auto& o = r.objects[0];
    EXPECT_TRUE(o.check.closed && o.check.manifold && o.check.oriented) << to_string(shape);
    const std::vector<double> z = lid_heights(o.mesh);
    ASSERT_FALSE(z.empty()) << to_string(shape);
    const auto [lo, hi] = std::minmax_element(z.begin(), z.end());
    EXPECT_LE(*hi, top) << to_string(shape) << ": nothing beyond the cap slice";
    if (shape == CapShape::Flat) {
      // One plane up to the rounding of the spline's crossing: within a pixel.
      EXPECT_LT(*hi - *lo, 1.0) << "flat lid between z " << *lo << " and " << *hi;
      EXPECT_GT(*lo, top - 1.0) << "the lid lies at the cap slice";
    } else {
      EXPECT_GT(*hi - *lo, 1.0) << "a dome's height follows the distance to the rim";
    }
  }
}

// On the bundled frog labels the fit holds its own bound. The
// stomach (label 15), the worst before (79 % of 16,449 leaves over tol, up to
// 30.8 px, 532 pixels overruled by the sign guard): no leaf farther than
// 2 tol, at most 1 % over tol, nothing for the sign guard.
TEST(EndToEnd, FrogStomachFitHoldsItsBound) {
  const std::string dir = std::string(ISOLOFT_SOURCE_DIR) + "/data/frog";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << dir << " not present";
  SliceStack st = read_slice_images(list_slice_files({dir}));
  st.kind = InputKind::Labels;
  for (std::size_t k = 0; k < st.slices.size(); ++k) st.slices[k].z = 6.0 * double(k);
  ReconstructOptions opt;
  opt.labels = {15};
  ReconstructParams p;
  p.mask_boundary = MaskBoundary::PixelCentres;  // the MPU fit (the traced boundary fits none)
  p.label_partition = false;
  const ReconstructResult r = reconstruct(st, p, opt);
  ASSERT_EQ(r.objects.size(), 1u);
  const FitStats& f = r.objects[0].fit;
  const double tol = ReconstructParams{}.mpu.tol;
  EXPECT_GT(f.leaves, 0);
  EXPECT_LE(f.leaves_over_tol, f.leaves / 100) << f.leaves_over_tol << " of " << f.leaves << " leaves over tol";
  EXPECT_LE(f.max_local_error, 2.0 * tol);
  EXPECT_EQ(f.sign_guarded_pixels, 0);
  EXPECT_TRUE(r.objects[0].check.closed && r.objects[0].check.manifold && r.objects[0].check.oriented);
}

// Features 2 px wide or more survive the labels path (mask_min_feature, MPU
// fit, band): bars of width 2, 3 and 4 px at 0, 15, 30 and 45 degrees, one
// free and one attached to a disc; bars 1 px wide are removed (segmentation
// noise) and leave no surface.
TEST(MarkerSlice, LabelFeaturesTwoPixelsWideAreKept) {
  constexpr int kN = 120;
  // Fraction of a bar's pixels that may come out outside: its rounded ends
  // (a 2 px bar ends in a cap within about a pixel of its last pixels).
  constexpr double kEndLoss = 0.2;
  for (const double w : {1.0, 2.0, 3.0, 4.0})
    for (const double deg : {0.0, 15.0, 30.0, 45.0}) {
      const double a = deg * M_PI / 180.0;
      const auto bar = [&](double cx, double cy, int x, int y) {
        const double u = (x - cx) * std::cos(a) + (y - cy) * std::sin(a), v = -(x - cx) * std::sin(a) + (y - cy) * std::cos(a);
        return std::abs(v) <= w / 2 && std::abs(u) <= 30;
      };
      const auto disc = [](int x, int y) { return (x - 30) * (x - 30) + (y - 30) * (y - 30) < 144; };
      const auto in_bar = [&](int x, int y) { return (bar(60.3, 30.2, x, y) || bar(60.4, 85.3, x, y)) && !disc(x, y); };
      SliceStack st = label_stack(1, kN, 1.0, [&](int x, int y, int) -> std::uint32_t { return disc(x, y) || in_bar(x, y); });
      st.kind = InputKind::Labels;
      const ReconstructParams p;
      const detail::SliceMasks m = detail::slice_masks(st, st.slices[0], p, 1);
      const SliceField r = detail::marker_slice(SliceInput{m, st.slices[0], PixelBox{0, 0, kN, kN}, st.kind, kN}, p);
      long pixels = 0, lost = 0;
      for (int y = 0; y < kN; ++y)
        for (int x = 0; x < kN; ++x)
          if (in_bar(x, y)) {
            ++pixels;
            lost += !(r.field(x, y) > 0);
          }
      const std::string what = "bar " + std::to_string(w) + " px at " + std::to_string(deg) + " deg";
      if (w < 2.0)
        EXPECT_EQ(lost, pixels) << what;
      else
        EXPECT_LE(double(lost), kEndLoss * double(pixels)) << what << ": " << lost << " of " << pixels << " pixels lost";
      EXPECT_EQ(r.sign_guarded, 0) << what;
    }
}
