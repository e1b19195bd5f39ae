// Consolidation (paper §4.1) against analytic oracles: sphere distance, truth normals, brute force.
#include <gtest/gtest.h>
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/consolidate/knn.hpp"
#include "autoscan/core/error.hpp"
#include "test_data.hpp"

namespace ac = autoscan::consolidate;
using autoscan::InputError;
using autoscan::PointCloud;
using autoscan::Rng;
using autoscan::Vec3;
using autoscan::testdata::angle_deg;

namespace {

double rms_sphere_distance(const PointCloud& c, double radius) {
  double s = 0.0;
  for (const auto& p : c.positions) s += (p.norm() - radius) * (p.norm() - radius);
  return std::sqrt(s / static_cast<double>(c.size()));
}

struct NormalStats {
  double mean_angle = 0.0;
  double outward = 0.0;  ///< fraction with a positive dot with the truth
};

/// Compares normals against truth normals looked up through the "truth_id" column.
NormalStats compare_normals(const PointCloud& c, const std::vector<Vec3>& truth) {
  const auto& id = c.scalars.get("truth_id");
  NormalStats st;
  std::size_t good = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Vec3& t = truth[static_cast<std::size_t>(id[i])];
    st.mean_angle += angle_deg(c.normals[i], t);
    if (c.normals[i].dot(t) > 0.0) ++good;
  }
  st.mean_angle /= static_cast<double>(c.size());
  st.outward = static_cast<double>(good) / static_cast<double>(c.size());
  return st;
}

}  // namespace

TEST(Consolidate, WlopReducesNoiseOnSphereAtLeastThreeFold) {
  constexpr double R = 0.5;
  auto data = autoscan::testdata::sphere_scan(30000, R, 0.01, 1);
  const double before = rms_sphere_distance(data.cloud, R);
  ac::ConsolidateOptions opt;  // defaults: WLOP automatic with unknown noise → on
  ASSERT_TRUE(ac::wlop_enabled(opt.wlop));
  const auto res = ac::consolidate(data.cloud, opt);
  ASSERT_TRUE(res.wlop.applied);
  const double after = rms_sphere_distance(res.cloud, R);
  EXPECT_GT(before, 0.009);
  EXPECT_LT(after * 3.0, before) << "before " << before << " after " << after;
  ASSERT_EQ(res.cloud.normals.size(), res.cloud.size());
  // Normals of the denoised points are outward (sensor orientation) and close to the radial direction.
  std::size_t outward = 0;
  for (std::size_t i = 0; i < res.cloud.size(); ++i)
    if (res.cloud.normals[i].dot(res.cloud.positions[i]) > 0.0) ++outward;
  EXPECT_GT(static_cast<double>(outward) / static_cast<double>(res.cloud.size()), 0.995);
  EXPECT_EQ(res.points_out, res.cloud.size());
  EXPECT_EQ(res.points_in, data.cloud.size());
}

// The no-sensor case of docs/consolidation.md on a sphere: noise 1 % of the radius, 1 % outliers
// uniform in the enlarged bounding box, no sensor positions, default options. Jet smoothing, WLOP and
// the projection must at least halve the RMS distance to the surface (measured: about 4x), the MST
// must orient all but a few normals outward, and no outlier may survive far from the surface.
TEST(Consolidate, DefaultsDenoiseAndOrientWithoutSensors) {
  constexpr double R = 0.5, kNoise = 0.005;
  constexpr std::size_t kInliers = 20000, kOutliers = 200;
  auto data = autoscan::testdata::sphere_scan(kInliers, R, kNoise, 11);
  for (const char* c : {"sensor_x", "sensor_y", "sensor_z"}) data.cloud.scalars.erase(c);
  const double before = rms_sphere_distance(data.cloud, R);
  Rng rng(12);
  PointCloud out;
  for (std::size_t i = 0; i < kOutliers; ++i)
    out.positions.emplace_back(rng.uniform(-0.55, 0.55), rng.uniform(-0.55, 0.55), rng.uniform(-0.55, 0.55));
  PointCloud cloud = data.cloud;
  cloud.append(out);
  const auto res = ac::consolidate(cloud, {});
  ASSERT_TRUE(res.wlop.applied);
  EXPECT_TRUE(res.smoothing.projected_wlop);
  EXPECT_EQ(res.normals.orientation, ac::Orientation::mst);
  const double after = rms_sphere_distance(res.cloud, R);
  EXPECT_LT(after * 2.5, before) << "before " << before << " after " << after;
  double worst = 0.0, angle = 0.0;
  std::size_t inward = 0;
  for (std::size_t i = 0; i < res.cloud.size(); ++i) {
    const Vec3& p = res.cloud.positions[i];
    worst = std::max(worst, std::abs(p.norm() - R));
    const Vec3 truth = p.normalized();
    if (res.cloud.normals[i].dot(truth) < 0.0) ++inward;
    angle += angle_deg(res.cloud.normals[i], truth);
  }
  angle /= static_cast<double>(res.cloud.size());
  EXPECT_LT(worst, 0.04) << "an outlier survived";
  EXPECT_LE(static_cast<double>(inward), 0.002 * static_cast<double>(res.cloud.size())) << inward << " inward";
  EXPECT_LT(angle, 3.0);
}

TEST(Consolidate, StatisticalOutlierRemovalFindsInjectedOutliers) {
  constexpr double R = 0.5;
  constexpr std::size_t kInliers = 20000, kOutliers = 200;  // 1 %
  auto data = autoscan::testdata::sphere_scan(kInliers, R, 0.002, 2);
  // Outliers uniform in the bounding box enlarged by 50 %. A point that lands within two sampling
  // steps of the surface (step = sqrt(area / n) = 0.0125) is a surface sample to any density statistic,
  // not an outlier: it is drawn again.
  const double step = std::sqrt(4.0 * 3.14159265358979 * R * R / kInliers);
  Rng rng(7);
  PointCloud out;
  while (out.size() < kOutliers) {
    const Vec3 p(rng.uniform(-0.75, 0.75), rng.uniform(-0.75, 0.75), rng.uniform(-0.75, 0.75));
    if (std::abs(p.norm() - R) > 2.0 * step) out.positions.push_back(p);
  }
  out.scalars.set("truth_id", std::vector<double>(kOutliers, -1.0));
  PointCloud cloud = data.cloud;
  cloud.append(out);  // the other columns are filled with 0 for the outliers
  const auto rep = ac::remove_statistical_outliers(cloud, {});
  std::size_t inliers_left = 0, outliers_left = 0;
  for (double id : cloud.scalars.get("truth_id")) (id < 0 ? outliers_left : inliers_left)++;
  EXPECT_EQ(rep.removed, kInliers + kOutliers - cloud.size());
  EXPECT_GE(static_cast<double>(kOutliers - outliers_left), 0.95 * kOutliers) << "outliers left " << outliers_left;
  EXPECT_LT(static_cast<double>(kInliers - inliers_left), 0.01 * kInliers)
      << "inliers removed " << kInliers - inliers_left;
  EXPECT_GT(rep.threshold, rep.median);
}

TEST(Consolidate, CleanScanNormalsMatchTruthWithSensorOrientation) {
  auto data = autoscan::testdata::sphere_scan(20000, 0.5, 0.0, 3);
  ac::ConsolidateOptions opt;
  opt.wlop.noise_hint = 0.0;  // exact data: WLOP automatic → off
  const auto res = ac::consolidate(data.cloud, opt);
  EXPECT_FALSE(res.wlop.applied);
  EXPECT_EQ(res.normals.orientation, ac::Orientation::sensor);
  const auto st = compare_normals(res.cloud, data.truth_normals);
  EXPECT_LT(st.mean_angle, 5.0);
  EXPECT_GT(st.outward, 0.995);
  for (const auto& n : res.cloud.normals) EXPECT_NEAR(n.norm(), 1.0, 1e-9);
}

TEST(Consolidate, CleanScanNormalsWithMstFallbackAreOutward) {
  auto data = autoscan::testdata::sphere_scan(20000, 0.5, 0.0, 4);
  for (const char* c : {"sensor_x", "sensor_y", "sensor_z"}) data.cloud.scalars.erase(c);
  ac::ConsolidateOptions opt;
  opt.wlop.mode = ac::WlopMode::off;
  const auto res = ac::consolidate(data.cloud, opt);
  EXPECT_EQ(res.normals.orientation, ac::Orientation::mst);
  const auto st = compare_normals(res.cloud, data.truth_normals);
  EXPECT_LT(st.mean_angle, 5.0);
  EXPECT_GT(st.outward, 0.995);
}

TEST(Consolidate, SensorOrientationIsExactOnThinPartWhereMstFlips) {
  // Two faces 1.5 % of the size apart, closer than the sampling step: k-NN graphs join the faces.
  const auto data = autoscan::testdata::thin_slab(60, 1.0, 0.015, 5);
  PointCloud with_sensor = data.cloud;
  ac::NormalOptions sensor_opt;
  sensor_opt.orientation = ac::Orientation::sensor;
  const auto rs = ac::estimate_normals(with_sensor, sensor_opt);
  EXPECT_EQ(rs.ambiguous, 0u);
  const auto st_sensor = compare_normals(with_sensor, data.truth_normals);
  EXPECT_EQ(st_sensor.outward, 1.0);
  EXPECT_LT(st_sensor.mean_angle, 5.0);

  PointCloud with_mst = data.cloud;
  ac::NormalOptions mst_opt;
  mst_opt.orientation = ac::Orientation::mst;
  ac::estimate_normals(with_mst, mst_opt);
  const auto st_mst = compare_normals(with_mst, data.truth_normals);
  // Propagation across the faces makes them agree, so one face ends up inward.
  EXPECT_LT(st_mst.outward, 0.75) << "MST orientation unexpectedly right on the thin slab";
}

TEST(Consolidate, AttributesFollowPointsThroughEverySelectingStep) {
  auto data = autoscan::testdata::sphere_scan(5000, 0.5, 0.003, 6);
  data.cloud.colors.resize(data.cloud.size());
  for (std::size_t i = 0; i < data.cloud.size(); ++i)
    data.cloud.colors[i] = {static_cast<std::uint8_t>(i % 251), static_cast<std::uint8_t>(i % 13), 7};
  const PointCloud original = data.cloud;
  auto check_subset = [&](const PointCloud& c) {
    const auto& id = c.scalars.get("truth_id");
    const auto& scan = c.scalars.get("scan_id");
    const auto& sx = c.scalars.get("sensor_x");
    for (std::size_t i = 0; i < c.size(); ++i) {
      const auto j = static_cast<std::size_t>(id[i]);
      ASSERT_EQ(c.positions[i], original.positions[j]);
      ASSERT_EQ(c.colors[i], original.colors[j]);
      ASSERT_EQ(scan[i], original.scalars.get("scan_id")[j]);
      ASSERT_EQ(sx[i], original.scalars.get("sensor_x")[j]);
    }
  };
  PointCloud a = original;
  ac::remove_statistical_outliers(a, {});
  check_subset(a);
  PointCloud b = original;
  ac::ThinningOptions thin;
  thin.voxel_size = 0.05;
  const auto tr = ac::voxel_thin(b, thin);
  EXPECT_GT(tr.removed, 0u);
  check_subset(b);
  // WLOP: every new point carries the attributes of its nearest input point (brute force).
  PointCloud w = original;
  ac::WlopOptions wo;
  wo.iterations = 5;
  const auto wr = ac::apply_wlop(w, wo);
  EXPECT_EQ(wr.points_out, w.size());
  EXPECT_EQ(w.size(), static_cast<std::size_t>(0.2 * static_cast<double>(original.size())));
  for (std::size_t i = 0; i < w.size(); i += 7) {
    std::size_t best = 0;
    double bd = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < original.size(); ++j) {
      const double d = (original.positions[j] - w.positions[i]).squaredNorm();
      if (d < bd) bd = d, best = j;
    }
    ASSERT_EQ(w.scalars.get("truth_id")[i], original.scalars.get("truth_id")[best]);
    ASSERT_EQ(w.scalars.get("sensor_z")[i], original.scalars.get("sensor_z")[best]);
    ASSERT_EQ(w.colors[i], original.colors[best]);
  }
}

TEST(Consolidate, VoxelThinningKeepsOnePointPerVoxelAndBoundsTheCount) {
  auto data = autoscan::testdata::sphere_scan(20000, 0.5, 0.0, 8);
  PointCloud c = data.cloud;
  const auto origin = c.bounds().min;
  ac::ThinningOptions opt;
  opt.voxel_size = 0.04;
  ac::voxel_thin(c, opt);
  // Brute-force oracle: the number of occupied voxels, each kept point in its own voxel.
  auto key = [&](const Vec3& p) {
    return std::array<long long, 3>{static_cast<long long>(std::floor((p.x() - origin.x()) / 0.04)),
                                    static_cast<long long>(std::floor((p.y() - origin.y()) / 0.04)),
                                    static_cast<long long>(std::floor((p.z() - origin.z()) / 0.04))};
  };
  std::set<std::array<long long, 3>> occupied, kept;
  for (const auto& p : data.cloud.positions) occupied.insert(key(p));
  for (const auto& p : c.positions) kept.insert(key(p));
  EXPECT_EQ(kept.size(), c.size());
  EXPECT_EQ(occupied.size(), c.size());

  PointCloud bounded = data.cloud;
  ac::ThinningOptions cap;
  cap.max_points = 3000;
  const auto rep = ac::voxel_thin(bounded, cap);
  EXPECT_LE(bounded.size(), 3000u);
  EXPECT_GT(bounded.size(), 2000u);  // the bisection does not overshoot by much
  EXPECT_GT(rep.voxel_size, 0.0);
}

TEST(Consolidate, DeterministicAndParallelEqualsSequential) {
  auto data = autoscan::testdata::sphere_scan(6000, 0.5, 0.01, 9);
  ac::ConsolidateOptions opt;
  opt.wlop.iterations = 10;
  const auto a = ac::consolidate(data.cloud, opt);
  const auto b = ac::consolidate(data.cloud, opt);
  EXPECT_EQ(a.cloud.positions, b.cloud.positions);
  EXPECT_EQ(a.cloud.normals, b.cloud.normals);
  ac::ConsolidateResult seq;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    auto o = opt;
    o.wlop.parallel = false;
    seq = ac::consolidate(data.cloud, o);
  }
  EXPECT_EQ(a.cloud.positions, seq.cloud.positions);
  EXPECT_EQ(a.cloud.normals, seq.cloud.normals);
  EXPECT_EQ(a.cloud.scalars.get("truth_id"), seq.cloud.scalars.get("truth_id"));
}

TEST(Consolidate, KnnMeanDistancesMatchBruteForce) {
  Rng rng(10);
  std::vector<Vec3> pts;
  for (int i = 0; i < 400; ++i) pts.emplace_back(rng.uniform(), rng.uniform(), rng.uniform());
  pts.push_back(pts[3]);  // a duplicate
  const std::size_t k = 8;
  const auto d = ac::knn_mean_distances(pts, k);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    std::vector<double> all;
    for (std::size_t j = 0; j < pts.size(); ++j)
      if (j != i) all.push_back((pts[i] - pts[j]).norm());
    std::sort(all.begin(), all.end());
    double s = 0.0;
    for (std::size_t j = 0; j < k; ++j) s += all[j];
    EXPECT_NEAR(d[i], s / k, 1e-12) << i;
  }
}

TEST(Consolidate, RadiusFilterRemovesIsolatedPoints) {
  auto data = autoscan::testdata::sphere_scan(5000, 0.5, 0.0, 11);
  PointCloud c = data.cloud;
  c.positions.emplace_back(2.0, 2.0, 2.0);
  c.positions.emplace_back(2.0, 2.0, 2.01);
  for (auto& [name, col] : c.scalars.columns()) col.resize(c.size(), -1.0);
  ac::RadiusFilterOptions opt;
  opt.radius = 0.05;
  opt.min_neighbors = 2;
  EXPECT_EQ(ac::remove_sparse_points(c, opt), 2u);
  EXPECT_EQ(c.size(), data.cloud.size());
}

TEST(Consolidate, BadInputIsAnInputError) {
  ac::ConsolidateOptions opt;
  EXPECT_THROW(ac::consolidate(PointCloud{}, opt), InputError);
  auto data = autoscan::testdata::sphere_scan(200, 0.5, 0.0, 12);
  PointCloud nan = data.cloud;
  nan.positions[17].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ac::consolidate(nan, opt), InputError);
  PointCloud small = data.cloud;
  small.select({0, 1, 2, 3, 4, 5, 6, 7, 8, 9});
  EXPECT_THROW(ac::consolidate(small, opt), InputError);  // k = 16 > 10 points
  PointCloud same;
  same.positions.assign(100, Vec3(0.1, 0.2, 0.3));
  EXPECT_THROW(ac::consolidate(same, opt), InputError);
  // Bad options and missing sensors when they are required.
  auto bad = opt;
  bad.wlop.select_percentage = 0.0;
  EXPECT_THROW(ac::consolidate(data.cloud, bad), InputError);
  bad = opt;
  bad.outliers.std_ratio = -1.0;
  EXPECT_THROW(ac::consolidate(data.cloud, bad), InputError);
  PointCloud no_sensor = data.cloud;
  no_sensor.scalars.erase("sensor_x");
  ac::NormalOptions sensor_only;
  sensor_only.orientation = ac::Orientation::sensor;
  EXPECT_THROW(ac::estimate_normals(no_sensor, sensor_only), InputError);
  // k larger than the cloud in the single steps as well.
  ac::OutlierOptions big_k;
  big_k.k = 500;
  EXPECT_THROW(ac::remove_statistical_outliers(data.cloud, big_k), InputError);
  try {
    ac::consolidate(same, opt);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("identical"), std::string::npos) << e.what();
  }
}

TEST(Consolidate, ProgressIsReportedAndCancellationStops) {
  auto data = autoscan::testdata::sphere_scan(3000, 0.5, 0.01, 13);
  std::set<std::string> stages;
  ac::ConsolidateOptions opt;
  opt.wlop.iterations = 3;
  ac::consolidate(data.cloud, opt, [&](std::string_view stage, double f) {
    EXPECT_GE(f, 0.0);
    EXPECT_LE(f, 1.0);
    stages.insert(std::string(stage));
    return true;
  });
  EXPECT_TRUE(stages.count("outliers"));
  EXPECT_TRUE(stages.count("wlop"));
  EXPECT_TRUE(stages.count("normals"));
  EXPECT_THROW(ac::consolidate(data.cloud, opt, [](std::string_view stage, double) { return stage != "wlop"; }),
               autoscan::Cancelled);
}
