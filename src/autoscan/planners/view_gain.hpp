#pragma once
// The predicted gain of a view (beyond the paper, issue 43; docs/planners.md "Predicted gain"): a
// virtual scan of the current model. From a candidate pose, rays over the scanner's field of view
// are cast against the Poisson surface; a ray that hits it within the scanner's far range, at an
// incidence under max_incidence_deg, measures the iso-point nearest to its hit. The gain of a view
// is the need (1 − f, Eq. 3) summed over the iso-points it measures; a round's views are picked
// greedily with diminishing returns (weighted maximum coverage: an iso-point counts once per round,
// for the first view that measures it), so two views of one region are not both taken.
//
// Why: the viewing field (Eq. 4) places a view at d_o from the iso-point it aims at (Eq. 5). From
// little data the Poisson surface is the solver's closing of a one-sided patch, a balloon up to the
// octree's box around the measured part (measured on anchor_dense from one start scan: surface area
// 2.9 against the truth's 1.0, mean distance to the truth 0.15 of the diagonal); views aimed at the
// balloon pass the object by 0.3-0.46 and gain 1-5 % of the surface each. Views from the view
// sphere around the measured part, aimed at its centre, see the object whatever the balloon's size.
// Scoring both kinds of candidate by the same virtual scan lets the round take whichever measures
// the most uncertain surface: sphere views while whole sides are unseen, the field's aimed views
// once what is left is in cavities and at grazing angles.
//
// The near limit is not applied: where the model is a balloon the true surface lies behind it, so
// a hit closer than `near` does not mean the view is too close.
#include <cstdint>
#include <span>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/core/types.hpp"
#include "autoscan/spatial/kdtree.hpp"
#include "autoscan/spatial/ray_scene.hpp"

namespace autoscan::planners {

class ViewGain {
 public:
  /// `mesh`: the model's surface (what the rays hit, occluders included); `points`: the iso-points
  /// a hit measures (the nearest one to it); `rays_across`: rays across the image width (rows by
  /// the scanner's aspect ratio). Throws InputError for an empty mesh or point set, or rays_across < 1.
  ViewGain(const TriangleMesh& mesh, std::span<const Vec3> points, const ScannerSpec& scanner, int rays_across);

  /// Sorted, unique indices of the points a scan from `pose` would measure. Thread-safe.
  std::vector<std::uint32_t> seen(const Pose& pose) const;
  /// seen() of every pose, in parallel (oneTBB).
  std::vector<std::vector<std::uint32_t>> seen(std::span<const Pose> poses) const;

  int columns() const { return cols_; }
  int rows() const { return rows_; }

 private:
  spatial::RayScene scene_;
  spatial::KdTree points_;
  ScannerSpec scanner_;
  int cols_ = 1, rows_ = 1;
  double tan_half_ = 0.0;  ///< tan(fov/2), horizontal
  double cos_max_ = 0.0;   ///< cos(max_incidence_deg)
};

/// One pick of pick_by_gain().
struct GainPick {
  std::size_t candidate = 0;  ///< index into the candidates
  double gain = 0.0;          ///< Σ need over its points not measured by an earlier pick of the round
};

/// Greedy weighted maximum coverage: at most `k` candidates, each maximising the need of its `seen`
/// points not covered by the earlier picks, until the best gain is below `min_gain`. Lazy evaluation
/// (a candidate's gain only falls as picks are made, so a stale upper bound that still leads is
/// recomputed and taken when it stays ahead). Ties go to the lower index (deterministic). Within
/// (1 − 1/e) of the best set of k [Nemhauser et al. 1978].
std::vector<GainPick> pick_by_gain(const std::vector<std::vector<std::uint32_t>>& seen, std::vector<double> need, int k,
                                   double min_gain);

}  // namespace autoscan::planners
