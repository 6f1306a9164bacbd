// @file io/volume_sections.cpp
// @brief Annotated slices of a label volume as sections with label images.
#include "isoloft/io/volume_sections.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "isoloft/core/error.h"
#include "isoloft/io/text.h"

namespace isoloft {

namespace {

/// Two spacings (or grid coordinates) differing by at most this share of
/// their size are equal: headers store them as decimal strings or floats
/// (NIfTI: float32, 6e-8 relative), while a real anisotropy (0.8 vs 0.81 mm)
/// is 1e-2.
constexpr double kSameSpacingTolerance = 1e-6;

constexpr char kAxisName[3] = {'i', 'j', 'k'};

int size_on(const Volume& v, int axis) { return axis == 0 ? v.nx : axis == 1 ? v.ny : v.nz; }

bool nearly(double a, double b, double scale) { return std::abs(a - b) <= kSameSpacingTolerance * scale; }

std::string name(const std::string& path) { return std::filesystem::path(path).filename().string(); }

// Voxel (i, j, k) of slice s on axis a at pixel (x, y).
std::array<int, 3> voxel_of(int axis, int s, int x, int y) {
  std::array<int, 3> ijk{};
  ijk[std::size_t(axis)] = s;
  ijk[std::size_t((axis + 1) % 3)] = x;
  ijk[std::size_t((axis + 2) % 3)] = y;
  return ijk;
}

std::string voxel_text(const std::array<int, 3>& v) {
  return "(" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + ", " + std::to_string(v[2]) + ")";
}

}  // namespace

AnnotatedSlices parse_annotated_slices(const std::string& spec, const Volume& v) {
  auto fail = [&](const std::string& problem) { return ParamError("annotated slices '" + spec + "': " + problem); };
  std::string text;
  for (char c : spec)
    if (!detail::is_space(c)) text += c;
  AnnotatedSlices out;
  std::array<bool, 3> seen{};
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(';', start), text.size());
    const std::string part = text.substr(start, end - start);
    start = end + 1;
    if (part.empty()) continue;
    const auto colon = part.find(':');
    const std::string axis_text = part.substr(0, colon);
    const int axis = axis_text == "i" ? 0 : axis_text == "j" ? 1 : axis_text == "k" ? 2 : -1;
    if (colon == std::string::npos || axis < 0)
      throw fail("'" + part + "' is not AXIS:N,N,... with AXIS one of i, j, k");
    if (seen[std::size_t(axis)]) throw fail("axis " + axis_text + " given twice");
    seen[std::size_t(axis)] = true;
    auto& list = out.index[std::size_t(axis)];
    std::size_t p = colon + 1;
    while (p <= part.size()) {
      const std::size_t q = std::min(part.find(',', p), part.size());
      long long s = -1;
      const std::string tok = part.substr(p, q - p);
      if (!detail::parse_number(tok, s) || s < 0 || s >= size_on(v, axis))
        throw fail("slice '" + tok + "' on axis " + axis_text + " is not an index in 0.." +
                   std::to_string(size_on(v, axis) - 1));
      list.push_back(int(s));
      p = q + 1;
    }
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  if (out.count() == 0) throw fail("no slice given");
  return out;
}

AnnotatedSlices annotated_slices_from_mask(const Volume& mask, const Volume& labels, const std::string& mask_path) {
  if (mask.nx != labels.nx || mask.ny != labels.ny || mask.nz != labels.nz)
    throw InputError(mask_path, "annotation mask of " + std::to_string(mask.nx) + " x " + std::to_string(mask.ny) +
                                    " x " + std::to_string(mask.nz) + " voxels, labels of " +
                                    std::to_string(labels.nx) + " x " + std::to_string(labels.ny) + " x " +
                                    std::to_string(labels.nz) + " voxels: not the same grid");
  const double extent = std::max({labels.spacing[0] * labels.nx, labels.spacing[1] * labels.ny,
                                  labels.spacing[2] * labels.nz, 1.0});
  for (int a = 0; a < 3; ++a) {
    const bool same = nearly(mask.spacing[std::size_t(a)], labels.spacing[std::size_t(a)], labels.spacing[std::size_t(a)]) &&
                      nearly(mask.origin[std::size_t(a)], labels.origin[std::size_t(a)], extent) &&
                      (mask.direction.col(a) - labels.direction.col(a)).norm() <= kSameSpacingTolerance;
    if (!same)
      throw InputError(mask_path, std::string("annotation mask's spacing, origin or direction differ from the labels' on axis ") +
                                      kAxisName[a] + ": not the same grid");
  }
  // Marked voxels per slice, per axis: a slice is annotated when all are.
  std::array<std::vector<std::size_t>, 3> marked;
  for (int a = 0; a < 3; ++a) marked[std::size_t(a)].assign(std::size_t(size_on(labels, a)), 0);
  for (int k = 0; k < mask.nz; ++k)
    for (int j = 0; j < mask.ny; ++j)
      for (int i = 0; i < mask.nx; ++i)
        if (mask.value(mask.index(i, j, k)) != 0) ++marked[0][std::size_t(i)], ++marked[1][std::size_t(j)], ++marked[2][std::size_t(k)];
  AnnotatedSlices out;
  std::array<std::vector<bool>, 3> whole;
  for (int a = 0; a < 3; ++a) {
    const std::size_t per_slice = std::size_t(size_on(labels, (a + 1) % 3)) * std::size_t(size_on(labels, (a + 2) % 3));
    whole[std::size_t(a)].assign(marked[std::size_t(a)].size(), false);
    for (std::size_t s = 0; s < marked[std::size_t(a)].size(); ++s)
      if (marked[std::size_t(a)][s] == per_slice) {
        whole[std::size_t(a)][s] = true;
        out.index[std::size_t(a)].push_back(int(s));
      }
  }
  for (int k = 0; k < mask.nz; ++k)
    for (int j = 0; j < mask.ny; ++j)
      for (int i = 0; i < mask.nx; ++i)
        if (mask.value(mask.index(i, j, k)) != 0 && !whole[0][std::size_t(i)] && !whole[1][std::size_t(j)] &&
            !whole[2][std::size_t(k)])
          throw InputError(mask_path, "annotation mask marks voxel " + voxel_text({i, j, k}) +
                                          " but no whole slice through it (an annotated slice is marked in every voxel)");
  if (out.count() == 0) throw InputError(mask_path, "annotation mask marks no whole slice");
  return out;
}

std::vector<Section> label_volume_sections(const Volume& labels, const AnnotatedSlices& slices, const std::string& path) {
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if (std::abs(labels.direction.col(a).dot(labels.direction.col(b))) > detail::kOrthogonalityTolerance)
        throw InputError(path, std::string("voxel axes ") + kAxisName[a] + " and " + kAxisName[b] +
                                   " are not orthogonal (a sheared grid): its slices have no pixel grid");
  if (slices.count() == 0) throw InputError(path, "no annotated slice");
  std::vector<Section> out;
  for (int a = 0; a < 3; ++a) {
    const int ax = (a + 1) % 3, ay = (a + 2) % 3;
    const double sx = labels.spacing[std::size_t(ax)], sy = labels.spacing[std::size_t(ay)];
    for (int s : slices.index[std::size_t(a)]) {
      const std::string slice = std::string("slice ") + kAxisName[a] + "=" + std::to_string(s);
      if (s < 0 || s >= size_on(labels, a))
        throw InputError(path, slice + " is outside the volume (0.." + std::to_string(size_on(labels, a) - 1) + ")");
      if (!nearly(sx, sy, std::max(sx, sy)))
        throw InputError(path, slice + ": its pixels are " + detail::shortest_text(sx) + " x " +
                                   detail::shortest_text(sy) + " mm (axes " + kAxisName[ax] + ", " + kAxisName[ay] +
                                   "); a section's label image has square pixels");
      Section sec;
      const std::array<int, 3> o = voxel_of(a, s, 0, 0);
      sec.pose.origin = labels.to_patient(Vec3d(o[0], o[1], o[2]));
      sec.pose.u = labels.direction.col(ax).normalized();
      sec.pose.v = labels.direction.col(ay).normalized();
      sec.pixel_size = sx;
      sec.source = name(path) + ", " + slice;
      const int w = size_on(labels, ax), h = size_on(labels, ay);
      sec.labels = Grid2u32(w, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const std::array<int, 3> ijk = voxel_of(a, s, x, y);
          const double value = labels.value(labels.index(ijk[0], ijk[1], ijk[2]));
          if (!(value >= 0 && value <= 4294967295.0 && value == std::floor(value)))
            throw InputError(path, "voxel " + voxel_text(ijk) + " holds " + detail::shortest_text(value) +
                                       ", not a label (an integer in 0..2^32-1)");
          sec.labels.data[sec.labels.index(x, y)] = static_cast<std::uint32_t>(value);
        }
      out.push_back(std::move(sec));
    }
  }
  return out;
}

}  // namespace isoloft
