#pragma once
// Supports and fixtures in the scans (issue 17, docs/supports.md; paper §6: "we utilize prior
// knowledge on the geometry of the robot arm and the supporting table to remove any captured points
// associated with them from the raw scan data").
//
// Before anything else sees a scan (registration, insertion, the planner), the session flags:
//   * fixture points — within a declared fixture's tolerance (Rig::fixtures), or inside it (below a
//     table, inside a turntable disc or a box);
//   * support-plane points — when no support is declared and SupportOptions::detect_plane is on:
//     the dominant near-horizontal plane with (almost) nothing below it, found by RANSAC and refitted
//     by least squares, and everything below it. The first plane found is the session's support
//     (ScanRecord::support_plane keeps it), applied to the later scans as a declared one would be.
// Flagged points stay in the scan file (column "removed", a RemovalReason code) and are kept out of
// the model.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/schema.hpp"

namespace autoscan::session {

/// The scan-file column of the per-point removal reason (RemovalReason; 0 = kept).
inline constexpr const char* kRemovedColumn = "removed";
enum class RemovalReason : std::uint8_t { kept = 0, fixture = 1, support_plane = 2 };

struct SupportOptions {
  /// Remove the points of the rig's declared fixtures (Rig::fixtures, each with its tolerance).
  bool remove_fixtures = true;
  /// When the rig declares no support: detect the dominant near-horizontal plane under the object.
  bool detect_plane = false;
  double plane_tolerance = 0.004;  ///< RANSAC inlier distance (benchmark frame: 0.4 % of the diagonal)
  double max_tilt_deg = 10.0;      ///< the plane's normal within this angle of +Z (the rig frame is Z up)
  /// An inlier's own normal (when the scan has normals) lies within this angle of the plane's: the
  /// rim of an object seen from above is a horizontal band of points, not a plane.
  double normal_tolerance_deg = 30.0;
  int ransac_iterations = 400;
  int ransac_sample = 4000;        ///< points each hypothesis is scored on (a fixed-seed subsample)
  double min_inlier_share = 0.03;  ///< a support has at least this share of a scan's points...
  int min_inliers = 100;           ///< ... and at least this many
  double max_below_share = 0.01;   ///< a support has at most this share of the points below it
  /// The contact region: the model's surface within this distance above the support is where the
  /// object touches it — unreachable, not low quality (certificate reason "unreachable", detail
  /// "on the support"). Just above the removal's tolerance (plane_tolerance, a fixture's 0.004):
  /// the object's side above that band is scanned and kept, so views must still reach it (0.01
  /// settled a 6 mm band of the built-in object's wall as unreachable; docs/supports.md).
  double contact_tolerance = 0.005;

  template <class V>
  void visit_fields(V& v) {
    v("remove_fixtures", remove_fixtures);
    v("detect_plane", detect_plane);
    v("plane_tolerance", plane_tolerance, schema::at_least(0));
    v("max_tilt_deg", max_tilt_deg, schema::closed(0, 90));
    v("normal_tolerance_deg", normal_tolerance_deg, schema::closed(0, 180));
    v("ransac_iterations", ransac_iterations, schema::at_least(1));
    v("ransac_sample", ransac_sample, schema::at_least(3));
    v("min_inlier_share", min_inlier_share, schema::closed(0, 1));
    v("min_inliers", min_inliers, schema::at_least(3));
    v("max_below_share", max_below_share, schema::closed(0, 1));
    v("contact_tolerance", contact_tolerance, schema::at_least(0));
  }
};

/// A plane n·x = offset with a unit normal n pointing up (away from what is below the support).
struct SupportPlane {
  Vec3 normal = Vec3::UnitZ();
  double offset = 0.0;
  double distance(const Vec3& p) const { return normal.dot(p) - offset; }  ///< signed, > 0 above
};

/// The rig's fixtures ready to measure distances (a mesh fixture's file read and indexed).
class FixtureGeometry {
 public:
  /// Throws InputError when a mesh fixture's file cannot be read.
  explicit FixtureGeometry(const Rig& rig);
  ~FixtureGeometry();
  FixtureGeometry(FixtureGeometry&&) noexcept;
  FixtureGeometry& operator=(FixtureGeometry&&) noexcept;
  bool empty() const;
  std::size_t size() const;
  /// Signed distance of p from fixture i (negative inside a primitive; a mesh's is unsigned).
  double distance(std::size_t i, const Vec3& p) const;
  /// The fixture p belongs to (within its tolerance, or inside it), or -1.
  int owner(const Vec3& p) const;
  /// The declared support as a plane (the highest support top), if any.
  std::optional<SupportPlane> support() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The dominant near-horizontal plane of `cloud` with at most max_below_share of its points below
/// it (RANSAC over a subsample, then a least-squares refit on the inliers; an inlier lies within
/// plane_tolerance and, when the cloud has normals, its normal agrees with the plane's); nullopt
/// when none has enough inliers. Deterministic in `rng`.
std::optional<SupportPlane> detect_support_plane(const PointCloud& cloud, const SupportOptions& options, Rng& rng);

/// What removal did to one scan.
struct RemovalReport {
  std::size_t fixture = 0;            ///< points of declared fixtures
  std::size_t support_plane = 0;      ///< points on or below the detected support plane
  std::optional<SupportPlane> plane;  ///< the support plane used (detected now or before)
  bool plane_detected = false;        ///< found in this scan (false: an earlier scan's)
  std::size_t removed() const { return fixture + support_plane; }
};

/// Per point of `scan`, its RemovalReason code: declared fixtures first, then (no declared support,
/// detect_plane on) the support plane: `known` (an earlier scan's) when given, else one detected in
/// this scan from `rng`.
std::vector<std::uint8_t> classify_scan(const PointCloud& scan, const FixtureGeometry& fixtures,
                                        const SupportOptions& options, const std::optional<SupportPlane>& known,
                                        Rng& rng, RemovalReport& report);

/// Copies `cloud` without the points whose code is not kept (every column, colour and normal).
PointCloud kept_points(const PointCloud& cloud, const std::vector<std::uint8_t>& codes);

}  // namespace autoscan::session
