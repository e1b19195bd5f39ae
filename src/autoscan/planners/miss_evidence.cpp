#include "autoscan/planners/miss_evidence.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "autoscan/core/error.hpp"
#include "autoscan/spatial/ray_scene.hpp"

namespace autoscan::planners {

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

/// The pinhole of the virtual scanner (scanner/virtual_scanner.hpp): pixel (c, r) looks along
/// ((c + 0.5 − cx)/f, (r + 0.5 − cy)/f, 1) in the camera frame (right, down, forward).
struct Pinhole {
  double f, cx, cy;
  explicit Pinhole(const ScannerSpec& spec)
      : f((spec.width / 2.0) / std::tan(spec.fov_deg * kDegToRad / 2.0)), cx(spec.width / 2.0), cy(spec.height / 2.0) {}
};

/// True when a declared fixture lies on the segment a → b (sampled; a mesh fixture, whose shape is
/// not known here, always counts as in the way).
bool fixture_between(const Rig& rig, const Vec3& a, const Vec3& b) {
  for (const auto& fx : rig.fixtures) {
    if (!fx.signed_distance(a).has_value()) return true;
    const double len = (b - a).norm();
    const int steps = std::clamp(static_cast<int>(len / std::max(fx.tolerance, 1e-3)), 8, 256);
    for (int i = 1; i < steps; ++i) {
      const Vec3 p = a + (b - a) * (static_cast<double>(i) / steps);
      if (*fx.signed_distance(p) <= fx.tolerance) return true;
    }
  }
  return false;
}

}  // namespace

int default_block_px(const ScannerSpec& spec) { return std::max(1, spec.width / 640); }

DepthBlocks depth_blocks(const PointCloud& scan, const Pose& pose, const ScannerSpec& spec, int block_px) {
  AUTOSCAN_REQUIRE(block_px > 0, "depth_blocks: the block size must be positive, got {}", block_px);
  DepthBlocks out;
  out.pose = pose.normalized();
  out.block = block_px;
  out.cols = (spec.width + block_px - 1) / block_px;
  out.rows = (spec.height + block_px - 1) / block_px;
  const Pinhole cam(spec);
  const Mat3 R = out.pose.rotation();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<float> own(static_cast<std::size_t>(out.cols) * out.rows, kInf);
  for (const auto& p : scan.positions) {
    const Vec3 d = R.transpose() * (p - out.pose.position);
    if (!(d.z() > 0.0)) continue;
    const double u = cam.f * d.x() / d.z() + cam.cx, v = cam.f * d.y() / d.z() + cam.cy;
    if (!(u >= 0.0 && v >= 0.0 && u < spec.width && v < spec.height)) continue;
    float& m =
        own[static_cast<std::size_t>(static_cast<int>(v) / block_px) * out.cols + static_cast<int>(u) / block_px];
    m = std::min(m, static_cast<float>(d.z()));
  }
  out.nearest.assign(own.size(), kInf);
  for (int r = 0; r < out.rows; ++r)
    for (int c = 0; c < out.cols; ++c) {
      float m = kInf;
      for (int dr = -1; dr <= 1; ++dr)
        for (int dc = -1; dc <= 1; ++dc) {
          const int rr = r + dr, cc = c + dc;
          if (rr >= 0 && cc >= 0 && rr < out.rows && cc < out.cols)
            m = std::min(m, own[static_cast<std::size_t>(rr) * out.cols + cc]);
        }
      out.nearest[static_cast<std::size_t>(r) * out.cols + c] = m;
    }
  return out;
}

std::vector<int> miss_evidence(const PointCloud& points, const std::vector<char>& candidate,
                               const std::vector<DepthBlocks>& scans, const ScannerSpec& spec,
                               const TriangleMesh& model, const Rig& rig, const MissEvidenceOptions& options,
                               const std::function<bool(const Vec3&)>& transparent) {
  AUTOSCAN_REQUIRE(candidate.size() == points.size(), "miss_evidence: {} candidate flags for {} points",
                   candidate.size(), points.size());
  if (scans.empty() || model.empty() || std::none_of(candidate.begin(), candidate.end(), [](char c) { return c; }))
    return std::vector<int>(points.size(), 0);
  return miss_evidence(points, candidate, scans, spec, spatial::RayScene(model), rig, options, transparent);
}

std::vector<int> miss_evidence(const PointCloud& points, const std::vector<char>& candidate,
                               const std::vector<DepthBlocks>& scans, const ScannerSpec& spec,
                               const spatial::RayScene& scene, const Rig& rig, const MissEvidenceOptions& options,
                               const std::function<bool(const Vec3&)>& transparent) {
  const std::size_t n = points.size();
  AUTOSCAN_REQUIRE(candidate.size() == n, "miss_evidence: {} candidate flags for {} points", candidate.size(), n);
  AUTOSCAN_REQUIRE(points.has_normals(), "miss_evidence: the points need normals");
  std::vector<int> evidence(n, 0);
  if (scans.empty() || scene.triangle_count() == 0 ||
      std::none_of(candidate.begin(), candidate.end(), [](char c) { return c; }))
    return evidence;
  const double diag = std::max(scene.bounds().diagonal(), 1e-9);
  const double eps = 0.005 * diag;  // s's own patch does not occlude it
  const double margin = options.depth_margin * diag;
  const double cos_ok = std::cos(std::max(0.0, spec.max_incidence_deg - options.incidence_margin_deg) * kDegToRad);
  const Pinhole cam(spec);
  const std::optional<double> support = rig.support_height();
  std::vector<Mat3> rot(scans.size());
  for (std::size_t j = 0; j < scans.size(); ++j) rot[j] = scans[j].pose.rotation();

  // Occlusion of the segment from `from` to s, stopping eps before s; hits on transparent parts of
  // the model are passed through (at most kMaxPasses of them).
  constexpr int kMaxPasses = 16;
  auto occluded = [&](const Vec3& from, const Vec3& s) {
    const Vec3 d = s - from;
    const double len = d.norm();
    if (len <= eps) return true;
    const double t_end = 1.0 - eps / len;
    if (!transparent) return scene.occluded(from, d, t_end);
    double t0 = 0.0;
    for (int pass = 0; pass < kMaxPasses; ++pass) {
      double t = 0.0;
      if (scene.first_hit(from, d, t0, t_end, &t) == spatial::RayScene::kNoHit) return false;
      if (!transparent(from + t * d)) return true;
      t0 = t + 0.05 * eps / len;  // past the transparent hit
    }
    return true;
  };
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
    if (!candidate[k]) return;
    const Vec3& s = points.positions[k];
    const Vec3& nrm = points.normals[k];
    if (support && s.z() <= *support + 0.01 * diag) return;
    int count = 0;
    for (std::size_t j = 0; j < scans.size() && (options.stop_at <= 0 || count < options.stop_at); ++j) {
      const DepthBlocks& sc = scans[j];
      const Vec3& c = sc.pose.position;
      const Vec3 d = rot[j].transpose() * (s - c);
      if (!(d.z() >= spec.near && d.z() <= spec.far)) continue;
      const double u = cam.f * d.x() / d.z() + cam.cx, v = cam.f * d.y() / d.z() + cam.cy;
      if (!(u >= 0.0 && v >= 0.0 && u < spec.width && v < spec.height)) continue;
      const std::size_t b = static_cast<std::size_t>(static_cast<int>(v) / sc.block) * sc.cols +
                            static_cast<std::size_t>(static_cast<int>(u) / sc.block);
      if (!(d.z() + margin < sc.nearest[b])) continue;  // something returned at or before s
      const Vec3 to_cam = c - s;
      if (nrm.dot(to_cam) < cos_ok * to_cam.norm()) continue;  // grazing or from behind: no return expected
      const Vec3 proj = c + spec.baseline * rot[j].col(0);     // the projector (virtual_scanner.hpp)
      const Vec3 to_proj = proj - s;
      if (nrm.dot(to_proj) < cos_ok * to_proj.norm()) continue;
      if (occluded(c, s) || occluded(proj, s)) continue;
      if (!rig.fixtures.empty() && (fixture_between(rig, c, s) || fixture_between(rig, proj, s))) continue;
      ++count;
    }
    evidence[k] = count;
  });
  return evidence;
}

}  // namespace autoscan::planners
