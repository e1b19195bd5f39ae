#pragma once
// Next-best views (paper §5.1-5.2, Figure 6): the viewing vector field (Eq. 4) over a voxel grid of
// the search space B, field-guided view selection (per-cell maxima, greedy non-adjacent choice), view
// directions (Eq. 5) and the ordering of the views into a scan path for the robot.
//
// Inputs (data contract):
//  * iso-points S = {(s_k, n_k)}: a PointCloud with OUTWARD unit normals and a scalar column "f", the
//    confidence of Eq. 3 in [0, 1] (the confidence stage's output);
//  * the current Poisson mesh (watertight, CCW seen from outside), used for the visibility term w_v
//    (Embree 3 ray casts) and, unless an ImplicitField is given, for the inside/outside test;
//  * optionally the Poisson field (core/implicit.hpp, larger inside) for the inside/outside test;
//  * the scanner (ScannerSpec: d_n = near, d_f = far, d_o = optimal_distance(), field of view);
//  * the robot rig (reachability, travel cost) and the scanner's current pose.
//
// Typical use (the planner keeps the Embree scene of the mesh between calls, docs/conventions.md, "Build once, query
// many"):
//   nbv::NbvPlanner planner(mesh, scanner, rig);
//   nbv::PlanResult r = planner.plan(iso_points, current_pose);
//   nbv::write_views_json("views.json", r);
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "autoscan/core/implicit.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/progress.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/core/schema.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan::nbv {

/// How the viewing vector field is computed. Both give the same g on every voxel to within
/// NbvOptions::tolerance (tests/nbv checks it); `reference` is the literal brute force of Eq. 4.
enum class FieldMethod {
  fast,       ///< cluster/block bounds, iso-points by decreasing weight, rays only for possible maxima
  reference,  ///< every candidate voxel x every iso-point, one visibility ray per pair
};
/// How the views of one round are chosen from the field (§5.2).
enum class Selection {
  paper,  ///< §5.2 as published: per-cell maxima of g by decreasing g, neighbouring cells of a pick removed
  joint,  ///< the per-cell maxima (and region views) as candidates, chosen greedily by what each adds to
          ///< what the earlier picks already measure (facility location over the iso-points' need,
          ///< weighted by the scanner model's quality; docs/planners.md, "Joint selection")
};
inline constexpr schema::EnumName<Selection> kSelectionNames[] = {{Selection::paper, "paper"},
                                                                  {Selection::joint, "joint"}};
constexpr std::span<const schema::EnumName<Selection>> enum_names(Selection) { return kSelectionNames; }

inline constexpr schema::EnumName<FieldMethod> kFieldMethodNames[] = {{FieldMethod::fast, "fast"},
                                                                      {FieldMethod::reference, "reference"}};
constexpr std::span<const schema::EnumName<FieldMethod>> enum_names(FieldMethod) { return kFieldMethodNames; }

struct NbvOptions {
  int grid_resolution = 100;               ///< §5.1: voxels per axis of the search box B (paper: 100^3)
  double sigma_deg = 25.0;                 ///< Eq. 4: sigma, the angular width of the orientation term w_o
  double distance_width_factor = 0.25;     ///< Eq. 4: the width of w_d is this times d_n (paper: d_n/4)
  double upsilon_radius_factor = 0.1;      ///< Eq. 5: Upsilon_k = iso-points within this times d_f of s_k (10 %)
  int cells = 10;                          ///< §5.2: the field is partitioned into cells^3 cells
  double min_score = 0.05;                 ///< §5.2: per-cell maxima with g below this are dropped (paper: "a given
                                           ///< threshold", no value given; g is in [0, 1])
  int max_views = 10;                      ///< §5.2 / Table 1: most views per iteration (paper: usually 5-15)
  double visibility_offset = 2e-3;         ///< w_v: a visibility ray ends this far off the surface along the
                                           ///< outward normal, relative to the iso-points' bounding-box diagonal
  double tolerance = 1e-7;                 ///< fast path: pairs with w*(1-f) <= tolerance may be ignored, so g is
                                           ///< exact to within this (must be < 1e-6)
  FieldMethod method = FieldMethod::fast;  ///< see FieldMethod
  int block_size = 4;                      ///< fast path: voxels per side of a block sharing one cluster list
  int cluster_size = 32;                   ///< fast path: most iso-points per bounding cluster
  bool optimize_path = true;               ///< order views by nearest neighbour, then exact (<= 10 views) or 2-opt
  Selection selection = Selection::joint;  ///< see Selection (the paper's rule: `paper`)
  int candidate_pool = 64;                 ///< joint: the best per-cell maxima (by g) evaluated as candidates
  double min_view_gain = 0.001;            ///< joint: a view must add at least this times #iso-points of need x quality
  bool region_views = true;                ///< joint: search views for low-confidence regions the field misses
  /// joint: the region views are picked before the greedy choice over the rest (each while it still
  /// adds min_view_gain): a hole the field's views miss gets its view in every round until the
  /// certificate settles it, instead of losing to views that raise f a little everywhere.
  bool region_views_first = true;
  /// joint: region views searched per region and round, each for what the earlier ones leave, while
  /// the candidates measure less than half of the region's need (a channel's walls face different ways).
  int region_views_per_region = 3;
  /// joint: iso-points at or above this f are done; below, their need is (done_confidence - f) /
  /// done_confidence (1: the paper's 1 - f, the default) and those below region_confidence form regions.
  /// Measured on the demo (docs/planners.md): 0.5 spent 14 views for 96.7 % of the scannable surface,
  /// 1.0 spent 32 for 98.0 %.
  double done_confidence = 1.0;
  double region_confidence = 0.5;  ///< joint: iso-points with f below this form the low-confidence regions
  int region_min_points = 10;      ///< joint: smaller regions are left to the field
  int region_samples = 64;         ///< joint: region points tested per candidate position
  int region_positions = 4000;     ///< joint: candidate voxels tested per region (evenly thinned)
  /// Eq. 5: the candidate targets s_k' in Upsilon_k scored per view, evenly thinned to at most this
  /// many (the seed s_k always among them); 0 scores every one, as the paper's Eq. 5 does. Each costs
  /// a pass over the iso-points in the view's reach; targets a few spacings apart aim the frustum
  /// alike (docs/planners.md, "Plan time").
  int aim_targets = 96;
  /// The frontier (scenes, issue 18; docs/planners.md "The frontier"): iso-points farther than this
  /// times d_f from every measured point draw no views (f := 1); 0 = off (the paper: every iso-point
  /// counts). Read by the planners (planners/), which hold the measured points; the scene presets
  /// turn it on.
  double frontier_range = 0.0;

  template <class V>
  void visit_fields(V& v) {
    v("grid_resolution", grid_resolution, schema::closed(1, 1024));
    v("sigma_deg", sigma_deg, schema::open(0, 180));
    v("distance_width_factor", distance_width_factor, schema::above(0));
    v("upsilon_radius_factor", upsilon_radius_factor, schema::at_least(0));
    v("cells", cells, schema::at_least(1));
    v("min_score", min_score, schema::at_least(0));
    v("max_views", max_views, schema::at_least(0));
    v("visibility_offset", visibility_offset, schema::at_least(0));
    v("tolerance", tolerance, schema::open(0, 1e-6));
    v("method", method);
    v("block_size", block_size, schema::at_least(1));
    v("cluster_size", cluster_size, schema::at_least(1));
    v("optimize_path", optimize_path);
    v("selection", selection);
    v("candidate_pool", candidate_pool, schema::at_least(1));
    v("min_view_gain", min_view_gain, schema::at_least(0));
    v("region_views", region_views);
    v("region_views_first", region_views_first);
    v("region_views_per_region", region_views_per_region, schema::at_least(1));
    v("done_confidence", done_confidence, schema::open_closed(0, 1));
    v("region_confidence", region_confidence, schema::open_closed(0, 1));
    v("region_min_points", region_min_points, schema::at_least(1));
    v("region_samples", region_samples, schema::at_least(1));
    v("region_positions", region_positions, schema::at_least(1));
    v("aim_targets", aim_targets, schema::at_least(0));
    v("frontier_range", frontier_range, schema::at_least(0));
  }
  /// Throws InputError naming the option for values out of range.
  void validate(const std::string& what = "nbv") const;
};

/// The voxel grid over the search box B: an oriented box (Z vertical, X-Y along the horizontal
/// principal axes) split into dims voxels. Voxel (i, j, k) has linear index i + nx*(j + ny*k).
struct GridGeometry {
  Vec3 origin = Vec3::Zero();        ///< world position of the box corner (lower corner of voxel (0,0,0))
  Mat3 axes = Mat3::Identity();      ///< columns: the box's X, Y, Z axes in world coordinates (Z = +Z world)
  std::array<int, 3> dims{0, 0, 0};  ///< voxels per axis
  Vec3 spacing = Vec3::Zero();       ///< voxel size along each axis

  std::size_t size() const { return std::size_t(dims[0]) * dims[1] * dims[2]; }
  std::size_t index(int i, int j, int k) const {
    return std::size_t(i) + std::size_t(dims[0]) * (j + std::size_t(dims[1]) * k);
  }
  std::array<int, 3> ijk(std::size_t idx) const;
  /// World position of a voxel centre.
  Vec3 center(int i, int j, int k) const;
  Vec3 center(std::size_t idx) const;
  /// Box coordinates (along axes, from origin) of a world point.
  Vec3 to_local(const Vec3& world) const { return axes.transpose() * (world - origin); }
};

/// Why a voxel is or is not a candidate view position (§5.1: empty voxels at least d_n and at most
/// d_f from the surface).
/// A voxel's place in the search space: a candidate viewpoint, or why not (inside the model or the
/// ground, nearer than d_n or farther than d_f from the surface, or a position the rig cannot take:
/// below the support, inside a fixture, outside the arm's reach).
enum class VoxelState : std::uint8_t { candidate = 0, inside = 1, too_close = 2, too_far = 3, unreachable = 4 };

/// The viewing vector field (VVF) of §5.1.
struct ViewingField {
  GridGeometry grid;
  std::vector<double> g;          ///< Eq. 4, per voxel; 0 for non-candidates
  std::vector<Vec3f> direction;   ///< unit vector from the voxel toward the maximising iso-point s_k (the
                                  ///< suggested scan direction, i.e. -d(v, s_k)); zero where g = 0
  std::vector<int> argmax;        ///< index of the maximising iso-point s_k, -1 where g = 0
  std::vector<VoxelState> state;  ///< per voxel
};

struct NbvView {
  Pose pose;                   ///< position v_i, direction toward the target, up = +Z made orthogonal
  double score = 0.0;          ///< g(v_i), Eq. 4
  Vec3 target = Vec3::Zero();  ///< s_k', Eq. 5
  std::size_t voxel = 0;       ///< linear voxel index of v_i
  int cell = 0;                ///< linear cell index (§5.2)
  int seed_point = -1;         ///< s_k, the iso-point maximising Eq. 4 at v_i
  int target_point = -1;       ///< s_k', the iso-point chosen by Eq. 5
  double eta = 0.0;            ///< Eq. 5 terms at the chosen s_k'
  double zeta = 0.0;
  double gain = 0.0;    ///< joint selection: need x quality this view adds to the earlier picks
  bool region = false;  ///< joint selection: found by the region search (not a per-cell maximum)
  int region_id = -1;   ///< the low-confidence region it was searched for (region views only)
};

struct NbvDiagnostics {
  std::size_t iso_points = 0;
  std::size_t active_points = 0;  ///< iso-points with 1 - f > tolerance (the others cannot raise g)
  std::size_t voxels = 0;
  std::size_t candidates = 0;            ///< empty voxels within [d_n, d_f] of the surface
  std::size_t clusters = 0;              ///< fast path: bounding clusters of active iso-points
  std::size_t pair_evaluations = 0;      ///< (voxel, iso-point) weight evaluations
  std::size_t rays_cast = 0;             ///< visibility rays for the field
  std::size_t bound_evaluations = 0;     ///< fast path: (block or voxel, cluster) bounds evaluated
  std::size_t cell_maxima = 0;           ///< §5.2: cells with a candidate of g > 0
  std::size_t above_threshold = 0;       ///< cell maxima with g >= min_score
  std::size_t dropped_unreachable = 0;   ///< views the rig cannot reach (dropped, never moved)
  std::size_t unreachable_voxels = 0;    ///< voxels in range whose position the rig cannot take (no candidates)
  std::size_t dropped_out_of_range = 0;  ///< views with no visible target within [d_n, d_f]
  std::size_t pool = 0;                  ///< joint: candidates evaluated (per-cell maxima + region views)
  std::size_t regions = 0;               ///< joint: low-confidence regions (f < region_confidence)
  std::size_t regions_searched = 0;      ///< joint: regions no field candidate covered, searched directly
  std::size_t region_views = 0;          ///< joint: region-search candidates added to the pool
  std::size_t region_views_chosen = 0;   ///< joint: ... and chosen
  std::size_t rays_select = 0;           ///< joint: visibility rays of coverage and region search
  double need = 0.0;                     ///< joint: sum over iso-points of their need (done_confidence)
  double gain = 0.0;                     ///< joint: need x quality the chosen views measure
  double nn_path_length = 0.0;           ///< path length of the nearest-neighbour order
  double seconds_space = 0.0;            ///< search space and candidates
  double seconds_field = 0.0;            ///< Eq. 4
  double seconds_select = 0.0;           ///< §5.2 selection and Eq. 5 aiming
  double seconds_path = 0.0;
  double seconds_total = 0.0;
  std::vector<std::string> messages;  ///< human-readable notes (e.g. "no low-confidence iso-points")
};

struct PlanResult {
  std::vector<NbvView> views;  ///< in path order
  double path_length = 0.0;    ///< Rig::travel_cost summed from the current pose (if given) through the views
  ViewingField field;
  NbvDiagnostics diagnostics;
};

/// Next-best-view planner. Holds the Embree scene of the current Poisson mesh (built once; call
/// set_mesh() after a new reconstruction). plan() and compute_field() are const and may be called
/// concurrently. Results do not depend on the number of threads.
class NbvPlanner {
 public:
  /// Throws InputError for an empty or invalid mesh, an invalid scanner (near >= far, ...), rig or options.
  NbvPlanner(const TriangleMesh& mesh, ScannerSpec scanner, Rig rig = {}, NbvOptions options = {});
  ~NbvPlanner();
  NbvPlanner(NbvPlanner&&) noexcept;
  NbvPlanner& operator=(NbvPlanner&&) noexcept;

  void set_mesh(const TriangleMesh& mesh);
  /// The rig of the next plans (a support plane found since, poses the robot refused).
  void set_rig(const Rig& rig);
  void set_options(const NbvOptions& options);
  const NbvOptions& options() const;
  const ScannerSpec& scanner() const;
  const Rig& rig() const;

  /// One planning iteration: field (Eq. 4), selection (§5.2), aiming (Eq. 5), path from `from`.
  /// `iso`: iso-points with outward normals and "f" in [0, 1]. `field`: optional inside test (else the
  /// mesh is used). Without low-confidence iso-points the result has no views and says so in
  /// diagnostics.messages. Throws InputError for bad iso-points.
  PlanResult plan(const PointCloud& iso, const std::optional<Pose>& from = std::nullopt,
                  const ImplicitField* field = nullptr, const ProgressCallback& progress = {}) const;

  /// Only the search space and the viewing vector field (Eq. 4), with options().method.
  ViewingField compute_field(const PointCloud& iso, const ImplicitField* field = nullptr,
                             NbvDiagnostics* diagnostics = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One-off form of NbvPlanner::plan.
PlanResult plan_next_best_views(const TriangleMesh& mesh, const PointCloud& iso, const ScannerSpec& scanner,
                                const Rig& rig = {}, const std::optional<Pose>& from = std::nullopt,
                                const NbvOptions& options = {}, const ImplicitField* field = nullptr);

/// The search box B (§5.1): Z vertical, X-Y along the principal axes of the points projected on
/// the horizontal plane, extended by d_f around the points; `resolution` voxels per axis.
/// Throws InputError for no points or resolution < 1.
GridGeometry search_box(const std::vector<Vec3>& points, double far, int resolution);

/// Result of ordering views into a path.
struct PathOrder {
  std::vector<std::size_t> order;  ///< permutation of the views
  double length = 0.0;             ///< Rig::travel_cost summed along the path (from `from` if given)
  double nn_length = 0.0;          ///< the same for the nearest-neighbour order
};

/// Orders `views` into a short open path starting at `from` (or, without it, at views[0]):
/// nearest neighbour by Rig::travel_cost, then improved (exact for <= 10 views, 2-opt and
/// or-opt moves otherwise) when `optimize`; never longer than the nearest-neighbour order.
PathOrder order_path(const std::vector<Pose>& views, const std::optional<Pose>& from, const Rig& rig,
                     bool optimize = true);

/// Eq. 4's weight without visibility: w_d * w_o for a voxel v and an iso-point s with OUTWARD unit
/// normal n_out (the paper's inward n_k = -n_out), scanner distances from `scanner`.
double view_weight(const Vec3& v, const Vec3& s, const Vec3& n_out, const ScannerSpec& scanner,
                   const NbvOptions& options = {});

// ---- writers (all atomic) -------------------------------------------------------------------------
/// {"views":[{"position":..,"direction":..,"up":..,"score":g,"target":[x,y,z]}..],"path_length":L}
nlohmann::json views_to_json(const PlanResult& result);
void write_views_json(const std::filesystem::path& path, const PlanResult& result);
/// Diagnostics as a JSON object (counts, timings, messages).
nlohmann::json diagnostics_to_json(const NbvDiagnostics& d);
/// The whole field g as an NRRD volume: raw little-endian float32, x fastest, with "space
/// directions" (axes * spacing) and "space origin" (centre of voxel (0,0,0)) in the header.
void write_field_nrrd(const std::filesystem::path& path, const ViewingField& field);
/// The magnitude g on the horizontal grid layer through `center` (e.g. the object's centre) as a
/// colour-mapped PNG (the paper's Figure 2(d)/7 bottom row). Voxels inside the solid are dark grey,
/// other non-candidates black; views are marked (white ring, line along their direction projected on the slice).
void write_slice_png(const std::filesystem::path& path, const ViewingField& field, const Vec3& center,
                     const std::vector<NbvView>& views = {}, int min_pixels = 512);

}  // namespace autoscan::nbv
