// PCA normals over k neighbours, oriented toward the recorded scanner positions or by MST propagation.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <queue>
#include <tuple>

#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/consolidate/knn.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::consolidate {
namespace {

bool has_sensors(const PointCloud& c) {
  return c.scalars.has("sensor_x") && c.scalars.has("sensor_y") && c.scalars.has("sensor_z");
}

/// Unit normal of the least-squares plane through `pts[idx[0..m)]` (the eigenvector of the smallest
/// eigenvalue of their covariance, closed-form 3×3 solver on the trace-normalised covariance); UnitZ
/// when degenerate. Unoriented.
template <typename Index>
Vec3 plane_normal(const std::vector<Vec3>& pts, const Index* idx, std::size_t m,
                  Eigen::SelfAdjointEigenSolver<Mat3>& eig) {
  Vec3 mean = Vec3::Zero();
  for (std::size_t j = 0; j < m; ++j) mean += pts[idx[j]];
  mean /= static_cast<double>(m);
  Mat3 cov = Mat3::Zero();
  for (std::size_t j = 0; j < m; ++j) {
    const Vec3 q = pts[idx[j]] - mean;
    cov.noalias() += q * q.transpose();
  }
  const double tr = cov.trace();
  if (!(tr > 0.0) || !std::isfinite(tr)) return Vec3::UnitZ();
  eig.computeDirect(cov / tr);  // eigenvalues ascending
  const Vec3 n = eig.eigenvectors().col(0);
  const double len = n.norm();
  return (len > 0.0 && std::isfinite(len)) ? Vec3(n / len) : Vec3::UnitZ();
}

/// The k nearest points of each point (the point included), k per point; with `fit`, also the PCA
/// normals over them (unoriented) in cloud.normals.
std::vector<std::uint32_t> neighbours_and_normals(PointCloud& cloud, const spatial::KdTree& index, std::size_t k,
                                                  bool fit, Progress& prog) {
  AUTOSCAN_REQUIRE(cloud.size() < (std::size_t{1} << 32), "normals: {} points is more than supported", cloud.size());
  if (fit) cloud.normals.assign(cloud.size(), Vec3::UnitZ());
  std::vector<std::uint32_t> nbr(cloud.size() * k);
  parallel_blocks(cloud.size(), &prog, [&](std::size_t b, std::size_t e) {
    std::vector<std::size_t> idx(k);
    std::vector<double> d2(k);
    Eigen::SelfAdjointEigenSolver<Mat3> eig;
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t m = index.knn(cloud.positions[i], k, idx.data(), d2.data());  // m == k: size() >= k
      for (std::size_t j = 0; j < k; ++j) nbr[i * k + j] = static_cast<std::uint32_t>(idx[std::min(j, m - 1)]);
      if (fit) cloud.normals[i] = plane_normal(cloud.positions, idx.data(), m, eig);
    }
  });
  return nbr;
}

/// Second PCA pass over the k nearest points whose oriented normal agrees with the point's
/// (n_i · n_j > 0), among its 2k nearest. Two sheets of a thin part closer than the sampling step
/// share k-NN neighbourhoods, which tilts the first fit; once oriented, their normals are opposite and
/// this pass fits each sheet alone. Points whose k neighbours all agree keep the first fit (it is the
/// same fit). Keeps each normal's orientation.
void refine_by_sheet(PointCloud& cloud, const spatial::KdTree& index, std::size_t k,
                     const std::vector<std::uint32_t>& nbr) {
  const std::vector<Vec3> first = cloud.normals;
  const std::size_t m2 = std::min(2 * k, cloud.size());
  parallel_blocks(cloud.size(), nullptr, [&](std::size_t b, std::size_t e) {
    std::vector<std::size_t> idx(m2), same(m2);
    std::vector<double> d2(m2);
    Eigen::SelfAdjointEigenSolver<Mat3> eig;
    for (std::size_t i = b; i < e; ++i) {
      bool mixed = false;
      for (std::size_t j = 0; j < k && !mixed; ++j) mixed = first[nbr[i * k + j]].dot(first[i]) <= 0.0;
      if (!mixed) continue;
      const std::size_t m = index.knn(cloud.positions[i], m2, idx.data(), d2.data());
      std::size_t c = 0;
      for (std::size_t j = 0; j < m && c < k; ++j)
        if (first[idx[j]].dot(first[i]) > 0.0) same[c++] = idx[j];
      if (c < 3) continue;
      const Vec3 n = plane_normal(cloud.positions, same.data(), c, eig);
      cloud.normals[i] = n.dot(first[i]) < 0.0 ? Vec3(-n) : n;
    }
  });
}

}  // namespace

std::size_t orient_toward_sensors(PointCloud& cloud) {
  AUTOSCAN_REQUIRE(has_sensors(cloud),
                   "normals: orientation toward the sensor needs the scalars sensor_x, sensor_y, sensor_z");
  AUTOSCAN_REQUIRE(cloud.has_normals(), "normals: the cloud has no normals to orient");
  const auto& sx = cloud.scalars.get("sensor_x");
  const auto& sy = cloud.scalars.get("sensor_y");
  const auto& sz = cloud.scalars.get("sensor_z");
  std::size_t ambiguous = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3 s(sx[i], sy[i], sz[i]);
    AUTOSCAN_REQUIRE(s.allFinite(), "normals: sensor position of point {} is not finite", i);
    const double dot = cloud.normals[i].dot(s - cloud.positions[i]);
    if (dot < 0.0)
      cloud.normals[i] = -cloud.normals[i];
    else if (dot == 0.0)
      ++ambiguous;
  }
  return ambiguous;
}

namespace {

/// Sign propagation along a minimum spanning tree of the symmetric k-NN graph [Hoppe et al. 1992].
/// Edge cost 1 − |n_i · n_j| (Hoppe's: propagate between parallel normals first) plus
/// `crossing_weight` × (|n_i · e| + |n_j · e|) / 2 with e the unit edge direction: an edge along the
/// normals leaves the surface (it joins two sheets of a thin part, or a point to a sheet it does not
/// lie on), where the sign rule n_i · n_j > 0 is wrong; the cost makes the tree cross there last.
/// Prim's algorithm from the highest point, whose normal is taken to point up (on a closed surface
/// the topmost point's normal points up); each further component of the graph starts at its lowest
/// index, oriented away from `centroid`. Ties are broken by index: deterministic. Returns the number of
/// points outside the first component.
std::size_t mst_propagate(const std::vector<Vec3>& pts, std::vector<Vec3>& normals, const spatial::KdTree& index,
                          std::size_t k, double crossing_weight, const Vec3& centroid) {
  const std::size_t n = pts.size();
  // Symmetric adjacency: i's k nearest other points, and every point that has i among its k nearest.
  std::vector<std::uint32_t> knn(n * k);
  std::vector<std::uint32_t> count(n, 0);
  parallel_blocks(n, nullptr, [&](std::size_t b, std::size_t e) {
    std::vector<std::size_t> idx(k + 1);
    std::vector<double> d2(k + 1);
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t m = index.knn_of_point(i, k, idx.data(), d2.data());
      for (std::size_t j = 0; j < k; ++j) knn[i * k + j] = static_cast<std::uint32_t>(j < m ? idx[j] : i);
    }
  });
  std::vector<std::size_t> start(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < k; ++j)
      if (knn[i * k + j] != i) {
        ++start[i + 1];
        ++start[knn[i * k + j] + 1];
      }
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<std::uint32_t> adj(start[n]);
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < k; ++j) {
      const std::uint32_t o = knn[i * k + j];
      if (o == i) continue;
      adj[fill[i]++] = o;
      adj[fill[o]++] = static_cast<std::uint32_t>(i);
    }
  auto cost = [&](std::size_t i, std::size_t j) {
    const Vec3 d = pts[j] - pts[i];
    const double len = d.norm();
    const double along = len > 0.0 ? 0.5 * (std::abs(normals[i].dot(d)) + std::abs(normals[j].dot(d))) / len : 0.0;
    return 1.0 - std::abs(normals[i].dot(normals[j])) + crossing_weight * along;
  };
  using Entry = std::tuple<double, std::uint32_t, std::uint32_t>;  // cost, to, from: smallest first
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> heap;
  std::vector<char> done(n, 0);
  auto visit = [&](std::size_t i) {
    done[i] = 1;
    for (std::size_t a = start[i]; a < start[i + 1]; ++a)
      if (!done[adj[a]]) heap.emplace(cost(i, adj[a]), adj[a], static_cast<std::uint32_t>(i));
  };
  auto grow = [&](std::size_t seed) {
    std::size_t reached = 0;
    visit(seed);
    ++reached;
    while (!heap.empty()) {
      const auto [c, to, from] = heap.top();
      heap.pop();
      if (done[to]) continue;
      if (normals[to].dot(normals[from]) < 0.0) normals[to] = -normals[to];
      visit(to);
      ++reached;
    }
    return reached;
  };
  std::size_t top = 0;
  for (std::size_t i = 1; i < n; ++i)
    if (pts[i].z() > pts[top].z()) top = i;
  if (normals[top].z() < 0.0) normals[top] = -normals[top];
  const std::size_t first = grow(top);
  for (std::size_t i = 0; i < n; ++i)
    if (!done[i]) {
      if (normals[i].dot(pts[i] - centroid) < 0.0) normals[i] = -normals[i];
      grow(i);
    }
  return n - first;
}

}  // namespace

NormalReport orient_by_mst(PointCloud& cloud, int k, double crossing_weight) {
  AUTOSCAN_REQUIRE(k >= 2, "normals: mst_k must be at least 2 (got {})", k);
  AUTOSCAN_REQUIRE(std::isfinite(crossing_weight) && crossing_weight >= 0.0,
                   "normals: mst_crossing_weight must be >= 0 (got {})", crossing_weight);
  validate_cloud(cloud, k, "normals");
  AUTOSCAN_REQUIRE(cloud.has_normals(), "normals: the cloud has no normals to orient");
  AUTOSCAN_REQUIRE(cloud.size() < (std::size_t{1} << 32), "normals: {} points is more than supported", cloud.size());
  NormalReport r;
  r.orientation = Orientation::mst;
  Vec3 c = Vec3::Zero();
  for (const auto& p : cloud.positions) c += p;
  c /= static_cast<double>(cloud.size());
  const spatial::KdTree index(cloud.positions, kKdLeafSize);
  r.unreached = mst_propagate(cloud.positions, cloud.normals, index, static_cast<std::size_t>(k), crossing_weight, c);
  std::size_t outward = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.normals[i].dot(cloud.positions[i] - c) > 0.0) ++outward;
  if (2 * outward < cloud.size()) {
    r.flipped_all = true;
    for (auto& n : cloud.normals) n = -n;
  }
  return r;
}

namespace {

/// estimate_normals() and orient_normals(): with `fit`, PCA normals first; then orientation and the
/// sheet refinement.
NormalReport normals_step(PointCloud& cloud, const NormalOptions& o, ProgressCallback progress, bool fit) {
  AUTOSCAN_REQUIRE(o.k >= 3, "normals: k must be at least 3 (got {})", o.k);
  validate_cloud(cloud, o.k - 1, "normals");
  if (!fit) AUTOSCAN_REQUIRE(cloud.normals.size() == cloud.size(), "normals: the cloud has no normals to orient");
  Orientation how = o.orientation;
  if (how == Orientation::automatic) how = has_sensors(cloud) ? Orientation::sensor : Orientation::mst;
  if (how == Orientation::sensor)
    AUTOSCAN_REQUIRE(has_sensors(cloud),
                     "normals: orientation 'sensor' needs the scalars sensor_x, sensor_y, sensor_z in the cloud");
  Progress prog(std::move(progress), "normals");
  const spatial::KdTree index(cloud.positions, kKdLeafSize);
  const auto k = static_cast<std::size_t>(o.k);
  const auto nbr = neighbours_and_normals(cloud, index, k, fit, prog);
  NormalReport r;
  if (how == Orientation::sensor) {
    r.orientation = Orientation::sensor;
    r.ambiguous = orient_toward_sensors(cloud);
  } else {
    r = orient_by_mst(cloud, o.mst_k, o.mst_crossing_weight);
  }
  if (o.sheet_refinement) {
    refine_by_sheet(cloud, index, k, nbr);
    if (how == Orientation::sensor) r.ambiguous = orient_toward_sensors(cloud);  // exact by construction
  }
  prog.report(1.0);
  return r;
}

}  // namespace

NormalReport estimate_normals(PointCloud& cloud, const NormalOptions& o, ProgressCallback progress) {
  return normals_step(cloud, o, std::move(progress), true);
}

NormalReport orient_normals(PointCloud& cloud, const NormalOptions& o, ProgressCallback progress) {
  return normals_step(cloud, o, std::move(progress), false);
}

}  // namespace autoscan::consolidate
