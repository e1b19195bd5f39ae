#include "autoscan/scanner/blind_scan.hpp"

#include <cmath>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/timer.hpp"

namespace autoscan::scanner {

void BlindScanOptions::validate(const std::string& what) const {
  schema::check(*this, what);
  AUTOSCAN_REQUIRE(!elevations_deg.empty(), "{}: at least one elevation is needed", what);
}

BlindScanOptions BlindScanOptions::seeded(std::uint64_t seed) const {
  BlindScanOptions o = *this;
  if (!random_start) return o;
  Rng rng = Rng(seed).stream(0xb11dULL);  // a stream of its own: the scans' noise is not shifted
  o.azimuth_offset_deg += 360.0 * rng.uniform();
  o.random_start = false;
  return o;
}

std::vector<Pose> blind_scan_poses(const AABB& object, const ScannerSpec& spec, const BlindScanOptions& options) {
  options.validate();
  spec.validate("scanner");
  AUTOSCAN_REQUIRE(!object.empty() && object.min.allFinite() && object.max.allFinite(),
                   "blind scan: the object's bounding box is empty or not finite");
  const Vec3 c = object.center();
  const double dist = options.distance > 0 ? options.distance : spec.optimal_distance();
  const int rings = static_cast<int>(options.elevations_deg.size());
  constexpr double deg = std::numbers::pi / 180.0;
  std::vector<Pose> poses;
  poses.reserve(static_cast<std::size_t>(options.views));
  for (int i = 0; i < options.views; ++i) {
    const int k = i % rings;  // ring
    const int j = i / rings;  // index within the ring
    const int in_ring = options.views / rings + (k < options.views % rings ? 1 : 0);
    const double step = 360.0 / in_ring;
    const double az = (options.azimuth_offset_deg + j * step + (k % 2 == 1 ? step / 2 : 0.0)) * deg;
    const double el = options.elevations_deg[static_cast<std::size_t>(k)] * deg;
    const Vec3 dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    poses.push_back(Pose::look_at(c + dist * dir, c, Vec3::UnitZ()));
  }
  return poses;
}

BlindScanResult blind_scan(const VirtualScanner& scanner, const BlindScanOptions& options, std::uint64_t seed,
                           const ProgressCallback& progress) {
  Stopwatch clock;
  Progress bar(progress, "blind scan");
  BlindScanResult res;
  res.poses = blind_scan_poses(scanner.bounds(), scanner.spec(), options.seeded(seed));
  for (std::size_t i = 0; i < res.poses.size(); ++i) {
    ScanResult s = scanner.scan(res.poses[i], options.first_scan_id + i, seed);
    res.rays_cast += s.diagnostics.rays_cast;
    res.shadow_rays += s.diagnostics.shadow_rays;
    res.scans.push_back(s.diagnostics);
    res.misalignments.push_back(s.misalignment);
    res.cloud.append(s.cloud);
    bar.report(static_cast<double>(i + 1) / static_cast<double>(res.poses.size()));
  }
  res.seconds = clock.seconds();
  return res;
}

}  // namespace autoscan::scanner
