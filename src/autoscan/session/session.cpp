#include "autoscan/session/session.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/session_layout.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/registration/hand_eye.hpp"
#include "autoscan/session/quality.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::session {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kFormat = "autoscan-session";
constexpr int kVersion = 1;
// Leaf size of the kd-trees over the iso-points (Eq. 6 and the registration weights): 10, as when
// the session borrowed the registration's tree, so that ties between equidistant iso-points resolve
// as before.
constexpr std::size_t kIsoLeafSize = 10;

// Random streams derived from the session seed (independent of restarts and of each other).
constexpr std::uint64_t kInsertionStream = 0x45713;  // Eq. 6, one sub-stream per scan id
constexpr std::uint64_t kPlannerStream = 0x9a11e7;   // planner, one sub-stream per iteration
constexpr std::uint64_t kSupportStream = 0x5aa0b7;   // support-plane RANSAC, one sub-stream per scan id

// A stored scan's removed points (supports.hpp, column "removed") are dropped with their flags, as
// add_scan kept them out of everything.
void drop_removed(PointCloud& scan, std::vector<char>& keep) {
  const auto* removed = scan.scalars.find(kRemovedColumn);
  if (!removed) return;
  std::vector<std::size_t> idx;
  std::vector<char> kept_flags;
  for (std::size_t i = 0; i < scan.size(); ++i)
    if ((*removed)[i] == 0.0) {
      idx.push_back(i);
      kept_flags.push_back(keep[i]);
    }
  scan.scalars.erase(kRemovedColumn);
  scan.select(idx);
  keep = std::move(kept_flags);
}

json matrix_json(const Eigen::Isometry3d& T) {
  json m = json::array();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m.push_back(T.matrix()(i, j));
  return m;
}

Eigen::Isometry3d matrix_from_json(const json& m, const std::string& what) {
  AUTOSCAN_REQUIRE(m.is_array() && m.size() == 16, "{}: expected 16 numbers (a 4x4 row-major matrix)", what);
  Eigen::Matrix4d M;
  for (int i = 0; i < 16; ++i) {
    AUTOSCAN_REQUIRE(m[i].is_number(), "{}: entry {} is not a number", what, i);
    M(i / 4, i % 4) = m[i].get<double>();
  }
  AUTOSCAN_REQUIRE(M.allFinite(), "{}: non-finite entry", what);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix() = M;
  return T;
}

// ---- strict readers of session.json: type and range checked, the field named (issue 21) -----------

std::string brief(const json& v) {
  std::string s = v.dump();
  return s.size() > 40 ? s.substr(0, 37) + "..." : s;
}

const json& member(const json& j, const char* key, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: expected an object (got {})", what, brief(j));
  AUTOSCAN_REQUIRE(j.contains(key), "{}.{}: missing", what, key);
  return j.at(key);
}

long long integer_in(const json& v, const std::string& what, long long lo, long long hi) {
  bool ok = v.is_number_integer();
  long long x = 0;
  if (ok && v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    ok = u <= static_cast<std::uint64_t>(LLONG_MAX);
    x = static_cast<long long>(u);
  } else if (ok) {
    x = v.get<long long>();
  }
  AUTOSCAN_REQUIRE(ok && x >= lo && x <= hi, "{}: expected an integer in [{}, {}] (got {})", what, lo, hi, brief(v));
  return x;
}

double number_in(const json& v, const std::string& what, double lo, double hi) {
  AUTOSCAN_REQUIRE(v.is_number() && std::isfinite(v.get<double>()) && v.get<double>() >= lo && v.get<double>() <= hi,
                   "{}: expected a number in [{}, {}] (got {})", what, lo, hi, brief(v));
  return v.get<double>();
}

bool boolean(const json& v, const std::string& what) {
  AUTOSCAN_REQUIRE(v.is_boolean(), "{}: expected true or false (got {})", what, brief(v));
  return v.get<bool>();
}

std::string string_or_null(const json& v, const std::string& what) {
  AUTOSCAN_REQUIRE(v.is_null() || v.is_string(), "{}: expected a string or null (got {})", what, brief(v));
  return v.is_string() ? v.get<std::string>() : std::string();
}

const json& object_or_null(const json& v, const std::string& what) {
  AUTOSCAN_REQUIRE(v.is_null() || v.is_object(), "{}: expected an object or null (got {})", what, brief(v));
  return v;
}

constexpr long long kMaxCount = LLONG_MAX;
constexpr double kInf = std::numeric_limits<double>::infinity();

// A world-frame correction must be rigid: a rotation (orthonormal, determinant +1), a bounded
// translation and the row 0 0 0 1.
void require_rigid(const Eigen::Isometry3d& T, const std::string& what) {
  const Eigen::Matrix3d R = T.linear();
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const bool last_row = (T.matrix().row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() < 1e-9;
  AUTOSCAN_REQUIRE(orthogonality < 1e-6 && R.determinant() > 0.0 && last_row,
                   "{}: not a rigid transform (a rotation and a translation; rotation off by {:.3g})", what,
                   orthogonality);
  AUTOSCAN_REQUIRE(T.translation().cwiseAbs().maxCoeff() <= kMaxCoordinate, "{}: translation beyond {:g}", what,
                   kMaxCoordinate);
}

// Applies a rigid correction to a scan: positions, normals and the sensor position scalars.
void apply_transform(PointCloud& c, const Eigen::Isometry3d& T) {
  if (T.isApprox(Eigen::Isometry3d::Identity(), 0.0)) return;
  for (auto& p : c.positions) p = T * p;
  for (auto& n : c.normals) n = T.linear() * n;
  auto* sx = c.scalars.find("sensor_x");
  auto* sy = c.scalars.find("sensor_y");
  auto* sz = c.scalars.find("sensor_z");
  if (sx && sy && sz) {
    for (std::size_t i = 0; i < c.size(); ++i) {
      const Vec3 s = T * Vec3((*sx)[i], (*sy)[i], (*sz)[i]);
      (*sx)[i] = s.x();
      (*sy)[i] = s.y();
      (*sz)[i] = s.z();
    }
  }
}

// The part of a scan the model keeps: positions, scan_id and the sensor position.
/// The points of `registered` that `keep` names, with what the model keeps of them: scan id, sensor
/// position, the depth σ (fusion), colours and their colour weight (1/σ², from `scanner`).
PointCloud model_part(const PointCloud& registered, const std::vector<char>& keep, const ScannerSpec& scanner) {
  PointCloud out;
  std::vector<double> id, sx, sy, sz;
  const auto& cid = registered.scalars.get("scan_id");
  const auto& csx = registered.scalars.get("sensor_x");
  const auto& csy = registered.scalars.get("sensor_y");
  const auto& csz = registered.scalars.get("sensor_z");
  for (std::size_t i = 0; i < registered.size(); ++i) {
    if (!keep[i]) continue;
    out.positions.push_back(registered.positions[i]);
    id.push_back(cid[i]);
    sx.push_back(csx[i]);
    sy.push_back(csy[i]);
    sz.push_back(csz[i]);
  }
  out.scalars.set("scan_id", std::move(id));
  out.scalars.set("sensor_x", std::move(sx));
  out.scalars.set("sensor_y", std::move(sy));
  out.scalars.set("sensor_z", std::move(sz));
  if (const auto* q = registered.scalars.find(kDepthSigmaColumn)) {
    std::vector<double> sigma;
    sigma.reserve(out.positions.size());
    for (std::size_t i = 0; i < registered.size(); ++i)
      if (keep[i]) sigma.push_back((*q)[i]);
    out.scalars.set(kDepthSigmaColumn, std::move(sigma));
  }
  if (registered.has_colors()) {
    const auto* q = registered.scalars.find(kDepthSigmaColumn);
    const std::vector<double> sigma = q ? std::vector<double>() : predicted_depth_sigma(registered, scanner);
    const std::vector<double>& s = q ? *q : sigma;
    std::vector<double> w;
    w.reserve(out.positions.size());
    out.colors.reserve(out.positions.size());
    for (std::size_t i = 0; i < registered.size(); ++i) {
      if (!keep[i]) continue;
      out.colors.push_back(registered.colors[i]);
      w.push_back(1.0 / std::max(s[i] * s[i], 1e-12));
    }
    out.scalars.set(kColorWeightColumn, std::move(w));
  }
  return out;
}

io::WriteOptions exact_ply() {
  io::WriteOptions w;
  w.double_coordinates = true;
  w.double_scalars = true;
  return w;
}

json pose_or_null(const std::optional<Pose>& p) { return p ? to_json(*p) : json(nullptr); }

// Removes temporary files a crash may have left: only write_file_atomic's own ".NAME.tmp.PID.N".
void remove_temporaries(const fs::path& dir) {
  static const std::regex pattern(R"(\..+\.tmp\.\d+\.\d+)");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (std::regex_match(name, pattern) && e.is_regular_file(ec)) {
      fs::remove(e.path(), ec);
      log::warn("{}: removed a temporary file left by an interrupted write", e.path().string());
    }
  }
}

}  // namespace

// ---- free functions --------------------------------------------------------------------------------

std::vector<char> selective_insertion_mask(const std::vector<Vec3>& points, const std::vector<Vec3>& iso_points,
                                           const std::vector<double>& iso_f, double rho, Rng& rng) {
  return selective_insertion_mask(points, {}, iso_points, {}, iso_f, rho, rng, 0, 0.0);
}

std::vector<char> selective_insertion_mask(const std::vector<Vec3>& points, const std::vector<Vec3>& normals,
                                           const std::vector<Vec3>& iso_points, const std::vector<Vec3>& iso_normals,
                                           const std::vector<double>& iso_f, double rho, Rng& rng, int neighbours,
                                           double normal_deg) {
  AUTOSCAN_REQUIRE(iso_f.size() == iso_points.size(), "selective insertion: {} confidence values for {} iso-points",
                   iso_f.size(), iso_points.size());
  AUTOSCAN_REQUIRE(std::isfinite(rho) && rho >= 0.0, "selective insertion: rho must be >= 0 (got {})", rho);
  std::vector<char> keep(points.size(), 1);
  if (iso_points.empty() || points.empty()) return keep;
  const spatial::KdTree nn(iso_points, kIsoLeafSize);
  std::vector<std::size_t> idx(points.size());
  const bool oriented = neighbours > 0 && normals.size() == points.size() && iso_normals.size() == iso_points.size();
  if (!oriented) nn.nearest(points, idx, {});  // the paper's s_k; the oriented look-up sets idx itself
  // A point none of whose nearest iso-points faces its way measures a sheet the model does not have
  // yet (the far side of a thin wall, the ceiling of a channel the surface bridges): f = 0 there.
  std::vector<char> unrepresented(points.size(), 0);
  if (oriented) {
    const double cos_max = std::cos(normal_deg * std::numbers::pi / 180.0);
    const auto k = static_cast<std::size_t>(neighbours);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size()), [&](const auto& range) {
      std::vector<std::size_t> nb(k);
      std::vector<double> d2(k);
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const std::size_t m = nn.knn(points[i], k, nb.data(), d2.data());
        unrepresented[i] = 1;
        for (std::size_t t = 0; t < m; ++t)
          if (normals[i].dot(iso_normals[nb[t]]) >= cos_max * normals[i].norm() * iso_normals[nb[t]].norm()) {
            idx[i] = nb[t];
            unrepresented[i] = 0;
            break;
          }
      }
    });
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double f = unrepresented[i] ? 0.0 : std::clamp(iso_f[idx[i]], 0.0, 1.0);
    const double p = std::pow(1.0 - f, rho);  // Eq. 6: P(p_i) = (1 − f(s_k))^ρ
    keep[i] = rng.uniform() < p ? 1 : 0;
  }
  return keep;
}

bool confidence_converged(double previous_mean_f, double mean_f, double threshold) {
  return std::abs(mean_f - previous_mean_f) < threshold;
}

int best_by_confidence(const std::vector<double>& mean_f, double tolerance) {
  if (mean_f.empty()) return -1;
  const double top = *std::max_element(mean_f.begin(), mean_f.end());
  for (std::size_t i = mean_f.size(); i-- > 0;)
    if (mean_f[i] >= top - tolerance) return static_cast<int>(i);
  return -1;
}

AccuracyBest best_by_fit(const std::vector<double>& share_confident, const std::vector<double>& fit_residual,
                         double complete_tolerance, double accuracy_tolerance) {
  AccuracyBest out;
  const std::size_t n = std::min(share_confident.size(), fit_residual.size());
  double top = -1.0;
  for (std::size_t i = 0; i < n; ++i)
    if (fit_residual[i] > 0.0) top = std::max(top, share_confident[i]);
  auto candidate = [&](std::size_t i) {
    return fit_residual[i] > 0.0 && share_confident[i] >= top - complete_tolerance;
  };
  double least = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i)
    if (candidate(i)) least = std::min(least, fit_residual[i]);
  for (std::size_t i = n; i-- > 0;)
    if (candidate(i) && fit_residual[i] <= least * (1.0 + accuracy_tolerance)) {
      out.best = static_cast<int>(i);
      out.after = static_cast<int>(n) - 1 - out.best;
      break;
    }
  return out;
}

std::string remaining_rule(const Certificate& certificate, double mean_f, std::optional<double> best_previous_mean_f,
                           const StopOptions& options) {
  // Quality fell: worse than the best iteration beyond the noise of the measure. Stop at once; the
  // best iteration's model is the result.
  if (!options.quality_by_truth && best_previous_mean_f && *best_previous_mean_f - mean_f > options.quality_tolerance)
    return "quality_fell";
  // Nothing left that views can improve (a small share of the surface).
  if (certificate.done) return "complete";
  // The last rounds' views raised the confidence nowhere they looked.
  if (certificate.stalled_rounds >= options.stalled_rounds) return "no_improvement";
  return "";
}

json to_json(const ScanRecord& r) {
  json j = {{"id", r.id},
            {"file", SessionLayout::scan_file(r.id)},
            {"points", r.points},
            {"inserted", r.inserted},
            {"quality_refused", r.quality_refused},
            {"model_iteration", r.model_iteration},
            {"pose", to_json(r.reported_pose)},
            {"registered_pose", to_json(r.registered_pose)},
            {"correction", matrix_json(r.correction)},
            {"added_correction", matrix_json(r.added_correction)},
            {"registration", r.registration ? registration::to_json(*r.registration) : json(nullptr)},
            {"registration_accepted", !r.correction.isApprox(Eigen::Isometry3d::Identity(), 0.0)},
            {"global_registration", r.global_registration},
            {"excluded", r.excluded},
            {"excluded_reason", r.excluded ? json(r.excluded_reason) : json(nullptr)},
            {"seconds", {{"registration", r.seconds_registration}, {"insertion", r.seconds_insertion}}}};
  // Only when something was removed or a plane is known: older readers see what they saw before.
  if (r.removed_fixture + r.removed_support_plane > 0 || r.support_plane) {
    json rm = {{"fixture", r.removed_fixture}, {"support_plane", r.removed_support_plane}};
    if (r.support_plane) {
      const auto& pl = *r.support_plane;
      rm["plane"] = {pl.normal.x(), pl.normal.y(), pl.normal.z(), pl.offset};
      rm["plane_detected"] = r.support_plane_detected;
    }
    j["removed"] = rm;
  }
  return j;
}

json to_json(const IterationRecord& r) {
  json secs = json::object();
  for (const auto& [k, v] : r.seconds) secs[k] = v;
  json j = {{"index", r.index},
            {"scans", r.scans},
            {"points", r.raw_points},
            {"consolidated_points", r.consolidated_points},
            {"mesh_vertices", r.mesh_vertices},
            {"iso_points", r.iso_points},
            {"views", r.views},
            {"mean_f", r.mean_f},
            {"mean_f_g", r.mean_f_g},
            {"mean_f_s", r.mean_f_s},
            {"delta_mean_f", r.delta_mean_f},
            {"path_length", r.path_length},
            {"seconds", secs},
            {"planner", r.planner_diagnostics},
            {"registration", r.registration},
            {"truth", r.truth},
            {"certificate", r.certificate},
            {"stopped", r.stopped},
            {"stop_reason", r.stop_reason.empty() ? json(nullptr) : json(r.stop_reason)}};
  if (!r.hand_eye.is_null()) j["hand_eye"] = r.hand_eye;  // absent before issue 45
  return j;
}

json to_json(const SessionStatus& s) {
  return {{"directory", s.directory.string()},
          {"planner", s.planner},
          {"scans", s.scans},
          {"model_points", s.model_points},
          {"iterations", s.iterations},
          {"views_planned", s.views_planned},
          {"pending_scans", s.pending_scans},
          {"excluded_scans", s.excluded_scans},
          {"refused_views", s.refused_views},
          {"registration", s.registration},
          {"stopped", s.stopped},
          {"stop_reason", s.stop_reason.empty() ? json(nullptr) : json(s.stop_reason)},
          {"last_mean_f", s.last_mean_f ? json(*s.last_mean_f) : json(nullptr)},
          {"best_iteration", s.best_iteration},
          {"certificate", s.certificate},
          {"hand_eye", s.hand_eye},
          {"current_pose", pose_or_null(s.current_pose)}};
}

namespace {

ScanRecord scan_from_json(const json& j, const std::string& what, int expected_id, int iterations) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: expected an object (got {})", what, brief(j));
  ScanRecord r;
  r.id = static_cast<int>(integer_in(member(j, "id", what), what + ".id", 0, INT_MAX));
  AUTOSCAN_REQUIRE(r.id == expected_id, "{}.id: scan id {} out of order (expected {})", what, r.id, expected_id);
  if (j.contains("file")) {
    const std::string file = SessionLayout::scan_file(r.id);
    AUTOSCAN_REQUIRE(j.at("file").is_string() && j.at("file").get<std::string>() == file, "{}.file: expected \"{}\"",
                     what, file);
  }
  r.points = static_cast<std::size_t>(integer_in(member(j, "points", what), what + ".points", 0, kMaxCount));
  r.inserted = static_cast<std::size_t>(
      integer_in(member(j, "inserted", what), what + ".inserted", 0, static_cast<long long>(r.points)));
  if (j.contains("quality_refused"))  // absent in sessions written before quality-weighted fusion
    r.quality_refused = static_cast<std::size_t>(
        integer_in(j.at("quality_refused"), what + ".quality_refused", 0, static_cast<long long>(r.points)));
  r.model_iteration =
      static_cast<int>(integer_in(member(j, "model_iteration", what), what + ".model_iteration", -1, iterations - 1));
  const json& secs = member(j, "seconds", what);
  r.seconds_registration =
      number_in(member(secs, "registration", what + ".seconds"), what + ".seconds.registration", 0.0, kInf);
  r.seconds_insertion = number_in(member(secs, "insertion", what + ".seconds"), what + ".seconds.insertion", 0.0, kInf);
  r.reported_pose = pose_from_json(member(j, "pose", what), what + ".pose");
  r.registered_pose = pose_from_json(member(j, "registered_pose", what), what + ".registered_pose");
  r.correction = matrix_from_json(member(j, "correction", what), what + ".correction");
  require_rigid(r.correction, what + ".correction");
  r.added_correction = r.correction;  // a session written before the field: no global registration moved it
  if (j.contains("added_correction")) {
    r.added_correction = matrix_from_json(j.at("added_correction"), what + ".added_correction");
    require_rigid(r.added_correction, what + ".added_correction");
  }
  if (j.contains("global_registration"))
    r.global_registration = object_or_null(j.at("global_registration"), what + ".global_registration");
  if (j.contains("registration_accepted")) boolean(j.at("registration_accepted"), what + ".registration_accepted");
  if (j.contains("excluded")) {
    r.excluded = boolean(j.at("excluded"), what + ".excluded");
    if (j.contains("excluded_reason")) {
      const std::string reason = string_or_null(j.at("excluded_reason"), what + ".excluded_reason");
      if (r.excluded) r.excluded_reason = reason;
    }
  }
  if (j.contains("removed")) {  // absent in sessions written before supports (issue 17)
    const std::string w = what + ".removed";
    const json& rm = j.at("removed");
    AUTOSCAN_REQUIRE(rm.is_object(), "{}: expected an object (got {})", w, brief(rm));
    const auto most = static_cast<long long>(r.points);
    r.removed_fixture = static_cast<std::size_t>(integer_in(member(rm, "fixture", w), w + ".fixture", 0, most));
    r.removed_support_plane =
        static_cast<std::size_t>(integer_in(member(rm, "support_plane", w), w + ".support_plane", 0, most));
    AUTOSCAN_REQUIRE(r.removed_fixture + r.removed_support_plane + r.inserted <= r.points,
                     "{}: more points removed and inserted than the scan has", w);
    if (rm.contains("plane")) {
      const json& pl = rm.at("plane");
      AUTOSCAN_REQUIRE(pl.is_array() && pl.size() == 4, "{}.plane: expected [nx, ny, nz, offset]", w);
      SupportPlane plane;
      for (int k = 0; k < 3; ++k) plane.normal[k] = number_in(pl[static_cast<std::size_t>(k)], w + ".plane", -1.0, 1.0);
      plane.offset = number_in(pl[3], w + ".plane", -kMaxCoordinate, kMaxCoordinate);
      AUTOSCAN_REQUIRE(std::abs(plane.normal.norm() - 1.0) < 1e-6, "{}.plane: the normal is not a unit vector", w);
      r.support_plane = plane;
      if (rm.contains("plane_detected"))
        r.support_plane_detected = boolean(rm.at("plane_detected"), w + ".plane_detected");
    }
  }
  if (j.contains("registration") && !object_or_null(j.at("registration"), what + ".registration").is_null()) {
    const std::string w = what + ".registration";
    member(j.at("registration"), "correction", w);  // required; the other fields default to 0
    r.registration = registration::icp_result_from_json(j.at("registration"), w);
  }
  return r;
}

IterationRecord iteration_from_json(const json& j, const std::string& what, int expected_index) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: expected an object (got {})", what, brief(j));
  IterationRecord r;
  r.index = static_cast<int>(integer_in(member(j, "index", what), what + ".index", 0, INT_MAX));
  AUTOSCAN_REQUIRE(r.index == expected_index, "{}.index: {} out of order (expected {})", what, r.index, expected_index);
  const json& scans = member(j, "scans", what);
  AUTOSCAN_REQUIRE(scans.is_array(), "{}.scans: expected an array of scan ids (got {})", what, brief(scans));
  for (std::size_t i = 0; i < scans.size(); ++i)
    r.scans.push_back(static_cast<int>(integer_in(scans[i], fmt::format("{}.scans[{}]", what, i), 0, INT_MAX)));
  auto count = [&](const char* key) {
    return static_cast<std::size_t>(integer_in(member(j, key, what), what + "." + key, 0, kMaxCount));
  };
  auto num = [&](const char* key, double lo, double hi) {
    return number_in(member(j, key, what), what + "." + key, lo, hi);
  };
  r.raw_points = count("points");
  r.consolidated_points = count("consolidated_points");
  r.mesh_vertices = count("mesh_vertices");
  r.iso_points = count("iso_points");
  r.views = static_cast<int>(integer_in(member(j, "views", what), what + ".views", 0, INT_MAX));
  r.mean_f = num("mean_f", -kInf, kInf);
  r.mean_f_g = num("mean_f_g", -kInf, kInf);
  r.mean_f_s = num("mean_f_s", -kInf, kInf);
  r.delta_mean_f = num("delta_mean_f", -kInf, kInf);
  r.path_length = num("path_length", 0.0, kInf);
  const json& secs = member(j, "seconds", what);
  AUTOSCAN_REQUIRE(secs.is_object(), "{}.seconds: expected an object (got {})", what, brief(secs));
  for (const auto& [k, v] : secs.items()) r.seconds[k] = number_in(v, what + ".seconds." + k, 0.0, kInf);
  r.planner_diagnostics = member(j, "planner", what);
  if (j.contains("registration")) r.registration = object_or_null(j.at("registration"), what + ".registration");
  r.truth = object_or_null(member(j, "truth", what), what + ".truth");
  if (j.contains("certificate") && !object_or_null(j.at("certificate"), what + ".certificate").is_null()) {
    certificate_from_json(j.at("certificate"), what + ".certificate");  // validated; kept as written
    r.certificate = j.at("certificate");
  }
  if (j.contains("hand_eye")) {
    r.hand_eye = object_or_null(j.at("hand_eye"), what + ".hand_eye");
    if (!r.hand_eye.is_null()) registration::hand_eye_from_json(r.hand_eye, what + ".hand_eye");  // validated
  }
  r.stopped = boolean(member(j, "stopped", what), what + ".stopped");
  r.stop_reason = string_or_null(member(j, "stop_reason", what), what + ".stop_reason");
  return r;
}

}  // namespace

SessionFile parse_session_json(std::string_view text, const std::string& where) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, or out_of_range for 1e999
    throw InputError(fmt::format("{}: not valid JSON: {}", where, e.what()));
  }
  SessionFile out;
  std::vector<ScanRecord>& records = out.scans;
  try {
    AUTOSCAN_REQUIRE(j.is_object() && j.value("format", "") == kFormat, "{}: not an autoscan session file", where);
    AUTOSCAN_REQUIRE(j.contains("version") && j.at("version") == kVersion, "{}: version: unsupported version {}", where,
                     j.contains("version") ? brief(j.at("version")) : std::string("(missing)"));
    for (const char* key : {"scanner", "rig", "params", "scans", "iterations"})
      AUTOSCAN_REQUIRE(j.contains(key), "{}: missing '{}'", where, key);
    out.scanner = scanner_from_json(j.at("scanner"), where + ": scanner");
    out.rig = rig_from_json(j.at("rig"), where + ": rig");
    out.options = session_options_from_json(without_legacy_options(j.at("params")), {}, where + ": params");
    out.options.validate();
    if (j.contains("current_pose") && !j.at("current_pose").is_null())
      out.current_pose = pose_from_json(j.at("current_pose"), where + ": current_pose");
    if (j.contains("views_planned"))
      out.views_planned = static_cast<int>(integer_in(j.at("views_planned"), where + ": views_planned", 0, INT_MAX));
    if (j.contains("stopped")) out.stopped = boolean(j.at("stopped"), where + ": stopped");
    if (j.contains("stop_reason")) out.stop_reason = string_or_null(j.at("stop_reason"), where + ": stop_reason");
    if (j.contains("planner_state")) out.planner_state = j.at("planner_state");
    if (j.contains("refused_views")) {
      const json& rv = j.at("refused_views");
      AUTOSCAN_REQUIRE(rv.is_array(), "{}: refused_views: expected an array (got {})", where, brief(rv));
      for (std::size_t i = 0; i < rv.size(); ++i) {
        const std::string w = fmt::format("{}: refused_views[{}]", where, i);
        AUTOSCAN_REQUIRE(rv[i].is_object() && rv[i].contains("pose"), "{}: expected {{\"pose\": ..., \"reason\": ...}}",
                         w);
        RefusedView r;
        r.pose = pose_from_json(rv[i].at("pose"), w + ": pose");
        if (rv[i].contains("reason")) r.reason = string_or_null(rv[i].at("reason"), w + ": reason");
        out.refused_views.push_back(std::move(r));
      }
    }
    const json& scans_j = j.at("scans");
    const json& iters_j = j.at("iterations");
    AUTOSCAN_REQUIRE(scans_j.is_array(), "{}: scans: expected an array of scan records (got {})", where,
                     brief(scans_j));
    AUTOSCAN_REQUIRE(iters_j.is_array(), "{}: iterations: expected an array of iteration records (got {})", where,
                     brief(iters_j));
    for (std::size_t i = 0; i < iters_j.size(); ++i)
      out.iterations.push_back(
          iteration_from_json(iters_j[i], fmt::format("{}: iterations[{}]", where, i), static_cast<int>(i)));
    const int n_iterations = static_cast<int>(out.iterations.size());
    if (j.contains("best_iteration"))
      out.best_iteration =
          static_cast<int>(integer_in(j.at("best_iteration"), where + ": best_iteration", -1, n_iterations - 1));
    for (std::size_t i = 0; i < scans_j.size(); ++i)
      records.push_back(
          scan_from_json(scans_j[i], fmt::format("{}: scans[{}]", where, i), static_cast<int>(i), n_iterations));
    // Each scan belongs to at most one iteration, in order; every scan an iteration lists exists.
    int next = 0;
    for (std::size_t k = 0; k < out.iterations.size(); ++k) {
      const auto& ids = out.iterations[k].scans;
      for (std::size_t i = 0; i < ids.size(); ++i) {
        AUTOSCAN_REQUIRE(ids[i] < static_cast<int>(records.size()),
                         "{}: iterations[{}].scans[{}]: scan {} does not exist (session.json lists {} scans)", where, k,
                         i, ids[i], records.size());
        AUTOSCAN_REQUIRE(ids[i] >= next, "{}: iterations[{}].scans[{}]: scan {} listed out of order or twice", where, k,
                         i, ids[i]);
        next = ids[i] + 1;
      }
    }
    std::size_t model_points = 0;
    for (const auto& r : records)
      if (!r.excluded) model_points += r.inserted;
    if (j.contains("model_points")) {
      const auto stated = integer_in(j.at("model_points"), where + ": model_points", 0, kMaxCount);
      AUTOSCAN_REQUIRE(static_cast<std::size_t>(stated) == model_points,
                       "{}: scans: the scans listed hold {} inserted points but model_points says {}: session.json "
                       "is inconsistent; nothing was moved",
                       where, model_points, stated);
    }
  } catch (const json::exception& e) {  // a type the checks above did not foresee: still named
    throw InputError(fmt::format("{}: {}", where, e.what()));
  }
  return out;
}

// ---- Session ---------------------------------------------------------------------------------------

struct Session::Impl {
  fs::path dir;
  int lock_fd = -1;
  ScannerSpec scanner;
  Rig rig;
  SessionOptions options;
  std::unique_ptr<planners::Planner> planner;
  std::unique_ptr<FixtureGeometry> fixture_geometry;  // built at the first scan (supports.hpp)
  Reconstructor reconstructor = reconstruct_model;
  ProgressCallback progress;

  std::vector<ScanRecord> scans;
  std::vector<IterationRecord> iterations;
  PointCloud model;  // every inserted point, registered
  // Parallel to model.positions: each point and its sensor position as received (the reported
  // pose's frame), so a changed correction recomputes them exactly as open() does.
  std::vector<Vec3> model_src, model_src_sensor;
  // Per scan: a stride sample (positions, normals when the scan has them) at its reported pose, for
  // the global registration; empty for an excluded scan (it takes no further part).
  std::vector<PointCloud> reg_samples;
  // Each scan's preparation for the global registration (surface fits), kept across iterations: it
  // depends only on the scan (docs/registration.md). Rebuilt lazily after open(): same inputs, same bits.
  std::vector<std::shared_ptr<const registration::PreparedScan>> reg_prepared;
  std::size_t model_size_at_last_iteration = 0;
  std::optional<Pose> current_pose;
  int views_planned = 0;
  bool stopped = false;
  std::string stop_reason;
  std::vector<RefusedView> refused;  // refuse_view()
  int best_iteration = -1;           // the session's result (best_iteration())
  bool best_fixed = false;           // set by finish(): not recomputed

  // The registration target and Eq. 6's confidence, from the last iteration (reloaded on open).
  PointCloud target;                  // consolidated points with normals
  std::vector<double> target_weight;  // f of the iso-point nearest to each target point
  std::vector<Vec3> iso_positions;
  std::vector<Vec3> iso_normals;
  std::vector<double> iso_f;
  QualityGate quality_gate;  // the consolidated surface with its σ (insertion by quality)

  ~Impl() {
    if (lock_fd >= 0) ::close(lock_fd);
  }

  SessionLayout layout() const { return SessionLayout(dir); }
  fs::path session_json() const { return layout().session_json(); }

  // The lock is held on an open descriptor of the session directory itself: no file whose deletion
  // would break it (issue 21).
  void lock() {
    lock_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (lock_fd < 0)
      throw RuntimeError(fmt::format("{}: cannot open the session directory: {}", dir.string(), std::strerror(errno)));
    if (::flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      if (err == EWOULDBLOCK)
        throw InputError(fmt::format("{}: the session is in use by another process", dir.string()));
      throw RuntimeError(fmt::format("{}: cannot lock the session directory: {}", dir.string(), std::strerror(err)));
    }
  }

  int pending_from() const {
    // First scan id not yet used by an iteration.
    int n = 0;
    for (const auto& it : iterations)
      for (int s : it.scans) n = std::max(n, s + 1);
    return n;
  }

  json to_json_all() const {
    json scans_j = json::array();
    for (const auto& s : scans) scans_j.push_back(to_json(s));
    json iters_j = json::array();
    for (const auto& it : iterations) iters_j.push_back(to_json(it));
    return {{"format", kFormat},
            {"version", kVersion},
            {"scanner", to_json(scanner)},
            {"rig", to_json(rig)},
            {"seed", options.seed},
            {"planner", options.planner},
            {"params", to_json(options)},
            {"planner_state", planner ? planner->saved_state() : json(nullptr)},
            {"current_pose", pose_or_null(current_pose)},
            {"views_planned", views_planned},
            {"model_points", model.size()},
            {"scans", scans_j},
            {"iterations", iters_j},
            {"best_iteration", best_iteration},
            {"stopped", stopped},
            {"stop_reason", stop_reason.empty() ? json(nullptr) : json(stop_reason)},
            {"refused_views", refused_json()}};
  }
  json refused_json() const {
    json a = json::array();
    for (const auto& r : refused) a.push_back({{"pose", to_json(r.pose)}, {"reason", r.reason}});
    return a;
  }

  void persist() const { write_session_json(to_json_all()); }
  void write_session_json(const json& all) const { write_text_atomic(session_json(), all.dump(1) + "\n"); }

  void make_planner_object() {
    planners::PlannerOptions po;
    po.nbv = options.nbv;
    po.params = options.planner_params;
    po.scanner = scanner;
    // Forward to the session's current callback (set_progress may change it later).
    po.progress = [this](std::string_view stage, double f) { return progress ? progress(stage, f) : true; };
    planner = planners::make_planner(options.planner, po);
  }

  bool fusion_on() const { return options.quality_weights || options.quality_insertion_ratio > 0.0; }

  bool has_model() const { return !iterations.empty() && !target.empty(); }

  // The most accurate iteration by the certificates' confident share and fit residual (0 without a
  // certificate: no candidate), with `pending` as one more iteration after the recorded ones.
  AccuracyBest accuracy_best(const Certificate* pending = nullptr) const {
    std::vector<double> conf, fit;
    for (const auto& it : iterations) {
      const bool c = it.certificate.is_object();
      conf.push_back(c ? it.certificate.value("share_confident", 0.0) : 0.0);
      fit.push_back(c ? it.certificate.value("fit_residual", 0.0) : 0.0);
    }
    if (pending) {
      conf.push_back(pending->share_confident);
      fit.push_back(pending->fit_residual);
    }
    return best_by_fit(conf, fit, options.stop.complete_tolerance, options.stop.accuracy_tolerance);
  }

  void update_best() {
    if (best_fixed) return;
    // The most accurate model by the session's own figures (StopOptions::best_rounds): the result
    // whatever stopped the session, except a fall of the mean confidence (its own best), and before
    // any truth a driver attaches (docs/stop-rule.md, "The most accurate model").
    if (options.stop.rule == StopRule::remaining && options.stop.best_rounds > 0 &&
        !(stopped && stop_reason == "quality_fell")) {
      if (const int b = accuracy_best().best; b >= 0) {
        best_iteration = b;
        return;
      }
    }
    if (options.stop.quality_by_truth) {
      // The driver knows the truth: the latest iteration whose F-score is within the tolerance of the
      // best one's (iterations without truth figures yet are not candidates).
      std::vector<double> fs(iterations.size(), -1.0);
      for (std::size_t i = 0; i < iterations.size(); ++i)
        if (iterations[i].truth.is_object() && iterations[i].truth.contains("fscore"))
          fs[i] = iterations[i].truth["fscore"].get<double>();
      if (std::any_of(fs.begin(), fs.end(), [](double x) { return x >= 0.0; })) {
        best_iteration = best_by_confidence(fs, options.stop.truth_fscore_tolerance);
        return;
      }
    }
    std::vector<double> f;
    for (const auto& it : iterations) f.push_back(it.mean_f);
    best_iteration = best_by_confidence(f, options.stop.quality_tolerance);
  }

  // The result: the best iteration's mesh as model.ply (atomically), when the session stops.
  void write_result_model() const {
    if (best_iteration < 0) return;
    const fs::path src = layout().mesh(best_iteration);
    std::error_code ec;
    if (!fs::exists(src, ec)) return;
    io::WriteOptions exact;
    exact.double_coordinates = true;
    io::write_mesh(layout().model(), io::read_mesh(src), exact);
  }

  // Sets the registration target and Eq. 6's look-up from a reconstruction.
  void set_target(const PointCloud& consolidated, const PointCloud& iso) {
    target = PointCloud{};
    target.positions = consolidated.positions;
    target.normals = consolidated.normals;
    const auto* tsigma = consolidated.scalars.find(kDepthSigmaColumn);
    quality_gate =
        tsigma && tsigma->size() == consolidated.size() ? QualityGate(consolidated.positions, *tsigma) : QualityGate();
    iso_positions = iso.positions;
    iso_normals = iso.normals;
    const auto* f = iso.scalars.find("f");
    iso_f = f ? *f : std::vector<double>(iso.size(), 0.0);
    target_weight.assign(target.size(), 1.0);
    if (!iso_positions.empty() && !target.empty()) {
      const spatial::KdTree nn(iso_positions, kIsoLeafSize);
      std::vector<std::size_t> idx(target.size());
      nn.nearest(target.positions, idx, {});
      for (std::size_t i = 0; i < target.size(); ++i) target_weight[i] = std::clamp(iso_f[idx[i]], 0.0, 1.0);
    }
  }

  PointCloud registration_sample(const PointCloud& scan) const {
    PointCloud out;
    const std::size_t cap = std::max<std::size_t>(1, options.multiway.target_points);
    const std::size_t stride = std::max<std::size_t>(1, (scan.size() + cap - 1) / cap);
    for (std::size_t i = 0; i < scan.size(); i += stride) {
      out.positions.push_back(scan.positions[i]);
      if (scan.has_normals()) out.normals.push_back(scan.normals[i]);
    }
    return out;
  }

  // Appends the kept points of a scan: `reported` as received, `registered` after its correction.
  void append_to_model(const PointCloud& reported, const PointCloud& registered, const std::vector<char>& keep) {
    if (registered.empty()) return;
    model.append(model_part(registered, keep, scanner));
    const auto& sx = reported.scalars.get("sensor_x");
    const auto& sy = reported.scalars.get("sensor_y");
    const auto& sz = reported.scalars.get("sensor_z");
    for (std::size_t i = 0; i < reported.size(); ++i) {
      if (!keep[i]) continue;
      model_src.push_back(reported.positions[i]);
      model_src_sensor.emplace_back(sx[i], sy[i], sz[i]);
    }
  }

  // Recomputes, in one pass over the model, the points of the scans flagged in `moved` from their
  // received positions and the scan's correction (the same arithmetic as apply_transform, so a
  // resumed session rebuilds identical points).
  void reapply_corrections(const std::vector<char>& moved) {
    const auto& sid = model.scalars.get("scan_id");
    auto& sx = *model.scalars.find("sensor_x");
    auto& sy = *model.scalars.find("sensor_y");
    auto& sz = *model.scalars.find("sensor_z");
    for (std::size_t k = 0; k < model.size(); ++k) {
      const auto id = static_cast<std::size_t>(sid[k]);
      if (!moved[id]) continue;
      const Eigen::Isometry3d& C = scans[id].correction;
      const bool identity = C.isApprox(Eigen::Isometry3d::Identity(), 0.0);
      const Vec3 p = identity ? model_src[k] : Vec3(C * model_src[k]);
      const Vec3 q = identity ? model_src_sensor[k] : Vec3(C * model_src_sensor[k]);
      model.positions[k] = p;
      sx[k] = q.x();
      sy[k] = q.y();
      sz[k] = q.z();
    }
  }

  void remove_from_model(int id) {
    const auto& sid = model.scalars.get("scan_id");
    std::vector<std::size_t> keep;
    keep.reserve(model.size());
    for (std::size_t k = 0; k < model.size(); ++k)
      if (static_cast<int>(sid[k]) != id) keep.push_back(k);
    if (keep.size() == model.size()) return;
    model.select(keep);
    std::vector<Vec3> a, b;
    a.reserve(keep.size());
    b.reserve(keep.size());
    for (std::size_t k : keep) {
      a.push_back(model_src[k]);
      b.push_back(model_src_sensor[k]);
    }
    model_src = std::move(a);
    model_src_sensor = std::move(b);
  }

  // The session's multiway options: the depth uncertainty that weighs the points is the scanner's
  // model (docs/registration.md, "Quality weighting"): its incidence term comes from the scanner JSON
  // (`noise.depth_incidence_gain`), not from a session option.
  registration::MultiwayOptions multiway_options() const {
    auto m = options.multiway;
    m.incidence_gain = scanner.noise.depth_incidence_gain;
    return m;
  }

  // The global multi-view registration of an iteration (docs/registration.md): the scans added since
  // the last iteration are freed, with the scans they overlap; the others anchor them. With
  // options.hand_eye_priors, when the hand-eye estimate from that solution (its flagged scans
  // included: an error shared by every scan is no outlier) is significant and differs from the one
  // the priors were centred on, every scan is solved once more around the new estimate's centres,
  // starting from the first solution; only the second solution is applied and flags scans.
  void global_registration(IterationRecord& it) {
    const int first = pending_from();
    const int n = static_cast<int>(scans.size());
    if (!options.register_scans || !options.global_registration || first >= n) return;
    std::vector<char> free(scans.size(), 0);
    for (int i = first; i < n; ++i)
      free[static_cast<std::size_t>(i)] = scans[static_cast<std::size_t>(i)].excluded ? 0 : 1;
    std::vector<Eigen::Isometry3d> initial;
    for (const auto& r : scans) initial.push_back(r.correction);
    const auto last = options.hand_eye_priors ? last_hand_eye() : std::nullopt;
    const bool applied = last && last->significant;
    // The plain solution: the priors on the reported poses, or around C_i Ĥ of the applied estimate.
    auto res = solve_multiway(free, initial, hand_eye_prior_centers(),
                              applied ? std::pair{last->translation_se, last->rotation_se_deg} : std::pair{0.0, 0.0});
    double seconds = res.seconds;
    bool repass = false;
    json hand_eye_test = nullptr;
    if (options.hand_eye_priors) {
      // The offset's evidence: the plain solution once an estimate is applied; before, a solution with
      // the priors widened by the calibration's uncertainty (a shared error is then no outlier).
      registration::MultiwayResult wide;
      const registration::MultiwayResult* evidence = &res;
      if (!applied) {
        wide = solve_multiway(free, initial, {},
                              {options.hand_eye_translation_sigma, options.hand_eye_rotation_sigma_deg});
        seconds += wide.seconds;
        evidence = &wide;
      }
      const json now = hand_eye_estimate(evidence, false);
      const auto h = now.is_null() ? std::nullopt : std::optional(registration::hand_eye_from_json(now, "hand_eye"));
      if (h && hand_eye_changed(*h)) {
        std::vector<char> all(scans.size(), 0);
        for (int i = 0; i < n; ++i)
          all[static_cast<std::size_t>(i)] = scans[static_cast<std::size_t>(i)].excluded ? 0 : 1;
        auto with = solve_multiway(all, evidence->corrections, prior_centers_for(h->offset),
                                   {h->translation_se, h->rotation_se_deg});
        seconds += with.seconds;
        // Taken when it keeps fewer scans out than the plain solution, or as many and fits the pairs
        // better on average by the share hand_eye_min_fit_gain.
        const auto flagged = [](const registration::MultiwayResult& r) {
          return std::count_if(r.scans.begin(), r.scans.end(), [](const auto& sc) { return sc.flagged; });
        };
        const auto mean_chi2 = [](const registration::MultiwayResult& r) {
          return r.pair_chi2_pairs > 0 ? r.pair_chi2 / double(r.pair_chi2_pairs) : 0.0;
        };
        const auto fw = flagged(with), fp = flagged(res);
        const bool take =
            fw < fp || (fw == fp && mean_chi2(with) < (1.0 - options.hand_eye_min_fit_gain) * mean_chi2(res));
        hand_eye_test = {{"mean_pair_chi2_with", mean_chi2(with)},
                         {"mean_pair_chi2_plain", mean_chi2(res)},
                         {"flagged_with", fw},
                         {"flagged_plain", fp},
                         {"taken", take}};
        log::info(
            "iteration {}: hand-eye offset tested on all {} scans: pairs' mean chi2 {:.3g} with it, {:.3g} without; {} "
            "and {} scans kept out: {}",
            it.index, std::count(all.begin(), all.end(), 1), mean_chi2(with), mean_chi2(res), fw, fp,
            take ? "taken" : "not taken");
        if (take) {
          res = std::move(with);
          free = std::move(all);
        }
        repass = true;
      }
    }
    const auto [moved, excluded] = apply_multiway(res, it);
    // Points of the scans before this iteration's (for the "new" flags of cloud.ply).
    const auto& sid = model.scalars.get("scan_id");
    model_size_at_last_iteration = static_cast<std::size_t>(
        std::count_if(sid.begin(), sid.end(), [&](double v) { return static_cast<int>(v) < first; }));
    json summary = registration::to_json(res);
    summary["scans_moved"] = moved;
    summary["scans_excluded"] = excluded;
    if (repass) summary["hand_eye_repass"] = true;
    if (!hand_eye_test.is_null()) summary["hand_eye_test"] = std::move(hand_eye_test);
    summary["seconds"] = seconds;
    it.registration = std::move(summary);
    it.seconds["global_registration"] = seconds;
    log::info(
        "iteration {}: global registration of {} scans: {} pairs used ({} bridging), {} dropped, {} scans kept out "
        "({:.2f} s)",
        it.index, std::count(free.begin(), free.end(), 1), it.registration["pairs_used"].get<std::size_t>(),
        it.registration["pairs_bridging"].get<std::size_t>(), it.registration["pairs_dropped"].get<std::size_t>(),
        excluded, seconds);
  }

  // One register_multiway over the free scans from `initial`, the priors centred on `centers` (none:
  // the reported poses) and widened by `widen` (translation, degrees; in quadrature).
  registration::MultiwayResult solve_multiway(const std::vector<char>& free,
                                              const std::vector<Eigen::Isometry3d>& initial,
                                              const std::vector<Eigen::Isometry3d>& centers,
                                              std::pair<double, double> widen) {
    std::vector<Vec3> sensors;
    sensors.reserve(scans.size());
    for (const auto& r : scans) sensors.push_back(r.reported_pose.position);
    reg_prepared.resize(reg_samples.size());
    auto mo = multiway_options();
    mo.robot_translation_sigma = std::hypot(mo.robot_translation_sigma, widen.first);
    mo.robot_rotation_sigma_deg = std::hypot(mo.robot_rotation_sigma_deg, widen.second);
    return registration::register_multiway(reg_samples, sensors, initial, free, mo, progress, &reg_prepared, centers);
  }

  // The last iteration's hand-eye estimate, if any.
  std::optional<registration::HandEyeEstimate> last_hand_eye() const {
    if (iterations.empty() || iterations.back().hand_eye.is_null()) return std::nullopt;
    return registration::hand_eye_from_json(iterations.back().hand_eye, "hand_eye");
  }

  // Applies a registration's corrections to its free scans and keeps out the scans it flags; returns
  // how many moved and how many were kept out.
  std::pair<int, int> apply_multiway(const registration::MultiwayResult& res, const IterationRecord& it) {
    const int n = static_cast<int>(scans.size());
    int moved = 0, excluded = 0;
    std::vector<char> moved_flags(scans.size(), 0);
    for (int i = 0; i < n; ++i) {
      const auto& rep = res.scans[static_cast<std::size_t>(i)];
      auto& r = scans[static_cast<std::size_t>(i)];
      if (!rep.free) continue;
      json g = {{"iteration", it.index},
                {"pairs_used", rep.pairs_used},
                {"mahalanobis", rep.mahalanobis},
                {"correction_translation", rep.correction_translation},
                {"correction_rotation_deg", rep.correction_rotation_deg},
                {"previous_correction", matrix_json(r.correction)},
                {"flagged", rep.flagged}};
      if (rep.flagged) {
        r.excluded = true;
        r.excluded_reason = rep.flag_reason;
        reg_samples[static_cast<std::size_t>(i)] = PointCloud{};
        reg_prepared[static_cast<std::size_t>(i)] = nullptr;
        remove_from_model(i);
        ++excluded;
        log::warn("scan {}: kept out of the model ({})", i, rep.flag_reason);
      } else if (!res.corrections[static_cast<std::size_t>(i)].isApprox(r.correction, 0.0)) {
        r.correction = res.corrections[static_cast<std::size_t>(i)];
        r.registered_pose = r.reported_pose.transformed(r.correction);
        moved_flags[static_cast<std::size_t>(i)] = 1;
        ++moved;
      }
      r.global_registration = std::move(g);
    }
    if (moved > 0) reapply_corrections(moved_flags);
    return {moved, excluded};
  }

  // The support plane of the session: the first one a scan detected (supports.hpp).
  std::optional<SupportPlane> known_support_plane() const {
    for (const auto& r : scans)
      if (r.support_plane) return r.support_plane;
    return std::nullopt;
  }

  // Flags the points of declared fixtures and of the support plane (supports.hpp), before anything
  // else sees the scan; fills the record's counts. Empty codes: nothing to flag (no fixture declared
  // and no plane detection), the scan is untouched.
  std::vector<std::uint8_t> classify_removal(const PointCloud& scan, ScanRecord& rec) {
    const SupportOptions& o = options.supports;
    if ((rig.fixtures.empty() || !o.remove_fixtures) && !o.detect_plane) return {};
    if (!fixture_geometry) fixture_geometry = std::make_unique<FixtureGeometry>(rig);
    Rng rng = Rng(options.seed).stream(kSupportStream).stream(static_cast<std::uint64_t>(rec.id));
    RemovalReport report;
    auto codes = classify_scan(scan, *fixture_geometry, o, known_support_plane(), rng, report);
    rec.removed_fixture = report.fixture;
    rec.removed_support_plane = report.support_plane;
    rec.support_plane = report.plane;
    rec.support_plane_detected = report.plane_detected;
    if (report.removed() > 0 || report.plane_detected)
      log::info("scan {}: {} of {} points removed ({} of declared fixtures, {} on or below the support plane{})",
                rec.id, report.removed(), scan.size(), report.fixture, report.support_plane,
                report.plane_detected ? ", plane detected in this scan" : "");
    return codes;
  }

  // Registers (when a model exists) and selects the points of a scan; returns the registered scan.
  PointCloud register_and_select(PointCloud& scan, ScanRecord& rec, std::vector<char>& keep) {
    Stopwatch clock;
    // With options.hand_eye_priors and a significant estimate: the scan starts where the estimated
    // hand-eye offset puts it (C Ĥ C⁻¹); ICP's correction and its bounds are on top of that.
    Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
    if (const auto h = hand_eye_offset()) {
      const Eigen::Isometry3d C = rec.reported_pose.world_from_camera();
      start = C * *h * C.inverse();
      apply_transform(scan, start);
    }
    if (options.register_scans && has_model() && !scan.empty()) {
      const auto r = registration::icp(scan, target, target_weight, options.icp);
      rec.registration = r;
      const bool improves = r.rms_after <= (1.0 - options.registration_min_improvement) * r.rms_before;
      const bool bounded = (options.registration_max_translation <= 0.0 ||
                            r.correction_translation <= options.registration_max_translation) &&
                           (options.registration_max_rotation_deg <= 0.0 ||
                            r.correction_rotation_deg <= options.registration_max_rotation_deg);
      if (r.degenerate)
        log::warn("scan {}: registration found too few correspondences; the reported pose is kept", rec.id);
      else if (!improves)
        log::debug("scan {}: registration lowered the residual only {:.4g} -> {:.4g}; the reported pose is kept",
                   rec.id, r.rms_before, r.rms_after);
      else if (!bounded)
        log::info(
            "scan {}: registration correction ({:.4g}, {:.2f} deg) exceeds the robot's accuracy; the "
            "reported pose is kept",
            rec.id, r.correction_translation, r.correction_rotation_deg);
      else
        rec.correction = r.correction;
    }
    if (!start.isApprox(Eigen::Isometry3d::Identity(), 0.0)) {
      apply_transform(scan, start.inverse());  // the caller's scan as it came
      rec.correction = rec.correction * start;
    }
    rec.seconds_registration = clock.seconds();
    rec.registered_pose = rec.reported_pose.transformed(rec.correction);
    PointCloud registered = scan;
    apply_transform(registered, rec.correction);
    clock.reset();
    if (options.selective_insertion && has_model()) {
      Rng rng = Rng(options.seed).stream(kInsertionStream).stream(static_cast<std::uint64_t>(rec.id));
      keep = selective_insertion_mask(registered.positions, registered.normals, iso_positions, iso_normals, iso_f,
                                      options.rho, rng, options.insertion_neighbours, options.insertion_normal_deg);
    } else {
      keep.assign(registered.size(), 1);
    }
    rec.quality_refused = 0;
    if (options.quality_insertion_ratio > 0.0 && has_model()) {
      if (const auto* q = registered.scalars.find(kDepthSigmaColumn))
        rec.quality_refused = quality_gate.apply(registered.positions, *q, options.quality_insertion_ratio, keep);
    }
    rec.inserted = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), 1));
    rec.seconds_insertion = clock.seconds();
    return registered;
  }

  // ---- the steps of next_views ----

  // The answer of a session that has stopped: the last iteration's reason, no views.
  NextViews stopped_answer() const {
    NextViews ans;
    ans.stopped = true;
    ans.reason = stop_reason;
    ans.iteration = iterations.empty() ? -1 : iterations.back().index;
    if (ans.iteration >= 0) ans.directory = layout().iteration_dir(ans.iteration);
    return ans;
  }

  // Iteration k's record: the scans added since the last iteration and their timings.
  IterationRecord start_iteration(int k) const {
    IterationRecord it;
    it.index = k;
    for (int s = pending_from(); s < static_cast<int>(scans.size()); ++s) it.scans.push_back(s);
    for (int s : it.scans) {
      it.seconds["registration"] += scans[s].seconds_registration;
      it.seconds["insertion"] += scans[s].seconds_insertion;
    }
    return it;
  }

  // The reconstruction's figures into the iteration's record.
  void record_reconstruction(const Reconstruction& rec, IterationRecord& it) const {
    for (const auto& [stage, s] : rec.seconds) it.seconds[stage] = s;
    it.raw_points = model.size();
    it.consolidated_points = rec.consolidated.size();
    it.mesh_vertices = rec.mesh.vertices.size();
    it.iso_points = rec.iso_points.size();
    it.mean_f = rec.mean_f;
    it.mean_f_g = rec.mean_f_g;
    it.mean_f_s = rec.mean_f_s;
    if (it.index > 0) it.delta_mean_f = rec.mean_f - iterations.back().mean_f;
  }

  // Where the object touches its support (declared, or the detected plane): unreachable from the start.
  std::optional<SupportContact> support_contact() const {
    if (const auto h = rig.support_height())
      return SupportContact{SupportPlane{Vec3::UnitZ(), *h}, options.supports.contact_tolerance};
    if (const auto pl = known_support_plane()) return SupportContact{*pl, options.supports.contact_tolerance};
    return std::nullopt;
  }

  // With options.hand_eye_priors and a significant estimate at the last iteration: that offset.
  std::optional<Eigen::Isometry3d> hand_eye_offset() const {
    if (!options.hand_eye_priors) return std::nullopt;
    const auto e = last_hand_eye();
    if (!e || !e->significant) return std::nullopt;
    return e->offset;
  }
  // Whether `now` (significant) moves the priors: no estimate was applied yet, or it differs from the
  // applied one by more than twice its standard errors.
  bool hand_eye_changed(const registration::HandEyeEstimate& now) const {
    if (!now.significant) return false;
    const auto was = last_hand_eye();
    if (!was || !was->significant) return true;
    return (now.translation - was->translation).norm() > 2.0 * now.translation_se ||
           (now.rotation_deg - was->rotation_deg).norm() > 2.0 * now.rotation_se_deg;
  }
  // Per scan, the world-frame correction an offset H explains, C_i H C_i⁻¹ (the priors' centres).
  std::vector<Eigen::Isometry3d> prior_centers_for(const Eigen::Isometry3d& H) const {
    std::vector<Eigen::Isometry3d> out;
    out.reserve(scans.size());
    for (const auto& s : scans) {
      const Eigen::Isometry3d C = s.reported_pose.world_from_camera();
      out.push_back(C * H * C.inverse());
    }
    return out;
  }
  std::vector<Eigen::Isometry3d> hand_eye_prior_centers() const {
    const auto h = hand_eye_offset();
    return h ? prior_centers_for(*h) : std::vector<Eigen::Isometry3d>{};
  }

  // The robot's hand-eye offset from the scans kept, reported against registered
  // (registration/hand_eye.hpp); null with fewer than 2. `solution`: registered = reported with its
  // corrections instead of the scans' own, its flagged scans left out. `say`: log a significant one.
  json hand_eye_estimate(const registration::MultiwayResult* solution = nullptr, bool say = true) const {
    std::vector<Eigen::Isometry3d> commanded, registered;
    for (std::size_t i = 0; i < scans.size(); ++i) {
      const auto& s = scans[i];
      if (s.excluded || (solution && solution->scans[i].flagged)) continue;
      commanded.push_back(s.reported_pose.world_from_camera());
      registered.push_back(solution ? s.reported_pose.transformed(solution->corrections[i]).world_from_camera()
                                    : s.registered_pose.world_from_camera());
    }
    if (commanded.size() < 2) return nullptr;
    const auto e = registration::estimate_hand_eye(commanded, registered);
    if (e.significant && say)
      log::info(
          "hand-eye offset: ({:.4g}, {:.4g}, {:.4g}) ± {:.2g}, rotation ({:.3g}, {:.3g}, {:.3g}) deg ± {:.2g} "
          "from {} scans{}",
          e.translation.x(), e.translation.y(), e.translation.z(), e.translation_se, e.rotation_deg.x(),
          e.rotation_deg.y(), e.rotation_deg.z(), e.rotation_se_deg, e.scans,
          e.observable ? "" : " (one motion axis: the part about and along it is not seen)");
    return registration::to_json(e);
  }

  // The quality certificate (docs/stop-rule.md), tracked from the previous iteration's.
  Certificate certify(const Reconstruction& rec, IterationRecord& it) const {
    Stopwatch cclock;
    const int k = it.index;
    std::optional<Certificate> previous;
    if (k > 0 && iterations.back().certificate.is_object())
      previous = certificate_from_json(iterations.back().certificate, "previous certificate");
    const std::optional<SupportContact> contact = support_contact();
    Certificate cert = compute_certificate(k, rec.mesh, rec.iso_points, rec.consolidated, scanner, options.stop,
                                           previous ? &*previous : nullptr, contact ? &*contact : nullptr);
    it.seconds["certificate"] = cclock.seconds();
    return cert;
  }

  // Why iteration k stops, or "" to plan views: the stop rule (options.stop.rule), then the budgets.
  std::string stop_reason_of(int k, const Reconstruction& rec, const Certificate& cert) const {
    std::string reason;
    if (options.stop.rule == StopRule::paper) {  // §5.3
      if (k > 0 && confidence_converged(iterations.back().mean_f, rec.mean_f, options.stop_threshold))
        reason = "converged";
      else if (k > 0 && options.stop_when_confidence_falls &&
               iterations.back().mean_f - rec.mean_f >= options.stop_threshold)
        reason = "confidence_fell";
    } else {
      std::optional<double> best_before;
      for (const auto& prev : iterations) best_before = std::max(best_before.value_or(prev.mean_f), prev.mean_f);
      reason = remaining_rule(cert, rec.mean_f, best_before, options.stop);
      // The most accurate model lies best_rounds iterations back: stop, it is the result. Checked
      // before "complete" so that the result is that model, not this one.
      if ((reason.empty() || reason == "complete") && options.stop.best_rounds > 0) {
        const AccuracyBest b = accuracy_best(&cert);
        if (b.best >= 0 && b.after >= options.stop.best_rounds) {
          log::info(
              "iteration {}: the model was most accurate at iteration {} (fit residual {:.3g} against {:.3g} now): "
              "stop, the result is iteration {} (past_best)",
              k, b.best, iterations[static_cast<std::size_t>(b.best)].certificate.value("fit_residual", 0.0),
              cert.fit_residual, b.best);
          reason = "past_best";
        }
      }
    }
    if (reason.empty() && k + 1 >= options.max_iterations)
      reason = "max_iterations";
    else if (reason.empty() && views_planned >= options.max_views)
      reason = "max_views";
    return reason;
  }

  // The planner's views from `current` for iteration k, cut to the view budget left; the certificate
  // counts the views aimed at each of its regions. An empty plan stops the session ("no_views").
  planners::PlanOutput plan_views(int k, const Pose& current, const Reconstruction& rec, Certificate& cert,
                                  IterationRecord& it) {
    Stopwatch clock;
    planners::ModelState state;
    state.iteration = k;
    state.raw = model;
    state.consolidated = rec.consolidated;
    state.field = rec.field;
    state.reference_gradient = rec.reference_gradient;
    state.mesh = rec.mesh;
    state.iso_points = rec.iso_points;
    // Regions that views looked at without improving them draw no more views (docs/stop-rule.md).
    if (options.stop.rule == StopRule::remaining) {
      const std::size_t masked = mask_settled_regions(cert, state.iso_points);
      if (masked > 0)
        log::info("iteration {}: {} iso-points in unreachable or too noisy regions draw no views", k, masked);
    }
    state.mean_f = rec.mean_f;
    state.scanner = scanner;
    state.rig = rig;
    // A support plane the session detected binds the planner as a declared one would: no view below.
    if (!rig.support_height())
      if (const auto pl = known_support_plane(); pl && pl->normal.z() > 0.5) {
        Fixture detected;
        detected.name = "detected support plane";
        detected.height = pl->offset / pl->normal.z();
        detected.half_extent = kMaxCoordinate / 2;
        state.rig.fixtures.push_back(detected);
      }
    // Poses the robot refused (refuse_view): the planner's rig treats a ball around each as solid.
    if (!refused.empty()) {
      std::vector<Vec3> at;
      for (const auto& r : refused) at.push_back(r.pose.position);
      const double radius = Session::kRefusedViewRadius * scanner.near;
      state.rig.inside_solid = [solid = state.rig.inside_solid, at = std::move(at), radius](const Vec3& p) {
        for (const auto& q : at)
          if ((p - q).squaredNorm() < radius * radius) return true;
        return solid ? solid(p) : false;
      };
    }
    state.acquired_bounds = model.bounds();
    for (const auto& s : scans) state.scan_poses.push_back(s.registered_pose);
    Rng rng = Rng(options.seed).stream(kPlannerStream).stream(static_cast<std::uint64_t>(k));
    planners::PlanOutput plan = planner->plan(state, current, rng);
    const auto budget = static_cast<std::size_t>(options.max_views - views_planned);
    if (plan.views.size() > budget) {
      plan.views.resize(budget);
      plan.path_length = planners::path_length(rig, current, plan.views);
    }
    it.planner_diagnostics = plan.diagnostics;
    std::vector<Vec3> targets;
    for (const auto& v : plan.views) targets.push_back(v.target);
    count_views_aimed(cert, targets);
    it.seconds["plan"] = clock.seconds();
    if (plan.views.empty()) it.stop_reason = "no_views";
    return plan;
  }

  // Iteration k's artefacts (iterations/iter_KKK/): the model with its new points, the consolidated
  // points, the mesh (and its coloured copy), the iso-points and the views. Returns the directory.
  fs::path write_iteration(int k, const Reconstruction& rec, const planners::PlanOutput& plan,
                           IterationRecord& it) const {
    Stopwatch wclock;
    const SessionLayout L = layout();
    const fs::path idir = L.iteration_dir(k);
    std::error_code ec;
    fs::create_directories(idir, ec);
    if (ec) throw RuntimeError(fmt::format("{}: cannot create: {}", idir.string(), ec.message()));
    {
      PointCloud cloud = model;
      std::vector<double> fresh(cloud.size(), 0.0);
      for (std::size_t i = model_size_at_last_iteration; i < cloud.size(); ++i) fresh[i] = 1.0;
      cloud.scalars.set("new", std::move(fresh));
      io::write_point_cloud(L.cloud(k), cloud);
    }
    io::write_point_cloud(L.consolidated(k), rec.consolidated, exact_ply());
    if (!rec.mesh.empty()) {
      // Double coordinates: a driver that evaluates the mesh after a restart (the simulator's truth
      // figures) reads back exactly the mesh of this iteration.
      io::WriteOptions exact;
      exact.double_coordinates = true;
      if (support_contact()) {  // which part of the closed surface data supports (docs/supports.md)
        TriangleMesh marked = rec.mesh;
        marked.vertex_scalars.set("supported", vertex_data_support(rec.mesh, rec.consolidated));
        io::write_mesh(L.mesh(k), marked, exact);
      } else {
        io::write_mesh(L.mesh(k), rec.mesh, exact);
      }
      if (rec.surface_colors.size() == rec.mesh.vertices.size()) {
        // The coloured model (docs/colour.md): the same mesh with the surface colours.
        TriangleMesh colored;
        colored.vertices = rec.mesh.vertices;
        colored.faces = rec.mesh.faces;
        colored.vertex_normals = rec.mesh.vertex_normals;
        colored.vertex_colors = rec.surface_colors;
        io::write_mesh(L.mesh_color(k), colored, exact);
      }
    }
    io::write_point_cloud(L.iso(k), rec.iso_points, exact_ply());
    json extra = {{"iteration", k},
                  {"planner", options.planner},
                  {"stopped", it.stopped},
                  {"stop_reason", it.stopped ? json(it.stop_reason) : json(nullptr)},
                  {"mean_f", it.mean_f}};
    write_text_atomic(L.views(k), planners::views_to_json(plan, extra).dump(1) + "\n");
    if (plan.write_artifacts) plan.write_artifacts(idir);
    it.seconds["write"] = wclock.seconds();
    return idir;
  }

  // The iteration into the session's state, then session.json (last: an iteration interrupted
  // before is simply recomputed after open()).
  void commit_iteration(const IterationRecord& it, const Reconstruction& rec) {
    views_planned += it.views;
    stopped = it.stopped;
    stop_reason = it.stop_reason;
    iterations.push_back(it);
    update_best();
    model_size_at_last_iteration = model.size();
    set_target(rec.consolidated, rec.iso_points);
    if (stopped) write_result_model();
    persist();
  }

  // ---- the steps of open ----

  // Takes the validated content of session.json; returns its scan records (replayed by replay_scan).
  std::vector<ScanRecord> apply(SessionFile stored, const std::string& where) {
    scanner = std::move(stored.scanner);
    rig = std::move(stored.rig);
    options = std::move(stored.options);
    current_pose = stored.current_pose;
    views_planned = stored.views_planned;
    refused = std::move(stored.refused_views);
    stopped = stored.stopped;
    stop_reason = std::move(stored.stop_reason);
    iterations = std::move(stored.iterations);
    best_iteration = stored.best_iteration;
    // finish() named the result: the truth's later figures do not move it, after a resume as before.
    best_fixed = stopped && stop_reason == "quality_fell_truth";
    if (best_iteration < 0) update_best();  // a session written before the field
    make_planner_object();
    // What the planner fixed at an earlier plan() (an occupancy grid's frame), before the replay.
    if (!stored.planner_state.is_null() && planner)
      planner->restore_state(stored.planner_state, where + ": planner_state");
    return std::move(stored.scans);
  }

  // Scan files session.json does not name. A crash during add_scan leaves at most the files of the
  // next id (written, never acknowledged): those are returned, to be set aside. Anything beyond means
  // that session.json does not describe this directory (edited, truncated, or an older copy):
  // refused, nothing moved.
  std::vector<fs::path> unacknowledged_scans(std::size_t referenced, const std::string& where) const {
    std::error_code ec;
    std::vector<fs::path> orphans;
    const fs::path scans_dir = layout().scans_dir();
    if (!fs::is_directory(scans_dir, ec)) return orphans;
    for (const auto& e : fs::directory_iterator(scans_dir, ec)) {
      const std::optional<std::size_t> id = SessionLayout::scan_id_of(e.path().filename().string());
      if (!id || *id < referenced) continue;
      AUTOSCAN_REQUIRE(*id == referenced,
                       "{}: scans: lists {} scans but {} exists: session.json does not describe the scan files (was "
                       "it edited or replaced?); nothing was moved",
                       where, referenced, e.path().string());
      orphans.push_back(e.path());
    }
    return orphans;
  }

  // Rebuilds the model with one acknowledged scan, exactly as add_scan built it (reads only).
  void replay_scan(ScanRecord& rec) {
    std::error_code ec;
    const fs::path file = layout().scan_ply(rec.id);
    PointCloud scan;
    if (rec.points > 0) {
      AUTOSCAN_REQUIRE(fs::exists(file, ec), "{}: acknowledged scan file is missing", file.string());
      scan = io::read_point_cloud(file);
    }
    AUTOSCAN_REQUIRE(scan.size() == rec.points, "{}: holds {} points, session.json says {}", file.string(), scan.size(),
                     rec.points);
    std::vector<char> keep(scan.size(), 1);
    if (const auto* ins = scan.scalars.find("inserted")) {
      for (std::size_t k = 0; k < scan.size(); ++k) keep[k] = (*ins)[k] != 0.0 ? 1 : 0;
      scan.scalars.erase("inserted");
    }
    drop_removed(scan, keep);  // supports.hpp: what add_scan removed stays out
    AUTOSCAN_REQUIRE(static_cast<std::size_t>(std::count(keep.begin(), keep.end(), 1)) == rec.inserted,
                     "{}: insertion flags disagree with session.json", file.string());
    // As add_scan computed it (a session written before quality-weighted fusion has no column).
    if (!scan.empty() && fusion_on())
      scan.scalars.set(kDepthSigmaColumn, predicted_depth_sigma(scan, scanner));
    else
      scan.scalars.erase(kDepthSigmaColumn);
    PointCloud registered = scan;
    apply_transform(registered, rec.correction);
    if (planner) {
      // As add_scan showed it to the planner: with the correction of that time.
      if (rec.added_correction.isApprox(rec.correction, 0.0)) {
        planner->observe_scan(registered, rec.registered_pose);
      } else {
        PointCloud observed = scan;
        apply_transform(observed, rec.added_correction);
        planner->observe_scan(observed, rec.reported_pose.transformed(rec.added_correction));
      }
    }
    if (!rec.excluded) append_to_model(scan, registered, keep);
    reg_samples.push_back(rec.excluded ? PointCloud{} : registration_sample(scan));
    scans.push_back(std::move(rec));
  }

  // After the replay: the model size at the last iteration and its registration target.
  void restore_last_iteration() {
    // Points inserted before the last iteration: the scans it (and earlier ones) used.
    const int used = pending_from();
    std::size_t n = 0;
    for (int i = 0; i < used && i < static_cast<int>(scans.size()); ++i)
      if (!scans[static_cast<std::size_t>(i)].excluded) n += scans[static_cast<std::size_t>(i)].inserted;
    model_size_at_last_iteration = n;
    if (!iterations.empty()) {
      const int last = iterations.back().index;
      PointCloud consolidated = io::read_point_cloud(layout().consolidated(last));
      PointCloud iso = io::read_point_cloud(layout().iso(last));
      set_target(consolidated, iso);
    }
  }

  // Tidies up after a crash, with everything read and consistent: temporary files of the session's
  // own atomic writes (in every iteration directory, recorded or not: an interrupted next_views
  // leaves them in the one it was writing), then the unacknowledged scan's files (to scans/orphaned/).
  void tidy_after_crash(std::vector<fs::path> orphans) const {
    const SessionLayout L = layout();
    std::error_code ec;
    remove_temporaries(dir);
    remove_temporaries(L.scans_dir());
    if (fs::is_directory(L.iterations_dir(), ec)) {
      for (const auto& e : fs::directory_iterator(L.iterations_dir(), ec))
        if (SessionLayout::is_iteration_name(e.path().filename().string())) remove_temporaries(e.path());
    }
    std::sort(orphans.begin(), orphans.end());
    if (!orphans.empty()) fs::create_directories(L.orphaned_dir(), ec);
    for (const auto& p : orphans) {
      fs::path to;
      for (int k = 0;; ++k) {
        to = L.orphaned_dir() / fmt::format("{}.{}", p.filename().string(), k);
        if (!fs::exists(to, ec)) break;
      }
      fs::rename(p, to, ec);
      log::warn("{}: scan file not acknowledged before an interruption; moved to {}", p.string(), to.string());
    }
  }
};

Session::Session(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Session::Session(Session&&) noexcept = default;
Session& Session::operator=(Session&&) noexcept = default;
Session::~Session() = default;

Session Session::create(const fs::path& dir, const ScannerSpec& scanner, const Rig& rig,
                        const SessionOptions& options) {
  scanner.validate("scanner");
  rig.validate("rig");
  options.validate();
  std::error_code ec;
  AUTOSCAN_REQUIRE(!dir.empty(), "session: no directory given");
  const SessionLayout layout(dir);
  AUTOSCAN_REQUIRE(!fs::exists(layout.session_json(), ec), "{}: already holds a session (use open to resume)",
                   dir.string());
  AUTOSCAN_REQUIRE(!fs::exists(dir, ec) || fs::is_directory(dir, ec), "{}: exists and is not a directory",
                   dir.string());
  fs::create_directories(layout.scans_dir(), ec);
  if (ec) throw RuntimeError(fmt::format("{}: cannot create the session directory: {}", dir.string(), ec.message()));
  fs::create_directories(layout.iterations_dir(), ec);
  auto impl = std::make_unique<Impl>();
  impl->dir = dir;
  impl->lock();
  impl->scanner = scanner;
  impl->rig = rig;
  impl->options = options;
  impl->make_planner_object();  // validates the planner name and its options before anything is written
  impl->persist();
  return Session(std::move(impl));
}

Session Session::open(const fs::path& dir) {
  std::error_code ec;
  const SessionLayout layout(dir);
  AUTOSCAN_REQUIRE(fs::is_directory(dir, ec), "{}: no such session directory", dir.string());
  AUTOSCAN_REQUIRE(fs::exists(layout.session_json(), ec), "{}: not a session directory (no session.json)",
                   dir.string());
  auto impl = std::make_unique<Impl>();
  impl->dir = dir;
  impl->lock();
  const std::string where = layout.session_json().string();
  // 1. The whole file is validated (types, ranges, consistency) before anything is applied or any
  //    file is touched: a file that cannot be read moves no data (issue 21).
  std::vector<ScanRecord> records =
      impl->apply(parse_session_json(read_text_file(layout.session_json()), where), where);
  // 2. Scan files session.json does not name (refused, or set aside in step 4).
  std::vector<fs::path> orphans = impl->unacknowledged_scans(records.size(), where);
  // 3. Rebuild the model from the acknowledged scans, exactly as add_scan built it (reads only).
  for (auto& rec : records) impl->replay_scan(rec);
  impl->restore_last_iteration();
  // 4. Only now, with everything read and consistent, tidy up after a crash.
  impl->tidy_after_crash(std::move(orphans));
  return Session(std::move(impl));
}

ScanRecord Session::add_scan(const PointCloud& scan_in, const Pose& reported_pose) {
  auto& m = *impl_;
  reported_pose.validate("scan pose");
  scan_in.validate("scan");
  ScanRecord rec;
  rec.id = static_cast<int>(m.scans.size());
  rec.points = scan_in.size();
  rec.reported_pose = reported_pose;
  rec.model_iteration = m.iterations.empty() ? -1 : m.iterations.back().index;

  PointCloud scan = scan_in;
  scan.scalars.erase("inserted");
  scan.scalars.erase(kRemovedColumn);
  scan.scalars.set("scan_id", std::vector<double>(scan.size(), static_cast<double>(rec.id)));
  if (!(scan.scalars.has("sensor_x") && scan.scalars.has("sensor_y") && scan.scalars.has("sensor_z"))) {
    const Vec3 s = reported_pose.position;
    scan.scalars.set("sensor_x", std::vector<double>(scan.size(), s.x()));
    scan.scalars.set("sensor_y", std::vector<double>(scan.size(), s.y()));
    scan.scalars.set("sensor_z", std::vector<double>(scan.size(), s.z()));
  }
  // The depth uncertainty the scanner's model predicts for each point (docs/fusion.md), only when
  // fusion uses it: off, add_scan does no extra work.
  if (m.fusion_on()) scan.scalars.set(kDepthSigmaColumn, predicted_depth_sigma(scan, m.scanner));
  // Fixtures and the support plane (supports.hpp): flagged, kept in the file, out of everything else.
  const std::vector<std::uint8_t> removal = m.classify_removal(scan, rec);
  const std::size_t removed = rec.removed_fixture + rec.removed_support_plane;
  PointCloud received;
  if (removed > 0) {
    received = scan;
    scan = kept_points(received, removal);
  }
  std::vector<char> keep;
  PointCloud registered = m.register_and_select(scan, rec, keep);
  rec.added_correction = rec.correction;

  // Persist: the scan file (as received, with the insertion flags), its sidecar, then session.json.
  // Until session.json names it the scan is not acknowledged; open() sets such files aside. A write
  // that fails (a full disk) removes this call's files and changes nothing in memory: a retry does
  // not leave another copy behind.
  const fs::path ply_path = m.layout().scan_ply(rec.id);
  const fs::path json_path = m.layout().scan_json(rec.id);
  bool wrote_ply = false, wrote_json = false;
  try {
    if (removed > 0) {
      // Every point received, the removed ones flagged with their reason and never inserted.
      PointCloud stored = received;
      std::vector<double> ins(stored.size(), 0.0), why(removal.begin(), removal.end());
      for (std::size_t i = 0, k = 0; i < stored.size(); ++i)
        if (removal[i] == 0) ins[i] = keep[k++];
      stored.scalars.set("inserted", std::move(ins));
      stored.scalars.set(kRemovedColumn, std::move(why));
      io::write_point_cloud(ply_path, stored, exact_ply());
      wrote_ply = true;
    } else if (!scan.empty()) {
      PointCloud stored = scan;
      std::vector<double> ins(keep.begin(), keep.end());
      stored.scalars.set("inserted", std::move(ins));
      io::write_point_cloud(ply_path, stored, exact_ply());
      wrote_ply = true;
    }
    write_text_atomic(json_path, to_json(rec).dump(1) + "\n");
    wrote_json = true;
    json all = m.to_json_all();
    all["scans"].push_back(to_json(rec));
    all["model_points"] = m.model.size() + rec.inserted;
    all["current_pose"] = to_json(rec.registered_pose);
    m.write_session_json(all);
  } catch (...) {
    std::error_code ec;
    if (wrote_ply) fs::remove(ply_path, ec);
    if (wrote_json) fs::remove(json_path, ec);
    throw;
  }
  if (m.planner) m.planner->observe_scan(registered, rec.registered_pose);
  m.append_to_model(scan, registered, keep);
  m.reg_samples.push_back(m.registration_sample(scan));
  m.scans.push_back(rec);
  m.current_pose = rec.registered_pose;
  return rec;
}

NextViews Session::next_views() {
  AUTOSCAN_REQUIRE(impl_->current_pose.has_value(), "next_views: no current pose known (give one, or add a scan)");
  return next_views(*impl_->current_pose);
}

NextViews Session::next_views(const Pose& current) {
  auto& m = *impl_;
  current.validate("current pose");
  if (m.stopped) return m.stopped_answer();
  AUTOSCAN_REQUIRE(!m.scans.empty(), "next_views: the session has no scan yet (add the blind scans first)");
  AUTOSCAN_REQUIRE(!m.model.empty(), "next_views: the scans hold no points");
  m.current_pose = current;
  const int k = static_cast<int>(m.iterations.size());
  IterationRecord it = m.start_iteration(k);
  m.global_registration(it);
  AUTOSCAN_REQUIRE(!m.model.empty(), "next_views: every scan was kept out of the model (see session status)");
  it.hand_eye = m.hand_eye_estimate();

  auto rec = std::make_shared<Reconstruction>(m.reconstructor(m.model, m.options, m.progress));
  m.record_reconstruction(*rec, it);
  Certificate cert = m.certify(*rec, it);
  it.stop_reason = m.stop_reason_of(k, *rec, cert);
  planners::PlanOutput plan;
  if (it.stop_reason.empty()) plan = m.plan_views(k, current, *rec, cert, it);
  it.views = static_cast<int>(plan.views.size());
  it.path_length = plan.path_length;
  it.stopped = !it.stop_reason.empty();
  it.certificate = to_json(cert);
  log::info(
      "iteration {}: {:.1f} % of the surface above confidence {:.3f}; {:.1f} % left that views can improve, "
      "{:.1f} % unreachable, {:.1f} % too noisy ({} regions){}",
      k, 100.0 * cert.share_confident, cert.threshold, 100.0 * cert.share_improvable, 100.0 * cert.share_unreachable,
      100.0 * cert.share_too_noisy, cert.regions.size(), it.stopped ? "; stop: " + it.stop_reason : std::string());

  // Artefacts first (iterations/iter_KKK/), session.json last: an interrupted iteration is simply
  // recomputed after open().
  const fs::path idir = m.write_iteration(k, *rec, plan, it);
  m.commit_iteration(it, *rec);

  NextViews ans;
  ans.views = std::move(plan.views);
  ans.path_length = plan.path_length;
  ans.stopped = it.stopped;
  ans.reason = it.stop_reason;
  ans.iteration = k;
  ans.directory = idir;
  ans.reconstruction = std::move(rec);
  return ans;
}

void Session::finish(const std::string& reason, int best) {
  auto& m = *impl_;
  AUTOSCAN_REQUIRE(!reason.empty(), "finish: no reason given");
  AUTOSCAN_REQUIRE(!m.iterations.empty(), "finish: the session has no iteration yet");
  AUTOSCAN_REQUIRE(best >= 0 && best < static_cast<int>(m.iterations.size()),
                   "finish: no iteration {} (the session has {})", best, m.iterations.size());
  if (m.stopped) return;
  auto& last = m.iterations.back();
  last.stopped = true;
  last.stop_reason = reason;
  m.stopped = true;
  m.stop_reason = reason;
  m.best_iteration = best;
  m.best_fixed = true;
  m.write_result_model();
  m.persist();
}

int Session::best_iteration() const { return impl_->best_iteration; }

void Session::attach_truth(int index, const json& truth) {
  auto& m = *impl_;
  AUTOSCAN_REQUIRE(index >= 0 && index < static_cast<int>(m.iterations.size()),
                   "attach_truth: no iteration {} (the session has {})", index, m.iterations.size());
  m.iterations[static_cast<std::size_t>(index)].truth = truth;
  if (m.options.stop.quality_by_truth && !m.best_fixed) {
    const int before = m.best_iteration;
    m.update_best();
    if (m.stopped && m.best_iteration != before) m.write_result_model();
  }
  m.persist();
}

void Session::refuse_view(const Pose& pose, const std::string& reason) {
  pose.validate("refuse_view: pose");
  auto& m = *impl_;
  m.refused.push_back({pose, reason});
  m.persist();
  log::info("view at ({:.4g}, {:.4g}, {:.4g}) refused ({}): no view within {:.3g} of it is planned again",
            pose.position.x(), pose.position.y(), pose.position.z(), reason.empty() ? "no reason given" : reason,
            kRefusedViewRadius * m.scanner.near);
}

const std::vector<RefusedView>& Session::refused_views() const { return impl_->refused; }

SessionStatus Session::status() const {
  const auto& m = *impl_;
  SessionStatus s;
  s.directory = m.dir;
  s.planner = m.options.planner;
  s.scans = static_cast<int>(m.scans.size());
  s.model_points = m.model.size();
  s.iterations = static_cast<int>(m.iterations.size());
  s.views_planned = m.views_planned;
  s.stopped = m.stopped;
  s.stop_reason = m.stop_reason;
  if (!m.iterations.empty()) s.last_mean_f = m.iterations.back().mean_f;
  s.best_iteration = m.best_iteration;
  if (!m.iterations.empty()) s.certificate = m.iterations.back().certificate;
  if (!m.iterations.empty()) s.hand_eye = m.iterations.back().hand_eye;
  s.current_pose = m.current_pose;
  s.pending_scans = static_cast<int>(m.scans.size()) - m.pending_from();
  s.excluded_scans =
      static_cast<int>(std::count_if(m.scans.begin(), m.scans.end(), [](const ScanRecord& r) { return r.excluded; }));
  s.refused_views = static_cast<int>(m.refused.size());
  if (!m.iterations.empty() && m.iterations.back().registration.is_object()) {
    const auto& g = m.iterations.back().registration;
    s.registration = {{"iteration", m.iterations.back().index},
                      {"pairs_used", g.value("pairs_used", 0)},
                      {"pairs_dropped", g.value("pairs_dropped", 0)},
                      {"pairs_bridging", g.value("pairs_bridging", 0)},
                      {"scans_moved", g.value("scans_moved", 0)},
                      {"scans_excluded", g.value("scans_excluded", 0)},
                      {"seconds", g.value("seconds", 0.0)}};
  }
  return s;
}

const fs::path& Session::directory() const { return impl_->dir; }
const SessionOptions& Session::options() const { return impl_->options; }
const ScannerSpec& Session::scanner() const { return impl_->scanner; }
const Rig& Session::rig() const { return impl_->rig; }
const std::vector<ScanRecord>& Session::scans() const { return impl_->scans; }
const std::vector<IterationRecord>& Session::iterations() const { return impl_->iterations; }
const PointCloud& Session::model_points() const { return impl_->model; }
void Session::set_reconstructor(Reconstructor r) {
  AUTOSCAN_REQUIRE(static_cast<bool>(r), "set_reconstructor: empty reconstructor");
  impl_->reconstructor = std::move(r);
}
void Session::set_progress(ProgressCallback cb) { impl_->progress = std::move(cb); }

}  // namespace autoscan::session
