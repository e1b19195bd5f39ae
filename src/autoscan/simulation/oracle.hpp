#pragma once
// The coverage oracle of the curve protocol (docs/benchmarks.md, "Coverage per view"; issue 43):
// how fast any planner could cover the object with the same scanner, given the truth. From the same
// start scan as the planners' runs, each next view is the candidate that covers the most scannable
// truth samples not yet covered (greedy set cover, with the truth's visibility: every candidate is
// scanned noise-free beforehand). The candidates are the scannable reference's views (scannable.hpp):
// one along the normal of each of `surface_views` area-uniform surface samples at d_o, and the d_o
// sphere's views; views the rig cannot reach are left out.
//
// Not a planner a user can run (it knows the truth) and not an exact optimum (greedy set cover is
// within 1 - 1/e of the best cover of the same size; a planner choosing views outside the candidate
// set can beat it at a point of the curve). Tables mark it "oracle" and give each planner's area
// under the curve as a ratio to its.
#include <nlohmann/json.hpp>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/simulation/scannable.hpp"

namespace autoscan::simulation {

struct OracleOptions {
  int views = 30;                                        ///< next-best views after the start scans
  ScannableOptions candidates;                           ///< the candidate views (the scannable reference's)
  eval::EvalOptions eval = {0.005, 60000, 1, 20, 0.02};  ///< τ and the truth samples (simulate's)
};

struct OracleResult {
  /// In the format of SimulateResult::curve: one point per scan (the start scans, then the chosen
  /// views): {scan, iteration (-1 for the start, else the view's index), scans, views, coverage,
  /// coverage_scannable, path_length, gain (scannable samples newly covered)}.
  nlohmann::json curve = nlohmann::json::array();
  std::vector<Pose> poses;  ///< the start poses, then the chosen views in order
  int candidates = 0;       ///< candidate views scanned
  int refused = 0;          ///< candidates the rig cannot reach (or inside the object)
  double seconds = 0;
};

/// `truth` in its final frame (as simulate() scans it), `start` the planners' start poses,
/// `reference` the scannable reference (null: coverage of the whole truth only). Stops adding views
/// when no candidate covers a new scannable sample (the curve stays flat). Deterministic.
/// Throws InputError for an empty truth, no start pose or views < 0.
OracleResult coverage_oracle(const TriangleMesh& truth, const ScannerSpec& spec, const Rig& rig,
                             const std::vector<Pose>& start, const PointCloud* reference,
                             const OracleOptions& options = {}, const ProgressCallback& progress = {});

}  // namespace autoscan::simulation
