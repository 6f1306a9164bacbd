#include "isoloft/io/volume_slices.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <unordered_map>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"
#include "isoloft/io/file_util.h"

namespace isoloft {

namespace {

// In-plane voxel sizes differing by more than this (relative) are not square:
// the per-slice distance fields need square pixels.
constexpr double kSquareTolerance = 1e-4;

// The two in-plane voxel axes of slicing axis a, in order.
std::array<int, 2> in_plane(int a) {
  return a == 0 ? std::array<int, 2>{1, 2} : a == 1 ? std::array<int, 2>{0, 2} : std::array<int, 2>{0, 1};
}

std::array<int, 3> sizes(const Volume& v) { return {v.nx, v.ny, v.nz}; }

// A volume's voxels row by row (x runs): its floats, or the file's samples as
// stored, decoded a row at a time (no float copy of the whole volume).
class VoxelRows {
 public:
  explicit VoxelRows(const Volume& v) : v_(v) {}
  VoxelRows(const Volume& geometry, const VolumeSamples& samples)
      : v_(geometry), samples_(&samples), size_(detail::scalar_size(samples.type)) {}

  [[nodiscard]] const Volume& volume() const { return v_; }
  [[nodiscard]] std::size_t count() const { return std::size_t(v_.nx) * std::size_t(v_.ny) * std::size_t(v_.nz); }
  /// Row (j, k) as floats; `buffer` (nx floats) holds it when it is decoded.
  const float* row(int j, int k, float* buffer) const {
    if (!samples_) return v_.data.data() + v_.index(0, j, k);
    if (samples_->planes) {
      const SamplePlane& p = (*samples_->planes)[std::size_t(k)];
      if (p.empty()) {  // an all-0 plane (the reader keeps none of it)
        std::fill(buffer, buffer + v_.nx, 0.0f);
      } else {
        p.row_floats(j, samples_->type, samples_->big_endian, buffer);
      }
      return buffer;
    }
    const unsigned char* b = bytes(v_.index(0, j, k));
    detail::decode_scalars(b, std::size_t(v_.nx), samples_->type, samples_->big_endian, buffer);
    return buffer;
  }
  /// Row (j, k) is all 0, seen without decoding it (integer samples whose
  /// bytes are all 0); false says nothing (the floats are read as they are).
  [[nodiscard]] bool known_zero(int j, int k) const {
    if (!samples_) return false;
    if (samples_->planes) return (*samples_->planes)[std::size_t(k)].row_zero(j);
    const unsigned char* b = bytes(v_.index(0, j, k));
    unsigned char any = 0;
    for (std::size_t i = 0, n = std::size_t(v_.nx) * size_; i < n; ++i) any |= b[i];  // branch-free: vectorises
    return any == 0;
  }
  /// Voxel i's value.
  [[nodiscard]] float at(std::size_t i) const {
    if (!samples_) return v_.data[i];
    if (samples_->planes) {
      const std::size_t plane = std::size_t(v_.nx) * std::size_t(v_.ny), in = i % plane;
      return (*samples_->planes)[i / plane].at(int(in % std::size_t(v_.nx)), int(in / std::size_t(v_.nx)), samples_->type,
                                               samples_->big_endian);
    }
    const unsigned char* b = bytes(i);
    float x;
    detail::decode_scalars(b, 1, samples_->type, samples_->big_endian, &x);
    return x;
  }
  /// The samples are held plane by plane (VolumeSamples::planes).
  [[nodiscard]] bool by_plane() const { return samples_ && samples_->planes; }
  [[nodiscard]] const VolumeSamples& samples() const { return *samples_; }

 private:
  const Volume& v_;
  const VolumeSamples* samples_ = nullptr;
  std::size_t size_ = 4;

  // Sample i's bytes in the one buffer (not held plane by plane).
  [[nodiscard]] const unsigned char* bytes(std::size_t i) const { return samples_->bytes + i * size_; }
};

using Occupancy = std::array<std::vector<std::uint8_t>, 3>;
constexpr std::size_t kNoRow = std::numeric_limits<std::size_t>::max();

// One pass over the voxels: which slices along each axis hold any non-zero
// voxel, and the first row (x run) holding a NaN or infinite voxel, or, with
// `labels`, a value that is not a non-negative integer up to 2^24.
struct VoxelScan {
  Occupancy occupied;
  std::vector<std::uint8_t> row_any;  // per row (j, k), k-major: it holds a non-zero voxel
  std::size_t first_nonfinite_row = kNoRow;
  std::size_t first_nonlabel_row = kNoRow;
};

VoxelScan scan_voxels(const VoxelRows& rows, bool labels) {
  const Volume& v = rows.volume();
  constexpr float kMaxFinite = std::numeric_limits<float>::max(), kMaxLabel = float(1 << 24), kExact = float(1 << 23);
  struct Plane {
    std::vector<std::uint8_t> occ_i, occ_j;
    bool any = false;
    std::size_t nonfinite = kNoRow, nonlabel = kNoRow;
  };
  std::vector<Plane> planes(std::size_t(v.nz));
  VoxelScan out;
  out.row_any.assign(std::size_t(v.ny) * std::size_t(v.nz), 0);
  tbb::parallel_for(0, v.nz, [&](int k) {
    Plane& p = planes[std::size_t(k)];
    p.occ_i.assign(std::size_t(v.nx), 0);
    p.occ_j.assign(std::size_t(v.ny), 0);
    std::vector<float> buffer(std::size_t(v.nx));
    for (int j = 0; j < v.ny; ++j) {
      if (rows.known_zero(j, k)) continue;  // nothing to mark or refuse
      const float* row = rows.row(j, k, buffer.data());
      int any = 0, bad_finite = 0, bad_label = 0;
      for (int i = 0; i < v.nx; ++i) {  // branch-free, so it vectorises
        const float x = row[i];
        any |= int(x != 0);
        bad_finite |= int(!(std::abs(x) <= kMaxFinite));  // NaN and infinities
        // Below 2^23, x + 2^23 rounds to an integer (spacing 1 there): x is
        // integral iff that leaves it unchanged; from 2^23 on every float is.
        const float rounded = (x + kExact) - kExact;
        bad_label |= int(!((x >= 0) & (x <= kMaxLabel) & ((x >= kExact) | (rounded == x))));
      }
      if (any)
        for (int i = 0; i < v.nx; ++i) p.occ_i[std::size_t(i)] |= std::uint8_t(row[i] != 0);
      const std::size_t r = std::size_t(k) * std::size_t(v.ny) + std::size_t(j);
      if (any) p.occ_j[std::size_t(j)] = 1, p.any = true, out.row_any[r] = 1;
      if (bad_finite) p.nonfinite = std::min(p.nonfinite, r);
      if (labels && bad_label) p.nonlabel = std::min(p.nonlabel, r);
    }
  });
  out.occupied[0].assign(std::size_t(v.nx), 0);
  out.occupied[1].assign(std::size_t(v.ny), 0);
  out.occupied[2].assign(std::size_t(v.nz), 0);
  for (std::size_t k = 0; k < planes.size(); ++k) {
    const Plane& p = planes[k];
    for (std::size_t i = 0; i < p.occ_i.size(); ++i) out.occupied[0][i] |= p.occ_i[i];
    for (std::size_t j = 0; j < p.occ_j.size(); ++j) out.occupied[1][j] |= p.occ_j[j];
    out.occupied[2][k] = p.any;
    out.first_nonfinite_row = std::min(out.first_nonfinite_row, p.nonfinite);
    out.first_nonlabel_row = std::min(out.first_nonlabel_row, p.nonlabel);
  }
  return out;
}

// The share of empty slices between the first and the last occupied one.
double sparsity(const std::vector<std::uint8_t>& occ) {
  const auto first = std::find(occ.begin(), occ.end(), 1);
  if (first == occ.end()) return 0;
  const auto last = std::find(occ.rbegin(), occ.rend(), 1).base();
  const double extent = double(last - first), annotated = double(std::count(first, last, 1));
  return 1.0 - annotated / extent;
}

int sparse_axis_of(const Occupancy& occupancy) {
  int best = 2;
  double best_sparsity = 0;
  for (int a : {2, 1, 0}) {  // ties go to k, then j
    const double s = sparsity(occupancy[std::size_t(a)]);
    if (s > best_sparsity + 1e-12) best = a, best_sparsity = s;
  }
  return best;
}

const char* const kAxisNames = "ijk";

// A label or mask drawn on slices along another axis than the one sliced:
// along the sliced one it is a stack of one-voxel lines.
std::string off_axis_warning(const std::string& path, const std::string& what, int drawn, int sliced,
                             const std::vector<std::uint8_t>& occ_drawn) {
  const auto first = std::find(occ_drawn.begin(), occ_drawn.end(), 1);
  const auto last = std::find(occ_drawn.rbegin(), occ_drawn.rend(), 1).base();
  return path + ": " + what + ": drawn on slices along " + kAxisNames[drawn] + " (" +
         std::to_string(std::count(first, last, 1)) + " of the " + std::to_string(last - first) + " slices from " +
         kAxisNames[drawn] + " = " + std::to_string(first - occ_drawn.begin()) + " hold it), but the volume is sliced along " +
         kAxisNames[sliced] + ", across which it is thin lines: the surface will be wrong (give " +
         option_given("--axis", std::string(1, kAxisNames[drawn])) +
         (what == "the mask" ? "" : " with " + option_name("--labels") + " for it") + ")";
}

// An annotated slice with under kStrayFraction of the non-zero voxels of the
// annotated slices either side, next to a slice that is not annotated: a
// stray voxel made it "annotated", and every object crossing it is cut or
// pinched there. (A dense run of slices is data throughout: not checked.)
constexpr double kStrayFraction = 0.01;

std::size_t nonzero(const Grid2u32& g) {
  return std::size_t(std::count_if(g.data.begin(), g.data.end(), [](std::uint32_t x) { return x != 0; }));
}

// Annotated slice s borders a slice that is not.
bool borders_gap(const VolumeStack& vs, std::size_t s) {
  const int t = vs.annotated[s];
  const bool before = s > 0 && vs.annotated[s - 1] == t - 1, after = s + 1 < vs.annotated.size() && vs.annotated[s + 1] == t + 1;
  return !(before && after);
}

// The stray slices (stack indices) and their non-zero voxel counts.
std::vector<std::size_t> stray_slices(const VolumeStack& vs, std::vector<std::size_t>& count) {
  const auto& sl = vs.stack.slices;
  count.assign(sl.size(), 0);
  for (std::size_t s = 0; s < sl.size(); ++s)
    count[s] = nonzero(vs.stack.load_image ? vs.stack.load_image(s) : sl[s].image);
  std::vector<std::size_t> out;
  for (std::size_t s = 1; s + 1 < sl.size(); ++s)
    if (borders_gap(vs, s) && double(count[s]) < kStrayFraction * double(std::min(count[s - 1], count[s + 1])))
      out.push_back(s);
  return out;
}

std::string stray_text(const std::string& path, const VolumeStack& vs, std::size_t s, const std::vector<std::size_t>& count) {
  return path + ": annotated slice " + kAxisNames[vs.axis] + " = " + std::to_string(vs.annotated[s]) + " holds " +
         std::to_string(count[s]) + " non-zero voxel(s), against " + std::to_string(count[s - 1]) + " and " +
         std::to_string(count[s + 1]) + " on the annotated slices either side (stray voxels?)";
}

// Per label (a voxel value, or its value-table index; with `binary`, one
// object of every non-zero voxel): the slices along each axis that hold it,
// as bitmaps (label l's words for axis a at bits[a][l * words[a] ...]), its
// voxels, and its voxels whose neighbour at +1 along each axis is the same
// label. Empty when the volume holds more than kMaxCheckedLabels labels (the
// checks' memory would grow with them).
constexpr std::size_t kMaxCheckedLabels = std::size_t(1) << 16;

struct LabelOccupancy {
  std::vector<float> keys;  // voxel values, in order of first appearance
  std::array<std::size_t, 3> words{};
  std::array<std::vector<std::uint64_t>, 3> bits;
  std::vector<std::uint64_t> voxels;
  std::vector<std::array<std::uint64_t, 3>> pairs;
  [[nodiscard]] bool test(std::size_t label, int axis, std::size_t t) const {
    return (bits[std::size_t(axis)][label * words[std::size_t(axis)] + t / 64] >> (t % 64)) & 1;
  }
  [[nodiscard]] std::vector<std::uint8_t> slices(std::size_t label, int axis, std::size_t n) const {
    std::vector<std::uint8_t> o(n);
    for (std::size_t t = 0; t < n; ++t) o[t] = test(label, axis, t);
    return o;
  }
};

LabelOccupancy label_occupancy(const VoxelRows& rows, const std::vector<std::uint8_t>& row_any, bool binary) {
  const Volume& v = rows.volume();
  LabelOccupancy out;
  std::unordered_map<float, std::size_t> id;
  out.words = {(std::size_t(v.nx) + 63) / 64, (std::size_t(v.ny) + 63) / 64, (std::size_t(v.nz) + 63) / 64};
  auto set = [&](std::size_t l, int a, std::size_t t) {
    out.bits[std::size_t(a)][l * out.words[std::size_t(a)] + t / 64] |= std::uint64_t(1) << (t % 64);
  };
  auto same = [binary](float x, float y) { return binary ? y != 0 : x == y; };  // x != 0
  std::size_t last = 0;
  bool have_last = false;
  float last_key = 0;
  std::vector<float> here(std::size_t(v.nx)), below_row(here.size()), behind_row(here.size());
  for (int k = 0; k < v.nz; ++k)
    for (int j = 0; j < v.ny; ++j) {
      if (!row_any[std::size_t(k) * std::size_t(v.ny) + std::size_t(j)]) continue;  // no run of a label
      const float* row = rows.row(j, k, here.data());
      const float* below = j > 0 ? rows.row(j - 1, k, below_row.data()) : nullptr;   // (i, j - 1, k)
      const float* behind = k > 0 ? rows.row(j, k - 1, behind_row.data()) : nullptr;  // (i, j, k - 1)
      for (int i = 0; i < v.nx;) {
        const float x = row[i];
        int e = i + 1;
        while (e < v.nx && (binary ? (row[e] != 0) == (x != 0) : row[e] == x)) ++e;  // a run of one label
        if (x != 0) {
          const float key = binary ? 1.0f : x;
          if (!have_last || key != last_key) {
            auto [it, added] = id.emplace(key, out.keys.size());
            if (added) {
              if (out.keys.size() == kMaxCheckedLabels) return {};
              out.keys.push_back(key);
              for (std::size_t a = 0; a < 3; ++a) out.bits[a].resize(out.keys.size() * out.words[a], 0);
              out.voxels.push_back(0);
              out.pairs.push_back({});
            }
            last = it->second, last_key = key, have_last = true;
          }
          auto& p = out.pairs[last];
          out.voxels[last] += std::uint64_t(e - i);
          p[0] += std::uint64_t(e - i - 1);
          for (int t = i; t < e; ++t) {
            set(last, 0, std::size_t(t));
            if (below) p[1] += same(x, below[t]);
            if (behind) p[2] += same(x, behind[t]);
          }
          set(last, 1, std::size_t(j));
          set(last, 2, std::size_t(k));
        }
        i = e;
      }
    }
  return out;
}

// Drawn slice by slice along axis b, seen across axis `sliced`: on at least 3
// slices along b, almost no voxel has a neighbour of its label along b (the
// slices are one voxel thick), while most have one along `sliced` (the label
// is not drawn along that one too). A real object, even a thin one, is more
// than one voxel thick along some slices' normal; a speck is neither.
constexpr double kDrawnPairs = 0.05, kDensePairs = 0.5;

int other_drawn_axis(const LabelOccupancy& occ, std::size_t l, int sliced, const std::array<std::size_t, 3>& n) {
  const double voxels = double(occ.voxels[l]);
  if (!(double(occ.pairs[l][std::size_t(sliced)]) >= kDensePairs * voxels)) return -1;
  for (int b : {2, 1, 0}) {
    if (b == sliced || double(occ.pairs[l][std::size_t(b)]) > kDrawnPairs * voxels) continue;
    const auto o = occ.slices(l, b, n[std::size_t(b)]);
    if (std::count(o.begin(), o.end(), 1) >= 3) return b;
  }
  return -1;
}

// Labels: (1) a label drawn along another axis than the one sliced; (2) a
// stray slice, with the labels it cuts.
void label_warnings(const VoxelRows& rows, const std::vector<std::uint8_t>& row_any, VolumeStack& vs,
                    const std::string& path) {
  constexpr std::size_t kNamed = 5;  // labels named per warning; the rest counted
  const Volume& v = rows.volume();
  const LabelOccupancy occ = label_occupancy(rows, row_any, false);
  const std::array<std::size_t, 3> n{std::size_t(v.nx), std::size_t(v.ny), std::size_t(v.nz)};
  const int a = vs.axis;
  auto label_of = [&](float key) {
    return v.value_table.empty() ? std::int64_t(key) : v.value_table[std::size_t(key)];
  };
  std::vector<std::size_t> order(occ.keys.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return label_of(occ.keys[x]) < label_of(occ.keys[y]); });
  // (1) drawn axis -> the labels drawn along it, and one's slices.
  std::map<int, std::vector<std::string>> off_axis;
  std::map<int, std::vector<std::uint8_t>> example;
  // (2) per annotated slice (stack index), the labels cut there.
  std::vector<std::size_t> count;
  const std::vector<std::size_t> stray = stray_slices(vs, count);
  std::vector<std::vector<std::string>> cut(stray.size());
  for (const std::size_t l : order) {
    if (const int drawn = other_drawn_axis(occ, l, a, n); drawn >= 0) {
      off_axis[drawn].push_back(std::to_string(label_of(occ.keys[l])));
      example.emplace(drawn, occ.slices(l, drawn, n[std::size_t(drawn)]));
      continue;  // cut everywhere along the sliced axis: (2) would only repeat it
    }
    const auto mine = occ.slices(l, a, n[std::size_t(a)]);
    const auto first = std::find(mine.begin(), mine.end(), 1) - mine.begin();
    const auto last = std::find(mine.rbegin(), mine.rend(), 1).base() - mine.begin();
    for (std::size_t i = 0; i < stray.size(); ++i) {
      const int t = vs.annotated[stray[i]];
      if (t > first && t < last - 1 && !mine[std::size_t(t)]) cut[i].push_back(std::to_string(label_of(occ.keys[l])));
    }
  }
  auto listed = [&](const auto& labels) {
    std::string out;
    for (std::size_t i = 0; i < labels.size() && i < kNamed; ++i) out += (i ? ", " : "") + std::string(labels[i]);
    if (labels.size() > kNamed) out += " and " + std::to_string(labels.size() - kNamed) + " more";
    return out;
  };
  for (const auto& [drawn, labels] : off_axis)
    vs.warnings.push_back(off_axis_warning(path, "label(s) " + listed(labels), drawn, a, example[drawn]));
  for (std::size_t i = 0; i < stray.size() && i < kNamed; ++i)
    vs.warnings.push_back(stray_text(path, vs, stray[i], count) +
                          (cut[i].empty() ? "" : ": label(s) " + listed(cut[i]) + " crossing it are cut there"));
  if (stray.size() > kNamed)
    vs.warnings.push_back(path + ": " + std::to_string(stray.size() - kNamed) + " more annotated slice(s) like that");
}

}  // namespace

namespace detail {

int sparse_axis(const Volume& v) { return sparse_axis_of(scan_voxels(VoxelRows(v), false).occupied); }

}  // namespace detail

namespace {

VolumeStack slice_rows(const VoxelRows& rows, const VolumeSlicing& slicing, const std::string& path) {
  const Volume& v = rows.volume();
  if (slicing.kind != InputKind::Labels && slicing.kind != InputKind::Masks)
    throw ParamError("a volume holds labels or masks");
  if (slicing.axis < -1 || slicing.axis > 2) throw ParamError(option_name("--axis") + ": must be i, j or k");
  VolumeStack out;
  const VoxelScan scan = scan_voxels(rows, slicing.kind == InputKind::Labels);
  out.axis = slicing.axis >= 0 ? slicing.axis : sparse_axis_of(scan.occupied);
  const int a = out.axis;
  const auto [u, w] = in_plane(a);
  const double su = v.spacing[std::size_t(u)], sw = v.spacing[std::size_t(w)], sa = v.spacing[std::size_t(a)];
  const char* const kAxis = kAxisNames;
  if (scan.first_nonfinite_row != kNoRow) detail::check_finite_voxels(v, path);
  if (std::abs(su - sw) > kSquareTolerance * std::max(su, sw))
    throw InputError(path, std::string("voxels are not square across axis ") + kAxis[a] + " (" + std::to_string(su) +
                               " x " + std::to_string(sw) + " mm): resample the volume, or give another " + option_name("--axis"));
  const bool labels = slicing.kind == InputKind::Labels;
  if (labels && scan.first_nonlabel_row != kNoRow)
    for (std::size_t i = scan.first_nonlabel_row * std::size_t(v.nx); i < rows.count(); ++i)
      if (const float x = rows.at(i); x < 0 || x != std::floor(x) || x > float(1 << 24))
        throw InputError(path, "not a label map: value " + std::to_string(x) + " at voxel " + std::to_string(i) +
                                   " is not a non-negative integer (use " + option_given("--input", "masks") +
                                   " for any non-zero voxel as inside)");
  if (labels)  // exact values beyond 2^24 (the voxels hold indices into the table)
    for (const std::int64_t x : v.value_table)
      if (x < 0 || x > std::int64_t(std::numeric_limits<std::uint32_t>::max()))
        throw InputError(path, "not a label map: value " + std::to_string(x) + " is not a label (0 .. 2^32 - 1; use " +
                                   option_given("--input", "masks") + " for any non-zero voxel as inside)");
  const auto& occ = scan.occupied[std::size_t(a)];
  for (int t = 0; t < int(occ.size()); ++t)
    if (occ[std::size_t(t)]) out.annotated.push_back(t);
  if (out.annotated.size() < 2)
    throw InputError(path, std::to_string(out.annotated.size()) + " annotated slice(s) along axis " + kAxis[a] +
                               " (slices holding a non-zero voxel): a surface needs at least 2");
  const auto n = sizes(v);
  SliceStack& st = out.stack;
  st.kind = slicing.kind;
  st.width = n[std::size_t(u)];
  st.height = n[std::size_t(w)];
  st.max_value = slicing.kind == InputKind::Masks ? 255 : std::numeric_limits<std::uint32_t>::max();
  st.pixel_size = su;
  PatientFrame frame;
  frame.axes.col(0) = v.direction.col(u) * su;
  frame.axes.col(1) = v.direction.col(w) * su;
  frame.axes.col(2) = v.direction.col(a) * su;
  frame.origin = Vec3d(v.origin[0], v.origin[1], v.origin[2]);
  st.patient = frame;
  const bool masks = slicing.kind == InputKind::Masks;
  const std::int64_t* table = v.value_table.empty() ? nullptr : v.value_table.data();
  // By value: the lazy loader below keeps it (its samples, 8- or 16-bit, have no table).
  auto pixel = [masks, table](float val) {
    return masks ? (val != 0 ? 255u : 0u) : std::uint32_t(table ? table[std::size_t(val)] : std::int64_t(val));
  };
  st.slices.resize(out.annotated.size());
  auto image = [pixel, a, w = st.width, h = st.height](const VoxelRows& r, int t) {
    const Volume& g = r.volume();
    Grid2u32 im(w, h, 0);
    std::vector<float> buffer(std::size_t(g.nx));
    for (int y = 0; y < h; ++y) {
      std::uint32_t* dst = &im(0, y);
      if (a == 0) {  // pixel (x, y) is voxel (t, x, y)
        for (int x = 0; x < w; ++x) dst[x] = pixel(r.at(g.index(t, x, y)));
      } else {  // a row of the slice is an x run: row (y, t) along k, (t, y) along j
        const float* src = a == 2 ? r.row(y, t, buffer.data()) : r.row(t, y, buffer.data());
        for (int x = 0; x < w; ++x) dst[x] = pixel(src[x]);
      }
    }
    return im;
  };
  // Samples held plane by plane, sliced along k: the images are made when
  // read (SliceStack::load_image) from the kept planes, not held.
  const bool lazy = rows.by_plane() && a == 2;
  tbb::parallel_for(std::size_t(0), out.annotated.size(), [&](std::size_t i) {  // fresh images: faulted in on both threads
    const int t = out.annotated[i];
    Slice& s = st.slices[i];
    s.z = double(t) * sa / su;
    s.source = path + " slice " + std::string(1, kAxis[a]) + " = " + std::to_string(t);
    if (!lazy) s.image = image(rows, t);
  });
  if (lazy) {
    struct Kept {  // the geometry and the planes, owned by the loader
      Volume geometry;
      VolumeSamples samples;
    };
    auto kept = std::make_shared<Kept>(Kept{v, rows.samples()});
    kept->geometry.data.clear();
    st.load_image = [kept, image, annotated = out.annotated](std::size_t k) {
      return image(VoxelRows(kept->geometry, kept->samples), annotated[k]);
    };
  }
  if (labels) {
    label_warnings(rows, scan.row_any, out, path);
  } else {
    const LabelOccupancy occ = label_occupancy(rows, scan.row_any, true);
    const std::array<std::size_t, 3> n{std::size_t(v.nx), std::size_t(v.ny), std::size_t(v.nz)};
    if (const int drawn = occ.keys.empty() ? -1 : other_drawn_axis(occ, 0, a, n); drawn >= 0)
      out.warnings.push_back(off_axis_warning(path, "the mask", drawn, a, scan.occupied[std::size_t(drawn)]));
    std::vector<std::size_t> count;
    for (const std::size_t i : stray_slices(out, count))
      out.warnings.push_back(stray_text(path, out, i, count) + ": the object is pinched to them there");
  }
  return out;
}

}  // namespace

bool slices_samples(detail::ScalarType t) {
  using detail::ScalarType;
  return t == ScalarType::U8 || t == ScalarType::I8 || t == ScalarType::U16 || t == ScalarType::I16;
}

VolumeStack volume_stack(const Volume& v, const VolumeSlicing& slicing, const std::string& path) {
  return slice_rows(VoxelRows(v), slicing, path);
}

VolumeStack volume_stack(const Volume& geometry, const VolumeSamples& samples, const VolumeSlicing& slicing,
                         const std::string& path) {
  if (!slices_samples(samples.type)) throw ParamError("volume_stack: samples of a type it does not read as stored");
  return slice_rows(VoxelRows(geometry, samples), slicing, path);
}

LabelmapBuilder::LabelmapBuilder(const Volume& input, const VolumeStack& vs, const SliceStack& annotated)
    : axis_(vs.axis), u_(in_plane(vs.axis)[0]), v_(in_plane(vs.axis)[1]),
      z_per_index_(input.spacing[std::size_t(vs.axis)] / input.spacing[std::size_t(in_plane(vs.axis)[0])]) {
  if (annotated.slices.size() != vs.annotated.size())
    throw ParamError("LabelmapBuilder: " + std::to_string(annotated.slices.size()) + " slices for " +
                     std::to_string(vs.annotated.size()) + " annotated indices");
  out_.nx = input.nx, out_.ny = input.ny, out_.nz = input.nz;  // the geometry; `input` may hold no voxels
  out_.spacing = input.spacing, out_.origin = input.origin, out_.direction = input.direction;
  out_.integer = true;
  const bool masks = annotated.kind == InputKind::Masks;
  if (!masks) out_.value_table = input.value_table;  // masks: labels 0 and 1
  const auto n = sizes(input);
  annotated_.assign(std::size_t(n[std::size_t(axis_)]), 0);
  for (int t : vs.annotated) annotated_[std::size_t(t)] = 1;
  detail::resize_large(out_.data, std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]));
  best_.assign(out_.data.size(), 0.0f);
  // The annotated slices as they were: masks 1 where non-zero, labels their value (or table index).
  for (std::size_t s = 0; s < vs.annotated.size(); ++s) {
    const Grid2u32 lazy = annotated.load_image ? annotated.load_image(s) : Grid2u32{};
    const Grid2u32& image = annotated.load_image ? lazy : annotated.slices[s].image;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        const std::uint32_t l = image(x, y);
        if (l == 0) continue;
        out_.data[voxel(x, y, vs.annotated[s])] = masks ? 1.0f : stored_value(l);
      }
  }
}

float LabelmapBuilder::stored_value(std::uint32_t label) const {
  const auto& table = out_.value_table;
  return table.empty() ? float(label)
                       : float(std::lower_bound(table.begin() + 1, table.end(), std::int64_t(label)) - table.begin());
}

std::size_t LabelmapBuilder::voxel(int x, int y, int t) const {
  std::array<int, 3> idx{};
  idx[std::size_t(u_)] = x, idx[std::size_t(v_)] = y, idx[std::size_t(axis_)] = t;
  return out_.index(idx[0], idx[1], idx[2]);
}

std::vector<double> LabelmapBuilder::sample_z() const {
  std::vector<double> z;
  for (std::size_t t = 0; t < annotated_.size(); ++t)
    if (!annotated_[t]) z.push_back(double(t) * z_per_index_);
  return z;
}

void LabelmapBuilder::add(std::uint32_t label, const Grid2f& field, const PixelBox& box, double z) {
  const long t = std::lround(z / z_per_index_);
  if (t < 0 || t >= long(annotated_.size()) || annotated_[std::size_t(t)]) return;
  const float value = label == 0 ? 1.0f : stored_value(label);  // masks: one object, label 1
  for (int y = 0; y < field.height; ++y)
    for (int x = 0; x < field.width; ++x) {
      const float f = field(x, y);
      if (!(f > 0)) continue;
      const std::size_t i = voxel(box.x0 + x, box.y0 + y, int(t));
      if (f > best_[i]) best_[i] = f, out_.data[i] = value;
    }
}

Volume LabelmapBuilder::finish() const { return out_; }

}  // namespace isoloft
