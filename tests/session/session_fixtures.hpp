#pragma once
// Shared helpers for the session tests: a sphere scan generator, a scripted reconstructor (no
// Poisson solve: the stop rule and persistence do not need one) and a simple registered planner.
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <numbers>

#include "autoscan/core/random.hpp"
#include "autoscan/planners/planner.hpp"
#include "autoscan/session/session.hpp"
#include "support/temp_dir.hpp"

namespace autoscan::test {

/// A path for a new session directory (not created), below the test process's scratch root
/// (removed when the process exits: support/temp_dir.hpp).
inline std::filesystem::path fresh_dir(const std::string& name) {
  return testing::scratch_dir("session_" + name, false);
}

/// Points of the sphere of radius 0.25 (centred at the origin) facing `from`, jittered by `noise`.
inline PointCloud sphere_scan(const Vec3& from, std::size_t n, std::uint64_t seed, double noise = 0.0) {
  Rng rng(seed);
  PointCloud c;
  const Vec3 dir = from.normalized();
  while (c.size() < n) {
    const Vec3 u = rng.unit_vector();
    if (u.dot(dir) < 0.3) continue;
    c.positions.push_back(0.25 * u + noise * rng.normal() * u);
    c.normals.push_back(u);
  }
  return c;
}

/// Fibonacci points on the sphere of radius 0.25.
inline std::vector<Vec3> fibonacci(std::size_t n) {
  std::vector<Vec3> p;
  const double ga = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double r = std::sqrt(1.0 - z * z);
    p.push_back(0.25 * Vec3(r * std::cos(ga * i), r * std::sin(ga * i), z));
  }
  return p;
}

/// A reconstructor that models the object as the known sphere and reports scripted confidences:
/// call k returns mean f = script[min(k, size-1)] (every iso-point gets that f).
inline session::Reconstructor scripted_reconstructor(std::vector<double> script,
                                                     std::shared_ptr<int> calls = std::make_shared<int>(0)) {
  return [script, calls](const PointCloud& raw, const session::SessionOptions&, const ProgressCallback&) {
    const double f = script[std::min<std::size_t>(static_cast<std::size_t>(*calls), script.size() - 1)];
    ++*calls;
    session::Reconstruction r;
    // Consolidated: a deterministic subset of the raw points with radial normals.
    for (std::size_t i = 0; i < raw.size(); i += 4) {
      r.consolidated.positions.push_back(raw.positions[i]);
      r.consolidated.normals.push_back(raw.positions[i].normalized());
    }
    const auto iso = fibonacci(500);
    r.iso_points.positions = iso;
    for (const auto& p : iso) r.iso_points.normals.push_back(p.normalized());
    r.iso_points.scalars.set("f", std::vector<double>(iso.size(), f));
    r.iso_points.scalars.set("f_g", std::vector<double>(iso.size(), std::sqrt(f)));
    r.iso_points.scalars.set("f_s", std::vector<double>(iso.size(), std::sqrt(f)));
    r.mean_f = f;
    r.mean_f_g = r.mean_f_s = std::sqrt(f);
    r.seconds["consolidate"] = 0.0;
    return r;
  };
}

/// Planner "test_ring": `views` views (params, default 3) on a ring of radius 1.2 around Z, looking
/// at the origin; its diagnostics report how many scans it observed (tests the replay on open()).
class RingPlanner final : public planners::Planner {
 public:
  explicit RingPlanner(const planners::PlannerOptions& o) : views_(o.params.value("views", 3)) {}
  std::string name() const override { return "test_ring"; }
  void observe_scan(const PointCloud&, const Pose&) override { ++observed_; }
  planners::PlanOutput plan(const planners::ModelState& state, const Pose& current, Rng& rng) override {
    planners::PlanOutput out;
    const double phase = rng.uniform(0.0, 0.1);
    for (int i = 0; i < views_; ++i) {
      const double a = phase + 2.0 * std::numbers::pi * (i + 0.5 * state.iteration) / std::max(views_, 1);
      planners::PlannedView v;
      v.pose = Pose::look_at(Vec3(1.2 * std::cos(a), 1.2 * std::sin(a), 0.3), Vec3::Zero());
      v.score = 1.0 - state.mean_f;
      out.views.push_back(v);
    }
    out.views = planners::order_greedy(state.rig, current, out.views);
    out.path_length = planners::path_length(state.rig, current, out.views);
    out.diagnostics = {{"observed", observed_}};
    return out;
  }

 private:
  int views_;
  int observed_ = 0;
};

inline void register_test_planner() {
  static std::atomic<bool> done{false};
  if (done.exchange(true)) return;
  planners::register_planner("test_ring",
                             [](const planners::PlannerOptions& o) { return std::make_unique<RingPlanner>(o); });
}

inline session::SessionOptions test_options() {
  register_test_planner();
  session::SessionOptions o;
  o.planner = "test_ring";
  o.seed = 7;
  // The sphere fixtures leave rotations about the centre free, which no registration can fix: the
  // global registration is tested on an asymmetric shape (tests/support/bumpy.hpp).
  o.global_registration = false;
  // The scripted reconstructor builds no mesh, so no quality certificate: these tests drive the
  // paper's rule (§5.3); the rule "remaining" has its own tests (test_stop_rule.cpp).
  o.stop.rule = session::StopRule::paper;
  return o;
}

}  // namespace autoscan::test
