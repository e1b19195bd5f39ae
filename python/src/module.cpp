// The Python module `autoscan` (docs/python.md): the library's stages over NumPy arrays.
//
// Memory: PointCloud and TriangleMesh are the C++ structs themselves; their array properties are
// NumPy views of the std::vector buffers (no copy), kept alive by the Python object. Assigning to
// a property copies in place, so a column never moves while a view may exist. Results of C++
// calls are moved (not copied) into the Python objects. Batch field queries read the caller's
// (N, 3) float64 array in place when it is C-contiguous.
//
// Errors: autoscan::InputError -> autoscan.InputError (a ValueError), any other autoscan::Error ->
// autoscan.Error (a RuntimeError); the messages are the library's.
//
// Logging: the library logs through spdlog (core/log.hpp); the module installs a sink that queues
// the records and hands them to logging.getLogger("autoscan") when the call returns (the GIL is
// released during long calls, so worker threads never call into Python). The spdlog level follows
// the Python logger's effective level at each call. Stage progress is logged at DEBUG level.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <spdlog/sinks/base_sink.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "autoscan/confidence/assess.hpp"
#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/json_io.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/rig.hpp"
#include "autoscan/core/scanner_spec.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/nbv/nbv.hpp"
#include "autoscan/poisson/poisson.hpp"
#include "autoscan/scanner/blind_scan.hpp"
#include "autoscan/scanner/virtual_scanner.hpp"
#include "autoscan/session/options.hpp"
#include "autoscan/session/session.hpp"
#include "autoscan/simulation/simulate.hpp"
#include "convert.hpp"

namespace py = pybind11;
using namespace py::literals;
using json = nlohmann::json;

namespace autoscan::python {

// ---- JSON <-> Python --------------------------------------------------------------------------

json to_json(py::handle obj, const std::string& what) {
  if (obj.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(obj)) return obj.cast<bool>();
  if (py::isinstance<py::int_>(obj)) {
    const auto v = obj.cast<py::int_>();
    if (v < py::int_(0)) return v.cast<long long>();
    return v.cast<unsigned long long>();
  }
  if (py::isinstance<py::float_>(obj)) {
    const double d = obj.cast<double>();
    AUTOSCAN_REQUIRE(std::isfinite(d), "{}: not a finite number ({})", what, d);
    return d;
  }
  if (py::isinstance<py::str>(obj)) return obj.cast<std::string>();
  if (py::isinstance<py::dict>(obj)) {
    json j = json::object();
    for (auto [k, v] : obj.cast<py::dict>()) {
      AUTOSCAN_REQUIRE(py::isinstance<py::str>(k), "{}: keys must be strings (got {})", what, std::string(py::repr(k)));
      const auto key = k.cast<std::string>();
      j[key] = to_json(v, what + "." + key);
    }
    return j;
  }
  if (py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj)) {
    json j = json::array();
    std::size_t i = 0;
    for (auto v : obj) j.push_back(to_json(v, fmt::format("{}[{}]", what, i++)));
    return j;
  }
  if (py::isinstance<py::array>(obj)) return to_json(obj.attr("tolist")(), what);
  if (py::hasattr(obj, "item") && py::hasattr(obj, "dtype")) return to_json(obj.attr("item")(), what);  // NumPy scalar
  if (py::hasattr(obj, "__fspath__")) return py::str(obj.attr("__fspath__")()).cast<std::string>();
  throw InputError(fmt::format("{}: cannot be given as JSON ({})", what,
                               std::string(py::str(py::type::handle_of(obj).attr("__name__")))));
}

py::object from_json(const json& j) {
  switch (j.type()) {
    case json::value_t::null:
      return py::none();
    case json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case json::value_t::number_integer:
      return py::int_(j.get<long long>());
    case json::value_t::number_unsigned:
      return py::int_(j.get<unsigned long long>());
    case json::value_t::number_float:
      return py::float_(j.get<double>());
    case json::value_t::string:
      return py::str(j.get<std::string>());
    case json::value_t::array: {
      py::list l;
      for (const auto& e : j) l.append(from_json(e));
      return l;
    }
    case json::value_t::object: {
      py::dict d;
      for (const auto& [k, v] : j.items()) d[py::str(k)] = from_json(v);
      return d;
    }
    default:
      return py::none();
  }
}

namespace {

// ---- logging ----------------------------------------------------------------------------------

struct Record {
  spdlog::level::level_enum level;
  std::string message;
};

/// Queues spdlog records (from any thread); drain() hands them to Python's logging with the GIL held.
class QueueSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  std::vector<Record> take() {
    std::lock_guard lock(mutex_);
    return std::exchange(queue_, {});
  }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    queue_.push_back({msg.level, std::string(msg.payload.data(), msg.payload.size())});
  }
  void flush_() override {}

 private:
  std::vector<Record> queue_;
};

std::shared_ptr<QueueSink>& queue_sink() {
  static auto sink = std::make_shared<QueueSink>();
  return sink;
}

py::object python_logger() { return py::module_::import("logging").attr("getLogger")("autoscan"); }

/// Sends the queued records to logging.getLogger("autoscan"). GIL held.
void drain_log() {
  auto records = queue_sink()->take();
  if (records.empty()) return;
  py::object logger = python_logger();
  for (const auto& r : records) {
    int level = 20;
    switch (r.level) {
      case spdlog::level::trace:
        level = 5;
        break;
      case spdlog::level::debug:
        level = 10;
        break;
      case spdlog::level::info:
        level = 20;
        break;
      case spdlog::level::warn:
        level = 30;
        break;
      case spdlog::level::err:
        level = 40;
        break;
      default:
        level = 50;
    }
    logger.attr("log")(level, "%s", r.message);
  }
}

/// Sets spdlog's level from the Python logger's effective level (so that nothing is formatted that
/// Python would drop).
void sync_log_level() {
  const int py_level = python_logger().attr("getEffectiveLevel")().cast<int>();
  auto level = spdlog::level::off;
  if (py_level < 10)
    level = spdlog::level::trace;
  else if (py_level < 20)
    level = spdlog::level::debug;
  else if (py_level < 30)
    level = spdlog::level::info;
  else if (py_level < 40)
    level = spdlog::level::warn;
  else if (py_level < 50)
    level = spdlog::level::err;
  else
    level = spdlog::level::critical;
  spdlog::set_level(level);
}

/// Runs `f` (which must not touch Python objects) with the GIL released; the library's log records
/// reach Python's logging when it returns or throws.
template <class F>
auto call(F&& f) -> decltype(f()) {
  sync_log_level();
  struct Drain {
    ~Drain() {
      try {
        drain_log();
      } catch (...) {  // never let logging turn a result or an error into a crash
      }
    }
  } drain;
  py::gil_scoped_release release;
  return f();
}

/// Logs each stage's progress at DEBUG level in steps of 10 %.
ProgressCallback progress_logger() {
  struct State {
    std::mutex m;
    std::map<std::string, int, std::less<>> last;
  };
  auto state = std::make_shared<State>();
  return [state](std::string_view stage, double fraction) {
    const int step = static_cast<int>(std::floor(std::clamp(fraction, 0.0, 1.0) * 10.0));
    std::lock_guard lock(state->m);
    auto it = state->last.find(stage);
    if (it == state->last.end()) it = state->last.emplace(std::string(stage), -1).first;
    if (step > it->second) {
      it->second = step;
      log::debug("{}: {}%", stage, step * 10);
    }
    return true;
  };
}

// ---- options and small types --------------------------------------------------------------------

json options_json(const py::object& obj, const std::string& what) {
  if (obj.is_none()) return json::object();
  AUTOSCAN_REQUIRE(py::isinstance<py::dict>(obj), "{}: expected a dict of options, got {}", what,
                   std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  return to_json(obj, what);
}

ScannerSpec to_scanner(const py::object& obj, const std::string& what = "scanner") {
  if (obj.is_none()) return {};
  if (py::isinstance<py::str>(obj) || py::hasattr(obj, "__fspath__"))
    return load_scanner(py::str(py::module_::import("os").attr("fspath")(obj)).cast<std::string>());
  ScannerSpec s = scanner_from_json(options_json(obj, what), what);
  s.validate(what);
  return s;
}

Rig to_rig(const py::object& obj, const std::string& what = "rig") {
  if (obj.is_none()) return {};
  if (py::isinstance<py::str>(obj)) {
    const auto name = obj.cast<std::string>();
    if (name.find('/') == std::string::npos && name.find('.') == std::string::npos) {
      Rig r;
      r.kind = Rig::parse_kind(name);
      return r;
    }
    return rig_from_json(read_json_file(name), name);
  }
  Rig r = rig_from_json(options_json(obj, what), what);
  r.validate(what);
  return r;
}

Vec3 to_vec3(py::handle obj, const std::string& what) {
  const auto a = as_array<double>(obj, what);
  AUTOSCAN_REQUIRE(a.ndim() == 1 && a.shape(0) == 3, "{}: expected 3 numbers", what);
  const Vec3 v(a.at(0), a.at(1), a.at(2));
  AUTOSCAN_REQUIRE(within_coordinate_range(v), "{}: not finite or beyond {:g}", what, kMaxCoordinate);
  return v;
}

/// A pose from a dict with "position" and "direction" (optional "up"; other keys, e.g. a planned
/// view's "score", are ignored), a "px,py,pz,dx,dy,dz" string, or 6 numbers.
Pose to_pose(const py::object& obj, const std::string& what = "pose") {
  Pose p;
  if (py::isinstance<py::str>(obj)) return parse_pose(obj.cast<std::string>(), what);
  if (py::isinstance<py::dict>(obj)) {
    const auto d = obj.cast<py::dict>();
    AUTOSCAN_REQUIRE(d.contains("position") && d.contains("direction"), "{}: needs 'position' and 'direction'", what);
    p.position = to_vec3(d["position"], what + ".position");
    p.direction = to_vec3(d["direction"], what + ".direction");
    if (d.contains("up")) p.up = to_vec3(d["up"], what + ".up");
  } else {
    const auto a = as_array<double>(obj, what);
    AUTOSCAN_REQUIRE(a.ndim() == 1 && (a.shape(0) == 6 || a.shape(0) == 9),
                     "{}: expected a dict, a 'px,py,pz,dx,dy,dz' string or 6 (or 9, with up) numbers", what);
    p.position = Vec3(a.at(0), a.at(1), a.at(2));
    p.direction = Vec3(a.at(3), a.at(4), a.at(5));
    if (a.shape(0) == 9) p.up = Vec3(a.at(6), a.at(7), a.at(8));
  }
  p.validate(what);
  return p;
}

std::optional<Pose> to_optional_pose(const py::object& obj, const std::string& what) {
  if (obj.is_none()) return std::nullopt;
  return to_pose(obj, what);
}

py::dict pose_dict(const Pose& p) { return from_json(autoscan::to_json(p)).cast<py::dict>(); }

py::array matrix4(const Eigen::Isometry3d& t) {
  py::array_t<double> a({4, 4});
  auto r = a.mutable_unchecked<2>();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r(i, j) = t.matrix()(i, j);
  return a;
}

std::filesystem::path to_path(const py::object& obj) {
  return std::filesystem::path(py::str(py::module_::import("os").attr("fspath")(obj)).cast<std::string>());
}

/// A mesh argument: a TriangleMesh, or a path to read.
TriangleMesh to_mesh(const py::object& obj) {
  if (py::isinstance<TriangleMesh>(obj)) return obj.cast<const TriangleMesh&>();
  return io::read_mesh(to_path(obj));
}

std::vector<Vec3> points_arg(py::handle obj, const std::string& what) {
  const auto a = as_array<double>(obj, what);
  const std::size_t n = check_rows3(a, -1, what);
  std::vector<Vec3> v(n);
  if (n) std::memcpy(static_cast<void*>(v.data()), a.data(), n * sizeof(Vec3));
  return v;
}

// ---- result types held by Python ----------------------------------------------------------------

struct PyScan {
  scanner::ScanResult r;
};

struct PyBlindScan {
  scanner::BlindScanResult r;
};

struct PyConsolidation {
  consolidate::ConsolidateResult r;
};

struct PyPlan {
  nbv::PlanResult r;
};

struct PyNextViews {
  session::NextViews r;
};

/// A session that can be closed (releasing its lock) before the Python object goes away.
struct PySession {
  std::optional<session::Session> s;
  session::Session& get() {
    AUTOSCAN_CHECK(s.has_value(), "the session is closed");
    return *s;
  }
};

py::dict scan_diagnostics(const scanner::ScanDiagnostics& d) {
  return py::dict("rays_cast"_a = d.rays_cast, "shadow_rays"_a = d.shadow_rays, "hits"_a = d.hits,
                  "points"_a = d.points, "rejected_range"_a = d.rejected_range,
                  "rejected_incidence"_a = d.rejected_incidence, "rejected_projector_fov"_a = d.rejected_projector_fov,
                  "rejected_projector_incidence"_a = d.rejected_projector_incidence,
                  "rejected_projector_shadow"_a = d.rejected_projector_shadow, "outliers"_a = d.outliers,
                  "seconds"_a = d.seconds);
}

py::dict poisson_diagnostics(const poisson::PoissonDiagnostics& d) {
  py::list levels;
  for (const auto& l : d.levels)
    levels.append(py::dict("depth"_a = l.depth, "nodes"_a = l.nodes, "support_nodes"_a = l.support_nodes,
                           "splat_samples"_a = l.splat_samples, "iterations"_a = l.iterations,
                           "initial_residual"_a = l.initial_residual, "final_residual"_a = l.final_residual));
  return py::dict("points"_a = d.points, "density_depth"_a = d.density_depth, "finest_depth"_a = d.finest_depth,
                  "levels"_a = levels,
                  "seconds"_a = py::dict("octree"_a = d.seconds_octree, "splat"_a = d.seconds_splat,
                                         "system"_a = d.seconds_system, "solve"_a = d.seconds_solve,
                                         "extract"_a = d.seconds_extract, "total"_a = d.seconds_total));
}

py::dict consolidate_report(const consolidate::ConsolidateResult& r) {
  py::dict timings;
  for (const auto& t : r.timings) timings[py::str(t.step)] = t.seconds;
  return py::dict(
      "points_in"_a = r.points_in, "points_out"_a = r.points_out, "outliers_removed"_a = r.outliers.removed,
      "outlier_threshold"_a = r.outliers.threshold, "radius_removed"_a = r.radius_removed,
      "thinning_removed"_a = r.thinning.removed, "thinning_voxel_size"_a = r.thinning.voxel_size,
      "smoothing_iterations"_a = r.smoothing.iterations, "smoothing_rms_displacement"_a = r.smoothing.rms_displacement,
      "wlop_applied"_a = r.wlop.applied, "wlop_radius"_a = r.wlop.radius,
      "normals_orientation"_a = r.normals.orientation == consolidate::Orientation::sensor ? "sensor" : "mst",
      "normals_ambiguous"_a = r.normals.ambiguous, "seconds"_a = timings, "total_seconds"_a = r.total_seconds);
}

py::list planned_views(const std::vector<planners::PlannedView>& views) {
  py::list l;
  for (const auto& v : views) {
    py::dict d = pose_dict(v.pose);
    d["score"] = v.score;
    d["target"] = py::make_tuple(v.target.x(), v.target.y(), v.target.z());
    l.append(d);
  }
  return l;
}

// ---- the classes with NumPy views -----------------------------------------------------------------

py::dict scalar_views(ScalarAttributes& s, py::handle owner) {
  py::dict d;
  for (auto& [name, values] : s.columns()) d[py::str(name)] = column_view(values, owner);
  return d;
}

void set_scalar(ScalarAttributes& s, std::size_t rows, const std::string& name, py::handle values,
                const std::string& what) {
  const auto a = as_array<double>(values, what + "[" + name + "]");
  AUTOSCAN_REQUIRE(a.ndim() == 1 && static_cast<std::size_t>(a.shape(0)) == rows,
                   "{}['{}']: expected {} values (one per element)", what, name, rows);
  if (auto* col = s.find(name)) {  // in place: views of the column stay valid
    if (rows) std::memcpy(col->data(), a.data(), rows * sizeof(double));
  } else {
    s.set(name, std::vector<double>(a.data(), a.data() + rows));
  }
}

void bind_geometry(py::module_& m) {
  py::class_<PointCloud>(m, "PointCloud", R"doc(
A point cloud: positions, optional normals and colours, and named per-point scalars
(core/point_cloud.hpp). Conventional scalars: "scan_id", "sensor_x/y/z" (the scanner position each
point was seen from, used to orient normals), "f", "f_g", "f_s" (confidence, paper Eq. 1-3).

The array properties are NumPy views of the C++ storage (no copy): writing into them changes the
cloud. Assigning an array copies it in place; the point count is fixed at construction.)doc")
      .def(py::init([](const py::object& positions, const py::object& normals, const py::object& colors,
                       const py::object& scalars) {
             PointCloud c;
             copy_rows(c.positions, positions, -1, "PointCloud.positions");
             const long n = static_cast<long>(c.positions.size());
             if (!normals.is_none()) copy_rows(c.normals, normals, n, "PointCloud.normals");
             if (!colors.is_none()) copy_rows(c.colors, colors, n, "PointCloud.colors");
             if (!scalars.is_none())
               for (auto [k, v] : scalars.cast<py::dict>())
                 set_scalar(c.scalars, c.size(), k.cast<std::string>(), v, "PointCloud.scalars");
             c.validate("PointCloud");
             return c;
           }),
           "positions"_a, "normals"_a = py::none(), "colors"_a = py::none(), "scalars"_a = py::none(),
           "Positions (N, 3); optional normals (N, 3), colours (N, 3) uint8, scalars {name: (N,)}.")
      .def("__len__", &PointCloud::size)
      .def("__repr__",
           [](const PointCloud& c) {
             std::string names;
             for (const auto& [k, v] : c.scalars.columns()) names += (names.empty() ? "" : ", ") + k;
             return fmt::format("<autoscan.PointCloud {} points, normals: {}, colors: {}, scalars: [{}]>", c.size(),
                                c.has_normals(), c.has_colors(), names);
           })
      .def_property(
          "positions", [](py::object self) { return rows_view(self.cast<PointCloud&>().positions, self); },
          [](PointCloud& c, py::handle a) {
            copy_rows(c.positions, a, static_cast<long>(c.size()), "PointCloud.positions");
          },
          "(N, 3) float64 view of the positions.")
      .def_property(
          "normals", [](py::object self) { return rows_view(self.cast<PointCloud&>().normals, self); },
          [](PointCloud& c, py::handle a) {
            if (a.is_none())
              c.normals.clear();  // keeps the buffer: earlier views stay valid memory
            else
              copy_rows(c.normals, a, static_cast<long>(c.size()), "PointCloud.normals");
          },
          "(N, 3) float64 view of the unit outward normals, or (0, 3) when there are none. None removes them.")
      .def_property(
          "colors", [](py::object self) { return rows_view(self.cast<PointCloud&>().colors, self); },
          [](PointCloud& c, py::handle a) {
            if (a.is_none())
              c.colors.clear();
            else
              copy_rows(c.colors, a, static_cast<long>(c.size()), "PointCloud.colors");
          },
          "(N, 3) uint8 view of the colours, or (0, 3).")
      .def_property_readonly(
          "scalars", [](py::object self) { return scalar_views(self.cast<PointCloud&>().scalars, self); },
          "{name: (N,) float64 view} of the named scalars (set_scalar adds or overwrites one).")
      .def(
          "set_scalar",
          [](PointCloud& c, const std::string& name, py::handle values) {
            set_scalar(c.scalars, c.size(), name, values, "PointCloud.scalars");
          },
          "name"_a, "values"_a, "Adds or overwrites (in place) the scalar column `name` (N values).")
      .def_property_readonly("has_normals", &PointCloud::has_normals)
      .def_property_readonly("has_colors", &PointCloud::has_colors)
      .def(
          "bounds",
          [](const PointCloud& c) {
            const AABB b = c.bounds();
            return py::make_tuple(take_column(std::vector<double>{b.min.x(), b.min.y(), b.min.z()}),
                                  take_column(std::vector<double>{b.max.x(), b.max.y(), b.max.z()}));
          },
          "(min, max) corners of the axis-aligned bounding box.")
      .def(
          "copy", [](const PointCloud& c) { return PointCloud(c); }, "A deep copy.")
      .def(
          "validate", [](const PointCloud& c, const std::string& what) { c.validate(what); }, "what"_a = "point cloud",
          "Raises InputError if sizes disagree or a coordinate or normal is NaN/Inf.");

  py::class_<TriangleMesh>(m, "TriangleMesh", R"doc(
A triangle mesh: vertices, triangles (indices into vertices, counter-clockwise seen from outside),
optional per-vertex normals, colours and named per-vertex scalars (core/mesh.hpp). Array
properties are NumPy views of the C++ storage (no copy).)doc")
      .def(py::init([](const py::object& vertices, const py::object& faces, const py::object& normals,
                       const py::object& colors, const py::object& scalars) {
             TriangleMesh t;
             copy_rows(t.vertices, vertices, -1, "TriangleMesh.vertices");
             copy_rows(t.faces, faces, -1, "TriangleMesh.faces");
             const long n = static_cast<long>(t.vertices.size());
             if (!normals.is_none()) copy_rows(t.vertex_normals, normals, n, "TriangleMesh.vertex_normals");
             if (!colors.is_none()) copy_rows(t.vertex_colors, colors, n, "TriangleMesh.vertex_colors");
             if (!scalars.is_none())
               for (auto [k, v] : scalars.cast<py::dict>())
                 set_scalar(t.vertex_scalars, t.vertices.size(), k.cast<std::string>(), v, "TriangleMesh.scalars");
             t.validate("TriangleMesh");
             return t;
           }),
           "vertices"_a, "faces"_a, "vertex_normals"_a = py::none(), "vertex_colors"_a = py::none(),
           "scalars"_a = py::none(), "Vertices (V, 3) and faces (F, 3) int32; optional per-vertex data.")
      .def("__repr__",
           [](const TriangleMesh& t) {
             return fmt::format("<autoscan.TriangleMesh {} vertices, {} faces>", t.vertices.size(), t.faces.size());
           })
      .def_property(
          "vertices", [](py::object self) { return rows_view(self.cast<TriangleMesh&>().vertices, self); },
          [](TriangleMesh& t, py::handle a) {
            copy_rows(t.vertices, a, static_cast<long>(t.vertices.size()), "TriangleMesh.vertices");
          },
          "(V, 3) float64 view of the vertices.")
      .def_property(
          "faces", [](py::object self) { return rows_view(self.cast<TriangleMesh&>().faces, self); },
          [](TriangleMesh& t, py::handle a) {
            copy_rows(t.faces, a, static_cast<long>(t.faces.size()), "TriangleMesh.faces");
          },
          "(F, 3) int32 view of the triangles.")
      .def_property(
          "vertex_normals", [](py::object self) { return rows_view(self.cast<TriangleMesh&>().vertex_normals, self); },
          [](TriangleMesh& t, py::handle a) {
            copy_rows(t.vertex_normals, a, static_cast<long>(t.vertices.size()), "TriangleMesh.vertex_normals");
          },
          "(V, 3) float64 view of the vertex normals, or (0, 3).")
      .def_property(
          "vertex_colors", [](py::object self) { return rows_view(self.cast<TriangleMesh&>().vertex_colors, self); },
          [](TriangleMesh& t, py::handle a) {
            copy_rows(t.vertex_colors, a, static_cast<long>(t.vertices.size()), "TriangleMesh.vertex_colors");
          },
          "(V, 3) uint8 view of the vertex colours, or (0, 3).")
      .def_property_readonly(
          "scalars", [](py::object self) { return scalar_views(self.cast<TriangleMesh&>().vertex_scalars, self); },
          "{name: (V,) float64 view} of the per-vertex scalars (e.g. 'density', 'f').")
      .def(
          "set_scalar",
          [](TriangleMesh& t, const std::string& name, py::handle values) {
            set_scalar(t.vertex_scalars, t.vertices.size(), name, values, "TriangleMesh.scalars");
          },
          "name"_a, "values"_a, "Adds or overwrites (in place) the per-vertex scalar `name`.")
      .def("area", &TriangleMesh::area, "Total surface area.")
      .def(
          "compute_vertex_normals",
          [](TriangleMesh& t) {
            TriangleMesh tmp;
            tmp.vertices = t.vertices;
            tmp.faces = t.faces;
            tmp.compute_vertex_normals();
            if (t.vertex_normals.empty()) t.vertex_normals.resize(t.vertices.size());
            std::copy(tmp.vertex_normals.begin(), tmp.vertex_normals.end(), t.vertex_normals.begin());
          },
          "Sets the vertex normals to the area-weighted average of the incident face normals.")
      .def(
          "bounds",
          [](const TriangleMesh& t) {
            const AABB b = t.bounds();
            return py::make_tuple(take_column(std::vector<double>{b.min.x(), b.min.y(), b.min.z()}),
                                  take_column(std::vector<double>{b.max.x(), b.max.y(), b.max.z()}));
          },
          "(min, max) corners of the axis-aligned bounding box.")
      .def(
          "copy", [](const TriangleMesh& t) { return TriangleMesh(t); }, "A deep copy.");
}

// ---- the module -----------------------------------------------------------------------------------

void bind_io(py::module_& m) {
  m.def(
      "read_mesh", [](const py::object& path) { return call([p = to_path(path)] { return io::read_mesh(p); }); },
      "path"_a, R"doc(Reads a triangle mesh (.ply .obj .off .stl; polygons fan-triangulated). PLY vertex
normals, colours and scalar properties are kept. Raises InputError naming the file for any problem.)doc");
  m.def(
      "read_point_cloud",
      [](const py::object& path) { return call([p = to_path(path)] { return io::read_point_cloud(p); }); }, "path"_a,
      R"doc(Reads a point cloud: a PLY's vertices with their properties, a PCD (ASCII or binary) or XYZ/PTS
file, or the vertices of a mesh file. Raises InputError naming the file for any problem.)doc");
  const auto write_options = [](bool ascii, bool big_endian, bool double_coordinates, bool double_scalars) {
    io::WriteOptions o;
    o.ascii = ascii;
    o.big_endian = big_endian;
    o.double_coordinates = double_coordinates;
    o.double_scalars = double_scalars;
    return o;
  };
  m.def(
      "write_mesh",
      [write_options](const py::object& path, const TriangleMesh& mesh, bool ascii, bool big_endian,
                      bool double_coordinates, bool double_scalars) {
        const auto o = write_options(ascii, big_endian, double_coordinates, double_scalars);
        call([&, p = to_path(path)] { io::write_mesh(p, mesh, o); });
      },
      "path"_a, "mesh"_a, "ascii"_a = false, "big_endian"_a = false, "double_coordinates"_a = false,
      "double_scalars"_a = false,
      "Writes a mesh, format by extension (.ply .obj .off .stl), atomically (nothing is left on error).");
  m.def(
      "write_point_cloud",
      [write_options](const py::object& path, const PointCloud& cloud, bool ascii, bool big_endian,
                      bool double_coordinates, bool double_scalars) {
        const auto o = write_options(ascii, big_endian, double_coordinates, double_scalars);
        call([&, p = to_path(path)] { io::write_point_cloud(p, cloud, o); });
      },
      "path"_a, "cloud"_a, "ascii"_a = false, "big_endian"_a = false, "double_coordinates"_a = false,
      "double_scalars"_a = false,
      "Writes a point cloud (.ply with normals, colours and scalars; .pcd; .xyz/.pts), atomically.");
}

void bind_scanner(py::module_& m) {
  py::class_<PyScan>(m, "ScanResult", "One scan of the virtual scanner (scanner/virtual_scanner.hpp).")
      .def_property_readonly(
          "cloud", [](PyScan& s) -> PointCloud& { return s.r.cloud; }, py::return_value_policy::reference_internal,
          "Points in the world frame of the commanded pose, unit normals facing the camera, scalars scan_id and "
          "sensor_x/y/z.")
      .def_property_readonly(
          "pixels", [](py::object self) { return column_view(self.cast<PyScan&>().r.pixels, self); },
          "Pixel index (row * width + column) of each point (uint32 view).")
      .def_property_readonly("scan_id", [](const PyScan& s) { return s.r.scan_id; })
      .def_property_readonly(
          "commanded", [](const PyScan& s) { return pose_dict(s.r.commanded); }, "The pose asked for.")
      .def_property_readonly(
          "actual", [](const PyScan& s) { return pose_dict(s.r.actual); },
          "Where the scanner really was (differs only with pose error).")
      .def_property_readonly(
          "misalignment", [](const PyScan& s) { return matrix4(s.r.misalignment); },
          "4x4 rigid transform from true world positions to reported ones.")
      .def_property_readonly("diagnostics", [](const PyScan& s) { return scan_diagnostics(s.r.diagnostics); })
      .def("__repr__",
           [](const PyScan& s) { return fmt::format("<autoscan.ScanResult {} points>", s.r.cloud.size()); });

  py::class_<PyBlindScan>(m, "BlindScanResult", "The initial all-round scan (scanner/blind_scan.hpp).")
      .def_property_readonly(
          "cloud", [](PyBlindScan& s) -> PointCloud& { return s.r.cloud; }, py::return_value_policy::reference_internal,
          "All scans merged (world frame, scan_id per point).")
      .def_property_readonly(
          "poses",
          [](const PyBlindScan& s) {
            py::list l;
            for (const auto& p : s.r.poses) l.append(pose_dict(p));
            return l;
          },
          "Commanded poses, one per scan.")
      .def_property_readonly("scans",
                             [](const PyBlindScan& s) {
                               py::list l;
                               for (const auto& d : s.r.scans) l.append(scan_diagnostics(d));
                               return l;
                             })
      .def_property_readonly("seconds", [](const PyBlindScan& s) { return s.r.seconds; });

  py::class_<scanner::VirtualScanner>(m, "VirtualScanner", R"doc(
The virtual structured-light scanner bound to one mesh (paper §6, Figure 15): camera and projector
ray cast with Embree; the BVH is built once and reused by every scan.

scanner: a dict of ScannerSpec fields (near, far, fov_deg, width, height, baseline, noise {...}) or
a JSON file path; rig: a rig kind ("free", "turntable_arm", "view_sphere"), a dict or a JSON file.)doc")
      .def(py::init([](const py::object& mesh, const py::object& spec, const py::object& rig, bool check_pose_inside) {
             const TriangleMesh t = to_mesh(mesh);
             const ScannerSpec s = to_scanner(spec);
             scanner::VirtualScannerOptions o;
             o.rig = to_rig(rig);
             o.check_pose_inside = check_pose_inside;
             return call([&] { return std::make_unique<scanner::VirtualScanner>(t, s, o); });
           }),
           "mesh"_a, "scanner"_a = py::none(), "rig"_a = py::none(), "check_pose_inside"_a = true)
      .def(
          "scan",
          [](const scanner::VirtualScanner& vs, const py::object& pose, std::uint64_t scan_id, std::uint64_t seed) {
            const Pose p = to_pose(pose);
            return call([&] { return PyScan{vs.scan(p, scan_id, seed)}; });
          },
          "pose"_a, "scan_id"_a = 0, "seed"_a = 42,
          R"doc(Scans from `pose` (a dict with position/direction[/up], e.g. a planned view, a
"px,py,pz,dx,dy,dz" string or 6 numbers). Noise, including the pose error, is drawn from (seed,
scan_id). Raises InputError for a pose the rig cannot reach or a camera inside the mesh.)doc")
      .def(
          "blind_scan",
          [](const scanner::VirtualScanner& vs, const py::object& options, std::uint64_t seed) {
            simulation::SimulateOptions base;
            base.blind = {};
            json j = json::object();
            if (!options.is_none()) j["blind"] = options_json(options, "blind_scan options");
            const auto blind = simulation::simulate_options_from_json(j, base, "options").blind;
            blind.validate();
            auto progress = progress_logger();
            return call([&] { return PyBlindScan{scanner::blind_scan(vs, blind, seed, progress)}; });
          },
          "options"_a = py::none(), "seed"_a = 42,
          R"doc(The blind scan (paper §3, Figure 2(b)): views on rings around the object's centre at the
optimal distance. options: {views, elevations_deg, distance, azimuth_offset_deg}.)doc")
      .def(
          "inside",
          [](const scanner::VirtualScanner& vs, const py::object& points) {
            const auto pts = points_arg(points, "points");
            std::vector<std::uint8_t> in(pts.size());
            call([&] {
              for (std::size_t i = 0; i < pts.size(); ++i) in[i] = vs.inside(pts[i]) ? 1 : 0;
            });
            return take_column(std::move(in)).attr("astype")("bool");
          },
          "points"_a, "True for each (N, 3) point inside the mesh (outward faces; small holes tolerated).")
      .def_property_readonly("triangle_count", &scanner::VirtualScanner::triangle_count)
      .def_property_readonly("spec",
                             [](const scanner::VirtualScanner& vs) { return from_json(autoscan::to_json(vs.spec())); });

  m.def(
      "scan",
      [](const py::object& mesh, const py::object& pose, const py::object& spec, const py::object& rig,
         std::uint64_t scan_id, std::uint64_t seed) {
        const TriangleMesh t = to_mesh(mesh);
        const ScannerSpec s = to_scanner(spec);
        const Pose p = to_pose(pose);
        scanner::VirtualScannerOptions o;
        o.rig = to_rig(rig);
        return call([&] { return PyScan{scanner::scan_mesh(t, s, p, scan_id, seed, o)}; });
      },
      "mesh"_a, "pose"_a, "scanner"_a = py::none(), "rig"_a = py::none(), "scan_id"_a = 0, "seed"_a = 42,
      "One scan of `mesh` (a TriangleMesh or a path) from `pose` (see VirtualScanner.scan).");
  m.def(
      "blind_scan",
      [](const py::object& mesh, const py::object& spec, const py::object& options, std::uint64_t seed) {
        const TriangleMesh t = to_mesh(mesh);
        const ScannerSpec s = to_scanner(spec);
        simulation::SimulateOptions base;
        base.blind = {};
        json j = json::object();
        if (!options.is_none()) j["blind"] = options_json(options, "blind_scan options");
        const auto blind = simulation::simulate_options_from_json(j, base, "options").blind;
        blind.validate();
        auto progress = progress_logger();
        return call([&] {
          const scanner::VirtualScanner vs(t, s);
          return PyBlindScan{scanner::blind_scan(vs, blind, seed, progress)};
        });
      },
      "mesh"_a, "scanner"_a = py::none(), "options"_a = py::none(), "seed"_a = 42,
      "The blind scan of `mesh` (see VirtualScanner.blind_scan).");
}

session::SessionOptions session_options(const py::object& options, const std::string& what) {
  return session::session_options_from_json(options_json(options, what), {}, what);
}

void bind_reconstruction(py::module_& m) {
  py::class_<PyConsolidation>(m, "ConsolidateResult", "Consolidated points and what each step did.")
      .def_property_readonly(
          "cloud", [](PyConsolidation& c) -> PointCloud& { return c.r.cloud; },
          py::return_value_policy::reference_internal,
          "Consolidated points with unit outward normals and the input's attributes.")
      .def_property_readonly("report", [](const PyConsolidation& c) { return consolidate_report(c.r); });

  m.def(
      "consolidate",
      [](const PointCloud& raw, const py::object& options) {
        session::SessionOptions base;
        base.consolidate = {};  // the library's defaults, not the session's
        json j = json::object();
        if (!options.is_none()) j["consolidate"] = options_json(options, "consolidate options");
        const auto o = session::session_options_from_json(j, base, "options").consolidate;
        auto progress = progress_logger();
        return call([&] { return PyConsolidation{consolidate::consolidate(raw, o, progress)}; });
      },
      "raw"_a, "options"_a = py::none(),
      R"doc(Point consolidation (paper §4.1): thinning, outlier removal, [jet smoothing, WLOP] on noisy
data, normals oriented toward the scanner (scalars sensor_x/y/z) or by MST. options: the
"consolidate" object of the session config (docs/session-format.md), e.g.
{"outliers": {"k": 16}, "wlop": {"mode": "off"}}.)doc");

  py::class_<poisson::PoissonField, std::shared_ptr<poisson::PoissonField>>(m, "PoissonField", R"doc(
The screened Poisson indicator chi as an evaluable field (poisson/poisson.hpp). Larger inside (about
+1/2 inside, -1/2 outside), so its gradient points inward at the surface. Values and exact gradients
of the piecewise-trilinear basis. Batch queries run in parallel with the GIL released and read a
C-contiguous float64 (N, 3) array in place.)doc")
      .def(
          "values",
          [](const poisson::PoissonField& f, const py::object& points) {
            const auto a = as_array<double>(points, "points");
            const std::size_t n = check_rows3(a, -1, "points");
            std::vector<double> out(n);
            call([&] {
              f.values(std::span<const Vec3>(reinterpret_cast<const Vec3*>(a.data()), n), std::span<double>(out));
            });
            return take_column(std::move(out));
          },
          "points"_a, "chi at each of the (N, 3) points: (N,) float64.")
      .def(
          "gradients",
          [](const poisson::PoissonField& f, const py::object& points) {
            const auto a = as_array<double>(points, "points");
            const std::size_t n = check_rows3(a, -1, "points");
            std::vector<Vec3> out(n);
            call([&] {
              f.gradients(std::span<const Vec3>(reinterpret_cast<const Vec3*>(a.data()), n), std::span<Vec3>(out));
            });
            return take_rows(std::move(out));
          },
          "points"_a, "The exact gradient of chi (world units) at each of the (N, 3) points: (N, 3) float64.")
      .def(
          "density",
          [](const poisson::PoissonField& f, const py::object& points) {
            const auto pts = points_arg(points, "points");
            std::vector<double> out(pts.size());
            call([&] {
              for (std::size_t i = 0; i < pts.size(); ++i) out[i] = f.density(pts[i]);
            });
            return take_column(std::move(out));
          },
          "points"_a, "Sample density estimate (weighted samples per unit area) at each point.")
      .def(
          "sample_grid",
          [](const poisson::PoissonField& f, int res) {
            AUTOSCAN_REQUIRE(res >= 2 && res <= 1024, "sample_grid: res {} out of range [2, 1024]", res);
            auto grid = call([&] { return f.sample_grid(res); });
            return take_column(std::move(grid), {res, res, res});
          },
          "res"_a, "chi at the centres of a res^3 grid over the bounding cube, as a float32 array [z, y, x].")
      .def_property_readonly("iso_value", &poisson::PoissonField::iso_value, "The level of the surface.")
      .def_property_readonly("reference_gradient", &poisson::PoissonField::reference_gradient,
                             "|grad chi| of a densely, cleanly sampled surface (normalises f_g, Eq. 1).")
      .def_property_readonly("finest_cell_width", &poisson::PoissonField::finest_cell_width)
      .def_property_readonly("depth", &poisson::PoissonField::depth)
      .def_property_readonly("finest_depth", &poisson::PoissonField::finest_depth)
      .def_property_readonly(
          "bounding_cube",
          [](const poisson::PoissonField& f) {
            const AABB b = f.bounding_cube();
            return py::make_tuple(take_column(std::vector<double>{b.min.x(), b.min.y(), b.min.z()}),
                                  take_column(std::vector<double>{b.max.x(), b.max.y(), b.max.z()}));
          },
          "(min, max) of the discretisation cube.");

  py::class_<poisson::PoissonResult>(m, "PoissonResult", "A screened Poisson surface and its field.")
      .def_property_readonly(
          "mesh", [](poisson::PoissonResult& r) -> TriangleMesh& { return r.mesh; },
          py::return_value_policy::reference_internal,
          "The iso-surface: outward-facing triangles, vertex scalar 'density'.")
      .def_property_readonly(
          "field",
          [](const poisson::PoissonResult& r) { return std::const_pointer_cast<poisson::PoissonField>(r.field); })
      .def_property_readonly("diagnostics",
                             [](const poisson::PoissonResult& r) { return poisson_diagnostics(r.diagnostics); });

  m.def(
      "reconstruct",
      [](const PointCloud& cloud, const py::object& options) {
        json j = json::object();
        if (!options.is_none()) j["poisson"] = options_json(options, "poisson options");
        const auto o = session::session_options_from_json(j, {}, "options").poisson;
        auto progress = progress_logger();
        return call([&] { return poisson::reconstruct(cloud, o, progress); });
      },
      "cloud"_a, "options"_a = py::none(),
      R"doc(Screened Poisson reconstruction of oriented points (paper §4.1, Kazhdan & Hoppe 2013): returns
a PoissonResult with the watertight mesh and the evaluable field. options: the "poisson" object of
the session config, e.g. {"depth": 8, "screening": 4.0}. Raises InputError for too few points,
missing normals, non-finite values or options out of range.)doc");

  py::class_<confidence::ConfidenceResult>(m, "ConfidenceResult", R"doc(
The confidence map (paper §4.2, Eq. 1-3): iso-points with scalars f, f_g, f_s (normalised to
[0, 1]), f_g_raw, f_s_raw, h; outward normals; colours by f; and the coloured mesh.)doc")
      .def_property_readonly(
          "iso_points", [](confidence::ConfidenceResult& r) -> PointCloud& { return r.iso_points; },
          py::return_value_policy::reference_internal)
      .def_property_readonly(
          "mesh", [](confidence::ConfidenceResult& r) -> TriangleMesh& { return r.mesh; },
          py::return_value_policy::reference_internal)
      .def_property_readonly(
          "inward_normals",
          [](py::object self) { return rows_view(self.cast<confidence::ConfidenceResult&>().inward_normals, self); })
      .def_readonly("mean_f", &confidence::ConfidenceResult::mean_f)
      .def_readonly("mean_f_g", &confidence::ConfidenceResult::mean_f_g)
      .def_readonly("mean_f_s", &confidence::ConfidenceResult::mean_f_s)
      .def_readonly("reference_gradient", &confidence::ConfidenceResult::reference_gradient)
      .def_readonly("reference_smoothness", &confidence::ConfidenceResult::reference_smoothness)
      .def_readonly("spacing", &confidence::ConfidenceResult::spacing)
      .def_readonly("seconds_total", &confidence::ConfidenceResult::seconds_total);

  const auto confidence_options = [](const py::object& options) {
    json j = json::object();
    if (!options.is_none()) j["confidence"] = options_json(options, "confidence options");
    auto o = session::session_options_from_json(j, {}, "options").confidence;
    o.progress = progress_logger();
    return o;
  };
  m.def(
      "confidence",
      [confidence_options](const poisson::PoissonResult& recon, const PointCloud& raw, const py::object& options) {
        const auto o = confidence_options(options);
        return call([&] { return confidence::assess(recon, raw, o); });
      },
      "reconstruction"_a, "raw"_a, "options"_a = py::none(),
      R"doc(The confidence map of a Poisson reconstruction against the raw points Q (paper §4.2): iso-points
s_k with completeness f_g (Eq. 1), smoothness f_s (Eq. 2) and f = f_g * f_s (Eq. 3). options: the
"confidence" object of the session config, e.g. {"k": 100, "iso": {"count": 10000}}.)doc");

  py::class_<confidence::CloudAssessment>(m, "CloudAssessment", "A reconstruction and its confidence map.")
      .def_property_readonly(
          "reconstruction", [](confidence::CloudAssessment& a) -> poisson::PoissonResult& { return a.reconstruction; },
          py::return_value_policy::reference_internal)
      .def_property_readonly(
          "confidence", [](confidence::CloudAssessment& a) -> confidence::ConfidenceResult& { return a.confidence; },
          py::return_value_policy::reference_internal);
  m.def(
      "assess_cloud",
      [confidence_options](const PointCloud& cloud, const py::object& poisson_options, const py::object& options) {
        json j = json::object();
        if (!poisson_options.is_none()) j["poisson"] = options_json(poisson_options, "poisson options");
        const auto po = session::session_options_from_json(j, {}, "options").poisson;
        const auto co = confidence_options(options);
        return call([&] { return confidence::assess_cloud(cloud, po, co); });
      },
      "cloud"_a, "poisson"_a = py::none(), "confidence"_a = py::none(),
      "Reconstructs an oriented cloud and assesses the result against the same points (what `autoscan plan` "
      "does before planning).");

  py::class_<PyPlan>(m, "PlanResult", R"doc(
Next-best views of one iteration (paper §5.1-5.2): the views in path order, the path length, the
viewing vector field g (Eq. 4) on its voxel grid, and the diagnostics.)doc")
      .def_property_readonly(
          "views",
          [](const PyPlan& p) {
            py::list l;
            for (const auto& v : p.r.views) {
              py::dict d = pose_dict(v.pose);
              d["score"] = v.score;
              d["target"] = py::make_tuple(v.target.x(), v.target.y(), v.target.z());
              d["voxel"] = v.voxel;
              d["cell"] = v.cell;
              d["eta"] = v.eta;
              d["zeta"] = v.zeta;
              l.append(d);
            }
            return l;
          },
          "The views as dicts: position, direction, up, score (g, Eq. 4), target (s_k', Eq. 5), voxel, cell, eta, "
          "zeta.")
      .def_property_readonly(
          "positions",
          [](const PyPlan& p) {
            std::vector<Vec3> v;
            for (const auto& w : p.r.views) v.push_back(w.pose.position);
            return take_rows(std::move(v));
          },
          "(K, 3) view positions.")
      .def_property_readonly(
          "directions",
          [](const PyPlan& p) {
            std::vector<Vec3> v;
            for (const auto& w : p.r.views) v.push_back(w.pose.normalized().direction);
            return take_rows(std::move(v));
          },
          "(K, 3) unit view directions.")
      .def_property_readonly(
          "targets",
          [](const PyPlan& p) {
            std::vector<Vec3> v;
            for (const auto& w : p.r.views) v.push_back(w.target);
            return take_rows(std::move(v));
          },
          "(K, 3) aimed-at iso-points.")
      .def_property_readonly(
          "scores",
          [](const PyPlan& p) {
            std::vector<double> v;
            for (const auto& w : p.r.views) v.push_back(w.score);
            return take_column(std::move(v));
          },
          "(K,) g of each view.")
      .def_property_readonly("path_length", [](const PyPlan& p) { return p.r.path_length; })
      .def_property_readonly(
          "g",
          [](py::object self) {
            auto& f = self.cast<PyPlan&>().r.field;
            const auto& d = f.grid.dims;
            if (f.g.empty()) return py::array(py::array_t<double>(0));
            return py::array(py::array_t<double>({py::ssize_t(d[2]), py::ssize_t(d[1]), py::ssize_t(d[0])},
                                                 {py::ssize_t(sizeof(double)) * d[0] * d[1],
                                                  py::ssize_t(sizeof(double)) * d[0], py::ssize_t(sizeof(double))},
                                                 f.g.data(), self));
          },
          "The viewing vector field g (Eq. 4) as a [k, j, i] float64 view (x fastest).")
      .def_property_readonly(
          "grid",
          [](const PyPlan& p) {
            const auto& g = p.r.field.grid;
            py::array_t<double> axes({3, 3});
            for (int i = 0; i < 3; ++i)
              for (int j = 0; j < 3; ++j) axes.mutable_at(i, j) = g.axes(i, j);
            return py::dict("origin"_a = py::make_tuple(g.origin.x(), g.origin.y(), g.origin.z()), "axes"_a = axes,
                            "dims"_a = py::make_tuple(g.dims[0], g.dims[1], g.dims[2]),
                            "spacing"_a = py::make_tuple(g.spacing.x(), g.spacing.y(), g.spacing.z()));
          },
          "The voxel grid: origin (corner), axes (columns), dims (nx, ny, nz), spacing.")
      .def_property_readonly("diagnostics",
                             [](const PyPlan& p) { return from_json(nbv::diagnostics_to_json(p.r.diagnostics)); })
      .def(
          "to_json", [](const PyPlan& p) { return from_json(nbv::views_to_json(p.r)); },
          "The views file's content ({'views': [...], 'path_length': L}).");

  m.def(
      "plan",
      [](const TriangleMesh& mesh, const PointCloud& iso_points, const py::object& spec, const py::object& rig,
         const py::object& current, const py::object& options, const std::shared_ptr<poisson::PoissonField>& field) {
        const ScannerSpec s = to_scanner(spec);
        const Rig r = to_rig(rig);
        const auto from = to_optional_pose(current, "current");
        json j = json::object();
        if (!options.is_none()) j["nbv"] = options_json(options, "plan options");
        const auto o = session::session_options_from_json(j, {}, "options").nbv;
        auto progress = progress_logger();
        return call([&] {
          const nbv::NbvPlanner planner(mesh, s, r, o);
          return PyPlan{planner.plan(iso_points, from, field.get(), progress)};
        });
      },
      "mesh"_a, "iso_points"_a, "scanner"_a = py::none(), "rig"_a = py::none(), "current"_a = py::none(),
      "options"_a = py::none(), "field"_a = py::none(),
      R"doc(Next-best views (paper §5.1-5.2): the viewing vector field (Eq. 4) around `mesh` from the
iso-points (outward normals, scalar "f"), per-cell maxima, aiming (Eq. 5), ordered into a path from
`current`. `field` (a PoissonField) is the inside test when given. options: the "nbv" object of the
session config, e.g. {"grid_resolution": 100, "max_views": 10}.)doc");
}

void bind_session(py::module_& m) {
  py::class_<PyNextViews>(m, "NextViews", "One iteration's answer (session/session.hpp).")
      .def_property_readonly(
          "views", [](const PyNextViews& n) { return planned_views(n.r.views); },
          "The views in path order, as dicts (position, direction, up, score, target): pass one to "
          "VirtualScanner.scan or send it to the robot.")
      .def_property_readonly("path_length", [](const PyNextViews& n) { return n.r.path_length; })
      .def_property_readonly("stopped", [](const PyNextViews& n) { return n.r.stopped; })
      .def_property_readonly(
          "reason", [](const PyNextViews& n) { return n.r.reason; },
          "Why it stopped: '', 'complete', 'no_improvement', 'quality_fell' (the default rule), 'converged', "
          "'confidence_fell' (the paper's rule), 'quality_fell_truth', 'max_iterations', 'max_views', 'no_views' "
          "(docs/stop-rule.md).")
      .def_property_readonly("iteration", [](const PyNextViews& n) { return n.r.iteration; })
      .def_property_readonly("directory", [](const PyNextViews& n) { return n.r.directory; })
      .def_property_readonly(
          "mesh",
          [](const PyNextViews& n) -> py::object {
            if (!n.r.reconstruction) return py::none();
            return py::cast(TriangleMesh(n.r.reconstruction->mesh));
          },
          "A copy of this iteration's model (coloured by f), or None when the answer was replayed.")
      .def_property_readonly(
          "iso_points",
          [](const PyNextViews& n) -> py::object {
            if (!n.r.reconstruction) return py::none();
            return py::cast(PointCloud(n.r.reconstruction->iso_points));
          },
          "A copy of this iteration's iso-points (scalars f, f_g, f_s), or None.")
      .def_property_readonly("mean_f", [](const PyNextViews& n) -> py::object {
        if (!n.r.reconstruction) return py::none();
        return py::float_(n.r.reconstruction->mean_f);
      });

  py::class_<PySession>(m, "Session", R"doc(
The autoscanning loop as a step-by-step API a robot drives (paper §3, §5.3):

    s = autoscan.Session.create(dir, scanner={...}, rig="free", options={...})   # or Session.open(dir)
    for cloud, pose in blind_scans: s.add_scan(cloud, pose)
    while True:
        step = s.next_views()
        if step.stopped: break
        for view in step.views: s.add_scan(robot.scan(view), robot.reported_pose())

All state lives in the directory (docs/session-format.md) and every scan is durable when add_scan
returns. One process per directory (a lock file); close() or `with` releases it.)doc")
      .def_static(
          "create",
          [](const py::object& dir, const py::object& spec, const py::object& rig, const py::object& options) {
            const auto path = to_path(dir);
            const ScannerSpec s = to_scanner(spec);
            const Rig r = to_rig(rig);
            const auto o = session_options(options, "session options");
            auto ps = std::make_unique<PySession>();
            ps->s.emplace(call([&] { return session::Session::create(path, s, r, o); }));
            return ps;
          },
          "directory"_a, "scanner"_a = py::none(), "rig"_a = py::none(), "options"_a = py::none(),
          "Creates a session in `directory` (must not hold one). options: the session config "
          "(docs/session-format.md), e.g. {'planner': 'poisson', 'max_views': 40}.")
      .def_static(
          "open",
          [](const py::object& dir) {
            const auto path = to_path(dir);
            auto ps = std::make_unique<PySession>();
            ps->s.emplace(call([&] { return session::Session::open(path); }));
            return ps;
          },
          "directory"_a, "Resumes the session in `directory` (the model is bit-identical to before).")
      .def(
          "add_scan",
          [](PySession& ps, const PointCloud& scan, const py::object& pose) {
            const Pose p = to_pose(pose, "reported_pose");
            auto& s = ps.get();
            const auto rec = call([&] { return s.add_scan(scan, p); });
            return from_json(session::to_json(rec));
          },
          "scan"_a, "reported_pose"_a,
          "Takes one scan (points in the world frame of `reported_pose`): registers it to the model "
          "(weighted ICP), inserts its points selectively (Eq. 6) and persists it. Returns the scan record.")
      .def(
          "next_views",
          [](PySession& ps, const py::object& current) {
            const auto from = to_optional_pose(current, "current");
            auto& s = ps.get();
            return call([&] { return PyNextViews{from ? s.next_views(*from) : s.next_views()}; });
          },
          "current"_a = py::none(),
          "Runs one iteration: consolidate -> Poisson -> confidence -> planner, or stops (the stop rule, "
          "docs/stop-rule.md; a budget spent, nothing to scan). `current`: the scanner's pose (default: the last "
          "scan's).")
      .def(
          "refuse_view",
          [](PySession& ps, const py::object& pose, const std::string& reason) {
            const Pose p = to_pose(pose, "pose");
            call([&] { ps.get().refuse_view(p, reason); });
          },
          "pose"_a, "reason"_a = "",
          "Tells the session the robot could not take `pose` (a collision, a joint limit): later plans keep "
          "every view out of a ball of 0.5 d_n around it (persisted in session.json 'refused_views').")
      .def(
          "status", [](PySession& ps) { return from_json(session::to_json(ps.get().status())); },
          "The session's state: scans, model points, iterations, stopped, last mean f...")
      .def(
          "iterations",
          [](PySession& ps) {
            py::list l;
            for (const auto& it : ps.get().iterations()) l.append(from_json(session::to_json(it)));
            return l;
          },
          "Every iteration's record (session.json 'iterations').")
      .def(
          "model_points", [](PySession& ps) { return PointCloud(ps.get().model_points()); },
          "A copy of the model's raw points (every inserted point, registered, world frame).")
      .def(
          "attach_truth",
          [](PySession& ps, int index, const py::object& truth) {
            ps.get().attach_truth(index, to_json(truth, "truth"));
          },
          "index"_a, "truth"_a, "Attaches ground-truth figures (a dict) to iteration `index`.")
      .def_property_readonly("directory", [](PySession& ps) { return ps.get().directory(); })
      .def_property_readonly("options", [](PySession& ps) { return from_json(session::to_json(ps.get().options())); })
      .def(
          "close", [](PySession& ps) { ps.s.reset(); }, "Releases the session (and its lock file).")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](PySession& ps, const py::args&) { ps.s.reset(); });
}

void bind_simulation(py::module_& m) {
  m.def(
      "simulate",
      [](const py::object& mesh, const py::object& out, const py::object& options) {
        const TriangleMesh t = to_mesh(mesh);
        const auto path = to_path(out);
        const simulation::SimulateOptions defaults;  // named: GCC 12 warns (maybe-uninitialized) about a temporary
        const auto o = simulation::simulate_options_from_json(options_json(options, "simulate options"), defaults,
                                                              "simulate options");
        o.validate();
        auto progress = progress_logger();
        return from_json(call([&] { return simulation::simulate(t, path, o, progress); }).to_json());
      },
      "mesh"_a, "out"_a, "options"_a = py::none(),
      R"doc(The whole loop in simulation (paper §6): the virtual scanner drives a session in `out` (blind
scan, then next views -> scans until the stop rule), with ground-truth figures per iteration.
options: the simulate config ({"session": {...}, "scanner": {...}, "rig": {...}, "blind": {...},
"eval": {...}, "report": false, ...}). Returns the summary (mean_f, truth, views, ...).)doc");

  const auto eval_options = [](const py::object& options) {
    simulation::SimulateOptions base;
    base.eval = {};
    json j = json::object();
    if (!options.is_none()) j["eval"] = options_json(options, "evaluate options");
    return simulation::simulate_options_from_json(j, base, "options").eval;
  };
  m.def(
      "evaluate",
      [eval_options](const py::object& mesh, const py::object& truth, const py::object& options) {
        const TriangleMesh r = to_mesh(mesh);
        const TriangleMesh t = to_mesh(truth);
        const auto o = eval_options(options);
        return from_json(call([&] { return eval::evaluate_mesh(r, t, o); }).to_json());
      },
      "mesh"_a, "truth"_a, "options"_a = py::none(),
      R"doc(Ground-truth metrics of a reconstruction (meshes or paths): accuracy, completeness,
precision/recall/F-score at tau, the Figure 9 histogram. options: {tau, samples, seed,
histogram_bins, histogram_max}.)doc");
  m.def(
      "evaluate_cloud",
      [eval_options](const PointCloud& cloud, const py::object& truth, const py::object& options) {
        const TriangleMesh t = to_mesh(truth);
        const auto o = eval_options(options);
        return from_json(call([&] { return eval::evaluate_cloud(cloud, t, o); }).to_json());
      },
      "cloud"_a, "truth"_a, "options"_a = py::none(),
      "Accuracy of a point cloud against the truth and its coverage of the truth (evaluate --cloud).");
}

}  // namespace
}  // namespace autoscan::python

PYBIND11_MODULE(_autoscan, m) {
  using namespace autoscan::python;
  m.doc() = "Quality-driven Poisson-guided autoscanning (Wu et al. 2014): the autoscan library over NumPy.";
  m.attr("__version__") = AUTOSCAN_VERSION;

  static py::exception<autoscan::Error> error(m, "Error", PyExc_RuntimeError);
  static py::exception<autoscan::InputError> input_error(m, "InputError",
                                                         py::make_tuple(error, py::handle(PyExc_ValueError)));
  // Translators run most recent first: InputError before its base.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const autoscan::InputError& e) {
      PyErr_SetString(input_error.ptr(), e.what());
    } catch (const autoscan::Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });

  auto logger = std::make_shared<spdlog::logger>("autoscan", queue_sink());
  spdlog::set_default_logger(logger);

  bind_geometry(m);
  bind_io(m);
  bind_scanner(m);
  bind_reconstruction(m);
  bind_session(m);
  bind_simulation(m);
}
