// render_mesh: headless shaded rendering of meshes to PNG (figures for paper/).
// A z-buffer rasterizer with two-sided Lambert + ambient shading and
// per-vertex colours when the PLY carries them; orthographic camera given by
// azimuth/elevation. Optional overlay: polyline contours (CSV x,y,z per
// point, blank line between contours) drawn as dark lines on top.
//
// usage: render_mesh OUT.png MESH.ply [MESH2.ply ...] [--size W H] [--azim deg] [--elev deg]
//                    [--color r,g,b] [--contours FILE.csv]
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "isoloft/io/mesh_io.h"
#include "isoloft/io/png.h"

using namespace isoloft;

int main(int argc, char** argv) {
  std::vector<std::string> meshes;
  std::string out, contours;
  int W = 800, H = 800;
  double azim = 35, elev = 25;
  Rgb base{200, 180, 160};
  bool base_given = false;
  // Several meshes without vertex colours (e.g. one per structure) get one
  // colour each from this palette unless --color is given.
  const Rgb palette[] = {{200, 180, 160}, {120, 170, 220}, {230, 140, 120}, {140, 200, 140}, {210, 190, 90}, {180, 140, 210}};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::runtime_error("missing value after " + a);
      return argv[++i];
    };
    if (a == "--size") W = std::stoi(next()), H = std::stoi(next());
    else if (a == "--azim") azim = std::stod(next());
    else if (a == "--elev") elev = std::stod(next());
    else if (a == "--contours") contours = next();
    else if (a == "--color") {
      int r, g, b;
      std::sscanf(next().c_str(), "%d,%d,%d", &r, &g, &b);
      base = {std::uint8_t(r), std::uint8_t(g), std::uint8_t(b)};
      base_given = true;
    } else if (out.empty()) out = a;
    else meshes.push_back(a);
  }
  if (out.empty() || meshes.empty()) {
    std::cerr << "usage: render_mesh OUT.png MESH.ply [...] [--size W H] [--azim deg] [--elev deg] [--color r,g,b] [--contours F.csv]\n";
    return 2;
  }
  try {
    struct Part {
      TriMesh m;
      std::vector<Rgb> c;
    };
    std::vector<Part> parts;
    Eigen::AlignedBox3d box;
    for (const auto& path : meshes) {
      Part p;
      p.m = read_mesh(path, &p.c);
      for (const auto& v : p.m.vertices) box.extend(v.cast<double>());
      parts.push_back(std::move(p));
    }
    // Camera: rotate so the view direction is -z'; y' up on screen (image rows grow downward).
    const double a = azim * M_PI / 180, e = elev * M_PI / 180;
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(-e, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    const Eigen::Vector3d centre = box.center();
    double extent = 0;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d q = R * (box.corner(Eigen::AlignedBox3d::CornerType(k)) - centre);
      extent = std::max({extent, std::abs(q.x()), std::abs(q.y())});
    }
    const double scale = 0.46 * std::min(W, H) / std::max(extent, 1e-9);
    auto project = [&](const Eigen::Vector3d& p) {
      const Eigen::Vector3d q = R * (p - centre);
      return Eigen::Vector3d(W / 2.0 + scale * q.x(), H / 2.0 - scale * q.y(), q.z());
    };
    std::vector<double> zbuf(std::size_t(W) * H, -std::numeric_limits<double>::infinity());
    Grid2u32 img(W, H, 0xFFFFFFu);
    const Eigen::Vector3d light = Eigen::Vector3d(-0.4, 0.5, 1.0).normalized();
    for (std::size_t pi = 0; pi < parts.size(); ++pi) {
      const auto& part = parts[pi];
      const Rgb part_colour = base_given || parts.size() == 1 ? base : palette[pi % std::size(palette)];
      for (const auto& t : part.m.triangles) {
        Eigen::Vector3d P[3], Wp[3];
        for (int k = 0; k < 3; ++k) Wp[k] = part.m.vertices[t[k]].cast<double>(), P[k] = project(Wp[k]);
        Eigen::Vector3d n = R * (Wp[1] - Wp[0]).cross(Wp[2] - Wp[0]);
        if (n.norm() == 0) continue;
        n.normalize();
        const double shade = 0.25 + 0.75 * std::abs(n.dot(light));
        Rgb c = part_colour;
        if (!part.c.empty()) c = part.c[t[0]];
        const std::uint32_t col = (std::uint32_t(c.r * shade) << 16) | (std::uint32_t(c.g * shade) << 8) | std::uint32_t(c.b * shade);
        const int x0 = std::max(0, int(std::floor(std::min({P[0].x(), P[1].x(), P[2].x()}))));
        const int x1 = std::min(W - 1, int(std::ceil(std::max({P[0].x(), P[1].x(), P[2].x()}))));
        const int y0 = std::max(0, int(std::floor(std::min({P[0].y(), P[1].y(), P[2].y()}))));
        const int y1 = std::min(H - 1, int(std::ceil(std::max({P[0].y(), P[1].y(), P[2].y()}))));
        const double area = (P[1].x() - P[0].x()) * (P[2].y() - P[0].y()) - (P[2].x() - P[0].x()) * (P[1].y() - P[0].y());
        if (std::abs(area) < 1e-12) continue;
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x) {
            const double px = x + 0.5, py = y + 0.5;
            double w[3];
            for (int k = 0; k < 3; ++k) {
              const auto& A = P[(k + 1) % 3];
              const auto& B = P[(k + 2) % 3];
              w[k] = ((B.x() - A.x()) * (py - A.y()) - (px - A.x()) * (B.y() - A.y())) / area;
            }
            if (w[0] < 0 || w[1] < 0 || w[2] < 0) continue;
            const double z = w[0] * P[0].z() + w[1] * P[1].z() + w[2] * P[2].z();
            double& zb = zbuf[std::size_t(y) * W + x];
            if (z > zb) zb = z, img(x, y) = col;
          }
      }
    }
    if (!contours.empty()) {
      std::ifstream in(contours);
      if (!in) throw std::runtime_error("cannot open " + contours);
      std::string line;
      bool have = false;
      Eigen::Vector3d prev;
      while (std::getline(in, line)) {
        double x, y, z;
        if (std::sscanf(line.c_str(), "%lf,%lf,%lf", &x, &y, &z) != 3) {
          have = false;
          continue;
        }
        const Eigen::Vector3d cur = project({x, y, z});
        if (have) {
          const int steps = int(std::ceil((cur - prev).head<2>().norm())) + 1;
          for (int s = 0; s <= steps; ++s) {
            const Eigen::Vector3d q = prev + (cur - prev) * (double(s) / steps);
            // Two pixels wide, so contours stay visible on large renders.
            for (int dy = 0; dy < 2; ++dy)
              for (int dx = 0; dx < 2; ++dx) {
                const int xi = int(q.x()) + dx, yi = int(q.y()) + dy;
                if (xi >= 0 && yi >= 0 && xi < W && yi < H) img(xi, yi) = 0x202020u;
              }
          }
        }
        prev = cur;
        have = true;
      }
    }
    write_png_rgb(out, img);
  } catch (const std::exception& ex) {
    std::cerr << "render_mesh: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}
