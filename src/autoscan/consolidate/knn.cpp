#include "autoscan/consolidate/knn.hpp"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::consolidate {

void parallel_blocks(std::size_t n, Progress* progress, const std::function<void(std::size_t, std::size_t)>& body) {
  constexpr std::size_t kBlock = 1 << 15;
  for (std::size_t b = 0; b < n; b += kBlock) {
    const std::size_t e = std::min(n, b + kBlock);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(b, e, 256),
                      [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
    if (progress) progress->report(static_cast<double>(e) / static_cast<double>(n));
  }
}

std::vector<double> knn_mean_distances(const std::vector<Vec3>& points, std::size_t k, Progress* progress) {
  std::vector<double> out(points.size(), 0.0);
  if (points.empty() || k == 0) return out;
  const spatial::KdTree index(points, kKdLeafSize);
  parallel_blocks(points.size(), progress, [&](std::size_t b, std::size_t e) {
    std::vector<std::size_t> idx(k + 1);
    std::vector<double> d2(k + 1);
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t m = index.knn_of_point(i, k, idx.data(), d2.data());
      double s = 0.0;
      for (std::size_t j = 0; j < m; ++j) s += std::sqrt(d2[j]);
      out[i] = m > 0 ? s / static_cast<double>(m) : 0.0;
    }
  });
  return out;
}

double average_spacing(const std::vector<Vec3>& points, std::size_t k, Progress* progress) {
  const auto d = knn_mean_distances(points, k, progress);
  if (d.empty()) return 0.0;
  // Sequential sum in index order: deterministic.
  double s = 0.0;
  for (double v : d) s += v;
  return s / static_cast<double>(d.size());
}

}  // namespace autoscan::consolidate
