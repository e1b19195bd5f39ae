// Screened Poisson reconstruction [Kazhdan & Hoppe 2013], written for autoscan.
//
// Discretisation. Points are mapped into the unit cube U = [0,1]^3 (a cube of side W around their
// box). At depth d the grid has n = 2^d cells of side h = 1/n per axis and (n+1)^3 nodes; node i
// carries the trilinear hat H_{d,i}(u) = prod_a hat(u_a / h - i_a). The unknown is
// chi = sum_d sum_{i in A_d} x_{d,i} H_{d,i} (a hierarchical, redundant basis as PoissonRecon's).
// A_d (the active nodes) is the full grid for d <= full_depth; deeper, it is the corners of the
// cells within one cell of a cell that holds a sample splatted at depth >= d. E_d = A_d plus a
// one-node halo; chi_{<=d} (the sum of depths <= d) is stored at E_d. Because a depth-(d-1) hat is a
// combination of depth-d hats (hat(x) = hat(2x+1)/2 + hat(2x) + hat(2x-1)/2), chi_{<d} at the
// depth-d nodes is its trilinear interpolation (prolongation), and right-hand sides restrict
// exactly from fine to coarse with the transposed weights.
//
// Normal field. Sample p (unit-cube position u_p, outward unit normal n_p, weight w_p, area a_p =
// 1 / local density) is splatted at depth s_p: V = sum_p c_p K_{s_p}(u - u_p), c_p = -w_p a_p n_p,
// K_s(u - u_p) = sum_j H_{s,j}(u_p) H_{s,j}(u) / h_s^3 (unit integral). The minus sign makes chi
// grow inward (about +1/2 inside, -1/2 outside), so grad chi = V points inward (core/implicit.hpp).
//
// Energy. E(chi) = Int_U |V - grad chi|^2 + sum_d alpha 2^d sum_{p: s_p >= d} w_p a_p chi(p)^2
// (screening, Kazhdan & Hoppe 2013 Eq. 4 with Area/sum w replaced by the per-sample area, scaled
// by 2^d at depth d so that the balance with the gradient term does not change with depth).
// Depth by depth, from 0 to D (cascadic): minimise over x_d with chi_{<d} fixed, i.e.
//   (L_d + S_d) x_d = b_d - L_d P_d - S_d P_d,   P_d = chi_{<d} at the depth-d nodes,
// L_{ij} = Int grad H_i . grad H_j (27-point stencil, Neumann boundary), S_d the screening matrix,
// b_{d,i} = Int V . grad H_{d,i}. Solved by Jacobi-preconditioned conjugate gradients.
//
// Determinism. Every parallel loop writes disjoint outputs: scatters from samples go cell colour
// by cell colour (cells of one parity share no corner), reductions sum fixed-size chunks in order.
// Results do not depend on the number of threads.
#include "autoscan/poisson/poisson.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <numbers>
#include <numeric>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/poisson/detail.hpp"

namespace autoscan::poisson {
namespace {

using detail::FieldData;
using detail::FieldLevel;
using detail::key_x;
using detail::key_y;
using detail::key_z;
using detail::KeyIndex;
using detail::kNoKey;
using detail::pack;

/// reference_gradient() = kReferenceGradientConstant * 2^D / W (W: side of the bounding cube).
/// |grad chi| * W / 2^D was measured at the samples of densely, cleanly sampled spheres (radius 0.3
/// and 2, i.e. about 0.45 of the cube, 100k samples at depth 6 and 250k at depth 8, alpha = 4): its
/// mean is this constant within 15 % (tests/poisson, ReferenceGradientIsCalibrated; with the default
/// normal_smoothing 1/8, which lowers it from 0.54). chi jumps by
/// about 1 across the surface over a kernel a few cells wide, hence a constant of order 1/2.
constexpr double kReferenceGradientConstant = 0.46;
/// The density kernel radius is the cell width of the finest depth whose occupied cells hold at
/// least this many samples on average.
constexpr double kDensitySamplesPerCell = 6.0;

// ---- small helpers -----------------------------------------------------------------------------

std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}
std::uint64_t morton(int x, int y, int z) {
  return spread_bits(std::uint64_t(x)) | (spread_bits(std::uint64_t(y)) << 1) | (spread_bits(std::uint64_t(z)) << 2);
}

/// Sum of f(i) for i in [0, n), in fixed-size chunks summed in order (thread-count independent).
template <class F>
double det_sum(std::size_t n, F&& f) {
  constexpr std::size_t kChunk = 8192;
  const std::size_t nc = (n + kChunk - 1) / kChunk;
  std::vector<double> part(nc, 0.0);
  tbb::parallel_for(std::size_t{0}, nc, [&](std::size_t c) {
    double s = 0.0;
    const std::size_t e = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < e; ++i) s += f(i);
    part[c] = s;
  });
  double s = 0.0;
  for (double v : part) s += v;
  return s;
}

/// For i in [0, count): out[i * stride] = position of key_of(i) in the sorted `table`, or -1
/// (also when key_of returns kNoKey). The valid keys must be non-decreasing in i (a merge).
template <class KeyFn>
void match_sorted(std::size_t count, KeyFn&& key_of, const std::vector<std::uint64_t>& table, std::int32_t* out,
                  std::size_t stride) {
  constexpr std::size_t kChunk = 4096;
  const std::size_t nc = (count + kChunk - 1) / kChunk;
  tbb::parallel_for(std::size_t{0}, nc, [&](std::size_t c) {
    const std::size_t b = c * kChunk, e = std::min(count, b + kChunk);
    std::size_t pos = table.size();
    for (std::size_t i = b; i < e; ++i) {
      const std::uint64_t q = key_of(i);
      if (q == kNoKey) {
        out[i * stride] = -1;
        continue;
      }
      if (pos == table.size()) pos = std::lower_bound(table.begin(), table.end(), q) - table.begin();
      while (pos < table.size() && table[pos] < q) ++pos;
      out[i * stride] = (pos < table.size() && table[pos] == q) ? static_cast<std::int32_t>(pos) : -1;
    }
  });
}

/// Keys dilated along each axis by offsets [lo, hi], clamped to [0, nmax]; sorted, unique.
/// `cur` must be sorted. A shift along one axis keeps the (z, y, x) order of pack() keys, so each
/// shifted copy is sorted and one axis is a merge of hi - lo + 1 sorted lists (no sort needed).
std::vector<std::uint64_t> dilate(std::vector<std::uint64_t> cur, int lo, int hi, int nmax) {
  const int w = hi - lo + 1;
  AUTOSCAN_CHECK(w >= 1 && w <= 8, "poisson: dilation width {} out of range", w);
  for (int axis = 0; axis < 3; ++axis) {
    const int sh = axis * detail::kKeyBits;
    std::size_t pos[8] = {};
    std::vector<std::uint64_t> out;
    out.reserve(cur.size() * 2);
    // Head of list o (the shifted key of cur[pos[o]], skipping keys shifted off the grid).
    auto head = [&](int o) -> std::uint64_t {
      const int off = lo + o;
      while (pos[o] < cur.size()) {
        const int c = static_cast<int>((cur[pos[o]] >> sh) & detail::kKeyMask) + off;
        if (c >= 0 && c <= nmax)
          return off >= 0 ? cur[pos[o]] + (std::uint64_t(off) << sh) : cur[pos[o]] - (std::uint64_t(-off) << sh);
        ++pos[o];
      }
      return kNoKey;
    };
    std::uint64_t h[8];
    for (int o = 0; o < w; ++o) h[o] = head(o);
    while (true) {
      int best = 0;
      for (int o = 1; o < w; ++o)
        if (h[o] < h[best]) best = o;
      if (h[best] == kNoKey) break;
      if (out.empty() || out.back() != h[best]) out.push_back(h[best]);
      ++pos[best];
      h[best] = head(best);
    }
    cur.swap(out);
  }
  return cur;
}

/// One-dimensional integrals of hats at depth with n cells (h = 1/n) for node i and neighbour i+o:
/// mass Int h_i h_{i+o}, stiffness Int h_i' h_{i+o}', and Int h_{i+o} h_i' (for the divergence).
struct Hat1D {
  double m, k, g;
};
Hat1D hat1d(int i, int o, int n) {
  const double h = 1.0 / n;
  const bool left = i > 0, right = i < n;
  if (o == 0) return {h / 3.0 * (left + right), (left + right) / h, 0.5 * (double(left) - double(right))};
  const bool exists = o < 0 ? left : right;
  if (!exists) return {0.0, 0.0, 0.0};
  return {h / 6.0, -1.0 / h, o < 0 ? 0.5 : -0.5};
}

/// Stencils (27 entries, k = (ox+1) + 3(oy+1) + 9(oz+1)) of the Laplacian L and of the divergence
/// G (Int H_j grad H_i) at node (x, y, z).
void stencils(int x, int y, int z, int n, double* L, Vec3* G) {
  for (int oz = -1; oz <= 1; ++oz)
    for (int oy = -1; oy <= 1; ++oy)
      for (int ox = -1; ox <= 1; ++ox) {
        const Hat1D a = hat1d(x, ox, n), b = hat1d(y, oy, n), c = hat1d(z, oz, n);
        const int k = (ox + 1) + 3 * (oy + 1) + 9 * (oz + 1);
        if (L) L[k] = a.k * b.m * c.m + a.m * b.k * c.m + a.m * b.m * c.k;
        if (G) G[k] = Vec3(a.g * b.m * c.m, a.m * b.g * c.m, a.m * b.m * c.g);
      }
}

/// Trilinear prolongation from a coarse depth (node index `cindex`, values `cval`) to the nodes
/// `fkeys` of the next depth: out[i] += sum over the parents of fine node i (weights 1 or 1/2 per
/// axis). Every parent must be stored (the node sets are nested); checked.
template <class T>
void prolong(const KeyIndex& cindex, const std::vector<T>& cval, const std::vector<std::uint64_t>& fkeys,
             std::vector<T>& out) {
  std::atomic<std::size_t> missing{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, fkeys.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const std::uint64_t key = fkeys[i];
      const int c[3] = {key_x(key), key_y(key), key_z(key)};
      for (int m = 0; m < 8; ++m) {
        int p[3];
        double w = 1.0;
        bool skip = false;
        for (int a = 0; a < 3; ++a) {
          const int up = (m >> a) & 1;
          if (up && !(c[a] & 1)) skip = true;
          p[a] = (c[a] + up) >> 1;
          if (c[a] & 1) w *= 0.5;
        }
        if (skip) continue;
        const int j = cindex.find(pack(p[0], p[1], p[2]));
        if (j < 0) {
          missing.fetch_add(1, std::memory_order_relaxed);
          continue;
        }
        out[i] += w * cval[j];
      }
    }
  });
  AUTOSCAN_CHECK(missing.load() == 0, "poisson: {} nodes miss a parent at the coarser depth", missing.load());
}

// ---- the solver --------------------------------------------------------------------------------

struct Samples {
  std::vector<Vec3> u;              ///< unit-cube positions
  std::vector<Vec3> n;              ///< outward unit normals
  std::vector<double> w;            ///< user weights
  std::vector<double> area;         ///< a_p = 1 / density
  std::vector<std::int8_t> depth;   ///< finest splat depth s_p (the octree is refined to it)
  std::vector<double> frac;         ///< share of the sample splatted at s_p (the rest at s_p - 1)
  std::vector<std::int8_t> refine;  ///< depth the octree is refined to around the sample (>= s_p)
  std::vector<std::uint64_t> code;  ///< Morton code at depth D (the samples are sorted by it)
};

struct Level {
  int depth = 0;
  int n = 1;
  std::vector<std::uint64_t> keys;  ///< E_d, sorted
  std::vector<std::int32_t> act;    ///< indices (into keys) of A_d, ascending
  KeyIndex index;
  std::vector<double> b;  ///< right-hand side from V (on E, zero on the halo)
  std::vector<Vec3> own;  ///< V of the samples splatted at this depth, as node coefficients
  // samples with s_p >= depth, in Morton order, grouped by cell
  std::vector<std::uint32_t> samples;
  std::vector<std::uint32_t> cell_begin;            ///< cells + 1 entries
  std::vector<std::int32_t> corners;                ///< 8 per cell, indices into keys
  std::array<std::vector<std::uint32_t>, 8> color;  ///< cells by parity of their coordinates
  std::size_t splat = 0;
};

// Int V . grad H_a at active node a of L: the gradient stencils of H_a against the coefficients W of
// V at its 27 neighbours (nbr: 27 indices per active node, -1 outside E).
double divergence_at(const Level& L, const std::vector<std::int32_t>& nbr, std::size_t a, const std::vector<Vec3>& W) {
  Vec3 G[27];
  const std::uint64_t key = L.keys[L.act[a]];
  stencils(key_x(key), key_y(key), key_z(key), L.n, nullptr, G);
  double sum = 0.0;
  for (int k = 0; k < 27; ++k) {
    const std::int32_t j = nbr[a * 27 + k];
    if (j >= 0) sum += G[k].dot(W[j]);
  }
  return sum;
}

class Solver {
 public:
  Solver(const PoissonOptions& opt, Samples& s, PoissonDiagnostics& diag, const ProgressCallback& cb)
      : opt_(opt), s_(s), diag_(diag), cb_(cb) {}

  std::shared_ptr<FieldData> run(const Vec3& origin, double width);

 private:
  void estimate_density();
  struct DensityCells;
  int choose_density_depth() const;
  DensityCells density_cells(int k) const;
  template <class F, class Visit>
  void kernel_sums(const DensityCells& cells, F&& f, Visit&& visit) const;
  void assign_splat_depths(const DensityCells& cells);
  void splat_density_grid(const DensityCells& cells);
  void build_levels();
  void build_level_cells(Level& L);
  void build_neighbours(const Level& L, std::vector<std::int32_t>& nbr) const;
  void compute_rhs();
  void solve(FieldData& field);
  struct LevelSystem;
  void add_coarse_divergence(Level& L, const std::vector<std::int32_t>& nbr, const std::vector<Vec3>& W) const;
  static int pcg(const LevelSystem& A, const std::vector<double>& diag, std::vector<double>& r, std::vector<double>& x,
                 int max_iterations, double target, double& residual);

  /// Trilinear weights of sample p in its cell at level L (corner k: bits x, y, z).
  static void weights(const Level& L, const Vec3& u, double w[8]) {
    double t[3];
    for (int a = 0; a < 3; ++a) {
      const double x = u[a] * L.n;
      t[a] = x - std::clamp(std::floor(x), 0.0, double(L.n - 1));
    }
    for (int k = 0; k < 8; ++k)
      w[k] = ((k & 1) ? t[0] : 1 - t[0]) * ((k & 2) ? t[1] : 1 - t[1]) * ((k & 4) ? t[2] : 1 - t[2]);
  }
  /// Calls f(cell index) for every cell of L, colour by colour, cells of one colour in parallel.
  template <class F>
  static void for_cells_coloured(const Level& L, F&& f) {
    for (const auto& cells : L.color)
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 256), [&](const auto& r) {
        for (std::size_t c = r.begin(); c != r.end(); ++c) f(cells[c]);
      });
  }

  const PoissonOptions& opt_;
  Samples& s_;
  PoissonDiagnostics& diag_;
  const ProgressCallback& cb_;
  int D_ = 0;
  int density_depth_ = 1;
  std::vector<Level> levels_;
  FieldLevel density_;
};

// The depth-k cells that hold samples: runs of the Morton-sorted samples.
struct Solver::DensityCells {
  int k = 1;
  int nk = 2;                             ///< 2^k cells per axis
  std::vector<std::uint32_t> run_begin;   ///< cells + 1 entries, into the samples
  KeyIndex runs;                          ///< Morton code at depth k -> cell
  std::vector<std::uint64_t> cell_keys;   ///< pack() key of each cell
  double r = 0.5, r2 = 0.25, norm = 0.0;  ///< kernel radius (one cell), r^2, its plane integral pi r^2 / 3
};

// The finest depth whose occupied cells hold kDensitySamplesPerCell samples on average (Morton
// prefixes are runs).
int Solver::choose_density_depth() const {
  const std::size_t N = s_.u.size();
  int depth = 1;
  for (int d = 1; d <= D_; ++d) {
    const int shift = 3 * (D_ - d);
    std::size_t cells = 0;
    std::uint64_t prev = kNoKey;
    for (std::uint64_t c : s_.code) {
      c >>= shift;
      cells += (c != prev);
      prev = c;
    }
    if (static_cast<double>(N) / static_cast<double>(cells) >= kDensitySamplesPerCell) depth = d;
  }
  return depth;
}

Solver::DensityCells Solver::density_cells(int k) const {
  const std::size_t N = s_.u.size();
  DensityCells cells;
  cells.k = k;
  cells.nk = 1 << k;
  const int shift = 3 * (D_ - k), nk = cells.nk;
  std::vector<std::uint64_t> run_code;
  for (std::size_t j = 0; j < N; ++j) {
    const std::uint64_t c = s_.code[j] >> shift;
    if (run_code.empty() || run_code.back() != c) {
      run_code.push_back(c);
      cells.run_begin.push_back(static_cast<std::uint32_t>(j));
    }
  }
  cells.run_begin.push_back(static_cast<std::uint32_t>(N));
  cells.runs.build(run_code);
  cells.cell_keys.resize(run_code.size());
  tbb::parallel_for(std::size_t{0}, run_code.size(), [&](std::size_t c) {
    const Vec3& u = s_.u[cells.run_begin[c]];
    int x[3];
    for (int a = 0; a < 3; ++a) x[a] = std::clamp(static_cast<int>(u[a] * nk), 0, nk - 1);
    cells.cell_keys[c] = pack(x[0], x[1], x[2]);
  });
  cells.r = 1.0 / nk;
  cells.r2 = cells.r * cells.r;
  cells.norm = std::numbers::pi * cells.r2 / 3.0;
  return cells;
}

// Kernel sums cell by cell: the candidates of every sample of cell c are the runs of the 27 cells
// around c. visit(j, sum of w_q phi_q f(q), sum of w_q phi_q) for every sample j, phi(t) = (1-t^2)^2
// with t = |u_j - u_q| / r; neighbours q facing away (n_j . n_q <= 0) are on the other side of a
// thin part and do not count.
template <class F, class Visit>
void Solver::kernel_sums(const DensityCells& cells, F&& f, Visit&& visit) const {
  const int nk = cells.nk;
  const double r2 = cells.r2;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.cell_keys.size(), 64), [&](const auto& rg) {
    std::pair<std::uint32_t, std::uint32_t> nb[27];
    for (std::size_t c = rg.begin(); c != rg.end(); ++c) {
      const std::uint64_t ck = cells.cell_keys[c];
      const int cx = key_x(ck), cy = key_y(ck), cz = key_z(ck);
      int m = 0;
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int x = cx + dx, y = cy + dy, z = cz + dz;
            if (x < 0 || y < 0 || z < 0 || x >= nk || y >= nk || z >= nk) continue;
            const int ri = cells.runs.find(morton(x, y, z));
            if (ri >= 0) nb[m++] = {cells.run_begin[ri], cells.run_begin[ri + 1]};
          }
      for (std::uint32_t j = cells.run_begin[c]; j < cells.run_begin[c + 1]; ++j) {
        const Vec3 u = s_.u[j], n = s_.n[j];
        double sum = 0.0, ws = 0.0;
        for (int b = 0; b < m; ++b)
          for (std::uint32_t q = nb[b].first; q < nb[b].second; ++q) {
            const double d2 = (s_.u[q] - u).squaredNorm();
            // Only the same side of a thin sheet counts (opposite normals: the other side).
            if (d2 < r2 && s_.n[q].dot(n) > 0.0) {
              const double t = 1.0 - d2 / r2;
              const double wt = s_.w[q] * t * t;
              sum += wt * f(q);
              ws += wt;
            }
          }
        visit(j, sum, ws);
      }
    }
  });
}

// Area density at each sample: sum_q w_q phi(|u_p - u_q| / r) / (pi r^2 / 3) (the kernel's integral
// over a plane through its centre), a_p = 1 / density; and the splat depth from the density.
void Solver::assign_splat_depths(const DensityCells& cells) {
  const std::size_t N = s_.u.size();
  s_.area.assign(N, 0.0);
  s_.depth.assign(N, 0);
  s_.frac.assign(N, 1.0);
  s_.refine.assign(N, 0);
  const double spn = opt_.samples_per_node;
  const int min_depth = std::min(opt_.full_depth, D_);
  std::vector<double> logrho(N);
  kernel_sums(
      cells, [](std::uint32_t) { return 1.0; },
      [&](std::uint32_t j, double sum, double) {
        const double rho = sum / cells.norm;  // > 0 (itself)
        s_.area[j] = 1.0 / rho;
        logrho[j] = std::log2(rho);
      });
  kernel_sums(
      cells, [&](std::uint32_t q) { return logrho[q]; },
      [&](std::uint32_t i, double sum, double ws) {
        // The splat depth follows the density averaged once more over the kernel, so that it
        // changes along smooth fronts rather than from sample to sample (a patchy octree makes
        // bumps).
        const double lr = sum / ws;
        // Fractional splat depth (as PoissonRecon): share t at floor(sd) + 1, 1 - t at
        // floor(sd), so that the kernel width varies smoothly with the density.
        const double sd = 0.5 * (lr - std::log2(spn));
        // The octree is refined around the sample down to its finest splat depth.
        if (sd >= D_) {
          s_.depth[i] = static_cast<std::int8_t>(D_);
          s_.frac[i] = 1.0;
          s_.refine[i] = static_cast<std::int8_t>(D_);
        } else if (sd < min_depth) {
          s_.depth[i] = static_cast<std::int8_t>(min_depth);
          s_.frac[i] = 1.0;
          s_.refine[i] = s_.depth[i];
        } else {
          const int s0 = static_cast<int>(std::floor(sd));
          const double t = sd - s0;
          s_.depth[i] = static_cast<std::int8_t>(t > 0.0 ? s0 + 1 : s0);
          s_.frac[i] = t > 0.0 ? t : 1.0;
          s_.refine[i] = s_.depth[i];
        }
      });
}

// Density output grid: corners of the depth-k cells that hold samples, trilinear splat of w_p
// normalised by the mean plane integral of the kernel (2/3 h^2): samples per unit area.
void Solver::splat_density_grid(const DensityCells& cells) {
  const auto& cell_keys = cells.cell_keys;
  const int nk = cells.nk;
  std::vector<std::uint64_t> corner_keys;
  corner_keys.reserve(cell_keys.size() * 8);
  for (std::uint64_t ck : cell_keys)
    for (int q = 0; q < 8; ++q)
      corner_keys.push_back(pack(key_x(ck) + (q & 1), key_y(ck) + ((q >> 1) & 1), key_z(ck) + ((q >> 2) & 1)));
  tbb::parallel_sort(corner_keys.begin(), corner_keys.end());
  corner_keys.erase(std::unique(corner_keys.begin(), corner_keys.end()), corner_keys.end());
  density_.depth = cells.k;
  density_.keys = std::move(corner_keys);
  density_.index.build(density_.keys);
  density_.value.assign(density_.keys.size(), 0.0);
  const double dnorm = 1.0 / (cells.r2 * 2.0 / 3.0);
  // Colour the cells by parity so that scatters do not collide.
  std::array<std::vector<std::uint32_t>, 8> color;
  for (std::size_t c = 0; c < cell_keys.size(); ++c)
    color[(key_x(cell_keys[c]) & 1) | ((key_y(cell_keys[c]) & 1) << 1) | ((key_z(cell_keys[c]) & 1) << 2)].push_back(
        static_cast<std::uint32_t>(c));
  for (const auto& same : color)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, same.size(), 256), [&](const auto& rg) {
      for (std::size_t ci = rg.begin(); ci != rg.end(); ++ci) {
        const std::uint32_t c = same[ci];
        const std::uint64_t ck = cell_keys[c];
        int idx[8];
        for (int q = 0; q < 8; ++q)
          idx[q] =
              density_.index.find(pack(key_x(ck) + (q & 1), key_y(ck) + ((q >> 1) & 1), key_z(ck) + ((q >> 2) & 1)));
        for (std::uint32_t j = cells.run_begin[c]; j < cells.run_begin[c + 1]; ++j) {
          double t[3];
          for (int a = 0; a < 3; ++a) t[a] = s_.u[j][a] * nk - key_x(ck >> (a * detail::kKeyBits));
          for (int q = 0; q < 8; ++q) {
            const double wq = ((q & 1) ? t[0] : 1 - t[0]) * ((q & 2) ? t[1] : 1 - t[1]) * ((q & 4) ? t[2] : 1 - t[2]);
            density_.value[idx[q]] += s_.w[j] * wq * dnorm;
          }
        }
      }
    });
  density_.keys = {};
}

// The samples are stored in Morton order (Solver::run): a cell's samples are consecutive at every
// depth, so the kernel sums read contiguous runs.
void Solver::estimate_density() {
  density_depth_ = choose_density_depth();
  diag_.density_depth = density_depth_;
  const DensityCells cells = density_cells(density_depth_);
  assign_splat_depths(cells);
  splat_density_grid(cells);
}

void Solver::build_level_cells(Level& L) {
  const int shift = 3 * (D_ - L.depth);
  L.samples.clear();
  L.cell_begin.clear();
  // A sample is screened at every depth where its cell is complete (all corners stored), as
  // PoissonRecon evaluates every point constraint at every depth; deeper than the sample's splat
  // depth its screening weight stops growing (see screen_weight).
  std::vector<std::uint8_t> complete(s_.u.size(), 1);
  tbb::parallel_for(std::size_t{0}, s_.u.size(), [&](std::size_t i) {
    if (s_.refine[i] >= L.depth) return;
    int x[3];
    for (int a = 0; a < 3; ++a) x[a] = std::clamp(static_cast<int>(std::floor(s_.u[i][a] * L.n)), 0, L.n - 1);
    for (int q = 0; q < 8; ++q)
      if (L.index.find(pack(x[0] + (q & 1), x[1] + ((q >> 1) & 1), x[2] + ((q >> 2) & 1))) < 0) {
        complete[i] = 0;
        return;
      }
  });
  std::vector<std::uint64_t> cell_code;
  for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(s_.u.size()); ++i) {
    if (!complete[i]) continue;
    const std::uint64_t c = s_.code[i] >> shift;
    if (cell_code.empty() || cell_code.back() != c) {
      cell_code.push_back(c);
      L.cell_begin.push_back(static_cast<std::uint32_t>(L.samples.size()));
    }
    L.samples.push_back(i);
  }
  L.cell_begin.push_back(static_cast<std::uint32_t>(L.samples.size()));
  const std::size_t nc = cell_code.size();
  L.corners.assign(nc * 8, -1);
  for (auto& c : L.color) c.clear();
  std::vector<std::uint8_t> col(nc);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nc, 1024), [&](const auto& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c) {
      const Vec3& u = s_.u[L.samples[L.cell_begin[c]]];
      int x[3];
      for (int a = 0; a < 3; ++a) x[a] = std::clamp(static_cast<int>(std::floor(u[a] * L.n)), 0, L.n - 1);
      for (int q = 0; q < 8; ++q)
        L.corners[c * 8 + q] = L.index.find(pack(x[0] + (q & 1), x[1] + ((q >> 1) & 1), x[2] + ((q >> 2) & 1)));
      col[c] = static_cast<std::uint8_t>((x[0] & 1) | ((x[1] & 1) << 1) | ((x[2] & 1) << 2));
    }
  });
  for (std::size_t c = 0; c < nc; ++c) {
    AUTOSCAN_CHECK(L.corners[c * 8] >= 0 && L.corners[c * 8 + 7] >= 0, "poisson: cell corner missing at depth {}",
                   L.depth);
    L.color[col[c]].push_back(static_cast<std::uint32_t>(c));
  }
}

void Solver::build_levels() {
  levels_.resize(D_ + 1);
  const int full = std::min(opt_.full_depth, D_);
  for (int d = 0; d <= D_; ++d) {
    Level& L = levels_[d];
    L.depth = d;
    L.n = 1 << d;
    if (d <= full) {
      const std::size_t m = static_cast<std::size_t>(L.n) + 1;
      L.keys.resize(m * m * m);
      std::size_t i = 0;
      for (int z = 0; z <= L.n; ++z)
        for (int y = 0; y <= L.n; ++y)
          for (int x = 0; x <= L.n; ++x) L.keys[i++] = pack(x, y, z);
      L.act.resize(L.keys.size());
      std::iota(L.act.begin(), L.act.end(), 0);
    } else {
      // Cells holding a sample refined to depth >= d (samples are in Morton order: a cell's samples
      // are consecutive, so one key per run).
      std::vector<std::uint64_t> cells;
      const int shift = 3 * (D_ - d);
      std::uint64_t prev = kNoKey;
      for (std::size_t i = 0; i < s_.u.size(); ++i) {
        if (s_.refine[i] < d) continue;
        const std::uint64_t c = s_.code[i] >> shift;
        if (c == prev) continue;
        prev = c;
        int x[3];
        for (int a = 0; a < 3; ++a) x[a] = std::clamp(static_cast<int>(std::floor(s_.u[i][a] * L.n)), 0, L.n - 1);
        cells.push_back(pack(x[0], x[1], x[2]));
      }
      if (cells.empty()) {
        levels_.resize(d);
        break;
      }
      tbb::parallel_sort(cells.begin(), cells.end());
      cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
      std::vector<std::uint64_t> active = dilate(std::move(cells), -1, 2, L.n);
      L.keys = dilate(active, -1, 1, L.n);
      L.act.resize(active.size());
      std::vector<std::int32_t>& act = L.act;
      match_sorted(
          active.size(), [&](std::size_t i) { return active[i]; }, L.keys, act.data(), 1);
    }
    L.index.build(L.keys);
    build_level_cells(L);
    for (std::uint32_t i : L.samples) L.splat += (s_.depth[i] == d) || (s_.depth[i] == d + 1 && s_.frac[i] < 1.0);
  }
}

void Solver::build_neighbours(const Level& L, std::vector<std::int32_t>& nbr) const {
  const std::size_t nA = L.act.size();
  nbr.assign(nA * 27, -1);
  tbb::parallel_for(0, 27, [&](int k) {
    const int ox = k % 3 - 1, oy = (k / 3) % 3 - 1, oz = k / 9 - 1;
    match_sorted(
        nA,
        [&](std::size_t a) {
          const std::uint64_t key = L.keys[L.act[a]];
          const int x = key_x(key) + ox, y = key_y(key) + oy, z = key_z(key) + oz;
          if (x < 0 || y < 0 || z < 0 || x > L.n || y > L.n || z > L.n) return kNoKey;
          return pack(x, y, z);
        },
        L.keys, nbr.data() + k, 27);
  });
}

void Solver::compute_rhs() {
  // From the finest depth up: b_d = (divergence of the samples splatted at d) + R^T b_{d+1}.
  Progress prog(cb_, "poisson: normal field");
  std::vector<std::int32_t> nbr;
  for (int d = static_cast<int>(levels_.size()) - 1; d >= 0; --d) {
    Level& L = levels_[d];
    const std::size_t nE = L.keys.size(), nA = L.act.size();
    L.b.assign(nE, 0.0);
    if (L.splat > 0) {
      std::vector<Vec3> v(nE, Vec3::Zero());
      const double inv_h3 = double(L.n) * L.n * L.n;
      for_cells_coloured(L, [&](std::uint32_t c) {
        const std::int32_t* idx = &L.corners[c * 8];
        for (std::uint32_t j = L.cell_begin[c]; j < L.cell_begin[c + 1]; ++j) {
          const std::uint32_t p = L.samples[j];
          const double share = s_.depth[p] == d ? s_.frac[p] : (s_.depth[p] == d + 1 ? 1.0 - s_.frac[p] : 0.0);
          if (share == 0.0) continue;
          double w[8];
          weights(L, s_.u[p], w);
          const Vec3 cp = -share * s_.w[p] * s_.area[p] * inv_h3 * s_.n[p];
          for (int q = 0; q < 8; ++q) v[idx[q]] += w[q] * cp;
        }
      });
      build_neighbours(L, nbr);
      // Normal smoothing: v <- (a, 1 - 2a, a) along x, then y, then z (PoissonOptions). The splatted
      // nodes' neighbours are all active (A_d spans the cells around every sample cell), so no
      // weight leaves the active set.
      if (const double a = opt_.normal_smoothing; a > 0.0) {
        std::vector<Vec3> tmp(nE, Vec3::Zero());
        for (const int step : {1, 3, 9}) {  // neighbour offsets in the 27-stencil: x, y, z
          tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nA, 1024), [&](const auto& r) {
            for (std::size_t q = r.begin(); q != r.end(); ++q) {
              const std::int32_t lft = nbr[q * 27 + 13 - step], rgt = nbr[q * 27 + 13 + step];
              Vec3 sum = (1.0 - 2.0 * a) * v[L.act[q]];
              if (lft >= 0) sum += a * v[lft];
              if (rgt >= 0) sum += a * v[rgt];
              tmp[L.act[q]] = sum;
            }
          });
          v.swap(tmp);
        }
      }
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nA, 1024), [&](const auto& r) {
        for (std::size_t a = r.begin(); a != r.end(); ++a) L.b[L.act[a]] = divergence_at(L, nbr, a, v);
      });
      L.own = std::move(v);
    }
    if (d + 1 < static_cast<int>(levels_.size())) {
      // Restriction: H_{d,i} = sum_o prod_a (1 - |o_a|/2) H_{d+1, 2i+o}.
      const Level& F = levels_[d + 1];
      std::vector<std::int32_t> fi(nA);
      for (int k = 0; k < 27; ++k) {
        const int ox = k % 3 - 1, oy = (k / 3) % 3 - 1, oz = k / 9 - 1;
        const double wk = (1.0 - 0.5 * std::abs(ox)) * (1.0 - 0.5 * std::abs(oy)) * (1.0 - 0.5 * std::abs(oz));
        match_sorted(
            nA,
            [&](std::size_t a) {
              const std::uint64_t key = L.keys[L.act[a]];
              const int x = 2 * key_x(key) + ox, y = 2 * key_y(key) + oy, z = 2 * key_z(key) + oz;
              if (x < 0 || y < 0 || z < 0 || x > F.n || y > F.n || z > F.n) return kNoKey;
              return pack(x, y, z);
            },
            F.keys, fi.data(), 1);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nA, 4096), [&](const auto& r) {
          for (std::size_t a = r.begin(); a != r.end(); ++a)
            if (fi[a] >= 0) L.b[L.act[a]] += wk * F.b[fi[a]];
        });
      }
    }
    if (d + 1 < static_cast<int>(levels_.size())) levels_[d + 1].b = {};
    prog.report(double(levels_.size() - d) / double(levels_.size()));
  }
}

// The operator (L + S) of one depth's system on its active nodes (x on E, zero on the halo): the
// Laplacian stencils and the screening term, sample p weighted alpha 2^min(d, s_p) w_p a_p.
struct Solver::LevelSystem {
  LevelSystem(const Level& level, const std::vector<std::int32_t>& neighbours, const Samples& samples, double screening,
              std::size_t depth)
      : L(level),
        nbr(neighbours),
        s(samples),
        alpha(screening),
        d(depth),
        omega(screening * std::ldexp(1.0, static_cast<int>(depth))),
        use_mat(omega > 0.0 && level.samples.size() >= 2 * (level.cell_begin.size() - 1)) {
    // Laplacian stencils: constant away from the cube's faces.
    stencils(1, 1, 1, std::max(L.n, 2), Lin, nullptr);
    // Screening per cell: S restricted to a cell is the 8x8 matrix sum_p omega w_p a_p W(p) W(p)^T;
    // precomputed when cells hold several samples (cheaper than visiting every sample each time).
    if (!use_mat) return;
    const std::size_t ncells = L.cell_begin.size() - 1;
    cellmat.assign(ncells * 64, 0.0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ncells, 256), [&](const auto& r) {
      for (std::size_t c = r.begin(); c != r.end(); ++c) {
        double* M = &cellmat[c * 64];
        for_samples_of(static_cast<std::uint32_t>(c), [&](std::uint32_t p, const double* w) {
          const double f = screen_weight(p);
          for (int q = 0; q < 8; ++q)
            for (int k = 0; k < 8; ++k) M[q * 8 + k] += f * w[q] * w[k];
        });
      }
    });
  }

  // Calls fn(p, w) for each sample p in cell c, with w its 8 trilinear weights on the cell's corners
  // (L.corners[8 c ...]): the one traversal of the screening term (its cell matrices, its product,
  // its diagonal).
  template <class Fn>
  void for_samples_of(std::uint32_t c, Fn&& fn) const {
    for (std::uint32_t j = L.cell_begin[c]; j < L.cell_begin[c + 1]; ++j) {
      const std::uint32_t p = L.samples[j];
      double w[8];
      weights(L, s.u[p], w);
      fn(p, static_cast<const double*>(w));
    }
  }

  const double* stencil_of(std::size_t a, double* out) const {
    const std::uint64_t key = L.keys[L.act[a]];
    const int x = key_x(key), y = key_y(key), z = key_z(key);
    if (x > 0 && y > 0 && z > 0 && x < L.n && y < L.n && z < L.n) return Lin;
    stencils(x, y, z, L.n, out, nullptr);
    return out;
  }
  // Screening weight of sample p at this depth: alpha 2^min(d, s_p) w_p a_p.
  double screen_weight(std::uint32_t p) const {
    return alpha * std::ldexp(1.0, std::min(static_cast<int>(d), static_cast<int>(s.depth[p]))) * s.w[p] * s.area[p];
  }

  // y = (L + S) x on the active nodes.
  void apply(const std::vector<double>& x, std::vector<double>& y) const {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, L.act.size(), 1024), [&](const auto& r) {
      double buf[27];
      for (std::size_t a = r.begin(); a != r.end(); ++a) {
        const double* st = stencil_of(a, buf);
        const std::int32_t* nb = &nbr[a * 27];
        double sum = 0.0;
        for (int k = 0; k < 27; ++k)
          if (nb[k] >= 0) sum += st[k] * x[nb[k]];
        y[L.act[a]] = sum;
      }
    });
    if (omega > 0.0 && use_mat)
      for_cells_coloured(L, [&](std::uint32_t c) {
        const std::int32_t* idx = &L.corners[c * 8];
        const double* M = &cellmat[std::size_t(c) * 64];
        double xs[8];
        for (int q = 0; q < 8; ++q) xs[q] = x[idx[q]];
        for (int q = 0; q < 8; ++q) {
          double v = 0.0;
          for (int k = 0; k < 8; ++k) v += M[q * 8 + k] * xs[k];
          y[idx[q]] += v;
        }
      });
    else if (omega > 0.0)
      for_cells_coloured(L, [&](std::uint32_t c) {
        const std::int32_t* idx = &L.corners[c * 8];
        for_samples_of(c, [&](std::uint32_t p, const double* w) {
          double v = 0.0;
          for (int q = 0; q < 8; ++q) v += w[q] * x[idx[q]];
          const double f = screen_weight(p) * v;
          for (int q = 0; q < 8; ++q) y[idx[q]] += f * w[q];
        });
      });
  }

  // Adds the screening term's diagonal to diag (which holds the Laplacian's).
  void add_screening_diagonal(std::vector<double>& diag) const {
    if (!(omega > 0.0)) return;
    for_cells_coloured(L, [&](std::uint32_t c) {
      const std::int32_t* idx = &L.corners[c * 8];
      for_samples_of(c, [&](std::uint32_t p, const double* w) {
        const double f = screen_weight(p);
        for (int q = 0; q < 8; ++q) diag[idx[q]] += f * w[q] * w[q];
      });
    });
  }

  const Level& L;
  const std::vector<std::int32_t>& nbr;
  const Samples& s;
  double alpha;
  std::size_t d;
  double omega;
  bool use_mat;
  double Lin[27];
  std::vector<double> cellmat;
};

// b_d += Int V_{<d} . grad H: the coarser depths' splatted V, W as depth-d coefficients.
void Solver::add_coarse_divergence(Level& L, const std::vector<std::int32_t>& nbr, const std::vector<Vec3>& W) const {
  if (std::all_of(W.begin(), W.end(), [](const Vec3& w) { return w == Vec3::Zero(); })) return;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, L.act.size(), 1024), [&](const auto& r) {
    for (std::size_t a = r.begin(); a != r.end(); ++a) L.b[L.act[a]] += divergence_at(L, nbr, a, W);
  });
}

// Jacobi-preconditioned conjugate gradients on the active nodes: x += the solution of A x = r,
// r becomes the residual. Stops after max_iterations or when |r| <= target; returns the
// iterations and the final |r| in `residual`.
int Solver::pcg(const LevelSystem& A, const std::vector<double>& diag, std::vector<double>& r, std::vector<double>& x,
                int max_iterations, double target, double& residual) {
  const Level& L = A.L;
  const std::size_t nE = L.keys.size(), nA = L.act.size();
  std::vector<double> z(nE, 0.0), p(nE, 0.0), Ap(nE, 0.0);
  auto dot = [&](const std::vector<double>& a, const std::vector<double>& b) {
    return det_sum(nA, [&](std::size_t k) { return a[L.act[k]] * b[L.act[k]]; });
  };
  tbb::parallel_for(std::size_t{0}, nA, [&](std::size_t a) {
    const std::size_t i = L.act[a];
    z[i] = r[i] / diag[i];
    p[i] = z[i];
  });
  double rz = dot(r, z), rn = residual;
  int it = 0;
  while (it < max_iterations && rn > target && rn > 0.0) {
    A.apply(p, Ap);
    const double pAp = dot(p, Ap);
    if (!(pAp > 0.0)) break;
    const double alpha = rz / pAp;
    tbb::parallel_for(std::size_t{0}, nA, [&](std::size_t a) {
      const std::size_t i = L.act[a];
      x[i] += alpha * p[i];
      r[i] -= alpha * Ap[i];
      z[i] = r[i] / diag[i];
    });
    ++it;
    rn = std::sqrt(dot(r, r));
    const double rz_new = dot(r, z);
    const double beta = rz_new / rz;
    rz = rz_new;
    tbb::parallel_for(std::size_t{0}, nA, [&](std::size_t a) {
      const std::size_t i = L.act[a];
      p[i] = z[i] + beta * p[i];
    });
  }
  residual = rn;
  return it;
}

void Solver::solve(FieldData& field) {
  Progress prog(cb_, "poisson: solve");
  Stopwatch sw;
  std::vector<std::int32_t> nbr;
  field.levels.resize(levels_.size());
  const int full = std::min(opt_.full_depth, D_);
  std::vector<Vec3> Vc;  // V_{<=d-1} as depth-(d-1) coefficients
  for (std::size_t d = 0; d < levels_.size(); ++d) {
    sw.reset();
    Level& L = levels_[d];
    const std::size_t nE = L.keys.size(), nA = L.act.size();
    LevelDiagnostics ld;
    ld.depth = static_cast<int>(d);
    ld.nodes = nA;
    ld.support_nodes = nE;
    ld.splat_samples = L.splat;
    // P = chi_{<d} at the depth-d nodes: trilinear interpolation of chi_{<=d-1}.
    std::vector<double> P(nE, 0.0);
    if (d > 0) prolong(field.levels[d - 1].index, field.levels[d - 1].value, L.keys, P);
    // V splatted at coarser depths, as depth-d coefficients (V_{<d} is trilinear on depth-d cells).
    std::vector<Vec3> W(nE, Vec3::Zero());
    if (d > 0 && !Vc.empty()) prolong(field.levels[d - 1].index, Vc, L.keys, W);
    build_neighbours(L, nbr);
    // b_d = Int V_{>=d} . grad H (from compute_rhs) + Int V_{<d} . grad H.
    add_coarse_divergence(L, nbr, W);
    if (!L.own.empty())
      for (std::size_t i = 0; i < nE; ++i) W[i] += L.own[i];
    L.own = {};
    Vc = std::move(W);
    const LevelSystem A(L, nbr, s_, opt_.screening, d);
    // Right-hand side: b - (L + S) P; the diagonal for the preconditioner.
    std::vector<double> r(nE, 0.0), diag(nE, 0.0);
    A.apply(P, r);
    tbb::parallel_for(std::size_t{0}, nA, [&](std::size_t a) {
      const std::size_t i = L.act[a];
      r[i] = L.b[i] - r[i];
      double buf[27];
      diag[i] = A.stencil_of(a, buf)[13];
    });
    L.b = {};
    A.add_screening_diagonal(diag);
    diag_.seconds_system += sw.seconds();
    sw.reset();
    std::vector<double> x(nE, 0.0);
    double rn = std::sqrt(det_sum(nA, [&](std::size_t k) { return r[L.act[k]] * r[L.act[k]]; }));
    ld.initial_residual = rn;
    const bool coarse = static_cast<int>(d) <= full;
    const int max_it = coarse ? opt_.coarse_max_iterations : opt_.fine_iterations;
    const double target = coarse ? opt_.coarse_tolerance * rn : 0.0;
    ld.iterations = pcg(A, diag, r, x, max_it, target, rn);
    ld.final_residual = rn;
    FieldLevel& F = field.levels[d];
    F.depth = static_cast<int>(d);
    for (std::size_t i = 0; i < nE; ++i) P[i] += x[i];
    F.value = std::move(P);
    F.keys = std::move(L.keys);
    F.index = std::move(L.index);
    if (d > 0) field.levels[d - 1].keys = {};
    diag_.levels.push_back(ld);
    diag_.seconds_solve += sw.seconds();
    prog.report(double(d + 1) / double(levels_.size()));
  }
  if (!field.levels.empty()) field.levels.back().keys = {};
}

std::shared_ptr<FieldData> Solver::run(const Vec3& origin, double width) {
  D_ = opt_.depth;
  Stopwatch sw;
  const std::size_t N = s_.u.size();
  // Morton order at depth D.
  const int nD = 1 << D_;
  s_.code.resize(N);
  tbb::parallel_for(std::size_t{0}, N, [&](std::size_t i) {
    int x[3];
    for (int a = 0; a < 3; ++a) x[a] = std::clamp(static_cast<int>(std::floor(s_.u[i][a] * nD)), 0, nD - 1);
    s_.code[i] = morton(x[0], x[1], x[2]);
  });
  std::vector<std::uint32_t> order(N);
  std::iota(order.begin(), order.end(), 0u);
  tbb::parallel_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return s_.code[a] != s_.code[b] ? s_.code[a] < s_.code[b] : a < b;
  });
  // Store the samples in Morton order: every later pass (density, splatting, screening per level)
  // walks them cell by cell, and reading them through the permutation was a cache miss per sample.
  auto permute = [&](auto& v) {
    std::remove_reference_t<decltype(v)> out(v.size());
    tbb::parallel_for(std::size_t{0}, N, [&](std::size_t j) { out[j] = v[order[j]]; });
    v.swap(out);
  };
  permute(s_.u);
  permute(s_.n);
  permute(s_.w);
  permute(s_.code);
  Progress prog(cb_, "poisson: octree");
  estimate_density();
  prog.report(0.3);
  build_levels();
  prog.report(1.0);
  diag_.seconds_octree = sw.seconds();
  sw.reset();
  compute_rhs();
  diag_.seconds_splat = sw.seconds();
  auto field = std::make_shared<FieldData>();
  field->origin = origin;
  field->width = width;
  field->max_depth = D_;
  field->reference_gradient = kReferenceGradientConstant * std::ldexp(1.0, D_) / width;
  solve(*field);
  diag_.finest_depth = static_cast<int>(field->levels.size()) - 1;
  field->density = std::move(density_);
  // Iso-value: weighted mean of chi at the samples.
  double wsum = det_sum(N, [&](std::size_t i) { return s_.w[i]; });
  double vsum = det_sum(N, [&](std::size_t i) { return s_.w[i] * field->eval(s_.u[i], nullptr); });
  field->iso = vsum / wsum;
  return field;
}

}  // namespace

void PoissonOptions::validate(const std::string& what) const { schema::check(*this, what); }

PoissonResult reconstruct(const PointCloud& cloud, const PoissonOptions& opt, ProgressCallback progress) {
  Stopwatch total;
  opt.validate();
  cloud.validate("poisson input");
  AUTOSCAN_REQUIRE(cloud.size() >= std::max<std::size_t>(opt.min_points, 4),
                   "poisson input: {} points, at least {} are needed", cloud.size(),
                   std::max<std::size_t>(opt.min_points, 4));
  AUTOSCAN_REQUIRE(cloud.size() < (std::size_t{1} << 31), "poisson input: too many points ({})", cloud.size());
  AUTOSCAN_REQUIRE(cloud.has_normals(), "poisson input: the points have no normals (oriented points are needed)");
  const std::vector<double>* wcol = nullptr;
  if (!opt.weight_scalar.empty()) {
    wcol = cloud.scalars.find(opt.weight_scalar);
    AUTOSCAN_REQUIRE(wcol != nullptr, "poisson input: no weight column '{}'", opt.weight_scalar);
    AUTOSCAN_REQUIRE(wcol->size() == cloud.size(), "poisson input: weight column '{}' has {} values for {} points",
                     opt.weight_scalar, wcol->size(), cloud.size());
  }
  Samples s;
  const AABB box = cloud.bounds();
  const double extent = box.extent().maxCoeff();
  AUTOSCAN_REQUIRE(extent > 0.0 && std::isfinite(extent), "poisson input: all points coincide");
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3& nrm = cloud.normals[i];
    const double len = nrm.norm();
    AUTOSCAN_REQUIRE(std::isfinite(len) && len > 1e-12, "poisson input: normal {} is zero or not finite", i);
    double w = 1.0;
    if (wcol) {
      w = (*wcol)[i];
      AUTOSCAN_REQUIRE(std::isfinite(w) && w >= 0.0, "poisson input: weight {} of point {} is negative or not finite",
                       w, i);
      if (w == 0.0) continue;
    }
    s.u.push_back(cloud.positions[i]);
    s.n.push_back(nrm / len);
    s.w.push_back(w);
  }
  AUTOSCAN_REQUIRE(s.u.size() >= std::max<std::size_t>(opt.min_points, 4),
                   "poisson input: {} points with a positive weight, at least {} are needed", s.u.size(),
                   std::max<std::size_t>(opt.min_points, 4));
  // Coplanarity: the smallest principal extent relative to the largest.
  {
    Vec3 mean = Vec3::Zero();
    for (const Vec3& p : s.u) mean += p;
    mean /= static_cast<double>(s.u.size());
    Mat3 cov = Mat3::Zero();
    for (const Vec3& p : s.u) cov += (p - mean) * (p - mean).transpose();
    cov /= static_cast<double>(s.u.size());
    Eigen::SelfAdjointEigenSolver<Mat3> es(cov);
    const Vec3 ev = es.eigenvalues();
    AUTOSCAN_REQUIRE(ev(0) > 1e-10 * ev(2),
                     "poisson input: all points are coplanar (or collinear); a surface needs "
                     "points spread in three dimensions");
  }
  const double width = opt.scale * extent;
  const Vec3 origin = box.center() - Vec3::Constant(0.5 * width);
  for (Vec3& p : s.u) p = ((p - origin) / width).cwiseMax(0.0).cwiseMin(1.0);

  PoissonResult res;
  res.diagnostics.points = s.u.size();
  Solver solver(opt, s, res.diagnostics, progress);
  auto data = solver.run(origin, width);
  res.field = std::make_shared<PoissonField>(std::move(data));
  if (opt.extract_mesh) {
    Stopwatch sw;
    std::vector<Vec3> seeds(s.u.size());
    for (std::size_t i = 0; i < s.u.size(); ++i) seeds[i] = origin + width * s.u[i];
    res.mesh = extract_surface(*res.field, seeds, opt.vertex_refinement);
    if (opt.trim > 0.0) trim_by_density(res.mesh, opt.trim);
    res.diagnostics.seconds_extract = sw.seconds();
  }
  res.diagnostics.seconds_total = total.seconds();
  log::debug("poisson: {} points, depth {}, {} vertices, {} faces, {:.2f} s", s.u.size(), opt.depth,
             res.mesh.vertices.size(), res.mesh.faces.size(), res.diagnostics.seconds_total);
  return res;
}

}  // namespace autoscan::poisson
