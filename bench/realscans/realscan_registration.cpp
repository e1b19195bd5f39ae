// Real range scans through a session, with and without a robot's pose error (docs/benchmarks.md,
// "Real scans: dragon_stand"). Reads a scanalyze .conf and its range scans (the Stanford
// dragon_stand set: 15 Cyberware scans on a turntable, metres; pose convention p_world = Rᵀ p + t
// with R from the quaternion (qx, qy, qz, qw)), places each scan with its true pose, perturbs it by
// a robot error (a turn of σ_r about the sensor and a shift of σ_t, seeded), feeds the scans to a
// session as a robot would, runs the first iteration (global registration, consolidation, Poisson)
// and measures, after the one rigid motion that best fits the result to the truth:
//   * per scan: median distance of its registered points from their true places;
//   * the Poisson mesh: median distance of the truly aligned scan points to it, and the share
//     farther than 0.5 mm.
// Usage: realscan_registration DIR OUT [--sigma-t M] [--sigma-r DEG] [--seed S] [--no-global] [--cap K]
//        [--depth D] [--sensor-distance M] [--json FILE] [--hand-eye tx,ty,tz,rx,ry,rz] [--hand-eye-priors]
//        [--min-significance F] (MultiwayOptions::min_significance: keep the reported poses below F)
// --hand-eye: a hand-eye error H (metres, rotation vector in degrees, the scanner's frame) shared by
// every scan on top of the random error: the robot reports C_i = P_i H⁻¹ for the true P_i. The
// session's estimate is compared with what the estimator gives from the exact C_i and C_i H (the same
// gauge: on the turntable's one axis the turn about it and the shift along it are not seen,
// registration/hand_eye.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/eval/mesh_distance.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/registration/hand_eye.hpp"
#include "autoscan/registration/icp.hpp"
#include "autoscan/session/session.hpp"
#include "autoscan/spatial/kdtree.hpp"

using namespace autoscan;
namespace fs = std::filesystem;

namespace {

struct Scan {
  std::string name;
  PointCloud truth;                                        // world frame, true pose
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // scan → world (true)
};

std::vector<Scan> load(const fs::path& dir) {
  fs::path conf;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".conf") conf = e.path();
  if (conf.empty()) throw std::runtime_error(dir.string() + ": no .conf file");
  std::ifstream in(conf);
  std::vector<Scan> scans;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string kind, name;
    double tx, ty, tz, qx, qy, qz, qw;
    if (!(ls >> kind >> name >> tx >> ty >> tz >> qx >> qy >> qz >> qw) || kind != "bmesh") continue;
    Scan s;
    s.name = name;
    const Mat3 R = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    s.pose.linear() = R.transpose();  // p_world = Rᵀ p + t (dragon_stand README, verified)
    s.pose.translation() = Vec3(tx, ty, tz);
    PointCloud c = io::read_point_cloud(dir / name);
    c.normals.clear();
    c.scalars = {};
    for (auto& p : c.positions) p = s.pose * p;
    s.truth = std::move(c);
    scans.push_back(std::move(s));
  }
  return scans;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: %s DIR OUT [--sigma-t M] [--sigma-r DEG] [--seed S] [--no-global] [--depth D] "
                 "[--sensor-distance M] [--json FILE]\n",
                 argv[0]);
    return 2;
  }
  const fs::path dir = argv[1], out = argv[2];
  double sigma_t = 0.003, sigma_r = 1.0, sensor_distance = 0.4;
  std::uint64_t seed = 1;
  bool global = true;
  int depth = 0;
  double min_significance = -1.0;  // < 0: the session's default
  double prior_scale = 1.0, info_points = 0.0, robust = -1.0, trim = 0.0, incidence = 0.0, power = -1.0, disagree = 0.0,
         min_overlap = 0.0, boundary = -1.0;
  std::size_t samples = 0;
  int rounds = 0, cap = -1, normal_k = -1, anchor_points = -1;
  std::string json_out;
  bool hand_eye_priors = false;
  Eigen::Isometry3d hand_eye = Eigen::Isometry3d::Identity();
  for (int a = 3; a < argc; ++a) {
    const std::string k = argv[a];
    auto next = [&]() -> std::string { return a + 1 < argc ? argv[++a] : ""; };
    if (k == "--sigma-t")
      sigma_t = std::stod(next());
    else if (k == "--sigma-r")
      sigma_r = std::stod(next());
    else if (k == "--seed")
      seed = std::stoull(next());
    else if (k == "--no-global")
      global = false;
    else if (k == "--depth")
      depth = std::stoi(next());
    else if (k == "--sensor-distance")
      sensor_distance = std::stod(next());
    else if (k == "--json")
      json_out = next();
    else if (k == "--prior-scale")
      prior_scale = std::stod(next());
    else if (k == "--info-points")
      info_points = std::stod(next());
    else if (k == "--robust")
      robust = std::stod(next());
    else if (k == "--trim")
      trim = std::stod(next());
    else if (k == "--rounds")
      rounds = std::stoi(next());
    else if (k == "--incidence")
      incidence = std::stod(next());
    else if (k == "--gain")
      power = std::stod(next());
    else if (k == "--min-significance")
      min_significance = std::stod(next());
    else if (k == "--disagree")
      disagree = std::stod(next());
    else if (k == "--samples")
      samples = std::stoul(next());
    else if (k == "--cap")
      cap = std::stoi(next());
    else if (k == "--min-overlap")
      min_overlap = std::stod(next());
    else if (k == "--k")
      normal_k = std::stoi(next());
    else if (k == "--anchor-points")
      anchor_points = std::stoi(next());
    else if (k == "--hand-eye") {
      double v[6];
      if (std::sscanf(next().c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5]) != 6) {
        std::fprintf(stderr, "--hand-eye: expected tx,ty,tz,rx,ry,rz\n");
        return 2;
      }
      hand_eye = rigid_from_vectors(Vec3(v[0], v[1], v[2]), Vec3(v[3], v[4], v[5]));
    } else if (k == "--hand-eye-priors")
      hand_eye_priors = true;
    else if (k == "--boundary")
      boundary = std::stod(next());
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  log::set_level(log::Level::warn);
  const auto scans = load(dir);
  std::printf("%zu scans\n", scans.size());
  Vec3 centre = Vec3::Zero();
  std::size_t total = 0;
  for (const auto& s : scans)
    for (const auto& p : s.truth.positions) centre += p, ++total;
  centre /= static_cast<double>(total);

  // The robot's error per scan: a turn about the sensor (on the scan's +z axis, sensor_distance from
  // the object's centre) and a shift.
  Rng rng(seed);
  std::vector<Eigen::Isometry3d> error;
  std::vector<Pose> reported;
  std::vector<Eigen::Isometry3d> commanded_exact, reported_exact;  // C_i and C_i H (hand-eye check)
  for (const auto& s : scans) {
    const Vec3 axis = s.pose.linear() * Vec3::UnitZ();
    const Vec3 sensor = centre + sensor_distance * axis;
    Eigen::Isometry3d E = Eigen::Isometry3d::Identity();
    if (sigma_t > 0 || sigma_r > 0) {
      const Eigen::Isometry3d S{Eigen::Translation3d(sensor)};
      Eigen::Isometry3d Rt = Eigen::Isometry3d::Identity();
      const double angle = sigma_r * std::numbers::pi / 180.0 * rng.normal();
      const Vec3 turn_axis = rng.unit_vector();
      Rt.linear() = Eigen::AngleAxisd(angle, turn_axis).toRotationMatrix();
      Vec3 t;
      for (int c = 0; c < 3; ++c) t[c] = sigma_t * rng.normal();  // in sequence: deterministic
      E = Eigen::Translation3d(t) * S * Rt * S.inverse();
    }
    const Pose truth = Pose::look_at(sensor, centre, Vec3::UnitY());
    const Eigen::Isometry3d P = truth.world_from_camera();
    E = E * P * hand_eye.inverse() * P.inverse();  // C_i = E_rand P_i H⁻¹
    error.push_back(E);
    reported.push_back(truth.transformed(E));
    commanded_exact.push_back(reported.back().world_from_camera());
    reported_exact.push_back(commanded_exact.back() * hand_eye);
  }

  fs::remove_all(out);
  ScannerSpec spec;
  spec.near = 0.5 * sensor_distance;
  spec.far = 1.5 * sensor_distance;
  spec.noise.magnitude = 0.0;
  // The scanner's declared depth model (its JSON's noise.depth_incidence_gain): the session weighs
  // the registration's points by it. --gain overrides the default 1.
  if (power >= 0) spec.noise.depth_incidence_gain = power;
  Rig rig;
  session::SessionOptions opt;
  opt.max_iterations = 1;
  opt.hand_eye_priors = hand_eye_priors;
  opt.global_registration = global;
  opt.multiway.robot_translation_sigma = prior_scale * (sigma_t > 0 ? sigma_t : 0.003);
  opt.multiway.robot_rotation_sigma_deg = prior_scale * (sigma_r > 0 ? sigma_r : 1.0);
  if (info_points > 0) opt.multiway.information_points = info_points;
  if (cap >= 0) opt.multiway.max_pairs_per_scan = cap;
  if (robust >= 0) opt.multiway.robust_scale = robust;
  if (trim > 0) opt.multiway.icp.trim_fraction = trim;
  if (rounds > 0) opt.multiway.rounds = rounds;
  if (incidence > 0) opt.multiway.max_incidence_deg = incidence;
  if (disagree > 0) opt.multiway.max_disagreement = disagree;
  if (min_significance >= 0) opt.multiway.min_significance = min_significance;
  if (min_overlap > 0) opt.multiway.min_overlap = min_overlap;
  if (normal_k >= 0) opt.multiway.normal_k = normal_k;
  if (anchor_points >= 0) opt.multiway.surface.anchor_points = anchor_points;
  if (boundary >= 0) opt.multiway.surface.boundary_shift = boundary;
  if (samples > 0) {
    opt.multiway.sample_points = samples;
    opt.multiway.target_points = std::max(samples, opt.multiway.target_points);
  }
  opt.consolidate.wlop.noise_hint = 1.0;  // a real scanner: noisy
  if (depth > 0) opt.poisson.depth = depth;
  auto sess = session::Session::create(out, spec, rig, opt);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    PointCloud c = scans[i].truth;
    for (auto& p : c.positions) p = error[i] * p;
    sess.add_scan(c, reported[i]);
  }
  const auto step = sess.next_views();
  const auto& rec = *step.reconstruction;

  // Per-scan: the registered points against their true places, after the best global rigid fit.
  std::vector<Eigen::Isometry3d> corr;
  for (const auto& r : sess.scans()) corr.push_back(r.correction);
  std::size_t m = 0;
  for (const auto& s : scans) m += (s.truth.size() + 19) / 20;
  Eigen::Matrix3Xd A(3, static_cast<Eigen::Index>(m)), B(3, static_cast<Eigen::Index>(m));
  Eigen::Index col = 0;
  for (std::size_t i = 0; i < scans.size(); ++i)
    for (std::size_t k = 0; k < scans[i].truth.size(); k += 20, ++col) {
      A.col(col) = corr[i] * (error[i] * scans[i].truth.positions[k]);
      B.col(col) = scans[i].truth.positions[k];
    }
  const Eigen::Isometry3d G(Eigen::Matrix4d(Eigen::umeyama(A, B, false)));
  std::vector<double> scan_before, scan_after;
  {
    // "Before": the reported placement, also after its own best global fit.
    for (std::size_t i = 0, c2 = 0; i < scans.size(); ++i)
      for (std::size_t k = 0; k < scans[i].truth.size(); k += 20, ++c2)
        A.col(static_cast<Eigen::Index>(c2)) = error[i] * scans[i].truth.positions[k];
    const Eigen::Isometry3d G0(Eigen::Matrix4d(Eigen::umeyama(A, B, false)));
    for (std::size_t i = 0; i < scans.size(); ++i) {
      std::vector<double> b, a;
      for (const auto& p : scans[i].truth.positions) {
        b.push_back((G0 * (error[i] * p) - p).norm());
        a.push_back((G * (corr[i] * (error[i] * p)) - p).norm());
      }
      scan_before.push_back(median(b));
      scan_after.push_back(median(a));
    }
  }

  // The mesh: rigidly fitted to the true points (ICP of its vertices), then the true points' distances.
  PointCloud truth_all;
  for (const auto& s : scans)
    for (std::size_t k = 0; k < s.truth.size(); k += 4) truth_all.positions.push_back(s.truth.positions[k]);
  PointCloud verts;
  verts.positions = rec.mesh.vertices;
  registration::IcpOptions io;
  io.point_to_plane = false;
  io.max_correspondence_distance = 0.003;
  io.max_source_points = 50000;
  io.max_iterations = 60;
  const auto fit = registration::icp(verts, truth_all, {}, io, G);
  TriangleMesh mesh = rec.mesh;
  for (auto& v : mesh.vertices) v = fit.transform * v;
  const eval::MeshDistance md(mesh, "poisson mesh");
  const auto dist = md.distances(truth_all.positions);
  const double mesh_median = median(dist);
  const double far_share =
      static_cast<double>(std::count_if(dist.begin(), dist.end(), [](double x) { return x > 0.0005; })) /
      static_cast<double>(dist.size());

  if (std::getenv("REALSCAN_DEBUG"))
    for (std::size_t i = 0; i < scans.size(); ++i) {
      const Eigen::Isometry3d Rz = G * corr[i] * error[i];
      const Eigen::AngleAxisd aa(Rz.linear());
      std::printf("residual %zu: %.4f deg about (%.2f %.2f %.2f), t %.3f %.3f %.3f mm\n", i,
                  aa.angle() * 180 / std::numbers::pi, aa.axis().x(), aa.axis().y(), aa.axis().z(),
                  1e3 * Rz.translation().x(), 1e3 * Rz.translation().y(), 1e3 * Rz.translation().z());
    }
  if (std::getenv("REALSCAN_DEBUG")) {
    // A turntable turns the object by the same angle about one fixed axis between scans: how far
    // the reference poses and the registered ones are from that (relative motion of neighbours).
    auto turntable = [&](auto pose_of, const char* name) {
      std::vector<Vec3> axes;
      std::vector<double> angles;
      for (std::size_t i = 0; i < scans.size(); ++i) {
        const std::size_t j = (i + 1) % scans.size();
        const Eigen::Isometry3d rel = pose_of(j) * pose_of(i).inverse();
        const Eigen::AngleAxisd aa(rel.linear());
        Vec3 ax = aa.axis();
        if (ax.y() < 0) ax = -ax;
        axes.push_back(ax);
        angles.push_back(aa.angle() * 180 / std::numbers::pi);
      }
      Vec3 mean_axis = Vec3::Zero();
      for (const auto& a : axes) mean_axis += a;
      mean_axis.normalize();
      double spread = 0, am = 0, ad = 0;
      for (std::size_t k = 0; k < axes.size(); ++k) {
        spread += std::acos(std::min(1.0, axes[k].dot(mean_axis))) * 180 / std::numbers::pi;
        am += angles[k];
      }
      am /= angles.size();
      for (double a : angles) ad += std::abs(a - am);
      std::printf("%s: relative turn %.3f deg (mean |dev| %.4f deg), axis spread %.4f deg\n", name, am,
                  ad / angles.size(), spread / axes.size());
    };
    turntable([&](std::size_t i) { return scans[i].pose; }, "turntable, reference poses");
    turntable([&](std::size_t i) { return Eigen::Isometry3d(G * corr[i] * error[i] * scans[i].pose); },
              "turntable, registered poses");
  }
  if (std::getenv("REALSCAN_DEBUG")) {
    // Self-consistency: median nearest-neighbour distance between ring neighbours (within 5 mm).
    auto consistency = [&](auto place) {
      std::vector<double> med;
      for (std::size_t i = 0; i < scans.size(); ++i) {
        const std::size_t j = (i + 1) % scans.size();
        std::vector<Vec3> pj;
        for (const auto& p : scans[j].truth.positions) pj.push_back(place(j, p));
        const spatial::KdTree nn(pj);
        std::vector<double> d;
        for (std::size_t k = 0; k < scans[i].truth.size(); k += 5) {
          double d2 = 0;
          nn.nearest(place(i, scans[i].truth.positions[k]), &d2);
          if (d2 < 25e-6) d.push_back(std::sqrt(d2));
        }
        med.push_back(median(d));
      }
      return median(med);
    };
    std::printf("ring consistency: conf poses %.4f mm, registered %.4f mm\n",
                1e3 * consistency([&](std::size_t, const Vec3& p) { return p; }),
                1e3 * consistency([&](std::size_t i, const Vec3& p) { return Vec3(corr[i] * (error[i] * p)); }));
  }
  // The hand-eye estimate against the injected offset, in the estimator's gauge.
  nlohmann::json he = sess.iterations().back().hand_eye;
  double he_t_err = -1.0, he_r_err = -1.0;
  if (!he.is_null()) {
    const auto est = registration::hand_eye_from_json(he, "hand_eye");
    const auto ref = registration::estimate_hand_eye(commanded_exact, reported_exact);
    he_t_err = (est.translation - ref.translation).norm();
    he_r_err =
        Eigen::AngleAxisd(est.offset.linear() * ref.offset.linear().transpose()).angle() * 180 / std::numbers::pi;
    std::printf(
        "hand-eye estimate: (%.3f %.3f %.3f) mm ± %.3f, (%.3f %.3f %.3f) deg ± %.3f, ranks %d/%d, %s; injected in "
        "the same gauge (%.3f %.3f %.3f) mm, (%.3f %.3f %.3f) deg: error %.3f mm, %.3f deg\n",
        1e3 * est.translation.x(), 1e3 * est.translation.y(), 1e3 * est.translation.z(), 1e3 * est.translation_se,
        est.rotation_deg.x(), est.rotation_deg.y(), est.rotation_deg.z(), est.rotation_se_deg, est.rotation_rank,
        est.translation_rank, est.significant ? "significant" : "not significant", 1e3 * ref.translation.x(),
        1e3 * ref.translation.y(), 1e3 * ref.translation.z(), ref.rotation_deg.x(), ref.rotation_deg.y(),
        ref.rotation_deg.z(), 1e3 * he_t_err, he_r_err);
  }
  std::printf("%-26s %10s %10s %8s\n", "scan", "before mm", "after mm", "flagged");
  for (std::size_t i = 0; i < scans.size(); ++i)
    std::printf("%-26s %10.3f %10.3f %8s\n", scans[i].name.c_str(), 1e3 * scan_before[i], 1e3 * scan_after[i],
                sess.scans()[i].excluded ? "yes" : "");
  const auto& g = sess.iterations().back().registration;
  std::printf(
      "global registration: %s\n",
      g.is_object()
          ? fmt::format("{} pairs used, {} dropped, {:.2f} s; pairs' chi2 {:.1f} at the start, {:.1f} "
                        "solved (priors {:.1f}), {} scans: F = {}{}",
                        g.value("pairs_used", 0), g.value("pairs_dropped", 0), g.value("seconds", 0.0),
                        g.value("pair_chi2_initial", 0.0), g.value("pair_chi2", 0.0), g.value("prior_chi2", 0.0),
                        g.value("solved_scans", 0), g.value("significance", nlohmann::json(0.0)).dump(),
                        g.value("kept_initial", false) ? ", kept the starting poses" : "")
                .c_str()
          : "off");
  std::printf("median per-scan error after: %.3f mm (max %.3f)\n", 1e3 * median(scan_after),
              1e3 * *std::max_element(scan_after.begin(), scan_after.end()));
  std::printf("mesh: median distance of the true points %.3f mm, %.1f %% beyond 0.5 mm (%zu vertices)\n",
              1e3 * mesh_median, 100.0 * far_share, mesh.vertices.size());
  nlohmann::json j = {{"sigma_t", sigma_t},
                      {"sigma_r_deg", sigma_r},
                      {"seed", seed},
                      {"global", global},
                      {"scan_before_mm", scan_before},
                      {"scan_after_mm", scan_after},
                      {"mesh_median_mm", 1e3 * mesh_median},
                      {"mesh_far_share", far_share},
                      {"registration", g},
                      {"hand_eye", he},
                      {"hand_eye_translation_error_mm", 1e3 * he_t_err},
                      {"hand_eye_rotation_error_deg", he_r_err},
                      {"seconds", sess.iterations().back().seconds}};
  for (auto& v : j["scan_before_mm"]) v = v.get<double>() * 1e3;
  for (auto& v : j["scan_after_mm"]) v = v.get<double>() * 1e3;
  if (!json_out.empty()) write_text_atomic(json_out, j.dump(1));
  return 0;
}
