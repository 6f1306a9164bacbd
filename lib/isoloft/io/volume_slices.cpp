#include "isoloft/io/volume_slices.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "isoloft/core/error.h"

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

// Which slices along axis a hold any non-zero voxel.
std::vector<std::uint8_t> occupied(const Volume& v, int a) {
  const auto n = sizes(v);
  std::vector<std::uint8_t> out(std::size_t(n[std::size_t(a)]), 0);
  for (int k = 0; k < v.nz; ++k)
    for (int j = 0; j < v.ny; ++j) {
      const float* row = v.data.data() + v.index(0, j, k);
      for (int i = 0; i < v.nx; ++i)
        if (row[i] != 0) out[std::size_t(a == 0 ? i : a == 1 ? j : k)] = 1;
    }
  return out;
}

}  // namespace

namespace detail {

int sparse_axis(const Volume& v) {
  int best = 2;
  double best_sparsity = 0;
  for (int a : {2, 1, 0}) {  // ties go to k, then j
    const auto occ = occupied(v, a);
    const auto first = std::find(occ.begin(), occ.end(), 1);
    if (first == occ.end()) continue;
    const auto last = std::find(occ.rbegin(), occ.rend(), 1).base();
    const double extent = double(last - first), annotated = double(std::count(first, last, 1));
    const double sparsity = 1.0 - annotated / extent;
    if (sparsity > best_sparsity + 1e-12) best = a, best_sparsity = sparsity;
  }
  return best;
}

}  // namespace detail

VolumeStack volume_stack(const Volume& v, const VolumeSlicing& slicing, const std::string& path) {
  if (slicing.kind != InputKind::Labels && slicing.kind != InputKind::Masks)
    throw ParamError("a volume holds labels or masks");
  if (slicing.axis < -1 || slicing.axis > 2) throw ParamError("--axis: must be i, j or k");
  VolumeStack out;
  out.axis = slicing.axis >= 0 ? slicing.axis : detail::sparse_axis(v);
  const int a = out.axis;
  const auto [u, w] = in_plane(a);
  const double su = v.spacing[std::size_t(u)], sw = v.spacing[std::size_t(w)], sa = v.spacing[std::size_t(a)];
  static const char* kAxis = "ijk";
  detail::check_finite_voxels(v, path);
  if (std::abs(su - sw) > kSquareTolerance * std::max(su, sw))
    throw InputError(path, std::string("voxels are not square across axis ") + kAxis[a] + " (" + std::to_string(su) +
                               " x " + std::to_string(sw) + " mm): resample the volume, or give another --axis");
  if (slicing.kind == InputKind::Labels)
    for (std::size_t i = 0; i < v.data.size(); ++i)
      if (v.data[i] < 0 || v.data[i] != std::floor(v.data[i]) || v.data[i] > float(1 << 24))
        throw InputError(path, "not a label map: value " + std::to_string(v.data[i]) + " at voxel " + std::to_string(i) +
                                   " is not a non-negative integer (use --input masks for any non-zero voxel as inside)");
  const auto occ = occupied(v, a);
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
    for (int y = 0; y < st.height; ++y)
      for (int x = 0; x < st.width; ++x) {
        std::array<int, 3> idx{};
        idx[std::size_t(u)] = x, idx[std::size_t(w)] = y, idx[std::size_t(a)] = t;
        const float val = v.at(idx[0], idx[1], idx[2]);
        s.image(x, y) = slicing.kind == InputKind::Masks ? (val != 0 ? 255u : 0u) : std::uint32_t(val);
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
