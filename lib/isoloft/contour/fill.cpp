// Even-odd fill of contour images; see fill.h.
#include "isoloft/contour/fill.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "isoloft/core/error.h"

namespace isoloft {
namespace {

constexpr int kDx4[4] = {1, -1, 0, 0};
constexpr int kDy4[4] = {0, 0, 1, -1};
// 8-neighbours in circular order N, NE, E, SE, S, SW, W, NW (for run counting).
constexpr int kDx8[8] = {0, 1, 1, 1, 0, -1, -1, -1};
constexpr int kDy8[8] = {-1, -1, 0, 1, 1, 1, 0, -1};

/// Components, regions and their adjacency for one contour image.
struct Topology {
  Grid2i comp;    ///< contour component per pixel or -1
  Grid2i region;  ///< background region per pixel or -1
  int n_comp = 0;
  int n_region = 0;
  std::vector<char> comp_on_border, region_on_border;
  // CSR adjacency component -> regions and region -> components.
  std::vector<int> comp_start, comp_adj, region_start, region_adj;
};

void build_csr(int n, const std::vector<std::pair<int, int>>& edges, bool first_is_key,
               std::vector<int>& start, std::vector<int>& adj) {
  start.assign(std::size_t(n) + 1, 0);
  for (const auto& e : edges) ++start[std::size_t(first_is_key ? e.first : e.second) + 1];
  for (int i = 0; i < n; ++i) start[std::size_t(i) + 1] += start[std::size_t(i)];
  adj.resize(edges.size());
  std::vector<int> pos(start.begin(), start.end() - 1);
  for (const auto& e : edges) {
    const int key = first_is_key ? e.first : e.second;
    adj[std::size_t(pos[std::size_t(key)]++)] = first_is_key ? e.second : e.first;
  }
}

Topology analyse(const Grid2u8& contour) {
  Topology t;
  t.n_comp = detail::label_components(contour, true, true, t.comp);
  t.n_region = detail::label_components(contour, false, false, t.region);
  t.comp_on_border.assign(std::size_t(t.n_comp), 0);
  t.region_on_border.assign(std::size_t(t.n_region), 0);
  const int w = contour.width, h = contour.height;
  std::vector<std::pair<int, int>> edges;  // (component, region)
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool border = x == 0 || y == 0 || x == w - 1 || y == h - 1;
      const int c = t.comp(x, y);
      if (c < 0) {
        if (border) t.region_on_border[std::size_t(t.region(x, y))] = 1;
        continue;
      }
      if (border) t.comp_on_border[std::size_t(c)] = 1;
      // 4-adjacency suffices: a background pixel diagonal to a contour pixel
      // shares a 4-neighbour with it that is contour (same component) or
      // background (same region) and 4-adjacent to both.
      for (int k = 0; k < 4; ++k) {
        const int nx = x + kDx4[k], ny = y + kDy4[k];
        if (!contour.contains(nx, ny)) continue;
        const int r = t.region(nx, ny);
        if (r >= 0) edges.emplace_back(c, r);
      }
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  build_csr(t.n_comp, edges, true, t.comp_start, t.comp_adj);
  build_csr(t.n_region, edges, false, t.region_start, t.region_adj);
  return t;
}

std::string pixel(int x, int y) { return "(" + std::to_string(x) + ", " + std::to_string(y) + ")"; }

/// Finds open components, repairs what the policy allows. Returns true if
/// `contour` was changed.
bool find_open(const Topology& t, Grid2u8& contour, const FillParams& params,
               std::vector<OpenContour>& open) {
  // Pixels per component, bucketed in one pass.
  std::vector<std::vector<int>> endpoints(std::size_t(t.n_comp));
  std::vector<char> candidate(std::size_t(t.n_comp), 0);
  for (int c = 0; c < t.n_comp; ++c)
    candidate[std::size_t(c)] = t.comp_start[std::size_t(c) + 1] - t.comp_start[std::size_t(c)] <= 1;
  const int w = contour.width;
  for (int y = 0; y < contour.height; ++y)
    for (int x = 0; x < w; ++x) {
      const int c = t.comp(x, y);
      if (c >= 0 && candidate[std::size_t(c)] && detail::is_endpoint(contour, x, y))
        endpoints[std::size_t(c)].push_back(y * w + x);
    }
  bool changed = false;
  for (int c = 0; c < t.n_comp; ++c) {
    const auto& e = endpoints[std::size_t(c)];
    if (!candidate[std::size_t(c)] || e.empty()) continue;
    OpenContour oc;
    oc.component = c;
    oc.x0 = oc.x1 = e[0] % w;
    oc.y0 = oc.y1 = e[0] / w;
    oc.gap = std::numeric_limits<double>::infinity();
    oc.ends = int(e.size());
    for (std::size_t i = 0; i < e.size(); ++i)
      for (std::size_t j = i + 1; j < e.size(); ++j) {
        const int ax = e[i] % w, ay = e[i] / w, bx = e[j] % w, by = e[j] / w;
        const double d = std::hypot(double(ax - bx), double(ay - by));
        if (d < oc.gap) {
          oc.gap = d;
          oc.x0 = ax, oc.y0 = ay, oc.x1 = bx, oc.y1 = by;
        }
      }
    if (params.open_policy != OpenContourPolicy::Ignore && oc.gap <= double(params.max_gap)) {
      detail::draw_segment(contour, oc.x0, oc.y0, oc.x1, oc.y1);
      oc.repaired = true;
      changed = true;
    }
    open.push_back(oc);
  }
  return changed;
}

}  // namespace

namespace detail {

int label_components(const Grid2u8& image, bool foreground, bool eight_connected, Grid2i& labels) {
  const int w = image.width, h = image.height;
  labels = Grid2i(w, h, -1);
  std::vector<int> stack;
  int n = 0;
  const int reach = eight_connected ? 8 : 4;
  for (int y0 = 0; y0 < h; ++y0)
    for (int x0 = 0; x0 < w; ++x0) {
      if ((image(x0, y0) != 0) != foreground || labels(x0, y0) >= 0) continue;
      labels(x0, y0) = n;
      stack.assign(1, y0 * w + x0);
      while (!stack.empty()) {
        const int p = stack.back();
        stack.pop_back();
        const int px = p % w, py = p / w;
        for (int k = 0; k < reach; ++k) {
          const int nx = px + (eight_connected ? kDx8[k] : kDx4[k]);
          const int ny = py + (eight_connected ? kDy8[k] : kDy4[k]);
          if (!image.contains(nx, ny) || (image(nx, ny) != 0) != foreground || labels(nx, ny) >= 0)
            continue;
          labels(nx, ny) = n;
          stack.push_back(ny * w + nx);
        }
      }
      ++n;
    }
  return n;
}

bool is_endpoint(const Grid2u8& contour, int x, int y) {
  if (!contour.contains(x, y) || !contour(x, y)) return false;
  bool present[8];
  int count = 0;
  for (int k = 0; k < 8; ++k) {
    const int nx = x + kDx8[k], ny = y + kDy8[k];
    present[k] = contour.contains(nx, ny) && contour(nx, ny) != 0;
    count += present[k];
  }
  int runs = 0;
  for (int k = 0; k < 8; ++k) runs += present[k] && !present[(k + 7) % 8];
  return runs == 1 && count <= 2;
}

void draw_segment(Grid2u8& image, int x0, int y0, int x1, int y1) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  for (;;) {
    if (image.contains(x0, y0)) image(x0, y0) = 1;
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) err += dy, x0 += sx;
    if (e2 <= dx) err += dx, y0 += sy;
  }
}

}  // namespace detail

FillResult fill_even_odd(const Grid2u8& contour, const FillParams& params) {
  params_table<FillParams>().validate(params);
  FillResult res;
  res.contour = Grid2u8(contour.width, contour.height);
  for (std::size_t i = 0; i < contour.size(); ++i) res.contour.data[i] = contour.data[i] ? 1 : 0;

  Topology t = analyse(res.contour);
  if (find_open(t, res.contour, params, res.open_contours)) t = analyse(res.contour);

  if (params.open_policy == OpenContourPolicy::Error) {
    const auto bad = std::find_if(res.open_contours.begin(), res.open_contours.end(),
                                  [](const OpenContour& o) { return !o.repaired; });
    if (bad != res.open_contours.end()) {
      std::string problem;
      if (bad->ends == 1) {
        problem = "open contour with a single end, at pixel " + pixel(bad->x0, bad->y0);
      } else {
        char gap[32];
        std::snprintf(gap, sizeof gap, "%.2f", bad->gap);
        problem = "open contour: gap of " + std::string(gap) + " px between pixels " + pixel(bad->x0, bad->y0) +
                  " and " + pixel(bad->x1, bad->y1) + " exceeds max_gap " + std::to_string(params.max_gap);
      }
      const auto more = std::count_if(res.open_contours.begin(), res.open_contours.end(),
                                      [](const OpenContour& o) { return !o.repaired; });
      if (more > 1) problem += " (" + std::to_string(more - 1) + " more open contours)";
      throw InputError("", problem);
    }
  }

  // BFS over regions and components. Node distance: region 2*depth,
  // component 2*depth+1 (depth of its outer side). Beyond the image is
  // outside: border regions start at 0, border components at 1.
  const int nr = t.n_region, nc = t.n_comp;
  std::vector<int> dist(std::size_t(nr + nc), -1);
  std::vector<int> queue;
  queue.reserve(std::size_t(nr + nc));
  for (int r = 0; r < nr; ++r)
    if (t.region_on_border[std::size_t(r)]) dist[std::size_t(r)] = 0, queue.push_back(r);
  for (int c = 0; c < nc; ++c)
    if (t.comp_on_border[std::size_t(c)]) dist[std::size_t(nr + c)] = 1, queue.push_back(nr + c);
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int node = queue[head];
    const int d = dist[std::size_t(node)];
    const bool is_region = node < nr;
    const int id = is_region ? node : node - nr;
    const auto& start = is_region ? t.region_start : t.comp_start;
    const auto& adj = is_region ? t.region_adj : t.comp_adj;
    for (int k = start[std::size_t(id)]; k < start[std::size_t(id) + 1]; ++k) {
      const int other = is_region ? nr + adj[std::size_t(k)] : adj[std::size_t(k)];
      if (dist[std::size_t(other)] >= 0) continue;
      dist[std::size_t(other)] = d + 1;
      queue.push_back(other);
    }
  }

  std::vector<char> region_inside(std::size_t(nr), 0);
  for (int r = 0; r < nr; ++r) {
    const int depth = std::max(dist[std::size_t(r)], 0) / 2;  // unreachable cannot happen; treat as outside
    region_inside[std::size_t(r)] = depth % 2 == 1;
    res.max_depth = std::max(res.max_depth, depth);
  }
  // An open contour left open bounds nothing: its pixels leave the contour
  // and take the inside/outside of the one region around them, so no
  // surface wraps the bare curve.
  std::vector<int> open_side(std::size_t(nc), -2);  // -2: closed; else 0/1 for the region around it
  for (const OpenContour& o : res.open_contours) {
    if (o.repaired) continue;
    const int c = t.comp(o.x0, o.y0);
    if (c < 0) continue;
    const int a = t.comp_start[std::size_t(c)], b = t.comp_start[std::size_t(c) + 1];
    open_side[std::size_t(c)] = b > a ? region_inside[std::size_t(t.comp_adj[std::size_t(a)])] : 0;
  }
  res.inside = Grid2u8(contour.width, contour.height);
  for (std::size_t i = 0; i < contour.size(); ++i) {
    const int r = t.region.data[i];
    const int c = t.comp.data[i];
    if (c >= 0 && open_side[std::size_t(c)] != -2) {
      res.inside.data[i] = std::uint8_t(open_side[std::size_t(c)]);
      res.contour.data[i] = 0;
      continue;
    }
    res.inside.data[i] = (r < 0 || region_inside[std::size_t(r)]) ? 1 : 0;
  }
  res.contour_components = nc;
  return res;
}

Grid2u8 mask_boundary(const Grid2u8& mask) {
  const int w = mask.width, h = mask.height;
  Grid2u8 out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!mask(x, y)) continue;
      bool edge = x == 0 || y == 0 || x == w - 1 || y == h - 1;
      for (int k = 0; k < 4 && !edge; ++k) edge = !mask(x + kDx4[k], y + kDy4[k]);
      out(x, y) = edge ? 1 : 0;
    }
  return out;
}

namespace {
/// Opening of the set {mask == fg} by a k x k square, pixels beyond the image
/// counting as `beyond`; the result uses the same encoding as the input.
/// Separable, by run lengths: O(1) per pixel for any k.
Grid2u8 open_square(const Grid2u8& mask, int k, bool fg, bool beyond) {
  const int w = mask.width, h = mask.height, pad = k - 1;
  const int W = w + 2 * pad, H = h + 2 * pad;  // padded frame: squares reaching beyond the image count too
  const auto in = [&](int X, int Y) {
    const int x = X - pad, y = Y - pad;
    return (x < 0 || y < 0 || x >= w || y >= h) ? beyond : (mask(x, y) != 0) == fg;
  };
  const auto at = [W](int X, int Y) { return std::size_t(Y) * std::size_t(W) + std::size_t(X); };
  std::vector<std::uint8_t> row(std::size_t(W) * H), sq(row.size());
  std::vector<int> col(W);
  // Erosion: sq(X, Y) = the square with top-left corner (X, Y) lies in the set
  // (k set pixels from X to the right, then k such rows from Y down).
  for (int Y = 0; Y < H; ++Y)
    for (int X = W - 1, run = 0; X >= 0; --X) {
      run = in(X, Y) ? run + 1 : 0;
      row[at(X, Y)] = run >= k;
    }
  std::fill(col.begin(), col.end(), 0);
  for (int Y = H - 1; Y >= 0; --Y)
    for (int X = 0; X < W; ++X) {
      col[X] = row[at(X, Y)] ? col[X] + 1 : 0;
      sq[at(X, Y)] = col[X] >= k;
    }
  // Dilation: a pixel is kept if such a square covers it (one starts at most
  // k - 1 to its left, then at most k - 1 rows above).
  for (int Y = 0; Y < H; ++Y)
    for (int X = 0, last = -k; X < W; ++X) {
      if (sq[at(X, Y)]) last = X;
      row[at(X, Y)] = X - last < k;
    }
  std::fill(col.begin(), col.end(), -k);
  Grid2u8 out(w, h);
  for (int Y = 0; Y < H; ++Y)
    for (int X = 0; X < W; ++X) {
      if (row[at(X, Y)]) col[X] = Y;
      const int x = X - pad, y = Y - pad;
      if (x >= 0 && y >= 0 && x < w && y < h) out(x, y) = (Y - col[X] < k) == fg ? 1 : 0;
    }
  return out;
}
}  // namespace

Grid2u8 remove_thin_features(const Grid2u8& mask, int width) {
  if (width <= 1) return mask;
  // Opening of the mask (beyond = outside), then of its outside (beyond = outside too).
  return open_square(open_square(mask, width, true, false), width, false, true);
}

Grid2u8 binarize(const Grid2u32& values, std::uint32_t threshold) {
  Grid2u8 out(values.width, values.height);
  for (std::size_t i = 0; i < values.size(); ++i) out.data[i] = values.data[i] > threshold ? 1 : 0;
  return out;
}

}  // namespace isoloft
