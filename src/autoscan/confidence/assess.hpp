#pragma once
// The confidence map of a screened Poisson reconstruction (paper §4.1 → §4.2): convenience entry points
// over confidence.hpp that read the field, mesh and absolute reference gradient of a PoissonResult.
#include "autoscan/confidence/confidence.hpp"
#include "autoscan/poisson/poisson.hpp"

namespace autoscan::confidence {

/// The confidence map of `recon` against the raw points `raw` (the scans Q, positions only), normalising
/// f_g by recon.field->reference_gradient() (absolute, see normalize_completeness).
/// Throws InputError if recon has no field or an empty mesh, or for the reasons of ConfidenceEvaluator.
ConfidenceResult assess(const poisson::PoissonResult& recon, const PointCloud& raw,
                        const ConfidenceOptions& options = {});
/// Same with a prebuilt evaluator (its raw points and options).
ConfidenceResult assess(const poisson::PoissonResult& recon, const ConfidenceEvaluator& evaluator);

/// A reconstruction and its confidence map.
struct CloudAssessment {
  poisson::PoissonResult reconstruction;
  ConfidenceResult confidence;
};

/// Reconstructs `cloud` (oriented: outward unit normals are required by the Poisson solver) and
/// assesses the result against the same points as the raw set Q. Throws InputError naming the problem
/// if the cloud has no normals, has fewer than options.k points, or is otherwise bad input.
CloudAssessment assess_cloud(const PointCloud& cloud, const poisson::PoissonOptions& poisson_options = {},
                             const ConfidenceOptions& options = {});

}  // namespace autoscan::confidence
