// SessionOptions ↔ JSON. Each options struct lists its fields once (fields() below); one writer and
// one reader walk those lists, so the JSON form, the defaults and the unknown-key check never drift.
#include "autoscan/session/options.hpp"

#include <set>
#include <type_traits>

#include "autoscan/core/error.hpp"

namespace autoscan::session {

namespace {

// ---- field lists ------------------------------------------------------------------------------
template <class V>
void fields(consolidate::OutlierOptions& o, V& v) {
  v("enabled", o.enabled);
  v("k", o.k);
  v("std_ratio", o.std_ratio);
  v("min_spread", o.min_spread);
}
template <class V>
void fields(consolidate::RadiusFilterOptions& o, V& v) {
  v("radius", o.radius);
  v("min_neighbors", o.min_neighbors);
}
template <class V>
void fields(consolidate::ThinningOptions& o, V& v) {
  v("voxel_size", o.voxel_size);
  v("max_points", o.max_points);
}
template <class V>
void fields(consolidate::WlopOptions& o, V& v) {
  v("mode", o.mode);
  v("noise_hint", o.noise_hint);
  v("select_percentage", o.select_percentage);
  v("radius", o.radius);
  v("radius_factor", o.radius_factor);
  v("spacing_k", o.spacing_k);
  v("iterations", o.iterations);
  v("uniform_sampling", o.uniform_sampling);
  v("parallel", o.parallel);
  v("seed", o.seed);
}
template <class V>
void fields(consolidate::SmoothingOptions& o, V& v) {
  v("enabled", o.enabled);
  v("k", o.k);
  v("degree", o.degree);
  v("iterations", o.iterations);
  v("project_wlop", o.project_wlop);
  v("jet_normals", o.jet_normals);
}
template <class V>
void fields(consolidate::NormalOptions& o, V& v) {
  v("enabled", o.enabled);
  v("k", o.k);
  v("orientation", o.orientation);
  v("mst_k", o.mst_k);
  v("mst_crossing_weight", o.mst_crossing_weight);
  v("sheet_refinement", o.sheet_refinement);
}
template <class V>
void fields(consolidate::ConsolidateOptions& o, V& v) {
  v("outliers", o.outliers);
  v("radius_filter", o.radius_filter);
  v("thinning", o.thinning);
  v("smoothing", o.smoothing);
  v("wlop", o.wlop);
  v("normals", o.normals);
}
template <class V>
void fields(poisson::PoissonOptions& o, V& v) {
  v("depth", o.depth);
  v("screening", o.screening);
  v("samples_per_node", o.samples_per_node);
  v("normal_smoothing", o.normal_smoothing);
  v("scale", o.scale);
  v("full_depth", o.full_depth);
  v("fine_iterations", o.fine_iterations);
  v("coarse_max_iterations", o.coarse_max_iterations);
  v("coarse_tolerance", o.coarse_tolerance);
  v("weight_scalar", o.weight_scalar);
  v("vertex_refinement", o.vertex_refinement);
  v("extract_mesh", o.extract_mesh);
  v("trim", o.trim);
  v("min_points", o.min_points);
}
template <class V>
void fields(confidence::IsoPointOptions& o, V& v) {
  v("count", o.count);
  v("spacing", o.spacing);
  v("candidate_factor", o.candidate_factor);
  v("elimination_alpha", o.elimination_alpha);
  v("projection_steps", o.projection_steps);
  v("max_step_fraction", o.max_step_fraction);
  v("seed", o.seed);
}
template <class V>
void fields(confidence::ConfidenceOptions& o, V& v) {
  v("iso", o.iso);
  v("k", o.k);
  v("theta_divisor", o.theta_divisor);
  v("phi_divisor", o.phi_divisor);
  v("reference_smoothness", o.reference_smoothness);
  v("mesh_neighbours", o.mesh_neighbours);
}
template <class V>
void fields(nbv::NbvOptions& o, V& v) {
  v("grid_resolution", o.grid_resolution);
  v("sigma_deg", o.sigma_deg);
  v("distance_width_factor", o.distance_width_factor);
  v("upsilon_radius_factor", o.upsilon_radius_factor);
  v("cells", o.cells);
  v("min_score", o.min_score);
  v("max_views", o.max_views);
  v("visibility_offset", o.visibility_offset);
  v("tolerance", o.tolerance);
  v("method", o.method);
  v("block_size", o.block_size);
  v("cluster_size", o.cluster_size);
  v("optimize_path", o.optimize_path);
}
template <class V>
void fields(registration::IcpOptions& o, V& v) {
  v("max_iterations", o.max_iterations);
  v("max_correspondence_distance", o.max_correspondence_distance);
  v("trim_fraction", o.trim_fraction);
  v("translation_tolerance", o.translation_tolerance);
  v("rotation_tolerance_deg", o.rotation_tolerance_deg);
  v("point_to_plane", o.point_to_plane);
  v("allow_point_to_point", o.allow_point_to_point);
  v("max_source_points", o.max_source_points);
  v("min_correspondences", o.min_correspondences);
  v("weights_are_precisions", o.weights_are_precisions);
  v("damping", o.damping);
}
template <class V>
void fields(registration::SurfaceFitOptions& o, V& v) {
  v("quadric", o.quadric);  // k: MultiwayOptions::normal_k
  v("adaptive_factor", o.adaptive_factor);
  v("k_min", o.k_min);
  v("k_max", o.k_max);
  v("probe_k", o.probe_k);
}
template <class V>
void fields(registration::MultiwayOptions& o, V& v) {
  v("robot_translation_sigma", o.robot_translation_sigma);
  v("robot_rotation_sigma_deg", o.robot_rotation_sigma_deg);
  v("min_overlap", o.min_overlap);
  v("overlap_distance", o.overlap_distance);
  v("sample_points", o.sample_points);
  v("target_points", o.target_points);
  v("normal_k", o.normal_k);
  v("surface", o.surface);
  v("max_incidence_deg", o.max_incidence_deg);
  // incidence_gain: not a session option; the session takes the scanner's noise.depth_incidence_gain.
  v("max_pairs_per_scan", o.max_pairs_per_scan);
  v("rounds", o.rounds);
  v("max_disagreement", o.max_disagreement);
  v("outlier_sigma", o.outlier_sigma);
  v("free_neighbors", o.free_neighbors);
  v("robust_scale", o.robust_scale);
  v("information_points", o.information_points);
  v("icp", o.icp);
}
template <class V>
void fields(SessionOptions& o, V& v) {
  v("planner", o.planner);
  v("planner_params", o.planner_params);
  v("consolidate", o.consolidate);
  v("poisson", o.poisson);
  v("confidence", o.confidence);
  v("smoothness_points", o.smoothness_points);
  v("nbv", o.nbv);
  v("icp", o.icp);
  v("register_scans", o.register_scans);
  v("global_registration", o.global_registration);
  v("multiway", o.multiway);
  v("registration_min_improvement", o.registration_min_improvement);
  v("registration_max_translation", o.registration_max_translation);
  v("registration_max_rotation_deg", o.registration_max_rotation_deg);
  v("selective_insertion", o.selective_insertion);
  v("rho", o.rho);
  v("quality_weights", o.quality_weights);
  v("quality_insertion_ratio", o.quality_insertion_ratio);
  v("stop_threshold", o.stop_threshold);
  v("stop_when_confidence_falls", o.stop_when_confidence_falls);
  v("max_iterations", o.max_iterations);
  v("max_views", o.max_views);
  v("seed", o.seed);
}

// ---- enums --------------------------------------------------------------------------------------
template <class E>
struct EnumNames;
template <>
struct EnumNames<consolidate::WlopMode> {
  static constexpr std::pair<consolidate::WlopMode, const char*> values[] = {
      {consolidate::WlopMode::automatic, "automatic"},
      {consolidate::WlopMode::on, "on"},
      {consolidate::WlopMode::off, "off"}};
};
template <>
struct EnumNames<SmoothnessPoints> {
  static constexpr std::pair<SmoothnessPoints, const char*> values[] = {
      {SmoothnessPoints::automatic, "automatic"},
      {SmoothnessPoints::raw, "raw"},
      {SmoothnessPoints::consolidated, "consolidated"}};
};
template <>
struct EnumNames<consolidate::Orientation> {
  static constexpr std::pair<consolidate::Orientation, const char*> values[] = {
      {consolidate::Orientation::automatic, "automatic"},
      {consolidate::Orientation::sensor, "sensor"},
      {consolidate::Orientation::mst, "mst"}};
};
template <>
struct EnumNames<nbv::FieldMethod> {
  static constexpr std::pair<nbv::FieldMethod, const char*> values[] = {{nbv::FieldMethod::fast, "fast"},
                                                                        {nbv::FieldMethod::reference, "reference"}};
};

struct Probe {
  template <class T>
  void operator()(const char*, T&) {}
};
template <class T>
concept HasFields = requires(T& t, Probe& p) {
  fields(t, p);
};

// ---- writer ---------------------------------------------------------------------------------------
struct Writer {
  nlohmann::json& j;
  template <class T>
  void operator()(const char* key, T& x) {
    j[key] = write(x);
  }
  template <class T>
  static nlohmann::json write(T& x) {
    if constexpr (HasFields<T>) {
      nlohmann::json o = nlohmann::json::object();
      Writer w{o};
      fields(x, w);
      return o;
    } else if constexpr (std::is_enum_v<T>) {
      for (const auto& [e, name] : EnumNames<T>::values)
        if (e == x) return name;
      return nullptr;
    } else {
      return nlohmann::json(x);
    }
  }
};

// ---- reader ---------------------------------------------------------------------------------------
struct Reader {
  const nlohmann::json& j;
  std::string path;
  std::set<std::string> seen;
  template <class T>
  void operator()(const char* key, T& x) {
    seen.insert(key);
    if (j.contains(key)) read(j.at(key), x, path + "." + key);
  }
  template <class T>
  static void read(const nlohmann::json& v, T& x, const std::string& where) {
    if constexpr (HasFields<T>) {
      AUTOSCAN_REQUIRE(v.is_object(), "{}: expected a JSON object", where);
      Reader r{v, where, {}};
      fields(x, r);
      for (const auto& [k, unused] : v.items())
        AUTOSCAN_REQUIRE(r.seen.count(k) != 0, "{}: unknown option '{}'", where, k);
    } else if constexpr (std::is_enum_v<T>) {
      AUTOSCAN_REQUIRE(v.is_string(), "{}: expected a string", where);
      std::string known;
      for (const auto& [e, name] : EnumNames<T>::values) {
        if (v.get<std::string>() == name) {
          x = e;
          return;
        }
        known += (known.empty() ? "" : ", ") + std::string(name);
      }
      throw InputError(fmt::format("{}: unknown value '{}' (expected one of: {})", where, v.get<std::string>(), known));
    } else if constexpr (std::is_same_v<T, bool>) {
      AUTOSCAN_REQUIRE(v.is_boolean(), "{}: expected true or false", where);
      x = v.get<bool>();
    } else if constexpr (std::is_integral_v<T>) {
      AUTOSCAN_REQUIRE(v.is_number_integer(), "{}: expected an integer", where);
      if constexpr (std::is_unsigned_v<T>)
        AUTOSCAN_REQUIRE(v.is_number_unsigned() || v.get<long long>() >= 0, "{}: expected a non-negative integer",
                         where);
      x = v.get<T>();
    } else if constexpr (std::is_floating_point_v<T>) {
      AUTOSCAN_REQUIRE(v.is_number(), "{}: expected a number", where);
      x = v.get<T>();
    } else if constexpr (std::is_same_v<T, std::string>) {
      AUTOSCAN_REQUIRE(v.is_string(), "{}: expected a string", where);
      x = v.get<std::string>();
    } else {
      static_assert(std::is_same_v<T, nlohmann::json>);
      AUTOSCAN_REQUIRE(v.is_object(), "{}: expected a JSON object", where);
      x = v;
    }
  }
};

}  // namespace

void SessionOptions::validate() const {
  AUTOSCAN_REQUIRE(!planner.empty(), "options: planner must not be empty");
  AUTOSCAN_REQUIRE(planner_params.is_object(), "options: planner_params must be a JSON object");
  AUTOSCAN_REQUIRE(std::isfinite(rho) && rho >= 0.0, "options: rho (Eq. 6) must be >= 0 (got {})", rho);
  AUTOSCAN_REQUIRE(
      std::isfinite(quality_insertion_ratio) && (quality_insertion_ratio == 0.0 || quality_insertion_ratio >= 1.0),
      "options: quality_insertion_ratio must be 0 (off) or >= 1 (got {})", quality_insertion_ratio);
  AUTOSCAN_REQUIRE(std::isfinite(registration_min_improvement) && registration_min_improvement >= 0.0 &&
                       registration_min_improvement < 1.0,
                   "options: registration_min_improvement must be in [0, 1) (got {})", registration_min_improvement);
  AUTOSCAN_REQUIRE(
      std::isfinite(registration_max_translation) && registration_max_translation >= 0.0 &&
          std::isfinite(registration_max_rotation_deg) && registration_max_rotation_deg >= 0.0,
      "options: registration_max_translation and registration_max_rotation_deg must be >= 0 (0 = no bound)");
  AUTOSCAN_REQUIRE(std::isfinite(stop_threshold) && stop_threshold >= 0.0,
                   "options: stop_threshold must be >= 0 (got {})", stop_threshold);
  AUTOSCAN_REQUIRE(max_iterations >= 1, "options: max_iterations must be >= 1 (got {})", max_iterations);
  AUTOSCAN_REQUIRE(max_views >= 0, "options: max_views must be >= 0 (got {})", max_views);
  nbv.validate();
  multiway.validate("options: multiway");
}

nlohmann::json to_json(const SessionOptions& o) {
  SessionOptions copy = o;
  return Writer::write(copy);
}

SessionOptions session_options_from_json(const nlohmann::json& j, SessionOptions base, const std::string& what) {
  Reader::read(j, base, what);
  return base;
}

}  // namespace autoscan::session
