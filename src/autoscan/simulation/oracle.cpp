#include "autoscan/simulation/oracle.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/simulation/fixtures.hpp"

namespace autoscan::simulation {

OracleResult coverage_oracle(const TriangleMesh& truth, const ScannerSpec& spec, const Rig& rig,
                             const std::vector<Pose>& start, const PointCloud* reference, const OracleOptions& o,
                             const ProgressCallback& progress) {
  AUTOSCAN_REQUIRE(!truth.empty(), "coverage oracle: empty truth mesh");
  AUTOSCAN_REQUIRE(!start.empty(), "coverage oracle: no start pose");
  AUTOSCAN_REQUIRE(o.views >= 0, "coverage oracle: views must be >= 0, got {}", o.views);
  o.candidates.validate("coverage oracle: candidates");
  const Stopwatch clock;
  Progress bar(progress, "coverage oracle");
  ScannerSpec s = spec;
  s.noise = NoiseSpec{};  // the truth's visibility: noise-free scans
  scanner::VirtualScannerOptions so;
  so.rig = rig;
  so.fixtures = fixture_meshes(rig);
  const scanner::VirtualScanner sc(truth, s, so);
  const eval::CoverageProbe probe(truth, reference, o.eval.tau, o.eval.samples, o.eval.seed);

  // The samples one scan covers: its object points only (a fixture is not the object).
  auto covered_by = [&](const Pose& pose, std::uint64_t id) {
    const scanner::ScanResult r = sc.scan(pose, id, 1);
    PointCloud object;
    for (std::size_t k = 0; k < r.cloud.size(); ++k)
      if (r.geometry[k] == scanner::ScanResult::kObject) object.positions.push_back(r.cloud.positions[k]);
    return probe.covered(object);
  };

  OracleResult out;
  const std::vector<Pose> all = scannable_views(truth, s, rig, o.candidates);
  std::vector<Pose> cand;
  for (const Pose& p : all) {
    if (sc.refusal(p))
      ++out.refused;
    else
      cand.push_back(p);
  }
  out.candidates = static_cast<int>(cand.size());
  std::vector<std::vector<std::uint32_t>> sets(cand.size());
  tbb::parallel_for(std::size_t{0}, cand.size(), [&](std::size_t i) { sets[i] = covered_by(cand[i], 1000 + i); });
  bar.report(0.5);

  std::vector<char> got(probe.samples(), 0);
  std::size_t all_covered = 0, scannable_covered = 0;
  const double n = static_cast<double>(probe.samples());
  const double ns = static_cast<double>(std::max<std::size_t>(1, probe.scannable_count()));
  double path = 0.0;
  auto add = [&](const std::vector<std::uint32_t>& set, const Pose& pose, int iteration) {
    std::size_t gain = 0;
    for (auto i : set)
      if (!got[i]) {
        got[i] = 1;
        ++all_covered;
        if (probe.scannable(i)) ++scannable_covered, ++gain;
      }
    if (!out.poses.empty()) path += (pose.position - out.poses.back().position).norm();
    out.poses.push_back(pose);
    const int scans = static_cast<int>(out.poses.size());
    nlohmann::json e = {{"scan", scans - 1},
                        {"iteration", iteration},
                        {"scans", scans},
                        {"views", std::max(0, scans - static_cast<int>(start.size()))},
                        {"coverage", static_cast<double>(all_covered) / n},
                        {"path_length", path},
                        {"gain", gain}};
    if (reference) e["coverage_scannable"] = static_cast<double>(scannable_covered) / ns;
    out.curve.push_back(std::move(e));
  };
  for (std::size_t i = 0; i < start.size(); ++i)
    if (!sc.refusal(start[i])) add(covered_by(start[i], i), start[i], -1);
  AUTOSCAN_REQUIRE(!out.poses.empty(), "coverage oracle: every start pose is refused by the rig");

  std::vector<char> used(cand.size(), 0);
  for (int v = 0; v < o.views; ++v) {
    std::size_t best = cand.size(), best_gain = 0;
    for (std::size_t c = 0; c < cand.size(); ++c) {
      if (used[c]) continue;
      std::size_t g = 0;
      for (auto i : sets[c]) g += !got[i] && probe.scannable(i);
      if (g > best_gain) best = c, best_gain = g;  // ties: the first candidate
    }
    if (best == cand.size()) break;  // nothing left to cover: the curve stays flat
    used[best] = 1;
    add(sets[best], cand[best], v);
    bar.report(0.5 + 0.5 * (v + 1) / std::max(1, o.views));
  }
  out.seconds = clock.seconds();
  log::info("coverage oracle: {} candidates ({} refused), {} views, {:.1f} % of the scannable, {:.1f} s",
            out.candidates, out.refused, out.poses.size() - start.size(),
            100.0 * out.curve.back().value("coverage_scannable", out.curve.back().value("coverage", 0.0)), out.seconds);
  return out;
}

}  // namespace autoscan::simulation
