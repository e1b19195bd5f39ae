// Confidence map: f_g (Eq. 1), f_s (Eq. 2), f (Eq. 3) on the iso-points, and the coloured mesh.
#include "autoscan/confidence/confidence.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "autoscan/core/error.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/io/colormap.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::confidence {

void ConfidenceOptions::validate(const std::string& what) const { schema::check(*this, what); }

namespace {

double clamp01(double x) { return std::isfinite(x) ? std::clamp(x, 0.0, 1.0) : 0.0; }

}  // namespace

double plane_smoothness(int k, double theta_divisor) {
  AUTOSCAN_REQUIRE(k >= 1, "plane_smoothness: k must be >= 1 (got {})", k);
  AUTOSCAN_REQUIRE(theta_divisor > 0.0, "plane_smoothness: theta_divisor must be > 0 (got {})", theta_divisor);
  const double a2 = theta_divisor * theta_divisor;
  return static_cast<double>(k - 1) * (1.0 - std::exp(-a2)) / a2 + std::exp(-a2);
}

// ABSOLUTE mappings (see the header): the divisors are constants of the set-up (the solver's
// reference gradient at its depth; a perfect plane's Eq. 2 value for K and θ), never statistics of the
// current map. The session's stop rule compares mean f between iterations against 0.005; a mapping
// relative to this iteration's max (or min/max stretch) would rescale each iteration differently and
// make that difference meaningless.
double normalize_completeness(double f_g_raw, double reference_gradient) {
  AUTOSCAN_REQUIRE(reference_gradient > 0.0 && std::isfinite(reference_gradient),
                   "confidence: reference_gradient must be > 0 (got {})", reference_gradient);
  return clamp01(f_g_raw / reference_gradient);
}

double normalize_smoothness(double f_s_raw, double reference_smoothness) {
  AUTOSCAN_REQUIRE(reference_smoothness > 0.0 && std::isfinite(reference_smoothness),
                   "confidence: reference_smoothness must be > 0 (got {})", reference_smoothness);
  return clamp01(f_s_raw / reference_smoothness);
}

TriangleMesh color_mesh(const TriangleMesh& mesh, const PointCloud& iso_points, int neighbours) {
  AUTOSCAN_REQUIRE(!iso_points.empty(), "color_mesh: no iso-points");
  AUTOSCAN_REQUIRE(neighbours >= 1, "color_mesh: neighbours must be >= 1 (got {})", neighbours);
  const char* names[] = {"f", "f_g", "f_s"};
  const std::vector<double>* cols[3];
  for (int c = 0; c < 3; ++c) {
    cols[c] = iso_points.scalars.find(names[c]);
    AUTOSCAN_REQUIRE(cols[c] && cols[c]->size() == iso_points.size(), "color_mesh: iso-points lack scalar '{}'",
                     names[c]);
  }
  TriangleMesh out = mesh;
  const std::size_t nv = out.vertices.size();
  std::vector<double> vals[3];
  for (auto& v : vals) v.assign(nv, 0.0);
  const spatial::KdTree tree(iso_points.positions);
  const std::size_t kk = std::min<std::size_t>(static_cast<std::size_t>(neighbours), iso_points.size());
  const double diag = iso_points.bounds().diagonal();
  const double eps2 = std::max(1e-24, (1e-6 * diag) * (1e-6 * diag));  // keeps 1/d² finite at d = 0
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 512), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<spatial::KdTree::Index> idx(kk);
    std::vector<double> d2(kk);
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      const std::size_t found = tree.knn(out.vertices[v], kk, idx.data(), d2.data());
      double wsum = 0.0, acc[3] = {0.0, 0.0, 0.0};
      for (std::size_t j = 0; j < found; ++j) {
        const double w = 1.0 / (d2[j] + eps2);
        wsum += w;
        for (int c = 0; c < 3; ++c) acc[c] += w * (*cols[c])[idx[j]];
      }
      for (int c = 0; c < 3; ++c) vals[c][v] = wsum > 0.0 ? acc[c] / wsum : 0.0;
    }
  });
  out.vertex_colors.resize(nv);
  for (std::size_t v = 0; v < nv; ++v) out.vertex_colors[v] = io::colormap(vals[0][v]);
  for (int c = 0; c < 3; ++c) out.vertex_scalars.set(names[c], std::move(vals[c]));
  return out;
}

struct ConfidenceEvaluator::Impl {
  ConfidenceOptions options;
  std::vector<Vec3> raw;
  std::unique_ptr<spatial::KdTree> tree;  // refers to `raw`: Impl is never copied or moved, only its pointer
};

ConfidenceEvaluator::ConfidenceEvaluator(const PointCloud& raw, ConfidenceOptions options)
    : ConfidenceEvaluator(raw.positions, std::move(options)) {}

ConfidenceEvaluator::ConfidenceEvaluator(std::vector<Vec3> raw_positions, ConfidenceOptions options)
    : impl_(std::make_unique<Impl>()) {
  options.validate();
  AUTOSCAN_REQUIRE(!raw_positions.empty(), "confidence: the raw point cloud is empty");
  AUTOSCAN_REQUIRE(raw_positions.size() >= static_cast<std::size_t>(options.k),
                   "confidence: k = {} (K of Eq. 2) is larger than the raw point cloud ({} points)", options.k,
                   raw_positions.size());
  AUTOSCAN_REQUIRE(raw_positions.size() < std::numeric_limits<spatial::KdTree::Index>::max(),
                   "confidence: too many raw points ({})", raw_positions.size());
  for (std::size_t i = 0; i < raw_positions.size(); ++i)
    AUTOSCAN_REQUIRE(raw_positions[i].allFinite(), "confidence: raw point {} has a non-finite coordinate", i);
  impl_->options = std::move(options);
  impl_->raw = std::move(raw_positions);
  impl_->tree = std::make_unique<spatial::KdTree>(impl_->raw);
}

ConfidenceEvaluator::~ConfidenceEvaluator() = default;
ConfidenceEvaluator::ConfidenceEvaluator(ConfidenceEvaluator&&) noexcept = default;
ConfidenceEvaluator& ConfidenceEvaluator::operator=(ConfidenceEvaluator&&) noexcept = default;

const ConfidenceOptions& ConfidenceEvaluator::options() const { return impl_->options; }
std::size_t ConfidenceEvaluator::raw_size() const { return impl_->raw.size(); }
const std::vector<Vec3>& ConfidenceEvaluator::raw_positions() const { return impl_->raw; }

std::vector<double> ConfidenceEvaluator::smoothness(std::span<const Vec3> points, std::span<const Vec3> normals,
                                                    std::vector<double>* support) const {
  AUTOSCAN_REQUIRE(points.size() == normals.size(), "confidence: {} points but {} normals", points.size(),
                   normals.size());
  const auto& o = impl_->options;
  const std::size_t n = points.size();
  const auto k = static_cast<std::size_t>(o.k);
  const double a2 = o.theta_divisor * o.theta_divisor, b2 = o.phi_divisor * o.phi_divisor;
  const auto& raw = impl_->raw;
  const auto& tree = *impl_->tree;
  std::vector<double> fs(n, 0.0);
  if (support) support->assign(n, 0.0);
  Progress progress(o.progress, "confidence");
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<spatial::KdTree::Index> idx(k);
    std::vector<double> d2(k);
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const Vec3& s = points[i];
      const double nn = normals[i].norm();
      const Vec3 nk = nn > 0.0 ? Vec3(normals[i] / nn) : Vec3::Zero();
      const std::size_t found = tree.knn(s, k, idx.data(), d2.data());
      // Eq. 2: h_k = max_j ‖s_k − q_j‖ (the results are sorted, the last is the farthest).
      const double h2 = found ? d2[found - 1] : 0.0;
      double sum = 0.0;
      if (h2 > 0.0) {
        const double inv = 1.0 / h2;
        for (std::size_t j = 0; j < found; ++j) {
          const double t = nk.dot(raw[idx[j]] - s);
          // θ = exp(−d²/(h/a)²) = exp(−a² d²/h²); φ = exp(−b² (nᵀ(q − s))²/h²).
          sum += std::exp(-(a2 * d2[j] + b2 * t * t) * inv);
        }
      } else {
        sum = static_cast<double>(found);  // all K neighbours coincide with s_k: θ = φ = 1
      }
      fs[i] = sum;
      if (support) (*support)[i] = std::sqrt(h2);
    }
    if (o.progress) {
      const std::size_t d = done.fetch_add(r.size()) + r.size();
      progress.report(0.2 + 0.7 * static_cast<double>(d) / static_cast<double>(n));
    }
  });
  return fs;
}

ConfidenceResult ConfidenceEvaluator::score(const IsoPoints& iso, const TriangleMesh& mesh,
                                            double reference_gradient) const {
  AUTOSCAN_REQUIRE(reference_gradient > 0.0 && std::isfinite(reference_gradient),
                   "confidence: reference_gradient must be > 0 (got {})", reference_gradient);
  const std::size_t n = iso.positions.size();
  AUTOSCAN_REQUIRE(n > 0, "confidence: no iso-points to score");
  AUTOSCAN_REQUIRE(iso.inward_normals.size() == n && iso.gradients.size() == n,
                   "confidence: iso-points have {} positions, {} normals, {} gradients", n, iso.inward_normals.size(),
                   iso.gradients.size());
  const auto& o = impl_->options;
  Stopwatch sw;
  ConfidenceResult res;
  res.reference_gradient = reference_gradient;
  res.reference_smoothness =
      o.reference_smoothness > 0.0 ? o.reference_smoothness : plane_smoothness(o.k, o.theta_divisor);
  res.spacing = iso.spacing;
  res.candidates = iso.candidates;
  res.max_projection_residual = iso.max_residual;
  res.mean_projection_residual = iso.mean_residual;

  std::vector<double> h;
  std::vector<double> fs_raw = smoothness(iso.positions, iso.inward_normals, &h);
  res.seconds_smoothness = sw.seconds();

  std::vector<double> fg_raw(n), fg(n), fs(n), f(n);
  auto& cloud = res.iso_points;
  cloud.positions = iso.positions;
  cloud.normals.resize(n);
  cloud.colors.resize(n);
  res.inward_normals = iso.inward_normals;
  double sf = 0.0, sg = 0.0, ss = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    // Eq. 1: f_g = Γ(s_k)·n_k, n_k the inward unit normal (|Γ| where n_k is the gradient direction).
    fg_raw[i] = iso.gradients[i].dot(iso.inward_normals[i]);
    fg[i] = normalize_completeness(fg_raw[i], reference_gradient);
    fs[i] = normalize_smoothness(fs_raw[i], res.reference_smoothness);
    f[i] = fg[i] * fs[i];  // Eq. 3
    cloud.normals[i] = -iso.inward_normals[i];
    cloud.colors[i] = io::colormap(f[i]);
    sf += f[i];
    sg += fg[i];
    ss += fs[i];
  }
  const double inv = 1.0 / static_cast<double>(n);
  res.mean_f = sf * inv;
  res.mean_f_g = sg * inv;
  res.mean_f_s = ss * inv;
  cloud.scalars.set("f", std::move(f));
  cloud.scalars.set("f_g", std::move(fg));
  cloud.scalars.set("f_s", std::move(fs));
  cloud.scalars.set("f_g_raw", std::move(fg_raw));
  cloud.scalars.set("f_s_raw", std::move(fs_raw));
  cloud.scalars.set("h", std::move(h));

  Stopwatch swm;
  if (!mesh.vertices.empty()) res.mesh = color_mesh(mesh, cloud, o.mesh_neighbours);
  res.seconds_mesh = swm.seconds();
  Progress(o.progress, "confidence").report(1.0);
  return res;
}

ConfidenceResult ConfidenceEvaluator::assess(const ImplicitField& field, const TriangleMesh& mesh,
                                             double reference_gradient) const {
  AUTOSCAN_REQUIRE(reference_gradient > 0.0 && std::isfinite(reference_gradient),
                   "confidence: reference_gradient must be > 0 (got {})", reference_gradient);
  Stopwatch total;
  Progress(impl_->options.progress, "confidence").report(0.0);
  const IsoPoints iso = sample_iso_points(field, mesh, impl_->options.iso);
  const double t_sample = total.seconds();
  Progress(impl_->options.progress, "confidence").report(0.2);
  ConfidenceResult res = score(iso, mesh, reference_gradient);
  res.seconds_sampling = t_sample;
  res.seconds_total = total.seconds();
  return res;
}

ConfidenceResult assess_confidence(const ImplicitField& field, const TriangleMesh& mesh, const PointCloud& raw,
                                   double reference_gradient, const ConfidenceOptions& options) {
  AUTOSCAN_REQUIRE(!mesh.faces.empty(), "confidence: the iso-surface mesh is empty (no triangles)");
  return ConfidenceEvaluator(raw, options).assess(field, mesh, reference_gradient);
}

}  // namespace autoscan::confidence
