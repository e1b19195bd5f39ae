// WLOP step: parameters, seeding, attribute transfer; the projection itself is CGAL's (cgal_backend.cpp).
#include <cmath>
#include <numeric>

#include "autoscan/consolidate/cgal_backend.hpp"
#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/consolidate/knn.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::consolidate {

bool wlop_enabled(const WlopOptions& o) {
  switch (o.mode) {
    case WlopMode::on:
      return true;
    case WlopMode::off:
      return false;
    case WlopMode::automatic:
      return o.noise_hint != 0.0;  // unknown (< 0) or positive noise: expected
  }
  return false;
}

WlopReport apply_wlop(PointCloud& cloud, const WlopOptions& o, ProgressCallback progress) {
  AUTOSCAN_REQUIRE(std::isfinite(o.select_percentage) && o.select_percentage > 0.0 && o.select_percentage <= 100.0,
                   "wlop: select_percentage must be in (0, 100] (got {})", o.select_percentage);
  AUTOSCAN_REQUIRE(std::isfinite(o.radius) && o.radius >= 0.0, "wlop: radius must be >= 0 (got {})", o.radius);
  AUTOSCAN_REQUIRE(std::isfinite(o.radius_factor) && o.radius_factor > 0.0,
                   "wlop: radius_factor must be positive (got {})", o.radius_factor);
  AUTOSCAN_REQUIRE(o.spacing_k >= 1, "wlop: spacing_k must be at least 1 (got {})", o.spacing_k);
  AUTOSCAN_REQUIRE(o.iterations >= 1, "wlop: iterations must be at least 1 (got {})", o.iterations);
  validate_cloud(cloud, o.spacing_k, "wlop");
  const std::size_t n = cloud.size();
  const auto samples = static_cast<std::size_t>(static_cast<double>(n) * (o.select_percentage / 100.0));
  AUTOSCAN_REQUIRE(samples >= 4, "wlop: {} % of {} points leaves {} samples; at least 4 are needed",
                   o.select_percentage, n, samples);
  const bool report_progress = static_cast<bool>(progress);
  Progress prog(std::move(progress), "wlop");
  WlopReport r;
  r.points_in = n;
  r.average_spacing = average_spacing(cloud.positions, static_cast<std::size_t>(o.spacing_k));
  r.radius = o.radius > 0.0 ? o.radius : o.radius_factor * r.average_spacing;
  AUTOSCAN_REQUIRE(r.radius > 0.0, "wlop: support radius is 0 (the points have no spacing)");
  r.parallel = o.parallel && detail::cgal_parallel_available();

  // Seeded shuffle: the initial samples are a random subset chosen by `seed` (CGAL then shuffles again,
  // deterministically).
  std::vector<Vec3> input = cloud.positions;
  Rng rng(o.seed);
  for (std::size_t i = n; i > 1; --i) std::swap(input[i - 1], input[rng.uniform_int(i)]);

  // Progress around the CGAL call (see cgal_backend.hpp for why CGAL gets no callback); a progress
  // callback that returns false stops here, before the work starts.
  if (report_progress) prog.report(0.0);
  std::vector<Vec3> out =
      detail::cgal_wlop(std::move(input), o.select_percentage, r.radius, o.iterations, o.uniform_sampling, o.parallel);
  if (report_progress) prog.report(1.0);
  AUTOSCAN_CHECK(!out.empty(), "wlop: CGAL returned no points");

  // Attributes of each new point: those of its nearest input point.
  std::vector<std::size_t> nearest(out.size());
  {
    const spatial::KdTree index(cloud.positions, kKdLeafSize);
    parallel_blocks(out.size(), nullptr, [&](std::size_t b, std::size_t e) {
      std::size_t idx = 0;
      double d2 = 0.0;
      for (std::size_t i = b; i < e; ++i) {
        index.knn(out[i], 1, &idx, &d2);
        nearest[i] = idx;
      }
    });
  }
  cloud.select(nearest);
  cloud.positions = std::move(out);
  r.points_out = cloud.size();
  r.applied = true;
  prog.report(1.0);
  return r;
}

}  // namespace autoscan::consolidate
