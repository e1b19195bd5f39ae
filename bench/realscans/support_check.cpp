// Do the real turntable scans of dragon_stand hold support points, and does the session's
// support-plane detection (session/supports.hpp) find them? (issue 17, docs/benchmarks.md
// "Supports"). Reads a scanalyze .conf and its range scans, places each scan with its pose
// (p_world = Rᵀ p + t, the dragon_stand README), turns the turntable axis (+Y) into +Z (the rig
// frame's up), and per scan prints the lowest points and what detect_support_plane finds and would
// remove. The tolerances are the session's defaults scaled from the benchmark frame (diagonal 1)
// to the merged scans' diagonal.
//   support_check DIR
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "autoscan/io/mesh_io.hpp"
#include "autoscan/session/supports.hpp"

using namespace autoscan;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: support_check DIR (a folder with a scanalyze .conf and its scans)\n");
    return 2;
  }
  const fs::path dir = argv[1];
  fs::path conf;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".conf") conf = e.path();
  if (conf.empty()) {
    std::fprintf(stderr, "%s: no .conf file\n", dir.c_str());
    return 2;
  }
  // +Y (the turntable axis) → +Z: a rotation of +90° about X.
  const Mat3 up = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix();
  std::vector<std::pair<std::string, PointCloud>> scans;
  AABB all;
  std::ifstream in(conf);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string kind, name;
    double tx, ty, tz, qx, qy, qz, qw;
    if (!(ls >> kind >> name >> tx >> ty >> tz >> qx >> qy >> qz >> qw) || kind != "bmesh") continue;
    const Mat3 R = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    PointCloud c = io::read_point_cloud(dir / name);
    c.normals.clear();
    c.scalars = {};
    for (auto& p : c.positions) {
      p = up * (R.transpose() * p + Vec3(tx, ty, tz));
      all.extend(p);
    }
    scans.emplace_back(name, std::move(c));
  }
  const double diag = all.diagonal();
  session::SupportOptions o;
  o.detect_plane = true;
  o.plane_tolerance *= diag;
  std::printf("%zu scans, merged box %.4f x %.4f x %.4f m (diagonal %.4f m), lowest z %.5f; plane tolerance %.5f m\n",
              scans.size(), all.extent().x(), all.extent().y(), all.extent().z(), diag, all.min.z(), o.plane_tolerance);
  std::size_t total = 0, removed = 0, found = 0;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const auto& [name, c] = scans[k];
    double lo = 1e300;
    for (const auto& p : c.positions) lo = std::min(lo, p.z());
    std::size_t near_lo = 0;
    for (const auto& p : c.positions) near_lo += p.z() <= lo + o.plane_tolerance;
    Rng rng = Rng(42).stream(k);
    session::RemovalReport rep;
    const auto codes = session::classify_scan(c, session::FixtureGeometry(Rig{}), o, std::nullopt, rng, rep);
    total += c.size();
    removed += rep.support_plane;
    found += rep.plane_detected;
    std::printf("%-26s %6zu points, lowest z %.5f, %5zu within the tolerance of it; ", name.c_str(), c.size(), lo,
                near_lo);
    if (rep.plane)
      std::printf("plane n = (%.3f, %.3f, %.3f) at height %.5f: %zu points removed (%.2f %%)\n", rep.plane->normal.x(),
                  rep.plane->normal.y(), rep.plane->normal.z(), rep.plane->offset / rep.plane->normal.z(),
                  rep.support_plane, 100.0 * double(rep.support_plane) / double(c.size()));
    else
      std::printf("no support plane\n");
  }
  std::printf("planes found in %zu of %zu scans; %zu of %zu points removed\n", found, scans.size(), removed, total);
  return 0;
}
