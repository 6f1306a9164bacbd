#include "isoloft/field/fast_sweeping.h"

#include <string>

#include "isoloft/core/error.h"

namespace isoloft {
namespace detail {

int fast_sweep(ExtendState& s, ExtendUpdate update, int max_cycles) {
  const int w = s.width, h = s.height;
  // ClosestPoint: pixel (x, y) in a sweep along (sx, sy) looks at the 4
  // neighbours already visited in this sweep: (x - sx, y) and the three of
  // row y - sy. The 4 orderings together cover all 8 neighbours.
  auto relax_cp = [&](int x, int y, int sx, int sy) {
    const std::size_t i = std::size_t(y) * w + x;
    if (s.fixed[i]) return false;
    const int nxs[4] = {x - sx, x - 1, x, x + 1};
    const int nys[4] = {y, y - sy, y - sy, y - sy};
    double best = s.value[i];
    std::int32_t from = -1;
    for (int k = 0; k < 4; ++k) {
      const int nx = nxs[k], ny = nys[k];
      if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
      const std::int32_t sg = s.seg[std::size_t(ny) * w + nx];
      if (sg < 0 || sg == s.seg[i] || sg == from) continue;  // no segment yet, or already tried
      const double c2 = segment_distance2(s, x, y, sg);
      if (c2 < best) {
        best = c2;
        from = sg;
      }
    }
    if (from < 0) return false;
    s.seg[i] = descend_along_curve(s, x, y, from, best);
    s.value[i] = best;
    return true;
  };
  auto relax_eikonal = [&](int x, int y) {
    const std::size_t i = std::size_t(y) * w + x;
    if (s.fixed[i]) return false;
    const double u = eikonal_update(s, x, y);
    if (!(u < s.value[i])) return false;
    s.value[i] = u;
    return true;
  };
  int cycles = 0;
  while (cycles < max_cycles) {
    ++cycles;
    bool changed = false;
    for (int order = 0; order < 4; ++order) {
      const int sx = (order == 1 || order == 2) ? -1 : 1, sy = order >= 2 ? -1 : 1;
      for (int yy = 0; yy < h; ++yy) {
        const int y = sy > 0 ? yy : h - 1 - yy;
        for (int xx = 0; xx < w; ++xx) {
          const int x = sx > 0 ? xx : w - 1 - xx;
          changed |= update == ExtendUpdate::ClosestPoint ? relax_cp(x, y, sx, sy) : relax_eikonal(x, y);
        }
      }
    }
    if (!changed) break;
  }
  return cycles;
}

}  // namespace detail

Grid2f extend_fast_sweeping(const NarrowBandResult& band, ExtendUpdate update, int max_cycles) {
  if (max_cycles < 1)
    throw ParamError("fast sweeping: max_cycles " + std::to_string(max_cycles) + " must be >= 1");
  detail::ExtendState s = detail::init_extend_state(band, update);
  detail::fast_sweep(s, update, max_cycles);
  return detail::finish_extend(band, s, update);
}

}  // namespace isoloft
