#pragma once
// The session's parameters: one struct holding every stage's options, persisted in session.json.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>

#include "autoscan/confidence/confidence.hpp"
#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/core/schema.hpp"
#include "autoscan/nbv/nbv.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "autoscan/registration/icp.hpp"
#include "autoscan/registration/multiway.hpp"
#include "autoscan/session/supports.hpp"

namespace autoscan::session {

/// Which points Q the smoothness score f_s (Eq. 2) is measured against.
///  * raw: every inserted raw point (the paper's Q, §4.2).
///  * consolidated: the consolidated points P (§4.1) that the Poisson surface is built from.
///  * automatic: consolidated when the consolidation denoised the points (WLOP ran, i.e. the scanner
///    is noisy or its noise unknown), raw otherwise. On noisy data the raw points' scatter is the
///    scanner's noise, which no number of further scans reduces: as scans accumulate the raw cloud
///    gets denser, h_k (Eq. 2) shrinks and f_s against the raw points FALLS with every scan (bunny00 at
///    noise 0.5: mean f 0.166 → 0.161 after 10 views, though the model's error fell by 36 %). The
///    denoised points are what the surface is fitted to, and their smoothness is what more scans
///    improve. On exact data both choices see the same surface and raw keeps the paper's figures.
enum class SmoothnessPoints { automatic, raw, consolidated };
inline constexpr schema::EnumName<SmoothnessPoints> kSmoothnessPointsNames[] = {
    {SmoothnessPoints::automatic, "automatic"},
    {SmoothnessPoints::raw, "raw"},
    {SmoothnessPoints::consolidated, "consolidated"}};
constexpr std::span<const schema::EnumName<SmoothnessPoints>> enum_names(SmoothnessPoints) {
  return kSmoothnessPointsNames;
}

/// How the Poisson mesh's vertex colours are made from the coloured raw points near each vertex
/// (session/quality.hpp, color_mesh_vertices): `quality` weighs each point by the precision its
/// measurement had (1/σ², σ from range and incidence: ScannerSpec::relative_depth_sigma), so grazing
/// and far views do not wash the colours out; `average` is the plain mean (PoissonRecon --colors).
enum class ColorWeighting { quality, average };
inline constexpr schema::EnumName<ColorWeighting> kColorWeightingNames[] = {{ColorWeighting::quality, "quality"},
                                                                            {ColorWeighting::average, "average"}};
constexpr std::span<const schema::EnumName<ColorWeighting>> enum_names(ColorWeighting) { return kColorWeightingNames; }
/// Which rule ends the loop (docs/stop-rule.md).
///  * remaining: the stop rule on what is left to do (issue 22). The iso-surface's low-confidence
///    regions are tracked from iteration to iteration; a region that the views of a round looked at
///    without raising its confidence becomes "unreachable" or "too noisy" and no longer draws views.
///    Stop when the low-confidence area that views can still improve is below
///    StopOptions::remaining_share of the surface ("complete"), when StopOptions::stalled_rounds
///    rounds in a row improved no region they looked at ("no_improvement"), or at once when the
///    mean confidence falls below the best iteration's by more than StopOptions::quality_tolerance
///    ("quality_fell"; the best iteration's model is the result).
///  * paper: §5.3, stop "once the overall confidence does not improve any more":
///    |mean f_k − mean f_{k−1}| < SessionOptions::stop_threshold (0.005), and, when
///    stop_when_confidence_falls is set, when it falls by at least that much.
enum class StopRule { remaining, paper };
inline constexpr schema::EnumName<StopRule> kStopRuleNames[] = {{StopRule::remaining, "remaining"},
                                                                {StopRule::paper, "paper"}};
constexpr std::span<const schema::EnumName<StopRule>> enum_names(StopRule) { return kStopRuleNames; }

/// The stop rule and the quality certificate (session/certificate.hpp, docs/stop-rule.md).
struct StopOptions {
  StopRule rule = StopRule::remaining;  ///< "remaining" (default) or "paper" (§5.3, stop_threshold)
  /// An iso-surface triangle is of low confidence when the mean f (Eq. 3) of its corners is below
  /// min(confidence, confidence_ratio · p75), p75 being the 75th percentile of f over the surface.
  /// The scanner's noise bounds f_s (Eq. 2) everywhere: on armadillo at noise 0.5 fully covered
  /// (scannable coverage 1.000) the median f is 0.46 and 67 % of the surface is below 0.5, while
  /// the holes of the blind scan are below 0.1. The percentile measures what this scanner reaches.
  double confidence = 0.5;
  double confidence_ratio = 0.5;  ///< see `confidence`
  /// "complete": the low-confidence area that views can still improve is below this share of the
  /// iso-surface's area.
  double remaining_share = 0.01;
  /// Low-confidence regions (connected triangles) smaller than this share of the surface are
  /// "scattered": counted in the certificate's figures, not tracked, and they keep no scan going.
  double min_region_share = 0.001;
  /// A region improved when its area-weighted mean f rose by at least region_gain, or its area
  /// shrank by at least region_shrink (a share of its area), since the previous iteration.
  double region_gain = 0.02;
  double region_shrink = 0.2;
  /// A region whose views did not improve it this many rounds in a row (or that the planner passed
  /// over this many rounds) is settled: unreachable or too noisy, it draws no more views. And
  /// "no_improvement": this many rounds in a row whose views looked at low-confidence regions and
  /// improved none of them. With 1, the demo stopped at 94.8 % of its scannable surface: a hole that
  /// one view of ten had looked at was given up after that one round.
  int stalled_rounds = 2;
  /// "quality_fell": the mean confidence is below the best iteration's by more than this (the noise
  /// of the measure: successive iterations of the demo differ by up to 0.006 while its coverage rises).
  double quality_tolerance = 0.02;
  /// Drivers that know the truth (the simulation, clearly labelled "quality_fell_truth"): stop when
  /// the model's F-score is below the best iteration's by more than this (the sampling noise of the
  /// F-score at 60k samples is about 0.003). 0 disables it.
  double truth_fscore_tolerance = 0.01;
  /// Set by drivers that know the truth (`simulate`, the demo; with truth_fscore_tolerance > 0): the
  /// truth judges the quality. The mean-confidence fall ("quality_fell") is not checked: at noise 1.0
  /// armadillo's mean f fell 0.362 → 0.334 while its F-score rose 0.874 → 0.903, and the rule stopped
  /// with the worse model as its result (docs/benchmarks.md). The driver stops on a fall of the
  /// F-score ("quality_fell_truth"), and the result is the latest iteration whose F-score is within
  /// truth_fscore_tolerance of the best one's. A real session (no truth) keeps the confidence check.
  bool quality_by_truth = false;
  /// "past_best" (issue 45; docs/stop-rule.md, "The most accurate model"): the model's accuracy
  /// estimated without the truth. Where more scans no longer complete the model, more of them can
  /// make it worse (at noise 0.5 homer was most accurate after 20 views and 4 % worse after 70, while
  /// the confidence and the F-score stayed within their tolerances). The estimate is the certificate's
  /// fit_residual (how far the consolidated points lie from the surface: it grows as the points
  /// thicken), compared only among iterations whose confident share is within complete_tolerance
  /// of the largest so far (a less complete model is not a candidate, however thin its points). The
  /// best is the latest candidate whose residual is within accuracy_tolerance (a share) of the
  /// smallest. Stop when best_rounds iterations came after it. The best is the session's result
  /// (best_iteration) whatever stops it, except "quality_fell". 0 disables both.
  int best_rounds = 2;
  /// See best_rounds. 0: the smallest residual (with 0.02, elk at noise 0.5 returned the later of two
  /// iterations 1.5 % apart in residual and 7.5 % apart in accuracy, the worse one).
  double accuracy_tolerance = 0.0;
  double complete_tolerance = 0.002;  ///< see best_rounds (a share of the surface)

  template <class V>
  void visit_fields(V& v) {
    v("rule", rule);
    v("confidence", confidence, schema::closed(0, 1));
    v("confidence_ratio", confidence_ratio, schema::closed(0, 1));
    v("remaining_share", remaining_share, schema::closed(0, 1));
    v("min_region_share", min_region_share, schema::closed(0, 1));
    v("region_gain", region_gain, schema::at_least(0));
    v("region_shrink", region_shrink, schema::closed(0, 1));
    v("stalled_rounds", stalled_rounds, schema::at_least(1));
    v("quality_tolerance", quality_tolerance, schema::at_least(0));
    v("truth_fscore_tolerance", truth_fscore_tolerance, schema::closed(0, 1));
    v("quality_by_truth", quality_by_truth);
    v("best_rounds", best_rounds, schema::at_least(0));
    v("accuracy_tolerance", accuracy_tolerance, schema::at_least(0));
    v("complete_tolerance", complete_tolerance, schema::closed(0, 1));
  }
};

struct SessionOptions {
  /// Sessions accumulate millions of raw points; each reconstruction consolidates a voxel-thinned
  /// subset of at most 200k points (then WLOP keeps 20 % of them when the data is noisy). Fewer
  /// points lower f_g as the model grows (the field's gradient follows the sample density): with 100k
  /// the demo's mean confidence fell from 0.641 to 0.613 between its second and third iteration.
  ///
  /// WLOP runs 10 iterations instead of CGAL's 35: on the accumulated scans of bunny00 (noise 0.5,
  /// 2.2 M points thinned to 100k) both give the same accuracy against the truth (mean 0.00287 vs
  /// 0.00286, p90 0.0071 both) and 10 takes a third of the time.
  ///
  /// (An aggregate, without a constructor, so that tests/session can count its fields.)
  std::string planner = "poisson";                           ///< planners::make_planner name
  nlohmann::json planner_params = nlohmann::json::object();  ///< planner-specific settings
  consolidate::ConsolidateOptions consolidate = [] {         ///< §4.1 thinning, outliers, WLOP, normals
    consolidate::ConsolidateOptions c;
    c.thinning.max_points = 200000;
    c.wlop.iterations = 10;
    return c;
  }();
  poisson::PoissonOptions poisson;                                   ///< §4.1 screened Poisson (depth, screening...)
  confidence::ConfidenceOptions confidence;                          ///< §4.2, Eq. 1-3 (K = 100)
  SmoothnessPoints smoothness_points = SmoothnessPoints::automatic;  ///< Q of Eq. 2 (see SmoothnessPoints)
  nbv::NbvOptions nbv;                                               ///< §5.1-5.2, Eq. 4-5 (100³ grid, σ = 25°)
  registration::IcpOptions icp;                                      ///< §5.3 weighted ICP
  bool register_scans = true;  ///< §5.3: register each scan to the model (weighted ICP) once a model exists
  /// Global multi-view registration (registration/multiway.hpp, docs/registration.md) at each
  /// iteration, before the reconstruction: the scans added since the last iteration and the scans
  /// they overlap are registered to each other in a pose graph whose priors are the reported poses
  /// (the robot's accuracy: multiway.robot_translation_sigma, robot_rotation_sigma_deg). Blind scans
  /// are thus aligned before the first model. Needs register_scans.
  bool global_registration = true;
  /// The global registration's robot priors centred on the reported poses with the estimated
  /// hand-eye offset applied (C_i Ĥ, Ĥ the last iteration's significant estimate,
  /// IterationRecord::hand_eye; docs/registration.md "Hand-eye offset"), and each new scan's ICP
  /// started there. When an iteration's estimate becomes significant or moves by more than twice
  /// its standard errors, every scan is registered once more around the new centres (the
  /// iteration's registration record says "hand_eye_repass"). false: on the reported poses.
  bool hand_eye_priors = false;
  /// With hand_eye_priors, until the estimate is significant: how far the hand-eye calibration may
  /// be off (one standard deviation; scene units, degrees), added in quadrature to the robot's
  /// accuracy (multiway.robot_*_sigma) in the registration's priors, so that an error shared by
  /// every scan is not taken for outliers. Once it is, the priors are the robot's accuracy and the
  /// estimate's standard errors in quadrature.
  double hand_eye_translation_sigma = 0.005;
  double hand_eye_rotation_sigma_deg = 2.0;
  /// With hand_eye_priors: a new estimate is applied only when the solution around C_i Ĥ keeps
  /// fewer scans out than the plain one, or as many and its pairs' mean chi2
  /// (MultiwayResult::pair_chi2) is lower by at least this share.
  double hand_eye_min_fit_gain = 0.0;
  registration::MultiwayOptions multiway;  ///< the robot's accuracy, overlap, rounds, outlier rule
  /// §5.3 registration acceptance. ICP's correction is applied only when it lowers the residual RMS by
  /// at least this share: on noisy data a correction that does not fit better is the scan sliding
  /// along the model, not a pose error being fixed (measured: bunny00 at noise 0.5 gave 3° corrections
  /// with a 0.3 % lower residual, ten times the injected 0.2°).
  double registration_min_improvement = 0.05;
  /// Larger corrections are rejected (the reported pose is kept): the robot's pose accuracy, world
  /// units / degrees. 0 = no bound. `simulate` sets them to 6σ of its scanner's pose noise.
  double registration_max_translation = 0.0;
  double registration_max_rotation_deg = 0.0;
  bool selective_insertion = true;  ///< Eq. 6: insert a point with probability (1 − f(s_k))^ρ; false inserts all
                                    ///< (when the goal is a mesh, not a point set)
  double rho = 3.0;                 ///< Eq. 6: ρ (paper: 3)
  /// Eq. 6's s_k for a point with a normal: the nearest of its `insertion_neighbours` nearest
  /// iso-points whose normal is within `insertion_normal_deg` of the point's; when none is, the point
  /// measures a sheet the model does not have yet and f = 0 (it is kept). The paper takes the plain nearest, which
  /// across a thin wall or a narrow channel is an iso-point of the other, confident side: a scan of the channel's
  /// ceiling was refused because the hood's top face above it was done (the demo, docs/stop-rule.md). 0 = the paper's
  /// plain nearest.
  int insertion_neighbours = 16;
  double insertion_normal_deg = 60.0;
  /// Quality-weighted fusion (docs/fusion.md). Every point carries the depth uncertainty the
  /// scanner's noise model predicts for it (ScannerSpec::relative_depth_sigma: range and incidence;
  /// the model point column `depth_sigma_rel`). When true the screened Poisson solve weighs each
  /// consolidated sample by the precision (1/σ²) of the raw points it stands for, normalised to a
  /// mean of 1 (unless poisson.weight_scalar names a column of its own). Off by default until it is
  /// measured to help: armadillo at noise 0.5 (docs/fusion.md) gave the same accuracy with and without.
  bool quality_weights = false;
  /// Selective insertion by quality (with Eq. 6): a new point whose predicted σ exceeds this many
  /// times that of the model's surface where it lands (the nearest consolidated point within two
  /// sample spacings) is not inserted: a region already measured better is neither displaced nor
  /// blurred by a worse measurement. 0 = off (the default, as quality_weights; 2 is the suggested value).
  double quality_insertion_ratio = 0.0;
  StopOptions stop;  ///< which stop rule, and the quality certificate's thresholds (docs/stop-rule.md)
  double stop_threshold =
      0.005;  ///< §5.3 (stop.rule "paper"): stop when |mean f_k − mean f_{k−1}| < this (paper: 0.005)
  /// ... and (when true) also when the mean confidence falls by at least stop_threshold. Off by
  /// default: small falls are common while the model grows (the demo fell 0.888 → 0.882 between two
  /// iterations and then rose again), and stopping there left its coverage at 0.949. The session's
  /// best model is in any case the iteration with the highest mean f (SimulateResult::best_iteration).
  bool stop_when_confidence_falls = false;
  int max_iterations = 15;  ///< budget of iterations (reconstructions); the last one only assesses
  int max_views = 200;      ///< budget of planned views over the session (Table 2: up to ~200)
  std::uint64_t seed = 42;  ///< seeds selective insertion and the planner's stream
  /// Colour (docs/colour.md): how the mesh's vertex colours weigh the raw points (not a paper
  /// constant; colour is not used to plan views, as in the paper) and how many nearest raw points
  /// each vertex takes its colour from.
  ColorWeighting color_weighting = ColorWeighting::quality;
  int color_neighbours = 8;
  /// Fixtures and the support in the scans: removal before anything else sees them, the contact
  /// region (docs/supports.md).
  SupportOptions supports;

  /// The session config, session.json's "params" and a simulation's "session" (docs/options.md).
  template <class V>
  void visit_fields(V& v) {
    v("planner", planner);
    v("planner_params", planner_params);
    v("consolidate", consolidate);
    v("poisson", poisson);
    v("confidence", confidence);
    v("smoothness_points", smoothness_points);
    v("nbv", nbv);
    v("icp", icp);
    v("register_scans", register_scans);
    v("global_registration", global_registration);
    v("hand_eye_priors", hand_eye_priors);
    v("hand_eye_translation_sigma", hand_eye_translation_sigma, schema::at_least(0));
    v("hand_eye_rotation_sigma_deg", hand_eye_rotation_sigma_deg, schema::at_least(0));
    v("hand_eye_min_fit_gain", hand_eye_min_fit_gain, schema::closed_open(0, 1));
    v("multiway", multiway);
    v("registration_min_improvement", registration_min_improvement, schema::closed_open(0, 1));
    v("registration_max_translation", registration_max_translation, schema::at_least(0));
    v("registration_max_rotation_deg", registration_max_rotation_deg, schema::at_least(0));
    v("selective_insertion", selective_insertion);
    v("rho", rho, schema::at_least(0));
    v("insertion_neighbours", insertion_neighbours, schema::at_least(0));
    v("insertion_normal_deg", insertion_normal_deg, schema::closed(0, 180));
    v("quality_weights", quality_weights);
    v("quality_insertion_ratio", quality_insertion_ratio, schema::at_least(1).or_zero());
    v("stop", stop);
    v("stop_threshold", stop_threshold, schema::at_least(0));
    v("stop_when_confidence_falls", stop_when_confidence_falls);
    v("max_iterations", max_iterations, schema::at_least(1));
    v("max_views", max_views, schema::at_least(0));
    v("seed", seed);
    v("color_weighting", color_weighting);
    v("color_neighbours", color_neighbours, schema::at_least(1));
    v("supports", supports);
  }
  /// Throws InputError naming the option for values out of range, in every stage's options
  /// (Session::create calls it: bad options are refused before any scan is acknowledged).
  void validate(const std::string& what = "options") const;
};

/// The session.json `params` of an older version with the keys that are no longer options removed:
/// `multiway.incidence_gain` (a session takes it from its scanner JSON since 2026-12-02). Only for
/// reading session.json; a config naming such a key is refused as unknown.
nlohmann::json without_legacy_options(nlohmann::json params);

/// SessionOptions as JSON (every field, nested option structs included) and back. Missing fields
/// keep their defaults; unknown fields are an InputError naming them (typos must not pass silently).
nlohmann::json to_json(const SessionOptions& o);
/// Applies the fields present in `j` onto `base` and validates the result; errors name `what` (the
/// file) and the option ("config.json: poisson.depth must be in [2, 12] (got 99)").
SessionOptions session_options_from_json(const nlohmann::json& j, SessionOptions base = {},
                                         const std::string& what = "config");

}  // namespace autoscan::session
