// Global registration on the virtual scanner's scans (docs/benchmarks.md, "Simulation: registration
// alone"): a mesh normalised to the benchmark frame is scanned from V views (the blind rings, then
// views on a sphere at d_o, seeded) with the noise model at magnitude N (depth noise, outliers and the
// robot's pose error), the scans are registered with register_multiway (all free, priors from the
// noise spec as `simulate` sets them) and each scan's true error is measured before and after: the
// mean distance of its points from where they belong (the simulator knows every scan's
// misalignment), absolute and after the one rigid motion that best fits all scans to the truth.
// Also the pairwise ICP alone: per used pair, the RMS displacement of the source's points between
// the pair's ICP result and the true relative placement.
// Usage: sim_registration MESH [--noise N] [--views V] [--seed S] [--gain G] [--depth-noise 0|1]
//        [--normal-k K] [--info-points P] [--rounds R] [--anchor-points A]
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

#include "autoscan/core/log.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/eval/mesh_distance.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/registration/multiway.hpp"
#include "autoscan/scanner/blind_scan.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/shapes/normalize.hpp"

using namespace autoscan;

namespace {

double mean_error(const PointCloud& c, const Eigen::Isometry3d& correction, const Eigen::Isometry3d& misalignment,
                  const Eigen::Isometry3d& gauge = Eigen::Isometry3d::Identity()) {
  const Eigen::Isometry3d truth = misalignment.inverse();
  double s = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < c.size(); k += 7, ++n)
    s += (gauge * (correction * c.positions[k]) - truth * c.positions[k]).norm();
  return n ? s / static_cast<double>(n) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MESH [--noise N] [--views V] [--seed S] [--gain G] [--depth-noise 0|1] ...\n",
                 argv[0]);
    return 2;
  }
  double noise = 0.5, gain = -1.0, info_points = 0.0, trim = 0.0, incidence = 0.0;
  int views = 20, normal_k = 0, rounds = 0, samples = 0, targets = 0;
  bool depth_noise = true, no_outliers = false;
  double noise_gain = -1.0, noise_power = -1.0;
  int anchor_points = -1;
  std::uint64_t seed = 1;
  for (int a = 2; a < argc; ++a) {
    const std::string k = argv[a];
    auto next = [&]() -> std::string { return a + 1 < argc ? argv[++a] : "0"; };
    if (k == "--noise")
      noise = std::stod(next());
    else if (k == "--views")
      views = std::stoi(next());
    else if (k == "--seed")
      seed = std::stoull(next());
    else if (k == "--gain")
      gain = std::stod(next());
    else if (k == "--depth-noise")
      depth_noise = std::stoi(next()) != 0;
    else if (k == "--normal-k")
      normal_k = std::stoi(next());
    else if (k == "--info-points")
      info_points = std::stod(next());
    else if (k == "--incidence")
      incidence = std::stod(next());
    else if (k == "--trim")
      trim = std::stod(next());
    else if (k == "--rounds")
      rounds = std::stoi(next());
    else if (k == "--noise-gain")
      noise_gain = std::stod(next());
    else if (k == "--noise-power")
      noise_power = std::stod(next());
    else if (k == "--samples")
      samples = std::stoi(next());
    else if (k == "--targets")
      targets = std::stoi(next());
    else if (k == "--anchor-points")
      anchor_points = std::stoi(next());
    else if (k == "--no-outliers")
      no_outliers = true;
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  log::set_level(log::Level::warn);
  TriangleMesh mesh = io::read_mesh(argv[1]);
  normalize_to_benchmark_frame(mesh);
  ScannerSpec spec;
  spec.noise.magnitude = noise;
  if (noise_gain >= 0.0) spec.noise.depth_incidence_gain = noise_gain;
  if (noise_power >= 0.0) spec.noise.depth_distance_power = noise_power;
  if (no_outliers) spec.noise.outlier_fraction = 0.0;
  if (!depth_noise) {
    spec.noise.depth_sigma = 0.0;
    spec.noise.outlier_fraction = 0.0;
  }
  const scanner::VirtualScanner scanner(mesh, spec);
  std::vector<Pose> poses = scanner::blind_scan_poses(scanner.bounds(), spec);
  Rng rng(seed);
  const Vec3 centre = scanner.bounds().center();
  while (static_cast<int>(poses.size()) < views) {
    Vec3 d = rng.unit_vector();
    d.z() = std::abs(d.z()) * 0.8;
    poses.push_back(Pose::look_at(centre + spec.optimal_distance() * d.normalized(), centre, Vec3::UnitZ()));
  }
  std::vector<PointCloud> clouds;
  std::vector<Vec3> sensors;
  std::vector<Eigen::Isometry3d> mis;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    try {
      auto r = scanner.scan(poses[i], i, seed);
      if (r.cloud.size() < 1000) continue;
      sensors.push_back(poses[i].position);
      mis.push_back(r.misalignment);
      clouds.push_back(std::move(r.cloud));
    } catch (const std::exception&) {
    }
  }
  if (std::getenv("SIM_BIAS")) {
    // Per scan: mean signed offset (towards the sensor positive) of the raw points and of the points
    // projected onto their k-NN planes, at their true places, from the true surface.
    const eval::MeshDistance md(mesh);
    for (std::size_t i = 0; i < clouds.size(); ++i) {
      std::vector<Vec3> pts;
      const std::size_t stride = std::max<std::size_t>(1, clouds[i].size() / 30000);
      for (std::size_t k = 0; k < clouds[i].size(); k += stride)
        pts.push_back(mis[i].inverse() * clouds[i].positions[k]);
      const Vec3 sensor = mis[i].inverse() * sensors[i];
      registration::SurfaceFitOptions fo;
      fo.k = normal_k > 0 ? normal_k : 20;
      fo.quadric = false;  // the plane fit this diagnostic has always shown
      const std::vector<Vec3> proj = registration::fit_scan_surface(pts, sensor, fo).projected;
      auto offset = [&](const std::vector<Vec3>& q) {
        double s = 0, a = 0;
        for (std::size_t k = 0; k < q.size(); k += 3) {
          const auto cp = md.closest(q[k]);
          const double sg = (q[k] - cp.point).dot((sensor - cp.point).normalized());
          s += sg, a += std::abs(sg);
        }
        return std::pair(s / (q.size() / 3.0), a / (q.size() / 3.0));
      };
      const auto [rs, ra] = offset(pts);
      const auto [ps, pa] = offset(proj);
      std::printf("scan %zu: raw signed %.5f abs %.5f; projected signed %.5f abs %.5f\n", i, rs, ra, ps, pa);
    }
  }
  registration::MultiwayOptions o;
  o.robot_translation_sigma = std::max(1e-6, noise * spec.noise.pose_translation_sigma);
  o.robot_rotation_sigma_deg = std::max(1e-4, noise * spec.noise.pose_rotation_sigma_deg);
  if (gain >= 0) o.incidence_gain = gain;
  if (normal_k > 0) o.normal_k = normal_k;
  if (anchor_points >= 0) o.surface.anchor_points = anchor_points;
  if (info_points > 0) o.information_points = info_points;
  if (rounds > 0) o.rounds = rounds;
  if (samples > 0) o.sample_points = static_cast<std::size_t>(samples);
  if (targets > 0) o.target_points = static_cast<std::size_t>(targets);
  if (trim > 0) o.icp.trim_fraction = trim;
  if (incidence > 0) o.max_incidence_deg = incidence;
  const auto res = registration::register_multiway(clouds, sensors, {}, {}, o);

  // Gauge: the best rigid fit of all registered points onto their true places.
  std::size_t m = 0;
  for (const auto& c : clouds) m += (c.size() + 49) / 50;
  Eigen::Matrix3Xd A(3, static_cast<Eigen::Index>(m)), B(3, static_cast<Eigen::Index>(m));
  Eigen::Index col = 0;
  for (std::size_t i = 0; i < clouds.size(); ++i)
    for (std::size_t k = 0; k < clouds[i].size(); k += 50, ++col) {
      A.col(col) = res.corrections[i] * clouds[i].positions[k];
      B.col(col) = mis[i].inverse() * clouds[i].positions[k];
    }
  const Eigen::Isometry3d G(Eigen::Matrix4d(Eigen::umeyama(A, B, false)));
  double sb = 0, sa = 0, sg = 0;
  std::printf("%4s %8s %10s %10s %10s %6s %s\n", "scan", "points", "before", "after", "after(fit)", "pairs", "flag");
  for (std::size_t i = 0; i < clouds.size(); ++i) {
    const double b = mean_error(clouds[i], Eigen::Isometry3d::Identity(), mis[i]);
    const double a = mean_error(clouds[i], res.corrections[i], mis[i]);
    const double g = mean_error(clouds[i], res.corrections[i], mis[i], G);
    sb += b, sa += a, sg += g;
    std::printf("%4zu %8zu %10.5f %10.5f %10.5f %6d %s\n", i, clouds[i].size(), b, a, g, res.scans[i].pairs_used,
                res.scans[i].flagged ? res.scans[i].flag_reason.c_str() : "");
  }
  const double nn = static_cast<double>(clouds.size());
  // Pairwise: the ICP's relative placement against the truth (the pair's measurement Z_ij is not
  // in the report; re-derived from the final corrections for the used pairs as their residual).
  std::printf("mean error: before %.5f, after %.5f (ratio %.3f), after best fit %.5f; %zu pairs, %.2f s\n", sb / nn,
              sa / nn, sa / sb, sg / nn, res.pairs.size(), res.seconds);
  // Pairwise: the ICP's relative placement against the truth (M_j M_i⁻¹), as the mean displacement
  // of scan i's points, and the part of it along the line of sight of scan i (towards its sensor).
  std::vector<double> perr, pradial;
  for (const auto& p : res.pairs) {
    if (!p.used) continue;
    const auto i = static_cast<std::size_t>(p.i), j = static_cast<std::size_t>(p.j);
    const Eigen::Isometry3d Zt = mis[j] * mis[i].inverse();
    double s = 0.0, r = 0.0;
    std::size_t cnt = 0;
    for (std::size_t k = 0; k < clouds[i].size(); k += 97, ++cnt) {
      const Vec3& q = clouds[i].positions[k];
      const Vec3 d = p.measurement * q - Zt * q;
      s += d.norm();
      r += d.dot((sensors[i] - q).normalized());
    }
    perr.push_back(s / static_cast<double>(cnt));
    pradial.push_back(r / static_cast<double>(cnt));
  }
  if (!perr.empty()) {
    double pm = 0, pr = 0;
    for (std::size_t k = 0; k < perr.size(); ++k) pm += perr[k], pr += pradial[k];
    std::sort(perr.begin(), perr.end());
    std::printf(
        "pair ICP error vs truth: mean %.5f, median %.5f, max %.5f; mean shift towards the source's sensor %.5f\n",
        pm / perr.size(), perr[perr.size() / 2], perr.back(), pr / pradial.size());
  }
  std::vector<double> rms;
  for (const auto& p : res.pairs)
    if (p.used) rms.push_back(p.rms_after);
  std::sort(rms.begin(), rms.end());
  if (!rms.empty())
    std::printf("pair rms after: median %.5f (min %.5f, max %.5f); depth sigma at d_o normal incidence %.5f\n",
                rms[rms.size() / 2], rms.front(), rms.back(),
                noise * spec.noise.depth_sigma * std::pow(spec.optimal_distance() / spec.near, 2.0));
  std::printf("surface fit per scan (k, noise):");
  for (const auto& sr : res.scans) std::printf(" %d/%.5f", sr.neighbors, sr.noise);
  std::printf("\n");
  return 0;
}
