#pragma once
// Internals of the nbv stage shared by its .cpp files (not for other stages): the ray scene of the
// mesh, the prepared iso-points, the pair weight of Eq. 4, radius queries on the iso-points' kd-tree.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "autoscan/nbv/nbv.hpp"
#include "autoscan/spatial/kdtree.hpp"
#include "autoscan/spatial/ray_scene.hpp"

namespace autoscan::nbv::detail {

/// The spatial floor's ray scene of the (Poisson) mesh, for visibility (w_v of Eq. 4) and the
/// inside test of the candidate space; built with Embree's high quality (millions of rays per build).
/// Throws InputError for a mesh without triangles or an invalid one.
std::unique_ptr<spatial::RayScene> make_scene(const TriangleMesh& mesh);

/// Iso-points prepared for Eq. 4: unit outward normals, a = 1 - f, and the visibility end points
/// s + offset * n (just off the surface, outside).
struct IsoData {
  std::vector<Vec3> p;
  std::vector<Vec3> n;
  std::vector<double> f;
  std::vector<double> a;     ///< 1 - f
  std::vector<Vec3> end;     ///< visibility ray end points
  std::vector<double> need;  ///< joint selection: (tau - f) / tau below tau = NbvOptions::done_confidence, else 0
  double diagonal = 0.0;     ///< bounding-box diagonal of p
  std::size_t size() const { return p.size(); }
};

/// Throws InputError for no points, missing normals or "f", non-finite values, zero normals, f
/// outside [0, 1] (a tolerance of 1e-9 is clamped).
IsoData prepare_iso(const PointCloud& iso, const NbvOptions& options);

/// Constants of Eq. 4 for one scanner and option set.
struct Weights {
  double d_o = 1.0;      ///< optimal distance (d_n + d_f) / 2
  double inv_sd2 = 1.0;  ///< 1 / (d_n/4)^2
  double inv_so2 = 1.0;  ///< 1 / (1 - cos sigma)^2
  double near = 0.0, far = 0.0;
  static Weights make(const ScannerSpec& s, const NbvOptions& o) {
    Weights w;
    w.d_o = s.optimal_distance();
    const double sd = o.distance_width_factor * s.near;
    w.inv_sd2 = 1.0 / (sd * sd);
    const double so = 1.0 - std::cos(o.sigma_deg * M_PI / 180.0);
    w.inv_so2 = 1.0 / (so * so);
    w.near = s.near;
    w.far = s.far;
    return w;
  }
};

/// w_d * w_o of Eq. 4 for voxel v and iso-point s with OUTWARD unit normal n_out. The paper's n_k
/// points inward (n_k = -n_out), so its 1 + n_k^T d(v, s) is 1 - n_out^T d(v, s) here.
/// The single definition used by the reference, the fast path and Eq. 5 (bitwise-equal results).
inline double pair_weight(const Weights& W, const Vec3& v, const Vec3& s, const Vec3& n_out) {
  const Vec3 d = v - s;
  const double r = d.norm();
  if (!(r > 0.0)) return 0.0;
  const double c = n_out.dot(d) / r;
  const double wd = std::exp(-(r - W.d_o) * (r - W.d_o) * W.inv_sd2);
  const double wo = std::exp(-(1.0 - c) * (1.0 - c) * W.inv_so2);
  return wd * wo;
}

/// Distance from q to the nearest point of `tree` (infinity when empty).
inline double nearest_distance(const spatial::KdTree& tree, const Vec3& q) {
  double d2 = 0.0;
  tree.nearest(q, &d2);
  return std::sqrt(d2);
}

/// Indices of the points of `tree` within `radius` of q (strictly), in increasing index order.
inline std::vector<std::uint32_t> radius_indices(const spatial::KdTree& tree, const Vec3& q, double radius) {
  std::vector<std::pair<spatial::KdTree::Index, double>> m;
  tree.radius(q, radius, m);
  std::vector<std::uint32_t> out;
  out.reserve(m.size());
  for (const auto& [i, d] : m) out.push_back(i);
  std::sort(out.begin(), out.end());
  return out;
}

/// Candidate mask (§5.1). Empty voxels whose distance to the surface (nearest iso-point) is in
/// [d_n, d_f]; outside tested with `field` when given, else with the mesh. With a `ground` (a scene
/// rig's, issue 18) the voxels whose centre lies at or below it are inside the ground: never views,
/// and their candidates are not joined with those above (the surface under a scene's ground is open
/// at the solver's box, so one component could otherwise wrap around its edge).
std::vector<VoxelState> classify_voxels(const GridGeometry& grid, const IsoData& iso, const spatial::KdTree& tree,
                                        const ScannerSpec& scanner, const spatial::RayScene& scene,
                                        const ImplicitField* field, int block_size,
                                        std::optional<double> ground = std::nullopt);

/// Eq. 4 on every candidate voxel, brute force or fast (see FieldMethod). Fills g, direction, argmax.
void compute_vvf(ViewingField& vf, const IsoData& iso, const spatial::RayScene& scene, const Weights& W,
                 const NbvOptions& options, NbvDiagnostics& diag);

/// Eq. 5's result: the iso-point s_k' a view at v aims at, with its eta and zeta.
struct AimResult {
  bool ok = false;  ///< false when no visible iso-point of Upsilon_k lies within [d_n, d_f] of v
  int target = -1;
  double eta = 0.0, zeta = 0.0;
};
/// Eq. 5 for a view at `v` whose field maximiser is iso-point `seed` (planner.cpp).
AimResult aim(const Vec3& v, int seed, const IsoData& iso, const spatial::KdTree& tree, const spatial::RayScene& scene,
              const Weights& W, const ScannerSpec& sc, const NbvOptions& o);

/// What one view would measure (select.cpp): the iso-points inside its frustum, within [d_n, d_f],
/// visible, and seen at an incidence up to the scanner's max_incidence_deg, each with the quality q
/// in (0, 1] the scanner model predicts there (σ at d_o and normal incidence over σ at the point,
/// ScannerSpec::relative_depth_sigma, capped at 1). Only points with need a = 1 - f > tolerance.
struct Coverage {
  std::vector<std::uint32_t> index;  ///< iso-point indices, increasing
  std::vector<float> q;              ///< quality per entry of `index`
  std::size_t rays = 0;              ///< visibility rays cast
};
Coverage view_coverage(const Pose& pose, const IsoData& iso, const spatial::KdTree& tree,
                       const spatial::RayScene& scene, const ScannerSpec& sc);

/// A candidate of the joint selection: a reachable, aimed view and what it would measure.
struct PoolView {
  NbvView view;
  Coverage coverage;
};

/// Regions of low confidence (f < o.region_confidence) that no candidate of `pool` covers to at
/// least half of their need: for each, the candidate voxel whose view measures most of the region
/// (scanner model, not Eq. 4's orientation term), aimed at what it sees. Appends to `pool`.
void add_region_views(std::vector<PoolView>& pool, const ViewingField& vf, const IsoData& iso,
                      const spatial::KdTree& tree, const spatial::RayScene& scene, const ScannerSpec& sc,
                      const Rig& rig, const NbvOptions& o, NbvDiagnostics& diag);

/// Greedy selection of at most o.max_views views of `pool` maximising the facility-location
/// objective sum_k need_k max_{v in S} q_{v,k} (submodular: each pick's value is what the earlier picks
/// of the round do not already measure as well), with lazy evaluation; stops when the best marginal
/// gain is below o.min_view_gain * #iso-points. Returns the picks in selection order, gain filled in.
std::vector<NbvView> select_joint(std::vector<PoolView>& pool, const IsoData& iso, const NbvOptions& o,
                                  NbvDiagnostics& diag);

}  // namespace autoscan::nbv::detail
