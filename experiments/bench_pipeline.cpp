// Question (issue "Speed and memory"): where does the time go, how does it
// scale with pixels per slice and with slices, and how much memory does a
// reconstruction take? Input: the analytic branching cylinders (synth/),
// stretched along z so that exactly K slices at spacing R cut it.
//
// Default mode: Google Benchmark micro-benchmarks of each stage on one
// 500x500 slice of the jawbone-scale stack (the whole slice grid, not the
// pipeline's object crop), each repeated kRepetitions times (median reported).
// Benchmark's own flags work: --benchmark_filter=..., --benchmark_format=json
// --benchmark_out=FILE.
//
// --end-to-end: reconstruct() (marker2006 defaults, decimation at
// --decimate-error) --runs times in this process; JSON with per-stage medians
// and all runs, triangles, the process's max RSS and a hash of the output mesh
// (FNV-1a 64 of vertex and triangle bytes) for determinism checks across
// --threads. Scales (paper Table 3 sizes):
//   jawbone: 48 contour images of 500x500 at z ratio 8:1;
//   pelvis:  34 slices at 14:1 as exact polygons, fitted on a 2000x2000
//            raster, fields at 500x500 (ReconstructParams::polyline_raster_width).
// --size/--slices/--z-spacing/--raster-width override the scale's values.
//
// usage: bench_pipeline [--threads N] [--benchmark_* flags]
//        bench_pipeline --end-to-end [--scale jawbone|pelvis] [--size S] [--slices K] [--z-spacing R]
//                       [--raster-width W] [--runs 5] [--threads N] [--decimate-error 0.25] [--out FILE.json]
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/io/atomic_file.h"
#include "experiment_util.h"
#include "isoloft/pipeline.h"
#include "isoloft/synth/synth.h"
#include "validation/decimate_openmesh.h"

using namespace isoloft;
using isoloft::experiments::median;

namespace {

constexpr const char* kShape = "branching-cylinders";  // the stand-in used for stage_times and the paper's Table 3
constexpr int kRepetitions = 5;                         // micro-benchmarks: median of 5
constexpr int kDefaultRuns = 5;                         // end-to-end runs per configuration
constexpr double kDefaultDecimateError = 0.25;          // px (params.decimate.max_error)
// Micro-benchmark slice: 70% of the way up, above the fork at ~50%, so the
// slice holds two branch contours (the MPU fit's multi-piece case).
constexpr double kMicroSliceFraction = 0.7;
// Decimation is benchmarked on the closed mesh of a small reconstruction
// (128 px, the synth default): the jawbone mesh takes seconds per collapse run.
constexpr int kDecimateMeshSize = 128;
constexpr double kDecimateMeshZSpacing = 8.0;
// Bisection steps locating where the shape starts covering pixel centres:
// 2^-30 of the shape height is far below a pixel.
constexpr int kBisectionSteps = 30;
constexpr double kKiBPerMiB = 1024.0;  // ru_maxrss is in KiB on Linux

struct Scale {
  int size = 500;           ///< slice width and height, pixels
  int slices = 48;
  double z_spacing = 8.0;   ///< pixels
  int raster_width = 0;     ///< > 0: polyline input fitted at this width (ReconstructParams::polyline_raster_width)
};

const std::map<std::string, Scale> kScales = {
    {"jawbone", {500, 48, 8.0, 0}},
    {"pelvis", {500, 34, 14.0, 2000}},
};

// `inner` stretched along z by s (about z = 0) and moved by t, with bounds
// in z tightened to [z_lo, z_hi] (inner coordinates). synthesize() needs only
// value() and bounds(); value() is no longer a distance in z, which the
// slices do not see.
class ZScaled final : public Shape {
 public:
  ZScaled(std::shared_ptr<const Shape> inner, double s, double z_lo, double z_hi, Vec3d t = Vec3d::Zero())
      : inner_(std::move(inner)), s_(s), z_lo_(z_lo), z_hi_(z_hi), t_(std::move(t)) {}
  [[nodiscard]] double value(const Vec3d& p) const override {
    const Vec3d q = p - t_;
    return inner_->value(Vec3d(q.x(), q.y(), q.z() / s_));
  }
  [[nodiscard]] bool exact() const override { return false; }
  [[nodiscard]] nlohmann::json to_json() const override {
    return {{"type", "z-scaled"}, {"z_scale", s_}, {"offset", {t_.x(), t_.y(), t_.z()}}, {"shape", inner_->to_json()}};
  }
  [[nodiscard]] std::array<Vec3d, 2> bounds() const override {
    auto [lo, hi] = inner_->bounds();
    lo.z() = z_lo_ * s_, hi.z() = z_hi_ * s_;
    return {lo + t_, hi + t_};
  }
  [[nodiscard]] std::unique_ptr<Shape> translated(const Vec3d& t) const override {
    return std::make_unique<ZScaled>(inner_, s_, z_lo_, z_hi_, t_ + t);
  }

 private:
  std::shared_ptr<const Shape> inner_;
  double s_, z_lo_, z_hi_;
  Vec3d t_;
};

// The z between empty_z (no pixel centre inside) and full_z (some inside)
// where the shape starts covering pixel centres: bounds() of blended shapes
// are padded (Capsules: by blend / 4), and a cut in the padding would be an
// empty slice.
double occupied_edge(const Shape& s, double empty_z, double full_z) {
  const auto [lo, hi] = s.bounds();
  auto occupied = [&](double z) {
    for (int y = int(std::ceil(lo.y())); y <= int(hi.y()); ++y)
      for (int x = int(std::ceil(lo.x())); x <= int(hi.x()); ++x)
        if (s.value(Vec3d(x, y, z)) > 0) return true;
    return false;
  };
  if (!occupied(full_z)) throw ParamError("bench: the shape covers no pixel at z = " + std::to_string(full_z));
  for (int i = 0; i < kBisectionSteps; ++i) {
    const double m = 0.5 * (empty_z + full_z);
    (occupied(m) ? full_z : empty_z) = m;
  }
  return full_z;
}

// The default shape for a size x size image, stretched along z so that
// exactly sc.slices cuts at sc.z_spacing meet it (the first and last
// first_offset spacings inside its ends).
SynthResult make_stack(const Scale& sc) {
  std::shared_ptr<const Shape> base = make_default_shape(kShape, sc.size);
  const auto [lo, hi] = base->bounds();
  const double mid = 0.5 * (lo.z() + hi.z());
  const double z_lo = occupied_edge(*base, lo.z(), mid), z_hi = occupied_edge(*base, hi.z(), mid);
  SynthParams sp;
  sp.size = sc.size;
  sp.z_spacing = sc.z_spacing;
  sp.kind = sc.raster_width > 0 ? InputKind::Polylines : InputKind::Contours;
  const double s = sc.z_spacing * (sc.slices - 1 + 2 * sp.first_offset) / (z_hi - z_lo);
  SynthResult r = synthesize(ZScaled(base, s, z_lo, z_hi), sp);
  if (int(r.stack.slices.size()) != sc.slices)
    throw Error("bench: synthesized " + std::to_string(r.stack.slices.size()) + " slices, wanted " + std::to_string(sc.slices));
  return r;
}

double max_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / kKiBPerMiB;
}

// FNV-1a 64 (Fowler, Noll, Vo) of the vertex then triangle bytes.
std::string mesh_hash(const TriMesh& m) {
  static_assert(sizeof(Vec3f) == 3 * sizeof(float) && sizeof(m.triangles[0]) == 3 * sizeof(std::int32_t));
  constexpr std::uint64_t kOffset = 14695981039346656037ull, kPrime = 1099511628211ull;
  std::uint64_t h = kOffset;
  auto add = [&h](const void* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) h = (h ^ static_cast<const unsigned char*>(p)[i]) * kPrime;
  };
  add(m.vertices.data(), m.vertices.size() * sizeof(Vec3f));
  add(m.triangles.data(), m.triangles.size() * sizeof(m.triangles[0]));
  std::ostringstream o;
  o << std::hex << std::setw(16) << std::setfill('0') << h;
  return o.str();
}

std::unique_ptr<tbb::global_control> limit_threads(int threads) {
  if (threads <= 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
}

int active_threads() { return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)); }

// ---------------------------------------------------------------- end-to-end

int end_to_end(int argc, char** argv) {
  std::string scale_name = "jawbone", out;
  int runs = kDefaultRuns, threads = 0;
  double decimate_error = kDefaultDecimateError;
  std::map<std::string, std::string> overrides;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--end-to-end") continue;
    if (i + 1 >= argc) throw ParamError("option " + a + " needs a value");
    const std::string v = argv[++i];
    if (a == "--scale") scale_name = v;
    else if (a == "--runs") runs = std::stoi(v);
    else if (a == "--threads") threads = std::stoi(v);
    else if (a == "--decimate-error") decimate_error = std::stod(v);
    else if (a == "--out") out = v;
    else if (a == "--size" || a == "--slices" || a == "--z-spacing" || a == "--raster-width") overrides[a] = v;
    else throw ParamError("unknown option " + a);
  }
  if (!kScales.count(scale_name)) throw ParamError("unknown --scale " + scale_name + " (expected jawbone or pelvis)");
  if (runs < 1) throw ParamError("--runs must be at least 1");
  Scale sc = kScales.at(scale_name);
  for (const auto& [k, v] : overrides) {
    if (k == "--size") sc.size = std::stoi(v);
    else if (k == "--slices") sc.slices = std::stoi(v);
    else if (k == "--z-spacing") sc.z_spacing = std::stod(v);
    else sc.raster_width = std::stoi(v);
  }
  const auto gc = limit_threads(threads);

  const SynthResult syn = make_stack(sc);
  const double rss_input = max_rss_mib();
  ReconstructParams p;  // marker2006 defaults
  p.decimate.max_error = decimate_error;
  p.polyline_raster_width = sc.raster_width;
  int planes = 0;
  ReconstructOptions opt;
  opt.on_plane = [&planes](std::uint32_t, const Grid2f&, double, double, double, int, int count) { planes = count; };

  std::map<std::string, std::vector<double>> t;
  std::vector<std::string> hashes;
  long before = 0, after = 0;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    const ReconstructResult res = reconstruct(syn.stack, p, opt);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (res.objects.size() != 1) throw Error("bench: expected one object, got " + std::to_string(res.objects.size()));
    const StageTimes& st = res.times;
    for (const auto& [k, v] : std::initializer_list<std::pair<const char*, double>>{
             {"contour", st.contour}, {"mpu", st.mpu}, {"dist", st.dist}, {"filter", st.filter}, {"interp", st.interp},
             {"mesh", st.mesh}, {"decimate", st.decimate}, {"total", st.total()}, {"wall", wall}})
      t[k].push_back(v);
    const ObjectResult& o = res.objects.front();
    before = o.triangles_before_decimation;
    after = long(o.mesh.triangles.size());
    hashes.push_back(mesh_hash(o.mesh));
    std::cerr << "bench " << scale_name << " run " << r + 1 << "/" << runs << ": total " << st.total() << " s, wall " << wall
              << " s, triangles " << before << " -> " << after << "\n";
  }
  nlohmann::json med;
  for (const auto& [k, v] : t) med[k] = median(v);
  const nlohmann::json report = {
      {"program", "bench_pipeline --end-to-end"},
      {"isoloft", {{"version", ISOLOFT_VERSION}, {"git", ISOLOFT_GIT}}},
      {"scale", scale_name},
      {"shape", kShape},
      {"input",
       {{"width", syn.stack.width},
        {"height", syn.stack.height},
        {"slices", syn.stack.slices.size()},
        {"z_spacing_px", sc.z_spacing},
        {"kind", sc.raster_width > 0 ? "polylines" : "contours"},
        {"fit_raster_width", sc.raster_width > 0 ? sc.raster_width : sc.size},
        {"output_planes", planes}}},
      {"threads", active_threads()},
      {"runs", runs},
      {"decimate_error_px", decimate_error},
      {"median_s", med},
      {"all_s", t},
      {"triangles_before_decimation", before},
      {"triangles_after_decimation", after},
      {"max_rss_mib", max_rss_mib()},
      {"max_rss_after_input_mib", rss_input},
      {"mesh_hash", hashes.front()},
      {"mesh_hash_same_every_run", std::all_of(hashes.begin(), hashes.end(), [&](const auto& h) { return h == hashes.front(); })}};
  if (out.empty()) {
    std::cout << report.dump(2) << "\n";
    return 0;
  }
  AtomicFile f(out);
  {
    std::ofstream os(f.temp_path());
    os << report.dump(2) << "\n";
    if (!os.flush()) throw Error(out + ": cannot write");
  }
  f.commit();
  std::cerr << "bench: wrote " << out << "\n";
  return 0;
}

// ----------------------------------------------------------- micro-benchmarks

// Inputs of every micro-benchmark, built once: one slice of the jawbone-scale
// stack carried through the stages as reconstruct() chains them.
struct Micro {
  Grid2u32 image;
  std::uint32_t max_value = 0;
  FillResult fill;
  OrientedPoints points;
  MpuParams mpu;
  MpuResult fit;
  Grid2f f;
  NarrowBandResult band;
  Grid2f distance;
  std::unique_ptr<ZInterpolator> interp;
  double z_mid = 0;
  Grid2f plane0, plane1;  ///< interpolated planes z_mid and z_mid + z_step
  TriMesh decimate_mesh;
};

Micro build_micro() {
  Micro m;
  const SynthResult syn = make_stack(kScales.at("jawbone"));
  const SliceStack& st = syn.stack;
  const Slice& s = st.slices[std::size_t(kMicroSliceFraction * double(st.slices.size()))];
  m.image = s.image;
  m.max_value = st.max_value;
  m.fill = fill_even_odd(binarize(m.image, m.max_value / 2));
  m.points = contour_normals(m.fill.contour, m.fill.inside);
  m.mpu.domain = Eigen::AlignedBox2d(Vec2d(-0.5, -0.5), Vec2d(st.width - 0.5, st.height - 0.5));
  m.fit = fit_mpu(m.points, m.mpu);
  m.f = evaluate_on_grid(m.fit.curve, st.width, st.height);
  const MpuCurve& curve = m.fit.curve;
  m.band = narrow_band_distance(m.f, [&curve](const Vec2d& q) { return curve.value(q); });
  m.distance = extend_distance(m.band);
  // The spline's cost does not depend on the field values, so every slice
  // gets its exact pixel distance (cheap) instead of a full marker2006 field.
  std::vector<Grid2f> fields;
  std::vector<double> z;
  for (const Slice& k : st.slices) {
    const FillResult fk = fill_even_odd(binarize(k.image, st.max_value / 2));
    fields.push_back(distance_to_contour_signed(fk.contour, fk.inside));
    z.push_back(k.z);
  }
  const InterpParams ip;
  add_end_caps(fields, z, ip);
  m.z_mid = s.z;
  m.interp = std::make_unique<ZInterpolator>(std::move(fields), std::move(z), ip.spline);
  m.interp->evaluate(m.z_mid, m.plane0);
  m.interp->evaluate(m.z_mid + ip.z_step, m.plane1);

  SynthParams dp;
  dp.size = kDecimateMeshSize;
  dp.z_spacing = kDecimateMeshZSpacing;
  m.decimate_mesh = reconstruct(synthesize(*make_default_shape(kShape, kDecimateMeshSize), dp).stack, {}).objects.front().mesh;
  return m;
}

const Micro& micro() {
  static const Micro m = build_micro();
  return m;
}

void BM_ContourFill(benchmark::State& state) {
  const Micro& m = micro();
  for (auto _ : state) benchmark::DoNotOptimize(fill_even_odd(binarize(m.image, m.max_value / 2)));
}

void BM_ContourNormals(benchmark::State& state) {
  const Micro& m = micro();
  for (auto _ : state) benchmark::DoNotOptimize(contour_normals(m.fill.contour, m.fill.inside));
  state.counters["points"] = double(m.points.size());
}

void BM_MpuFit(benchmark::State& state) {
  const Micro& m = micro();
  for (auto _ : state) benchmark::DoNotOptimize(fit_mpu(m.points, m.mpu));
  state.counters["leaves"] = m.fit.leaves;
}

void BM_MpuEvaluateGrid(benchmark::State& state) {
  const Micro& m = micro();
  for (auto _ : state) benchmark::DoNotOptimize(evaluate_on_grid(m.fit.curve, m.f.width, m.f.height));
}

void BM_NarrowBand(benchmark::State& state) {
  const Micro& m = micro();
  const MpuCurve& curve = m.fit.curve;
  for (auto _ : state) benchmark::DoNotOptimize(narrow_band_distance(m.f, [&curve](const Vec2d& q) { return curve.value(q); }));
}

void BM_Extend(benchmark::State& state) {
  const Micro& m = micro();
  for (auto _ : state) benchmark::DoNotOptimize(extend_distance(m.band));
}

void BM_Filter(benchmark::State& state) {
  const Micro& m = micro();
  for (auto _ : state) benchmark::DoNotOptimize(distance_filter(m.distance));
}

void BM_SplinePlane(benchmark::State& state) {
  const Micro& m = micro();
  Grid2f out;
  for (auto _ : state) {
    m.interp->evaluate(m.z_mid, out);
    benchmark::DoNotOptimize(out.data.data());
  }
}

// One cube layer: the builder is given its bottom plane untimed.
void BM_MarchingCubesAddPlane(benchmark::State& state) {
  const Micro& m = micro();
  for (auto _ : state) {
    state.PauseTiming();
    MarchingCubes mc(m.plane0.width, m.plane0.height);
    mc.add_plane(m.plane0, 0.0);
    state.ResumeTiming();
    mc.add_plane(m.plane1, 1.0);
    benchmark::DoNotOptimize(mc.planes_added());
  }
}

// The fast decimator and its strictly greedy OpenMesh reference (same bound).
template <DecimateResult (*Decimate)(TriMesh&, const DecimateParams&)>
void BM_Decimate(benchmark::State& state) {
  const Micro& m = micro();
  DecimateParams p;
  p.max_error = kDefaultDecimateError;
  long after = 0;
  for (auto _ : state) {
    state.PauseTiming();
    TriMesh mesh = m.decimate_mesh;
    state.ResumeTiming();
    after = Decimate(mesh, p).triangles_after;
    benchmark::DoNotOptimize(mesh.triangles.data());
  }
  state.counters["triangles"] = double(m.decimate_mesh.triangles.size());
  state.counters["triangles_after"] = double(after);
}

void configure(benchmark::internal::Benchmark* b) {
  // Real time: several stages run TBB workers, whose CPU time the main
  // thread's clock would miss.
  b->Unit(benchmark::kMillisecond)->UseRealTime()->Repetitions(kRepetitions)->ReportAggregatesOnly(true);
}

BENCHMARK(BM_ContourFill)->Apply(configure);
BENCHMARK(BM_ContourNormals)->Apply(configure);
BENCHMARK(BM_MpuFit)->Apply(configure);
BENCHMARK(BM_MpuEvaluateGrid)->Apply(configure);
BENCHMARK(BM_NarrowBand)->Apply(configure);
BENCHMARK(BM_Extend)->Apply(configure);
BENCHMARK(BM_Filter)->Apply(configure);
BENCHMARK(BM_SplinePlane)->Apply(configure);
BENCHMARK(BM_MarchingCubesAddPlane)->Apply(configure);
BENCHMARK(BM_Decimate<decimate>)->Name("BM_Decimate")->Apply(configure);
BENCHMARK(BM_Decimate<detail::decimate_openmesh>)->Name("BM_DecimateOpenMeshReference")->Apply(configure);

}  // namespace

int main(int argc, char** argv) {
  try {
    if (std::find_if(argv + 1, argv + argc, [](const char* a) { return std::string(a) == "--end-to-end"; }) != argv + argc)
      return end_to_end(argc, argv);
    // Take --threads out before benchmark parses the rest.
    int threads = 0, n = 1;
    for (int i = 1; i < argc; ++i) {
      if (std::string(argv[i]) == "--threads" && i + 1 < argc) threads = std::stoi(argv[++i]);
      else argv[n++] = argv[i];
    }
    argc = n;
    const auto gc = limit_threads(threads);
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
    benchmark::AddCustomContext("threads", std::to_string(active_threads()));
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
  } catch (const ParamError& e) {
    std::cerr << "bench_pipeline: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "bench_pipeline: " << e.what() << "\n";
    return 1;
  }
}
