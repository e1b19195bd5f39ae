#include "autoscan/session/supports.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/spatial/kdtree.hpp"
#include "autoscan/spatial/triangle.hpp"

namespace autoscan::session {
namespace {

/// A mesh fixture: its triangles indexed by their centroids; a query looks at the triangles whose
/// centroid lies within (the search radius + the largest centroid-to-corner distance).
struct MeshIndex {
  TriangleMesh mesh;
  std::unique_ptr<spatial::KdTree> tree;
  double reach = 0.0;  // largest distance from a centroid to its triangle's corners

  explicit MeshIndex(TriangleMesh m) : mesh(std::move(m)) {
    std::vector<Vec3> centroids;
    for (const auto& f : mesh.faces) {
      const Vec3 c = (mesh.vertices[static_cast<std::size_t>(f[0])] + mesh.vertices[static_cast<std::size_t>(f[1])] +
                      mesh.vertices[static_cast<std::size_t>(f[2])]) /
                     3.0;
      for (int k = 0; k < 3; ++k) reach = std::max(reach, (mesh.vertices[static_cast<std::size_t>(f[k])] - c).norm());
      centroids.push_back(c);
    }
    tree = std::make_unique<spatial::KdTree>(std::move(centroids));
  }
  /// Distance to the mesh when below `limit` (else a value >= limit).
  double distance(const Vec3& p, double limit) const {
    std::vector<std::pair<spatial::KdTree::Index, double>> hits;
    tree->radius(p, limit + reach, hits);
    double best = limit;
    for (const auto& [i, d2] : hits) {
      const Tri& f = mesh.faces[i];
      const Vec3 q = spatial::closest_point_on_triangle(p, mesh.vertices[static_cast<std::size_t>(f[0])],
                                                        mesh.vertices[static_cast<std::size_t>(f[1])],
                                                        mesh.vertices[static_cast<std::size_t>(f[2])]);
      best = std::min(best, (q - p).norm());
    }
    return best;
  }
};

}  // namespace

struct FixtureGeometry::Impl {
  std::vector<Fixture> fixtures;
  std::vector<std::unique_ptr<MeshIndex>> meshes;  // per fixture; null for a primitive
  std::optional<double> support_top;
};

FixtureGeometry::FixtureGeometry(const Rig& rig) : impl_(std::make_unique<Impl>()) {
  impl_->fixtures = rig.fixtures;
  impl_->support_top = rig.support_height();
  for (std::size_t i = 0; i < rig.fixtures.size(); ++i) {
    const Fixture& f = rig.fixtures[i];
    if (f.kind != Fixture::Kind::mesh) {
      impl_->meshes.push_back(nullptr);
      continue;
    }
    TriangleMesh m = io::read_mesh(f.file);
    AUTOSCAN_REQUIRE(!m.faces.empty(), "{}: {}: the mesh has no triangles", f.label(i), f.file);
    impl_->meshes.push_back(std::make_unique<MeshIndex>(std::move(m)));
  }
}
FixtureGeometry::~FixtureGeometry() = default;
FixtureGeometry::FixtureGeometry(FixtureGeometry&&) noexcept = default;
FixtureGeometry& FixtureGeometry::operator=(FixtureGeometry&&) noexcept = default;

bool FixtureGeometry::empty() const { return impl_->fixtures.empty(); }
std::size_t FixtureGeometry::size() const { return impl_->fixtures.size(); }

double FixtureGeometry::distance(std::size_t i, const Vec3& p) const {
  if (const auto d = impl_->fixtures[i].signed_distance(p)) return *d;
  return impl_->meshes[i]->distance(p, std::numeric_limits<double>::infinity());
}

int FixtureGeometry::owner(const Vec3& p) const {
  for (std::size_t i = 0; i < impl_->fixtures.size(); ++i) {
    const Fixture& f = impl_->fixtures[i];
    const double d = impl_->meshes[i] ? impl_->meshes[i]->distance(p, f.tolerance + 1e-12) : *f.signed_distance(p);
    if (d <= f.tolerance) return static_cast<int>(i);
  }
  return -1;
}

std::optional<SupportPlane> FixtureGeometry::support() const {
  if (!impl_->support_top) return std::nullopt;
  return SupportPlane{Vec3::UnitZ(), *impl_->support_top};
}

namespace {

/// Least-squares plane through `pts` (centroid and the direction of least variance), normal up.
SupportPlane refit(const std::vector<Vec3>& pts) {
  Vec3 c = Vec3::Zero();
  for (const auto& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  Mat3 cov = Mat3::Zero();
  for (const auto& p : pts) cov += (p - c) * (p - c).transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3> es(cov);
  Vec3 n = es.eigenvectors().col(0).normalized();  // smallest eigenvalue first
  if (n.z() < 0) n = -n;
  return {n, n.dot(c)};
}

}  // namespace

std::optional<SupportPlane> detect_support_plane(const PointCloud& cloud, const SupportOptions& o, Rng& rng) {
  const std::size_t n = cloud.size();
  const auto need = std::max<std::size_t>(static_cast<std::size_t>(o.min_inliers),
                                          static_cast<std::size_t>(std::ceil(o.min_inlier_share * double(n))));
  if (n < 3 || n < need) return std::nullopt;
  const bool normals = cloud.has_normals();
  // Score on a fixed subsample (the first draws of `rng`); hypotheses from the same subsample.
  const auto m = std::min<std::size_t>(n, static_cast<std::size_t>(o.ransac_sample));
  std::vector<std::size_t> sample(m);
  for (std::size_t k = 0; k < m; ++k) sample[k] = m == n ? k : static_cast<std::size_t>(rng.uniform_int(n));
  const double cos_tilt = std::cos(o.max_tilt_deg * std::numbers::pi / 180.0);
  const double cos_normal = std::cos(o.normal_tolerance_deg * std::numbers::pi / 180.0);
  const double tol = o.plane_tolerance;
  // Inlier: within the tolerance and (with normals) facing along the plane's normal; below: under it.
  auto classify = [&](std::size_t i, const SupportPlane& pl) {
    const double d = pl.distance(cloud.positions[i]);
    if (std::abs(d) <= tol) {
      if (!normals) return 1;
      const Vec3& nn = cloud.normals[i];
      return std::abs(nn.dot(pl.normal)) >= cos_normal * nn.norm() ? 1 : 0;
    }
    return d < 0 ? -1 : 0;
  };
  struct Count {
    std::size_t in = 0, below = 0;
  };
  auto count = [&](const SupportPlane& pl, bool all) {
    Count c;
    const std::size_t total = all ? n : m;
    for (std::size_t k = 0; k < total; ++k) {
      const int r = classify(all ? k : sample[k], pl);
      c.in += r == 1;
      c.below += r == -1;
    }
    return c;
  };
  // Hypotheses from the points that face up (when the scan has normals): a table seen over a small
  // share of a scan still gets sampled (a triple of uniform draws would hit it with probability
  // share³). Without normals, or fewer than three such points, from the whole subsample.
  std::vector<std::size_t> pool;
  if (normals)
    for (std::size_t k : sample) {
      const Vec3& nn = cloud.normals[k];
      if (nn.z() >= cos_normal * nn.norm() && nn.z() > 0) pool.push_back(k);
    }
  if (pool.size() < 3) pool = sample;
  std::optional<SupportPlane> best;
  std::size_t best_in = 0;
  for (int it = 0; it < o.ransac_iterations; ++it) {
    const Vec3& a = cloud.positions[pool[rng.uniform_int(pool.size())]];
    const Vec3& b = cloud.positions[pool[rng.uniform_int(pool.size())]];
    const Vec3& c = cloud.positions[pool[rng.uniform_int(pool.size())]];
    Vec3 nrm = (b - a).cross(c - a);
    if (nrm.norm() < 1e-15) continue;
    nrm.normalize();
    if (nrm.z() < 0) nrm = -nrm;
    if (nrm.z() < cos_tilt) continue;  // not near-horizontal
    const SupportPlane pl{nrm, nrm.dot(a)};
    const Count k = count(pl, false);
    if (static_cast<double>(k.below) > o.max_below_share * static_cast<double>(m)) continue;  // not under the rest
    if (k.in > best_in) {
      best_in = k.in;
      best = pl;
    }
  }
  if (!best) return std::nullopt;
  // Least-squares refit on every inlier of the whole cloud, twice (the refit plane's inliers).
  for (int round = 0; round < 2; ++round) {
    std::vector<Vec3> inliers;
    for (std::size_t i = 0; i < n; ++i)
      if (classify(i, *best) == 1) inliers.push_back(cloud.positions[i]);
    if (inliers.size() < 3) return std::nullopt;
    const SupportPlane refitted = refit(inliers);
    if (refitted.normal.z() < cos_tilt) break;
    best = refitted;
  }
  const Count k = count(*best, true);
  if (k.in < need || static_cast<double>(k.below) > o.max_below_share * static_cast<double>(n)) return std::nullopt;
  return best;
}

std::vector<std::uint8_t> classify_scan(const PointCloud& scan, const FixtureGeometry& fixtures,
                                        const SupportOptions& o, const std::optional<SupportPlane>& known, Rng& rng,
                                        RemovalReport& report) {
  const std::size_t n = scan.size();
  std::vector<std::uint8_t> code(n, static_cast<std::uint8_t>(RemovalReason::kept));
  report = {};
  if (o.remove_fixtures && !fixtures.empty()) {
    for (std::size_t i = 0; i < n; ++i)
      if (fixtures.owner(scan.positions[i]) >= 0) {
        code[i] = static_cast<std::uint8_t>(RemovalReason::fixture);
        ++report.fixture;
      }
  }
  if (!o.detect_plane || fixtures.support()) return code;
  report.plane = known;
  if (!report.plane) {
    report.plane = detect_support_plane(report.fixture > 0 ? kept_points(scan, code) : scan, o, rng);
    report.plane_detected = report.plane.has_value();
  }
  if (!report.plane) return code;
  for (std::size_t i = 0; i < n; ++i)
    if (code[i] == 0 && report.plane->distance(scan.positions[i]) <= o.plane_tolerance) {
      code[i] = static_cast<std::uint8_t>(RemovalReason::support_plane);
      ++report.support_plane;
    }
  return code;
}

PointCloud kept_points(const PointCloud& cloud, const std::vector<std::uint8_t>& codes) {
  std::vector<std::size_t> keep;
  keep.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (codes[i] == 0) keep.push_back(i);
  PointCloud out = cloud;
  out.select(keep);
  return out;
}

}  // namespace autoscan::session
