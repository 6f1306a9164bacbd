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
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>
#include <tuple>
#include <utility>

#include "isoloft/core/error.h"
#include "isoloft/field3d/image_sections.h"
#include "isoloft/interp/spline.h"
#include "isoloft/mesh/marching_cubes.h"

namespace isoloft {
namespace detail {
namespace {

using Polyline = std::vector<Vec2d>;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Smallest |grad f| (cells per cell) used to turn f into a distance; a flatter
/// field counts as a miss at any |f| above tolerance x this.
constexpr double kFlatGradient = 0.05;

/// Sections whose normals' cross product is shorter than this are parallel
/// (no common line; 1e-6 rad is far below any drawn angle).
constexpr double kParallelSine = 1e-6;

bool parallel_planes(const PlanePose& a, const PlanePose& b) {
  return a.normal().cross(b.normal()).norm() < kParallelSine;
}

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
/// per axis (in finest cells; above 1 along a parallel stack's normal, see
/// SectionGrid::step).
struct Level {
  int nx = 0, ny = 0, nz = 0;
  Vec3d H = Vec3d::Ones();
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
  bool contour = false;  ///< on a drawn contour (value 0)
};

/// The transpose of a gather list by counting sort: per node n, the entries
/// e (8 s + c) with node[e] == n are entry[off[n] .. off[n + 1]).
void transpose_gather(const std::vector<std::uint32_t>& node, std::size_t N, std::vector<std::uint32_t>& off,
                      std::vector<std::uint32_t>& entry) {
  off.assign(N + 1, 0);
  for (std::uint32_t n : node) ++off[n + 1];
  for (std::size_t n = 0; n < N; ++n) off[n + 1] += off[n];
  entry.resize(node.size());
  std::vector<std::uint32_t> fill(off.begin(), off.end() - 1);
  for (std::size_t e = 0; e < node.size(); ++e) entry[fill[node[e]]++] = std::uint32_t(e);
}

constexpr std::array<std::array<int, 3>, 6> kNeighbours{{{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}};

/// f(i, j, k, n) at every node of the level, z slabs side by side.
template <class F>
void for_nodes(const Level& lv, const F& f) {
  tbb::parallel_for(tbb::blocked_range<int>(0, lv.nz), [&](const auto& rg) {
    for (int k = rg.begin(); k < rg.end(); ++k)
      for (int j = 0; j < lv.ny; ++j)
        for (int i = 0; i < lv.nx; ++i) f(i, j, k, lv.index(i, j, k));
  });
}

/// The smoothness and boundary terms' coefficients on one level: the energy
/// smoothness * sum_interior (Lap f)^2 V + boundary_weight * sum_faces (f + b)^2 a (b: face_pull()),
/// with Lap the 7-point Laplacian at spacings H (finest cells), V = Hx Hy Hz
/// a node's volume and a the area a face node stands for (the product of the
/// two spacings in the face). Written lam (L f)^2 with L's axis weights
/// c_a = (min H / H_a)^2 (1 on an isotropic level) and lam = smoothness V / (min H)^4.
struct Energy {
  double lam = 0;
  std::array<double, 3> c{1, 1, 1};
  double centre = 6;              ///< L's diagonal, -2 (cx + cy + cz), negated
  std::array<double, 3> face{};   ///< boundary weight on a face normal to x, y, z

  Energy(const Level& lv, const Field3dParams& p) {
    const double hmin = lv.H.minCoeff();
    for (int a = 0; a < 3; ++a) c[std::size_t(a)] = (hmin / lv.H[a]) * (hmin / lv.H[a]);
    centre = 2 * (c[0] + c[1] + c[2]);
    lam = p.smoothness * (lv.H.prod() / (hmin * hmin * hmin * hmin));
    face = {p.boundary_weight * lv.H.y() * lv.H.z(), p.boundary_weight * lv.H.x() * lv.H.z(),
            p.boundary_weight * lv.H.x() * lv.H.y()};
  }
  /// The boundary weight at node (i, j, k): its first face's (0 inside).
  [[nodiscard]] double boundary(const Level& lv, int i, int j, int k) const {
    if (i == 0 || i == lv.nx - 1) return face[0];
    if (j == 0 || j == lv.ny - 1) return face[1];
    if (k == 0 || k == lv.nz - 1) return face[2];
    return 0.0;
  }
};

/// The diagonal of the smoothness and boundary terms, lam L^T L + the face
/// weights, at node (i, j, k).
double energy_diagonal(const Level& lv, const Energy& e, int i, int j, int k) {
  double inner = 0;  // interior neighbours, each its squared axis weight
  for (int o = 0; o < 6; ++o) {
    const auto& d = kNeighbours[std::size_t(o)];
    if (lv.interior(i + d[0], j + d[1], k + d[2])) inner += e.c[std::size_t(o / 2)] * e.c[std::size_t(o / 2)];
  }
  return e.lam * ((lv.interior(i, j, k) ? e.centre * e.centre : 0) + inner) + e.boundary(lv, i, j, k);
}

/// y = (lam L^T L + the face weights) x + data(i, j, k, n) per node (the
/// data term's row times x); lap: scratch for L x. Rows of interior nodes run
/// without the per-node bounds tests (the sums in the same order, so the same
/// bits); nodes on the grid's faces take the general form.
template <class Data>
void apply_energy(const Level& lv, const Energy& e, const Eigen::VectorXd& x, Eigen::VectorXd& lap, Eigen::VectorXd& y,
                  const Data& data) {
  lap.resize(x.size());
  y.resize(x.size());
  const std::size_t sx = 1, sy = std::size_t(lv.nx), sz = sy * std::size_t(lv.ny);
  const double cx = e.c[0], cy = e.c[1], cz = e.c[2], cc = e.centre;
  const int nx = lv.nx, ny = lv.ny, nz = lv.nz;
  const double* X = x.data();
  double* Lp = lap.data();
  double* Y = y.data();
  const auto interior_row = [&](int j, int k) { return nx > 2 && j > 0 && k > 0 && j < ny - 1 && k < nz - 1; };
  tbb::parallel_for(tbb::blocked_range<int>(0, nz), [&](const auto& rg) {
    for (int k = rg.begin(); k < rg.end(); ++k)
      for (int j = 0; j < ny; ++j) {
        const std::size_t r = lv.index(0, j, k);
        if (!interior_row(j, k)) {
          std::fill(Lp + r, Lp + r + std::size_t(nx), 0.0);
          continue;
        }
        Lp[r] = 0.0;
        Lp[r + std::size_t(nx - 1)] = 0.0;
        for (std::size_t n = r + 1; n < r + std::size_t(nx - 1); ++n)
          Lp[n] = cx * (X[n - sx] + X[n + sx]) + cy * (X[n - sy] + X[n + sy]) + cz * (X[n - sz] + X[n + sz]) - cc * X[n];
      }
  });
  const auto general = [&](int i, int j, int k, std::size_t n) {
    double l = -cc * Lp[n];
    if (i > 0) l += cx * Lp[n - sx];
    if (i < nx - 1) l += cx * Lp[n + sx];
    if (j > 0) l += cy * Lp[n - sy];
    if (j < ny - 1) l += cy * Lp[n + sy];
    if (k > 0) l += cz * Lp[n - sz];
    if (k < nz - 1) l += cz * Lp[n + sz];
    double v = e.lam * l + data(i, j, k, n);
    if (lv.boundary(i, j, k)) v += e.boundary(lv, i, j, k) * X[n];
    Y[n] = v;
  };
  tbb::parallel_for(tbb::blocked_range<int>(0, nz), [&](const auto& rg) {
    for (int k = rg.begin(); k < rg.end(); ++k)
      for (int j = 0; j < ny; ++j) {
        const std::size_t r = lv.index(0, j, k);
        if (!interior_row(j, k)) {
          for (int i = 0; i < nx; ++i) general(i, j, k, r + std::size_t(i));
          continue;
        }
        general(0, j, k, r);
        for (int i = 1; i < nx - 1; ++i) {
          const std::size_t n = r + std::size_t(i);
          double l = -cc * Lp[n];
          l += cx * Lp[n - sx];
          l += cx * Lp[n + sx];
          l += cy * Lp[n - sy];
          l += cy * Lp[n + sy];
          l += cz * Lp[n - sz];
          l += cz * Lp[n + sz];
          Y[n] = e.lam * l + data(i, j, k, n);
        }
        general(nx - 1, j, k, r + std::size_t(nx - 1));
      }
  });
}

/// lam L^T L + the face weights, assembled.
Eigen::SparseMatrix<double> energy_matrix(const Level& lv, const Energy& e) {
  const auto N = Eigen::Index(lv.size());
  std::vector<Eigen::Triplet<double>> lt, dt;
  for (int k = 0; k < lv.nz; ++k)
    for (int j = 0; j < lv.ny; ++j)
      for (int i = 0; i < lv.nx; ++i) {
        const auto n = Eigen::Index(lv.index(i, j, k));
        if (lv.boundary(i, j, k)) dt.emplace_back(n, n, e.boundary(lv, i, j, k));
        if (!lv.interior(i, j, k)) continue;
        lt.emplace_back(n, n, -e.centre);
        for (int o = 0; o < 6; ++o) {
          const auto& d = kNeighbours[std::size_t(o)];
          lt.emplace_back(n, Eigen::Index(lv.index(i + d[0], j + d[1], k + d[2])), e.c[std::size_t(o / 2)]);
        }
      }
  Eigen::SparseMatrix<double> L(N, N), D(N, N);
  L.setFromTriplets(lt.begin(), lt.end());
  D.setFromTriplets(dt.begin(), dt.end());
  Eigen::SparseMatrix<double> A = e.lam * Eigen::SparseMatrix<double>(L.transpose() * L);
  A += D;
  return A;
}

/// Sample s's cell on a level of spacing H (lower corner, clamped into the
/// grid) and its eight trilinear weights, corner c = dx + 2 dy + 4 dz.
std::array<int, 3> sample_cell(const Level& lv, const Sample& s, std::array<double, 8>& w) {
  const Vec3d q = s.g.cwiseQuotient(lv.H);
  const int i = std::clamp(int(std::floor(q.x())), 0, lv.nx - 2);
  const int j = std::clamp(int(std::floor(q.y())), 0, lv.ny - 2);
  const int k = std::clamp(int(std::floor(q.z())), 0, lv.nz - 2);
  const double fx = std::clamp(q.x() - i, 0.0, 1.0), fy = std::clamp(q.y() - j, 0.0, 1.0),
               fz = std::clamp(q.z() - k, 0.0, 1.0);
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = c >> 1 & 1, dz = c >> 2 & 1;
    w[std::size_t(c)] = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz);
  }
  return {i, j, k};
}

/// The normal equations' operator A = lam L^T L + B^T W B + boundary (Energy)
/// on one level, matrix-free (B and its transpose as gather lists); the
/// faces pull f to -pull (the right-hand side).
class Operator {
 public:
  Operator(const Level& lv, const std::vector<Sample>& samples, const Field3dParams& p, double pull)
      : lv_(lv), e_(lv, p), outside_(-pull) {
    const std::size_t S = samples.size(), N = lv.size();
    node_.resize(8 * S);
    bw_.resize(8 * S);
    sw_.resize(S);
    std::array<double, 8> w{};
    for (std::size_t s = 0; s < S; ++s) {
      const auto [i, j, k] = sample_cell(lv, samples[s], w);
      for (int c = 0; c < 8; ++c) {
        node_[8 * s + c] = std::uint32_t(lv.index(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1)));
        bw_[8 * s + c] = w[std::size_t(c)];
      }
      sw_[s] = samples[s].weight;
    }
    transpose_gather(node_, N, off_, entry_);

    b_ = Eigen::VectorXd::Zero(Eigen::Index(N));
    diag_ = Eigen::VectorXd::Zero(Eigen::Index(N));
    for_nodes(lv_, [&](int i, int j, int k, std::size_t n) {
      double d = energy_diagonal(lv_, e_, i, j, k), rhs = e_.boundary(lv_, i, j, k) * outside_;
      for (std::uint32_t a = off_[n]; a < off_[n + 1]; ++a) {
        const std::uint32_t e = entry_[a];
        d += sw_[e / 8] * bw_[e] * bw_[e];
        rhs += sw_[e / 8] * bw_[e] * samples[e / 8].value;
      }
      diag_[Eigen::Index(n)] = d;
      b_[Eigen::Index(n)] = rhs;
    });
  }

  [[nodiscard]] const Eigen::VectorXd& rhs() const { return b_; }
  [[nodiscard]] const Eigen::VectorXd& diagonal() const { return diag_; }

  /// y = A x.
  void apply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    r_.resize(Eigen::Index(sw_.size()));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sw_.size(), 4096), [&](const auto& rg) {
      for (std::size_t s = rg.begin(); s < rg.end(); ++s) {
        double v = 0;
        for (int c = 0; c < 8; ++c) v += bw_[8 * s + c] * x[node_[8 * s + c]];
        r_[Eigen::Index(s)] = sw_[s] * v;
      }
    });
    apply_energy(lv_, e_, x, lap_, y, [&](int, int, int, std::size_t n) {
      double v = 0;
      for (std::uint32_t a = off_[n]; a < off_[n + 1]; ++a) v += bw_[entry_[a]] * r_[entry_[a] / 8];
      return v;
    });
  }

  /// The same operator assembled (the direct twin; B^T W B as a sparse product).
  [[nodiscard]] Eigen::SparseMatrix<double> assemble() const {
    const auto N = Eigen::Index(lv_.size());
    std::vector<Eigen::Triplet<double>> bt;
    for (std::size_t s = 0; s < sw_.size(); ++s)
      for (int c = 0; c < 8; ++c) bt.emplace_back(Eigen::Index(s), node_[8 * s + c], std::sqrt(sw_[s]) * bw_[8 * s + c]);
    Eigen::SparseMatrix<double> B(Eigen::Index(sw_.size()), N);
    B.setFromTriplets(bt.begin(), bt.end());
    Eigen::SparseMatrix<double> A = energy_matrix(lv_, e_);
    A += Eigen::SparseMatrix<double>(B.transpose() * B);
    return A;
  }

 private:
  Level lv_;
  Energy e_;
  double outside_;
  std::vector<std::uint32_t> node_;  // 8 per sample
  std::vector<double> bw_;           // trilinear weights, 8 per sample
  std::vector<double> sw_;           // sample weights
  std::vector<std::uint32_t> off_, entry_;
  Eigen::VectorXd b_, diag_;
  mutable Eigen::VectorXd lap_, r_;
};

/// Index of entry (a, b) of a symmetric 8x8 block stored packed (36 entries).
constexpr int packed(int a, int b) { return a <= b ? a * (15 - a) / 2 + b : b * (15 - b) / 2 + a; }
constexpr int kPackedBlock = 36;

/// A multigrid coarse level's operator: Operator's energy on that level with
/// B^T W B summed per grid cell into a symmetric 8x8 block over the cell's
/// corners, instead of every sample's 8 node indices and weights (144 bytes
/// per sample and level). A plane crosses a cell of a grid 2^l times coarser
/// in ~4^l samples, so the blocks' memory falls by ~4 per level where the
/// samples' stayed the same (docs/decisions.md: field3d memory). The blocks
/// are float: they are a preconditioner's coefficients (CG runs on the
/// finest Operator in double), and the V-cycle stays one fixed symmetric
/// linear map. No right-hand side (the V-cycle restricts the residual).
class CellOperator {
 public:
  CellOperator(const Level& lv, const std::vector<Sample>& samples, const Field3dParams& p)
      : lv_(lv), e_(lv, p) {
    slot_.assign(std::size_t(lv.nx - 1) * std::size_t(lv.ny - 1) * std::size_t(lv.nz - 1), -1);
    std::array<double, 8> w{};
    for (const Sample& s : samples) {  // the cells holding a sample, numbered in cell order
      const auto [i, j, k] = sample_cell(lv, s, w);
      slot_[cell(i, j, k)] = 0;
    }
    std::int32_t used = 0;
    for (std::int32_t& s : slot_)
      if (s == 0) s = used++;
      else s = -1;
    block_.assign(std::size_t(used) * kPackedBlock, 0.0F);
    for (const Sample& s : samples) {
      const auto [i, j, k] = sample_cell(lv, s, w);
      float* B = &block_[std::size_t(slot_[cell(i, j, k)]) * kPackedBlock];
      for (int a = 0; a < 8; ++a)
        for (int b = a; b < 8; ++b) B[packed(a, b)] += float(s.weight * w[std::size_t(a)] * w[std::size_t(b)]);
    }
    diag_.resize(Eigen::Index(lv.size()));
    for_nodes(lv_, [&](int i, int j, int k, std::size_t n) {
      double d = energy_diagonal(lv_, e_, i, j, k);
      each_cell(i, j, k, [&](const float* B, int c, std::size_t) { d += B[packed(c, c)]; });
      diag_[Eigen::Index(n)] = d;
    });
  }

  [[nodiscard]] const Eigen::VectorXd& diagonal() const { return diag_; }

  /// Adds sample s's B^T W B with weight dw (a penalty sample added, or its
  /// weight changed by dw) to its cell's block (new if the cell had none) and
  /// to the diagonal: the operator built with the new weight, up to float
  /// rounding of the block sums (their order differs).
  void add(const Sample& s, double dw) {
    std::array<double, 8> w{};
    const auto [i, j, k] = sample_cell(lv_, s, w);
    std::int32_t& slot = slot_[cell(i, j, k)];
    if (slot < 0) {
      slot = std::int32_t(block_.size() / kPackedBlock);
      block_.resize(block_.size() + kPackedBlock, 0.0F);
    }
    float* B = &block_[std::size_t(slot) * kPackedBlock];
    const std::size_t n0 = lv_.index(i, j, k);
    for (int a = 0; a < 8; ++a) {
      const float before = B[packed(a, a)];
      for (int b = a; b < 8; ++b) B[packed(a, b)] += float(dw * w[std::size_t(a)] * w[std::size_t(b)]);
      diag_[Eigen::Index(n0 + corner(a))] += double(B[packed(a, a)]) - double(before);
    }
  }

  /// y = A x.
  void apply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    apply_energy(lv_, e_, x, lap_, y, [&](int i, int j, int k, std::size_t) {
      double v = 0;
      each_cell(i, j, k, [&](const float* B, int c, std::size_t n0) {
        for (int m = 0; m < 8; ++m) v += B[packed(c, m)] * x[Eigen::Index(n0 + corner(m))];
      });
      return v;
    });
  }

  /// The same operator assembled (the coarsest level's factorisation).
  [[nodiscard]] Eigen::SparseMatrix<double> assemble() const {
    const auto N = Eigen::Index(lv_.size());
    std::vector<Eigen::Triplet<double>> bt;
    for (int k = 0; k + 1 < lv_.nz; ++k)
      for (int j = 0; j + 1 < lv_.ny; ++j)
        for (int i = 0; i + 1 < lv_.nx; ++i) {
          const std::int32_t s = slot_[cell(i, j, k)];
          if (s < 0) continue;
          const float* B = &block_[std::size_t(s) * kPackedBlock];
          const std::size_t n0 = lv_.index(i, j, k);
          for (int a = 0; a < 8; ++a)
            for (int b = 0; b < 8; ++b)
              bt.emplace_back(Eigen::Index(n0 + corner(a)), Eigen::Index(n0 + corner(b)), double(B[packed(a, b)]));
        }
    Eigen::SparseMatrix<double> G(N, N);
    G.setFromTriplets(bt.begin(), bt.end());
    Eigen::SparseMatrix<double> A = energy_matrix(lv_, e_);
    A += G;
    return A;
  }

 private:
  [[nodiscard]] std::size_t cell(int i, int j, int k) const {
    return std::size_t(i) + std::size_t(lv_.nx - 1) * (std::size_t(j) + std::size_t(lv_.ny - 1) * std::size_t(k));
  }
  /// Node offset of a cell's corner c from its corner 0.
  [[nodiscard]] std::size_t corner(int c) const { return lv_.index(c & 1, c >> 1 & 1, c >> 2 & 1); }
  /// f(block, c, n0) for each cell with samples that holds node (i, j, k), the node as its corner c (n0: its corner 0).
  template <class F>
  void each_cell(int i, int j, int k, const F& f) const {
    if (lv_.interior(i, j, k)) {  // all eight cells in the grid: no bounds tests
      const std::size_t cy = std::size_t(lv_.nx - 1), cz = cy * std::size_t(lv_.ny - 1), c0 = cell(i, j, k);
      const std::size_t ny = std::size_t(lv_.nx), nz = ny * std::size_t(lv_.ny), n0 = lv_.index(i, j, k);
      for (int c = 0; c < 8; ++c) {
        const std::size_t dc = std::size_t(c & 1) + std::size_t(c >> 1 & 1) * cy + std::size_t(c >> 2 & 1) * cz;
        const std::int32_t s = slot_[c0 - dc];
        if (s >= 0)
          f(&block_[std::size_t(s) * kPackedBlock], c,
            n0 - std::size_t(c & 1) - std::size_t(c >> 1 & 1) * ny - std::size_t(c >> 2 & 1) * nz);
      }
      return;
    }
    for (int c = 0; c < 8; ++c) {
      const int ci = i - (c & 1), cj = j - (c >> 1 & 1), ck = k - (c >> 2 & 1);
      if (ci < 0 || cj < 0 || ck < 0 || ci >= lv_.nx - 1 || cj >= lv_.ny - 1 || ck >= lv_.nz - 1) continue;
      const std::int32_t s = slot_[cell(ci, cj, ck)];
      if (s >= 0) f(&block_[std::size_t(s) * kPackedBlock], c, lv_.index(ci, cj, ck));
    }
  }

  Level lv_;
  Energy e_;
  std::vector<std::int32_t> slot_;  // per cell: its block, or -1
  std::vector<float> block_;        // kPackedBlock per cell with samples
  Eigen::VectorXd diag_;
  mutable Eigen::VectorXd lap_;
};

/// Preconditioned conjugate gradients from x (M.precondition(r, z): z = M^-1 r,
/// M symmetric positive definite and linear); returns iterations, sets the
/// final relative residual.
template <class Op, class Prec>
int preconditioned_cg(const Op& A, const Prec& M, Eigen::VectorXd& x, double tol, int max_it, double& rel) {
  const Eigen::VectorXd& b = A.rhs();
  const double bnorm = std::max(b.norm(), std::numeric_limits<double>::min());
  Eigen::VectorXd r(x.size()), Ap(x.size()), z(x.size());
  A.apply(x, Ap);
  r = b - Ap;
  rel = r.norm() / bnorm;
  if (rel <= tol) return 0;
  M.precondition(r, z);
  Eigen::VectorXd p = z;
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
    M.precondition(r, z);
    const double rz_new = r.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  return it;
}

/// Per axis, whether `coarse` halves `fine` there (1) or keeps its nodes (0):
/// nested grids, each axis coarsened by 2 or not at all.
std::array<int, 3> halved(const Level& coarse, const Level& fine) {
  std::array<int, 3> h{};
  for (int a = 0; a < 3; ++a) h[std::size_t(a)] = coarse.H[a] > 1.5 * fine.H[a] ? 1 : 0;
  return h;
}

/// The coarse nodes (i0, i1) around fine node i along an axis (halved or
/// not; i0 == i1 on a coarse node), each weighing 1/2.
inline std::array<int, 2> coarse_pair(int i, int half, int n_coarse) {
  const int i0 = i >> half;
  return {i0, std::min(i0 + (i & half), n_coarse - 1)};
}

/// Coarse level's field trilinearly at the finer level's nodes (nested grids), into xf.
void prolong_into(const Level& coarse, const Eigen::VectorXd& xc, const Level& fine, Eigen::VectorXd& xf) {
  xf.resize(Eigen::Index(fine.size()));
  const std::array<int, 3> hv = halved(coarse, fine);
  tbb::parallel_for(tbb::blocked_range<int>(0, fine.nz), [&](const auto& rg) {
    for (int k = rg.begin(); k < rg.end(); ++k)
      for (int j = 0; j < fine.ny; ++j)
        for (int i = 0; i < fine.nx; ++i) {
          const auto [i0, i1] = coarse_pair(i, hv[0], coarse.nx);
          const auto [j0, j1] = coarse_pair(j, hv[1], coarse.ny);
          const auto [k0, k1] = coarse_pair(k, hv[2], coarse.nz);
          double v = 0;
          for (int c = 0; c < 8; ++c)
            v += xc[Eigen::Index(coarse.index(c & 1 ? i1 : i0, c >> 1 & 1 ? j1 : j0, c >> 2 & 1 ? k1 : k0))];
          xf[Eigen::Index(fine.index(i, j, k))] = v / 8;
        }
  });
}

/// prolong_into() as a new vector.
Eigen::VectorXd prolong(const Level& coarse, const Eigen::VectorXd& xc, const Level& fine) {
  Eigen::VectorXd xf;
  prolong_into(coarse, xc, fine, xf);
  return xf;
}

/// The transpose of prolong(): the fine residual summed onto the coarse nodes
/// with the interpolation's weights (restriction R = P^T, so that the coarse
/// correction keeps the V-cycle symmetric), into rc.
void restrict_to(const Level& coarse, const Eigen::VectorXd& rf, const Level& fine, Eigen::VectorXd& rc) {
  rc.setZero(Eigen::Index(coarse.size()));
  const std::array<int, 3> hv = halved(coarse, fine);
  for (int k = 0; k < fine.nz; ++k)
    for (int j = 0; j < fine.ny; ++j)
      for (int i = 0; i < fine.nx; ++i) {
        const auto [i0, i1] = coarse_pair(i, hv[0], coarse.nx);
        const auto [j0, j1] = coarse_pair(j, hv[1], coarse.ny);
        const auto [k0, k1] = coarse_pair(k, hv[2], coarse.nz);
        const double v = rf[Eigen::Index(fine.index(i, j, k))] / 8;
        for (int c = 0; c < 8; ++c)
          rc[Eigen::Index(coarse.index(c & 1 ? i1 : i0, c >> 1 & 1 ? j1 : j0, c >> 2 & 1 ? k1 : k0))] += v;
      }
}

/// Multigrid levels below a grid: coarsened while above this many nodes; the
/// coarsest is factorised (LDLT of a 10^3 bi-Laplacian: ~1 ms; 20^3 took ~0.5 s
/// per hierarchy, which made small grids 5-10x slower than Jacobi-PCG).
constexpr std::size_t kCoarsestNodes = 1000;
/// Most levels of one hierarchy (a 1024-cell axis reaches 4 cells in 8 halvings).
constexpr int kMaxMultigridLevels = 9;
/// A multigrid level halves only the axes whose spacing is at most this
/// times its smallest (semi-coarsening): along an anisotropic grid's wide
/// axis the point smoother leaves the modes smooth across it and rough along
/// it, and only a coarse grid that keeps that axis can correct them.
constexpr double kSemiCoarsening = 1.5;

/// The multigrid level below `f`: its axes within kSemiCoarsening of the
/// smallest spacing halved (nested nodes; an axis of 2 nodes kept).
Level coarser(const Level& f) {
  const double hmin = f.H.minCoeff();
  Level c = f;
  const std::array<int*, 3> n{&c.nx, &c.ny, &c.nz};
  for (int a = 0; a < 3; ++a)
    if (f.H[a] <= kSemiCoarsening * hmin && *n[std::size_t(a)] > 2) {
      *n[std::size_t(a)] = *n[std::size_t(a)] / 2 + 1;  // ceil((n - 1) / 2) cells
      c.H[a] = 2 * f.H[a];
    }
  return c;
}

/// Chebyshev smoothing steps before and after the coarse correction.
constexpr int kSmoothingSteps = 3;
/// The smoother damps the eigenvalues of D^-1 A in [lmax / ratio, lmax]: a
/// bi-Laplacian's smooth-in-all-but-one-axis modes sit near lmax / 36 (the
/// symbols 4 against 144 of the stencil's squared 7-point Laplacian).
constexpr double kChebyshevRatio = 30;
/// Power-iteration steps estimating lmax of D^-1 A, and the safety factor on
/// the estimate (power iteration approaches lmax from below; an
/// underestimated lmax would amplify the top modes).
constexpr int kPowerSteps = 20;
constexpr double kLmaxSafety = 1.2;
/// Power-iteration steps from the previous solve's vector on the same grids
/// (an active-set pass: the operator changed by a few penalty samples, so
/// the top eigenvector barely moved).
constexpr int kWarmPowerSteps = 5;

/// lmax of D^-1 A (apply(x, y): y = A x; n unknowns) by power iteration;
/// v: the start when `warm` (kWarmPowerSteps), left holding the last iterate.
template <class Apply>
double largest_eigenvalue(const Apply& apply, const Eigen::VectorXd& D, std::size_t n, Eigen::VectorXd& v, bool warm) {
  Eigen::VectorXd Av;
  if (!warm) {
    // A pseudo-random start: every mode present (a smooth start holds almost
    // none of the top modes, and the estimate stays far below lmax).
    v.resize(Eigen::Index(n));
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      const double q = std::sin(double(i) * 12.9898 + 78.233) * 43758.5453;
      v[i] = q - std::floor(q) - 0.5;
    }
  }
  double lmax = 0;
  for (int s = 0; s < (warm ? kWarmPowerSteps : kPowerSteps); ++s) {
    v /= v.norm();
    apply(v, Av);
    Av = Av.cwiseQuotient(D);
    lmax = Av.norm();
    v.swap(Av);
  }
  return lmax;
}

/// `steps` of Chebyshev iteration on D^-1 A x = D^-1 b from x, damping the
/// eigenvalues of D^-1 A in [lmax / ratio, lmax]; ax, r, d: work vectors.
template <class Apply>
void chebyshev(const Apply& apply, const Eigen::VectorXd& D, double lmax, double ratio, int steps, const Eigen::VectorXd& b,
               Eigen::VectorXd& x, Eigen::VectorXd& ax, Eigen::VectorXd& r, Eigen::VectorXd& d) {
  const double lmin = lmax / ratio;
  const double theta = (lmax + lmin) / 2, delta = (lmax - lmin) / 2, sigma = theta / delta;
  double rho = 1 / sigma;
  apply(x, ax);
  r = (b - ax).cwiseQuotient(D);
  d = r / theta;
  for (int k = 0; k < steps; ++k) {
    x += d;
    if (k + 1 == steps) break;
    apply(d, ax);
    r -= ax.cwiseQuotient(D);
    const double rho_new = 1 / (2 * sigma - rho);
    d = (rho_new * rho) * d + (2 * rho_new / delta) * r;
    rho = rho_new;
  }
}

/// The top eigenvectors of D^-1 A per multigrid level from one solve, for
/// the next solve on the same grids to start its power iterations from.
struct PowerStart {
  std::vector<Eigen::VectorXd> v;
};

/// A multigrid's coarse operators kept from one solve to the next on the
/// same grids (the base grid's active-set passes): samples before `first`
/// unchanged, those from `first` on (penalty samples) added or re-weighted,
/// so each pass adds the changed samples' B^T W B instead of summing all
/// samples again per level (docs/decisions.md: field3d memory and work budget).
struct CoarseReuse {
  std::size_t first = 0;
  std::vector<std::shared_ptr<CellOperator>> ops;  // levels 1, 2, ...; empty: none built yet
  std::vector<double> weight;                      // samples[first + i].weight as ops hold it

  /// The changed samples' deltas added to ops at every level.
  void update(const std::vector<Sample>& samples) {
    for (std::size_t k = first; k < samples.size(); ++k) {
      const std::size_t i = k - first;
      const double dw = samples[k].weight - (i < weight.size() ? weight[i] : 0.0);
      if (dw != 0)
        for (const auto& op : ops) op->add(samples[k], dw);
    }
    remember(samples);
  }
  void remember(const std::vector<Sample>& samples) {
    weight.clear();
    for (std::size_t k = first; k < samples.size(); ++k) weight.push_back(samples[k].weight);
  }
};

/// A geometric multigrid V-cycle as the preconditioner of conjugate
/// gradients on one level: the grids halved (nested nodes, the coarse box
/// covering the fine one; each coarse operator rediscretised from the same
/// samples at twice the spacing, the energy's scaling kept, so it
/// approximates P^T A P; its data term summed per cell, CellOperator),
/// Chebyshev smoothing on D^-1 A, restriction P^T, the coarsest level
/// factorised. Pre- and post-smoothing are one polynomial and the coarsest
/// solve is exact, so the preconditioner is symmetric, positive definite and
/// linear (plain CG applies). Jacobi-PCG needs O(h^-2) iterations on the
/// 4th-order operator; this needs a number nearly independent of the grid.
/// Memory: per level three work vectors (smoothing, residual, correction)
/// kept from one V-cycle to the next, and on coarse levels the restricted
/// residual and the correction; no copy of the samples.
class Multigrid {
 public:
  /// start: the previous solve's top eigenvectors on the same grids (null or
  /// not matching: a cold start); updated to this hierarchy's.
  /// reuse: the coarse operators of the last solve on these grids, updated
  /// for the changed samples (null, or none yet: built from all samples; kept there).
  Multigrid(const Level& top, const Operator& A, const std::vector<Sample>& samples, const Field3dParams& p,
            PowerStart* start = nullptr, CoarseReuse* reuse = nullptr)
      : top_(&A) {
    lv_.push_back(top);
    while (lv_.back().size() > kCoarsestNodes && int(lv_.size()) < kMaxMultigridLevels) {
      const Level c = coarser(lv_.back());
      if (c.size() == lv_.back().size()) break;
      lv_.push_back(c);
    }
    if (reuse && !reuse->ops.empty() && reuse->ops.size() + 1 == lv_.size()) {
      reuse->update(samples);
      coarse_ = reuse->ops;
    } else {
      for (std::size_t l = 1; l < lv_.size(); ++l) coarse_.push_back(std::make_shared<CellOperator>(lv_[l], samples, p));
      if (reuse) {
        reuse->ops = coarse_;
        reuse->remember(samples);
      }
    }
    work_.resize(lv_.size());
    const bool warm = start && start->v.size() + 1 == lv_.size();
    if (start && !warm) start->v.assign(lv_.size() - 1, Eigen::VectorXd());
    for (std::size_t l = 0; l + 1 < lv_.size(); ++l) {
      Eigen::VectorXd scratch;
      Eigen::VectorXd& v = start ? start->v[l] : scratch;
      const bool from_v = warm && v.size() == Eigen::Index(lv_[l].size());
      lmax_.push_back(kLmaxSafety * largest_eigenvalue(l, v, from_v));
    }
    coarsest_.compute(coarse_.empty() ? CellOperator(top, samples, p).assemble() : coarse_.back()->assemble());
    if (coarsest_.info() != Eigen::Success) throw Error("field3d: the multigrid's coarsest factorisation failed");
  }

  [[nodiscard]] int levels() const { return int(lv_.size()); }

  /// z = M^-1 r: one V-cycle from zero.
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) const { vcycle(0, r, z); }

 private:
  /// A level's vectors, kept between V-cycles: b and x (coarse levels: the
  /// restricted residual and the correction), ax, r and d (smoothing).
  struct Work {
    Eigen::VectorXd b, x, ax, r, d;
  };

  void apply(std::size_t l, const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    if (l == 0) top_->apply(x, y);
    else coarse_[l - 1]->apply(x, y);
  }
  [[nodiscard]] const Eigen::VectorXd& diagonal(std::size_t l) const {
    return l == 0 ? top_->diagonal() : coarse_[l - 1]->diagonal();
  }

  /// lmax of D^-1 A on level l (largest_eigenvalue()).
  [[nodiscard]] double largest_eigenvalue(std::size_t l, Eigen::VectorXd& v, bool warm) const {
    return detail::largest_eigenvalue([&](const Eigen::VectorXd& a, Eigen::VectorXd& y) { apply(l, a, y); }, diagonal(l),
                                      lv_[l].size(), v, warm);
  }

  /// kSmoothingSteps of Chebyshev iteration on D^-1 A x = D^-1 b from x.
  void smooth(std::size_t l, const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
    Work& w = work_[l];
    chebyshev([&](const Eigen::VectorXd& a, Eigen::VectorXd& y) { apply(l, a, y); }, diagonal(l), lmax_[l],
              kChebyshevRatio, kSmoothingSteps, b, x, w.ax, w.r, w.d);
  }

  void vcycle(std::size_t l, const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
    if (l + 1 == lv_.size()) {
      x = coarsest_.solve(b);
      return;
    }
    Work& w = work_[l];
    Work& c = work_[l + 1];
    x.setZero(b.size());
    smooth(l, b, x);
    apply(l, x, w.ax);
    w.r = b - w.ax;
    restrict_to(lv_[l + 1], w.r, lv_[l], c.b);
    vcycle(l + 1, c.b, c.x);
    prolong_into(lv_[l + 1], c.x, lv_[l], w.ax);
    x += w.ax;
    smooth(l, b, x);
  }

  std::vector<Level> lv_;
  const Operator* top_;
  std::vector<std::shared_ptr<CellOperator>> coarse_;  // levels 1, 2, ... (shared with a CoarseReuse)
  std::vector<double> lmax_;
  mutable std::vector<Work> work_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> coarsest_;
};

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

/// f at a point of the level (g in finest cells from node 0), trilinear;
/// clamped into the grid.
double base_value(const Level& lv, const Eigen::VectorXd& x, const Vec3d& g) {
  const Vec3d q = g.cwiseQuotient(lv.H);
  const int i = std::clamp(int(std::floor(q.x())), 0, lv.nx - 2), j = std::clamp(int(std::floor(q.y())), 0, lv.ny - 2),
            k = std::clamp(int(std::floor(q.z())), 0, lv.nz - 2);
  const double fx = std::clamp(q.x() - i, 0.0, 1.0), fy = std::clamp(q.y() - j, 0.0, 1.0),
               fz = std::clamp(q.z() - k, 0.0, 1.0);
  double v = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = c >> 1 & 1, dz = c >> 2 & 1;
    v += (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz) * x[Eigen::Index(lv.index(i + dx, j + dy, k + dz))];
  }
  return v;
}

/// The level's field at nodes one finest cell apart along `axis` (n_out of
/// them from node 0; the other axes' nodes as they are), x fastest: along
/// each line of nodes on that axis, the natural cubic spline through its
/// values (interp/spline.h). It is the smoothest curve through them (least
/// integral of f''^2, the 1D form of the solve's energy): C2 across the
/// nodes, so the surface has no crease at the input planes that lie on them.
std::vector<double> spline_along(const Level& lv, const Eigen::VectorXd& x, int axis, int n_out) {
  const std::array<int, 3> n{lv.nx, lv.ny, lv.nz};
  const std::array<std::size_t, 3> stride{1, std::size_t(lv.nx), std::size_t(lv.nx) * std::size_t(lv.ny)};
  std::array<int, 3> no = n;
  no[std::size_t(axis)] = n_out;
  const std::array<std::size_t, 3> ostride{1, std::size_t(no[0]), std::size_t(no[0]) * std::size_t(no[1])};
  const int m = n[std::size_t(axis)];
  const double step = lv.H[axis];
  std::vector<double> knots(static_cast<std::size_t>(m));  // node units
  std::iota(knots.begin(), knots.end(), 0.0);
  // Each output node's knot interval and Hermite basis: the same on every line.
  std::vector<std::size_t> interval(static_cast<std::size_t>(n_out));
  std::vector<HermiteBasis> basis;
  basis.reserve(std::size_t(n_out));
  for (int o = 0; o < n_out; ++o) {
    interval[std::size_t(o)] = knot_interval(knots, o / step);
    const double k = double(interval[std::size_t(o)]);
    basis.emplace_back(SplineKind::Natural, k, k + 1, std::min(o / step, knots.back()));
  }
  const int a1 = axis == 0 ? 1 : 0, a2 = axis == 2 ? 1 : 2;  // the other two axes
  std::vector<double> out(std::size_t(no[0]) * std::size_t(no[1]) * std::size_t(no[2]));
  tbb::parallel_for(0, n[std::size_t(a2)], [&](int q) {
    std::vector<double> y(static_cast<std::size_t>(m)), tangent(static_cast<std::size_t>(m));
    for (int p = 0; p < n[std::size_t(a1)]; ++p) {
      const std::size_t in0 = std::size_t(p) * stride[std::size_t(a1)] + std::size_t(q) * stride[std::size_t(a2)];
      const std::size_t out0 = std::size_t(p) * ostride[std::size_t(a1)] + std::size_t(q) * ostride[std::size_t(a2)];
      for (int k = 0; k < m; ++k) y[std::size_t(k)] = x[Eigen::Index(in0 + std::size_t(k) * stride[std::size_t(axis)])];
      spline_tangents(SplineKind::Natural, knots, y, tangent);
      for (int o = 0; o < n_out; ++o) {
        const std::size_t k = interval[std::size_t(o)];
        out[out0 + std::size_t(o) * ostride[std::size_t(axis)]] =
            basis[std::size_t(o)].value(y[k], y[k + 1], tangent[k], tangent[k + 1]);
      }
    }
  });
  return out;
}

/// Box dilation by w cells of a byte mask over cx x cy x cz cells (separable).
void dilate(std::vector<std::uint8_t>& m, int cx, int cy, int cz, int w) {
  const std::array<int, 3> dims{cx, cy, cz};
  const std::array<std::size_t, 3> stride{1, std::size_t(cx), std::size_t(cx) * std::size_t(cy)};
  for (int ax = 0; ax < 3; ++ax) {
    std::vector<std::uint8_t> out(m.size(), 0);
    for (std::size_t n = 0; n < m.size(); ++n) {
      if (!m[n]) continue;
      const int c = int(n / stride[ax] % std::size_t(dims[ax]));
      for (int d = std::max(0, c - w); d <= std::min(dims[ax] - 1, c + w); ++d) out[n + (d - c) * stride[ax]] = 1;
    }
    m.swap(out);
  }
}

/// The narrow band of the refined grid (spacing 1/r base cells): base cells near
/// the zero set, each storing the r^3 fine nodes it owns (local offsets 0..r-1
/// per axis). Nodes owned by the inner cells are unknowns; those owned by the
/// outer ring of cells are fixed (Dirichlet) at the base field prolonged, and
/// hold the two rings of neighbours the bi-Laplacian of an unknown reads.
/// Storage grows with the surface's area, not the box's volume.
struct Band {
  int r = 2, shift = 1;
  int cx = 0, cy = 0, cz = 0;             ///< base cells per axis
  std::vector<std::int32_t> block;        ///< per base cell: its block of r^3 nodes, or -1
  std::vector<std::array<int, 3>> cells;  ///< base cell of each block
  std::vector<std::uint8_t> inner;        ///< per block: its nodes are unknowns (else the fixed ring)
  std::vector<std::uint8_t> unknown;      ///< per stored node
  std::vector<std::int32_t> nbr;          ///< per stored node, its 6 neighbours (or -1)

  [[nodiscard]] std::size_t per_block() const { return std::size_t(r) * std::size_t(r) * std::size_t(r); }
  [[nodiscard]] std::size_t size() const { return cells.size() * per_block(); }
  /// Stored index of fine node (I, J, K), or -1.
  [[nodiscard]] std::int64_t node(int I, int J, int K) const {
    if (I < 0 || J < 0 || K < 0) return -1;
    const int a = I >> shift, b = J >> shift, c = K >> shift;
    if (a >= cx || b >= cy || c >= cz) return -1;
    const std::int32_t bl = block[std::size_t(a) + std::size_t(cx) * (std::size_t(b) + std::size_t(cy) * std::size_t(c))];
    if (bl < 0) return -1;
    const int m = r - 1;
    return std::int64_t(bl) * std::int64_t(per_block()) + (I & m) + r * ((J & m) + r * (K & m));
  }
  [[nodiscard]] std::array<int, 3> coords(std::size_t n) const {
    const std::size_t b = n / per_block(), l = n % per_block();
    return {cells[b][0] * r + int(l % std::size_t(r)), cells[b][1] * r + int(l / std::size_t(r) % std::size_t(r)),
            cells[b][2] * r + int(l / std::size_t(r * r))};
  }
  [[nodiscard]] bool has_lap(std::size_t n) const {
    for (int o = 0; o < 6; ++o)
      if (nbr[6 * n + std::size_t(o)] < 0) return false;
    return true;
  }
};

/// The band around the base field's zero set and every drawn contour (the
/// cells holding a contour sample: a thin part the base grid lost is re-solved
/// too), dilated by `width` cells; cells touching the box's faces stay fixed.
void build_band_nodes(Band& b);

Band make_band(const Level& lv, const Eigen::VectorXd& x, const std::vector<Sample>& samples, int r, int width) {
  Band b;
  b.r = r;
  b.shift = r == 4 ? 2 : (r == 2 ? 1 : 0);
  b.cx = lv.nx - 1;
  b.cy = lv.ny - 1;
  b.cz = lv.nz - 1;
  const std::size_t C = std::size_t(b.cx) * std::size_t(b.cy) * std::size_t(b.cz);
  const auto cell = [&](int a, int bb, int c) {
    return std::size_t(a) + std::size_t(b.cx) * (std::size_t(bb) + std::size_t(b.cy) * std::size_t(c));
  };
  std::vector<std::uint8_t> inner(C, 0);
  tbb::parallel_for(0, b.cz, [&](int c) {
    for (int bb = 0; bb < b.cy; ++bb)
      for (int a = 0; a < b.cx; ++a) {
        bool pos = false, neg = false;
        for (int q = 0; q < 8; ++q) {
          const double v = x[Eigen::Index(lv.index(a + (q & 1), bb + (q >> 1 & 1), c + (q >> 2 & 1)))];
          (v > 0 ? pos : neg) = true;
        }
        inner[cell(a, bb, c)] = pos && neg;
      }
  });
  for (const Sample& s : samples) {
    if (!s.contour) continue;
    const int a = std::clamp(int(std::floor(s.g.x())), 0, b.cx - 1), bb = std::clamp(int(std::floor(s.g.y())), 0, b.cy - 1),
              c = std::clamp(int(std::floor(s.g.z())), 0, b.cz - 1);
    inner[cell(a, bb, c)] = 1;
  }
  dilate(inner, b.cx, b.cy, b.cz, width);
  for (int c = 0; c < b.cz; ++c)
    for (int bb = 0; bb < b.cy; ++bb)
      for (int a = 0; a < b.cx; ++a)
        if (a == 0 || bb == 0 || c == 0 || a >= b.cx - 1 || bb >= b.cy - 1 || c >= b.cz - 1) inner[cell(a, bb, c)] = 0;
  std::vector<std::uint8_t> stored = inner;
  dilate(stored, b.cx, b.cy, b.cz, 1);
  b.block.assign(C, -1);
  for (int c = 0; c < b.cz; ++c)
    for (int bb = 0; bb < b.cy; ++bb)
      for (int a = 0; a < b.cx; ++a)
        if (stored[cell(a, bb, c)]) {
          b.block[cell(a, bb, c)] = std::int32_t(b.cells.size());
          b.cells.push_back({a, bb, c});
        }
  for (const auto& ce : b.cells) b.inner.push_back(inner[cell(ce[0], ce[1], ce[2])]);
  build_band_nodes(b);
  return b;
}

/// The band's per-node flags and neighbours from its blocks (Band::inner).
void build_band_nodes(Band& b) {
  const std::size_t n = b.size();
  b.unknown.resize(n);
  b.nbr.resize(6 * n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& rg) {
    for (std::size_t m = rg.begin(); m < rg.end(); ++m) {
      const auto [I, J, K] = b.coords(m);
      b.unknown[m] = b.inner[m / b.per_block()];
      for (int q = 0; q < 6; ++q)
        b.nbr[6 * m + std::size_t(q)] =
            std::int32_t(b.node(I + kNeighbours[std::size_t(q)][0], J + kNeighbours[std::size_t(q)][1], K + kNeighbours[std::size_t(q)][2]));
    }
  });
}

/// The band on the same base cells at half its refinement (the band
/// multigrid's next level): nested nodes, fine node 2 I on coarse node I.
Band coarser_band(const Band& f) {
  Band c{f.r / 2, f.shift - 1, f.cx, f.cy, f.cz, f.block, f.cells, f.inner, {}, {}};
  build_band_nodes(c);
  return c;
}

/// The base field prolonged to the band's nodes (the warm start and the fixed values).
Eigen::VectorXd band_prolong(const Band& b, const Level& lv, const Eigen::VectorXd& x) {
  Eigen::VectorXd z(Eigen::Index(b.size()));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, b.size(), 4096), [&](const auto& rg) {
    for (std::size_t m = rg.begin(); m < rg.end(); ++m) {
      const auto [I, J, K] = b.coords(m);
      z[Eigen::Index(m)] = base_value(lv, x, Vec3d(I, J, K) / b.r);
    }
  });
  return z;
}

/// The normal equations on the band's unknowns, the fixed nodes' values held:
/// apply() gives A x on unknowns and 0 on fixed nodes, so conjugate gradients
/// over the stored vector (fixed entries never move: the residual and the
/// search directions are 0 there) solve A_UU x_U = b_U - A_UF x_F.
class BandOperator {
 public:
  BandOperator(const Band& band, const std::vector<Sample>& samples, const Field3dParams& p)
      : b_(band), lam_(p.smoothness * band.r) {
    const std::size_t N = band.size();
    for (std::size_t s = 0; s < samples.size(); ++s) {
      const Vec3d q = samples[s].g * band.r;
      const int i = int(std::floor(q.x())), j = int(std::floor(q.y())), k = int(std::floor(q.z()));
      std::array<std::int64_t, 8> nd{};
      bool all = true, any_unknown = false;
      for (int c = 0; c < 8 && all; ++c) {
        nd[std::size_t(c)] = band.node(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1));
        all = nd[std::size_t(c)] >= 0;
        if (all) any_unknown = any_unknown || band.unknown[std::size_t(nd[std::size_t(c)])];
      }
      if (!all || !any_unknown) continue;
      const double fx = q.x() - i, fy = q.y() - j, fz = q.z() - k;
      for (int c = 0; c < 8; ++c) {
        const int dx = c & 1, dy = c >> 1 & 1, dz = c >> 2 & 1;
        node_.push_back(std::uint32_t(nd[std::size_t(c)]));
        bw_.push_back((dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz));
      }
      sw_.push_back(samples[s].weight);
      val_.push_back(samples[s].value);
      index_.push_back(s);
    }
    transpose_gather(node_, N, off_, entry_);
    rhs_ = Eigen::VectorXd::Zero(Eigen::Index(N));
    diag_ = Eigen::VectorXd::Ones(Eigen::Index(N));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, N, 4096), [&](const auto& rg) {
      for (std::size_t n = rg.begin(); n < rg.end(); ++n) {
        if (!b_.unknown[n]) continue;
        double d = 0, rhs = 0;
        for (std::uint32_t a = off_[n]; a < off_[n + 1]; ++a) {
          const std::uint32_t e = entry_[a];
          d += sw_[e / 8] * bw_[e] * bw_[e];
          rhs += sw_[e / 8] * bw_[e] * val_[e / 8];
        }
        int inner = 0;
        for (int o = 0; o < 6; ++o) inner += b_.has_lap(std::size_t(b_.nbr[6 * n + std::size_t(o)]));
        diag_[Eigen::Index(n)] = d + lam_ * ((b_.has_lap(n) ? 36 : 0) + inner);
        rhs_[Eigen::Index(n)] = rhs;
      }
    });
  }

  [[nodiscard]] const Eigen::VectorXd& rhs() const { return rhs_; }
  [[nodiscard]] const Eigen::VectorXd& diagonal() const { return diag_; }
  /// Samples seen by the band (indices into the caller's samples), and f at them.
  [[nodiscard]] const std::vector<std::size_t>& sample_index() const { return index_; }
  [[nodiscard]] double at_sample(std::size_t k, const Eigen::VectorXd& x) const {
    double v = 0;
    for (int c = 0; c < 8; ++c) v += bw_[8 * k + std::size_t(c)] * x[node_[8 * k + std::size_t(c)]];
    return v;
  }

  void apply(const Eigen::VectorXd& x, Eigen::VectorXd& y) const {
    const std::size_t N = b_.size();
    lap_.resize(x.size());
    r_.resize(Eigen::Index(sw_.size()));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, N, 4096), [&](const auto& rg) {
      for (std::size_t n = rg.begin(); n < rg.end(); ++n) {
        double l = -6 * x[Eigen::Index(n)];
        bool full = true;
        for (int o = 0; o < 6 && full; ++o) {
          const std::int32_t m = b_.nbr[6 * n + std::size_t(o)];
          full = m >= 0;
          if (full) l += x[m];
        }
        lap_[Eigen::Index(n)] = full ? l : 0.0;
      }
    });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sw_.size(), 4096), [&](const auto& rg) {
      for (std::size_t s = rg.begin(); s < rg.end(); ++s) r_[Eigen::Index(s)] = sw_[s] * at_sample(s, x);
    });
    y.resize(x.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, N, 4096), [&](const auto& rg) {
      for (std::size_t n = rg.begin(); n < rg.end(); ++n) {
        if (!b_.unknown[n]) {
          y[Eigen::Index(n)] = 0;
          continue;
        }
        double l = -6 * lap_[Eigen::Index(n)];
        for (int o = 0; o < 6; ++o) l += lap_[b_.nbr[6 * n + std::size_t(o)]];  // unknowns' neighbours are stored
        double v = lam_ * l;
        for (std::uint32_t a = off_[n]; a < off_[n + 1]; ++a) v += bw_[entry_[a]] * r_[entry_[a] / 8];
        y[Eigen::Index(n)] = v;
      }
    });
  }

  /// The twin: A_UU assembled over the unknowns (compact numbering `col`).
  [[nodiscard]] Eigen::SparseMatrix<double> assemble(const std::vector<std::int64_t>& col, Eigen::Index nu) const {
    const std::size_t N = b_.size();
    std::vector<Eigen::Triplet<double>> lt, bt;
    for (std::size_t n = 0; n < N; ++n) {
      if (!b_.has_lap(n)) continue;
      if (col[n] >= 0) lt.emplace_back(Eigen::Index(n), col[n], -6.0);
      for (int o = 0; o < 6; ++o) {
        const auto m = std::size_t(b_.nbr[6 * n + std::size_t(o)]);
        if (col[m] >= 0) lt.emplace_back(Eigen::Index(n), col[m], 1.0);
      }
    }
    for (std::size_t s = 0; s < sw_.size(); ++s)
      for (int c = 0; c < 8; ++c) {
        const std::uint32_t m = node_[8 * s + std::size_t(c)];
        if (col[m] >= 0) bt.emplace_back(Eigen::Index(s), col[m], std::sqrt(sw_[s]) * bw_[8 * s + std::size_t(c)]);
      }
    Eigen::SparseMatrix<double> L(Eigen::Index(N), nu), B(Eigen::Index(sw_.size()), nu);
    L.setFromTriplets(lt.begin(), lt.end());
    B.setFromTriplets(bt.begin(), bt.end());
    Eigen::SparseMatrix<double> A = lam_ * Eigen::SparseMatrix<double>(L.transpose() * L);
    A += Eigen::SparseMatrix<double>(B.transpose() * B);
    return A;
  }

 private:
  const Band& b_;
  double lam_;
  std::vector<std::uint32_t> node_;
  std::vector<double> bw_, sw_, val_;
  std::vector<std::size_t> index_;
  std::vector<std::uint32_t> off_, entry_;
  Eigen::VectorXd rhs_, diag_;
  mutable Eigen::VectorXd lap_, r_;
};

/// The band's system solved directly (SimplicialLDLT on A_UU; the twin of the
/// band's conjugate gradients). Returns the relative residual.
double band_direct(const BandOperator& A, const Band& b, Eigen::VectorXd& z) {
  std::vector<std::int64_t> col(b.size(), -1);
  Eigen::Index nu = 0;
  for (std::size_t n = 0; n < b.size(); ++n)
    if (b.unknown[n]) col[n] = nu++;
  if (std::size_t(nu) > kMaxDirectNodes)
    throw ParamError("field3d.direct: the band has " + std::to_string(nu) + " unknowns, more than the direct twin's " +
                     std::to_string(kMaxDirectNodes));
  Eigen::VectorXd Az;
  A.apply(z, Az);
  const Eigen::VectorXd r0 = A.rhs() - Az;
  Eigen::VectorXd ru(nu);
  for (std::size_t n = 0; n < b.size(); ++n)
    if (col[n] >= 0) ru[col[n]] = r0[Eigen::Index(n)];
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A.assemble(col, nu));
  if (ldlt.info() != Eigen::Success) throw Error("field3d: the band's direct factorisation failed");
  const Eigen::VectorXd du = ldlt.solve(ru);
  for (std::size_t n = 0; n < b.size(); ++n)
    if (col[n] >= 0) z[Eigen::Index(n)] += du[col[n]];
  A.apply(z, Az);
  return (A.rhs() - Az).norm() / std::max(A.rhs().norm(), std::numeric_limits<double>::min());
}

/// The band multigrid's coarsest level (the band at refinement 1, ~1/r^3 of
/// the nodes) is not factorised (a shell's thousands of unknowns): Chebyshev
/// steps over [lmax / kBandCoarsestRatio, lmax] instead, one fixed polynomial,
/// so the V-cycle stays linear and symmetric. Across a band a few base cells
/// wide the fixed rings bound the smallest eigenvalue; 16 steps over a ratio
/// of 300 took eight_15's band iterations from 917 (Jacobi) to 42 at
/// refinement 4, 462 to 23 at 2 (docs/decisions.md: the sparse field).
constexpr int kBandCoarsestSteps = 16;
constexpr double kBandCoarsestRatio = 300;

/// Per axis, the coarse nodes under fine coordinate I and their trilinear
/// weights (even: one node; odd: the two neighbours, half each).
inline int parents(int I, std::array<int, 2>& at, std::array<double, 2>& w) {
  if ((I & 1) == 0) {
    at[0] = I / 2;
    w[0] = 1;
    return 1;
  }
  at = {(I - 1) / 2, (I + 1) / 2};
  w = {0.5, 0.5};
  return 2;
}

/// y = P xc on the fine band's unknowns (0 on its fixed nodes): the coarse
/// band's correction prolonged trilinearly (its fixed entries are 0).
void band_prolong_into(const Band& coarse, const Eigen::VectorXd& xc, const Band& fine, Eigen::VectorXd& y) {
  y.resize(Eigen::Index(fine.size()));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, fine.size(), 4096), [&](const auto& rg) {
    for (std::size_t n = rg.begin(); n < rg.end(); ++n) {
      double v = 0;
      if (fine.unknown[n]) {
        const auto I = fine.coords(n);
        std::array<std::array<int, 2>, 3> at{};
        std::array<std::array<double, 2>, 3> w{};
        std::array<int, 3> cnt{};
        for (int a = 0; a < 3; ++a) cnt[std::size_t(a)] = parents(I[std::size_t(a)], at[std::size_t(a)], w[std::size_t(a)]);
        for (int c = 0; c < cnt[2]; ++c)
          for (int b = 0; b < cnt[1]; ++b)
            for (int a = 0; a < cnt[0]; ++a) {
              const std::int64_t m = coarse.node(at[0][std::size_t(a)], at[1][std::size_t(b)], at[2][std::size_t(c)]);
              if (m >= 0) v += w[0][std::size_t(a)] * w[1][std::size_t(b)] * w[2][std::size_t(c)] * xc[Eigen::Index(m)];
            }
      }
      y[Eigen::Index(n)] = v;
    }
  });
}

/// rc = P^T rf on the coarse band's unknowns (0 on its fixed nodes): each
/// coarse node gathers the fine unknowns it is a parent of.
void band_restrict(const Band& coarse, const Eigen::VectorXd& rf, const Band& fine, Eigen::VectorXd& rc) {
  rc.resize(Eigen::Index(coarse.size()));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, coarse.size(), 4096), [&](const auto& rg) {
    for (std::size_t m = rg.begin(); m < rg.end(); ++m) {
      double v = 0;
      if (coarse.unknown[m]) {
        const auto [i, j, k] = coarse.coords(m);
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const std::int64_t n = fine.node(2 * i + dx, 2 * j + dy, 2 * k + dz);
              if (n >= 0 && fine.unknown[std::size_t(n)])
                v += (dx ? 0.5 : 1.0) * (dy ? 0.5 : 1.0) * (dz ? 0.5 : 1.0) * rf[Eigen::Index(n)];
            }
      }
      rc[Eigen::Index(m)] = v;
    }
  });
}

/// The band's V-cycle, the preconditioner of its conjugate gradients: the
/// band at refinement r, r / 2, ..., 1 on the same base cells (nested nodes;
/// each coarse operator rediscretised from the same fine samples, lambda =
/// smoothness x its refinement, so it approximates P^T A P as the dense
/// multigrid's levels do); Chebyshev smoothing on D^-1 A, restriction P^T,
/// the fixed rings' corrections 0; the coarsest level smoothed by
/// kBandCoarsestSteps. Symmetric, positive definite and linear.
class BandMultigrid {
 public:
  BandMultigrid(const Band& top, const BandOperator& A, const std::vector<Sample>& samples, const Field3dParams& p) {
    bands_.push_back(&top);
    ops_.push_back(&A);
    while (bands_.back()->r > 1) {
      own_bands_.push_back(std::make_unique<Band>(coarser_band(*bands_.back())));
      bands_.push_back(own_bands_.back().get());
      own_ops_.push_back(std::make_unique<BandOperator>(*bands_.back(), samples, p));
      ops_.push_back(own_ops_.back().get());
    }
    work_.resize(bands_.size());
    for (std::size_t l = 0; l < bands_.size(); ++l) {
      Eigen::VectorXd v;
      lmax_.push_back(kLmaxSafety * largest_eigenvalue([&](const Eigen::VectorXd& a, Eigen::VectorXd& y) { ops_[l]->apply(a, y); },
                                                       ops_[l]->diagonal(), bands_[l]->size(), v, false));
    }
  }

  [[nodiscard]] int levels() const { return int(bands_.size()); }

  /// z = M^-1 r: one V-cycle from zero.
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) const { vcycle(0, r, z); }

 private:
  struct Work {
    Eigen::VectorXd b, x, ax, r, d;
  };

  void smooth(std::size_t l, const Eigen::VectorXd& b, Eigen::VectorXd& x, double ratio, int steps) const {
    Work& w = work_[l];
    chebyshev([&](const Eigen::VectorXd& a, Eigen::VectorXd& y) { ops_[l]->apply(a, y); }, ops_[l]->diagonal(), lmax_[l],
              ratio, steps, b, x, w.ax, w.r, w.d);
  }

  void vcycle(std::size_t l, const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
    x.setZero(b.size());
    if (l + 1 == bands_.size()) {
      smooth(l, b, x, kBandCoarsestRatio, kBandCoarsestSteps);
      return;
    }
    Work& w = work_[l];
    Work& c = work_[l + 1];
    smooth(l, b, x, kChebyshevRatio, kSmoothingSteps);
    ops_[l]->apply(x, w.ax);
    w.r = b - w.ax;
    band_restrict(*bands_[l + 1], w.r, *bands_[l], c.b);
    vcycle(l + 1, c.b, c.x);
    band_prolong_into(*bands_[l + 1], c.x, *bands_[l], w.ax);
    x += w.ax;
    smooth(l, b, x, kChebyshevRatio, kSmoothingSteps);
  }

  std::vector<const Band*> bands_;
  std::vector<const BandOperator*> ops_;
  std::vector<std::unique_ptr<Band>> own_bands_;
  std::vector<std::unique_ptr<BandOperator>> own_ops_;
  std::vector<double> lmax_;
  mutable std::vector<Work> work_;
};

/// Multiplies by `factor` the weight of every sample the field `at` misses:
/// a contour sample where |f| > tol (cells), a plane sample on the wrong side
/// (f and d of opposite signs, |d| > tol). Returns how many.
template <class At>
std::size_t reweight(std::vector<Sample>& samples, const std::vector<std::size_t>& seen, const At& at, double tol,
                     double factor) {
  std::size_t raised = 0;
  for (std::size_t k = 0; k < seen.size(); ++k) {
    Sample& s = samples[seen[k]];
    const double f = at(k);
    const bool missed = s.contour ? std::abs(f) > tol : (std::abs(s.value) > tol && f * s.value < 0);
    if (!missed) continue;
    s.weight *= factor;
    ++raised;
  }
  return raised;
}

/// Sign constraints: pixel centres of the label images, or plane samples of
/// polyline sections (plane_signs); positions in finest cells from the grid
/// origin, +1 inside (label), -1 outside.
struct SignPoints {
  std::vector<Vec3d> g;
  std::vector<std::int8_t> sign;
  std::vector<std::uint32_t> section, pixel;  ///< the section's index and the pixel's index in its image (kNoPixel: a plane sample)

  void append(SignPoints&& o) {
    g.insert(g.end(), o.g.begin(), o.g.end());
    sign.insert(sign.end(), o.sign.begin(), o.sign.end());
    section.insert(section.end(), o.section.begin(), o.section.end());
    pixel.insert(pixel.end(), o.pixel.begin(), o.pixel.end());
  }
};
/// SignPoints::pixel of a polyline section's plane sample (no image to check the mesh against).
constexpr std::uint32_t kNoPixel = std::numeric_limits<std::uint32_t>::max();

/// Every pixel centre of `sections`' label images inside the box [lo, hi]
/// (world mm; grid spacing h, origin lo).
SignPoints sign_points(const std::vector<Section>& sections, std::uint32_t label, const Vec3d& lo, const Vec3d& hi,
                       double h) {
  std::vector<SignPoints> per(sections.size());
  tbb::parallel_for(std::size_t(0), sections.size(), [&](std::size_t i) {
    const Section& sec = sections[i];
    if (!sec.is_image()) return;
    const double eps = 1e-9 * h;
    for (int y = 0; y < sec.labels.height; ++y)
      for (int x = 0; x < sec.labels.width; ++x) {
        const Vec3d w = sec.pose.to_world(Vec2d(x, y) * sec.pixel_size);
        if ((w.array() < lo.array() - eps).any() || (w.array() > hi.array() + eps).any()) continue;
        per[i].g.push_back((w - lo) / h);
        per[i].sign.push_back(sec.labels(x, y) == label ? 1 : -1);
        per[i].section.push_back(std::uint32_t(i));
        per[i].pixel.push_back(std::uint32_t(sec.labels.index(x, y)));
      }
  });
  SignPoints all;
  for (auto& p : per) all.append(std::move(p));
  return all;
}

/// Polyline sections' plane samples at least `dist` (cells) from their
/// drawn contours, signed by side. section_end[i]: one past section i's
/// samples in `samples` (make_samples' order).
SignPoints plane_sign_points(const std::vector<Section>& sections, const std::vector<Sample>& samples,
                             const std::vector<std::size_t>& section_end, double dist) {
  SignPoints sp;
  for (std::size_t i = 0, k = 0; i < sections.size(); k = section_end[i++]) {
    if (sections[i].is_image()) continue;  // its pixels are its sign points (pixel_signs)
    for (; k < section_end[i]; ++k) {
      const Sample& s = samples[k];
      if (s.contour || std::abs(s.value) < dist) continue;
      sp.g.push_back(s.g);
      sp.sign.push_back(s.value > 0 ? 1 : -1);
      sp.section.push_back(std::uint32_t(i));
      sp.pixel.push_back(kNoPixel);
    }
  }
  return sp;
}

/// The sign points on the wrong side of +-margin (cells) of the field x on lv.
std::vector<std::size_t> violated_signs(const SignPoints& sp, const Level& lv, const Eigen::VectorXd& x, double margin) {
  std::vector<std::uint8_t> bad(sp.g.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sp.g.size(), 4096), [&](const auto& rg) {
    for (std::size_t k = rg.begin(); k < rg.end(); ++k) bad[k] = sp.sign[k] * base_value(lv, x, sp.g[k]) < margin;
  });
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < bad.size(); ++k)
    if (bad[k]) out.push_back(k);
  return out;
}

/// Sign point k's penalty sample (target +-2 margin, sign_weight), made on
/// first use. sample_of[k]: point k's index in samples, -1 before.
Sample& penalty_sample(const SignPoints& sp, std::size_t k, const Field3dParams& p, std::vector<Sample>& samples,
                       std::vector<std::int64_t>& sample_of) {
  if (sample_of[k] < 0) {
    sample_of[k] = std::int64_t(samples.size());
    samples.push_back({sp.g[k], 2 * p.sign_margin * sp.sign[k], p.sign_weight / p.reweight_factor, false});
  }
  return samples[std::size_t(sample_of[k])];
}

/// One active-set step: each violated sign point's penalty sample is made
/// (weight sign_weight) or, already there, weighs reweight_factor times more.
void activate_signs(const SignPoints& sp, const std::vector<std::size_t>& violated, const Field3dParams& p,
                    std::vector<Sample>& samples, std::vector<std::int64_t>& sample_of) {
  for (const std::size_t k : violated) penalty_sample(sp, k, p, samples, sample_of).weight *= p.reweight_factor;
}

/// A guard penalty (sign_guard) counts as met while its point is short of the
/// margin by less than this share: a finite weight pulling to the margin leaves
/// the point just below it, which would re-activate it every pass. 0.1 and
/// 0.35 gave the 128 px sphere 4:1 and the 64 px ellipsoid and two-blobs 4:1
/// within 0.03 deg and 0.001 px of 0.2, whose 5-7 passes are the count without the guard.
constexpr double kGuardSlack = 0.2;

/// sign_guard's active-set step on the field x. An inactive point short of
/// the margin (s f < margin) becomes a penalty sample (sign_weight) pulling to
/// the margin while still on its drawn side (s f >= 0: a guard for the mesh,
/// the field agrees with the pixel) or to twice it on the wrong side; an
/// active one short of min(margin, (1 - kGuardSlack) target) weighs
/// reweight_factor times more; one beyond its target is released (weight 0,
/// made again when violated): a one-sided penalty, as the inequality, never
/// pulls the field back. Returns the violated points; with `apply` false, or
/// none violated, the samples are left as they are.
std::vector<std::size_t> guard_signs(const SignPoints& sp, const Level& lv, const Eigen::VectorXd& x, const Field3dParams& p,
                                     std::vector<Sample>& samples, std::vector<std::int64_t>& sample_of, bool apply) {
  const std::size_t n = sp.g.size();
  // 1: active and short; inactive and short: 2 on its drawn side (a guard), 3 on the wrong side; -1: to release
  std::vector<std::int8_t> state(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& rg) {
    for (std::size_t k = rg.begin(); k < rg.end(); ++k) {
      const double f = sp.sign[k] * base_value(lv, x, sp.g[k]);
      const Sample* s = sample_of[k] >= 0 ? &samples[std::size_t(sample_of[k])] : nullptr;
      if (s && s->weight > 0) {
        const double t = std::abs(s->value);
        if (f < std::min(p.sign_margin, (1 - kGuardSlack) * t)) state[k] = 1;
        else if (f > t) state[k] = -1;
      } else if (f < p.sign_margin) {
        state[k] = f >= 0 ? 2 : 3;
      }
    }
  });
  std::vector<std::size_t> violated;
  for (std::size_t k = 0; k < n; ++k)
    if (state[k] > 0) violated.push_back(k);
  if (!apply || violated.empty()) return violated;
  for (std::size_t k = 0; k < n; ++k) {
    if (state[k] == -1) samples[std::size_t(sample_of[k])].weight = 0;
    if (state[k] <= 0) continue;
    Sample& s = penalty_sample(sp, k, p, samples, sample_of);
    if (state[k] > 1) {
      s.value = (state[k] == 2 ? 1 : 2) * p.sign_margin * sp.sign[k];
      if (s.weight == 0) s.weight = p.sign_weight / p.reweight_factor;
    }
    s.weight *= p.reweight_factor;
  }
  return violated;
}

/// The sign points whose pixel the mesh draws on the wrong side (the mesh's
/// section by their image's plane, image_sections.h section_pixels): Marching
/// Cubes' surface is not the trilinear field's, so a small feature can pass
/// the field's check and still be lost.
std::vector<std::size_t> mesh_mismatches(const SignPoints& sp, const std::vector<Section>& sections, const TriMesh& mesh) {
  std::vector<Grid2u8> drawn(sections.size());
  tbb::parallel_for(std::size_t(0), sections.size(), [&](std::size_t i) {
    const Section& s = sections[i];
    if (s.is_image()) drawn[i] = section_pixels(mesh, s.pose, s.pixel_size, s.labels.width, s.labels.height);
  });
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < sp.g.size(); ++k)
    if (sp.pixel[k] != kNoPixel && (drawn[sp.section[k]].data[sp.pixel[k]] != 0) != (sp.sign[k] > 0)) out.push_back(k);
  return out;
}

/// Points the mesh misses: their penalty samples pull twice as far and weigh
/// reweight_factor times more (a new one: target +-4 margin, sign_weight).
void strengthen_signs(const SignPoints& sp, const std::vector<std::size_t>& missed, const Field3dParams& p,
                      std::vector<Sample>& samples, std::vector<std::int64_t>& sample_of) {
  for (const std::size_t k : missed) {
    Sample& s = penalty_sample(sp, k, p, samples, sample_of);
    s.value *= 2;
    if (s.weight == 0) s.weight = p.sign_weight / p.reweight_factor;  // released (sign_guard)
    s.weight *= p.reweight_factor;
  }
}

/// Marching Cubes of value(i, j, k) on fx x fy x fz nodes padded by a layer
/// of `outside` (closed, oriented), vertices in node units.
template <class F>
TriMesh march(int fx, int fy, int fz, double outside, const F& value) {
  const int W = fx + 2, Hh = fy + 2;
  MarchingCubes mc(W, Hh, -1, -1);
  for (int k = -1; k <= fz; ++k) {
    Grid2f plane(W, Hh, float(outside));
    if (k >= 0 && k < fz)
      tbb::parallel_for(0, fy, [&](int j) {
        for (int i = 0; i < fx; ++i) plane(i + 1, j + 1) = float(value(i, j, k));
      });
    mc.add_plane(std::move(plane), k);
  }
  return mc.finish();
}

/// The field on one level for `samples`, directly (the twin) or by
/// multigrid-preconditioned conjugate gradients warm from x; adds the
/// iterations to res. power: the multigrid's power-iteration starts, kept
/// from one solve on these grids to the next (null: a cold start); reuse:
/// its coarse operators, likewise (Multigrid); pull: the faces' -f (face_pull()).
void solve_level(const Level& lv, const std::vector<Sample>& samples, const Field3dParams& p, double pull, bool direct,
                 Eigen::VectorXd& x, Field3dResult& res, PowerStart* power = nullptr, CoarseReuse* reuse = nullptr) {
  const Operator A(lv, samples, p, pull);
  if (direct) {
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A.assemble());
    if (ldlt.info() != Eigen::Success) throw Error("field3d: the direct factorisation failed");
    x = ldlt.solve(A.rhs());
    Eigen::VectorXd Ax;
    A.apply(x, Ax);
    res.residual = (Ax - A.rhs()).norm() / A.rhs().norm();
    return;
  }
  const Multigrid M(lv, A, samples, p, power, reuse);
  const int it = preconditioned_cg(A, M, x, p.tolerance, p.max_iterations, res.residual);
  res.iterations += it;
  res.finest_iterations = it;
  res.multigrid_levels = M.levels();
}

}  // namespace

/// Closed components of `mesh` with positive volume that enclose none of
/// `inside` (points drawn inside) are removed. Returns how many. Inside test:
/// parity of the crossings of the ray from the point along +x with the
/// component's triangles.
std::size_t prune_unsupported(TriMesh& mesh, const std::vector<Vec3d>& inside) {
  const std::size_t V = mesh.vertices.size(), T = mesh.triangles.size();
  if (T == 0) return 0;
  std::vector<std::int32_t> parent(V);
  for (std::size_t v = 0; v < V; ++v) parent[v] = std::int32_t(v);
  const auto find = [&](std::int32_t v) {
    while (parent[std::size_t(v)] != v) v = parent[std::size_t(v)] = parent[std::size_t(parent[std::size_t(v)])];
    return v;
  };
  for (const auto& t : mesh.triangles)
    for (int c = 1; c < 3; ++c) {
      const std::int32_t a = find(t[0]), b = find(t[std::size_t(c)]);
      if (a != b) parent[std::size_t(a)] = b;
    }
  std::vector<std::int32_t> comp_of(V, -1);
  std::vector<std::vector<std::size_t>> tris;
  std::vector<std::size_t> comp(T);
  for (std::size_t t = 0; t < T; ++t) {
    const std::int32_t root = find(mesh.triangles[t][0]);
    if (comp_of[std::size_t(root)] < 0) {
      comp_of[std::size_t(root)] = std::int32_t(tris.size());
      tris.emplace_back();
    }
    comp[t] = std::size_t(comp_of[std::size_t(root)]);
    tris[comp[t]].push_back(t);
  }
  if (tris.size() == 1) return 0;
  const auto vtx = [&](std::int32_t i) { return mesh.vertices[std::size_t(i)].cast<double>(); };
  std::vector<std::uint8_t> keep(tris.size(), 1);
  std::size_t removed = 0;
  for (std::size_t c = 0; c < tris.size(); ++c) {
    double vol = 0;
    Vec3d lo = Vec3d::Constant(kInf), hi = Vec3d::Constant(-kInf);
    for (std::size_t t : tris[c]) {
      const auto& tr = mesh.triangles[t];
      const Vec3d a = vtx(tr[0]), b = vtx(tr[1]), d = vtx(tr[2]);
      vol += a.dot(b.cross(d)) / 6;
      lo = lo.cwiseMin(a).cwiseMin(b).cwiseMin(d);
      hi = hi.cwiseMax(a).cwiseMax(b).cwiseMax(d);
    }
    if (vol <= 0) continue;  // a cavity's shell: not an inside component
    bool supported = false;
    // Points on an axis-aligned input plane can share a coordinate with
    // vertices on the grid's lines: nudged off by an irrational-ish 1e-7 of
    // the component's size (far below any sample's distance to the surface).
    const Vec3d nudge = Vec3d(0.7071067, 1.7320508, 2.2360679) * 1e-7 * (hi - lo).norm();
    for (const Vec3d& p0 : inside) {
      const Vec3d p = p0 + nudge;
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
      int crossings = 0;
      for (std::size_t t : tris[c]) {
        const auto& tr = mesh.triangles[t];
        const Vec3d a = vtx(tr[0]), b = vtx(tr[1]), d = vtx(tr[2]);
        if (std::max({a.x(), b.x(), d.x()}) < p.x()) continue;
        // (y, z) of p inside the projected triangle: edge functions, half-open ties.
        const auto edge = [&](const Vec3d& e0, const Vec3d& e1) {
          return (e1.y() - e0.y()) * (p.z() - e0.z()) - (e1.z() - e0.z()) * (p.y() - e0.y());
        };
        const double w0 = edge(b, d), w1 = edge(d, a), w2 = edge(a, b);
        const bool pos = w0 > 0 && w1 > 0 && w2 > 0, neg = w0 < 0 && w1 < 0 && w2 < 0;
        if (!pos && !neg) continue;
        const double s = w0 + w1 + w2;
        const double x = (w0 * a.x() + w1 * b.x() + w2 * d.x()) / s;
        if (x > p.x()) ++crossings;
      }
      if (crossings % 2 == 1) {
        supported = true;
        break;
      }
    }
    if (!supported) {
      keep[c] = 0;
      ++removed;
    }
  }
  if (removed == 0) return 0;
  TriMesh out;
  std::vector<std::int32_t> remap(V, -1);
  for (std::size_t t = 0; t < T; ++t) {
    if (!keep[comp[t]]) continue;
    std::array<std::int32_t, 3> nt{};
    for (int c = 0; c < 3; ++c) {
      const auto v = std::size_t(mesh.triangles[t][std::size_t(c)]);
      if (remap[v] < 0) {
        remap[v] = std::int32_t(out.vertices.size());
        out.vertices.push_back(mesh.vertices[v]);
      }
      nt[std::size_t(c)] = remap[v];
    }
    out.triangles.push_back(nt);
  }
  mesh = std::move(out);
  return removed;
}

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

/// The label's polylines per section (checked) and the finest grid around
/// them: cells a multiple of 2^(levels-1) per axis, centred on the box. Along
/// the normal of a parallel stack (every section normal to one grid axis) the
/// solve's spacing is wider: step cells, the planes' spacing or a divisor of
/// it, every plane on a node; the field is then sampled back at spacing h
/// along that axis for the mesh (out_nodes).
struct SectionGrid {
  std::vector<std::vector<Polyline>> polys;  ///< per section
  Vec3d contour_lo = Vec3d::Zero(), contour_hi = Vec3d::Zero();  ///< the label's contours' box, mm
  double diag = 0;                           ///< the box's diagonal (contours' or Field3dParams::box), mm
  Vec3d origin = Vec3d::Zero(), box_hi = Vec3d::Zero();  ///< the grid's corners, mm
  double h = 0;                              ///< finest spacing, mm
  Vec3d step = Vec3d::Ones();                ///< the solve's spacing per axis, finest cells
  int stack_axis = -1;                       ///< the axis whose step is above 1, or -1
  std::array<int, 3> cells{};                ///< the solve's cells per axis (each of its step)
  std::array<int, 3> out_nodes{};            ///< the field's and the mesh's nodes per axis (spacing h)
  [[nodiscard]] std::array<int, 3> nodes() const { return {cells[0] + 1, cells[1] + 1, cells[2] + 1}; }
};

/// Section planes closer than this share a height (cells; far below a pixel).
constexpr double kSameHeight = 1e-6;
/// Fixed-point steps for the cell size under a band margin: each shrinks the error by 2 band_margin band /
/// resolution (< 1), so 100 reach double precision unless the margin takes nearly every cell.
constexpr int kMarginIterations = 100;
/// A stack's plane gaps are multiples of the smallest gap within this share
/// of it (readers place slices at k times a spacing; 1e-3 absorbs rounding in
/// the positions, not a missing slice's half-step).
constexpr double kGapMultiple = 1e-3;
/// The stack's spacing is used along its normal only from this many finest
/// cells up: below it the grid shrinks by less than a third.
constexpr double kMinStackStep = 1.5;

/// The parallel stack's axis (every section's normal along one grid axis,
/// the planes' gaps multiples of the smallest) and its solve spacing in mm:
/// the smallest gap divided into as few steps as keep each at most
/// stack_spacing cells of h. {-1, h} when the sections are no such stack.
std::pair<int, double> stack_step(const std::vector<Section>& sections, double h, const Field3dParams& params) {
  const std::pair<int, double> none{-1, h};
  if (params.stack_spacing <= 1 || params.refinement > 1 || sections.size() < 2) return none;
  const Vec3d n0 = sections[0].pose.normal();
  int axis = -1;
  n0.cwiseAbs().maxCoeff(&axis);
  if (std::abs(n0[axis]) < 1 - 1e-12) return none;
  std::vector<double> heights;
  for (const Section& s : sections) {
    if (std::abs(s.pose.normal()[axis]) < 1 - 1e-12) return none;
    heights.push_back(s.pose.origin[axis]);
  }
  std::sort(heights.begin(), heights.end());
  double gap = kInf;
  for (std::size_t i = 1; i < heights.size(); ++i)
    if (heights[i] - heights[i - 1] > kSameHeight * h) gap = std::min(gap, heights[i] - heights[i - 1]);
  if (!std::isfinite(gap)) return none;
  for (std::size_t i = 1; i < heights.size(); ++i) {
    const double m = (heights[i] - heights[0]) / gap;
    if (std::abs(m - std::round(m)) > kGapMultiple) return none;
  }
  const double step = gap / std::ceil(gap / (params.stack_spacing * h));
  if (step < kMinStackStep * h) return none;
  return {axis, step};
}

SectionGrid section_grid(const std::vector<Section>& sections, std::uint32_t label, const Field3dParams& params) {
  SectionGrid g;
  g.polys.resize(sections.size());
  Vec3d lo = Vec3d::Constant(kInf), hi = Vec3d::Constant(-kInf);
  for (std::size_t i = 0; i < sections.size(); ++i) {
    const Section& sec = sections[i];
    const std::string name = section_name(sections, i);
    if (!sec.pose.orthonormal(1e-6) || !sec.pose.origin.allFinite())
      throw InputError(name, "the plane's axes are not orthonormal or its origin is not finite");
    if (sec.is_image() && (!(sec.pixel_size > 0) || !std::isfinite(sec.pixel_size)))
      throw InputError(name, "the label image's pixel size is not positive and finite");
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
      g.polys[i].push_back(con.points);
    }
  }
  if (!(lo.array() <= hi.array()).all())
    throw InputError("", "no section holds a contour of label " + std::to_string(label));
  g.contour_lo = lo;
  g.contour_hi = hi;
  if (params.box) {  // a given box: the contours' box replaced (it must hold them; the caller's)
    lo = (*params.box)[0];
    hi = (*params.box)[1];
  }
  g.diag = (hi - lo).norm();
  if (!(g.diag > 0)) throw InputError("", "the contours of label " + std::to_string(label) + " span no extent");
  // Cells of the margined box's longest side / resolution, the band margin in those cells: the fixed point
  // h = f(h) (a contraction: the band margins on two sides take 2 band_margin band of the resolution's cells).
  if (params.band_margin > 0 && params.resolution <= 2 * params.band_margin * params.band)
    throw ParamError("field3d.band_margin: " + std::to_string(params.resolution) + " cells leave none inside a margin of " +
                     std::to_string(params.band_margin * params.band) + " cells on each side (raise resolution or lower band_margin)");
  const double gap = params.band_margin > 0 ? median_gap(sections) : 0;  // once: the fixed point's steps reuse it
  const auto margined = [&](double cell) {
    const std::array<Vec3d, 2> m = box_margins(params, sections, {lo, hi}, cell, gap);
    return std::pair<Vec3d, Vec3d>{(hi - lo) + m[0] + m[1], (m[1] - m[0]) / 2};
  };
  auto [ext, shift] = margined(0);
  g.h = ext.maxCoeff() / params.resolution;
  for (int it = 0; it < kMarginIterations && params.band_margin > 0; ++it) {
    std::tie(ext, shift) = margined(g.h);
    const double next = ext.maxCoeff() / params.resolution;
    const bool done = std::abs(next - g.h) <= 1e-12 * next;
    g.h = next;
    if (done) break;
  }
  const int unit = 1 << (params.levels - 1);
  for (int a = 0; a < 3; ++a) g.cells[a] = std::max(2, int(std::ceil(ext[a] / g.h / unit))) * unit;
  g.origin = (lo + hi) / 2 + shift - g.h / 2 * Vec3d(g.cells[0], g.cells[1], g.cells[2]);
  g.box_hi = g.origin + g.h * Vec3d(g.cells[0], g.cells[1], g.cells[2]);
  g.out_nodes = g.nodes();
  const auto [axis, step] = stack_step(sections, g.h, params);
  if (axis >= 0) {  // the stack's planes on nodes, the box as wide as before along its normal
    const double z0 = sections[0].pose.origin[axis], lo_a = (lo[axis] + hi[axis] - ext[axis]) / 2 + shift[axis];
    g.stack_axis = axis;
    g.step[axis] = step / g.h;
    g.origin[axis] = z0 - step * std::ceil((z0 - lo_a) / step - kSameHeight);
    g.cells[axis] = std::max(2, int(std::ceil((lo_a + ext[axis] - g.origin[axis]) / step / unit - kSameHeight))) * unit;
    g.box_hi[axis] = g.origin[axis] + step * g.cells[axis];
    g.out_nodes[axis] = int(std::floor(g.cells[axis] * g.step[axis] + kSameHeight)) + 1;
  }
  return g;
}

double median_gap(const std::vector<Section>& sections) {
  std::vector<double> gaps;
  for (std::size_t i = 0; i < sections.size(); ++i) {
    const PlanePose& pose = sections[i].pose;
    double g = kInf;
    for (std::size_t j = 0; j < sections.size(); ++j)
      if (j != i && parallel_planes(sections[j].pose, pose)) {
        const double o = std::abs(pose.height(sections[j].pose.origin));
        if (o > 0) g = std::min(g, o);
      }
    if (g < kInf) gaps.push_back(g);
  }
  if (gaps.empty()) return 0;
  std::nth_element(gaps.begin(), gaps.begin() + std::ptrdiff_t(gaps.size() / 2), gaps.end());
  return gaps[gaps.size() / 2];
}

/// A plane's sample raster over the box [lo, hi]: the points pmin + sp (k, j),
/// k < ns, j < nt, in-plane mm (those outside the box are dropped).
struct PlaneRaster {
  Vec2d pmin = Vec2d::Zero();
  int ns = 0, nt = 0;
};

PlaneRaster plane_raster(const PlanePose& pose, const Vec3d& lo, const Vec3d& hi, double sp) {
  Vec2d pmin = Vec2d::Constant(kInf), pmax = Vec2d::Constant(-kInf);
  for (int c = 0; c < 8; ++c) {
    const Vec2d q = pose.to_plane(Vec3d(c & 1 ? hi.x() : lo.x(), c & 2 ? hi.y() : lo.y(), c & 4 ? hi.z() : lo.z()));
    pmin = pmin.cwiseMin(q);
    pmax = pmax.cwiseMax(q);
  }
  return {pmin, int(std::floor((pmax.x() - pmin.x()) / sp)) + 1, int(std::floor((pmax.y() - pmin.y()) / sp)) + 1};
}

/// Least factor 1/sqrt(1 + s^2) of plane_slope: a slope of 4 (the surface within 14 deg of the plane), so that
/// a cap's empty neighbour section does not flatten the data to nothing.
inline constexpr double kMinSlopeFactor = 0.25;

/// Section i's in-plane distances `dists[i]` scaled by 1/sqrt(1 + s^2), s the change of the in-plane distance
/// per mm along i's normal between the nearest parallel sections on either side (central difference, one-sided
/// with one neighbour, none without), each read bilinearly at the sample's projection (outside its raster:
/// -band). For a surface with normal n, the in-plane distance is the 3D distance over |n_plane| = 1/sqrt(1 +
/// s^2): this is the 3D distance to first order, whose bi-Laplacian interpolation between planes has no bias
/// (a sphere's distance is biharmonic), while the in-plane distance's in-plane Laplacian bends the field
/// inward between planes on convex shapes.
Grid2d slope_corrected(const std::vector<Section>& sections, const std::vector<PlaneRaster>& rasters,
                       const std::vector<Grid2d>& dists, std::size_t i, double sp, double band) {
  const PlanePose& pose = sections[i].pose;
  std::array<std::ptrdiff_t, 2> nb{-1, -1};  // nearest below, above
  std::array<double, 2> off{-kInf, kInf};
  for (std::size_t j = 0; j < sections.size(); ++j) {
    if (j == i || !parallel_planes(sections[j].pose, pose)) continue;
    const double o = pose.height(sections[j].pose.origin);
    if (o < 0 && o > off[0]) off[0] = o, nb[0] = std::ptrdiff_t(j);
    if (o > 0 && o < off[1]) off[1] = o, nb[1] = std::ptrdiff_t(j);
  }
  Grid2d d = dists[i];
  if (nb[0] < 0 && nb[1] < 0) return d;
  const auto read = [&](std::size_t j, const Vec3d& w) {
    const PlaneRaster& r = rasters[j];
    const Vec2d q = (sections[j].pose.to_plane(w) - r.pmin) / sp;
    const int a = int(std::floor(q.x())), b = int(std::floor(q.y()));
    if (a < 0 || b < 0 || a + 1 >= r.ns || b + 1 >= r.nt) return -band;
    const double fx = q.x() - a, fy = q.y() - b;
    const Grid2d& g = dists[j];
    return (1 - fy) * ((1 - fx) * g(a, b) + fx * g(a + 1, b)) + fy * ((1 - fx) * g(a, b + 1) + fx * g(a + 1, b + 1));
  };
  const PlaneRaster& r = rasters[i];
  for (int t = 0; t < r.nt; ++t)
    for (int k = 0; k < r.ns; ++k) {
      const Vec3d w = pose.to_world({r.pmin.x() + k * sp, r.pmin.y() + t * sp});
      const double d0 = dists[i](k, t);
      double s = 0;
      if (nb[0] >= 0 && nb[1] >= 0)
        s = (read(std::size_t(nb[1]), w) - read(std::size_t(nb[0]), w)) / (off[1] - off[0]);
      else if (nb[0] >= 0)
        s = (d0 - read(std::size_t(nb[0]), w)) / -off[0];
      else
        s = (read(std::size_t(nb[1]), w) - d0) / off[1];
      d(k, t) = d0 * std::max(kMinSlopeFactor, 1 / std::sqrt(1 + s * s));
    }
  return d;
}

/// b of the energy (cells): the band, or boundary_slope x the grid faces' least distance to the contours' box
/// if less, so f falls beyond the contours no steeper than boundary_slope per cell (docs/decisions.md: field3d
/// pixel input: the box a band beyond the contours). `p` with band_per_gap applied.
/// @warning Labels solved on one box (Field3dParams::box, a partition's group) keep the band: at slope 1.5
/// two touching half-balls' fields were both slightly negative on a ring of their shared face, which the
/// partition's rule (field3d/partition3d.h) meshes as two faces apart (16 of 57 shared vertices).
double face_pull(const Field3dParams& p, const SectionGrid& g) {
  if (p.boundary_slope <= 0 || p.box) return p.band;
  const Vec3d below = (g.contour_lo - g.origin) / g.h, above = (g.box_hi - g.contour_hi) / g.h;
  return std::min(p.band, p.boundary_slope * std::min(below.minCoeff(), above.minCoeff()));
}

}  // namespace detail

Field3dStats solve_stats(const Field3dResult& r, const std::vector<Field3dPlaneResidual>* planes) {
  Field3dStats s;
  s.grid = {r.nx, r.ny, r.nz};
  s.solve_nodes = r.solve_nodes;
  s.samples = r.samples;
  s.iterations = r.iterations;
  s.finest_iterations = r.finest_iterations;
  s.multigrid_levels = r.multigrid_levels;
  s.relative_residual = r.residual;
  s.sign_points = r.sign_points;
  s.sign_active = r.sign_active;
  s.sign_violated = r.sign_violated;
  s.sign_passes = r.sign_passes;
  s.conflicts = r.conflicts.size();
  for (const Field3dConflict& c : r.conflicts) s.largest_conflict = std::max(s.largest_conflict, c.size);
  for (const Field3dPlaneResidual& p : planes ? *planes : r.planes) {
    ++s.planes;
    s.mesh_to_drawn = std::max(s.mesh_to_drawn, p.mesh_to_drawn);
    s.drawn_to_mesh = std::max(s.drawn_to_mesh, p.drawn_to_mesh);
  }
  s.seconds = r.seconds;
  return s;
}

Field3dParams model_scaled(const Field3dParams& p, const std::vector<Section>& sections) {
  if (p.model_resolution <= 0 || std::any_of(sections.begin(), sections.end(), [](const Section& s) { return s.is_image(); }))
    return p;
  // With f in cells, the smoothness term goes as 1/h, the plane, sign and box terms as 1/h^4 and the contour term
  // as 1/h^3 of the continuous integrals: rho^3 on the smoothness and rho on the contour weight keep their ratios.
  const double rho = double(p.resolution) / p.model_resolution;
  Field3dParams q = p;
  q.smoothness *= rho * rho * rho;
  q.contour_weight *= rho;
  q.band *= rho;
  q.sign_margin *= rho;
  q.plane_sign_distance *= rho;
  q.conflict_tolerance *= rho;
  return q;
}

double band_margin_mm(const Field3dParams& p, double cell, double gap) {
  return p.band_margin * std::max(p.band * cell, p.band_per_gap * gap);
}

std::array<Vec3d, 2> box_margins(const Field3dParams& p, const std::vector<Section>& sections,
                                 const std::array<Vec3d, 2>& box, double cell, double gap) {
  const auto& [lo, hi] = box;
  const double m0 = p.margin * (hi - lo).norm();
  std::array<Vec3d, 2> m{Vec3d::Constant(m0), Vec3d::Constant(m0)};
  if (p.band_margin <= 0 || sections.empty()) return m;
  const double band = std::max(m0, band_margin_mm(p, cell, gap));
  m = {Vec3d::Constant(band), Vec3d::Constant(band)};
  // A parallel stack normal to a world axis: an outermost plane beyond the contours (an empty slice) closes
  // that end, and the box keeps its margin there.
  int axis = -1;
  sections[0].pose.normal().cwiseAbs().maxCoeff(&axis);
  double below = std::numeric_limits<double>::infinity(), above = -below;
  for (const Section& s : sections) {
    if (std::abs(s.pose.normal()[axis]) < 1 - 1e-12) return m;
    below = std::min(below, s.pose.origin[axis]);
    above = std::max(above, s.pose.origin[axis]);
  }
  const double tol = 1e-9 * (hi - lo).norm();
  if (below < lo[axis] - tol) m[0][axis] = m0;
  if (above > hi[axis] + tol) m[1][axis] = m0;
  return m;
}

Field3dParams sparse_base(const Field3dParams& p) {
  if (p.base_resolution <= 0 || p.refinement > 1 || p.resolution <= p.base_resolution) return p;
  Field3dParams q = p;
  q.refinement = (p.resolution + 1) / 2 <= p.base_resolution ? 2 : 4;
  q.resolution = (p.resolution + q.refinement - 1) / q.refinement;
  return q;
}

Field3dResult reconstruct_sections(const std::vector<Section>& sections, std::uint32_t label,
                                   const Field3dParams& params_given) {
  using namespace detail;
  const auto start = std::chrono::steady_clock::now();
  params_table<Field3dParams>().validate(params_given);
  const Field3dParams params_in = sparse_base(params_given);
  Field3dResult res;

  const SectionGrid grid = section_grid(sections, label, params_in);
  Field3dParams params = model_scaled(params_in, sections);
  const double gap = median_gap(sections) / grid.h;  // cells
  if (params.band_per_gap > 0) params.band = std::max(params.band, params.band_per_gap * gap);
  // The planes' data per unit volume falls as 1 / gap against the bi-Laplacian's: plane_weight_per_gap keeps it.
  params.plane_weight = std::max(params.plane_weight, params.plane_weight_per_gap * gap);
  const double pull = face_pull(params, grid);
  const std::vector<std::vector<Polyline>>& polys = grid.polys;
  const double diag = grid.diag, h = grid.h;
  const std::array<int, 3>& cells = grid.cells;
  const Vec3d box_hi = grid.box_hi;
  res.spacing = h;
  res.origin = grid.origin;
  res.nx = grid.out_nodes[0];
  res.ny = grid.out_nodes[1];
  res.nz = grid.out_nodes[2];
  res.solve_nodes = grid.nodes();
  res.solve_spacing = h * grid.step;
  const std::size_t solve_size = std::size_t(res.solve_nodes[0]) * res.solve_nodes[1] * res.solve_nodes[2];
  if (params.direct && solve_size > kMaxDirectNodes)
    throw ParamError("field3d.direct: the grid has " + std::to_string(solve_size) + " nodes, more than the direct twin's " +
                     std::to_string(kMaxDirectNodes));

  // Samples: every plane's raster inside the box, and along every contour, at
  // spacing sp (mm); positions in base cells; `keep` filters them (the band).
  const double band = params.band * h;
  std::vector<std::size_t> section_end;  // per section: one past its samples in make_samples' result
  const auto make_samples = [&](double sp, const auto& keep) {
    std::vector<std::vector<Sample>> per(sections.size());
    std::vector<PlaneRaster> rasters(sections.size());
    const auto distances = [&](std::size_t i) {
      return signed_distance_raster(polys[i], rasters[i].pmin.x(), rasters[i].pmin.y(), sp, rasters[i].ns,
                                    rasters[i].nt, band);
    };
    for (std::size_t i = 0; i < sections.size(); ++i) rasters[i] = plane_raster(sections[i].pose, res.origin, box_hi, sp);
    // plane_slope reads the neighbours' distances: every section's held at once only then.
    std::vector<Grid2d> dists(params.plane_slope ? sections.size() : 0);
    if (params.plane_slope) tbb::parallel_for(std::size_t(0), sections.size(), [&](std::size_t i) { dists[i] = distances(i); });
    tbb::parallel_for(std::size_t(0), sections.size(), [&](std::size_t i) {
      const PlanePose& pose = sections[i].pose;
      const auto [pmin, ns, nt] = rasters[i];
      const Grid2d d = params.plane_slope ? slope_corrected(sections, rasters, dists, i, sp, band) : distances(i);
      const double eps = 1e-9 * h;
      const double wplane = params.plane_weight * (sp / h) * (sp / h);
      auto& out = per[i];
      for (int j = 0; j < nt; ++j)
        for (int k = 0; k < ns; ++k) {
          const Vec3d w = pose.to_world({pmin.x() + k * sp, pmin.y() + j * sp});
          if ((w.array() < res.origin.array() - eps).any() || (w.array() > box_hi.array() + eps).any()) continue;
          const Vec3d g = (w - res.origin) / h;
          if (keep(g)) out.push_back({g, d(k, j) / h, wplane, false});
        }
      if (params.contour_weight > 0)
        for (const auto& poly : polys[i])
          for (std::size_t e = 0; e < poly.size(); ++e) {
            const Vec2d& a = poly[e];
            const Vec2d& b = poly[(e + 1) % poly.size()];
            const double len = (b - a).norm();
            const int pieces = std::max(1, int(std::ceil(len / sp)));
            for (int q = 0; q < pieces; ++q) {
              const Vec3d g = (pose.to_world(a + (b - a) * ((q + 0.5) / pieces)) - res.origin) / h;
              if (keep(g)) out.push_back({g, 0.0, params.contour_weight * len / pieces / h, true});
            }
          }
    });
    std::vector<Sample> all;
    section_end.clear();
    for (auto& v : per) {
      all.insert(all.end(), v.begin(), v.end());
      section_end.push_back(all.size());
    }
    return all;
  };
  std::vector<Sample> samples = make_samples(params.sample_spacing * h, [](const Vec3d&) { return true; });
  const std::vector<std::size_t> base_section_end = section_end;
  res.samples = samples.size();
  const double miss_tol = params.reweight_tolerance * diag / h;  // cells
  const bool refine = params.refinement > 1;

  // Solve: coarse to fine by conjugate gradients, or directly on the finest grid.
  std::vector<Level> levels;
  for (int l = params.levels - 1; l >= 0; --l) {
    const int f = 1 << l;
    if (params.direct && l > 0 && !refine) continue;
    levels.push_back({cells[0] / f + 1, cells[1] / f + 1, cells[2] / f + 1, double(f) * grid.step});
  }
  Eigen::VectorXd x;
  // The base grid's multigrid power-iteration starts, kept for its re-solves.
  PowerStart power;
  for (std::size_t l = 0; l < levels.size(); ++l) {
    // Without a band the base grid is the last: its passes re-weight missed samples.
    const bool last = l + 1 == levels.size();
    const int passes = last && !refine ? params.reweight_passes : 0;
    for (int pass = 0; pass <= passes; ++pass) {
      const bool direct = params.direct && !refine;
      if (!direct && pass == 0)  // later passes start from the previous solution
        x = l == 0 ? Eigen::VectorXd::Constant(Eigen::Index(levels[l].size()), -params.band)
                   : prolong(levels[l - 1], x, levels[l]);
      solve_level(levels[l], samples, params, pull, direct, x, res, last ? &power : nullptr);
      if (pass == passes) break;
      std::vector<std::size_t> all(samples.size());
      for (std::size_t s = 0; s < all.size(); ++s) all[s] = s;
      // A contour sample's distance to the zero set: |f| over |grad f| (f is
      // no distance where the field is flat: |f| alone hid misses of 0.6 cells).
      const std::size_t raised = reweight(
          samples, all,
          [&](std::size_t k) {
            const Vec3d& g = samples[k].g;
            const double f = base_value(levels[l], x, g);
            if (!samples[k].contour) return f;
            Vec3d grad;
            for (int a = 0; a < 3; ++a)
              grad[a] = base_value(levels[l], x, g + 0.5 * Vec3d::Unit(a)) - base_value(levels[l], x, g - 0.5 * Vec3d::Unit(a));
            return f / std::max(grad.norm(), kFlatGradient);
          },
          miss_tol, params.reweight_factor);
      res.reweighted += raised;
      if (raised == 0) break;
    }
  }
  const Level& base = levels.back();
  // The field at one cell along every axis (a parallel stack's solve splined back along its normal).
  const auto store_field = [&] {
    if (grid.stack_axis >= 0) res.field = spline_along(base, x, grid.stack_axis, grid.out_nodes[std::size_t(grid.stack_axis)]);
    else res.field.assign(x.data(), x.data() + x.size());
  };

  // Pixel input: the active set of sign constraints at the label images' pixel centres.
  const std::size_t sign_first = samples.size();
  std::optional<SignPoints> signs;
  std::vector<std::int64_t> sign_sample;  // per sign point: its penalty sample, -1 while inactive
  // One active-set re-solve on the base grid, conjugate gradients warm from
  // the previous solution x, the multigrid's power iterations from the last
  // solve's, its coarse operators updated for the penalty samples.
  CoarseReuse reuse{sign_first, {}, {}};
  const auto sign_solve = [&](bool direct) {
    const int before = res.iterations;
    solve_level(base, samples, params, pull, direct, x, res, &power, &reuse);
    res.sign_iterations += res.iterations - before;
    ++res.sign_passes;
  };
  const auto seconds_since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  const auto signs_start = std::chrono::steady_clock::now();
  if (params.pixel_signs) signs = sign_points(sections, label, res.origin, box_hi, h);
  if (params.plane_signs) {
    if (!signs) signs.emplace();
    signs->append(plane_sign_points(sections, samples, base_section_end, params.plane_sign_distance));
  }
  if (signs && signs->g.empty()) signs.reset();
  if (signs) {
    res.sign_points = signs->g.size();
    sign_sample.assign(signs->g.size(), -1);
    for (int pass = 0;; ++pass) {
      const bool last = pass == params.sign_passes;
      const std::vector<std::size_t> violated =
          params.sign_guard ? guard_signs(*signs, base, x, params, samples, sign_sample, !last)
                            : violated_signs(*signs, base, x, params.sign_margin);
      res.sign_violated = violated.size();
      if (violated.empty() || last) break;
      if (!params.sign_guard) activate_signs(*signs, violated, params, samples, sign_sample);
      sign_solve(params.direct && !refine);
    }
    res.sign_active = samples.size() - sign_first;
  }
  if (refine) reuse = {};  // no more base-grid solves: the band's memory without the coarse blocks
  res.sign_seconds = seconds_since(signs_start);
  store_field();

  // The band: re-solved on the grid `refinement` times finer near the surface.
  Band bd;
  Eigen::VectorXd z;
  if (refine) {
    const int r = params.refinement;
    if (r != 2 && r != 4) throw ParamError("field3d.refinement: must be 1, 2 or 4, got " + std::to_string(r));
    bd = make_band(base, x, samples, r, int(std::ceil(params.refine_width)));
    z = band_prolong(bd, base, x);
    std::vector<Sample> fine = make_samples(params.sample_spacing * h / r, [&](const Vec3d& g) {
      const Vec3d q = g * r;
      const std::int64_t n = bd.node(int(std::floor(q.x())), int(std::floor(q.y())), int(std::floor(q.z())));
      return n >= 0;
    });
    for (std::size_t k = sign_first; k < samples.size(); ++k) {  // the active sign constraints in the band
      const Vec3d q = samples[k].g * r;
      if (bd.node(int(std::floor(q.x())), int(std::floor(q.y())), int(std::floor(q.z()))) >= 0) fine.push_back(samples[k]);
    }
    res.band_nodes = bd.size();
    res.band_unknowns = std::size_t(std::count(bd.unknown.begin(), bd.unknown.end(), std::uint8_t(1)));
    for (int pass = 0; pass <= params.reweight_passes; ++pass) {
      const BandOperator A(bd, fine, params);
      if (params.direct) {
        res.residual = band_direct(A, bd, z);
      } else {
        const int it = preconditioned_cg(A, BandMultigrid(bd, A, fine, params), z, params.tolerance,
                                         params.max_iterations, res.residual);
        res.band_iterations += it;
      }
      if (pass == params.reweight_passes) break;
      const std::size_t raised = reweight(
          fine, A.sample_index(), [&](std::size_t k) { return A.at_sample(k, z); }, miss_tol, params.reweight_factor);
      res.reweighted += raised;
      if (raised == 0) break;
    }
  }

  // Mesh: the field padded with a layer of outside samples, so the surface
  // closes; on the band's grid, the band's values where stored and the base
  // field prolonged elsewhere (no zero there: those cells hold no sign change).
  const auto base_mesh = [&] {
    TriMesh m = march(res.nx, res.ny, res.nz, -params.band, [&](int i, int j, int k) {
      return res.field[std::size_t(i) + std::size_t(res.nx) * (std::size_t(j) + std::size_t(res.ny) * std::size_t(k))];
    });
    for (Vec3f& v : m.vertices) v = (res.origin + h * v.cast<double>()).cast<float>();
    return m;
  };
  // Pixel input: the pixels the mesh itself draws wrong, put back (the base grid's mesh).
  const auto mesh_signs_start = std::chrono::steady_clock::now();
  // Only pixel sign points have a drawn image to compare the mesh with.
  const bool mesh_checks = signs && std::any_of(signs->pixel.begin(), signs->pixel.end(),
                                                [](std::uint32_t px) { return px != kNoPixel; });
  for (int pass = 0; mesh_checks && !refine && pass < params.sign_passes; ++pass) {
    const std::vector<std::size_t> missed = mesh_mismatches(*signs, sections, base_mesh());
    res.sign_violated = missed.size();
    if (missed.empty()) break;
    strengthen_signs(*signs, missed, params, samples, sign_sample);
    sign_solve(params.direct);
    store_field();
  }
  res.sign_seconds += seconds_since(mesh_signs_start);
  if (signs) res.sign_active = samples.size() - sign_first;
  reuse = {};
  if (!refine) {
    res.mesh = base_mesh();
  } else {
    const int r = params.refinement;
    res.mesh = march(r * (res.nx - 1) + 1, r * (res.ny - 1) + 1, r * (res.nz - 1) + 1, -params.band, [&](int i, int j, int k) {
      const std::int64_t n = bd.node(i, j, k);
      return n >= 0 ? z[Eigen::Index(n)] : base_value(base, x, Vec3d(i, j, k) / r);
    });
    for (Vec3f& v : res.mesh.vertices) v = (res.origin + h / r * v.cast<double>()).cast<float>();
  }
  if (params.prune) {
    std::vector<Vec3d> inside;
    for (const Sample& s : samples)
      if (!s.contour && s.value > 0) inside.push_back(res.origin + h * s.g);
    res.pruned_components = prune_unsupported(res.mesh, inside);
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

namespace {

// field3d's work estimate (estimate_sections()): bytes per item held at the
// finest solve, counted from the solver's data structures; measured against
// peak RSS in docs/decisions.md (field3d work estimate).
/// Per finest node: the solution and CG's r, A p, z, p; the operator's
/// right-hand side, diagonal and Laplacian; the V-cycle's three work vectors
/// (doubles), and the transposed gather's offsets (uint32).
constexpr double kBytesPerNode = 11 * 8 + 4;
/// Per coarse multigrid node: diagonal, Laplacian, restricted residual,
/// correction and three work vectors (doubles), and the cell's block slot.
constexpr double kBytesPerCoarseNode = 7 * 8 + 4;
/// Per coarse cell holding samples: its packed float block (CellOperator).
constexpr double kBytesPerBlock = 36 * 4;
/// Per sample: the Sample (48) and the finest operator's 8 node indices,
/// 8 weights, weight, 8 transposed entries and residual (144).
constexpr double kBytesPerSample = 48 + 144;
/// Marching Cubes triangles per cell^2 of surface (2 on a face-parallel
/// plane, more on oblique ones): synthetic spheres on 97-185 node grids got
/// 1.01-1.03 times the estimate; armadillo and frog organs 0.69-0.81 (their
/// boxes' ellipsoids overstate their area).
constexpr double kTrianglesPerCellArea = 3;
/// Per triangle: the mesh (vertices and triangles), the mesh check's edge
/// map and the pruning's components.
constexpr double kMeshBytesPerTriangle = 100;
/// Per stored node of the refined band (refinement > 1): its neighbours and
/// flag, the field, CG's four vectors, the band operator's right-hand side,
/// diagonal, Laplacian and transposed-gather offset, the band multigrid's
/// three work vectors (117), and its coarser levels (1/8 the nodes per level;
/// two more work vectors there).
constexpr double kBytesPerBandNode = 117 + (117 + 16) / 7.0;
/// The band's thickness in base cells around the surface: kBandThickness x
/// (2 refine_width + kBandExtraCells), the cells holding the zero set and the
/// fixed ring on either side, the box dilation thicker than its width across
/// oblique surfaces; fitted on spheres of 16-48 base cells (stored band nodes
/// 7.6 cells thick at width 1, 10.8 at width 2).
constexpr double kBandThickness = 1.6;
constexpr double kBandExtraCells = 2.75;
/// Per band sample: the Sample (48) and, per band multigrid level, the band
/// operator's 8 node indices, 8 weights, weight, value, index and transposed entries (172).
constexpr double kBytesPerBandSample = 48;
constexpr double kBytesPerBandSampleLevel = 172;
/// The estimate is this much above the counted bytes: what the count leaves
/// out (the process's own ~20-30 MiB, allocator rounding, TBB's per-thread
/// state, the samples' per-section vectors before they are joined). Peak RSS
/// over the counted bytes was 0.99-1.11 on six cases (three spheres, two
/// frog organs, armadillo; docs/decisions.md), so 1.25 keeps every measured
/// case under its estimate (0.79-0.89 of it) with room for the cases not
/// measured (re-weighting passes, several labels on one grid).
constexpr double kEstimateSafety = 1.25;
/// Per sign point (pixel input, Field3dParams::pixel_signs): its position,
/// sign, section and pixel (SignPoints), its penalty sample's index and
/// violated flag, and the mesh check's raster of its pixel (1 byte).
constexpr double kBytesPerSignPoint = 24 + 1 + 4 + 4 + 8 + 1 + 1;
/// Share of the sign points that become penalty samples (the active set,
/// each a sample of the solve): 0.19-0.46 % on five mask-kit rows (128 px;
/// sphere 4:1 804 of 353,648), 0.02 leaves 4x room for rougher masks.
constexpr double kSignActiveShare = 0.02;
/// A plane raster this large is counted as its bounding rectangle (an upper
/// bound) instead of row by row: the row count itself would take seconds.
constexpr double kRowCountLimit = 1e9;

/// Raster points of `r` inside [lo, hi] (eps-padded), row by row: each row is a line through the box.
double raster_points_inside(const PlanePose& pose, const detail::PlaneRaster& r, double sp, const Vec3d& lo,
                            const Vec3d& hi, double eps) {
  if (double(r.ns) * double(r.nt) > kRowCountLimit) return double(r.ns) * double(r.nt);
  const Vec3d step = pose.to_world(r.pmin + Vec2d(sp, 0)) - pose.to_world(r.pmin);
  double n = 0;
  for (int j = 0; j < r.nt; ++j) {
    const Vec3d w0 = pose.to_world({r.pmin.x(), r.pmin.y() + j * sp});
    double k0 = 0, k1 = r.ns - 1;
    for (int a = 0; a < 3 && k0 <= k1; ++a) {
      const double below = lo[a] - eps - w0[a], above = hi[a] + eps - w0[a];
      if (std::abs(step[a]) < 1e-12 * sp) {
        if (below > 0 || above < 0) k1 = -1;
        continue;
      }
      double t0 = below / step[a], t1 = above / step[a];
      if (t0 > t1) std::swap(t0, t1);
      k0 = std::max(k0, std::ceil(t0));
      k1 = std::min(k1, std::floor(t1));
    }
    if (k1 >= k0) n += k1 - k0 + 1;
  }
  return n;
}

}  // namespace

Field3dWork estimate_sections(const std::vector<Section>& sections, std::uint32_t label, const Field3dParams& given) {
  using namespace detail;
  params_table<Field3dParams>().validate(given);
  const Field3dParams params = sparse_base(given);
  const SectionGrid g = section_grid(sections, label, params);
  Field3dWork w;
  w.nx = g.out_nodes[0];
  w.ny = g.out_nodes[1];
  w.nz = g.out_nodes[2];
  const std::array<int, 3> sn = g.nodes();
  w.solve_nodes = double(sn[0]) * double(sn[1]) * double(sn[2]);
  const double sp = params.sample_spacing * g.h;
  for (std::size_t i = 0; i < sections.size(); ++i) {
    const PlanePose& pose = sections[i].pose;
    w.samples += raster_points_inside(pose, plane_raster(pose, g.origin, g.box_hi, sp), sp, g.origin, g.box_hi, 1e-9 * g.h);
    if (params.contour_weight > 0)
      for (const Polyline& poly : g.polys[i])
        for (std::size_t e = 0; e < poly.size(); ++e)
          w.samples += std::max(1.0, std::ceil((poly[(e + 1) % poly.size()] - poly[e]).norm() / sp));
  }
  // Pixel input: every pixel centre of the label images inside the box is a
  // sign point (sign_points()); the active ones are samples of the solve too.
  if (params.pixel_signs)
    for (const Section& s : sections)
      if (s.is_image())
        w.sign_points += raster_points_inside(s.pose, PlaneRaster{Vec2d::Zero(), s.labels.width, s.labels.height},
                                              s.pixel_size, g.origin, g.box_hi, 1e-9 * g.h);
  // plane_signs: a polyline section's plane samples (all of them, an upper bound).
  if (params.plane_signs)
    for (const Section& s : sections)
      if (!s.is_image()) w.sign_points += raster_points_inside(s.pose, plane_raster(s.pose, g.origin, g.box_hi, sp), sp,
                                                              g.origin, g.box_hi, 1e-9 * g.h);
  const double solve_samples = w.samples + kSignActiveShare * w.sign_points;
  // The multigrid hierarchy under the finest grid (Multigrid's halving rule):
  // its nodes, and its cells with samples (a plane crosses a cell of H
  // finest cells in ~H^2 samples).
  double coarse_nodes = 0, blocks = 0;
  Level lv{sn[0], sn[1], sn[2], g.step};
  for (int l = 1; lv.size() > kCoarsestNodes && l < kMaxMultigridLevels; ++l) {
    const Level c = coarser(lv);
    if (c.size() == lv.size()) break;
    lv = c;
    coarse_nodes += double(lv.size());
    // A plane crosses a cell in ~its in-plane area of samples: H^2 on an
    // isotropic level, the smallest face of an anisotropic one.
    const double face = lv.H.prod() / lv.H.maxCoeff();
    blocks += std::min(double(lv.nx - 1) * double(lv.ny - 1) * double(lv.nz - 1), solve_samples / face);
  }
  // The surface: the contours' box as an ellipsoid (Thomsen's area formula), in cells^2.
  const Vec3d semi = (g.contour_hi - g.contour_lo) / (2 * g.h);
  constexpr double kThomsen = 1.6075;
  const auto pw = [](double v) { return std::pow(v, kThomsen); };
  const double area = 4 * std::acos(-1.0) *
                      std::pow((pw(semi.x() * semi.y()) + pw(semi.x() * semi.z()) + pw(semi.y() * semi.z())) / 3, 1 / kThomsen);
  const int r = params.refinement;
  w.triangles = kTrianglesPerCellArea * area * r * r;
  // The band (refinement > 1): its cells around the surface, r^3 nodes each;
  // its samples: each section's plane within the band's thickness of its
  // contours at spacing 1 / r, and its contours at 1 / r, on every level of
  // the band multigrid (r, r / 2, ..., 1).
  double band_samples = 0;
  if (r > 1) {
    const double thick = kBandThickness * (2 * std::ceil(params.refine_width) + kBandExtraCells);
    w.band_nodes = area * thick * r * r * r;
    for (const auto& polys : g.polys)
      for (const Polyline& poly : polys)
        for (std::size_t e = 0; e < poly.size(); ++e) {
          const double len = (poly[(e + 1) % poly.size()] - poly[e]).norm() / g.h;
          band_samples += len * thick * r * r / (params.sample_spacing * params.sample_spacing) + len * r / params.sample_spacing;
        }
  }
  const double band_levels = r > 1 ? std::log2(double(r)) + 1 : 0;
  w.solve_bytes = kEstimateSafety * (w.solve_nodes * kBytesPerNode + coarse_nodes * kBytesPerCoarseNode +
                                     blocks * kBytesPerBlock + solve_samples * kBytesPerSample +
                                     w.sign_points * kBytesPerSignPoint + w.band_nodes * kBytesPerBandNode +
                                     band_samples * (kBytesPerBandSample + band_levels * kBytesPerBandSampleLevel));
  w.field_bytes = w.nodes() * sizeof(double);
  w.mesh_bytes = kEstimateSafety * w.triangles * kMeshBytesPerTriangle;
  return w;
}

namespace detail {
double coarse_update_mismatch(int nx, int ny, int nz, const std::vector<Vec3d>& g, const std::vector<double>& before,
                              const std::vector<double>& after, const Field3dParams& p) {
  const Level lv{nx, ny, nz, Vec3d::Ones()};
  const auto with = [&](const std::vector<double>& w) {
    std::vector<Sample> s;
    for (std::size_t k = 0; k < g.size(); ++k)
      if (w[k] != 0) s.push_back({g[k], 0.0, w[k], false});
    return s;
  };
  CellOperator updated(lv, with(before), p);
  for (std::size_t k = 0; k < g.size(); ++k)
    if (after[k] != before[k]) updated.add({g[k], 0.0, 1.0, false}, after[k] - before[k]);
  const CellOperator rebuilt(lv, with(after), p);
  const Eigen::SparseMatrix<double> R = rebuilt.assemble(), D = updated.assemble() - R;
  const double scale = R.coeffs().cwiseAbs().maxCoeff();
  return std::max(D.coeffs().cwiseAbs().maxCoeff(), (updated.diagonal() - rebuilt.diagonal()).cwiseAbs().maxCoeff()) / scale;
}
}  // namespace detail

}  // namespace isoloft
