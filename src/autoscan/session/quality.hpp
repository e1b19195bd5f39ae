#pragma once
// Quality-weighted fusion (docs/fusion.md): the depth uncertainty the scanner's noise model predicts
// for each point, carried from the scans into the model, the consolidated samples and the Poisson
// solve, and the insertion test that keeps a better measurement from being blurred by a worse one.
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::session {

/// The model point column holding each point's predicted depth σ relative to the scanner's best
/// (ScannerSpec::relative_depth_sigma: 1 at d_n and normal incidence).
inline constexpr const char* kDepthSigmaColumn = "depth_sigma_rel";
/// The consolidated point column of the Poisson sample weights (precision_weights).
inline constexpr const char* kQualityWeightColumn = "quality_weight";
/// The model point column of each coloured point's colour weight: 1/σ² of its measurement
/// (σ = ScannerSpec::relative_depth_sigma from range and incidence), set when the scan has colours.
inline constexpr const char* kColorWeightColumn = "color_weight";

/// Predicted relative depth σ of each point of `scan` (#P), measured from the sensor position in its
/// scalars sensor_x/y/z. The incidence comes from the scan's normals, or, when it has none, from the
/// plane of its `k` nearest neighbours (PCA). Deterministic.
std::vector<double> predicted_depth_sigma(const PointCloud& scan, const ScannerSpec& scanner, int k = 10);

/// The σ of each of #C `samples` (consolidated points) as the precision-weighted mean of the `k`
/// nearest points of `raw` (σ_c = (mean 1/σ_i²)^(-1/2)); `raw_sigma` is #R. Deterministic.
std::vector<double> sample_depth_sigma(std::span<const Vec3> samples, std::span<const Vec3> raw,
                                       std::span<const double> raw_sigma, int k = 8);

/// Poisson sample weights from σ: 1/σ², normalised to a mean of 1 (#S in, #S out).
std::vector<double> precision_weights(std::span<const double> sigma);

/// The colour of each of `vertices` from the coloured `points` (#P, with colours): the mean of the
/// colours of its `k` nearest points, each weighted by `weights[i]` (#P, the colour weight column)
/// when `weights` is not empty, equally otherwise; rounded to 0-255. A vertex whose neighbours all
/// have weight 0 takes their plain mean. Deterministic. Empty when the points have no colours.
std::vector<Rgb> color_vertices(std::span<const Vec3> vertices, const PointCloud& points,
                                std::span<const double> weights, int k);

/// The insertion test by quality: the model's consolidated surface with its σ; a new point landing
/// within two sample spacings of it with more than `ratio` times its σ is refused.
class QualityGate {
 public:
  QualityGate();
  QualityGate(std::span<const Vec3> surface, std::span<const double> sigma);
  ~QualityGate();
  QualityGate(QualityGate&&) noexcept;
  QualityGate& operator=(QualityGate&&) noexcept;

  bool empty() const;
  double gate_distance() const;  ///< two median sample spacings of the surface
  /// Clears keep[i] for the points that would blur a better measurement; returns how many it cleared.
  std::size_t apply(std::span<const Vec3> points, std::span<const double> sigma, double ratio,
                    std::vector<char>& keep) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace autoscan::session
