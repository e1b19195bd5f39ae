// Side-by-side benchmark: our screened Poisson (autoscan::poisson) against Open3D's PoissonRecon on
// the same oriented points, sampled from the benchmark meshes (normalised to diagonal 1).
// Each solver runs in its own child process (fork), so that its peak resident memory (ru_maxrss of
// the child) and its time are measured alone; both meshes are then compared with the true mesh
// (autoscan::eval: Chamfer = (accuracy mean + completeness mean) / 2, F-score at 0.5 % of the
// diagonal). Usage: compare_poisson_open3d [--quick] (quick: 100k points, depth 8, bunny only), or
// compare_poisson_open3d --diagnose [MODEL [POINTS [DEPTH [SCREENING:SPN[:REFINE[:SMOOTHING]] ...]]]] for the
// distance percentiles of both meshes and of our variants (NO_PEER=1 skips Open3D, DUMP=DIR writes
// the meshes).
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "autoscan/core/random.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "autoscan/shapes/normalize.hpp"
#include "autoscan/shapes/sampling.hpp"

using namespace autoscan;

namespace {

struct Run {
  double seconds = 0;
  double peak_mib = 0;
  TriangleMesh mesh;
  bool ok = false;
};

template <class F>
Run in_child(const std::string& tag, F&& body) {
  const auto dir = std::filesystem::temp_directory_path();
  const auto mesh_path = dir / ("autoscan_cmp_" + tag + "_" + std::to_string(::getpid()) + ".ply");
  const auto time_path = dir / ("autoscan_cmp_" + tag + "_" + std::to_string(::getpid()) + ".txt");
  const pid_t pid = ::fork();
  if (pid == 0) {
    try {
      const auto t0 = std::chrono::steady_clock::now();
      TriangleMesh m = body();
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      io::write_mesh(mesh_path, m);
      std::ofstream(time_path) << s;
      std::_Exit(0);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", tag.c_str(), e.what());
      std::_Exit(1);
    }
  }
  int status = 0;
  rusage ru{};
  ::wait4(pid, &status, 0, &ru);
  Run r;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
    std::ifstream(time_path) >> r.seconds;
    r.mesh = io::read_mesh(mesh_path);
    r.peak_mib = static_cast<double>(ru.ru_maxrss) / 1024.0;
    r.ok = true;
  }
  std::filesystem::remove(mesh_path);
  std::filesystem::remove(time_path);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::string(argv[1]) == "--quick";
  if (argc > 1 && std::string(argv[1]) == "--diagnose") {  // where the error is: distance percentiles
    const std::string name = argc > 2 ? argv[2] : "bunny00";
    const std::size_t n = argc > 3 ? std::stoul(argv[3]) : 100000;
    const int depth = argc > 4 ? std::stoi(argv[4]) : 8;
    TriangleMesh truth = io::read_mesh(std::string(AUTOSCAN_MODELS_DIR) + "/" + name + ".off");
    normalize_to_benchmark_frame(truth);
    Rng rng(7);
    PointCloud pc = sample_surface(truth, n, rng);
    pc.scalars.clear();
    auto show = [&](const char* tag, const TriangleMesh& m, double s) {
      const auto e = eval::evaluate_mesh(m, truth);
      std::printf(
          "%-28s %6.2f s V %8zu | acc mean %.7f med %.7f p90 %.7f p99 %.7f max %.5f | comp mean %.7f med %.7f "
          "p90 %.7f p99 %.7f max %.5f | chamfer %.7f\n",
          tag, s, m.vertices.size(), e.accuracy.mean, e.accuracy.median, e.accuracy.p90, e.accuracy.p99, e.accuracy.max,
          e.completeness.mean, e.completeness.median, e.completeness.p90, e.completeness.p99, e.completeness.max,
          0.5 * (e.accuracy.mean + e.completeness.mean));
      std::fflush(stdout);
    };
    if (!std::getenv("NO_PEER")) {
      const auto t0 = std::chrono::steady_clock::now();
      open3d::geometry::PointCloud o3;
      o3.points_ = pc.positions;
      o3.normals_ = pc.normals;
      auto [mesh, dens] = open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(o3, depth, 0, 1.1f, false, -1);
      TriangleMesh m;
      m.vertices = mesh->vertices_;
      for (const auto& t : mesh->triangles_) m.faces.push_back({t[0], t[1], t[2]});
      show("open3d", m, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      if (std::getenv("DUMP")) io::write_mesh(std::string(std::getenv("DUMP")) + "/open3d.ply", m);
    }
    struct Variant {
      const char* tag;
      int iters;
      double screening, spn;
      int refine = 2;
      double smoothing = poisson::PoissonOptions{}.normal_smoothing;
    };
    std::vector<Variant> variants = {Variant{"ours default", 12, 4.0, 1.5}, Variant{"ours iters 60", 60, 4.0, 1.5},
                                     Variant{"ours screening 16", 12, 16.0, 1.5}, Variant{"ours spn 4", 12, 4.0, 4.0}};
    if (argc > 5) {  // variants "screening:spn", e.g. 4:1.5 16:1
      variants.clear();
      for (int a = 5; a < argc; ++a) {
        const std::string spec = argv[a];
        const auto c = spec.find(':');
        Variant v{argv[a], 12, std::stod(spec.substr(0, c)), 0.0};
        const auto c2 = spec.find(':', c + 1);  // optional third field: vertex refinement steps
        v.spn = std::stod(spec.substr(c + 1, c2 - c - 1));
        if (c2 != std::string::npos) {
          const auto c3 = spec.find(':', c2 + 1);  // optional fourth field: normal smoothing
          v.refine = std::stoi(spec.substr(c2 + 1, c3 - c2 - 1));
          if (c3 != std::string::npos) v.smoothing = std::stod(spec.substr(c3 + 1));
        }
        variants.push_back(v);
      }
    }
    for (const Variant& v : variants) {
      poisson::PoissonOptions opt;
      opt.depth = depth;
      opt.fine_iterations = v.iters;
      opt.screening = v.screening;
      opt.samples_per_node = v.spn;
      opt.vertex_refinement = v.refine;
      opt.normal_smoothing = v.smoothing;
      const auto t0 = std::chrono::steady_clock::now();
      const auto res = poisson::reconstruct(pc, opt);
      show(v.tag, res.mesh, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      const auto& d = res.diagnostics;
      std::printf("%-28s stages: octree %.2f s, splat %.2f s, system %.2f s, solve %.2f s, extract %.2f s\n", "",
                  d.seconds_octree, d.seconds_splat, d.seconds_system, d.seconds_solve, d.seconds_extract);
      if (std::getenv("DUMP") && v.iters == 12 && v.screening == 4.0 && v.spn == 1.5)
        io::write_mesh(std::string(std::getenv("DUMP")) + "/ours.ply", res.mesh);
    }
    return 0;
  }
  std::printf(
      "| model | points | depth | ours s | Open3D s | time ratio ours/peer | ours peak MiB | Open3D peak MiB | "
      "ours Chamfer | Open3D Chamfer | Chamfer ratio | ours F@0.5%% | Open3D F@0.5%% | ours V | Open3D V |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const char* name : {"bunny00", "armadillo"}) {
    if (quick && std::string(name) != "bunny00") continue;
    TriangleMesh truth = io::read_mesh(std::string(AUTOSCAN_MODELS_DIR) + "/" + name + ".off");
    normalize_to_benchmark_frame(truth);
    for (std::size_t n : {std::size_t{100000}, std::size_t{500000}}) {
      if (quick && n != 100000) continue;
      Rng rng(7);
      PointCloud pc = sample_surface(truth, n, rng);
      pc.scalars.clear();
      for (int depth : {8, 9}) {
        if (quick && depth != 8) continue;
        Run ours = in_child("ours", [&] {
          poisson::PoissonOptions opt;
          opt.depth = depth;
          return poisson::reconstruct(pc, opt).mesh;
        });
        Run peer = in_child("open3d", [&] {
          open3d::geometry::PointCloud o3;
          o3.points_ = pc.positions;
          o3.normals_ = pc.normals;
          auto [mesh, dens] =
              open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(o3, depth, 0, 1.1f, false, -1);
          TriangleMesh m;
          m.vertices = mesh->vertices_;
          for (const auto& t : mesh->triangles_) m.faces.push_back({t[0], t[1], t[2]});
          return m;
        });
        if (!ours.ok || !peer.ok) {
          std::printf("| %s | %zu | %d | failed (ours %d, peer %d) |\n", name, n, depth, ours.ok, peer.ok);
          continue;
        }
        eval::EvalOptions eo;
        const auto eo_ours = eval::evaluate_mesh(ours.mesh, truth, eo);
        const auto eo_peer = eval::evaluate_mesh(peer.mesh, truth, eo);
        const double ch_ours = 0.5 * (eo_ours.accuracy.mean + eo_ours.completeness.mean);
        const double ch_peer = 0.5 * (eo_peer.accuracy.mean + eo_peer.completeness.mean);
        std::printf(
            "| %s | %zuk | %d | %.2f | %.2f | **%.2f** | %.0f | %.0f | %.5f | %.5f | **%.3f** | %.4f | %.4f | %zu | "
            "%zu |\n",
            name, n / 1000, depth, ours.seconds, peer.seconds, ours.seconds / peer.seconds, ours.peak_mib,
            peer.peak_mib, ch_ours, ch_peer, ch_ours / ch_peer, eo_ours.fscore, eo_peer.fscore,
            ours.mesh.vertices.size(), peer.mesh.vertices.size());
        std::fflush(stdout);
      }
    }
  }
  return 0;
}
