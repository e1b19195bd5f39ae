#include "autoscan/planners/view_gain.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <queue>

#include "autoscan/core/error.hpp"

namespace autoscan::planners {

namespace {
constexpr double kDegToRad = std::numbers::pi / 180.0;
}  // namespace

ViewGain::ViewGain(const TriangleMesh& mesh, std::span<const Vec3> points, const ScannerSpec& scanner, int rays_across)
    : scene_(mesh), points_(points), scanner_(scanner) {
  AUTOSCAN_REQUIRE(!points.empty(), "view gain: no iso-points");
  AUTOSCAN_REQUIRE(rays_across >= 1, "view gain: rays_across must be at least 1 (got {})", rays_across);
  scanner.validate("view gain: scanner");
  cols_ = rays_across;
  rows_ = std::max(1, static_cast<int>(std::lround(double(rays_across) * scanner.height / scanner.width)));
  tan_half_ = std::tan(scanner.fov_deg * kDegToRad / 2.0);
  cos_max_ = std::cos(scanner.max_incidence_deg * kDegToRad);
}

std::vector<std::uint32_t> ViewGain::seen(const Pose& pose) const {
  const Pose p = pose.normalized();
  const Mat3 R = p.rotation();  // columns: right, down, forward
  const double aspect = double(rows_) / double(cols_);
  const auto& normals = scene_.face_normals();
  std::vector<std::uint32_t> out;
  out.reserve(static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows_) / 2);
  for (int v = 0; v < rows_; ++v)
    for (int u = 0; u < cols_; ++u) {
      // The pixel grid's centres, over the horizontal field of view and the same focal length down.
      const double x = (2.0 * (u + 0.5) / cols_ - 1.0) * tan_half_;
      const double y = (2.0 * (v + 0.5) / rows_ - 1.0) * tan_half_ * aspect;
      const Vec3 dir = (R * Vec3(x, y, 1.0)).normalized();
      double t = 0.0;
      const auto prim = scene_.first_hit(p.position, dir, 0.0, scanner_.far, &t);
      if (prim == spatial::RayScene::kNoHit) continue;
      if (-normals[prim].dot(dir) < cos_max_) continue;  // grazing, or the back of a face
      out.push_back(static_cast<std::uint32_t>(points_.nearest(p.position + t * dir)));
    }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<std::vector<std::uint32_t>> ViewGain::seen(std::span<const Pose> poses) const {
  std::vector<std::vector<std::uint32_t>> out(poses.size());
  tbb::parallel_for(std::size_t(0), poses.size(), [&](std::size_t i) { out[i] = seen(poses[i]); });
  return out;
}

std::vector<GainPick> pick_by_gain(const std::vector<std::vector<std::uint32_t>>& seen, std::vector<double> need, int k,
                                   double min_gain) {
  auto gain_of = [&](std::size_t c) {
    double g = 0.0;
    for (const auto i : seen[c]) {
      AUTOSCAN_CHECK(i < need.size(), "pick_by_gain: point {} out of range ({} needs)", i, need.size());
      g += need[i];
    }
    return g;
  };
  // Max-heap on (bound, lower index first).
  using Entry = std::pair<double, std::size_t>;
  auto less = [](const Entry& a, const Entry& b) {
    return a.first < b.first || (a.first == b.first && a.second > b.second);
  };
  std::priority_queue<Entry, std::vector<Entry>, decltype(less)> heap(less);
  for (std::size_t c = 0; c < seen.size(); ++c) heap.push({gain_of(c), c});
  std::vector<GainPick> picks;
  std::vector<char> fresh(seen.size(), 1);  // bound computed since the last pick
  while (static_cast<int>(picks.size()) < k && !heap.empty()) {
    auto [bound, c] = heap.top();
    heap.pop();
    if (!fresh[c]) {
      fresh[c] = 1;
      heap.push({gain_of(c), c});
      continue;
    }
    if (bound < min_gain || !(bound > 0.0)) break;
    picks.push_back({c, bound});
    for (const auto i : seen[c]) need[i] = 0.0;
    std::fill(fresh.begin(), fresh.end(), 0);
  }
  return picks;
}

}  // namespace autoscan::planners
