// Pose graph and global multi-view registration against oracles: exact synthetic graphs, and scans
// of an analytic surface with injected robot pose errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/registration/multiway.hpp"
#include "autoscan/registration/pose_graph.hpp"
#include "support/bumpy.hpp"

using namespace autoscan;
using namespace autoscan::registration;

namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Isometry3d rigid(double angle_deg, const Vec3& axis, const Vec3& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_deg * kPi / 180.0, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

Eigen::Isometry3d random_rigid(Rng& rng, double max_deg, double max_t) {
  return rigid(rng.uniform(-max_deg, max_deg), rng.unit_vector(),
               Vec3(rng.uniform(-max_t, max_t), rng.uniform(-max_t, max_t), rng.uniform(-max_t, max_t)));
}

double pose_distance(const Eigen::Isometry3d& A, const Eigen::Isometry3d& B) {
  return (A.matrix() - B.matrix()).cwiseAbs().maxCoeff();
}

struct Scene {
  std::vector<PointCloud> truth;  // world frame, true placement
  std::vector<PointCloud> scans;  // at the reported (wrong) pose
  std::vector<Vec3> sensors;
  std::vector<Eigen::Isometry3d> error;  // scans = error * truth
};

Scene make_scene(int count, double sigma_t, double sigma_r_deg, std::uint64_t seed) {
  Scene s;
  Rng rng(seed);
  for (int k = 0; k < count; ++k) {
    const Vec3 sensor = test::ring_sensor(k, count);
    PointCloud t = test::bumpy_scan(sensor, 30000, 0.0005, seed + 100 + static_cast<std::uint64_t>(k));
    const Eigen::Isometry3d E = test::robot_error(sensor, sigma_t, sigma_r_deg, rng);
    PointCloud w = t;
    for (auto& p : w.positions) p = E * p;
    s.truth.push_back(std::move(t));
    s.scans.push_back(std::move(w));
    s.sensors.push_back(sensor);
    s.error.push_back(E);
  }
  return s;
}

// Median over scans of the RMS distance between each registered scan point and its true place, after
// the one rigid motion that best fits all registered scans to the truth (closed form, known pairs).
std::vector<double> per_scan_error(const Scene& s, const std::vector<Eigen::Isometry3d>& corr, int skip = -1) {
  Eigen::Matrix3Xd A, B;
  std::size_t total = 0;
  for (std::size_t k = 0; k < s.truth.size(); ++k)
    if (static_cast<int>(k) != skip) total += (s.truth[k].size() + 9) / 10;
  A.resize(3, static_cast<Eigen::Index>(total));
  B.resize(3, static_cast<Eigen::Index>(total));
  Eigen::Index col = 0;
  for (std::size_t k = 0; k < s.truth.size(); ++k)
    for (std::size_t i = 0; static_cast<int>(k) != skip && i < s.truth[k].size(); i += 10, ++col) {
      A.col(col) = corr[k] * s.scans[k].positions[i];
      B.col(col) = s.truth[k].positions[i];
    }
  const Eigen::Matrix4d G = Eigen::umeyama(A, B, false);
  Eigen::Isometry3d g(G);
  std::vector<double> err;
  for (std::size_t k = 0; k < s.truth.size(); ++k) {
    double sum = 0.0;
    for (std::size_t i = 0; i < s.truth[k].size(); ++i)
      sum += (g * (corr[k] * s.scans[k].positions[i]) - s.truth[k].positions[i]).squaredNorm();
    err.push_back(std::sqrt(sum / static_cast<double>(s.truth[k].size())));
  }
  return err;
}

// The edge (i, j) of poses `truth`, measured exactly.
PoseGraphEdge exact_edge(const std::vector<Eigen::Isometry3d>& truth, int i, int j,
                         const Eigen::Matrix<double, 6, 6>& information) {
  PoseGraphEdge e;
  e.from = i;
  e.to = j;
  e.measurement = truth[static_cast<std::size_t>(j)].inverse() * truth[static_cast<std::size_t>(i)];
  e.information = information;
  return e;
}

}  // namespace

TEST(PoseGraph, SolvesExactSyntheticGraphTo1e6) {
  Rng rng(7);
  const int n = 6;
  std::vector<Eigen::Isometry3d> truth;
  for (int i = 0; i < n; ++i) truth.push_back(random_rigid(rng, 25.0, 0.2));
  std::vector<PoseGraphEdge> edges;
  for (int i = 0; i < n; ++i)
    for (int j : {i + 1, i + 2}) {
      if (j >= n) continue;
      const Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Random();
      edges.push_back(exact_edge(truth, i, j, M * M.transpose() + Eigen::Matrix<double, 6, 6>::Identity()));
    }
  std::vector<Eigen::Isometry3d> initial(n, Eigen::Isometry3d::Identity());
  initial[0] = truth[0];
  std::vector<char> fixed(n, 0);
  fixed[0] = 1;
  PoseGraphOptions o;
  o.robust_scale = 0.0;
  const auto r = solve_pose_graph(initial, fixed, edges, {}, o);
  ASSERT_EQ(r.poses.size(), static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    EXPECT_LT(pose_distance(r.poses[static_cast<std::size_t>(i)], truth[static_cast<std::size_t>(i)]), 1e-6)
        << "node " << i;
  for (double c : r.edge_chi2) EXPECT_LT(c, 1e-10);
}

TEST(PoseGraph, RobustLossResistsOneWrongEdge) {
  Rng rng(11);
  const int n = 5;
  std::vector<Eigen::Isometry3d> truth;
  for (int i = 0; i < n; ++i) truth.push_back(random_rigid(rng, 5.0, 0.02));
  std::vector<PoseGraphEdge> edges;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      PoseGraphEdge e = exact_edge(truth, i, j, 1e6 * Eigen::Matrix<double, 6, 6>::Identity());
      if (i == 1 && j == 3) e.measurement = rigid(10.0, Vec3::UnitZ(), Vec3(0.05, 0, 0)) * e.measurement;
      edges.push_back(e);
    }
  std::vector<Eigen::Isometry3d> initial(n, Eigen::Isometry3d::Identity());
  initial[0] = truth[0];
  std::vector<char> fixed(n, 0);
  fixed[0] = 1;
  const auto robust = solve_pose_graph(initial, fixed, edges, {}, {});
  PoseGraphOptions plain;
  plain.robust_scale = 0.0;
  const auto ls = solve_pose_graph(initial, fixed, edges, {}, plain);
  double worst_robust = 0.0, worst_ls = 0.0;
  for (int i = 0; i < n; ++i) {
    worst_robust = std::max(
        worst_robust, pose_distance(robust.poses[static_cast<std::size_t>(i)], truth[static_cast<std::size_t>(i)]));
    worst_ls =
        std::max(worst_ls, pose_distance(ls.poses[static_cast<std::size_t>(i)], truth[static_cast<std::size_t>(i)]));
  }
  EXPECT_LT(worst_robust, 1e-4);
  EXPECT_GT(worst_ls, 1e-2);            // least squares alone is pulled by the wrong edge
  EXPECT_GT(robust.edge_chi2[5], 1e3);  // (1, 3) is the 6th edge in order
}

TEST(PoseGraph, PriorPullsAFreeNodeTowardsIdentityAboutItsPivot) {
  // One node, one prior: the solution is the identity whatever the start.
  std::vector<Eigen::Isometry3d> initial = {rigid(3.0, Vec3(1, 2, 3), Vec3(0.01, 0.0, -0.02))};
  std::vector<PoseGraphPrior> priors = {{0, Vec3(1, 0, 0), 0.003, 0.01}};
  const auto r = solve_pose_graph(initial, {}, {}, priors, {});
  EXPECT_LT(pose_distance(r.poses[0], Eigen::Isometry3d::Identity()), 1e-8);
}

TEST(PoseGraph, RejectsBadInput) {
  std::vector<Eigen::Isometry3d> initial(2, Eigen::Isometry3d::Identity());
  std::vector<PoseGraphEdge> self = {{1, 1, Eigen::Isometry3d::Identity(), Eigen::Matrix<double, 6, 6>::Identity()}};
  EXPECT_THROW(solve_pose_graph(initial, {}, self, {}, {}), InputError);
  std::vector<PoseGraphEdge> out = {{0, 2, Eigen::Isometry3d::Identity(), Eigen::Matrix<double, 6, 6>::Identity()}};
  EXPECT_THROW(solve_pose_graph(initial, {}, out, {}, {}), InputError);
  std::vector<PoseGraphPrior> bad = {{0, Vec3::Zero(), 0.0, 0.1}};
  EXPECT_THROW(solve_pose_graph(initial, {}, {}, bad, {}), InputError);
}

TEST(Multiway, AlignsScansWithInjectedRobotErrors) {
  const Scene s = make_scene(8, 0.006, 1.0, 3);
  const std::vector<Eigen::Isometry3d> none(s.scans.size(), Eigen::Isometry3d::Identity());
  const auto before = per_scan_error(s, none);
  MultiwayOptions o;
  o.robot_translation_sigma = 0.006;
  o.robot_rotation_sigma_deg = 1.0;
  const auto r = register_multiway(s.scans, s.sensors, {}, {}, o);
  ASSERT_EQ(r.corrections.size(), s.scans.size());
  const auto after = per_scan_error(s, r.corrections);
  if (std::getenv("MW_DEBUG")) std::printf("%s\n", to_json(r).dump(1).c_str());
  double mean_before = 0.0, mean_after = 0.0;
  for (std::size_t k = 0; k < after.size(); ++k) {
    mean_before += before[k] / static_cast<double>(after.size());
    mean_after += after[k] / static_cast<double>(after.size());
    EXPECT_LT(after[k], 0.002) << "scan " << k;  // 4x the depth noise
    EXPECT_FALSE(r.scans[k].flagged) << r.scans[k].flag_reason;
  }
  EXPECT_LT(mean_after, 0.2 * mean_before);
  EXPECT_GT(r.pairs.size(), 8u);
  // The same input gives the same answer.
  const auto again = register_multiway(s.scans, s.sensors, {}, {}, o);
  for (std::size_t k = 0; k < after.size(); ++k) EXPECT_EQ(again.corrections[k].matrix(), r.corrections[k].matrix());
  const auto j = to_json(r);
  EXPECT_EQ(j.at("scans").size(), s.scans.size());
}

// max_pairs_per_scan bounds the pairs each free scan takes part in (the cost of an iteration must
// not grow with the number of scans): with 2 per scan, 8 free scans use at most 16 pairs, each
// scan's kept partners are its largest overlaps, and the scans are still aligned.
TEST(Multiway, CapsThePairsPerScanAndStillAligns) {
  const Scene s = make_scene(8, 0.006, 1.0, 3);
  MultiwayOptions o;
  o.robot_translation_sigma = 0.006;
  o.robot_rotation_sigma_deg = 1.0;
  o.max_pairs_per_scan = 0;
  const auto all = register_multiway(s.scans, s.sensors, {}, {}, o);
  o.max_pairs_per_scan = 2;
  const auto capped = register_multiway(s.scans, s.sensors, {}, {}, o);
  EXPECT_EQ(all.pairs_capped, 0u);
  EXPECT_GT(capped.pairs_capped, 0u);
  EXPECT_LE(capped.pairs.size(), 16u);
  EXPECT_EQ(capped.pairs.size() + capped.pairs_capped, all.pairs.size());
  std::vector<int> degree(s.scans.size(), 0);
  for (const auto& p : capped.pairs) ++degree[p.i], ++degree[p.j];
  for (int d : degree) EXPECT_GE(d, 1);
  const auto after = per_scan_error(s, capped.corrections);
  for (std::size_t k = 0; k < after.size(); ++k) EXPECT_LT(after[k], 0.002) << "scan " << k;
  EXPECT_EQ(to_json(capped).at("pairs_capped").get<std::size_t>(), capped.pairs_capped);
}

TEST(Multiway, FlagsAScanFarBeyondTheDeclaredAccuracy) {
  Scene s = make_scene(8, 0.003, 0.5, 5);
  // Scan 3's reported pose is 12 sigma off: a shift of 3.6 cm.
  const Eigen::Isometry3d big = rigid(0.0, Vec3::UnitZ(), Vec3(0.0, 0.0, 0.036));
  for (auto& p : s.scans[3].positions) p = big * p;
  MultiwayOptions o;
  o.robot_translation_sigma = 0.003;
  o.robot_rotation_sigma_deg = 0.5;
  // The bumpy scans reach 70 degrees from the view direction; with the default cut at 60 degrees
  // the 3.6 cm shift leaves scan 3 too little overlap to be tested at all.
  o.max_incidence_deg = 80.0;
  const auto r = register_multiway(s.scans, s.sensors, {}, {}, o);
  EXPECT_TRUE(r.scans[3].flagged);
  int flagged = 0;
  for (const auto& sc : r.scans) flagged += sc.flagged ? 1 : 0;
  EXPECT_EQ(flagged, 1);
  // The others are still aligned.
  auto err = per_scan_error(s, r.corrections, 3);
  for (std::size_t k = 0; k < err.size(); ++k) {
    if (k == 3) continue;
    EXPECT_LT(err[k], 0.002) << "scan " << k;
  }
}

TEST(Multiway, AnchorsStayAndOnlyFreeScansMove) {
  const Scene s = make_scene(6, 0.004, 0.5, 9);
  std::vector<char> free(s.scans.size(), 0);
  free[5] = 1;
  MultiwayOptions o;
  o.robot_translation_sigma = 0.004;
  o.robot_rotation_sigma_deg = 0.5;
  o.free_neighbors = false;
  // Anchors at their true placement: scan 5 must come to its true place too.
  std::vector<Eigen::Isometry3d> init;
  for (const auto& E : s.error) init.push_back(E.inverse());
  init[5] = Eigen::Isometry3d::Identity();
  const auto r = register_multiway(s.scans, s.sensors, init, free, o);
  if (std::getenv("MW_DEBUG")) std::printf("%s\n", to_json(r).dump(1).c_str());
  for (std::size_t k = 0; k < 5; ++k) EXPECT_EQ(r.corrections[k].matrix(), init[k].matrix());
  const Eigen::Isometry3d residual = r.corrections[5] * s.error[5];
  EXPECT_LT(residual.translation().norm(), 0.001);
  EXPECT_LT(rotation_angle_deg(residual), 0.1);
}

TEST(Multiway, RejectsBadOptions) {
  MultiwayOptions o;
  o.robot_translation_sigma = 0.0;
  EXPECT_THROW(o.validate(), InputError);
  o = {};
  o.min_overlap = 1.5;
  EXPECT_THROW(o.validate(), InputError);
  o = {};
  o.min_significance = -1.0;
  EXPECT_THROW(o.validate(), InputError);
  std::vector<PointCloud> scans(2);
  std::vector<Vec3> sensors(1);
  EXPECT_THROW(register_multiway(scans, sensors, {}, {}, {}), InputError);
}

namespace {

// A cap of a sphere of radius R (centre at the origin) seen from +z, noisy along the rays to the
// sensor: the virtual scanner's depth noise in miniature.
std::vector<Vec3> noisy_cap(double R, double sigma, std::uint64_t seed, const Vec3& sensor) {
  Rng rng(seed);
  std::vector<Vec3> pts;
  for (int i = 0; i < 20000; ++i) {
    Vec3 d = rng.unit_vector();
    if (d.z() < 0.6) continue;
    const Vec3 p = R * d;
    pts.push_back(p + rng.normal(0.0, sigma) * (sensor - p).normalized());
  }
  return pts;
}

double mean_signed_offset(const std::vector<Vec3>& pts, double R) {
  double s = 0.0;
  for (const auto& p : pts) s += p.norm() - R;
  return s / static_cast<double>(pts.size());
}

}  // namespace

TEST(SurfaceFit, QuadricRemovesThePlanesCurvatureBias) {
  // Oracle: the sphere. A plane over k neighbours of radius r sits about r²/4R inside a sphere; the
  // quadric follows it.
  const double R = 0.1;
  const Vec3 sensor(0, 0, 1.0);
  const auto pts = noisy_cap(R, 0.0, 3, sensor);
  registration::SurfaceFitOptions o;
  o.k = 200;
  o.quadric = false;
  const auto plane = registration::fit_scan_surface(pts, sensor, o);
  o.quadric = true;
  const auto quad = registration::fit_scan_surface(pts, sensor, o);
  const double plane_bias = mean_signed_offset(plane.projected, R);
  const double quad_bias = mean_signed_offset(quad.projected, R);
  EXPECT_LT(plane_bias, -1e-5);  // inwards
  EXPECT_LT(std::abs(quad_bias), 0.05 * std::abs(plane_bias));
  for (std::size_t i = 0; i < pts.size(); i += 97) {
    EXPECT_GT(quad.normals[i].dot(pts[i].normalized()), 0.999);  // outward = towards the sensor
  }
}

TEST(SurfaceFit, NeighbourhoodGrowsWithTheNoiseAndDenoises) {
  const double R = 0.1;
  const Vec3 sensor(0, 0, 1.0);
  const auto clean = registration::fit_scan_surface(noisy_cap(R, 0.0, 5, sensor), sensor);
  const auto pts = noisy_cap(R, 0.003, 5, sensor);
  const auto noisy = registration::fit_scan_surface(pts, sensor);
  EXPECT_EQ(clean.neighbors, registration::SurfaceFitOptions{}.k_min);
  EXPECT_LT(clean.noise, 1e-6);
  EXPECT_NEAR(noisy.noise, 0.003, 0.001);  // the estimated scatter is the depth noise
  EXPECT_GT(noisy.neighbors, 3 * clean.neighbors);
  // Denoised: the projected points lie far closer to the sphere than the raw ones.
  double raw = 0.0, den = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    raw += std::abs(pts[i].norm() - R);
    den += std::abs(noisy.projected[i].norm() - R);
  }
  EXPECT_LT(den, 0.35 * raw);
  EXPECT_NEAR(mean_signed_offset(noisy.projected, R), 0.0, 2e-4);
  registration::SurfaceFitOptions bad;
  bad.k_min = 50;
  bad.k_max = 10;
  EXPECT_THROW(registration::fit_scan_surface(pts, sensor, bad), InputError);
}

// The surface fitted at one anchor in every k / anchor_points points, each point moved onto its
// nearest anchor's surface (the cost: a fit per anchor), denoises as fitting every point does and
// keeps the quadric's freedom from the curvature bias. Oracle: the sphere.
TEST(SurfaceFit, AnchoredFitsDenoiseAsFittingEveryPoint) {
  const double R = 0.1;
  const Vec3 sensor(0, 0, 1.0);
  const auto pts = noisy_cap(R, 0.003, 5, sensor);
  registration::SurfaceFitOptions o;
  o.k = 200;
  o.anchor_points = 0;
  const auto every = registration::fit_scan_surface(pts, sensor, o);
  o.anchor_points = 50;  // an anchor in every 4 points
  const auto anchored = registration::fit_scan_surface(pts, sensor, o);
  double e_every = 0.0, e_anchored = 0.0, a_every = 0.0, a_anchored = 0.0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    e_every += std::abs(every.projected[i].norm() - R);
    e_anchored += std::abs(anchored.projected[i].norm() - R);
    a_every += std::acos(std::min(1.0, every.normals[i].dot(pts[i].normalized())));
    a_anchored += std::acos(std::min(1.0, anchored.normals[i].dot(pts[i].normalized())));
  }
  EXPECT_LT(e_anchored, 1.15 * e_every);
  EXPECT_LT(a_anchored, 1.15 * a_every);  // mean normal error
  EXPECT_NEAR(mean_signed_offset(anchored.projected, R), 0.0, 2e-4);
  EXPECT_EQ(anchored.neighbors, 200);
  registration::SurfaceFitOptions bad;
  bad.anchor_points = -1;
  EXPECT_THROW(registration::fit_scan_surface(pts, sensor, bad), InputError);
}

// max_anchor_pairs_per_scan bounds each free scan's pairs with the fixed scans of earlier iterations
// (the later iterations' cost) and keeps every pair among the free scans: two new scans among six
// anchors at their true placement keep one anchor each and their own pair, and come to their true
// places.
TEST(Multiway, CapsTheAnchorPairsAndKeepsThePairsAmongTheFreeScans) {
  const Scene s = make_scene(8, 0.004, 0.5, 9);
  std::vector<char> free(s.scans.size(), 0);
  free[3] = free[4] = 1;  // neighbours on the ring
  MultiwayOptions o;
  o.robot_translation_sigma = 0.004;
  o.robot_rotation_sigma_deg = 0.5;
  std::vector<Eigen::Isometry3d> init;
  for (const auto& E : s.error) init.push_back(E.inverse());
  init[3] = init[4] = Eigen::Isometry3d::Identity();
  o.max_anchor_pairs_per_scan = 0;
  const auto all = register_multiway(s.scans, s.sensors, init, free, o);
  o.max_anchor_pairs_per_scan = 1;
  const auto capped = register_multiway(s.scans, s.sensors, init, free, o);
  EXPECT_GT(capped.pairs_capped, 0u);
  EXPECT_EQ(capped.pairs.size() + capped.pairs_capped, all.pairs.size());
  std::vector<int> anchors_of(s.scans.size(), 0);
  bool free_pair = false;
  for (const auto& p : capped.pairs) {
    const bool fi = free[static_cast<std::size_t>(p.i)] != 0, fj = free[static_cast<std::size_t>(p.j)] != 0;
    if (fi && fj) free_pair = true;
    if (fi != fj) ++anchors_of[static_cast<std::size_t>(fi ? p.i : p.j)];
  }
  EXPECT_TRUE(free_pair);
  EXPECT_EQ(anchors_of[3], 1);
  EXPECT_EQ(anchors_of[4], 1);
  for (std::size_t k : {std::size_t{3}, std::size_t{4}}) {
    const Eigen::Isometry3d residual = capped.corrections[k] * s.error[k];
    EXPECT_LT(residual.translation().norm(), 0.001) << "scan " << k;
    EXPECT_LT(rotation_angle_deg(residual), 0.1) << "scan " << k;
  }
  o.max_anchor_pairs_per_scan = -1;
  EXPECT_THROW(register_multiway(s.scans, s.sensors, init, free, o), InputError);
}

// Bridges (bridge_min_overlap): when the pairs that overlap by min_overlap leave a ring of scans in
// pieces (as at high noise, where neighbouring blind scans overlap by 12-19 % within three point
// spacings), the weak pairs of largest overlap that join the pieces are used, and only as many as
// that takes: every scan is aligned, where without bridges the pieces keep their relative error.
TEST(Multiway, BridgesJoinTheGroupsThatMinOverlapLeavesApart) {
  const Scene s = make_scene(8, 0.006, 1.0, 3);
  MultiwayOptions o;
  o.robot_translation_sigma = 0.006;
  o.robot_rotation_sigma_deg = 1.0;
  o.max_incidence_deg = 45.0;  // smaller scans: neighbouring views overlap less
  o.min_overlap = 0.2;
  o.bridge_min_overlap = 0.0;
  const auto apart = register_multiway(s.scans, s.sensors, {}, {}, o);
  if (std::getenv("MW_DEBUG")) std::printf("%s\n", to_json(apart).dump(1).c_str());
  o.bridge_min_overlap = 0.05;
  const auto joined = register_multiway(s.scans, s.sensors, {}, {}, o);
  if (std::getenv("MW_DEBUG")) std::printf("%s\n", to_json(joined).dump(1).c_str());
  // Without bridges the ring falls into three groups, one of them scan 6 alone.
  EXPECT_EQ(apart.scans[6].pairs_used, 0);
  for (const auto& p : apart.pairs) EXPECT_FALSE(p.bridge);
  // With them, two bridges (three groups) and every scan paired.
  int bridges = 0;
  for (const auto& p : joined.pairs) {
    bridges += p.bridge ? 1 : 0;
    if (p.bridge) {
      EXPECT_TRUE(p.used);
      EXPECT_LT(p.overlap, o.min_overlap);
    }
  }
  EXPECT_EQ(bridges, 2);
  for (const auto& sc : joined.scans) {
    EXPECT_GE(sc.pairs_used, 1);
    EXPECT_FALSE(sc.flagged) << sc.flag_reason;
  }
  const auto e_apart = per_scan_error(s, apart.corrections);
  const auto e_joined = per_scan_error(s, joined.corrections);
  double worst_apart = 0.0, worst_joined = 0.0;
  for (std::size_t k = 0; k < e_joined.size(); ++k) {
    worst_apart = std::max(worst_apart, e_apart[k]);
    worst_joined = std::max(worst_joined, e_joined[k]);
  }
  if (std::getenv("MW_DEBUG")) std::printf("worst error: apart %.5f joined %.5f\n", worst_apart, worst_joined);
  EXPECT_LT(worst_joined, 0.002);  // 4x the depth noise, as AlignsScansWithInjectedRobotErrors
  EXPECT_LT(worst_joined, 0.5 * worst_apart);
  EXPECT_TRUE(to_json(joined).at("pairs").at(0).contains("bridge"));
  o.bridge_min_overlap = 0.3;  // above min_overlap
  EXPECT_THROW(o.validate(), InputError);
}

// A prior centred on a correction (the part a hand-eye offset explains) pulls its node there, and
// its chi² is 0 at the centre.
TEST(PoseGraph, APriorCentredOnACorrectionPullsTheNodeThere) {
  Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
  P.linear() = Eigen::AngleAxisd(0.02, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  P.translation() = Vec3(0.004, -0.001, 0.002);
  const std::vector<Eigen::Isometry3d> initial = {Eigen::Isometry3d::Identity()};
  const std::vector<char> fixed = {0};
  std::vector<PoseGraphPrior> priors = {{0, Vec3(0.5, 0.2, 0.1), 0.003, 0.01, P}};
  const auto r = solve_pose_graph(initial, fixed, {}, priors, {});
  EXPECT_LT((r.poses[0].matrix() - P.matrix()).norm(), 1e-8);
  ASSERT_EQ(r.prior_chi2.size(), 1u);
  EXPECT_LT(r.prior_chi2[0], 1e-12);
  priors[0].center = Eigen::Isometry3d::Identity();  // the reported pose: back to the identity
  const auto r0 = solve_pose_graph(std::vector<Eigen::Isometry3d>{P}, fixed, {}, priors, {});
  EXPECT_LT((r0.poses[0].matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-8);
}

// Good poses stay put (MultiwayOptions::min_significance, issue 45): with the true poses the
// solution only fits the pairs' noise (F about 1) and the reported poses are kept; with a robot error
// the F statistic is far beyond it and the solution is taken, as without the test.
TEST(Multiway, TheTrueReportedPosesAreKeptAndAWrongOneIsCorrected) {
  MultiwayOptions o;
  o.robot_translation_sigma = 0.006;
  o.robot_rotation_sigma_deg = 1.0;
  o.min_significance = 4.0;  // the default
  const Scene exact = make_scene(12, 0.0, 0.0, 3);
  const auto kept = register_multiway(exact.scans, exact.sensors, {}, {}, o);
  if (std::getenv("MW_DEBUG")) std::printf("%s\n", to_json(kept).dump(1).c_str());
  EXPECT_EQ(kept.solved_scans, 12);
  EXPECT_LT(kept.significance, o.min_significance);
  EXPECT_GT(kept.pair_chi2_initial, kept.pair_chi2);  // the solution fits the pairs' noise a little better
  EXPECT_TRUE(kept.kept_initial);
  for (const auto& c : kept.corrections) EXPECT_TRUE(c.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(kept.significance_applies);

  // Scans that start from an earlier registration's correction are not at the robot's word: the
  // solution is taken whatever F says.
  std::vector<Eigen::Isometry3d> moved(exact.scans.size(), Eigen::Isometry3d::Identity());
  moved[3] = rigid(0.01, Vec3::UnitZ(), Vec3(1e-5, 0, 0));
  const auto from_moved = register_multiway(exact.scans, exact.sensors, moved, {}, o);
  EXPECT_FALSE(from_moved.significance_applies);
  EXPECT_FALSE(from_moved.kept_initial);

  const Scene wrong = make_scene(12, 0.006, 1.0, 3);
  const auto taken = register_multiway(wrong.scans, wrong.sensors, {}, {}, o);
  EXPECT_GT(taken.significance, 10.0 * o.min_significance);
  EXPECT_FALSE(taken.kept_initial);
  MultiwayOptions plain = o;
  plain.min_significance = 0.0;
  const auto always = register_multiway(wrong.scans, wrong.sensors, {}, {}, plain);
  for (std::size_t k = 0; k < taken.corrections.size(); ++k)
    EXPECT_EQ(taken.corrections[k].matrix(), always.corrections[k].matrix());
  EXPECT_EQ(to_json(taken).at("kept_initial"), false);
}
