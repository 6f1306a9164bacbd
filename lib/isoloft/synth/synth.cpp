#include "isoloft/synth/synth.h"

#include <tbb/parallel_for.h>

#include <cmath>

#include "isoloft/core/error.h"
#include "isoloft/field/narrow_band.h"

namespace isoloft {

Grid2u8 rasterize_implicit_contour(const Grid2f& f) {
  Grid2u8 out(f.width, f.height, 0);
  auto mark = [&](int x0, int y0, int x1, int y1) {
    const float a = f(x0, y0), b = f(x1, y1);
    if ((a > 0) == (b > 0)) return;
    if (std::abs(a) <= std::abs(b)) out(x0, y0) = 1;
    else out(x1, y1) = 1;
  };
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      if (x + 1 < f.width) mark(x, y, x + 1, y);
      if (y + 1 < f.height) mark(x, y, x, y + 1);
    }
  return out;
}

std::vector<Polygon> implicit_slice_polygons(const std::function<double(const Vec2d&)>& f, int width, int height, double step) {
  const int W = int(std::floor((width - 1) / step)) + 1, H = int(std::floor((height - 1) / step)) + 1;
  auto fine = [&](const Vec2d& q) { return f(q * step); };
  Grid2f samples(W, H);
  tbb::parallel_for(0, H, [&](int y) {
    for (int x = 0; x < W; ++x) samples(x, y) = float(fine(Vec2d(x, y)));
  });
  const detail::ZeroSet zs = detail::marching_squares(samples, fine, 30, 1);
  // Chain the segments into loops through their end-point links.
  std::vector<Polygon> out;
  std::vector<char> used(zs.segments.size(), 0);
  for (std::size_t start = 0; start < zs.segments.size(); ++start) {
    if (used[start]) continue;
    Polygon poly;
    std::int32_t k = std::int32_t(start);
    int end = 1;  // leave segment k through its end point `end`
    while (k >= 0 && !used[std::size_t(k)]) {
      used[std::size_t(k)] = 1;
      poly.points.push_back(zs.segments[std::size_t(k)][1 - end] * step);
      const std::int32_t next = zs.links[std::size_t(k)][end];
      if (next < 0) break;
      end = zs.links[std::size_t(next)][0] == k ? 1 : 0;
      k = next;
    }
    if (poly.points.size() >= 3) out.push_back(std::move(poly));
  }
  return out;
}

SynthResult synthesize_at(const Shape& shape, const std::vector<double>& z, int width, int height, const SynthParams& params) {
  if (width < 8 || height < 8) throw ParamError("synth: images must be at least 8 pixels across");
  if (params.kind == InputKind::Labels) throw ParamError("synth: writes contours, masks or polylines");
  if (z.size() < 2) throw ParamError("synth: fewer than 2 slices meet the shape; lower --z-spacing");
  const auto [lo, hi] = shape.bounds();
  if (lo.x() < 1 || lo.y() < 1 || hi.x() > width - 2 || hi.y() > height - 2)
    throw ParamError("synth: the shape does not fit in a " + std::to_string(width) + "x" + std::to_string(height) +
                     " pixel image");
  SynthResult r;
  r.shape = shape.translated(Vec3d::Zero());
  r.stack.width = width;
  r.stack.height = height;
  r.stack.max_value = 255;
  r.stack.kind = params.kind;
  for (std::size_t k = 0; k < z.size(); ++k) {
    Slice s;
    s.z = z[k];
    s.source = "synth slice " + std::to_string(k);
    if (params.kind == InputKind::Polylines) {
      const Shape& sh = *r.shape;
      const double zk = z[k];
      s.polygons = implicit_slice_polygons([&sh, zk](const Vec2d& q) { return sh.value(Vec3d(q.x(), q.y(), zk)); }, width,
                                           height, params.polyline_step);
      r.stack.slices.push_back(std::move(s));
      continue;
    }
    Grid2f f(width, height);
    tbb::parallel_for(0, height, [&](int y) {
      for (int x = 0; x < width; ++x) f(x, y) = float(r.shape->value(Vec3d(x, y, z[k])));
    });
    s.image = Grid2u32(width, height, 0);
    if (params.kind == InputKind::Contours) {
      const Grid2u8 c = rasterize_implicit_contour(f);
      for (std::size_t i = 0; i < c.size(); ++i) s.image.data[i] = c.data[i] ? 255u : 0u;
    } else {
      for (std::size_t i = 0; i < f.size(); ++i) s.image.data[i] = f.data[i] > 0 ? 255u : 0u;
    }
    r.stack.slices.push_back(std::move(s));
  }
  r.description = {{"shape", r.shape->to_json()},
                   {"stack",
                    {{"width", width},
                     {"height", height},
                     {"slices", r.stack.slices.size()},
                     {"z", z},
                     {"z_first", z.front()},
                     {"z_last", z.back()},
                     {"input", to_string(params.kind)},
                     {"units", "pixels; pixel (i, j) of slice k is at (i, j, z[k])"}}}};
  return r;
}

SynthResult synthesize(const Shape& shape, const SynthParams& params) {
  if (params.size < 8) throw ParamError("synth: --size must be at least 8");
  if (!(params.z_spacing > 0)) throw ParamError("synth: --z-spacing must be positive");
  if (params.kind == InputKind::Labels) throw ParamError("synth: writes contours, masks or polylines");
  const auto [lo, hi] = shape.bounds();
  if (lo.x() < 1 || lo.y() < 1 || hi.x() > params.size - 2 || hi.y() > params.size - 2)
    throw ParamError("synth: the shape does not fit in a " + std::to_string(params.size) + " pixel image");
  const double z0 = lo.z() + params.first_offset * params.z_spacing;
  const std::unique_ptr<Shape> moved = shape.translated(Vec3d(0, 0, -z0));
  std::vector<double> z;
  for (int k = 0; k * params.z_spacing + z0 < hi.z(); ++k) z.push_back(k * params.z_spacing);
  SynthResult r = synthesize_at(*moved, z, params.size, params.size, params);
  r.description["stack"] = {{"size", params.size},
                            {"z_spacing", params.z_spacing},
                            {"slices", r.stack.slices.size()},
                            {"z_first", r.stack.slices.front().z},
                            {"z_last", r.stack.slices.back().z},
                            {"input", to_string(params.kind)},
                            {"units", "pixels; pixel (i, j) of slice k is at (i, j, k * z_spacing)"}};
  return r;
}

}  // namespace isoloft
