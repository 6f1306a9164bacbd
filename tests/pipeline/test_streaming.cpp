// reconstruct() streams its slices (pipeline.h): the mesh and sampled fields
// are bit for bit those of holding every slice's field at once (the oracle
// below, built from the same per-slice functions), with empty slices in every
// position, every spline and lazily loaded images; and the slice fields held
// at once do not grow with the slice count.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "isoloft/methods/method.h"
#include "isoloft/pipeline.h"
#include "isoloft/objects/slice_fields.h"
#include "isoloft/interp/z_stream.h"
#include "isoloft/mesh/stream_mesher.h"
#include "isoloft/synth/synth.h"
#include "io/io_test_util.h"

using namespace isoloft;

namespace {

// A sphere cut into contour images every dz px, size x size.
SliceStack sphere_stack(int size, double dz) {
  SynthParams sp;
  sp.size = size;
  sp.z_spacing = dz;
  return synthesize(*make_default_shape("sphere", size), sp).stack;
}

struct Resident {
  TriMesh mesh;
  std::map<double, Grid2f> samples;
};

// Every slice's field held at once, as reconstruct() did before streaming.
Resident resident_oracle(const SliceStack& st, const ReconstructParams& p, const std::vector<double>& sample_z) {
  std::vector<detail::SliceMasks> masks;
  std::vector<PixelBox> bounds;
  for (const Slice& s : st.slices) {
    masks.push_back(detail::slice_masks(st, s, p, 0));
    bounds.push_back(detail::mask_bounds(masks.back()));
  }
  const PixelBox box = detail::object_box(bounds, st.width, st.height, p.crop_margin);
  std::vector<Grid2f> fields(st.slices.size());
  std::vector<double> z;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    z.push_back(st.slices[k].z);
    if (masks[k].empty) continue;
    fields[k] = method_spec(p.method.name()).slice_field(SliceInput{masks[k], st.slices[k], box, st.kind, st.width}, p).field;
  }
  detail::fill_empty_slices(fields, z, box, p.interp);
  add_end_caps(fields, z, p.interp);
  const ZInterpolator field(std::move(fields), z, p.interp.spline);
  Resident r;
  for (const double zs : sample_z)
    if (zs >= z.front() && zs <= z.back()) field.evaluate(zs, r.samples[zs]);
  StreamMeshOptions o;
  o.outside = -float(p.interp.cap_depth);
  r.mesh = mesh_interpolated_field(field, mesh_planes(z, p.interp), box.x0, box.y0, p.mc, o).mesh;
  return r;
}

struct Streamed {
  ObjectResult object;
  std::map<double, Grid2f> samples;
};

Streamed streamed(const SliceStack& st, const ReconstructParams& p, const std::vector<double>& sample_z,
                  const std::string& scratch_dir = "") {
  Streamed s;
  ReconstructOptions o;
  o.scratch_dir = scratch_dir;
  o.sample_z = sample_z;
  o.on_sample = [&](std::uint32_t, const Grid2f& f, const PixelBox&, double z) { s.samples[z] = f; };
  ReconstructResult r = reconstruct(st, p, o);
  EXPECT_EQ(r.objects.size(), 1u);
  if (!r.objects.empty()) s.object = std::move(r.objects.front());
  return s;
}

// The same stack with its images behind SliceStack::load_image.
SliceStack lazy(const SliceStack& st) {
  SliceStack l = st;
  std::vector<Grid2u32> images;
  for (auto& s : l.slices) images.push_back(std::move(s.image)), s.image = {};
  l.load_image = [images](std::size_t k) { return images.at(k); };
  return l;
}

ReconstructParams undecimated() {
  ReconstructParams p;
  p.decimate.max_error = 0;  // compare Marching Cubes' own output
  return p;
}

}  // namespace

TEST(Streaming, EqualsHoldingEverySliceWithEmptySlicesAnywhere) {
  SliceStack st = sphere_stack(40, 1.25);
  const std::size_t n = st.slices.size();
  ASSERT_GE(n, 20u);
  // Empty: a run at the bottom (slice 1 has no non-empty neighbour, below
  // the last non-empty slice), one between two non-empty slices, a pair, the top.
  for (const std::size_t k : {std::size_t(0), std::size_t(1), std::size_t(2), std::size_t(7), std::size_t(11),
                              std::size_t(12), n - 1})
    std::fill(st.slices[k].image.data.begin(), st.slices[k].image.data.end(), 0u);
  const std::vector<double> sample_z{-100.0, st.slices[1].z, 0.5 * (st.slices[5].z + st.slices[6].z), st.slices[n - 2].z + 0.1};
  struct Variant {
    std::string name;
    Method method;
    SplineKind spline;
    IsolatedEmpty isolated = InterpParams{}.isolated_empty;
  };
  for (const Variant& v : {Variant{"isoloft extremum-preserving", Method::Isoloft, SplineKind::ExtremumPreserving},
                           Variant{"isoloft, isolated lowest", Method::Isoloft, SplineKind::ExtremumPreserving, IsolatedEmpty::Lowest},
                           Variant{"marker2006 monotone", Method::Marker2006, SplineKind::Monotone},
                           Variant{"marker2006 catmull-rom", Method::Marker2006, SplineKind::CatmullRom},
                           Variant{"marker2006 natural", Method::Marker2006, SplineKind::Natural},
                           Variant{"marker2006 linear", Method::Marker2006, SplineKind::Linear},
                           Variant{"levin monotone", Method::Levin, SplineKind::Monotone},
                           Variant{"isoloft, isolated depth", Method::Isoloft, SplineKind::ExtremumPreserving, IsolatedEmpty::Depth},
                           Variant{"isoloft, isolated neighbours", Method::Isoloft, SplineKind::ExtremumPreserving,
                                   IsolatedEmpty::Neighbours},
                           Variant{"isoloft, isolated secant", Method::Isoloft, SplineKind::ExtremumPreserving, IsolatedEmpty::Secant},
                           Variant{"marker2006 monotone, isolated secant", Method::Marker2006, SplineKind::Monotone,
                                   IsolatedEmpty::Secant}}) {
    ReconstructParams p = undecimated();
    p.method = v.method;
    p.interp.spline = v.spline;
    p.interp.isolated_empty = v.isolated;
    const Resident want = resident_oracle(st, p, sample_z);
    ASSERT_FALSE(want.mesh.empty()) << v.name;
    ASSERT_EQ(want.samples.size(), 3u) << v.name << ": the sample below the caps is out of range";
    const test::TempDir dir;
    for (const int way : {0, 1, 2}) {  // held, lazy images, fields computed early on disk
      const bool lazily = way == 1;
      const std::string what = v.name + (lazily ? ", lazy images" : way == 2 ? ", scratch folder" : "");
      const Streamed got = streamed(lazily ? lazy(st) : st, p, sample_z, way == 2 ? dir.path().string() : "");
      EXPECT_EQ(got.object.mesh.vertices, want.mesh.vertices) << what;
      EXPECT_EQ(got.object.mesh.triangles, want.mesh.triangles) << what;
      ASSERT_EQ(got.samples.size(), want.samples.size()) << what;
      for (const auto& [z, f] : want.samples) EXPECT_EQ(got.samples.at(z).data, f.data) << what << ", sample at z " << z;
    }
  }
}

// Slice fields held at once with the monotone spline: the slices in flight
// (slices_in_flight(): the batch handed out and the next), the knot feed's (slices k - 1 .. k + 1 around an empty
// slice, and the end cap or slice 0 held for the next knot), and ZStream's
// window (2 (block + 1 + 2 reach) knots and tangents, 2 reach + 1 shared).
constexpr long kFeedFields = 3 + 1;
constexpr long kStreamFields = long(2 * (kZStreamBlock + 1 + 2 * 2) + 2 * 2 + 1);

TEST(Streaming, SliceFieldsHeldAtOnceDoNotGrowWithTheSlices) {
  const long bound = long(detail::slices_in_flight()) + kFeedFields + kStreamFields;
  long peak_at_fewer = 0;
  for (const double dz : {0.2, 0.1}) {
    const SliceStack st = sphere_stack(32, dz);
    const long n = long(st.slices.size());
    ASSERT_GT(n, 2 * bound) << "too few slices to tell a bound from holding them all";
    const long peak = streamed(lazy(st), undecimated(), {}).object.peak_resident_fields;
    EXPECT_LE(peak, bound) << n << " slices";
    if (peak_at_fewer) {
      EXPECT_EQ(peak, peak_at_fewer) << "the peak grew with the slice count, to " << n;
    }
    peak_at_fewer = peak;
    // The natural spline couples every knot: its documented fallback holds
    // them all, and the same count shows it.
    ReconstructParams natural = undecimated();
    natural.interp.spline = SplineKind::Natural;
    EXPECT_GT(streamed(lazy(st), natural, {}).object.peak_resident_fields, n) << n << " slices";
  }
}

// Under isolated_empty lowest an empty slice with no non-empty neighbour takes
// the lowest value of all the object's fields, so the feed computes them
// before it. With a scratch folder those fields wait on disk (no name) until
// their knot: the same mesh bit for bit, and the fields held at once keep the
// window's bound. The default (box) reads no field ahead: within the bound
// without a folder.
TEST(Streaming, FieldsComputedEarlyWaitOnDiskWithAScratchFolder) {
  SliceStack st = sphere_stack(32, 0.1);
  const std::size_t n = st.slices.size();
  const long bound = long(detail::slices_in_flight()) + kFeedFields + kStreamFields;
  for (std::size_t k = 0; k < n / 2; ++k) std::fill(st.slices[k].image.data.begin(), st.slices[k].image.data.end(), 0u);
  ASSERT_GT(long(n - n / 2), 2 * bound) << "too few non-empty slices to tell a bound from holding them all";
  ReconstructParams p = undecimated();
  const ReconstructResult local = reconstruct(st, p);
  ASSERT_EQ(local.objects.size(), 1u);
  EXPECT_LE(local.objects.front().peak_resident_fields, bound) << "the default rule pulls no field ahead";
  p.interp.isolated_empty = IsolatedEmpty::Lowest;
  const ReconstructResult held = reconstruct(st, p);
  ASSERT_EQ(held.objects.size(), 1u);
  EXPECT_GT(held.objects.front().peak_resident_fields, 2 * bound) << "in memory, the fields computed early are all held";
  const test::TempDir dir;
  ReconstructOptions o;
  o.scratch_dir = dir.path().string();
  const ReconstructResult parked = reconstruct(st, p, o);
  ASSERT_EQ(parked.objects.size(), 1u);
  EXPECT_LE(parked.objects.front().peak_resident_fields, bound);
  const TriMesh& want = held.objects.front().mesh;
  const TriMesh& got = parked.objects.front().mesh;
  ASSERT_FALSE(want.triangles.empty());
  ASSERT_EQ(got.vertices.size(), want.vertices.size());
  ASSERT_EQ(got.triangles.size(), want.triangles.size());
  for (std::size_t i = 0; i < want.vertices.size(); ++i) ASSERT_EQ(got.vertices[i], want.vertices[i]) << "vertex " << i;
  for (std::size_t i = 0; i < want.triangles.size(); ++i) ASSERT_EQ(got.triangles[i], want.triangles[i]) << "triangle " << i;
  EXPECT_EQ(dir.entries().size(), 0u) << "the scratch files have no name";
}

// The next batch of slices computes while the last is meshed: an error in it
// (here from its progress report, on a worker thread) comes out of
// reconstruct(); an error while meshing (on_plane) with a batch computing
// leaves none running; and a run after either gives the same mesh.
TEST(Streaming, ErrorsWithABatchInFlightComeOutAndLeaveNothingRunning) {
  const SliceStack st = sphere_stack(40, 0.5);
  const long window = long(detail::slice_window());
  ASSERT_GT(long(st.slices.size()), 3 * window) << "too few slices for a batch ahead";
  const ReconstructParams p = undecimated();
  const ReconstructResult clean = reconstruct(st, p);
  ASSERT_EQ(clean.objects.size(), 1u);
  struct Stop : std::runtime_error {
    using std::runtime_error::runtime_error;
  };
  for (const long at : {window + 1, 2 * window + 2}) {  // in the second and third batch
    ReconstructOptions o;
    o.progress = [at](std::uint32_t, const std::string& stage, long done, long) {
      if (stage.find("distance") != std::string::npos && done == at) throw Stop("slice field " + std::to_string(at));
    };
    EXPECT_THROW(reconstruct(st, p, o), Stop) << "at slice field " << at;
  }
  for (const int at : {1, 3, 20}) {  // the first planes, and one mid-stack
    ReconstructOptions o;
    o.on_plane = [at](std::uint32_t, const Grid2f&, double, double, double, int plane, int) {
      if (plane == at) throw Stop("plane " + std::to_string(at));
    };
    EXPECT_THROW(reconstruct(st, p, o), Stop) << "at plane " << at;
  }
  const ReconstructResult again = reconstruct(st, p);
  ASSERT_EQ(again.objects.size(), 1u);
  EXPECT_EQ(again.objects.front().mesh.vertices, clean.objects.front().mesh.vertices);
  EXPECT_EQ(again.objects.front().mesh.triangles, clean.objects.front().mesh.triangles);
}
