// A label stack for partition tests: a disc split by a turning line.
#pragma once

#include <cmath>
#include <string>
#include <utility>

#include "isoloft/pipeline.h"

namespace isoloft::test {

struct SplitDisc {
  int size = 64;             ///< px, square
  double radius = 22.0;      ///< px, centred
  int slices = 5;
  double spacing = 6.0;      ///< px between slices
  double turn = M_PI / 6;    ///< the line's turn per slice, rad
};

/// Label 1 on one side of a line through the centre, 2 on the other; the line
/// turns by `turn` per slice, so the halves move sideways between slices.
inline SliceStack split_disc(const SplitDisc& d = {}) {
  SliceStack st;
  st.width = st.height = d.size;
  st.kind = InputKind::Labels;
  const double c = (d.size - 1) / 2.0;
  for (int k = 0; k < d.slices; ++k) {
    Slice s;
    s.z = d.spacing * k;
    s.source = "slice" + std::to_string(k);
    s.image = Grid2u32(d.size, d.size, 0);
    const double a = k * d.turn;
    for (int y = 0; y < d.size; ++y)
      for (int x = 0; x < d.size; ++x) {
        const double dx = x - c, dy = y - c;
        if (dx * dx + dy * dy < d.radius * d.radius) s.image(x, y) = dx * std::cos(a) + dy * std::sin(a) > 0 ? 1 : 2;
      }
    st.slices.push_back(std::move(s));
  }
  return st;
}

}  // namespace isoloft::test
