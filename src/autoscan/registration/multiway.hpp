#pragma once
// Global multi-view registration (Pulli 1999; Open3D's multiway registration; what Artec Studio
// calls global registration): every overlapping pair of scans is registered with point-to-plane ICP
// (icp.hpp) and a pose graph (pose_graph.hpp) over all scans reconciles the pairwise results with
// the poses the robot reported, weighted by the robot's declared accuracy. Docs: docs/registration.md.
//
// The scans come in the world frame of their reported poses. The result is one correction per scan
// (world frame; the registered scan is correction * scan). Free scans move; the others are anchors
// that keep their initial correction (a session frees the newest scans and the scans they overlap,
// so an iteration's cost grows with the new scans and their neighbours, not with the square of all).
//
// Rounds: pairwise ICP from the current corrections → pose graph → pairs that disagree with the
// solution (their implied displacement beyond `max_disagreement` × the pair's own residual) are
// dropped and the graph solved again; the next round re-runs the pairs from the new corrections with
// a tighter correspondence distance. A free scan whose solved correction lies beyond
// `outlier_sigma` of the robot's accuracy (Mahalanobis, 6 dof), or that overlaps other scans but
// agrees with none of them, is flagged: a session keeps it out of the model rather than blurring it.
// Deterministic: every reduction is in index order; the pose graph is solved single-threaded.
#include <Eigen/Geometry>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>
#include <vector>

#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/registration/icp.hpp"

namespace autoscan::registration {

/// The local surface a scan's registration points are projected onto, and their normals
/// (docs/registration.md, "Denoised targets").
struct SurfaceFitOptions {
  int k = 0;  ///< neighbours of the fit; 0 = chosen per scan from its noise (below)
  /// Fit a quadric height function (a jet of order 2) over the PCA plane, not the plane alone: a plane
  /// over a curved neighbourhood is biased inwards by about r²/4R, and the bias differs between scans
  /// of different density (measured on the virtual scanner, refined_elephant at noise 1.0, k = 200:
  /// pairwise ICP error 0.00070 with planes, 0.00018 with quadrics).
  bool quadric = true;
  /// Automatic k = clamp(adaptive_factor · (σ̂ / s)², k_min, k_max), σ̂ the scan's scatter (1.4826 ×
  /// the median distance of a point from the quadric of its probe_k neighbours), s its point spacing.
  double adaptive_factor = 100.0;
  int k_min = 20;
  int k_max = 400;
  int probe_k = 64;
  /// Points per fitted neighbourhood, for the cost: the surface is fitted at one point in every
  /// max(1, k / anchor_points) (the anchors, a stride over the points), and every point is moved onto
  /// the surface of its nearest anchor (docs/registration.md, "Denoised targets"). A neighbourhood of
  /// k points spans about √(k/π) spacings while the nearest anchor lies within about one, so each
  /// point stays deep inside the neighbourhood its surface was fitted to. 0: every point is fitted
  /// (k fits of k neighbours each: the registration's largest cost at noise, measured).
  int anchor_points = 50;
  /// Boundary band: a point whose fitted neighbourhood lies to one side of it (the neighbours' mean,
  /// in the tangent plane, farther than this share of the neighbourhood's radius from the point; about
  /// 0.42 at a straight edge, near 0 inside) is marked `boundary`. Its surface is an extrapolation,
  /// and a range scanner's depth is least accurate at the edges of what it saw (silhouettes, shadow
  /// and occlusion edges). 0 = no band.
  double boundary_shift = 0.0;
  /// The JSON keys (docs/options.md); the ranges are checked by validate().
  template <class V>
  void visit_fields(V& v) {
    v("quadric", quadric);  // k: MultiwayOptions::normal_k
    v("adaptive_factor", adaptive_factor);
    v("k_min", k_min);
    v("k_max", k_max);
    v("probe_k", probe_k);
    v("anchor_points", anchor_points);
    v("boundary_shift", boundary_shift);
  }
  /// Throws InputError naming the option for values out of range.
  void validate(const std::string& what = "surface") const;
};

struct SurfaceFit {
  std::vector<Vec3> normals;    ///< oriented towards the sensor
  std::vector<Vec3> projected;  ///< each point moved onto its fitted surface (a denoised copy)
  std::vector<char> boundary;   ///< in the boundary band (SurfaceFitOptions::boundary_shift); all 0 without
  int neighbors = 0;            ///< k used
  double noise = 0.0;           ///< σ̂ (world units)
  double spacing = 0.0;         ///< s (world units)
};

/// Fits each point's local surface from its k nearest neighbours in `points` (k automatic when
/// options.k = 0). Deterministic; O(#points · k log #points).
SurfaceFit fit_scan_surface(std::span<const Vec3> points, const Vec3& sensor, const SurfaceFitOptions& options = {});

struct MultiwayOptions {
  /// The robot's declared accuracy (1σ): position of the tool (world units) and its orientation
  /// (degrees, a turn about the sensor position). The priors of the pose graph; real robots: a few
  /// mm and a degree or less.
  double robot_translation_sigma = 0.003;
  double robot_rotation_sigma_deg = 1.0;
  /// Candidate pairs: at least this share of one scan's samples has a point of the other within
  /// `overlap_distance`; a pair is used when, after its ICP, this share lies within three point
  /// spacings of the other scan.
  double min_overlap = 0.2;
  /// Bridges: a pair that overlaps by less than `min_overlap` at its ICP optimum (but at least this
  /// share, with a residual within three spacings) is used when it is the only way to join its two
  /// scans' groups: the pairs of largest overlap that connect the graph (Kruskal over the weak pairs,
  /// the anchors one group). At high noise neighbouring blind scans overlap by 12-19 % within three
  /// spacings, and a ring of 8 falls into pieces whose relative error no prior can fix (bunny00 at
  /// noise 1.0: four groups; docs/registration.md). Raising every pair's chance instead
  /// (`min_overlap` 0.12) made armadillo and refined_elephant worse. 0 = no bridges.
  double bridge_min_overlap = 0.1;
  /// 0 = automatic: 3 point spacings plus 3σ of the robot's pose error at the scan's range.
  double overlap_distance = 0.0;
  std::size_t sample_points = 3000;   ///< ICP source / overlap test points per scan (stride sampling)
  std::size_t target_points = 30000;  ///< ICP target points per scan (with normals)
  /// Neighbours of the local surface fit (normals and denoised targets); 0 = automatic from each
  /// scan's noise (`surface`).
  int normal_k = 0;
  SurfaceFitOptions surface;  ///< its `k` is ignored here: normal_k sets it
  /// Points seen at a larger angle between their normal and the ray to the sensor stay out of the
  /// registration: their depth is the least accurate, and on a curved surface depth noise along the
  /// ray biases them outwards (by about σ² sin²θ / 2R), which pulls every pair apart along the lines
  /// of sight. Measured on the virtual scanner at noise 0.5 (docs/registration.md): 80 → 60 degrees
  /// cuts the pairwise ICP's bias from 0.5 to 0.1 × 10⁻³ of the diagonal.
  double max_incidence_deg = 60.0;
  /// Quality weighting: a point's depth σ grows as 1 + incidence_gain · tan(incidence) (the
  /// scanner noise model's incidence term, NoiseSpec::depth_incidence_gain), a pair of points weighs
  /// 1/(σ_a² + σ_b²). A range scanner's depth is least accurate, and biased, at grazing angles
  /// (docs/registration.md). Default 1: the virtual scanner's model; the Cyberware scans of
  /// dragon_stand want about 10. A session sets it from its scanner JSON (noise.depth_incidence_gain).
  double incidence_gain = 1.0;
  /// At most this many pairs per free scan: its partners of largest overlap (0 = all). A scan added
  /// late overlaps more and more of the earlier ones; registering it to all of them makes an
  /// iteration's cost grow with the number of scans (measured on armadillo at noise 0.5, 40 views:
  /// 47, 70, 76, 120 pairs in iterations 1-4, registration half of the loop's time). Its best few
  /// partners should hold it as firmly; 0 (the default until that is measured) keeps every pair.
  int max_pairs_per_scan = 0;
  /// At most this many pairs of a free scan with the fixed scans of earlier iterations (anchors): its
  /// anchors of largest overlap (0 = all). The pairs among the free scans are all kept: capping them
  /// loses the long-baseline pairs that hold a ring of scans together (dragon_stand: the mesh 0.217
  /// mm from the truth with max_pairs_per_scan 6, 0.166 mm with all pairs; docs/benchmarks.md). A
  /// later iteration's new scans overlap more and more anchors: this bounds its cost by the new scans
  /// (armadillo at noise 0.5, 40 views: pair ICP 0.6, 3.6, 6.3, 8.6, 14.3 s in iterations 0-4 with
  /// all pairs, 0.6, 2.8, 2.5, 2.5, 2.1 s with 3; the model as accurate, docs/benchmarks.md).
  int max_anchor_pairs_per_scan = 3;
  int rounds = 3;                 ///< pairwise ICP + graph solve rounds
  double max_disagreement = 3.0;  ///< drop a pair whose implied displacement exceeds this × its RMS
  double outlier_sigma = 5.0;     ///< flag a scan whose correction is beyond this many σ (Mahalanobis)
  /// Also free the anchors that overlap a free scan. Off by default: measured on bunny00 at noise 0.5
  /// (docs/benchmarks.md) the older scans, registered before against as many neighbours, only get
  /// worse when new noisy pairs may move them, and the iteration costs more.
  bool free_neighbors = false;
  double robust_scale = 3.0;  ///< PoseGraphOptions::robust_scale
  /// A pair's information is its ICP normal matrix H (Σ J Jᵀ over its n overlapping points) over
  /// its residual², scaled to this many independent points: H · (information_points / n) / rms².
  /// Neighbouring points of a scan are not independent (shared calibration and smoothing errors).
  double information_points = 100.0;
  IcpOptions icp;  ///< pairwise ICP (max_correspondence_distance is set per round)
  /// Good poses stay put (issue 45): the solution is taken only when it lowers the graph's misfit
  /// beyond what fitting the noise would. With J the graph's cost (the pairs' Σ eᵀΛe plus the
  /// priors'), J₀ at the corrections the registration started from (the reported poses), J at the
  /// solution, m the pairs used and p the parameters they determine (6 per scan solved, less 6 per
  /// group of scans that no fixed scan holds: pairs see relative poses only), the F statistic
  ///   F = ((J₀ − J) / p) / (χ² / (6m − p))        (χ² the pairs' misfit at the solution)
  /// is about 1 when the reported poses are right (the solution only fits the pairs' noise) and
  /// grows with the pose error the pairs see. The loops of the graph (6m − p > 0) measure the
  /// pairs' noise; without a loop F is infinite and the solution taken. Below `min_significance`
  /// the starting corrections are kept (MultiwayResult::kept_initial). 0 = always take the solution.
  /// Only scans still at the robot's word are kept so: when a free scan starts from an earlier
  /// registration's correction (a session's ICP to the model at add_scan), the solution is taken
  /// (measured at noise 0.5 one view per round: keeping those made the model 12 % less accurate).
  /// Default 4, measured (docs/registration.md, "Good poses stay put"): with the true poses F is
  /// 2.8 on dragon_stand's real scans and 3.0 on a synthetic ring of 12, not 1, because the pairs'
  /// grazing-angle bias looks like a common motion of the scans; a robot's pose error gave 4.3-1100.
  double min_significance = 4.0;

  /// The JSON keys (docs/options.md); the ranges are checked by validate().
  template <class V>
  void visit_fields(V& v) {
    v("robot_translation_sigma", robot_translation_sigma);
    v("robot_rotation_sigma_deg", robot_rotation_sigma_deg);
    v("min_overlap", min_overlap);
    v("bridge_min_overlap", bridge_min_overlap);
    v("overlap_distance", overlap_distance);
    v("sample_points", sample_points);
    v("target_points", target_points);
    v("normal_k", normal_k);
    v("surface", surface);
    v("max_incidence_deg", max_incidence_deg);
    // incidence_gain: not listed; a session sets it from its scanner JSON (noise.depth_incidence_gain).
    v("max_pairs_per_scan", max_pairs_per_scan);
    v("max_anchor_pairs_per_scan", max_anchor_pairs_per_scan);
    v("rounds", rounds);
    v("max_disagreement", max_disagreement);
    v("outlier_sigma", outlier_sigma);
    v("free_neighbors", free_neighbors);
    v("robust_scale", robust_scale);
    v("information_points", information_points);
    v("icp", icp);
    v("min_significance", min_significance);
  }

  /// Throws InputError naming the option for values out of range.
  void validate(const std::string& what = "multiway") const;
};

struct MultiwayPair {
  int i = 0, j = 0;         ///< source and target scan (indices into the input)
  double overlap = 0.0;     ///< the overlap share that selected the pair
  double rms_before = 0.0;  ///< point-to-plane RMS at the corrections the round started from
  double rms_after = 0.0;   ///< at the pair's own ICP optimum
  std::size_t correspondences = 0;
  double disagreement = 0.0;  ///< RMS displacement the graph's solution implies against the pair's optimum
  bool used = false;          ///< in the final graph
  bool bridge = false;        ///< below min_overlap, used to join two groups of scans (bridge_min_overlap)
  std::string dropped;        ///< why not: "disagrees", "degenerate", "flagged scan", "no overlap"
  /// The pair's ICP result as a relative placement (world frame): scan i corrected by C_i lands on
  /// scan j corrected by C_j when C_j⁻¹ C_i = measurement.
  Eigen::Isometry3d measurement = Eigen::Isometry3d::Identity();
};

struct MultiwayScanReport {
  bool free = false;
  bool flagged = false;  ///< kept out: correction beyond the robot's accuracy, or no agreeing pair
  std::string flag_reason;
  int pairs_used = 0;
  double spacing = 0.0;         ///< median point spacing of the scan's registration sample
  std::size_t points_used = 0;  ///< points of the scan the registration used (incidence cut)
  int neighbors = 0;            ///< k of the scan's local surface fit
  double noise = 0.0;           ///< the scan's estimated scatter about its surface (world units)
  double mahalanobis = 0.0;     ///< of the correction against the robot's accuracy (6 dof)
  double correction_translation = 0.0;
  double correction_rotation_deg = 0.0;
};

struct MultiwayResult {
  std::vector<Eigen::Isometry3d> corrections;  ///< one per scan (anchors keep their initial one)
  std::vector<MultiwayScanReport> scans;
  std::vector<MultiwayPair> pairs;  ///< of the last round
  std::size_t pairs_tested = 0;     ///< overlap tests run (all rounds)
  std::size_t pairs_capped = 0;     ///< overlapping pairs left out by max_pairs_per_scan
  int rounds = 0;
  double overlap_distance = 0.0;  ///< of the first round
  double incidence_gain = 0.0;    ///< the depth model's incidence term the points were weighed by
  double seconds = 0.0;
  double seconds_pairs = 0.0, seconds_graph = 0.0;
  /// The scans' preparation (surface fits of the scans not cached, their search trees) and the
  /// overlap tests that select the pairs.
  double seconds_prepare = 0.0, seconds_fits = 0.0, seconds_select = 0.0;
  /// The pairs' misfit at the last solution: Σ eᵀ Λ e over the pairs used (Λ each pair's
  /// information, `information_points`), and how many pairs it sums. With pair errors as the
  /// information says, about 6 per pair; two solutions of the same scans compare by it.
  double pair_chi2 = 0.0;
  std::size_t pair_chi2_pairs = 0;
  /// The same pairs' misfit at the corrections the registration started from, and the priors' cost
  /// Σ |prior error|² at the solution and at the start (MultiwayOptions::min_significance).
  double pair_chi2_initial = 0.0;
  double prior_chi2 = 0.0, prior_chi2_initial = 0.0;
  int solved_scans = 0;       ///< scans solved in the last graph (6 parameters each)
  double significance = 0.0;  ///< the F statistic of min_significance (0: no graph; inf: no spare pair)
  bool kept_initial = false;  ///< F below min_significance: every scan kept its starting correction
  /// Whether the test applied: every free scan started at its reported pose (the prior's centre).
  bool significance_applies = false;
};

/// Registers `scans` to each other.
/// @param scans       #N scans, world frame of the reported pose
/// @param sensors     #N sensor positions (the pivots of the robot's rotation error; normals of
///                    scans without normals are oriented towards them)
/// @param initial     #N starting corrections (empty: identity)
/// @param free        #N flags; empty: all free
/// Throws InputError for size mismatches or invalid options.
/// A scan as the registration sees it, in the frame of its reported pose: its stride sample moved
/// onto the local surface fits, their normals and quality weights, grazing and off-surface points
/// left out. It depends only on the scan, its sensor and the options, so a caller that registers
/// the same scans again (a session, each iteration) keeps it (`cache` below).
struct PreparedScan {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;
  std::vector<double> weights;  ///< depth precision, 1/σ² relative (incidence term)
  int neighbors = 0;            ///< k of the surface fit
  double noise = 0.0;           ///< the scan's estimated scatter
};

/// @param cache  optional, #N entries: a null entry is filled with the scan's preparation, a non-null
///               one is used as is (the caller clears an entry when its scan changes; the options
///               must be the same as when it was filled)
/// @param prior_centers  optional, #N world-frame corrections the robot's priors are centred on (the
///               part of each correction an estimated hand-eye offset explains, C_i Ĥ C_i⁻¹); empty:
///               the identity, the reported poses
MultiwayResult register_multiway(std::span<const PointCloud> scans, std::span<const Vec3> sensors,
                                 std::span<const Eigen::Isometry3d> initial, std::span<const char> free,
                                 const MultiwayOptions& options = {}, ProgressCallback progress = {},
                                 std::vector<std::shared_ptr<const PreparedScan>>* cache = nullptr,
                                 std::span<const Eigen::Isometry3d> prior_centers = {});

nlohmann::json to_json(const MultiwayResult& r);

}  // namespace autoscan::registration
