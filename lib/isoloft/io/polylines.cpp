#include "isoloft/io/polylines.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string_view>
#include <vector>

#include "isoloft/core/error.h"
#include "isoloft/io/file_util.h"
#include "isoloft/io/text.h"
#include "isoloft/io/atomic_file.h"

namespace isoloft {
namespace {

using detail::shortest_text;

// A finite number filling the whole token.
bool to_double(std::string_view s, double& v) { return detail::parse_number(s, v) && std::isfinite(v); }

}  // namespace

SliceStack read_polylines(const std::string& path) {
  const std::vector<unsigned char> bytes = detail::read_file_bytes(path);
  auto fail = [&](std::size_t line, const std::string& problem) {
    return InputError(path + ":" + std::to_string(line), problem);
  };
  SliceStack stack;
  stack.kind = InputKind::Polylines;
  bool have_magic = false, have_size = false, have_pixel_size = false;
  Polygon* contour = nullptr;    // contour being filled
  std::size_t contour_line = 0;  // its `contour` keyword line
  auto close_contour = [&]() {
    if (!contour) return;
    // An explicitly repeated first point would make a zero-length closing edge.
    if (contour->points.size() > 1 && contour->points.back() == contour->points.front()) contour->points.pop_back();
    if (contour->points.size() < 3)
      throw fail(contour_line,
                 "contour with " + std::to_string(contour->points.size()) + " distinct points (need at least 3)");
    double area2 = 0;  // shoelace; exactly 0 only for collinear points
    const auto& v = contour->points;
    for (std::size_t i = 0; i < v.size(); ++i) {
      const Vec2d& b = v[(i + 1) % v.size()];
      area2 += v[i].x() * b.y() - b.x() * v[i].y();
    }
    if (area2 == 0) throw fail(contour_line, "contour has zero area (all its points lie on one line)");
    contour = nullptr;
  };

  detail::Lines lines(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  std::vector<std::string_view> tok;
  while (lines.next(line)) {
    const std::size_t line_no = lines.number();
    detail::split_tokens(line, tok, true);
    if (tok.empty()) continue;
    const std::string_view key = tok[0];
    if (!have_magic) {
      if (key != "isoloft-polylines")
        throw fail(line_no, "not an isoloft polyline file (expected 'isoloft-polylines 1')");
      if (tok.size() != 2 || tok[1] != "1")
        throw fail(line_no, "unsupported polyline format version (expected 'isoloft-polylines 1')");
      have_magic = true;
    } else if (key == "size") {
      long long w = 0, h = 0;
      if (tok.size() != 3 || !detail::parse_number(tok[1], w) || !detail::parse_number(tok[2], h) || w < 1 || h < 1 || w > (1 << 20) ||
          h > (1 << 20))
        throw fail(line_no, "expected 'size <width> <height>' with positive integers");
      if (have_size) throw fail(line_no, "duplicate 'size'");
      if (!stack.slices.empty()) throw fail(line_no, "'size' must come before the first slice");
      stack.width = int(w);
      stack.height = int(h);
      have_size = true;
    } else if (key == "pixel_size") {
      double s = 0;
      if (tok.size() != 2 || !to_double(tok[1], s) || s <= 0) throw fail(line_no, "expected 'pixel_size <number > 0>'");
      if (have_pixel_size) throw fail(line_no, "duplicate 'pixel_size'");
      if (!stack.slices.empty()) throw fail(line_no, "'pixel_size' must come before the first slice");
      stack.pixel_size = s;
      have_pixel_size = true;
    } else if (key == "slice") {
      close_contour();
      double z = 0;
      if (tok.size() != 2 || !to_double(tok[1], z)) throw fail(line_no, "expected 'slice <z>'");
      if (!have_size) throw fail(line_no, "missing 'size <width> <height>' before the first slice");
      if (!stack.slices.empty() && !(z > stack.slices.back().z))
        throw fail(line_no, "slice z " + shortest_text(z) + " is not greater than the previous " + shortest_text(stack.slices.back().z) +
                                " (z must strictly increase)");
      Slice s;
      s.z = z;
      s.source = path;
      stack.slices.push_back(std::move(s));
    } else if (key == "contour") {
      close_contour();
      if (tok.size() != 1) throw fail(line_no, "'contour' takes no arguments");
      if (stack.slices.empty()) throw fail(line_no, "'contour' before any 'slice'");
      stack.slices.back().polygons.emplace_back();
      contour = &stack.slices.back().polygons.back();
      contour_line = line_no;
    } else {
      double x = 0, y = 0;  // "nan" and "inf" parse too: named below, not as keywords
      const bool numeric = detail::parse_number(key, x) || key[0] == '-' || key[0] == '+' || key[0] == '.' ||
                           (key[0] >= '0' && key[0] <= '9');
      if (!numeric) throw fail(line_no, "unknown keyword '" + std::string(key) + "'");
      if (tok.size() != 2 || !detail::parse_number(tok[0], x) || !detail::parse_number(tok[1], y))
        throw fail(line_no, "expected two numbers");
      if (!std::isfinite(x) || !std::isfinite(y))
        throw fail(line_no, "point (" + std::string(tok[0]) + ", " + std::string(tok[1]) + ") is not finite");
      if (!contour) throw fail(line_no, "point outside a 'contour'");
      if (x < -0.5 || y < -0.5 || x > stack.width - 0.5 || y > stack.height - 0.5)
        throw fail(line_no, "point (" + shortest_text(x) + ", " + shortest_text(y) + ") outside the " + std::to_string(stack.width) + "x" +
                                std::to_string(stack.height) + " grid");
      contour->points.emplace_back(x, y);
    }
  }
  close_contour();
  if (!have_magic) throw InputError(path, "empty file (expected 'isoloft-polylines 1')");
  if (!have_size) throw InputError(path, "missing 'size <width> <height>'");
  if (stack.slices.empty()) throw InputError(path, "no slices");
  return stack;
}

void write_polylines(const std::string& path, const SliceStack& stack) {
  if (!stack.has_polygons()) throw ParamError(path + ": write_polylines needs a polyline stack (got images)");
  if (stack.width < 1 || stack.height < 1) throw ParamError(path + ": grid size must be >= 1");
  if (!(stack.pixel_size > 0 && std::isfinite(stack.pixel_size))) throw ParamError(path + ": pixel_size must be > 0");
  for (std::size_t k = 0; k < stack.slices.size(); ++k) {
    if (k > 0 && !(stack.slices[k].z > stack.slices[k - 1].z))
      throw ParamError(path + ": slice " + std::to_string(k) + " z does not increase");
    for (std::size_t c = 0; c < stack.slices[k].polygons.size(); ++c) {
      const auto& pts = stack.slices[k].polygons[c].points;
      const std::string where = path + ": slice " + std::to_string(k) + " contour " + std::to_string(c);
      if (pts.size() < 3) throw ParamError(where + " has fewer than 3 points");
      for (const Vec2d& q : pts)  // the reader would reject it
        if (!(q.x() >= -0.5 && q.y() >= -0.5 && q.x() <= stack.width - 0.5 && q.y() <= stack.height - 0.5))
          throw ParamError(where + " has a point outside the grid");
    }
  }
  std::string out;
  out += "# isoloft polyline contours; coordinates in pixels of the working grid\n";
  out += "isoloft-polylines 1\n";
  out += "size " + std::to_string(stack.width) + " " + std::to_string(stack.height) + "\n";
  out += "pixel_size " + shortest_text(stack.pixel_size) + "\n";
  for (const Slice& s : stack.slices) {
    out += "slice " + shortest_text(s.z) + "\n";
    for (const Polygon& poly : s.polygons) {
      out += "contour\n";
      for (const Vec2d& q : poly.points) out += shortest_text(q.x()) + " " + shortest_text(q.y()) + "\n";
    }
  }
  AtomicFile file(path);
  {
    std::FILE* fp = std::fopen(file.temp_path().c_str(), "wb");
    if (!fp) throw Error(path + ": cannot create file (" + std::strerror(errno) + ")");
    const bool ok = std::fwrite(out.data(), 1, out.size(), fp) == out.size();
    const bool closed = std::fclose(fp) == 0;
    if (!ok || !closed) throw Error(path + ": write error (" + std::strerror(errno) + ")");
  }
  file.commit();
}

}  // namespace isoloft
