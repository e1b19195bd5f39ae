// Consolidation denoising on a real mesh (docs/consolidation.md, docs/benchmarks.md "Consolidation
// denoising (issue 15)"): `n` uniform samples of a mesh normalised to diagonal 1, isotropic Gaussian
// noise of `sigma` per coordinate, `outliers` × n points uniform in the bounding box enlarged by 10 %,
// no sensor positions; consolidate() with the default options. Prints, per seed: the input RMS distance
// to the true surface (inliers only), the output RMS, their ratio, the share of normals pointing
// inward (against the normal of the nearest true face), the mean oriented and unoriented normal angle
// errors, the largest distance to the surface, and the time. A plain program (no Google Benchmark
// loop): one run per seed is the measurement.
//   build/bench/bench_denoise [--mesh FILE] [--seeds 1,2,3] [--n 100000] [--sigma 0.002]
//                             [--outliers 0.01] [--threads T] [--json] [--options JSON]
// --options takes the session options' "consolidate" object (docs/session-format.md), e.g.
// '{"normals":{"k":24}}', applied over the defaults: for trying settings without rebuilding.
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/eval/mesh_distance.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/io/normalize.hpp"
#include "autoscan/session/options.hpp"
#include "autoscan/shapes/sampling.hpp"

namespace ac = autoscan::consolidate;
using autoscan::PointCloud;
using autoscan::Rng;
using autoscan::Vec3;

namespace {

struct Args {
  std::string mesh = std::string(AUTOSCAN_MODELS_DIR) + "/bunny00.off";
  std::vector<std::uint64_t> seeds{1, 2, 3};
  std::size_t n = 100000;
  double sigma = 0.002;
  double outliers = 0.01;   ///< share of n, added on top of the n inliers
  double box_margin = 0.1;  ///< the outliers' box: the bounding box enlarged by this share per side
  int threads = 0;          ///< 0 = TBB's default
  bool json = false;
  std::string options;  ///< JSON of the session options' "consolidate" object, over the defaults
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", k.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (k == "--mesh") {
      a.mesh = next();
    } else if (k == "--seeds") {
      a.seeds.clear();
      std::stringstream ss(next());
      for (std::string t; std::getline(ss, t, ',');) a.seeds.push_back(std::stoull(t));
    } else if (k == "--n") {
      a.n = std::stoull(next());
    } else if (k == "--sigma") {
      a.sigma = std::stod(next());
    } else if (k == "--outliers") {
      a.outliers = std::stod(next());
    } else if (k == "--threads") {
      a.threads = std::stoi(next());
    } else if (k == "--options") {
      a.options = next();
    } else if (k == "--json") {
      a.json = true;
    } else {
      std::fprintf(stderr, "unknown argument %s\n", k.c_str());
      std::exit(2);
    }
  }
  return a;
}

struct Case {
  PointCloud cloud;  ///< noisy inliers then outliers, positions only
  std::size_t inliers = 0;
};

Case make_case(const autoscan::TriangleMesh& mesh, const Args& a, std::uint64_t seed) {
  Rng rng(seed);
  Case c;
  const PointCloud s = autoscan::sample_surface(mesh, a.n, rng);
  c.inliers = s.size();
  c.cloud.positions.reserve(s.size() + static_cast<std::size_t>(a.outliers * static_cast<double>(a.n)) + 1);
  for (const auto& p : s.positions)
    c.cloud.positions.push_back(p + Vec3(rng.normal(0, a.sigma), rng.normal(0, a.sigma), rng.normal(0, a.sigma)));
  autoscan::AABB box = autoscan::AABB::of(s.positions);
  const Vec3 pad = a.box_margin * box.extent();
  box.min -= pad;
  box.max += pad;
  const auto m = static_cast<std::size_t>(std::llround(a.outliers * static_cast<double>(a.n)));
  for (std::size_t i = 0; i < m; ++i)
    c.cloud.positions.emplace_back(rng.uniform(box.min.x(), box.max.x()), rng.uniform(box.min.y(), box.max.y()),
                                   rng.uniform(box.min.z(), box.max.z()));
  return c;
}

double rms(const std::vector<double>& d, std::size_t count) {
  double s = 0.0;
  for (std::size_t i = 0; i < count; ++i) s += d[i] * d[i];
  return count > 0 ? std::sqrt(s / static_cast<double>(count)) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  std::unique_ptr<tbb::global_control> limit;
  if (a.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                  static_cast<std::size_t>(a.threads));
  ac::ConsolidateOptions options;
  if (!a.options.empty()) {
    autoscan::session::SessionOptions base;
    base.consolidate = options;
    options = autoscan::session::session_options_from_json(
                  nlohmann::json{{"consolidate", nlohmann::json::parse(a.options)}}, base)
                  .consolidate;
  }
  autoscan::TriangleMesh mesh = autoscan::io::read_mesh(a.mesh);
  autoscan::io::normalize_to_unit_diagonal(mesh);
  const autoscan::eval::MeshDistance truth(mesh, a.mesh);
  std::vector<Vec3> face_normal(mesh.faces.size());
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    const Vec3 e =
        (mesh.vertices[static_cast<std::size_t>(t[1])] - mesh.vertices[static_cast<std::size_t>(t[0])])
            .cross(mesh.vertices[static_cast<std::size_t>(t[2])] - mesh.vertices[static_cast<std::size_t>(t[0])]);
    face_normal[f] = e.norm() > 0.0 ? Vec3(e.normalized()) : Vec3::Zero();
  }
  if (!a.json)
    std::printf("%-5s %9s %9s %6s %8s %9s %9s %9s %8s %8s %7s\n", "seed", "in_rms", "out_rms", "ratio", "flipped%",
                "angle_deg", "unor_deg", "max_dist", "pts_out", "removed", "time_s");
  for (const auto seed : a.seeds) {
    const Case c = make_case(mesh, a, seed);
    const auto d_in = truth.distances(c.cloud.positions);
    const double in_rms = rms(d_in, c.inliers);
    const autoscan::Stopwatch sw;
    const ac::ConsolidateResult r = ac::consolidate(c.cloud, options);
    const double seconds = sw.seconds();
    const auto& out = r.cloud;
    std::vector<double> d(out.size());
    double angle = 0.0, unoriented = 0.0, max_d = 0.0;
    std::size_t flipped = 0;
    std::vector<autoscan::eval::ClosestPoint> cp(out.size());
    for (std::size_t i = 0; i < out.size(); ++i) cp[i] = truth.closest(out.positions[i]);
    for (std::size_t i = 0; i < out.size(); ++i) {
      d[i] = cp[i].distance;
      max_d = std::max(max_d, d[i]);
      const Vec3& t = face_normal[static_cast<std::size_t>(cp[i].face)];
      const double dot = std::clamp(out.normals[i].dot(t), -1.0, 1.0);
      if (dot < 0.0) ++flipped;
      angle += std::acos(dot);
      unoriented += std::acos(std::abs(dot));
    }
    const double deg = 180.0 / 3.14159265358979323846, count = static_cast<double>(out.size());
    const double out_rms = rms(d, out.size());
    if (a.json)
      std::printf(
          "{\"seed\":%llu,\"input_rms\":%.6g,\"output_rms\":%.6g,\"ratio\":%.4g,\"flipped_percent\":%.4g,"
          "\"mean_angle_deg\":%.4g,\"mean_unoriented_angle_deg\":%.4g,\"max_distance\":%.6g,\"points_out\":%zu,"
          "\"outliers_removed\":%zu,\"seconds\":%.3f}\n",
          static_cast<unsigned long long>(seed), in_rms, out_rms, in_rms / out_rms, 100.0 * flipped / count,
          angle / count * deg, unoriented / count * deg, max_d, out.size(), r.outliers.removed, seconds);
    else
      std::printf("%-5llu %9.6f %9.6f %6.2f %8.3f %9.3f %9.3f %9.5f %8zu %8zu %7.2f\n",
                  static_cast<unsigned long long>(seed), in_rms, out_rms, in_rms / out_rms, 100.0 * flipped / count,
                  angle / count * deg, unoriented / count * deg, max_d, out.size(), r.outliers.removed, seconds);
    for (const auto& t : r.timings) std::fprintf(stderr, "  %s %.2f s\n", t.step.c_str(), t.seconds);
  }
  return 0;
}
