#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/planners/planner.hpp"

using namespace autoscan;
using namespace autoscan::planners;

namespace {

// A stateful planner: proposes one view per call, each further round the circle than the last.
class CountingPlanner final : public Planner {
 public:
  std::string name() const override { return "counting"; }
  void observe_scan(const PointCloud& scan, const Pose&) override { points_ += scan.size(); }
  PlanOutput plan(const ModelState& state, const Pose& current, Rng&) override {
    PlanOutput out;
    const double a = 0.5 * calls_++;
    out.views.push_back({Pose::look_at(Vec3(std::cos(a), std::sin(a), 0), Vec3::Zero()), 1.0, Vec3::Zero()});
    out.path_length = path_length(state.rig, current, out.views);
    out.diagnostics = {{"points_seen", points_}};
    return out;
  }

 private:
  int calls_ = 0;
  std::size_t points_ = 0;
};

}  // namespace

TEST(Planners, RegistryKnowsPoissonAndRejectsUnknownNames) {
  const auto names = planner_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "poisson"), names.end());
  EXPECT_EQ(make_planner("poisson")->name(), "poisson");
  try {
    make_planner("no_such");
    FAIL() << "unknown planner accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("poisson"), std::string::npos);  // lists the known ones
  }
  PlannerOptions bad;
  bad.params = {{"typo", 1}};
  EXPECT_THROW(make_planner("poisson", bad), InputError);
}

TEST(Planners, PoissonPlannerNeedsAModel) {
  auto p = make_planner("poisson");
  ModelState empty;
  Rng rng(1);
  EXPECT_THROW(p->plan(empty, Pose::look_at(Vec3(1, 0, 0), Vec3::Zero()), rng), InputError);
}

TEST(Planners, RegisteredPlannersKeepStateAcrossIterations) {
  register_planner("counting", [](const PlannerOptions&) { return std::make_unique<CountingPlanner>(); });
  auto p = make_planner("counting");
  PointCloud scan;
  scan.positions.assign(5, Vec3::Zero());
  p->observe_scan(scan, Pose{});
  p->observe_scan(scan, Pose{});
  ModelState st;
  Rng rng(3);
  const Pose here = Pose::look_at(Vec3(2, 0, 0), Vec3::Zero());
  const auto a = p->plan(st, here, rng);
  const auto b = p->plan(st, here, rng);
  EXPECT_EQ(a.diagnostics.at("points_seen"), 10);
  EXPECT_FALSE(a.views[0].pose.position.isApprox(b.views[0].pose.position));
  EXPECT_THROW(register_planner("", [](const PlannerOptions&) { return std::make_unique<CountingPlanner>(); }),
               InputError);
}

TEST(Planners, GreedyOrderAndPathLength) {
  Rig rig;  // free: Euclidean travel cost
  std::vector<PlannedView> views;
  for (double x : {3.0, 1.0, 2.0}) views.push_back({Pose::look_at(Vec3(x, 0, 0), Vec3(x, 1, 0)), x, Vec3::Zero()});
  const Pose start = Pose::look_at(Vec3(0, 0, 0), Vec3(0, 1, 0));
  const auto ordered = order_greedy(rig, start, views);
  ASSERT_EQ(ordered.size(), 3u);
  EXPECT_EQ(ordered[0].score, 1.0);
  EXPECT_EQ(ordered[1].score, 2.0);
  EXPECT_EQ(ordered[2].score, 3.0);
  EXPECT_NEAR(path_length(rig, start, ordered), 3.0, 1e-12);
  EXPECT_NEAR(path_length(rig, start, views), 3.0 + 2.0 + 1.0, 1e-12);
}

TEST(Planners, ViewsJsonRoundTrip) {
  PlanOutput out;
  out.views.push_back({Pose::look_at(Vec3(1, 2, 3), Vec3::Zero()), 0.75, Vec3(0.1, 0.2, 0.3)});
  out.views.push_back({Pose::look_at(Vec3(-1, 0, 1), Vec3::Zero()), 0.5, Vec3(0, 0, 0.1)});
  out.path_length = 4.5;
  const auto j = views_to_json(out, {{"iteration", 3}});
  EXPECT_EQ(j.at("iteration"), 3);
  EXPECT_EQ(j.at("path_length"), 4.5);
  const auto back = views_from_json(j);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_TRUE(back[0].pose.position.isApprox(out.views[0].pose.position));
  EXPECT_TRUE(back[0].pose.direction.isApprox(out.views[0].pose.direction));
  EXPECT_EQ(back[0].score, 0.75);
  EXPECT_TRUE(back[1].target.isApprox(Vec3(0, 0, 0.1)));
  EXPECT_THROW(views_from_json(nlohmann::json::array()), InputError);
  EXPECT_THROW(views_from_json({{"views", {{{"position", {1, 2}}}}}}), InputError);
}
