// Properties of the virtual structured-light scanner against oracles: brute-force point-triangle
// distances, analytic spheres, hand-built occlusion scenes and known rigid transforms.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <unordered_map>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/scanner/blind_scan.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "scanner_test_meshes.hpp"

using namespace autoscan;
using namespace autoscan::scanner;
using autoscan::testing::box;
using autoscan::testing::closest_triangle;
using autoscan::testing::icosphere;
using autoscan::testing::merge;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

ScannerSpec small_spec(int w = 160, int h = 120) {
  ScannerSpec s;
  s.width = w;
  s.height = h;
  return s;
}

/// Radius of the sphere whose bounding box has diagonal 1 (the benchmark frame).
const double kR = 0.5 / std::sqrt(3.0);

double angle_deg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) / kDeg;
}

}  // namespace

TEST(VirtualScanner, NoiseFreePointsLieOnTheMesh) {
  // Oracle: brute-force point-triangle distance on a small mesh; also normals and scalars.
  const TriangleMesh mesh = merge(icosphere(2, kR), box(Vec3(-0.2, -0.45, -0.1), Vec3(0.1, -0.3, 0.25)));
  const double diag = mesh.bounds().diagonal();
  const VirtualScanner scanner(mesh, small_spec());
  const Pose poses[] = {Pose::look_at(Vec3(1.2, 0.1, 0.2), Vec3::Zero()),
                        Pose::look_at(Vec3(-0.6, -0.9, 0.5), Vec3(0, -0.2, 0))};
  for (const Pose& pose : poses) {
    const ScanResult r = scanner.scan(pose, 3, 7);
    ASSERT_GT(r.cloud.size(), 500u);
    ASSERT_EQ(r.cloud.normals.size(), r.cloud.size());
    ASSERT_EQ(r.pixels.size(), r.cloud.size());
    EXPECT_EQ(r.diagnostics.points, r.cloud.size());
    EXPECT_EQ(r.diagnostics.rays_cast, 160u * 120u);
    const auto& d = r.diagnostics;
    EXPECT_EQ(d.hits, d.points + d.rejected_range + d.rejected_incidence + d.rejected_projector_fov +
                          d.rejected_projector_incidence + d.rejected_projector_shadow);
    EXPECT_TRUE(r.misalignment.isApprox(Eigen::Isometry3d::Identity()));
    const auto faces_n = mesh.face_normals();
    double worst = 0.0;
    int flat_normals_ok = 0, flat_points = 0;
    for (std::size_t i = 0; i < r.cloud.size(); ++i) {
      const Vec3& p = r.cloud.positions[i];
      const auto [dist, face] = closest_triangle(mesh, p);
      worst = std::max(worst, dist);
      // Normals face the camera.
      EXPECT_GT(r.cloud.normals[i].dot(pose.position - p), 0.0);
      EXPECT_NEAR(r.cloud.normals[i].norm(), 1.0, 1e-9);
      // On the box's flat faces (away from its edges) the range-image normal is the face normal.
      if (face >= 320) {
        ++flat_points;
        if (std::abs(r.cloud.normals[i].dot(faces_n[face])) > 0.999) ++flat_normals_ok;
      }
    }
    EXPECT_LT(worst, 1e-5 * diag);
    if (flat_points > 100) {
      EXPECT_GT(flat_normals_ok, 0.9 * flat_points);
    }
    for (const char* name : {"scan_id", "sensor_x", "sensor_y", "sensor_z"}) ASSERT_TRUE(r.cloud.scalars.has(name));
    EXPECT_EQ(r.cloud.scalars.get("scan_id").front(), 3.0);
    EXPECT_EQ(r.cloud.scalars.get("sensor_y").back(), pose.position.y());
  }
}

TEST(VirtualScanner, SurfaceHiddenFromTheProjectorYieldsNoPoints) {
  // Camera at the origin looking along +X (right = -Y, so the projector sits at (0, -0.3, 0)).
  // A target box at depth 1.1; a wall at x = 0.5 blocks the projector's light but not the camera.
  const TriangleMesh target = box(Vec3(1.1, -0.05, -0.05), Vec3(1.3, 0.05, 0.05));
  const TriangleMesh wall = box(Vec3(0.5, -0.25, -0.2), Vec3(0.52, -0.08, 0.2));
  const Pose pose = Pose::look_at(Vec3::Zero(), Vec3(1, 0, 0));
  ASSERT_TRUE(pose.rotation().col(0).isApprox(-Vec3::UnitY()));
  const ScannerSpec spec = small_spec(200, 150);

  const ScanResult open = VirtualScanner(target, spec).scan(pose, 0);
  ASSERT_GT(open.cloud.size(), 100u);  // control: without the wall the face is captured
  EXPECT_EQ(open.diagnostics.rejected_projector_shadow, 0u);

  const ScanResult shadowed = VirtualScanner(merge(target, wall), spec).scan(pose, 0);
  std::size_t on_target = 0;
  for (const auto& p : shadowed.cloud.positions) on_target += p.x() > 1.0;
  EXPECT_EQ(on_target, 0u);
  EXPECT_GE(shadowed.diagnostics.rejected_projector_shadow, open.cloud.size() * 9 / 10);

  // With the projector on the other side (baseline 0 puts it at the camera), the wall is harmless.
  ScannerSpec coaxial = spec;
  coaxial.baseline = 0.0;
  const ScanResult lit = VirtualScanner(merge(target, wall), coaxial).scan(pose, 0);
  std::size_t lit_target = 0;
  for (const auto& p : lit.cloud.positions) lit_target += p.x() > 1.0;
  EXPECT_GT(lit_target, 100u);
}

TEST(VirtualScanner, IncidenceAndRangeLimitsHold) {
  const TriangleMesh mesh = icosphere(3, kR);
  const auto fn = mesh.face_normals();
  ScannerSpec spec = small_spec();
  spec.max_incidence_deg = 40.0;
  spec.near = 0.95;  // cuts into the sphere's front (at distance 1.2 - 0.29 = 0.91)
  spec.far = 1.05;   // and its silhouette
  const Pose pose = Pose::look_at(Vec3(0, -1.2, 0.1), Vec3::Zero());
  const Mat3 rot = pose.rotation();
  const Vec3 projector = pose.position + spec.baseline * rot.col(0);
  const ScanResult r = VirtualScanner(mesh, spec).scan(pose, 0);
  ASSERT_GT(r.cloud.size(), 200u);
  EXPECT_GT(r.diagnostics.rejected_range, 0u);
  EXPECT_GT(r.diagnostics.rejected_incidence, 0u);
  for (const auto& p : r.cloud.positions) {
    const double depth = rot.col(2).dot(p - pose.position);
    EXPECT_GE(depth, spec.near - 1e-9);
    EXPECT_LE(depth, spec.far + 1e-9);
    const Vec3 n = fn[closest_triangle(mesh, p).second];
    EXPECT_LE(angle_deg(n, pose.position - p), spec.max_incidence_deg + 1e-6);
    EXPECT_LE(angle_deg(n, projector - p), spec.max_incidence_deg + 1e-6);
  }
  // A face tilted 60 degrees away from the camera: nothing under a 50 degree limit, plenty under 70.
  TriangleMesh slab = box(Vec3(-0.3, -0.3, -0.01), Vec3(0.3, 0.3, 0.01));
  const Eigen::AngleAxisd tilt(60 * kDeg, Vec3::UnitY());
  for (auto& v : slab.vertices) v = tilt * v;
  const Pose front = Pose::look_at(Vec3(0, 0, 1.2), Vec3::Zero(), Vec3::UnitY());
  ScannerSpec s50 = small_spec(), s70 = small_spec();
  s50.max_incidence_deg = 50;
  s70.max_incidence_deg = 70;
  s50.baseline = s70.baseline = 0.05;
  const Vec3 top = tilt * Vec3::UnitZ();  // the big face's normal (the thin rim faces the camera at 30°)
  auto on_top = [&](const ScanResult& scan) {
    std::size_t k = 0;
    for (const auto& p : scan.cloud.positions) k += std::abs(top.dot(p) - 0.01) < 1e-9;
    return k;
  };
  EXPECT_EQ(on_top(VirtualScanner(slab, s50).scan(front, 0)), 0u);
  EXPECT_GT(on_top(VirtualScanner(slab, s70).scan(front, 0)), 1000u);
}

TEST(VirtualScanner, SixAxisViewsCoverTheSphere) {
  const TriangleMesh mesh = icosphere(5, kR);
  const VirtualScanner scanner(mesh, small_spec(320, 240));
  const double d = scanner.spec().optimal_distance();
  PointCloud all;
  // The sphere (diagonal 1) just fits the 28 degree horizontal field at d_o but not the narrower
  // vertical one, so the sensor is rolled cyclically (up Z, X, Y for the X, Y, Z views): each band
  // between two axes then lies along some view's wide image axis.
  const Vec3 axes[] = {Vec3::UnitX(), -Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitY(), Vec3::UnitZ(), -Vec3::UnitZ()};
  const Vec3 ups[] = {Vec3::UnitZ(), Vec3::UnitZ(), Vec3::UnitX(), Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitY()};
  for (int k = 0; k < 6; ++k)
    all.append(scanner.scan(Pose::look_at(d * axes[k], Vec3::Zero(), ups[k]), static_cast<std::uint64_t>(k)).cloud);
  // Voxel hash of the scanned points; a sample is covered when a point lies within tau.
  const double tau = 0.01;
  auto key = [&](const Vec3& p) {
    const auto q = (p / tau).array().floor().cast<long long>();
    return (q.x() * 73856093LL) ^ (q.y() * 19349663LL) ^ (q.z() * 83492791LL);
  };
  std::unordered_multimap<long long, std::size_t> grid;
  for (std::size_t i = 0; i < all.size(); ++i) grid.emplace(key(all.positions[i]), i);
  Rng rng(5);
  const int samples = 20000;
  int covered = 0;
  for (int s = 0; s < samples; ++s) {
    const Vec3 q = kR * rng.unit_vector();
    bool hit = false;
    for (int dx = -1; dx <= 1 && !hit; ++dx)
      for (int dy = -1; dy <= 1 && !hit; ++dy)
        for (int dz = -1; dz <= 1 && !hit; ++dz) {
          const auto range = grid.equal_range(key(q + tau * Vec3(dx, dy, dz)));
          for (auto it = range.first; it != range.second && !hit; ++it)
            hit = (all.positions[it->second] - q).norm() < tau;
        }
    covered += hit;
  }
  EXPECT_GT(static_cast<double>(covered) / samples, 0.99);
}

TEST(VirtualScanner, SameSeedGivesBitIdenticalScansWhateverTheThreadCount) {
  const TriangleMesh mesh = icosphere(3, kR);
  ScannerSpec spec = small_spec();
  spec.noise.magnitude = 0.7;
  const VirtualScanner scanner(mesh, spec);
  const Pose pose = Pose::look_at(Vec3(0.3, 1.1, 0.4), Vec3::Zero());
  auto scan_with_threads = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return scanner.scan(pose, 11, 1234);
  };
  const ScanResult a = scan_with_threads(1), b = scan_with_threads(4), c = scanner.scan(pose, 11, 1234);
  ASSERT_GT(a.cloud.size(), 1000u);
  for (const ScanResult* o : {&b, &c}) {
    ASSERT_EQ(a.cloud.size(), o->cloud.size());
    EXPECT_EQ(a.pixels, o->pixels);
    EXPECT_TRUE(a.misalignment.matrix() == o->misalignment.matrix());
    for (std::size_t i = 0; i < a.cloud.size(); ++i) {
      ASSERT_EQ(a.cloud.positions[i], o->cloud.positions[i]);
      ASSERT_EQ(a.cloud.normals[i], o->cloud.normals[i]);
    }
  }
  // Another seed or another scan id gives another noise draw.
  const ScanResult other_seed = scanner.scan(pose, 11, 1235), other_id = scanner.scan(pose, 12, 1234);
  EXPECT_FALSE(other_seed.misalignment.isApprox(a.misalignment, 1e-12));
  EXPECT_FALSE(other_id.misalignment.isApprox(a.misalignment, 1e-12));
}

TEST(VirtualScanner, PacketsAndSingleRaysAgree) {
  const TriangleMesh mesh = merge(icosphere(3, kR), box(Vec3(-0.2, -0.45, -0.1), Vec3(0.1, -0.3, 0.25)));
  VirtualScannerOptions single;
  single.ray_mode = RayMode::single;
  const Pose pose = Pose::look_at(Vec3(-0.6, -0.9, 0.5), Vec3(0, -0.2, 0));
  const ScanResult a = VirtualScanner(mesh, small_spec()).scan(pose, 0);
  const ScanResult b = VirtualScanner(mesh, small_spec(), single).scan(pose, 0);
  ASSERT_GT(a.cloud.size(), 1000u);
  const double diff = std::abs(static_cast<double>(a.cloud.size()) - static_cast<double>(b.cloud.size()));
  EXPECT_LE(diff, 0.001 * static_cast<double>(a.cloud.size()));
  EXPECT_EQ(a.diagnostics.rays_cast, b.diagnostics.rays_cast);
}

namespace {
/// Rigid transform mapping src[i] to dst[i] in the least-squares sense (Kabsch/Umeyama).
Eigen::Isometry3d fit_rigid(const std::vector<Vec3>& src, const std::vector<Vec3>& dst) {
  Eigen::Matrix3Xd a(3, static_cast<Eigen::Index>(src.size())), b(3, static_cast<Eigen::Index>(dst.size()));
  for (std::size_t i = 0; i < src.size(); ++i) {
    a.col(static_cast<Eigen::Index>(i)) = src[i];
    b.col(static_cast<Eigen::Index>(i)) = dst[i];
  }
  Eigen::Isometry3d t;
  t.matrix() = Eigen::umeyama(a, b, false);
  return t;
}

/// Matches two scans pixel by pixel and fits the rigid transform from `from` to `to`.
Eigen::Isometry3d fit_scans(const ScanResult& from, const ScanResult& to, std::size_t* matched = nullptr) {
  std::unordered_map<std::uint32_t, std::size_t> index;
  for (std::size_t i = 0; i < from.pixels.size(); ++i) index.emplace(from.pixels[i], i);
  std::vector<Vec3> src, dst;
  for (std::size_t j = 0; j < to.pixels.size(); ++j) {
    auto it = index.find(to.pixels[j]);
    if (it == index.end()) continue;
    src.push_back(from.cloud.positions[it->second]);
    dst.push_back(to.cloud.positions[j]);
  }
  if (matched) *matched = src.size();
  return fit_rigid(src, dst);
}
}  // namespace

TEST(VirtualScanner, KnownPoseErrorGivesARigidMisalignmentOfThatSize) {
  const TriangleMesh mesh = merge(icosphere(3, kR), box(Vec3(-0.2, -0.45, -0.1), Vec3(0.1, -0.3, 0.25)));
  const VirtualScanner scanner(mesh, small_spec());
  const Pose commanded = Pose::look_at(Vec3(1.0, -0.6, 0.3), Vec3::Zero());
  // The robot really sits 0.5 degrees off about an axis through the sensor, and 4 mm away.
  const Vec3 axis = Vec3(0.3, -0.5, 0.8).normalized();
  const Vec3 shift(0.003, -0.002, 0.0025);
  Eigen::Isometry3d err = Eigen::Isometry3d::Identity();
  err.translate(commanded.position + shift).rotate(Eigen::AngleAxisd(0.5 * kDeg, axis)).translate(-commanded.position);
  const Pose actual = commanded.transformed(err);

  const ScanResult misaligned = scanner.scan_from(commanded, actual, 0);
  const ScanResult truth = scanner.scan_from(actual, actual, 0);  // the same pixels, reported correctly
  std::size_t matched = 0;
  const Eigen::Isometry3d fit = fit_scans(truth, misaligned, &matched);
  ASSERT_GT(matched, 0.99 * static_cast<double>(misaligned.cloud.size()));
  const double fit_angle = Eigen::AngleAxisd(fit.linear()).angle() / kDeg;
  EXPECT_NEAR(fit_angle, 0.5, 1e-6);
  EXPECT_TRUE(fit.isApprox(misaligned.misalignment, 1e-7));
  // The misalignment undoes the pose error: commanded · actual⁻¹ = err⁻¹.
  EXPECT_TRUE(misaligned.misalignment.isApprox(err.inverse(), 1e-9));
  // It moves the sensor by the translation error.
  EXPECT_NEAR((misaligned.misalignment * actual.position - commanded.position).norm(), 0.0, 1e-12);
  EXPECT_NEAR((actual.position - commanded.position).norm(), shift.norm(), 1e-12);
  // The reported sensor position is the commanded one.
  EXPECT_EQ(misaligned.cloud.scalars.get("sensor_x").front(), commanded.position.x());
}

// The systematic hand-eye error (issue 45): the true pose is commanded ∘ H in every scan, H in the
// scanner's frame; the scan is the one scan_from() takes from there, and the JSON form round-trips
// (and stays out of the files of runs without it).
TEST(VirtualScanner, HandEyeErrorIsTheSameScannerFrameMotionInEveryScan) {
  const TriangleMesh mesh = merge(icosphere(3, kR), box(Vec3(-0.2, -0.45, -0.1), Vec3(0.1, -0.3, 0.25)));
  ScannerSpec spec = small_spec();
  spec.noise.hand_eye_translation = Vec3(0.005, -0.002, 0.001);
  spec.noise.hand_eye_rotation_deg = Vec3(0.5, 1.0, -1.2);  // 1.64 degrees
  const VirtualScanner scanner(mesh, spec);
  Eigen::Isometry3d H = Eigen::Isometry3d::Identity();
  const Vec3 rv = spec.noise.hand_eye_rotation_deg * kDeg;
  H.linear() = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
  H.translation() = spec.noise.hand_eye_translation;
  for (const Pose& commanded :
       {Pose::look_at(Vec3(1.0, -0.6, 0.3), Vec3::Zero()), Pose::look_at(Vec3(-0.4, 1.1, -0.2), Vec3::Zero())}) {
    const ScanResult r = scanner.scan(commanded, 3, 7);
    const Eigen::Isometry3d truth = commanded.world_from_camera() * H;
    EXPECT_TRUE(r.actual.world_from_camera().isApprox(truth, 1e-9));
    EXPECT_TRUE(r.misalignment.isApprox(commanded.world_from_camera() * truth.inverse(), 1e-9));
    // The offset is H's in the scanner's frame: the sensor sits |t| away, turned by |rv|.
    EXPECT_NEAR((r.actual.position - commanded.position).norm(), spec.noise.hand_eye_translation.norm(), 1e-12);
    EXPECT_LE(angle_deg(r.actual.direction, commanded.direction), spec.noise.hand_eye_rotation_deg.norm() + 1e-9);
    const ScanResult same = scanner.scan_from(commanded, r.actual, 3, 7);
    ASSERT_EQ(same.cloud.size(), r.cloud.size());
    for (std::size_t i = 0; i < r.cloud.size(); i += 97)
      EXPECT_NEAR((same.cloud.positions[i] - r.cloud.positions[i]).norm(), 0.0, 1e-9);
  }
  const ScannerSpec back = scanner_from_json(to_json(spec), "spec");
  EXPECT_EQ(back.noise.hand_eye_translation, spec.noise.hand_eye_translation);
  EXPECT_EQ(back.noise.hand_eye_rotation_deg, spec.noise.hand_eye_rotation_deg);
  EXPECT_FALSE(to_json(ScannerSpec{})["noise"].contains("hand_eye_translation"));
  nlohmann::json bad = to_json(spec);
  bad["noise"]["hand_eye_rotation_deg"] = {1, 2};
  EXPECT_THROW(scanner_from_json(bad, "spec"), InputError);
}

TEST(VirtualScanner, NoisePoseErrorHasTheSpecifiedSize) {
  const TriangleMesh mesh = icosphere(2, kR);
  ScannerSpec spec = small_spec(32, 24);
  spec.noise.magnitude = 1.0;
  spec.noise.depth_sigma = 0.0;
  spec.noise.outlier_fraction = 0.0;
  spec.noise.pose_rotation_sigma_deg = 0.4;
  spec.noise.pose_translation_sigma = 0.004;
  const VirtualScanner scanner(mesh, spec);
  const Pose pose = Pose::look_at(Vec3(1.2, 0, 0), Vec3::Zero());
  double sum_a2 = 0, sum_t2 = 0;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    const ScanResult r = scanner.scan(pose, static_cast<std::uint64_t>(i), 99);
    const double a = Eigen::AngleAxisd(r.misalignment.linear()).angle() / kDeg;
    sum_a2 += a * a;
    sum_t2 += (r.actual.position - pose.position).squaredNorm();
    // The misalignment is the rigid map from the true pose to the commanded one.
    EXPECT_TRUE((r.misalignment * r.actual.world_from_camera()).isApprox(pose.world_from_camera(), 1e-9));
  }
  EXPECT_NEAR(std::sqrt(sum_a2 / n), 0.4, 0.4 * 0.2);
  EXPECT_NEAR(std::sqrt(sum_t2 / n), 0.004, 0.004 * 0.2);
}

TEST(VirtualScanner, DepthNoiseAndOutliersMatchTheirModel) {
  // Sphere seen head-on; residuals along each ray against the noise-free scan of the same pixels.
  const TriangleMesh mesh = icosphere(3, kR);
  const auto fn = mesh.face_normals();
  const ScannerSpec clean = small_spec();
  const Pose pose = Pose::look_at(Vec3(0, 0, 1.2), Vec3::Zero(), Vec3::UnitY());
  const ScanResult a = VirtualScanner(mesh, clean).scan(pose, 0);
  ASSERT_GT(a.cloud.size(), 1000u);
  auto residuals = [&](const ScanResult& b) {
    EXPECT_EQ(a.pixels, b.pixels);  // depth noise moves points, it does not change which pixels see
    std::vector<double> r;
    for (std::size_t i = 0; i < a.cloud.size(); ++i) {
      const Vec3 ray = (a.cloud.positions[i] - pose.position).normalized();
      r.push_back(ray.dot(b.cloud.positions[i] - a.cloud.positions[i]));
      EXPECT_LT((b.cloud.positions[i] - a.cloud.positions[i] - r.back() * ray).norm(), 1e-12);  // along the ray
    }
    return r;
  };
  // Depth noise only: residual / model std-dev has unit RMS.
  ScannerSpec depth = clean;
  depth.noise.magnitude = 0.5;
  depth.noise.outlier_fraction = 0;
  depth.noise.pose_rotation_sigma_deg = 0;
  depth.noise.pose_translation_sigma = 0;
  const auto rd = residuals(VirtualScanner(mesh, depth).scan(pose, 0));
  double sum2 = 0;
  for (std::size_t i = 0; i < rd.size(); ++i) {
    const Vec3 ray = (a.cloud.positions[i] - pose.position).normalized();
    const double z = pose.rotation().col(2).dot(a.cloud.positions[i] - pose.position);
    const double inc = angle_deg(fn[closest_triangle(mesh, a.cloud.positions[i]).second], -ray) * kDeg;
    const auto& n = depth.noise;
    const double sd = n.magnitude * n.depth_sigma * std::pow(z / depth.near, n.depth_distance_power) *
                      (1 + n.depth_incidence_gain * std::tan(inc));
    sum2 += (rd[i] / sd) * (rd[i] / sd);
  }
  EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(rd.size())), 1.0, 0.05);
  // Outliers only: magnitude × outlier_fraction of the points, displaced within ±outlier_range.
  ScannerSpec outl = depth;
  outl.noise.depth_sigma = 0;
  outl.noise.outlier_fraction = 0.1;  // 5 % at magnitude 0.5
  const ScanResult b = VirtualScanner(mesh, outl).scan(pose, 0);
  const auto ro = residuals(b);
  std::size_t moved = 0;
  for (double r : ro) {
    moved += std::abs(r) > 1e-9;
    EXPECT_LE(std::abs(r), outl.noise.outlier_range + 1e-9);
  }
  EXPECT_EQ(moved, b.diagnostics.outliers);
  EXPECT_NEAR(static_cast<double>(moved) / static_cast<double>(ro.size()), 0.05, 0.01);
}

namespace {
// The InputError message `f` throws, or "no InputError".
template <class F>
std::string message(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return std::string(e.what());
  }
  return std::string("no InputError");
}
}  // namespace

TEST(VirtualScanner, BadInputIsRefusedWithAClearMessage) {
  const TriangleMesh sphere = icosphere(2, kR);
  EXPECT_NE(message([] { VirtualScanner(TriangleMesh{}, ScannerSpec{}); }).find("no triangles"), std::string::npos);
  ScannerSpec inverted;
  inverted.near = 1.6;
  inverted.far = 0.8;
  EXPECT_NE(message([&] { VirtualScanner(sphere, inverted); }).find("near"), std::string::npos);
  TriangleMesh bad_index = sphere;
  bad_index.faces.push_back({0, 1, 100000});
  EXPECT_NE(message([&] { VirtualScanner(bad_index, ScannerSpec{}); }), "no InputError");
  TriangleMesh nan_vertex = sphere;
  nan_vertex.vertices[0].x() = std::nan("");
  EXPECT_NE(message([&] { VirtualScanner(nan_vertex, ScannerSpec{}); }), "no InputError");

  const VirtualScanner scanner(sphere, small_spec());
  Pose inside = Pose::look_at(Vec3(0.05, 0.02, 0.0), Vec3(1, 0, 0));
  EXPECT_NE(message([&] { scanner.scan(inside, 0); }).find("inside the mesh"), std::string::npos);
  EXPECT_TRUE(scanner.inside(Vec3(0.01, -0.02, 0.03)));
  EXPECT_FALSE(scanner.inside(Vec3(0.3, 0.0, 0.0)));
  Pose zero;
  zero.position = Vec3(1.2, 0, 0);
  zero.direction = Vec3::Zero();
  EXPECT_NE(message([&] { scanner.scan(zero, 0); }).find("zero length"), std::string::npos);
  Pose nan_pose = Pose::look_at(Vec3(1.2, 0, 0), Vec3::Zero());
  nan_pose.position.y() = std::nan("");
  EXPECT_NE(message([&] { scanner.scan(nan_pose, 0); }).find("non-finite"), std::string::npos);

  VirtualScannerOptions on_sphere;
  on_sphere.rig.kind = Rig::Kind::view_sphere;
  on_sphere.rig.sphere_radius = 1.2;
  const VirtualScanner sphere_rig(sphere, small_spec(), on_sphere);
  EXPECT_GT(sphere_rig.scan(Pose::look_at(Vec3(0, 1.2, 0), Vec3::Zero()), 0).cloud.size(), 100u);
  EXPECT_NE(message([&] { sphere_rig.scan(Pose::look_at(Vec3(0, 1.0, 0), Vec3::Zero()), 0); }).find("unreachable"),
            std::string::npos);
}

TEST(BlindScan, PosesRingTheObjectAtTheOptimalDistance) {
  AABB object;
  object.extend(Vec3(-0.2, -0.3, -0.1));
  object.extend(Vec3(0.4, 0.1, 0.3));
  const ScannerSpec spec;
  const auto poses = blind_scan_poses(object, spec);
  ASSERT_EQ(poses.size(), 8u);
  int low = 0, high = 0;
  for (const auto& p : poses) {
    const Vec3 to_centre = object.center() - p.position;
    EXPECT_NEAR(to_centre.norm(), spec.optimal_distance(), 1e-12);
    EXPECT_NEAR(angle_deg(p.direction, to_centre), 0.0, 1e-6);
    const double elevation = std::asin(-to_centre.normalized().z()) / kDeg;
    low += std::abs(elevation) < 1e-9;
    high += std::abs(elevation - 30.0) < 1e-9;
  }
  EXPECT_EQ(low, 4);
  EXPECT_EQ(high, 4);
  BlindScanOptions one_ring;
  one_ring.views = 6;
  one_ring.elevations_deg = {15.0};
  one_ring.distance = 2.0;
  const auto ring = blind_scan_poses(object, spec, one_ring);
  ASSERT_EQ(ring.size(), 6u);
  EXPECT_NEAR(angle_deg(ring[0].position - object.center(), ring[1].position - object.center()),
              2 * std::asin(std::cos(15 * kDeg) * std::sin(30 * kDeg)) / kDeg, 1e-6);
  BlindScanOptions bad;
  bad.views = 0;
  EXPECT_THROW(blind_scan_poses(object, spec, bad), InputError);
  bad.views = 4;
  bad.elevations_deg = {95.0};
  EXPECT_THROW(blind_scan_poses(object, spec, bad), InputError);
}

// blind.random_start: the first azimuth drawn from the seed, the same for a seed, in [0, 360).
TEST(BlindScan, RandomStartIsDrawnFromTheSeed) {
  BlindScanOptions o;
  o.views = 1;
  o.elevations_deg = {20.0};
  EXPECT_EQ(o.seeded(7).azimuth_offset_deg, 0.0);  // off: unchanged
  o.random_start = true;
  const auto a = o.seeded(7), b = o.seeded(7), c = o.seeded(8);
  EXPECT_FALSE(a.random_start);
  EXPECT_EQ(a.azimuth_offset_deg, b.azimuth_offset_deg);
  EXPECT_NE(a.azimuth_offset_deg, c.azimuth_offset_deg);
  std::set<int> sides;  // 16 seeds start from several of the four quadrants
  for (std::uint64_t s = 0; s < 16; ++s) {
    const double az = o.seeded(s).azimuth_offset_deg;
    EXPECT_GE(az, 0.0);
    EXPECT_LT(az, 360.0);
    sides.insert(static_cast<int>(az / 90.0));
  }
  EXPECT_GE(sides.size(), 3u);
}

TEST(BlindScan, MergesTheScansWithTheirIds) {
  const VirtualScanner scanner(icosphere(3, kR), small_spec(80, 60));
  const BlindScanResult r = blind_scan(scanner);
  ASSERT_EQ(r.scans.size(), 8u);
  EXPECT_EQ(r.rays_cast, 8u * 80u * 60u);
  std::size_t total = 0;
  for (const auto& s : r.scans) total += s.points;
  EXPECT_EQ(total, r.cloud.size());
  const auto& ids = r.cloud.scalars.get("scan_id");
  EXPECT_EQ(ids.front(), 0.0);
  EXPECT_EQ(ids.back(), 7.0);
  EXPECT_EQ(r.cloud.normals.size(), r.cloud.size());
}

// Issue 21, item 1: a scanner position at 1e19-1e20 (a pose, a blind-scan distance, a far range)
// aborted inside Embree (its rays are single precision). They are refused before any ray is cast;
// a far but bounded pose scans (and sees nothing in range) without a crash.
TEST(VirtualScanner, PosesAndRangesBeyondTheBoundNeverReachEmbree) {
  const TriangleMesh sphere = icosphere(2, kR);
  const VirtualScanner scanner(sphere, small_spec(40, 30));
  Pose far_away;
  far_away.position = Vec3(1e20, 0, 0);
  far_away.direction = Vec3(-1, 0, 0);
  EXPECT_NE(message([&] { scanner.scan(far_away, 0); }).find("position"), std::string::npos);
  far_away.position = Vec3(1e19, 0, 0);
  EXPECT_NE(message([&] { scanner.scan(far_away, 0); }).find("beyond"), std::string::npos);
  far_away.position = Vec3(1e11, 0, 0);  // bounded: traced, nothing within the working range
  EXPECT_EQ(scanner.scan(far_away, 0).cloud.size(), 0u);

  ScannerSpec long_range = small_spec(40, 30);
  long_range.far = 1e20;
  EXPECT_NE(message([&] { VirtualScanner(sphere, long_range); }).find("far"), std::string::npos);

  BlindScanOptions distant;
  distant.distance = 1e20;
  EXPECT_NE(message([&] { (void)blind_scan(scanner, distant); }).find("distance"), std::string::npos);
  // The object's centre plus a bounded distance can still leave the bound: the pose check catches it.
  TriangleMesh shifted = sphere;
  for (auto& v : shifted.vertices) v.x() += 9e11;
  const VirtualScanner shifted_scanner(shifted, small_spec(40, 30));
  distant.distance = 5e11;
  EXPECT_NE(message([&] { (void)blind_scan(shifted_scanner, distant); }).find("beyond"), std::string::npos);
}
