#include "autoscan/session/certificate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <numeric>

#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/union_find.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::session {

using nlohmann::json;

namespace {

bool settled(const CertificateRegion& r) { return r.reason == "unreachable" || r.reason == "too_noisy"; }

double number(const json& j, const char* key, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object() && j.contains(key) && j.at(key).is_number() && std::isfinite(j.at(key).get<double>()),
                   "{}.{}: expected a finite number", what, key);
  return j.at(key).get<double>();
}

int integer(const json& j, const char* key, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object() && j.contains(key) && j.at(key).is_number_integer(), "{}.{}: expected an integer",
                   what, key);
  return j.at(key).get<int>();
}

// Two median sample spacings of `consolidated` (over up to 2000 of its points), or two mesh edges.
double data_radius_of(const spatial::KdTree& tree, const PointCloud& consolidated, double edge_length) {
  std::vector<double> spacing;
  const std::size_t step = std::max<std::size_t>(1, consolidated.size() / 2000);
  std::size_t idx[2];
  double d2[2];
  for (std::size_t i = 0; i < consolidated.size(); i += step)
    if (tree.knn_of_point(i, 1, idx, d2) == 1) spacing.push_back(std::sqrt(d2[0]));
  double s = 0.0;
  if (!spacing.empty()) {
    std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2), spacing.end());
    s = spacing[spacing.size() / 2];
  }
  return 2.0 * std::max(s, edge_length);
}

// True when no view of `p` (outward normal `n`) within the scanner's incidence limit, at the optimal
// distance, lies above the support (where every view must be, Rig::reachable): the direction of the
// incidence cone that rises most decides.
bool hidden_by_support(const Vec3& p, const Vec3& n, const SupportContact& contact, const ScannerSpec& scanner) {
  if (n.squaredNorm() < 1e-24) return false;
  const Vec3 axis = n.normalized();
  const double theta = scanner.max_incidence_deg * std::numbers::pi / 180.0;
  const Vec3 up = contact.plane.normal;
  Vec3 side = up - up.dot(axis) * axis;  // toward "up" within the cone
  if (side.norm() < 1e-9) side = axis.unitOrthogonal();
  side.normalize();
  const double d = scanner.optimal_distance();
  const double to_up = std::acos(std::clamp(axis.dot(up), -1.0, 1.0));
  const Vec3 best = to_up <= theta ? up : Vec3(std::cos(theta) * axis + std::sin(theta) * side);
  return contact.plane.distance(p + d * best) <= 0.0;
}

}  // namespace

std::vector<double> vertex_data_support(const TriangleMesh& mesh, const PointCloud& consolidated) {
  std::vector<double> out(mesh.vertices.size(), 0.0);
  if (consolidated.empty() || mesh.faces.empty()) return out;
  double edges = 0.0;
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
      edges += (mesh.vertices[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])] -
                mesh.vertices[static_cast<std::size_t>(f[static_cast<std::size_t>((k + 1) % 3)])])
                   .norm();
  const spatial::KdTree tree(std::span<const Vec3>(consolidated.positions));
  const double r = data_radius_of(tree, consolidated, edges / (3.0 * static_cast<double>(mesh.faces.size())));
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    double d2 = 0.0;
    tree.nearest(mesh.vertices[v], &d2);
    out[v] = d2 <= r * r ? 1.0 : 0.0;
  }
  return out;
}

json to_json(const Certificate& c) {
  json regions = json::array();
  for (const auto& r : c.regions)
    regions.push_back({{"id", r.id},
                       {"area", r.area},
                       {"share", r.share},
                       {"centroid", {r.centroid.x(), r.centroid.y(), r.centroid.z()}},
                       {"radius", r.radius},
                       {"mean_f", r.mean_f},
                       {"has_data", r.has_data},
                       {"reason", r.reason},
                       {"detail", r.detail},
                       {"views_aimed", r.views_aimed},
                       {"stalls", r.stalls},
                       {"ignored", r.ignored},
                       {"previous", r.previous},
                       {"expected_accuracy", r.expected_accuracy}});
  return {{"iteration", c.iteration},
          {"threshold", c.threshold},
          {"surface_area", c.surface_area},
          {"share_confident", c.share_confident},
          {"share_scattered", c.share_scattered},
          {"share_improvable", c.share_improvable},
          {"share_unreachable", c.share_unreachable},
          {"share_too_noisy", c.share_too_noisy},
          {"regions_improved", c.regions_improved},
          {"regions_aimed_before", c.regions_aimed_before},
          {"stalled_rounds", c.stalled_rounds},
          {"views_planned", c.views_planned},
          {"done", c.done},
          {"expected_accuracy", c.expected_accuracy},
          {"scanner_accuracy", c.scanner_accuracy},
          {"fit_residual", c.fit_residual},
          {"tolerated_share", c.tolerated_share},
          {"regions", regions}};
}

Certificate certificate_from_json(const json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: expected an object", what);
  Certificate c;
  c.iteration = integer(j, "iteration", what);
  c.threshold = number(j, "threshold", what);
  c.surface_area = number(j, "surface_area", what);
  c.share_confident = number(j, "share_confident", what);
  c.share_scattered = number(j, "share_scattered", what);
  c.share_improvable = number(j, "share_improvable", what);
  c.share_unreachable = number(j, "share_unreachable", what);
  c.share_too_noisy = number(j, "share_too_noisy", what);
  c.regions_improved = integer(j, "regions_improved", what);
  c.regions_aimed_before = integer(j, "regions_aimed_before", what);
  c.stalled_rounds = integer(j, "stalled_rounds", what);
  c.views_planned = integer(j, "views_planned", what);
  AUTOSCAN_REQUIRE(j.contains("done") && j.at("done").is_boolean(), "{}.done: expected true or false", what);
  c.done = j.at("done").get<bool>();
  c.expected_accuracy = number(j, "expected_accuracy", what);
  // Since issue 45 (older sessions: the scanner's σ was the whole figure, nothing tolerated stated).
  c.scanner_accuracy = j.contains("scanner_accuracy") ? number(j, "scanner_accuracy", what) : c.expected_accuracy;
  c.fit_residual = j.contains("fit_residual") ? number(j, "fit_residual", what) : 0.0;
  c.tolerated_share = j.contains("tolerated_share") ? number(j, "tolerated_share", what) : 0.0;
  AUTOSCAN_REQUIRE(j.contains("regions") && j.at("regions").is_array(), "{}.regions: expected an array", what);
  for (std::size_t i = 0; i < j.at("regions").size(); ++i) {
    const json& e = j.at("regions")[i];
    const std::string w = what + ".regions[" + std::to_string(i) + "]";
    CertificateRegion r;
    r.id = integer(e, "id", w);
    r.area = number(e, "area", w);
    r.share = number(e, "share", w);
    AUTOSCAN_REQUIRE(e.contains("centroid") && e.at("centroid").is_array() && e.at("centroid").size() == 3 &&
                         std::all_of(e.at("centroid").begin(), e.at("centroid").end(),
                                     [](const json& x) { return x.is_number() && std::isfinite(x.get<double>()); }),
                     "{}.centroid: expected three finite numbers", w);
    r.centroid =
        Vec3(e.at("centroid")[0].get<double>(), e.at("centroid")[1].get<double>(), e.at("centroid")[2].get<double>());
    r.radius = number(e, "radius", w);
    r.mean_f = number(e, "mean_f", w);
    AUTOSCAN_REQUIRE(e.contains("has_data") && e.at("has_data").is_boolean(), "{}.has_data: expected true or false", w);
    r.has_data = e.at("has_data").get<bool>();
    AUTOSCAN_REQUIRE(e.contains("reason") && e.at("reason").is_string(), "{}.reason: expected a string", w);
    r.reason = e.at("reason").get<std::string>();
    if (e.contains("detail")) {  // absent before supports (issue 17)
      AUTOSCAN_REQUIRE(e.at("detail").is_string(), "{}.detail: expected a string", w);
      r.detail = e.at("detail").get<std::string>();
    }
    r.views_aimed = integer(e, "views_aimed", w);
    r.stalls = integer(e, "stalls", w);
    r.ignored = integer(e, "ignored", w);
    r.previous = integer(e, "previous", w);
    r.expected_accuracy = number(e, "expected_accuracy", w);
    c.regions.push_back(std::move(r));
  }
  return c;
}

namespace {

// f per vertex of `mesh` in [0, 1]: the mesh's own column "f", or the nearest iso-point's.
std::vector<double> vertex_confidence(const TriangleMesh& mesh, const PointCloud& iso_points) {
  const std::size_t nv = mesh.vertices.size();
  std::vector<double> f(nv, 0.0);
  if (const auto* mf = mesh.vertex_scalars.find("f"); mf && mf->size() == nv) {
    f = *mf;
  } else if (const auto* isof = iso_points.scalars.find("f"); isof && !iso_points.empty()) {
    const spatial::KdTree tree(std::span<const Vec3>(iso_points.positions));
    std::vector<std::size_t> idx(nv);
    tree.nearest(mesh.vertices, idx, {});
    for (std::size_t i = 0; i < nv; ++i) f[i] = (*isof)[idx[i]];
  }
  for (double& x : f) x = std::isfinite(x) ? std::clamp(x, 0.0, 1.0) : 0.0;
  return f;
}

// The threshold: min(confidence, confidence_ratio · p75 of f).
double confidence_threshold(const std::vector<double>& f, const StopOptions& options) {
  std::vector<double> sorted = f;
  const auto q = static_cast<std::ptrdiff_t>(0.75 * static_cast<double>(sorted.size() - 1));
  std::nth_element(sorted.begin(), sorted.begin() + q, sorted.end());
  const double p75 = sorted[static_cast<std::size_t>(q)];
  return options.confidence_ratio > 0.0 ? std::min(options.confidence, options.confidence_ratio * p75)
                                        : options.confidence;
}

// A connected set of low triangles: its area, area-weighted f and centroid, and its vertices.
struct LowComponent {
  double area = 0, fa = 0;
  Vec3 centroid = Vec3::Zero();
  std::vector<int> vertices;
};

// The triangles whose mean f is below c.threshold, joined through shared vertices into components
// (union-find). Sets c.surface_area, c.edge_length; `low_area` is the area of all low triangles.
//
// With a support, a low triangle whose corners lie mostly on it (`on_support`, per vertex; empty
// without a support) joins only low triangles of its own kind: the face resting on the support and
// the object's side just above it are different regions (the first no view sees, the second the
// planner must still reach), even where they meet at a rim.
std::vector<LowComponent> low_components(const TriangleMesh& mesh, const std::vector<double>& f,
                                         const std::vector<char>& on_support, Certificate& c, double& low_area) {
  const std::size_t nv = mesh.vertices.size(), nf = mesh.faces.size();
  std::vector<double> area(nf), face_f(nf);
  std::vector<char> low(nf, 0);
  // Union-find over (vertex, kind): kind 1 for triangles on the support, ids offset by nv.
  const auto kind_of = [&](const Tri& tri) -> int {
    if (on_support.empty()) return 0;
    int n = 0;
    for (int v : tri) n += on_support[static_cast<std::size_t>(v)] ? 1 : 0;
    return n >= 2 ? 1 : 0;
  };
  UnionFind groups(2 * nv);
  double edge_sum = 0.0;
  for (std::size_t t = 0; t < nf; ++t) {
    const auto& tri = mesh.faces[t];
    const Vec3& a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    const Vec3& b = mesh.vertices[static_cast<std::size_t>(tri[1])];
    const Vec3& d = mesh.vertices[static_cast<std::size_t>(tri[2])];
    area[t] = 0.5 * (b - a).cross(d - a).norm();
    edge_sum += (b - a).norm() + (d - b).norm() + (a - d).norm();
    face_f[t] = (f[static_cast<std::size_t>(tri[0])] + f[static_cast<std::size_t>(tri[1])] +
                 f[static_cast<std::size_t>(tri[2])]) /
                3.0;
    c.surface_area += area[t];
    if (face_f[t] < c.threshold) {
      low[t] = 1;
      const int offset = kind_of(tri) * static_cast<int>(nv);
      for (int k = 1; k < 3; ++k)
        groups.unite(static_cast<std::size_t>(tri[0] + offset),
                     static_cast<std::size_t>(tri[static_cast<std::size_t>(k)] + offset));
    }
  }
  c.edge_length = edge_sum / (3.0 * static_cast<double>(nf));
  std::vector<int> slot(2 * nv, -1);
  std::vector<LowComponent> acc;
  low_area = 0.0;
  if (c.surface_area <= 0.0) return acc;
  for (std::size_t t = 0; t < nf; ++t) {
    if (!low[t]) continue;
    const auto& tri = mesh.faces[t];
    const std::size_t root = groups.find(static_cast<std::size_t>(tri[0] + kind_of(tri) * static_cast<int>(nv)));
    if (slot[root] < 0) {
      slot[root] = static_cast<int>(acc.size());
      acc.emplace_back();
    }
    LowComponent& a = acc[static_cast<std::size_t>(slot[root])];
    const Vec3 centre =
        (mesh.vertices[static_cast<std::size_t>(tri[0])] + mesh.vertices[static_cast<std::size_t>(tri[1])] +
         mesh.vertices[static_cast<std::size_t>(tri[2])]) /
        3.0;
    a.area += area[t];
    a.fa += area[t] * face_f[t];
    a.centroid += area[t] * centre;
    low_area += area[t];
    for (int v : tri) a.vertices.push_back(v);
  }
  return acc;
}

// Data presence: a consolidated point within `radius` (two sample spacings, or two mesh edges) of a
// vertex. No tree when there is no consolidated point.
struct DataPresence {
  std::optional<spatial::KdTree> tree;
  double radius = 0.0;
};

DataPresence data_presence(const PointCloud& consolidated, double edge_length) {
  DataPresence data;
  if (consolidated.empty()) return data;
  data.tree.emplace(std::span<const Vec3>(consolidated.positions));
  data.radius = data_radius_of(*data.tree, consolidated, edge_length);
  return data;
}

// Vertex normals (the mesh's, or area-weighted from its faces) for the support's visibility test.
std::vector<Vec3> vertex_normals_of(const TriangleMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  if (mesh.vertex_normals.size() == nv) return mesh.vertex_normals;
  std::vector<Vec3> normals(nv, Vec3::Zero());
  for (const auto& t : mesh.faces) {
    const Vec3 fn =
        (mesh.vertices[static_cast<std::size_t>(t[1])] - mesh.vertices[static_cast<std::size_t>(t[0])])
            .cross(mesh.vertices[static_cast<std::size_t>(t[2])] - mesh.vertices[static_cast<std::size_t>(t[0])]);
    for (int k = 0; k < 3; ++k) normals[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])] += fn;
  }
  return normals;
}

// Per region: whether most of its vertices lie within the contact's tolerance of the support or
// face it so that no view above the support sees them (docs/supports.md).
// Per vertex: within the contact's tolerance of the support (or below it), or facing it so that no
// view above the support sees it. Empty without a contact.
std::vector<char> vertices_on_support(const TriangleMesh& mesh, const SupportContact* contact,
                                      const ScannerSpec& scanner) {
  if (!contact) return {};
  const std::vector<Vec3> normals = vertex_normals_of(mesh);
  std::vector<char> on(mesh.vertices.size(), 0);
  for (std::size_t v = 0; v < on.size(); ++v) {
    const Vec3& p = mesh.vertices[v];
    on[v] = contact->plane.distance(p) <= contact->tolerance || hidden_by_support(p, normals[v], *contact, scanner);
  }
  return on;
}

// Per region: whether most of its vertices are on the support (vertices_on_support).
std::vector<char> regions_on_support(const std::vector<std::vector<int>>& region_vertices,
                                     const std::vector<char>& vertex_on_support) {
  std::vector<char> on(region_vertices.size(), 0);
  if (vertex_on_support.empty()) return on;
  for (std::size_t r = 0; r < region_vertices.size(); ++r) {
    std::size_t touching = 0;
    for (int v : region_vertices[r]) touching += vertex_on_support[static_cast<std::size_t>(v)] ? 1 : 0;
    on[r] = 2 * touching >= region_vertices[r].size() ? 1 : 0;
  }
  return on;
}

// Point-to-mesh residuals of (at most kSample of) the consolidated points: the distance to the
// tangent plane of the nearest mesh vertex; `vertex_of` gets each sampled point's vertex.
struct FitResiduals {
  std::vector<double> residual;
  std::vector<std::size_t> vertex_of;
};
FitResiduals fit_residuals(const TriangleMesh& mesh, const PointCloud& consolidated) {
  constexpr std::size_t kSample = 20000;
  FitResiduals out;
  if (consolidated.empty() || mesh.vertices.empty()) return out;
  const spatial::KdTree tree(std::span<const Vec3>(mesh.vertices));
  const std::vector<Vec3> normals = vertex_normals_of(mesh);
  const std::size_t stride = std::max<std::size_t>(1, consolidated.size() / kSample);
  for (std::size_t i = 0; i < consolidated.size(); i += stride) {
    const Vec3& p = consolidated.positions[i];
    const std::size_t v = tree.nearest(p);
    const Vec3 n = normals[v].norm() > 0 ? Vec3(normals[v].normalized()) : Vec3::Zero();
    out.residual.push_back(n.isZero() ? (p - mesh.vertices[v]).norm() : std::abs(n.dot(p - mesh.vertices[v])));
    out.vertex_of.push_back(v);
  }
  return out;
}

// RMS of the values at or below their 95th percentile (the rest: outliers, points the surface does
// not pass through); 0 for none.
double trimmed_rms(std::vector<double> r) {
  if (r.empty()) return 0.0;
  std::sort(r.begin(), r.end());
  const std::size_t keep = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(0.95 * double(r.size()))));
  double s = 0.0;
  for (std::size_t i = 0; i < keep; ++i) s += r[i] * r[i];
  return std::sqrt(s / double(keep));
}

// The components large enough to be regions (the others add to c.share_scattered), with their
// extent and data presence; `region_vertices` gets each region's sorted vertex ids.
std::vector<CertificateRegion> measure_regions(std::vector<LowComponent>& acc, const TriangleMesh& mesh,
                                               const DataPresence& data, const StopOptions& options, Certificate& c,
                                               std::vector<std::vector<int>>& region_vertices) {
  std::vector<CertificateRegion> regions;
  for (auto& a : acc) {
    const double share = a.area / c.surface_area;
    if (share < options.min_region_share || a.area <= 0.0) {
      c.share_scattered += share;
      continue;
    }
    std::sort(a.vertices.begin(), a.vertices.end());
    a.vertices.erase(std::unique(a.vertices.begin(), a.vertices.end()), a.vertices.end());
    CertificateRegion r;
    r.area = a.area;
    r.share = share;
    r.centroid = a.centroid / a.area;
    r.mean_f = a.fa / a.area;
    std::size_t near_data = 0;
    for (int v : a.vertices) {
      const Vec3& p = mesh.vertices[static_cast<std::size_t>(v)];
      r.radius = std::max(r.radius, (p - r.centroid).norm());
      if (data.tree) {
        double d2 = 0.0;
        data.tree->nearest(p, &d2);
        if (d2 <= data.radius * data.radius) ++near_data;
      }
    }
    r.has_data = 2 * near_data >= a.vertices.size();
    r.expected_accuracy = c.expected_accuracy;
    regions.push_back(std::move(r));
    region_vertices.push_back(std::move(a.vertices));
  }
  return regions;
}

// Tracking: each region is matched to the previous iteration's region nearest to it whose extent
// overlaps it; its stalls, ignored rounds and reason follow. Sets c.regions_aimed_before,
// c.regions_improved and c.stalled_rounds.
void track_regions(std::vector<CertificateRegion>& regions, const std::vector<char>& on_support,
                   const Certificate* previous, const StopOptions& options, Certificate& c) {
  std::vector<char> prev_not_improved(previous ? previous->regions.size() : 0, 0);
  for (std::size_t ri = 0; ri < regions.size(); ++ri) {
    auto& r = regions[ri];
    if (previous) {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < previous->regions.size(); ++i) {
        const auto& p = previous->regions[i];
        const double d = (p.centroid - r.centroid).norm();
        if (d <= std::max(p.radius, r.radius) + 2.0 * c.edge_length && d < best) {
          best = d;
          r.previous = static_cast<int>(i);
        }
      }
    }
    if (r.previous >= 0) {
      const auto& p = previous->regions[static_cast<std::size_t>(r.previous)];
      const bool improved =
          r.mean_f >= p.mean_f + options.region_gain || r.area <= (1.0 - options.region_shrink) * p.area;
      if (p.views_aimed > 0) {
        r.stalls = improved ? 0 : p.stalls + 1;
        if (!improved) prev_not_improved[static_cast<std::size_t>(r.previous)] = 1;
      } else {
        r.stalls = p.stalls;
        r.ignored = improved ? 0 : p.ignored + (previous->views_planned > 0 ? 1 : 0);
      }
      r.previous = p.id;
    }
    const bool settled_now = r.stalls >= options.stalled_rounds || r.ignored >= options.stalled_rounds;
    r.reason = settled_now ? (r.has_data ? "too_noisy" : "unreachable") : (r.has_data ? "improving" : "not_scanned");
    if (on_support[ri]) {  // where the object touches its support: no pose sees it
      r.reason = "unreachable";
      r.detail = "on the support";
    }
  }
  if (previous) {
    for (std::size_t i = 0; i < previous->regions.size(); ++i)
      if (previous->regions[i].views_aimed > 0) {
        ++c.regions_aimed_before;
        if (!prev_not_improved[i]) ++c.regions_improved;
      }
  }
  const bool stalled_round = c.regions_aimed_before > 0 && c.regions_improved == 0;
  c.stalled_rounds = stalled_round ? (previous ? previous->stalled_rounds : 0) + 1 : 0;
}

// The regions into c, largest first, with their shares by reason; the runtime look-up of low
// vertices follows the new ids.
void add_regions_by_area(const std::vector<CertificateRegion>& regions,
                         const std::vector<std::vector<int>>& region_vertices, const TriangleMesh& mesh,
                         Certificate& c) {
  std::vector<std::size_t> order(regions.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return regions[a].area > regions[b].area; });
  for (std::size_t k = 0; k < order.size(); ++k) {
    CertificateRegion r = regions[order[k]];
    r.id = static_cast<int>(k);
    for (int v : region_vertices[order[k]]) {
      c.low_vertices.push_back(mesh.vertices[static_cast<std::size_t>(v)]);
      c.low_vertex_region.push_back(r.id);
    }
    if (r.reason == "unreachable")
      c.share_unreachable += r.share;
    else if (r.reason == "too_noisy")
      c.share_too_noisy += r.share;
    else
      c.share_improvable += r.share;
    c.regions.push_back(std::move(r));
  }
}

}  // namespace

Certificate compute_certificate(int iteration, const TriangleMesh& mesh, const PointCloud& iso_points,
                                const PointCloud& consolidated, const ScannerSpec& scanner, const StopOptions& options,
                                const Certificate* previous, const SupportContact* contact) {
  Certificate c;
  c.iteration = iteration;
  // The scanner's expected accuracy: its noise model's σ at the optimal distance d_o (§5.1), normal
  // incidence.
  c.scanner_accuracy = scanner.noise.magnitude * scanner.noise.depth_sigma *
                       scanner.relative_depth_sigma(scanner.optimal_distance(), 1.0);
  c.expected_accuracy = c.scanner_accuracy;
  c.tolerated_share = options.remaining_share;
  if (mesh.faces.empty() || mesh.vertices.empty()) {
    c.threshold = options.confidence;
    return c;
  }
  const std::vector<double> f = vertex_confidence(mesh, iso_points);
  c.threshold = confidence_threshold(f, options);
  double low_area = 0.0;
  const std::vector<char> on_support = vertices_on_support(mesh, contact, scanner);
  std::vector<LowComponent> acc = low_components(mesh, f, on_support, c, low_area);
  if (c.surface_area <= 0.0) return c;
  c.share_confident = 1.0 - low_area / c.surface_area;
  // The model's expected accuracy: the scanner's σ and how far the points lie from the surface.
  const FitResiduals fit = fit_residuals(mesh, consolidated);
  c.fit_residual = fit.residual.empty() ? c.edge_length / std::sqrt(12.0) : trimmed_rms(fit.residual);
  c.expected_accuracy = std::hypot(c.scanner_accuracy, c.fit_residual);
  const DataPresence data = data_presence(consolidated, c.edge_length);
  std::vector<std::vector<int>> region_vertices;
  std::vector<CertificateRegion> regions = measure_regions(acc, mesh, data, options, c, region_vertices);
  // A region with data: the residual of the points whose nearest vertex is one of its own.
  if (!fit.residual.empty()) {
    std::vector<int> region_of(mesh.vertices.size(), -1);
    for (std::size_t r = 0; r < region_vertices.size(); ++r)
      for (int v : region_vertices[r]) region_of[static_cast<std::size_t>(v)] = static_cast<int>(r);
    std::vector<std::vector<double>> per(regions.size());
    for (std::size_t k = 0; k < fit.residual.size(); ++k)
      if (const int r = region_of[fit.vertex_of[k]]; r >= 0)
        per[static_cast<std::size_t>(r)].push_back(fit.residual[k]);
    for (std::size_t r = 0; r < regions.size(); ++r)
      if (regions[r].has_data && per[r].size() >= 10)
        regions[r].expected_accuracy = std::hypot(c.scanner_accuracy, trimmed_rms(std::move(per[r])));
  }
  track_regions(regions, regions_on_support(region_vertices, on_support), previous, options, c);
  add_regions_by_area(regions, region_vertices, mesh, c);
  c.done = c.share_improvable < options.remaining_share;
  return c;
}

namespace {

// " with X % missing (unreachable Y %, too noisy Z %)" when a done scan still has settled regions: a
// verdict must not read as complete while part of the surface is certified missing.
std::string done_caveat(const Certificate& c) {
  const double missing = c.share_unreachable + c.share_too_noisy;
  if (!(missing > 0.0)) return {};
  return fmt::format(" with {:.2f} % missing (unreachable {:.2f} %, too noisy {:.2f} %)", 100.0 * missing,
                     100.0 * c.share_unreachable, 100.0 * c.share_too_noisy);
}

}  // namespace

std::string describe(const Certificate& c, std::size_t max_regions) {
  std::string out =
      fmt::format("quality certificate (iteration {}): {:.1f} % of the surface has confidence >= {:.3f}; {}\n",
                  c.iteration, 100.0 * c.share_confident, c.threshold,
                  c.done ? fmt::format("DONE{}: what views can still improve is {:.2f} % of the surface, under the "
                                       "{:.2f} % tolerated (stop.remaining_share: regions that small cost more "
                                       "views than the surface they add)",
                                       done_caveat(c), 100.0 * c.share_improvable, 100.0 * c.tolerated_share)
                         : fmt::format("NOT DONE: {:.2f} % of the surface can still be improved by views",
                                       100.0 * c.share_improvable));
  out += fmt::format(
      "  left: {:.2f} % unreachable, {:.2f} % too noisy, {:.2f} % scattered specks; the model's expected accuracy "
      "{:.3g} (scanner {:.3g}, points to surface {:.3g})\n",
      100.0 * c.share_unreachable, 100.0 * c.share_too_noisy, 100.0 * c.share_scattered, c.expected_accuracy,
      c.scanner_accuracy, c.fit_residual);
  for (std::size_t i = 0; i < c.regions.size() && i < max_regions; ++i) {
    const auto& r = c.regions[i];
    out += fmt::format(
        "  region {}: {:.2f} % of the surface at ({:.3f}, {:.3f}, {:.3f}), radius {:.3f}, mean f {:.3f}: {}{}\n", r.id,
        100.0 * r.share, r.centroid.x(), r.centroid.y(), r.centroid.z(), r.radius, r.mean_f, r.reason,
        r.detail.empty() ? std::string() : " (" + r.detail + ")");
  }
  if (c.regions.size() > max_regions)
    out += fmt::format("  ... and {} smaller regions\n", c.regions.size() - max_regions);
  return out;
}

void count_views_aimed(Certificate& c, const std::vector<Vec3>& targets) {
  for (auto& r : c.regions) r.views_aimed = 0;
  c.views_planned = static_cast<int>(targets.size());
  if (c.low_vertices.empty() || targets.empty()) return;
  const spatial::KdTree tree(std::span<const Vec3>(c.low_vertices));
  const double reach2 = 4.0 * c.edge_length * c.edge_length;
  for (const Vec3& t : targets) {
    double d2 = 0.0;
    const std::size_t i = tree.nearest(t, &d2);
    if (i < c.low_vertices.size() && d2 <= reach2)
      ++c.regions[static_cast<std::size_t>(c.low_vertex_region[i])].views_aimed;
  }
}

std::size_t mask_settled_regions(const Certificate& c, PointCloud& iso_points) {
  auto* f = iso_points.scalars.find("f");
  if (!f || c.low_vertices.empty()) return 0;
  if (std::none_of(c.regions.begin(), c.regions.end(), settled)) return 0;
  const spatial::KdTree tree(std::span<const Vec3>(c.low_vertices));
  const double reach2 = 4.0 * c.edge_length * c.edge_length;
  std::size_t changed = 0;
  for (std::size_t i = 0; i < iso_points.size(); ++i) {
    double d2 = 0.0;
    const std::size_t k = tree.nearest(iso_points.positions[i], &d2);
    if (k >= c.low_vertices.size() || d2 > reach2) continue;
    if (settled(c.regions[static_cast<std::size_t>(c.low_vertex_region[k])]) && (*f)[i] < 1.0) {
      (*f)[i] = 1.0;
      ++changed;
    }
  }
  return changed;
}

}  // namespace autoscan::session
