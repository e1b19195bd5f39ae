#pragma once
// Internals of the nbv stage shared by its .cpp files (not installed, not for other stages): the
// Embree scene used for visibility and inside tests, the prepared iso-points, the pair weight of
// Eq. 4, a kd-tree over points.
#include <embree3/rtcore.h>

#include <cmath>
#include <memory>
#include <nanoflann.hpp>
#include <vector>

#include "autoscan/nbv/nbv.hpp"

namespace autoscan::nbv::detail {

/// Embree 3 scene of a triangle mesh. Thread-safe queries after construction.
class RayScene {
 public:
  /// Throws InputError for an empty mesh, RuntimeError when Embree fails.
  explicit RayScene(const TriangleMesh& mesh);
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  /// True when the open segment from `from` to `to` hits the mesh (w_v = 0).
  bool occluded(const Vec3& from, const Vec3& to) const;
  /// Inside test by ray parity: the first hit along each of three fixed directions faces away from
  /// the ray (the ray leaves the solid); majority vote. A miss counts as outside.
  bool inside(const Vec3& p) const;
  std::size_t face_count() const { return face_normals_.size(); }

 private:
  int first_hit(const Vec3& org, const Vec3& dir) const;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<Vec3> face_normals_;
};

/// Iso-points prepared for Eq. 4: unit outward normals, a = 1 - f, and the visibility end points
/// s + offset * n (just off the surface, outside).
struct IsoData {
  std::vector<Vec3> p;
  std::vector<Vec3> n;
  std::vector<double> f;
  std::vector<double> a;  ///< 1 - f
  std::vector<Vec3> end;  ///< visibility ray end points
  double diagonal = 0.0;  ///< bounding-box diagonal of p
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

/// nanoflann adaptor over a vector of points.
struct PointsAdaptor {
  const std::vector<Vec3>* pts;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*pts)[i][static_cast<int>(dim)]; }
  template <class BBOX>
  bool kdtree_get_bbox(BBOX&) const {
    return false;
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor,
                                                   3, std::uint32_t>;

/// A kd-tree owning its adaptor (points must outlive it).
class PointTree {
 public:
  explicit PointTree(const std::vector<Vec3>& pts)
      : adaptor_{&pts}, tree_(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    tree_.buildIndex();
  }
  /// Distance to the nearest point (infinity when empty).
  double nearest_distance(const Vec3& q) const {
    if (adaptor_.pts->empty()) return std::numeric_limits<double>::infinity();
    std::uint32_t idx = 0;
    double d2 = 0;
    tree_.knnSearch(q.data(), 1, &idx, &d2);
    return std::sqrt(d2);
  }
  /// Indices of points within `radius` of q, in increasing index order.
  std::vector<std::uint32_t> radius(const Vec3& q, double radius) const {
    std::vector<std::pair<std::uint32_t, double>> m;
    tree_.radiusSearch(q.data(), radius * radius, m, nanoflann::SearchParams(32, 0.f, false));
    std::vector<std::uint32_t> out;
    out.reserve(m.size());
    for (const auto& [i, d] : m) out.push_back(i);
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  PointsAdaptor adaptor_;
  KdTree tree_;
};

/// Candidate mask (§5.1). Empty voxels whose distance to the surface (nearest iso-point) is in
/// [d_n, d_f]; outside tested with `field` when given, else with the mesh.
std::vector<VoxelState> classify_voxels(const GridGeometry& grid, const IsoData& iso, const PointTree& tree,
                                        const ScannerSpec& scanner, const RayScene& scene, const ImplicitField* field,
                                        int block_size);

/// Eq. 4 on every candidate voxel, brute force or fast (see FieldMethod). Fills g, direction, argmax.
void compute_vvf(ViewingField& vf, const IsoData& iso, const RayScene& scene, const Weights& W,
                 const NbvOptions& options, NbvDiagnostics& diag);

}  // namespace autoscan::nbv::detail
