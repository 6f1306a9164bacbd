#include "isoloft/io/volume_slices.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "isoloft/core/error.h"
#include "isoloft/core/option_names.h"

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

using Occupancy = std::array<std::vector<std::uint8_t>, 3>;
constexpr std::size_t kNoRow = std::numeric_limits<std::size_t>::max();

// One pass over the voxels: which slices along each axis hold any non-zero
// voxel, and the first row (x run) holding a NaN or infinite voxel, or, with
// `labels`, a value that is not a non-negative integer up to 2^24.
struct VoxelScan {
  Occupancy occupied;
  std::size_t first_nonfinite_row = kNoRow;
  std::size_t first_nonlabel_row = kNoRow;
};

VoxelScan scan_voxels(const Volume& v, bool labels) {
  constexpr float kMaxFinite = std::numeric_limits<float>::max(), kMaxLabel = float(1 << 24), kExact = float(1 << 23);
  struct Plane {
    std::vector<std::uint8_t> occ_i, occ_j;
    bool any = false;
    std::size_t nonfinite = kNoRow, nonlabel = kNoRow;
  };
  std::vector<Plane> planes(std::size_t(v.nz));
  tbb::parallel_for(0, v.nz, [&](int k) {
    Plane& p = planes[std::size_t(k)];
    p.occ_i.assign(std::size_t(v.nx), 0);
    p.occ_j.assign(std::size_t(v.ny), 0);
    for (int j = 0; j < v.ny; ++j) {
      const float* row = v.data.data() + v.index(0, j, k);
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
      if (any) p.occ_j[std::size_t(j)] = 1, p.any = true;
      if (bad_finite) p.nonfinite = std::min(p.nonfinite, r);
      if (labels && bad_label) p.nonlabel = std::min(p.nonlabel, r);
    }
  });
  VoxelScan out;
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

int sparse_axis_of(const Occupancy& occupancy) {
  int best = 2;
  double best_sparsity = 0;
  for (int a : {2, 1, 0}) {  // ties go to k, then j
    const auto& occ = occupancy[std::size_t(a)];
    const auto first = std::find(occ.begin(), occ.end(), 1);
    if (first == occ.end()) continue;
    const auto last = std::find(occ.rbegin(), occ.rend(), 1).base();
    const double extent = double(last - first), annotated = double(std::count(first, last, 1));
    const double sparsity = 1.0 - annotated / extent;
    if (sparsity > best_sparsity + 1e-12) best = a, best_sparsity = sparsity;
  }
  return best;
}

}  // namespace

namespace detail {

int sparse_axis(const Volume& v) { return sparse_axis_of(scan_voxels(v, false).occupied); }

}  // namespace detail

VolumeStack volume_stack(const Volume& v, const VolumeSlicing& slicing, const std::string& path) {
  if (slicing.kind != InputKind::Labels && slicing.kind != InputKind::Masks)
    throw ParamError("a volume holds labels or masks");
  if (slicing.axis < -1 || slicing.axis > 2) throw ParamError(option_name("--axis") + ": must be i, j or k");
  VolumeStack out;
  const VoxelScan scan = scan_voxels(v, slicing.kind == InputKind::Labels);
  out.axis = slicing.axis >= 0 ? slicing.axis : sparse_axis_of(scan.occupied);
  const int a = out.axis;
  const auto [u, w] = in_plane(a);
  const double su = v.spacing[std::size_t(u)], sw = v.spacing[std::size_t(w)], sa = v.spacing[std::size_t(a)];
  static const char* kAxis = "ijk";
  if (scan.first_nonfinite_row != kNoRow) detail::check_finite_voxels(v, path);
  if (std::abs(su - sw) > kSquareTolerance * std::max(su, sw))
    throw InputError(path, std::string("voxels are not square across axis ") + kAxis[a] + " (" + std::to_string(su) +
                               " x " + std::to_string(sw) + " mm): resample the volume, or give another " + option_name("--axis"));
  if (scan.first_nonlabel_row != kNoRow)
    for (std::size_t i = scan.first_nonlabel_row * std::size_t(v.nx); i < v.data.size(); ++i)
      if (v.data[i] < 0 || v.data[i] != std::floor(v.data[i]) || v.data[i] > float(1 << 24))
        throw InputError(path, "not a label map: value " + std::to_string(v.data[i]) + " at voxel " + std::to_string(i) +
                                   " is not a non-negative integer (use " + option_given("--input", "masks") +
                                   " for any non-zero voxel as inside)");
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
  for (int t : out.annotated) {
    Slice s;
    s.z = double(t) * sa / su;
    s.source = path + " slice " + std::string(1, kAxis[a]) + " = " + std::to_string(t);
    s.image = Grid2u32(st.width, st.height, 0);
    const std::array<std::size_t, 3> stride{1, std::size_t(v.nx), std::size_t(v.nx) * std::size_t(v.ny)};
    const std::size_t step_x = stride[std::size_t(u)], step_y = stride[std::size_t(w)];
    const float* plane = v.data.data() + std::size_t(t) * stride[std::size_t(a)];
    const bool masks = slicing.kind == InputKind::Masks;
    for (int y = 0; y < st.height; ++y) {
      const float* src = plane + std::size_t(y) * step_y;
      std::uint32_t* dst = &s.image(0, y);
      for (int x = 0; x < st.width; ++x) {
        const float val = src[std::size_t(x) * step_x];
        dst[x] = masks ? (val != 0 ? 255u : 0u) : std::uint32_t(val);
      }
    }
    st.slices.push_back(std::move(s));
  }
  return out;
}

LabelmapBuilder::LabelmapBuilder(const Volume& input, const VolumeStack& vs)
    : axis_(vs.axis), u_(in_plane(vs.axis)[0]), v_(in_plane(vs.axis)[1]),
      z_per_index_(input.spacing[std::size_t(vs.axis)] / input.spacing[std::size_t(in_plane(vs.axis)[0])]) {
  out_ = input;
  out_.integer = true;
  out_.warnings.clear();
  const auto n = sizes(input);
  annotated_.assign(std::size_t(n[std::size_t(axis_)]), 0);
  for (int t : vs.annotated) annotated_[std::size_t(t)] = 1;
  const bool masks = vs.stack.kind == InputKind::Masks;
  best_.assign(out_.data.size(), 0.0f);
  for (std::size_t i = 0; i < out_.data.size(); ++i) {
    const std::size_t t = axis_ == 0 ? i % std::size_t(n[0]) : axis_ == 1 ? i / std::size_t(n[0]) % std::size_t(n[1])
                                                                       : i / (std::size_t(n[0]) * std::size_t(n[1]));
    out_.data[i] = annotated_[t] ? (masks ? float(input.data[i] != 0) : input.data[i]) : 0.0f;
  }
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
  const float value = label == 0 ? 1.0f : float(label);  // masks: one object, label 1
  for (int y = 0; y < field.height; ++y)
    for (int x = 0; x < field.width; ++x) {
      const float f = field(x, y);
      if (!(f > 0)) continue;
      std::array<int, 3> idx{};
      idx[std::size_t(u_)] = box.x0 + x, idx[std::size_t(v_)] = box.y0 + y, idx[std::size_t(axis_)] = int(t);
      const std::size_t i = out_.index(idx[0], idx[1], idx[2]);
      if (f > best_[i]) best_[i] = f, out_.data[i] = value;
    }
}

Volume LabelmapBuilder::finish() const { return out_; }

}  // namespace isoloft
