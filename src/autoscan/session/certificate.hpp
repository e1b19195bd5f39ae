#pragma once
// The quality certificate of an iteration's model and the stop rule on what is left to do
// (issue 22, docs/stop-rule.md).
//
// The iso-surface (the Poisson mesh, vertex scalar f of Eq. 3) is split into triangles of low
// confidence (mean f of the corners below a threshold, StopOptions::confidence) and the rest; the
// low triangles sharing a vertex form regions. Each region carries its area, centroid, extent, mean
// f, whether the model has data there (a consolidated point near most of its vertices), the views of
// the round that looked at it (their targets, Eq. 5, nearest to it) and, matched to the previous
// iteration's region at the same place, whether those views improved it. A region the views looked
// at without improving it for StopOptions::stalled_rounds rounds in a row is "unreachable" (no data: the scanner cannot
// see it) or "too_noisy" (data, but more of it does not raise f), as is a region the planner passed over for
// StopOptions::stalled_rounds rounds in a row; the others are "not_scanned" (no data yet) or
// "improving" (data, low f, views still help). The rule stops when the area views can still
// improve (not_scanned + improving) is a small share of the surface.
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/core/types.hpp"
#include "autoscan/session/options.hpp"

namespace autoscan::session {

struct CertificateRegion {
  int id = 0;
  double area = 0.0;             ///< world units²
  double share = 0.0;            ///< of the iso-surface's area
  Vec3 centroid = Vec3::Zero();  ///< area-weighted
  double radius = 0.0;           ///< largest distance of its vertices from the centroid
  double mean_f = 0.0;           ///< area-weighted mean f of its triangles
  bool has_data = false;         ///< most of its vertices lie near a consolidated point
  /// "not_scanned", "improving" (views can still improve it), "unreachable", "too_noisy" (views
  /// looked at it and did not).
  std::string reason;
  /// Why, in words, when the reason alone does not say: "on the support" for the contact region
  /// (most of its vertices within SupportOptions::contact_tolerance above the support: unreachable
  /// from the start, not low quality; docs/supports.md). "" otherwise.
  std::string detail;
  int views_aimed = 0;  ///< views of this iteration's plan whose target lies in it
  /// Rounds in a row whose views looked at it without improving it (a match that no view looked at
  /// keeps its count); settled from StopOptions::stalled_rounds on.
  int stalls = 0;
  /// Rounds in a row whose plan had views, none aimed at it, and it did not improve: the viewing field
  /// finds no view for it (a phantom surface, or one no reachable view sees). From
  /// StopOptions::stalled_rounds on it is settled like a stalled one.
  int ignored = 0;
  int previous = -1;  ///< the matched region of the previous iteration's certificate (-1: new)
  /// The model's expected accuracy there (Certificate::expected_accuracy, with the residual of the
  /// points near its vertices when it has data).
  double expected_accuracy = 0.0;
};

struct Certificate {
  int iteration = 0;
  double threshold = 0.0;          ///< the confidence threshold used (StopOptions::confidence)
  double surface_area = 0.0;       ///< of the iso-surface
  double share_confident = 0.0;    ///< share of the area whose f is at or above the threshold
  double share_scattered = 0.0;    ///< low-confidence area in regions below min_region_share
  double share_improvable = 0.0;   ///< not_scanned + improving regions: what views can still do
  double share_unreachable = 0.0;  ///< unreachable regions
  double share_too_noisy = 0.0;    ///< too_noisy regions
  int regions_improved = 0;        ///< regions of the previous round's plan that improved (or vanished)
  int regions_aimed_before = 0;    ///< regions the previous round's views looked at
  int views_planned = 0;           ///< views of this iteration's plan (count_views_aimed)
  /// Rounds in a row, ending with this one, whose views looked at regions and improved none.
  int stalled_rounds = 0;
  bool done = false;  ///< share_improvable below StopOptions::remaining_share
  /// StopOptions::remaining_share: the improvable share DONE tolerates (regions that small cost more
  /// views than the surface they add; docs/stop-rule.md).
  double tolerated_share = 0.0;
  /// The model's expected accuracy, a distance: sqrt(scanner_accuracy² + fit_residual²), never 0 for
  /// a mesh with faces.
  double expected_accuracy = 0.0;
  double scanner_accuracy = 0.0;  ///< the scanner's σ at the optimal distance, normal incidence (0: noise-free)
  /// The RMS distance of the consolidated points to the mesh (point to the tangent plane of the
  /// nearest vertex; the largest 5 % left out as outliers); without points, the mesh's quantisation
  /// (mean edge / √12, a uniform error over one edge).
  double fit_residual = 0.0;
  std::vector<CertificateRegion> regions;  ///< largest first

  // Not persisted: the low-confidence vertices of the tracked regions and their region index, for
  // count_views_aimed and mask_settled_regions in the iteration that computed the certificate.
  std::vector<Vec3> low_vertices;
  std::vector<int> low_vertex_region;
  double edge_length = 0.0;  ///< mean edge length of the mesh
};

nlohmann::json to_json(const Certificate& c);
/// Throws InputError naming `what` for a malformed certificate.
Certificate certificate_from_json(const nlohmann::json& j, const std::string& what = "certificate");

/// Where the object touches its support: the surface within `tolerance` above `plane`.
struct SupportContact {
  SupportPlane plane;
  double tolerance = 0.0;
};

/// The certificate of a model: `mesh` with the vertex scalar "f" (or, without it, f of the nearest
/// of `iso_points`, scalar "f"), `consolidated` the points it was built from (data presence),
/// `previous` the previous iteration's certificate (with views_aimed filled in), for tracking.
/// With a `contact`, a region lying mostly within it is "unreachable" ("on the support") at once.
///
/// @param[in] iteration     index of the iteration (stored in the certificate)
/// @param[in] mesh          #V vertices, #F triangles (outward); optional vertex scalar "f" (#V)
/// @param[in] iso_points    #I points with scalar "f" (#I), used when `mesh` has no "f"
/// @param[in] consolidated  #C points (data presence; may be empty)
/// @param[in] scanner       its noise model gives expected_accuracy
/// @param[in] options       thresholds and settling rules (StopOptions)
/// @param[in] previous      the previous iteration's certificate, or null
/// @param[in] contact       the support contact (regions lying in it are "unreachable"), or null
/// @return  #R regions (largest first, ids 0..#R-1) with low_vertices / low_vertex_region of equal
///          length (the distinct vertices of all regions); no region for an empty mesh
Certificate compute_certificate(int iteration, const TriangleMesh& mesh, const PointCloud& iso_points,
                                const PointCloud& consolidated, const ScannerSpec& scanner, const StopOptions& options,
                                const Certificate* previous, const SupportContact* contact = nullptr);

/// Per vertex of `mesh`: 1 where a point of `consolidated` lies within the certificate's data radius
/// (two median sample spacings, or two mean mesh edges), 0 where screened Poisson closed the surface
/// without data (the face on the support, holes). The session writes it as mesh.ply's vertex
/// scalar "supported" when the rig has a support (docs/supports.md).
std::vector<double> vertex_data_support(const TriangleMesh& mesh, const PointCloud& consolidated);

/// The certificate for a person: a verdict line ("done" or what is missing) and one line per region
/// (at most `max_regions`, the largest), each with its area share, place, mean f and reason.
std::string describe(const Certificate& c, std::size_t max_regions = 8);

/// Counts, per region of `c`, the view targets (Eq. 5's s_k') that lie in it: the nearest
/// low-confidence vertex of a tracked region is within two mean edge lengths of the target.
///
/// @param[in,out] c        its regions' views_aimed (and views_planned = #T) are set
/// @param[in]     targets  #T view targets
void count_views_aimed(Certificate& c, const std::vector<Vec3>& targets);

/// Iso-points of regions marked unreachable or too noisy get f = 1 in a copy the planner sees, so
/// that they draw no more views (the viewing field weighs each iso-point by 1 − f, Eq. 4). Returns
/// the count changed.
///
/// @param[in]     c           a certificate computed in this iteration (with low_vertices)
/// @param[in,out] iso_points  #I points; scalar "f" (#I) set to 1 where settled
/// @return the number of iso-points changed, at most #I
std::size_t mask_settled_regions(const Certificate& c, PointCloud& iso_points);

}  // namespace autoscan::session
