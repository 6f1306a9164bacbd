// @file field3d/field3d.cpp
// @brief The field3d stage: samples on every section plane, the coarse-to-fine
// matrix-free conjugate gradients (or the direct twin), Marching Cubes, and the
// statistics (per-plane residuals of the mesh, conflicts at plane crossings).
#include "isoloft/field3d/field3d.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "isoloft/core/error.h"
#include "isoloft/mesh/marching_cubes.h"

namespace isoloft {
namespace detail {
namespace {

using Polyline = std::vector<Vec2d>;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Sections whose normals' cross product is shorter than this are parallel
/// (no common line; 1e-6 rad is far below any drawn angle).
constexpr double kParallelSine = 1e-6;

/// The section's source for messages, or its index.
std::string section_name(const std::vector<Section>& sections, std::size_t i) {
  return sections[i].source.empty() ? "section " + std::to_string(i) : sections[i].source;
}

double cross2(const Vec2d& a, const Vec2d& b) { return a.x() * b.y() - a.y() * b.x(); }

double point_segment_distance(const Vec2d& p, const Vec2d& a, const Vec2d& b) {
  const Vec2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

/// One level of the coarse-to-fine hierarchy: nodes per axis and spacing H
/// (in finest cells).
struct Level {
  int nx = 0, ny = 0, nz = 0;
  double H = 1;
  [[nodiscard]] std::size_t size() const { return std::size_t(nx) * std::size_t(ny) * std::size_t(nz); }
  [[nodiscard]] std::size_t index(int i, int j, int k) const {
    return std::size_t(i) + std::size_t(nx) * (std::size_t(j) + std::size_t(ny) * std::size_t(k));
  }
  [[nodiscard]] bool interior(int i, int j, int k) const {
    return i > 0 && j > 0 && k > 0 && i < nx - 1 && j < ny - 1 && k < nz - 1;
  }
  [[nodiscard]] bool boundary(int i, int j, int k) const { return !interior(i, j, k); }
};

/// A data sample: position in finest-cell units from the grid origin, target
/// value (cells) and weight.
struct Sample {
  Vec3d g;
  double value = 0;
  double weight = 0;
};

/// The normal equations' operator A = (smoothness / H) L^T L + B^T W B + boundary
/// on one level, matrix-free (B and its transpose as gather lists).
class Operator {
 public:
  Operator(const Level& lv, const std::vector<Sample>& samples, const Field3dParams& p)
      : lv_(lv), lam_(p.smoothness / lv.H), wb_(p.boundary_weight * lv.H * lv.H), outside_(-p.band) {
    const std::size_t S = samples.size(), N = lv.size();
    node_.resize(8 * S);
    bw_.resize(8 * S);
    sw_.resize(S);
    for (std::size_t s = 0; s < S; ++s) {
      const Vec3d q = samples[s].g / lv.H;
      const int i = std::clamp(int(std::floor(q.x())), 0, lv.nx - 2);
      const int j = std::clamp(int(std::floor(q.y())), 0, lv.ny - 2);
      const int k = std::clamp(int(std::floor(q.z())), 0, lv.nz - 2);
      const double fx = std::clamp(q.x() - i, 0.0, 1.0), fy = std::clamp(q.y() - j, 0.0, 1.0),
                   fz = std::clamp(q.z() - k, 0.0, 1.0);
      for (int c = 0; c < 8; ++c) {
        const int dx = c & 1, dy = c >> 1 & 1, dz = c >> 2 & 1;
        node_[8 * s + c] = std::uint32_t(lv.index(i + dx, j + dy, k + dz));
        bw_[8 * s + c] = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz);
      }
      sw_[s] = samples[s].weight;
    }
    // Transpose by counting sort: per node, the entries (8 s + c) touching it.
    off_.assign(N + 1, 0);
    for (std::uint32_t n : node_) ++off_[n + 1];
    for (std::size_t n = 0; n < N; ++n) off_[n + 1] += off_[n];
    entry_.resize(node_.size());
    std::vector<std::uint32_t> fill(off_.begin(), off_.end() - 1);
    for (std::size_t e = 0; e < node_.size(); ++e) entry_[fill[node_[e]]++] = std::uint32_t(e);

    b_ = Eigen::VectorXd::Zero(Eigen::Index(N));
    diag_ = Eigen::VectorXd::Zero(Eigen::Index(N));
    for_nodes([&](int i, int j, int k, std::size_t n) {
      double d = 0, rhs = 0;
      for (std::uint32_t a = off_[n]; a < off_[n + 1]; ++a) {
        const std::uint32_t e = entry_[a];
        d += sw_[e / 8] * bw_[e] * bw_[e];
        rhs += sw_[e / 8] * bw_[e] * samples[e / 8].value;
      }
      int inner = 0;  // interior nodes among the six neighbours
      for (const auto& o : kNeighbours) inner += lv_.interior(i + o[0], j + o[1], k + o[2]);
      d += lam_ * ((lv_.interior(i, j, k) ? 36 : 0) + inner);
      if (lv_.boundary(i, j, k)) {
        d += wb_;
        rhs += wb_ * outside_;
      }
      diag_[Eigen::Index(n)] = d;
      b_[Eigen::Index(n)] = rhs;
    });
  }

  [[nodiscard]] const Eigen::VectorXd& rhs() const { return b_; }
  [[nodiscard]] const Eigen::VectorXd& diagonal() const { return diag_; }

  /// y = A x.
  void apply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    lap_.resize(x.size());
    r_.resize(Eigen::Index(sw_.size()));
    const std::size_t sx = 1, sy = std::size_t(lv_.nx), sz = sy * std::size_t(lv_.ny);
    for_nodes([&](int i, int j, int k, std::size_t n) {
      lap_[Eigen::Index(n)] = lv_.interior(i, j, k)
                                  ? x[n - sx] + x[n + sx] + x[n - sy] + x[n + sy] + x[n - sz] + x[n + sz] - 6 * x[n]
                                  : 0.0;
    });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sw_.size(), 4096), [&](const auto& rg) {
      for (std::size_t s = rg.begin(); s < rg.end(); ++s) {
        double v = 0;
        for (int c = 0; c < 8; ++c) v += bw_[8 * s + c] * x[node_[8 * s + c]];
        r_[Eigen::Index(s)] = sw_[s] * v;
      }
    });
    y.resize(x.size());
    for_nodes([&](int i, int j, int k, std::size_t n) {
      double l = -6 * lap_[n];
      if (i > 0) l += lap_[n - sx];
      if (i < lv_.nx - 1) l += lap_[n + sx];
      if (j > 0) l += lap_[n - sy];
      if (j < lv_.ny - 1) l += lap_[n + sy];
      if (k > 0) l += lap_[n - sz];
      if (k < lv_.nz - 1) l += lap_[n + sz];
      double v = lam_ * l;
      for (std::uint32_t a = off_[n]; a < off_[n + 1]; ++a) v += bw_[entry_[a]] * r_[entry_[a] / 8];
      if (lv_.boundary(i, j, k)) v += wb_ * x[n];
      y[Eigen::Index(n)] = v;
    });
  }

  /// The same operator assembled (the direct twin).
  [[nodiscard]] Eigen::SparseMatrix<double> assemble() const {
    const auto N = Eigen::Index(lv_.size());
    std::vector<Eigen::Triplet<double>> lt, bt, dt;
    for (int k = 0; k < lv_.nz; ++k)
      for (int j = 0; j < lv_.ny; ++j)
        for (int i = 0; i < lv_.nx; ++i) {
          const auto n = Eigen::Index(lv_.index(i, j, k));
          if (lv_.boundary(i, j, k)) dt.emplace_back(n, n, wb_);
          if (!lv_.interior(i, j, k)) continue;
          lt.emplace_back(n, n, -6.0);
          for (const auto& o : kNeighbours) lt.emplace_back(n, Eigen::Index(lv_.index(i + o[0], j + o[1], k + o[2])), 1.0);
        }
    for (std::size_t s = 0; s < sw_.size(); ++s)
      for (int c = 0; c < 8; ++c) bt.emplace_back(Eigen::Index(s), node_[8 * s + c], std::sqrt(sw_[s]) * bw_[8 * s + c]);
    Eigen::SparseMatrix<double> L(N, N), B(Eigen::Index(sw_.size()), N), D(N, N);
    L.setFromTriplets(lt.begin(), lt.end());
    B.setFromTriplets(bt.begin(), bt.end());
    D.setFromTriplets(dt.begin(), dt.end());
    Eigen::SparseMatrix<double> A = lam_ * Eigen::SparseMatrix<double>(L.transpose() * L);
    A += Eigen::SparseMatrix<double>(B.transpose() * B);
    A += D;
    return A;
  }

 private:
  static constexpr std::array<std::array<int, 3>, 6> kNeighbours{
      {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}};

  template <class F>
  void for_nodes(const F& f) const {
    tbb::parallel_for(tbb::blocked_range<int>(0, lv_.nz), [&](const auto& rg) {
      for (int k = rg.begin(); k < rg.end(); ++k)
        for (int j = 0; j < lv_.ny; ++j)
          for (int i = 0; i < lv_.nx; ++i) f(i, j, k, lv_.index(i, j, k));
    });
  }

  Level lv_;
  double lam_, wb_, outside_;
  std::vector<std::uint32_t> node_;  // 8 per sample
  std::vector<double> bw_;           // trilinear weights, 8 per sample
  std::vector<double> sw_;           // sample weights
  std::vector<std::uint32_t> off_, entry_;
  Eigen::VectorXd b_, diag_;
  mutable Eigen::VectorXd lap_, r_;
};

/// Jacobi-preconditioned conjugate gradients from x; returns iterations, sets
/// the final relative residual.
int conjugate_gradients(const Operator& A, Eigen::VectorXd& x, double tol, int max_it, double& rel) {
  const Eigen::VectorXd& b = A.rhs();
  const double bnorm = std::max(b.norm(), std::numeric_limits<double>::min());
  const Eigen::VectorXd inv = A.diagonal().cwiseInverse();
  Eigen::VectorXd r(x.size()), Ap(x.size());
  A.apply(x, Ap);
  r = b - Ap;
  rel = r.norm() / bnorm;
  if (rel <= tol) return 0;
  Eigen::VectorXd z = inv.cwiseProduct(r), p = z;
  double rz = r.dot(z);
  int it = 0;
  while (it < max_it) {
    A.apply(p, Ap);
    const double alpha = rz / p.dot(Ap);
    x += alpha * p;
    r -= alpha * Ap;
    ++it;
    rel = r.norm() / bnorm;
    if (rel <= tol) break;
    z = inv.cwiseProduct(r);
    const double rz_new = r.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  return it;
}

/// Coarse level's field trilinearly at the finer level's nodes (nested grids).
Eigen::VectorXd prolong(const Level& coarse, const Eigen::VectorXd& xc, const Level& fine) {
  Eigen::VectorXd xf(Eigen::Index(fine.size()));
  tbb::parallel_for(tbb::blocked_range<int>(0, fine.nz), [&](const auto& rg) {
    for (int k = rg.begin(); k < rg.end(); ++k)
      for (int j = 0; j < fine.ny; ++j)
        for (int i = 0; i < fine.nx; ++i) {
          const int i0 = i / 2, j0 = j / 2, k0 = k / 2;
          const int i1 = std::min(i0 + (i & 1), coarse.nx - 1), j1 = std::min(j0 + (j & 1), coarse.ny - 1),
                    k1 = std::min(k0 + (k & 1), coarse.nz - 1);
          double v = 0;
          for (int c = 0; c < 8; ++c)
            v += xc[Eigen::Index(coarse.index(c & 1 ? i1 : i0, c >> 1 & 1 ? j1 : j0, c >> 2 & 1 ? k1 : k0))];
          xf[Eigen::Index(fine.index(i, j, k))] = v / 8;
        }
  });
  return xf;
}

/// In-plane signed distance (mm, positive inside by even-odd over `polys`,
/// clamped to +-band) on the raster s0 + i sp, t0 + j sp.
Grid2d signed_distance_raster(const std::vector<Polyline>& polys, double s0, double t0, double sp, int ns, int nt,
                              double band) {
  Grid2d d(ns, nt, band);
  for (const auto& poly : polys) {
    const std::size_t m = poly.size();
    for (std::size_t e = 0; e < m; ++e) {
      const Vec2d& a = poly[e];
      const Vec2d& b = poly[(e + 1) % m];
      const int i0 = std::max(0, int(std::floor((std::min(a.x(), b.x()) - band - s0) / sp)));
      const int i1 = std::min(ns - 1, int(std::ceil((std::max(a.x(), b.x()) + band - s0) / sp)));
      const int j0 = std::max(0, int(std::floor((std::min(a.y(), b.y()) - band - t0) / sp)));
      const int j1 = std::min(nt - 1, int(std::ceil((std::max(a.y(), b.y()) + band - t0) / sp)));
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i)
          d(i, j) = std::min(d(i, j), point_segment_distance({s0 + i * sp, t0 + j * sp}, a, b));
    }
  }
  std::vector<double> xs;
  for (int j = 0; j < nt; ++j) {
    const double t = t0 + j * sp;
    xs.clear();
    for (const auto& poly : polys) {
      const std::size_t m = poly.size();
      for (std::size_t e = 0; e < m; ++e) {
        const Vec2d& a = poly[e];
        const Vec2d& b = poly[(e + 1) % m];
        if ((a.y() <= t) == (b.y() <= t)) continue;  // half-open: each crossing counted once
        xs.push_back(a.x() + (t - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
      }
    }
    std::sort(xs.begin(), xs.end());
    std::size_t c = 0;
    for (int i = 0; i < ns; ++i) {
      const double s = s0 + i * sp;
      while (c < xs.size() && xs[c] < s) ++c;
      if (c % 2 == 0) d(i, j) = -d(i, j);
    }
  }
  return d;
}

/// Crossings (parameters along the line q0 + t e, in-plane) with the polylines.
std::vector<double> line_crossings(const std::vector<Polyline>& polys, const Vec2d& q0, const Vec2d& e) {
  std::vector<double> ts;
  for (const auto& poly : polys) {
    const std::size_t m = poly.size();
    for (std::size_t k = 0; k < m; ++k) {
      const Vec2d& a = poly[k];
      const Vec2d ab = poly[(k + 1) % m] - a;
      const double den = cross2(e, ab);
      if (den == 0) continue;
      const Vec2d aq = a - q0;
      const double mu = cross2(aq, e) / den;  // position on the segment, half-open
      if (mu >= 0 && mu < 1) ts.push_back(cross2(aq, ab) / den);
    }
  }
  std::sort(ts.begin(), ts.end());
  return ts;
}

}  // namespace

Field3dPlaneResidual plane_section_distance(const TriMesh& mesh, const PlanePose& pose,
                                            const std::vector<std::vector<Vec2d>>& drawn) {
  std::vector<std::array<Vec2d, 2>> cut;
  for (const auto& t : mesh.triangles) {
    std::array<Vec3d, 3> v;
    std::array<double, 3> h;
    for (int c = 0; c < 3; ++c) {
      v[c] = mesh.vertices[std::size_t(t[c])].cast<double>();
      h[c] = pose.height(v[c]);
    }
    std::array<Vec2d, 2> seg;
    int n = 0;
    for (int c = 0; c < 3 && n < 2; ++c) {
      const int d = (c + 1) % 3;
      if ((h[c] > 0) == (h[d] > 0)) continue;
      seg[n++] = pose.to_plane(v[c] + (v[d] - v[c]) * (h[c] / (h[c] - h[d])));
    }
    if (n == 2) cut.push_back(seg);
  }
  std::vector<std::array<Vec2d, 2>> segs;
  double mean_len = 0;
  for (const auto& poly : drawn)
    for (std::size_t k = 0; k < poly.size(); ++k) segs.push_back({poly[k], poly[(k + 1) % poly.size()]});
  for (const auto& c : cut) mean_len += (c[1] - c[0]).norm();
  Field3dPlaneResidual r;
  if (cut.empty() && segs.empty()) return r;
  if (cut.empty() || segs.empty()) {
    r.mesh_to_drawn = r.drawn_to_mesh = kInf;
    return r;
  }
  mean_len = std::max(mean_len / double(cut.size()), 1e-12);
  const auto farthest = [](const std::vector<Vec2d>& pts, const std::vector<std::array<Vec2d, 2>>& to) {
    std::vector<double> best(pts.size(), kInf);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pts.size(), 256), [&](const auto& rg) {
      for (std::size_t p = rg.begin(); p < rg.end(); ++p)
        for (const auto& s : to) best[p] = std::min(best[p], point_segment_distance(pts[p], s[0], s[1]));
    });
    return best.empty() ? 0.0 : *std::max_element(best.begin(), best.end());
  };
  std::vector<Vec2d> from_mesh, from_drawn;
  for (const auto& c : cut) {
    from_mesh.push_back(c[0]);
    from_mesh.push_back((c[0] + c[1]) / 2);
  }
  for (const auto& s : segs) {  // drawn points no farther apart than the mesh's section pieces
    const int pieces = std::max(1, int(std::ceil((s[1] - s[0]).norm() / mean_len)));
    for (int q = 0; q < pieces; ++q) from_drawn.push_back(s[0] + (s[1] - s[0]) * (double(q) / pieces));
  }
  r.mesh_to_drawn = farthest(from_mesh, segs);
  r.drawn_to_mesh = farthest(from_drawn, cut);
  return r;
}

}  // namespace detail

Field3dResult reconstruct_sections(const std::vector<Section>& sections, std::uint32_t label,
                                   const Field3dParams& params) {
  using namespace detail;
  const auto start = std::chrono::steady_clock::now();
  params_table<Field3dParams>().validate(params);
  Field3dResult res;

  // The label's polylines per section, checked.
  std::vector<std::vector<Polyline>> polys(sections.size());
  Vec3d lo = Vec3d::Constant(kInf), hi = Vec3d::Constant(-kInf);
  for (std::size_t i = 0; i < sections.size(); ++i) {
    const Section& sec = sections[i];
    const std::string name = section_name(sections, i);
    if (!sec.pose.orthonormal(1e-6) || !sec.pose.origin.allFinite())
      throw InputError(name, "the plane's axes are not orthonormal or its origin is not finite");
    if (sec.is_image()) throw InputError(name, "label-image sections are not supported by field3d (contours only)");
    for (std::size_t c = 0; c < sec.contours.size(); ++c) {
      const SectionContour& con = sec.contours[c];
      if (con.label != label) continue;
      if (con.points.size() < 3)
        throw InputError(name, "contour " + std::to_string(c) + " has fewer than 3 points");
      for (const Vec2d& p : con.points) {
        if (!p.allFinite()) throw InputError(name, "contour " + std::to_string(c) + " has a non-finite point");
        const Vec3d w = sec.pose.to_world(p);
        lo = lo.cwiseMin(w);
        hi = hi.cwiseMax(w);
      }
      polys[i].push_back(con.points);
    }
  }
  if (!(lo.array() <= hi.array()).all())
    throw InputError("", "no section holds a contour of label " + std::to_string(label));
  if (params.box) {  // a given box: the contours' box replaced (it must hold them; the caller's)
    lo = (*params.box)[0];
    hi = (*params.box)[1];
  }
  const double diag = (hi - lo).norm();
  if (!(diag > 0)) throw InputError("", "the contours of label " + std::to_string(label) + " span no extent");

  // The finest grid: cells a multiple of 2^(levels-1) per axis, centred on the box.
  const Vec3d ext = (hi - lo).array() + 2 * params.margin * diag;
  const double h = ext.maxCoeff() / params.resolution;
  const int unit = 1 << (params.levels - 1);
  std::array<int, 3> cells{};
  for (int a = 0; a < 3; ++a) cells[a] = std::max(2, int(std::ceil(ext[a] / h / unit))) * unit;
  const Vec3d centre = (lo + hi) / 2;
  res.spacing = h;
  res.origin = centre - h / 2 * Vec3d(cells[0], cells[1], cells[2]);
  res.nx = cells[0] + 1;
  res.ny = cells[1] + 1;
  res.nz = cells[2] + 1;
  const Vec3d box_hi = res.origin + h * Vec3d(cells[0], cells[1], cells[2]);
  if (params.direct && std::size_t(res.nx) * res.ny * res.nz > kMaxDirectNodes)
    throw ParamError("field3d.direct: the grid has " + std::to_string(std::size_t(res.nx) * res.ny * res.nz) +
                     " nodes, more than the direct twin's " + std::to_string(kMaxDirectNodes));

  // Samples: every plane's raster inside the box, and along every contour.
  const double sp = params.sample_spacing * h, band = params.band * h;
  std::vector<std::vector<Sample>> per(sections.size());
  tbb::parallel_for(std::size_t(0), sections.size(), [&](std::size_t i) {
    const PlanePose& pose = sections[i].pose;
    Vec2d pmin = Vec2d::Constant(kInf), pmax = Vec2d::Constant(-kInf);
    for (int c = 0; c < 8; ++c) {
      const Vec3d corner(c & 1 ? box_hi.x() : res.origin.x(), c & 2 ? box_hi.y() : res.origin.y(),
                         c & 4 ? box_hi.z() : res.origin.z());
      const Vec2d q = pose.to_plane(corner);
      pmin = pmin.cwiseMin(q);
      pmax = pmax.cwiseMax(q);
    }
    const int ns = int(std::floor((pmax.x() - pmin.x()) / sp)) + 1, nt = int(std::floor((pmax.y() - pmin.y()) / sp)) + 1;
    const Grid2d d = signed_distance_raster(polys[i], pmin.x(), pmin.y(), sp, ns, nt, band);
    const double eps = 1e-9 * h;
    const double wplane = params.plane_weight * (sp / h) * (sp / h);
    auto& out = per[i];
    for (int j = 0; j < nt; ++j)
      for (int k = 0; k < ns; ++k) {
        const Vec3d w = pose.to_world({pmin.x() + k * sp, pmin.y() + j * sp});
        if ((w.array() < res.origin.array() - eps).any() || (w.array() > box_hi.array() + eps).any()) continue;
        out.push_back({(w - res.origin) / h, d(k, j) / h, wplane});
      }
    if (params.contour_weight > 0)
      for (const auto& poly : polys[i])
        for (std::size_t e = 0; e < poly.size(); ++e) {
          const Vec2d& a = poly[e];
          const Vec2d& b = poly[(e + 1) % poly.size()];
          const double len = (b - a).norm();
          const int pieces = std::max(1, int(std::ceil(len / sp)));
          for (int q = 0; q < pieces; ++q) {
            const Vec3d w = pose.to_world(a + (b - a) * ((q + 0.5) / pieces));
            out.push_back({(w - res.origin) / h, 0.0, params.contour_weight * len / pieces / h});
          }
        }
  });
  std::vector<Sample> samples;
  for (auto& v : per) samples.insert(samples.end(), v.begin(), v.end());
  per.clear();
  res.samples = samples.size();

  // Solve: coarse to fine by conjugate gradients, or directly on the finest grid.
  std::vector<Level> levels;
  for (int l = params.levels - 1; l >= 0; --l) {
    const int f = 1 << l;
    if (params.direct && l > 0) continue;
    levels.push_back({cells[0] / f + 1, cells[1] / f + 1, cells[2] / f + 1, double(f)});
  }
  Eigen::VectorXd x;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const Operator A(levels[l], samples, params);
    if (params.direct) {
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A.assemble());
      if (ldlt.info() != Eigen::Success) throw Error("field3d: the direct factorisation failed");
      x = ldlt.solve(A.rhs());
      Eigen::VectorXd Ax;
      A.apply(x, Ax);
      res.residual = (Ax - A.rhs()).norm() / A.rhs().norm();
      continue;
    }
    if (l == 0)
      x = Eigen::VectorXd::Constant(Eigen::Index(levels[l].size()), -params.band);
    else
      x = prolong(levels[l - 1], x, levels[l]);
    const int it = conjugate_gradients(A, x, params.tolerance, params.max_iterations, res.residual);
    res.iterations += it;
    res.finest_iterations = it;
  }
  res.field.assign(x.data(), x.data() + x.size());

  // Mesh: the field padded with a layer of outside samples, so the surface closes.
  {
    const int W = res.nx + 2, Hh = res.ny + 2;
    MarchingCubes mc(W, Hh, -1, -1);
    for (int k = -1; k <= res.nz; ++k) {
      Grid2f plane(W, Hh, float(-params.band));
      if (k >= 0 && k < res.nz)
        for (int j = 0; j < res.ny; ++j)
          for (int i = 0; i < res.nx; ++i)
            plane(i + 1, j + 1) = float(x[Eigen::Index(i + std::size_t(res.nx) * (j + std::size_t(res.ny) * k))]);
      mc.add_plane(std::move(plane), k);
    }
    res.mesh = mc.finish();
    for (Vec3f& v : res.mesh.vertices) v = (res.origin + h * v.cast<double>()).cast<float>();
  }
  res.check = check_mesh(res.mesh);

  // Per-plane residuals of the mesh against the drawn contours.
  res.planes.resize(sections.size());
  for (std::size_t i = 0; i < sections.size(); ++i) {
    res.planes[i] = plane_section_distance(res.mesh, sections[i].pose, polys[i]);
    res.planes[i].section = i;
  }

  // Conflicts at plane crossings: inside intervals along each common line.
  for (std::size_t a = 0; a < sections.size(); ++a)
    for (std::size_t b = a + 1; b < sections.size(); ++b) {
      const PlanePose &pa = sections[a].pose, &pb = sections[b].pose;
      const Vec3d na = pa.normal(), nb = pb.normal(), u = na.cross(nb);
      if (u.norm() < kParallelSine) continue;
      const Vec3d p0 = (na.dot(pa.origin) * nb.cross(u) + nb.dot(pb.origin) * u.cross(na)) / u.squaredNorm();
      const Vec3d dir = u.normalized();
      double t0 = -kInf, t1 = kInf;  // the line inside the box (slabs)
      for (int ax = 0; ax < 3; ++ax) {
        if (std::abs(dir[ax]) < 1e-15) {
          if (p0[ax] < res.origin[ax] || p0[ax] > box_hi[ax]) t0 = kInf;
          continue;
        }
        double s0 = (res.origin[ax] - p0[ax]) / dir[ax], s1 = (box_hi[ax] - p0[ax]) / dir[ax];
        if (s0 > s1) std::swap(s0, s1);
        t0 = std::max(t0, s0);
        t1 = std::min(t1, s1);
      }
      if (!(t0 < t1)) continue;
      const auto crossings = [&](const PlanePose& pose, std::size_t i) {
        const Vec2d q0 = pose.to_plane(p0), e(dir.dot(pose.u), dir.dot(pose.v));
        return line_crossings(polys[i], q0, e);
      };
      const std::vector<double> ca = crossings(pa, a), cb = crossings(pb, b);
      // Walk the merged crossings; where the parities differ, one says inside, the other outside.
      std::vector<std::pair<double, int>> ev;
      for (double t : ca) ev.emplace_back(t, 0);
      for (double t : cb) ev.emplace_back(t, 1);
      std::sort(ev.begin(), ev.end());
      std::array<int, 2> par{0, 0};
      double open = 0;
      bool in_conflict = false;
      for (const auto& [t, who] : ev) {
        par[who] ^= 1;
        const bool differ = par[0] != par[1];
        if (differ && !in_conflict) {
          open = t;
          in_conflict = true;
        } else if (!differ && in_conflict) {
          in_conflict = false;
          const double lo_t = std::max(open, t0), hi_t = std::min(t, t1);
          if (hi_t - lo_t > params.conflict_tolerance * h) {
            Field3dConflict c{a, b, hi_t - lo_t, p0 + dir * ((lo_t + hi_t) / 2)};
            std::ostringstream msg;
            msg << section_name(sections, a) << " and " << section_name(sections, b) << " disagree on their common line over " << c.size
                << " mm near (" << c.where.x() << ", " << c.where.y() << ", " << c.where.z()
                << "); least squares passes between them";
            res.warnings.push_back(msg.str());
            res.conflicts.push_back(c);
          }
        }
      }
    }

  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return res;
}

}  // namespace isoloft
