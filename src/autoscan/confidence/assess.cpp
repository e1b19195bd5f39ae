#include "autoscan/confidence/assess.hpp"

#include "autoscan/core/error.hpp"

namespace autoscan::confidence {

namespace {
void check(const poisson::PoissonResult& recon) {
  AUTOSCAN_REQUIRE(recon.field != nullptr, "confidence: the Poisson reconstruction has no field");
  AUTOSCAN_REQUIRE(!recon.mesh.faces.empty(), "confidence: the Poisson iso-surface mesh is empty (no triangles)");
}
}  // namespace

ConfidenceResult assess(const poisson::PoissonResult& recon, const ConfidenceEvaluator& evaluator) {
  check(recon);
  return evaluator.assess(*recon.field, recon.mesh, recon.field->reference_gradient());
}

ConfidenceResult assess(const poisson::PoissonResult& recon, const PointCloud& raw, const ConfidenceOptions& options) {
  check(recon);
  return assess(recon, ConfidenceEvaluator(raw, options));
}

CloudAssessment assess_cloud(const PointCloud& cloud, const poisson::PoissonOptions& poisson_options,
                             const ConfidenceOptions& options) {
  AUTOSCAN_REQUIRE(!cloud.empty(), "confidence: the point cloud is empty");
  AUTOSCAN_REQUIRE(cloud.has_normals(),
                   "confidence: the point cloud has no normals (the Poisson reconstruction needs oriented "
                   "points; run `autoscan consolidate` first)");
  AUTOSCAN_REQUIRE(cloud.size() >= static_cast<std::size_t>(std::max(options.k, 1)),
                   "confidence: k = {} (K of Eq. 2) is larger than the point cloud ({} points)", options.k,
                   cloud.size());
  // Build the evaluator first: it validates the options before the (longer) reconstruction.
  ConfidenceEvaluator evaluator(cloud, options);
  CloudAssessment out;
  out.reconstruction = poisson::reconstruct(cloud, poisson_options, options.progress);
  out.confidence = assess(out.reconstruction, evaluator);
  return out;
}

}  // namespace autoscan::confidence
