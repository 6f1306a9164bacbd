// @file field3d/image_sections.cpp
// @brief Label images to traced polylines (clamped smoothed mask, marching
// squares with saddles joining the inside, segments chained into loops) and
// the grid resolution of pixel input.
#include "isoloft/field3d/image_sections.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "isoloft/core/error.h"
#include "isoloft/contour/rasterize.h"
#include "isoloft/field/narrow_band.h"
#include "isoloft/mesh/plane_cut.h"

namespace isoloft {

namespace {

/// Outside pixels added around the image: one closes every loop (the curve
/// crosses between the last image pixel and the pad); two keep the
/// smoothing's reach (sigma 0.7 px) the same as beyond-the-grid zeros.
constexpr int kPad = 2;

/// Fewest cells the pixel rule gives a grid: the coarse-to-fine solve halves
/// it twice (field3d.levels 3), and 16 cells leave 4, the resolution row's least.
constexpr int kMinPixelResolution = 16;
/// Largest field3d.resolution its row accepts (field3d/field3d.h).
constexpr int kMaxResolution = 1024;

}  // namespace

namespace {

/// The zero set of `f` (on the image padded by kPad pixels) by marching
/// squares, saddles joining the inside, chained into closed loops in the
/// image's pixel units.
std::vector<std::vector<Vec2d>> zero_loops(const Grid2f& f) {
  std::vector<std::vector<Vec2d>> loops;
  const detail::ZeroSet zs = detail::marching_squares(f, [](const Vec2d&) { return 1.0; }, 0, 1);
  std::vector<std::uint8_t> used(zs.segments.size(), 0);
  const Vec2d shift(kPad, kPad);
  for (std::size_t s0 = 0; s0 < zs.segments.size(); ++s0) {
    if (used[s0]) continue;
    std::vector<Vec2d> loop{zs.segments[s0][0] - shift};
    used[s0] = 1;
    // Walk from end 1 of s0; each next segment is entered at the end equal to the point reached.
    Vec2d at = zs.segments[s0][1];
    std::int32_t k = zs.links[s0][1];
    while (k >= 0 && !used[std::size_t(k)]) {
      loop.push_back(at - shift);
      used[std::size_t(k)] = 1;
      const auto& sg = zs.segments[std::size_t(k)];
      const int enter = sg[0] == at ? 0 : 1;
      at = sg[1 - enter];
      k = zs.links[std::size_t(k)][1 - enter];
    }
    if (loop.size() >= 3) loops.push_back(std::move(loop));
  }
  return loops;
}

/// `inside` with kPad outside pixels around it; nullopt when it is empty.
std::optional<Grid2u8> padded_mask(const Grid2u8& inside) {
  if (std::none_of(inside.data.begin(), inside.data.end(), [](std::uint8_t v) { return v != 0; })) return std::nullopt;
  Grid2u8 padded(inside.width + 2 * kPad, inside.height + 2 * kPad, 0);
  for (int y = 0; y < inside.height; ++y)
    for (int x = 0; x < inside.width; ++x) padded(x + kPad, y + kPad) = inside(x, y) != 0;
  return padded;
}

}  // namespace

std::vector<std::vector<Vec2d>> traced_loops(const Grid2u8& inside, const MaskCurveParams& params) {
  const auto padded = padded_mask(inside);
  if (!padded) return {};
  // Linear vertices (each between its inside and outside pixel centre), saddles joining the inside.
  return zero_loops(clamped_smoothed_mask(*padded, params));
}

std::vector<std::vector<Vec2d>> smoothed_loops(const Grid2u8& inside, double sigma) {
  const auto padded = padded_mask(inside);
  if (!padded) return {};
  return zero_loops(smoothed_mask(*padded, sigma));
}

std::vector<std::vector<Vec2d>> boundary_loops(const Grid2u8& inside, const MaskCurveParams& params, double sigma) {
  return sigma > 0 ? smoothed_loops(inside, sigma) : traced_loops(inside, params);
}

Section traced_section(const Section& section, std::uint32_t label, const MaskCurveParams& params,
                       const PixelBoundary& boundary) {
  if (!section.is_image()) return section;
  if (!(section.pixel_size > 0) || !std::isfinite(section.pixel_size))
    throw InputError(section.source, "the label image's pixel size is not positive and finite");
  Section out;
  out.pose = section.pose;
  out.source = section.source;
  if (boundary.keep_image) {
    out.labels = section.labels;
    out.pixel_size = section.pixel_size;
  }
  Grid2u8 inside(section.labels.width, section.labels.height, 0);
  for (std::size_t i = 0; i < inside.size(); ++i) inside.data[i] = section.labels.data[i] == label;
  for (auto& loop : boundary_loops(inside, params, boundary.sigma)) {
    for (Vec2d& p : loop) p *= section.pixel_size;
    out.contours.push_back({std::move(loop), label, false});
  }
  return out;
}

std::vector<Section> traced_sections(const std::vector<Section>& sections, std::uint32_t label,
                                     const MaskCurveParams& params, const PixelBoundary& boundary) {
  params_table<MaskCurveParams>().validate(params);
  std::vector<Section> out(sections.size());
  tbb::parallel_for(std::size_t(0), sections.size(),
                    [&](std::size_t i) { out[i] = traced_section(sections[i], label, params, boundary); });
  return out;
}

Field3dParams pixel_params(const std::vector<Section>& traced, std::uint32_t label, double pixel_size,
                           Field3dParams params) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Vec3d lo = Vec3d::Constant(kInf), hi = Vec3d::Constant(-kInf);
  for (const Section& s : traced)
    for (const SectionContour& c : s.contours)
      if (c.label == label)
        for (const Vec2d& p : c.points) {
          const Vec3d w = s.pose.to_world(p);
          lo = lo.cwiseMin(w);
          hi = hi.cwiseMax(w);
        }
  params = pixel_rows(params);
  params.resolution = pixel_resolution({lo, hi}, pixel_size, traced, params);
  return params;
}

Field3dParams pixel_rows(Field3dParams params) {
  params.band = params.pixel_band;
  params.contour_weight = params.pixel_contour_weight;
  params.plane_slope = params.pixel_slope;
  params.band_per_gap = params.pixel_band_per_gap;
  params.plane_weight_per_gap = params.pixel_plane_weight_per_gap;
  params.sign_guard = params.pixel_sign_guard;
  params.band_margin = params.pixel_band_margin;
  return params;
}

int pixel_resolution(const std::array<Vec3d, 2>& box, double pixel_size, const std::vector<Section>& sections,
                     const Field3dParams& params) {
  const auto& [lo, hi] = box;
  if (params.pixel_resolution > 0) return params.pixel_resolution;
  if (!(lo.array() <= hi.array()).all() || !(pixel_size > 0)) return params.resolution;
  // The box as reconstruct_sections() sizes it: the contours' extent plus the margin on each side.
  const double gap = params.band_margin > 0 ? detail::median_gap(sections) : 0;
  const std::array<Vec3d, 2> m = box_margins(params, sections, box, pixel_size / kImageCellsPerPixel, gap);
  const double longest = ((hi - lo) + m[0] + m[1]).maxCoeff();
  const int needed = int(std::ceil(longest * kImageCellsPerPixel / pixel_size));
  return std::clamp(needed, kMinPixelResolution, kMaxResolution);
}

Grid2u8 section_pixels(const TriMesh& mesh, const PlanePose& pose, double pixel_size, int width, int height) {
  // The mesh in the plane's frame (pixels along u and v, mm along the
  // normal), cut at height 0 with vertices on the plane counted above it.
  TriMesh local = mesh;
  const Vec3d n = pose.normal();
  for (Vec3f& v : local.vertices) {
    const Vec3d d = v.cast<double>() - pose.origin;
    v = Vec3d(d.dot(pose.u) / pixel_size, d.dot(pose.v) / pixel_size, d.dot(n)).cast<float>();
  }
  std::vector<Polygon> loops;
  for (auto& l : cut_mesh(local, 0.0)) loops.push_back({std::move(l)});
  return even_odd_inside(loops, width, height);
}

double dice(const Grid2u8& a, const Grid2u8& b) {
  long both = 0, sum = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    both += a.data[i] && b.data[i];
    sum += (a.data[i] != 0) + (b.data[i] != 0);
  }
  return sum > 0 ? 2.0 * double(both) / double(sum) : 1.0;
}

}  // namespace isoloft
