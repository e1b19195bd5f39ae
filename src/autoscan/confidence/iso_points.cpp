// Iso-points: Poisson-disk sampling of the iso-surface (paper §4.2, [Corsini et al. 2012]) by weighted
// sample elimination [Yuksel 2015], then Newton projection onto the iso-surface of the field.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include "autoscan/confidence/confidence.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::confidence {

namespace {

constexpr std::size_t kMaxIsoPoints = 20'000'000;  // guards absurd spacings (memory)

struct Candidates {
  std::vector<Vec3> positions;
  std::vector<int> faces;  // face each candidate lies on (for the fallback normal)
};

// Uniform random points on the mesh surface: a face by area, then uniform barycentric coordinates.
Candidates uniform_candidates(const TriangleMesh& mesh, const std::vector<double>& cdf, std::size_t m,
                              std::uint64_t seed) {
  Candidates c;
  c.positions.resize(m);
  c.faces.resize(m);
  Rng rng(seed);
  const double total = cdf.back();
  for (std::size_t i = 0; i < m; ++i) {
    const double u = rng.uniform() * total;
    auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
    if (it == cdf.end()) --it;
    const int f = static_cast<int>(it - cdf.begin());
    const double su = std::sqrt(rng.uniform());
    const double v = rng.uniform();
    const Tri& t = mesh.faces[static_cast<std::size_t>(f)];
    const Vec3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
    const Vec3& b = mesh.vertices[static_cast<std::size_t>(t[1])];
    const Vec3& cc = mesh.vertices[static_cast<std::size_t>(t[2])];
    c.positions[i] = (1.0 - su) * a + su * (1.0 - v) * b + su * v * cc;
    c.faces[i] = f;
  }
  return c;
}

// Weighted sample elimination [Yuksel 2015, "Sample Elimination for Generating Poisson Disk Sample
// Sets"]: each candidate gets the weight Σ_j (1 − d̂_ij/(2 r_max))^α over its neighbours within
// 2 r_max (d̂ = max(d, 2 r_min)); the heaviest candidate is removed and its neighbours' weights
// lowered, until n remain. Serial and index-ordered: deterministic.
std::vector<std::size_t> eliminate(const std::vector<Vec3>& cand, std::size_t n, double r_max, double alpha) {
  const std::size_t m = cand.size();
  std::vector<std::size_t> keep;
  if (n >= m) {
    keep.resize(m);
    for (std::size_t i = 0; i < m; ++i) keep[i] = i;
    return keep;
  }
  constexpr double gamma = 1.5, beta = 0.65;  // Yuksel's r_min = r_max (1 − (n/m)^γ) β
  const double r_min = r_max * (1.0 - std::pow(static_cast<double>(n) / static_cast<double>(m), gamma)) * beta;
  const double two_rmax = 2.0 * r_max;
  auto weight = [&](double d) {
    const double dd = std::clamp(d, 2.0 * r_min, two_rmax);
    return std::pow(1.0 - dd / two_rmax, alpha);
  };

  const spatial::KdTree tree(cand);
  std::vector<std::vector<std::pair<spatial::KdTree::Index, double>>> nbrs(m);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m, 256), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<std::pair<spatial::KdTree::Index, double>> found;
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      tree.radius(cand[i], two_rmax, found);
      auto& out = nbrs[i];
      out.reserve(found.size());
      for (const auto& [j, d2] : found)
        if (j != i) out.emplace_back(j, std::sqrt(d2));
      // Sorted by index so that the order of the weight sums does not depend on the tree traversal.
      std::sort(out.begin(), out.end());
    }
  });

  std::vector<double> w(m, 0.0);
  for (std::size_t i = 0; i < m; ++i)
    for (const auto& [j, d] : nbrs[i]) w[i] += weight(d);
  std::priority_queue<std::pair<double, std::size_t>> heap;
  for (std::size_t i = 0; i < m; ++i) heap.emplace(w[i], i);
  std::vector<char> alive(m, 1);
  std::size_t remaining = m;
  while (remaining > n && !heap.empty()) {
    const auto [wi, i] = heap.top();
    heap.pop();
    if (!alive[i] || wi != w[i]) continue;  // removed, or a stale entry
    alive[i] = 0;
    --remaining;
    for (const auto& [j, d] : nbrs[i]) {
      if (!alive[j]) continue;
      w[j] -= weight(d);
      heap.emplace(w[j], j);
    }
  }
  keep.reserve(n);
  for (std::size_t i = 0; i < m; ++i)
    if (alive[i]) keep.push_back(i);
  return keep;
}

}  // namespace

void IsoPointOptions::validate(const std::string& what) const {
  schema::check(*this, what);
  AUTOSCAN_REQUIRE(spacing > 0.0 || count >= 1, "{}: count must be >= 1 when no spacing is given", what);
}

IsoPoints sample_iso_points(const ImplicitField& field, const TriangleMesh& mesh, const IsoPointOptions& options) {
  options.validate();
  AUTOSCAN_REQUIRE(!mesh.faces.empty(), "iso-points: the iso-surface mesh is empty (no triangles)");
  mesh.validate("iso-surface mesh");

  // Area CDF over the faces.
  std::vector<double> cdf(mesh.faces.size());
  double area = 0.0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const Tri& t = mesh.faces[f];
    const Vec3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
    area += 0.5 * (mesh.vertices[static_cast<std::size_t>(t[1])] - a)
                      .cross(mesh.vertices[static_cast<std::size_t>(t[2])] - a)
                      .norm();
    cdf[f] = area;
  }
  AUTOSCAN_REQUIRE(area > 0.0 && std::isfinite(area), "iso-points: the iso-surface mesh has zero area");

  // Hexagonal packing: each sample owns 2√3 r_max² of area [Yuksel 2015]; spacing = 2 r_max.
  const double cell = 2.0 * std::sqrt(3.0);
  std::size_t n = options.count;
  double r_max = 0.0;
  if (options.spacing > 0.0) {
    r_max = 0.5 * options.spacing;
    const double nd = std::ceil(area / (cell * r_max * r_max));
    AUTOSCAN_REQUIRE(nd <= static_cast<double>(kMaxIsoPoints),
                     "iso-points: spacing {} gives {:.0f} iso-points on an area of {} (at most {})", options.spacing,
                     nd, area, kMaxIsoPoints);
    n = std::max<std::size_t>(1, static_cast<std::size_t>(nd));
  } else {
    AUTOSCAN_REQUIRE(n <= kMaxIsoPoints, "iso-points: count {} is above the maximum {}", n, kMaxIsoPoints);
    r_max = std::sqrt(area / (cell * static_cast<double>(n)));
  }
  const auto m = static_cast<std::size_t>(std::ceil(options.candidate_factor * static_cast<double>(n)));

  IsoPoints iso;
  iso.spacing = 2.0 * r_max;
  iso.surface_area = area;
  iso.candidates = m;
  const Candidates cand = uniform_candidates(mesh, cdf, m, options.seed);
  const std::vector<std::size_t> keep = eliminate(cand.positions, n, r_max, options.elimination_alpha);

  const std::size_t k = keep.size();
  iso.positions.resize(k);
  iso.inward_normals.resize(k);
  iso.gradients.resize(k);
  std::vector<double> residual(k, 0.0), moved(k, 0.0);
  const double iso_value = field.iso_value();
  const double max_step = options.max_step_fraction * iso.spacing;
  const auto face_normals = mesh.face_normals();

  // Newton projection onto F = iso along the gradient: p ← p − (F(p) − iso)·∇F/|∇F|², each step clamped
  // to max_step. Chunked batch calls so that a field may parallelise or vectorise its queries.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, k, 128), [&](const tbb::blocked_range<std::size_t>& r) {
    const std::size_t b = r.begin(), e = r.end(), len = e - b;
    std::vector<Vec3> p(len), g(len);
    std::vector<double> v(len);
    for (std::size_t i = 0; i < len; ++i) p[i] = cand.positions[keep[b + i]];
    for (int step = 0; step < options.projection_steps; ++step) {
      field.values(p, v);
      field.gradients(p, g);
      for (std::size_t i = 0; i < len; ++i) {
        const double g2 = g[i].squaredNorm();
        if (!(g2 > 0.0) || !std::isfinite(g2) || !std::isfinite(v[i])) continue;
        Vec3 delta = -(v[i] - iso_value) / g2 * g[i];
        const double dn = delta.norm();
        if (dn > max_step) delta *= max_step / dn;
        p[i] += delta;
      }
    }
    field.values(p, v);
    field.gradients(p, g);
    for (std::size_t i = 0; i < len; ++i) {
      const std::size_t idx = b + i;
      const std::size_t c = keep[idx];
      iso.positions[idx] = p[i];
      const double gn = g[i].norm();
      const bool ok = gn > 0.0 && std::isfinite(gn);
      iso.gradients[idx] = g[i].allFinite() ? g[i] : Vec3::Zero();
      // Inward = along the gradient (the field is larger inside); where the field is flat, the
      // mesh's outward face normal, negated.
      iso.inward_normals[idx] = ok ? Vec3(g[i] / gn) : Vec3(-face_normals[static_cast<std::size_t>(cand.faces[c])]);
      residual[idx] = ok && std::isfinite(v[i]) ? std::abs(v[i] - iso_value) / gn : 0.0;
      moved[idx] = (p[i] - cand.positions[c]).norm();
    }
  });
  double sum = 0.0;
  for (std::size_t i = 0; i < k; ++i) {
    iso.max_residual = std::max(iso.max_residual, residual[i]);
    iso.max_displacement = std::max(iso.max_displacement, moved[i]);
    sum += residual[i];
  }
  iso.mean_residual = k ? sum / static_cast<double>(k) : 0.0;
  return iso;
}

}  // namespace autoscan::confidence
