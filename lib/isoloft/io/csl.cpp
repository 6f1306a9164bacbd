// @file io/csl.cpp
// @brief The CSL reader: a line-by-line parse into raw planes, then the checks
// that need the whole file (the extent for the off-plane tolerance), then the
// sections.
#include "isoloft/io/csl.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numeric>
#include <optional>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/plane_fit.h"
#include "isoloft/io/text.h"

namespace isoloft {
namespace detail {

namespace {

double orient(const Vec2d& a, const Vec2d& b, const Vec2d& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

int sign(double v) { return (v > 0) - (v < 0); }

// c lies in the bounding box of segment ab (used once a, b, c are collinear).
bool in_box(const Vec2d& a, const Vec2d& b, const Vec2d& c) {
  return std::min(a.x(), b.x()) <= c.x() && c.x() <= std::max(a.x(), b.x()) && std::min(a.y(), b.y()) <= c.y() &&
         c.y() <= std::max(a.y(), b.y());
}

// Closed segments pq and rs share a point (crossing, touching or overlapping).
bool segments_meet(const Vec2d& p, const Vec2d& q, const Vec2d& r, const Vec2d& s) {
  const int d1 = sign(orient(r, s, p)), d2 = sign(orient(r, s, q));
  const int d3 = sign(orient(p, q, r)), d4 = sign(orient(p, q, s));
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;
  return (d1 == 0 && in_box(r, s, p)) || (d2 == 0 && in_box(r, s, q)) || (d3 == 0 && in_box(p, q, r)) ||
         (d4 == 0 && in_box(p, q, s));
}

}  // namespace

std::optional<std::pair<std::size_t, std::size_t>> first_self_contact(const std::vector<Vec2d>& p) {
  const std::size_t m = p.size();
  if (m < 3) return std::nullopt;
  auto a = [&](std::size_t e) -> const Vec2d& { return p[e]; };
  auto b = [&](std::size_t e) -> const Vec2d& { return p[(e + 1) % m]; };
  // Edges by their leftmost x; a pair can meet only if their x ranges overlap.
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), std::size_t{0});
  auto lo = [&](std::size_t e) { return std::min(a(e).x(), b(e).x()); };
  auto hi = [&](std::size_t e) { return std::max(a(e).x(), b(e).x()); };
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return lo(x) < lo(y); });
  std::optional<std::pair<std::size_t, std::size_t>> found;
  for (std::size_t oi = 0; oi < m; ++oi) {
    const std::size_t i = order[oi];
    for (std::size_t oj = oi + 1; oj < m && lo(order[oj]) <= hi(i); ++oj) {
      const std::size_t j = order[oj];
      if (std::max(a(i).y(), b(i).y()) < std::min(a(j).y(), b(j).y()) ||
          std::max(a(j).y(), b(j).y()) < std::min(a(i).y(), b(i).y()))
        continue;
      bool meet;
      if ((i + 1) % m == j || (j + 1) % m == i) {
        // Neighbours share a vertex s: they meet elsewhere only by folding back
        // along one line (the far ends on the same side of s).
        const std::size_t first = (i + 1) % m == j ? i : j;
        const Vec2d& s = b(first);
        const Vec2d& x = a(first);
        const Vec2d& y = b((first + 1) % m);
        meet = x != s && y != s && orient(x, s, y) == 0 && (x - s).dot(y - s) > 0;
      } else {
        meet = segments_meet(a(i), b(i), a(j), b(j));
      }
      if (!meet) continue;
      const std::pair<std::size_t, std::size_t> pair{std::min(i, j), std::max(i, j)};
      if (!found || pair < *found) found = pair;
    }
  }
  return found;
}

}  // namespace detail

namespace {

struct RawComponent {
  std::size_t line = 0;
  long long parent = -1;  // hole's parent component, -1 for none
  long long label = 0;
  std::vector<std::size_t> indices;
};

struct RawPlane {
  std::size_t line = 0;
  Vec3d abc = Vec3d::Zero();
  double d = 0;
  std::vector<Vec3d> vertices;
  std::vector<RawComponent> components;
};

bool to_double(std::string_view s, double& v) { return detail::parse_number(s, v) && std::isfinite(v); }
bool to_count(std::string_view s, long long& v) { return detail::parse_number(s, v) && v >= 0; }

std::string num(double v) { return detail::shortest_text(v); }

}  // namespace

CslFile parse_csl(std::string_view text, const std::string& name, const CslParams& params) {
  const auto* begin = reinterpret_cast<const unsigned char*>(text.data());
  detail::Lines lines(begin, begin + text.size());
  std::vector<std::string_view> tok;
  std::size_t line_no = 0;
  // The next non-blank line's tokens; false at the end of the text.
  auto next = [&]() {
    std::string_view line;
    while (lines.next(line)) {
      detail::split_tokens(line, tok, false);
      line_no = lines.number();
      if (!tok.empty()) return true;
    }
    return false;
  };
  auto fail = [&](const std::string& problem) { return InputError(name, problem); };
  auto where = [&](long long plane, std::size_t line) {
    return "plane " + std::to_string(plane) + " (line " + std::to_string(line) + "): ";
  };

  if (!next() || tok.size() != 1 || tok[0] != "CSLC") throw fail("not a CSL file (the first line must be CSLC)");
  long long n_planes = 0, n_labels = 0;
  if (!next()) throw fail("file ends after CSLC (expected the plane and label counts)");
  if (tok.size() != 2 || !to_count(tok[0], n_planes) || !to_count(tok[1], n_labels))
    throw fail("line " + std::to_string(line_no) + ": expected the plane count and the label count");
  if (n_planes == 0) throw fail("line " + std::to_string(line_no) + ": the file declares no planes");
  if (n_labels < 2 || n_labels > 0xFFFFFFFFLL)
    throw fail("line " + std::to_string(line_no) + ": label count " + std::to_string(n_labels) +
               " (must be at least 2, outside and one object, and fit 32 bits)");

  std::vector<RawPlane> planes;
  // Counts are read before they are trusted: no reservation from them.
  for (long long pi = 1; pi <= n_planes; ++pi) {
    RawPlane plane;
    if (!next())
      throw fail("file ends before plane " + std::to_string(pi) + " (declared " + std::to_string(n_planes) +
                 " planes)");
    plane.line = line_no;
    long long index = 0, nv = 0, nc = 0;
    double v[4];
    if (tok.size() != 7 || !to_count(tok[0], index) || !to_count(tok[1], nv) || !to_count(tok[2], nc) ||
        !to_double(tok[3], v[0]) || !to_double(tok[4], v[1]) || !to_double(tok[5], v[2]) || !to_double(tok[6], v[3]))
      throw fail(where(pi, line_no) +
                 "expected a plane header: index, vertex count, component count and finite A B C D");
    if (index != pi)
      throw fail(where(pi, line_no) + "plane index " + std::to_string(index) + " out of order (expected " +
                 std::to_string(pi) + ")");
    plane.abc = {v[0], v[1], v[2]};
    plane.d = v[3];
    if (plane.abc.stableNorm() == 0 || !std::isfinite(plane.abc.stableNorm()))
      throw fail(where(pi, line_no) + "zero normal (A = B = C = 0)");
    for (long long k = 0; k < nv; ++k) {
      if (!next())
        throw fail(where(pi, plane.line) + "file ends after " + std::to_string(k) + " of " + std::to_string(nv) +
                   " vertices");
      Vec3d x;
      if (tok.size() != 3 || !to_double(tok[0], x[0]) || !to_double(tok[1], x[1]) || !to_double(tok[2], x[2]))
        throw fail(where(pi, line_no) + "vertex " + std::to_string(k) + " of " + std::to_string(nv) +
                   ": expected three finite coordinates");
      plane.vertices.push_back(x);
    }
    if (nv > 0 && nc == 0)
      throw fail(where(pi, plane.line) + std::to_string(nv) + " vertices but no component uses them");
    for (long long c = 0; c < nc; ++c) {
      if (!next())
        throw fail(where(pi, plane.line) + "file ends after " + std::to_string(c) + " of " + std::to_string(nc) +
                   " components");
      RawComponent comp;
      comp.line = line_no;
      const std::string cname = "component " + std::to_string(c);
      const std::string_view head = tok[0];
      const std::size_t h = head.find('h');
      long long count = 0;
      if (!to_count(head.substr(0, h), count) ||
          (h != std::string_view::npos && !to_count(head.substr(h + 1), comp.parent)) || tok.size() < 2 ||
          !detail::parse_number(tok[1], comp.label))
        throw fail(where(pi, line_no) + cname + ": expected a vertex count (with hK for a hole in component K), "
                                            "a label and the vertex indices");
      if (static_cast<long long>(tok.size()) - 2 != count) {
        double x = 0;
        const bool vertex_like = tok.size() == 3 && std::all_of(tok.begin(), tok.end(), [&](std::string_view t) {
                                   return to_double(t, x);
                                 });
        throw fail(where(pi, line_no) + cname + " declares " + std::to_string(count) + " vertices but lists " +
                   std::to_string(tok.size() - 2) +
                   (vertex_like ? " (a vertex line: the plane's vertex count is short?)" : ""));
      }
      if (count < 3) throw fail(where(pi, line_no) + cname + " has " + std::to_string(count) + " vertices (need 3)");
      for (std::size_t t = 2; t < tok.size(); ++t) {
        long long j = 0;
        if (!to_count(tok[t], j) || j >= nv)
          throw fail(where(pi, line_no) + cname + ": vertex index '" + std::string(tok[t]) + "' is not in 0.." +
                     std::to_string(nv - 1));
        comp.indices.push_back(static_cast<std::size_t>(j));
      }
      plane.components.push_back(std::move(comp));
    }
    planes.push_back(std::move(plane));
  }
  if (next())
    throw fail("line " + std::to_string(line_no) + ": text after the last declared plane (" +
               std::to_string(n_planes) + ")");

  // Labels and holes, per plane.
  for (std::size_t pi = 0; pi < planes.size(); ++pi) {
    const auto& comps = planes[pi].components;
    for (std::size_t c = 0; c < comps.size(); ++c) {
      const RawComponent& comp = comps[c];
      const std::string at = where(static_cast<long long>(pi + 1), comp.line) + "component " + std::to_string(c);
      if (comp.parent < 0) {
        if (comp.label <= 0 || comp.label >= n_labels)
          throw fail(at + ": unknown label " + std::to_string(comp.label) + " (objects are 1.." +
                     std::to_string(n_labels - 1) + "; 0 is outside)");
        continue;
      }
      if (comp.parent >= static_cast<long long>(comps.size()))
        throw fail(at + ": hole in component " + std::to_string(comp.parent) + ", which the plane does not have");
      const RawComponent& parent = comps[static_cast<std::size_t>(comp.parent)];
      if (parent.parent >= 0)
        throw fail(at + ": hole in component " + std::to_string(comp.parent) + ", itself a hole");
      if (comp.label != parent.label && comp.label != n_labels)
        throw fail(at + ": hole labelled " + std::to_string(comp.label) + " in component " +
                   std::to_string(comp.parent) + " of label " + std::to_string(parent.label) +
                   " (a hole carries its parent's label, or " + std::to_string(n_labels) + " as OReX writes)");
    }
  }

  // Vertices on their planes, within the tolerance of the file's extent.
  Vec3d lo = Vec3d::Constant(INFINITY), hi = Vec3d::Constant(-INFINITY);
  for (const RawPlane& plane : planes)
    for (const Vec3d& x : plane.vertices) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
  const double extent = lo.x() <= hi.x() ? (hi - lo).norm() : 0.0;
  const double tolerance = kCslOffPlaneTolerance * extent;
  const std::string source = std::filesystem::path(name).filename().string();

  CslFile out;
  out.label_count = static_cast<std::uint32_t>(n_labels);
  for (std::size_t pi = 0; pi < planes.size(); ++pi) {
    const RawPlane& plane = planes[pi];
    const long long id = static_cast<long long>(pi + 1);
    const double scale = plane.abc.stableNorm();
    Section section;
    section.pose = plane_pose(plane.abc / scale, -plane.d / scale);
    if (!section.pose.origin.allFinite() || !section.pose.orthonormal(1e-12))
      throw fail(where(id, plane.line) + "the plane's A B C D give no usable pose (D / |(A, B, C)| overflows)");
    section.source = source + ", plane " + std::to_string(id);
    for (std::size_t k = 0; k < plane.vertices.size(); ++k) {
      const double off = section.pose.height(plane.vertices[k]);
      if (!(std::abs(off) <= tolerance))
        throw fail(where(id, plane.line) + "vertex " + std::to_string(k) + " lies " + num(std::abs(off)) +
                   " off the plane (tolerance " + num(tolerance) + " = " + num(kCslOffPlaneTolerance) +
                   " of the file's extent " + num(extent) + ")");
    }
    for (std::size_t c = 0; c < plane.components.size(); ++c) {
      const RawComponent& comp = plane.components[c];
      SectionContour contour;
      contour.hole = comp.parent >= 0;
      contour.label =
          static_cast<std::uint32_t>(contour.hole ? plane.components[static_cast<std::size_t>(comp.parent)].label
                                                  : comp.label);
      contour.points.reserve(comp.indices.size());
      for (std::size_t j : comp.indices) contour.points.push_back(section.pose.to_plane(plane.vertices[j]));
      if (params.refuse_self_intersections) {
        if (const auto hit = detail::first_self_contact(contour.points)) {
          const std::size_t m = comp.indices.size();
          auto edge = [&](std::size_t e) {
            return std::to_string(comp.indices[e]) + "-" + std::to_string(comp.indices[(e + 1) % m]);
          };
          throw fail(where(id, comp.line) + "component " + std::to_string(c) + " crosses or touches itself (edge " +
                     edge(hit->first) + " meets edge " + edge(hit->second) + ")");
        }
      }
      section.contours.push_back(std::move(contour));
    }
    out.sections.push_back(std::move(section));
  }
  return out;
}

CslFile read_csl(const std::string& path, const CslParams& params) {
  const detail::FileBytes bytes(path);
  return parse_csl(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), path, params);
}

}  // namespace isoloft
