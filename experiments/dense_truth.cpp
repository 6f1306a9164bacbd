// Question: on real segmentations with a dense truth, how close is the
// reconstruction from every k-th slice to the slices that were left out, for
// marker2006 (default) vs levin? Every k-th slice of a label volume (the Whole
// Frog, and optionally the AAL brain atlas) is reconstructed per label; the
// interpolated field of each reconstruction is captured on the z planes that
// coincide with original slices that were NOT input (between the first and the
// last input slice) and compared there with the original segmentation:
// Dice (pooled over all scored slices) and the symmetric boundary distance
// (boundary pixels of each mask via mask_boundary, each to the nearest boundary
// pixel of the other by the exact EDT; mean and 95th percentile over both
// sets, pooled over slices). A "nearest" reference copies the nearest input
// slice (zero-order hold), to show what the interpolation gains.
// Note: the truth is itself jagged in z by about a voxel (per-slice
// segmentation), so a perfect score is not reachable.
//
// usage: dense_truth [--out DIR] [--frog FILE.mhd] [--aal FILE.nii.gz|none] [--ks 2,4,8] [--threads N]
//                    [--labels 2,6 (frog only; default all)] [--check-inputs 1 (score the input slices: Dice ~ 1)]
// writes DIR/dense_truth.csv, DIR/dense_truth.json, DIR/dense_truth.md
#include <tbb/global_control.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "isoloft/contour/fill.h"
#include "isoloft/core/error.h"
#include "isoloft/field/edt.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/metaimage.h"
#include "experiment_util.h"
#include "isoloft/pipeline.h"

using namespace isoloft;
namespace fs = std::filesystem;

namespace {

struct LabelInfo {
  std::uint32_t value;
  std::string name;
};

struct Dataset {
  std::string name;
  Volume vol;
  double z_unit = 1.0;  ///< slice spacing in pixel units (spacing z / spacing x)
  std::uint32_t max_value = 255;
  std::vector<LabelInfo> labels;
};

// Minimal NIfTI-1 reader (single file .nii or .nii.gz, read through zlib's
// gzread, which also reads uncompressed files): 348-byte header, dim[1..3],
// datatype, vox_offset, pixdim[1..3], scl_slope ignored (label maps).
Volume read_nifti(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw InputError(path, "cannot open");
  std::vector<unsigned char> bytes;
  unsigned char buf[1 << 16];
  int n = 0;
  while ((n = gzread(f, buf, sizeof buf)) > 0) bytes.insert(bytes.end(), buf, buf + n);
  const bool bad = n < 0;
  gzclose(f);
  if (bad) throw InputError(path, "corrupt gzip stream");
  if (bytes.size() < 348) throw InputError(path, "shorter than a NIfTI-1 header (348 bytes)");
  auto get = [&](std::size_t off, auto v) {
    std::memcpy(&v, bytes.data() + off, sizeof v);
    return v;
  };
  if (get(0, std::int32_t{}) != 348) throw InputError(path, "not a little-endian NIfTI-1 file (sizeof_hdr != 348)");
  if (std::memcmp(bytes.data() + 344, "n+1", 3) != 0) throw InputError(path, "magic is not n+1 (single-file NIfTI-1)");
  const int ndim = get(40, std::int16_t{});
  if (ndim < 3) throw InputError(path, "fewer than 3 dimensions");
  for (int d = 4; d <= std::min(ndim, 7); ++d)
    if (get(40 + 2 * d, std::int16_t{}) > 1) throw InputError(path, "more than one volume (dim[4..] > 1)");
  Volume v;
  v.nx = get(42, std::int16_t{});
  v.ny = get(44, std::int16_t{});
  v.nz = get(46, std::int16_t{});
  const int datatype = get(70, std::int16_t{});
  for (int d = 0; d < 3; ++d) v.spacing[d] = std::abs(get(80 + 4 * d, float{}));
  const std::size_t offset = std::size_t(get(108, float{}));
  detail::ScalarType t;
  switch (datatype) {
    case 2: t = detail::ScalarType::U8; break;
    case 4: t = detail::ScalarType::I16; break;
    case 8: t = detail::ScalarType::I32; break;
    case 16: t = detail::ScalarType::F32; break;
    case 64: t = detail::ScalarType::F64; break;
    case 256: t = detail::ScalarType::I8; break;
    case 512: t = detail::ScalarType::U16; break;
    case 768: t = detail::ScalarType::U32; break;
    default: throw InputError(path, "unsupported NIfTI datatype " + std::to_string(datatype));
  }
  const std::size_t count = detail::checked_voxel_count(v.nx, v.ny, v.nz, path);
  if (bytes.size() < offset + count * detail::scalar_size(t)) throw InputError(path, "data shorter than dim[1..3] x datatype");
  v.data.resize(count);
  detail::decode_scalars(bytes.data() + offset, count, t, false, v.data.data());
  return v;
}


double percentile(std::vector<double>& v, double q) {
  if (v.empty()) return std::nan("");
  const std::size_t i = std::min(v.size() - 1, std::size_t(std::ceil(q * double(v.size())) - 1));
  std::nth_element(v.begin(), v.begin() + long(i), v.end());
  return v[i];
}

// Pooled scores of one (label, k, method).
struct Score {
  long inter = 0, sum = 0;          // Dice = 2 inter / sum, pooled over slices
  int slices = 0;                   // slices where truth or prediction is non-empty
  int one_sided = 0;                // of those, slices where only one is non-empty (no boundary distance)
  std::vector<double> distances;    // boundary distances of both sets, pooled
  void add(const Grid2u8& pred, const Grid2u8& truth) {
    long a = 0, b = 0, ab = 0;
    for (std::size_t i = 0; i < pred.data.size(); ++i) {
      a += pred.data[i];
      b += truth.data[i];
      ab += pred.data[i] & truth.data[i];
    }
    if (a == 0 && b == 0) return;
    ++slices;
    inter += ab;
    sum += a + b;
    if (a == 0 || b == 0) {
      ++one_sided;
      return;
    }
    const Grid2u8 bp = mask_boundary(pred), bt = mask_boundary(truth);
    const Grid2f dp = squared_edt(bp), dt = squared_edt(bt);
    for (std::size_t i = 0; i < bp.data.size(); ++i) {
      if (bp.data[i]) distances.push_back(std::sqrt(double(dt.data[i])));
      if (bt.data[i]) distances.push_back(std::sqrt(double(dp.data[i])));
    }
  }
  [[nodiscard]] double dice() const { return sum ? 2.0 * double(inter) / double(sum) : std::nan(""); }
  [[nodiscard]] double mean() const {
    double s = 0;
    for (double d : distances) s += d;
    return distances.empty() ? std::nan("") : s / double(distances.size());
  }
};

Grid2u8 label_mask(const Volume& v, int j, std::uint32_t label) {
  Grid2u8 m(v.nx, v.ny, 0);
  const float* p = v.data.data() + v.index(0, 0, j);
  for (std::size_t i = 0; i < m.data.size(); ++i) m.data[i] = std::uint32_t(std::lround(p[i])) == label;
  return m;
}

struct Row {
  std::string dataset, name, method;
  std::uint32_t label;
  int k;
  Score score;
  double seconds;
  std::string error;  ///< reconstruct() threw: scores are NaN
};

}  // namespace

int main(int argc, char** argv) {
  std::string out = "experiments/out/dense_truth", frog = "../shared/data/frog/frogtissue.mhd",
              aal = "/usr/share/mricron/templates/aal.nii.gz";
  int threads = 0;
  bool check_inputs = false;  // sanity check of the plane-to-image mapping: score the input slices instead (Dice ~ 1)
  std::vector<int> ks{2, 4, 8};
  std::vector<std::uint32_t> frog_only;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--out") out = v;
    else if (a == "--frog") frog = v;
    else if (a == "--aal") aal = v;
    else if (a == "--threads") threads = std::stoi(v);
    else if (a == "--check-inputs") check_inputs = v == "1";
    else if (a == "--ks") {
      ks.clear();
      for (const auto& s : experiments::split(v)) ks.push_back(std::stoi(s));
    } else if (a == "--labels") {
      for (const auto& s : experiments::split(v)) frog_only.push_back(std::uint32_t(std::stoul(s)));
    } else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  std::unique_ptr<tbb::global_control> gc;
  if (threads > 0) gc = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);

  std::vector<Dataset> datasets;
  {
    Dataset d;
    d.name = "frog";
    d.vol = read_metaimage(frog);
    d.labels = {{2, "brain"}, {4, "eye_retina"}, {5, "eye_white"}, {6, "heart"}, {8, "kidney"},
                {10, "liver"}, {11, "lung"},     {14, "spleen"},   {15, "stomach"}};
    if (!frog_only.empty())
      std::erase_if(d.labels, [&](const LabelInfo& l) { return std::find(frog_only.begin(), frog_only.end(), l.value) == frog_only.end(); });
    datasets.push_back(std::move(d));
  }
  if (aal != "none") {
    if (!fs::exists(aal)) {
      std::cerr << "dense_truth: " << aal << " not found (apt-get install mricron-data); skipping AAL\n";
    } else {
      Dataset d;
      d.name = "aal";
      d.vol = read_nifti(aal);
      d.labels = {{37, "Hippocampus_L"}, {41, "Amygdala_L"}, {71, "Caudate_L"}, {73, "Putamen_L"}, {77, "Thalamus_L"}};
      datasets.push_back(std::move(d));
    }
  }

  std::vector<Row> rows;
  const auto t_all = std::chrono::steady_clock::now();
  for (auto& ds : datasets) {
    const Volume& v = ds.vol;
    if (std::abs(v.spacing[0] - v.spacing[1]) > 1e-6 * v.spacing[0])
      std::cerr << "dense_truth: " << ds.name << ": non-square pixels; x spacing taken as the pixel unit\n";
    ds.z_unit = v.spacing[2] / v.spacing[0];
    float vmax = 0;
    for (float x : v.data) vmax = std::max(vmax, x);
    ds.max_value = vmax > 255 ? 65535 : 255;
    std::cerr << ds.name << ": " << v.nx << "x" << v.ny << "x" << v.nz << ", slice spacing " << ds.z_unit << " px\n";
    for (int k : ks) {
      // Input: slices 0, k, 2k, ... (all labels; the pipeline filters).
      SliceStack stack;
      stack.width = v.nx;
      stack.height = v.ny;
      stack.max_value = ds.max_value;
      stack.kind = InputKind::Labels;
      std::vector<int> input;
      for (int j = 0; j < v.nz; j += k) input.push_back(j);
      for (int j : input) {
        Slice s;
        s.z = ds.z_unit * j;
        s.source = ds.name + " slice " + std::to_string(j);
        s.image = Grid2u32(v.nx, v.ny, 0);
        const float* p = v.data.data() + v.index(0, 0, j);
        for (std::size_t i = 0; i < s.image.data.size(); ++i) s.image.data[i] = std::uint32_t(std::lround(p[i]));
        stack.slices.push_back(std::move(s));
      }
      const int j_first = input.front(), j_last = input.back();
      std::vector<int> left_out;
      for (int j = j_first; j <= j_last; ++j)
        if ((j - j_first) % k != 0) left_out.push_back(j);

      ReconstructParams base;
      base.interp.z_step = ds.z_unit;  // planes on original slices...
      // ...provided the lower cap (z_first - cap_extent * k * z_unit) lies a
      // whole number of slices below the first slice.
      const double cap_slices = base.interp.cap_extent * k;
      if (std::abs(cap_slices - std::round(cap_slices)) > 1e-9) {
        base.interp.cap_extent = std::max(1.0, std::round(cap_slices)) / k;
        std::cerr << "dense_truth: k=" << k << ": cap_extent set to " << base.interp.cap_extent
                  << " so that the sampled planes fall on original slices\n";
      }
      base.decimate.max_error = 0;  // the mesh is not scored

      for (const auto& L : ds.labels) {
        // Reference: nearest input slice (ties to the lower one).
        {
          Row r{ds.name, L.name, "nearest", L.value, k, {}, 0.0, {}};
          for (int j : left_out) {
            const int jn = j_first + ((j - j_first + k / 2 - (k % 2 == 0 ? 1 : 0)) / k) * k;
            r.score.add(label_mask(v, jn, L.value), label_mask(v, j, L.value));
          }
          rows.push_back(std::move(r));
        }
        for (const Method m : {Method::Marker2006, Method::Levin}) {
          ReconstructParams p = base;
          p.method = m;
          p.interp.spline = method_defaults(m).interp.spline;
          Row r{ds.name, L.name, to_string(m), L.value, k, {}, 0.0, {}};
          std::vector<char> seen(std::size_t(v.nz), 0);
          int misaligned = 0;
          ReconstructOptions opt;
          opt.labels = {L.value};
          opt.on_plane = [&](std::uint32_t, const Grid2f& plane, double x0, double y0, double z, int, int) {
            const double jd = z / ds.z_unit;
            const long j = std::lround(jd);
            if (std::abs(jd - double(j)) > 1e-6) {
              ++misaligned;
              return;
            }
            if (j < j_first || j > j_last || ((j - j_first) % k == 0) != check_inputs) return;
            seen[std::size_t(j)] = 1;
            Grid2u8 pred(v.nx, v.ny, 0);
            const int ox = int(std::lround(x0)), oy = int(std::lround(y0));
            for (int y = 0; y < plane.height; ++y)
              for (int x = 0; x < plane.width; ++x)
                if (plane(x, y) > 0 && pred.contains(x + ox, y + oy)) pred(x + ox, y + oy) = 1;
            r.score.add(pred, label_mask(v, int(j), L.value));
          };
          const auto t0 = std::chrono::steady_clock::now();
          ReconstructResult res;
          try {
            res = reconstruct(stack, p, opt);
          } catch (const std::exception& e) {
            // Recorded as a failed row (NaN scores) so the other rows still
            // come out; small pieces of the label in the input slices are
            // listed as the likely cause.
            r.error = e.what();
            std::cerr << "dense_truth: " << ds.name << " " << L.name << " k=" << k << " " << r.method << " failed: " << e.what()
                      << "; input slices with < 10 px of the label:";
            for (int j : input) {
              long c = 0;
              for (auto b : label_mask(v, j, L.value).data) c += b;
              if (c > 0 && c < 10) std::cerr << " " << j << " (" << c << " px)";
            }
            std::cerr << "\n";
            rows.push_back(std::move(r));
            continue;
          }
          r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          for (const auto& w : res.warnings) std::cerr << "  warning: " << w << "\n";
          int missing = 0;
          if (!check_inputs)
            for (int j : left_out) missing += !seen[std::size_t(j)];
          // A label absent from every input slice has no reconstruction: its
          // left-out slices are scored against an empty prediction.
          if (res.objects.empty()) {
            for (int j : left_out) r.score.add(Grid2u8(v.nx, v.ny, 0), label_mask(v, j, L.value));
            missing = 0;
          }
          if (misaligned || missing)
            std::cerr << "  warning: " << misaligned << " planes off the original slices, " << missing
                      << " left-out slices not sampled\n";
          std::cerr << ds.name << " " << L.name << " k=" << k << " " << r.method << ": dice " << std::fixed
                    << std::setprecision(4) << r.score.dice() << ", mean " << std::setprecision(3) << r.score.mean() << " px, "
                    << r.score.slices << " slices, " << std::setprecision(1) << r.seconds << " s\n"
                    << std::defaultfloat;
          rows.push_back(std::move(r));
        }
      }
    }
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_all).count();

  // Rows label x k (the loops run k outer to build each input stack once).
  std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
    const bool fa = a.dataset == "frog", fb = b.dataset == "frog";
    return std::tie(fb, a.label, a.k) < std::tie(fa, b.label, b.k);
  });
  fs::create_directories(out);
  std::ofstream csv(fs::path(out) / "dense_truth.csv");
  csv << "dataset,label,name,k,method,slices_scored,one_sided_slices,dice,mean_boundary_px,p95_boundary_px,seconds\n";
  nlohmann::json jrows = nlohmann::json::array();
  std::map<std::string, std::map<std::string, std::string>> cells;
  std::vector<std::string> keys;
  const std::vector<std::string> methods{"marker2006", "levin", "nearest"};
  for (auto& r : rows) {
    const double p95 = percentile(r.score.distances, 0.95);
    csv << r.dataset << "," << r.label << "," << r.name << "," << r.k << "," << r.method << "," << r.score.slices << ","
        << r.score.one_sided << "," << r.score.dice() << "," << r.score.mean() << "," << p95 << "," << r.seconds << "\n";
    jrows.push_back({{"dataset", r.dataset}, {"label", r.label}, {"name", r.name}, {"k", r.k}, {"method", r.method},
                     {"slices_scored", r.score.slices}, {"one_sided_slices", r.score.one_sided}, {"dice", r.score.dice()},
                     {"mean_boundary_px", r.score.mean()}, {"p95_boundary_px", p95}, {"seconds", r.seconds}, {"error", r.error}});
    std::ostringstream key, cell;
    key << r.dataset << " " << r.label << " " << r.name << ", k=" << r.k;
    if (std::find(keys.begin(), keys.end(), key.str()) == keys.end()) keys.push_back(key.str());
    if (!r.error.empty())
      cell << "failed (" << r.error << ")";
    else
      cell << std::fixed << std::setprecision(3) << r.score.dice() << " / " << std::setprecision(2) << r.score.mean();
    cells[key.str()][r.method] = cell.str();
  }
  std::ofstream(fs::path(out) / "dense_truth.json") << nlohmann::json{{"seconds_total", total}, {"rows", jrows}}.dump(1) << "\n";
  std::ofstream md(fs::path(out) / "dense_truth.md");
  md << "Cells: Dice / mean symmetric boundary distance (px), over the left-out original slices between the first and last input "
        "slice (input: every k-th slice). `nearest` copies the nearest input slice (reference, no interpolation). Total "
     << std::fixed << std::setprecision(0) << total << " s.\n\n| label, k | marker2006 | levin | nearest (reference) |\n|---|---|---|---|\n";
  for (const auto& key : keys) {
    md << "| " << key << " |";
    for (const auto& m : methods) md << " " << cells[key][m] << " |";
    md << "\n";
  }
  std::cerr << "wrote " << out << "/dense_truth.{csv,json,md} in " << total << " s\n";
  return 0;
}
