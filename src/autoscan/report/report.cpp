#include "autoscan/report/report.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <unordered_map>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/html.hpp"
#include "autoscan/core/log.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/session_layout.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/report/bundle.hpp"

namespace autoscan::report {
namespace fs = std::filesystem;
using nlohmann::json;

std::string base64(const void* data, std::size_t size) {
  static constexpr char tbl[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* b = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const unsigned v = (b[i] << 16) | (b[i + 1] << 8) | b[i + 2];
    out += tbl[(v >> 18) & 63];
    out += tbl[(v >> 12) & 63];
    out += tbl[(v >> 6) & 63];
    out += tbl[v & 63];
  }
  if (i < size) {
    unsigned v = b[i] << 16;
    if (i + 1 < size) v |= b[i + 1] << 8;
    out += tbl[(v >> 18) & 63];
    out += tbl[(v >> 12) & 63];
    out += i + 1 < size ? tbl[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

namespace {

// Collects the binary buffers of the page; each becomes a <script type="application/octet-stream">.
struct Buffers {
  std::vector<std::pair<std::string, std::string>> items;  // id, base64
  std::size_t bytes = 0;
  template <typename T>
  std::string add(const std::vector<T>& v) {
    std::string id = "buf-" + std::to_string(items.size());
    items.emplace_back(id, base64(v.data(), v.size() * sizeof(T)));
    bytes += v.size() * sizeof(T);
    return id;
  }
};

std::optional<json> read_json_file(const fs::path& p) {
  std::error_code ec;
  if (!fs::exists(p, ec)) return std::nullopt;
  auto j = json::parse(read_text_file(p), nullptr, false);
  AUTOSCAN_REQUIRE(!j.is_discarded(), "{}: not valid JSON", p.string());
  return j;
}

json number_or_null(const json& obj, const char* key) {
  if (obj.is_object() && obj.contains(key) && obj[key].is_number()) return obj[key];
  return nullptr;
}

// JSON embedded in a <script> must not contain "</".
std::string script_safe(std::string s) {
  std::string::size_type pos = 0;
  while ((pos = s.find("</", pos)) != std::string::npos) {
    s.replace(pos, 2, "<\\/");
    pos += 3;
  }
  return s;
}

const char* kStyle = R"CSS(
*{box-sizing:border-box}
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;margin:0;background:#fafafa;color:#222;overflow-x:hidden}
header{padding:10px 16px;background:#1f2937;color:#fff}header h1{font-size:18px;margin:0;overflow-wrap:anywhere}
header p{margin:4px 0 0;font-size:13px;color:#cbd5e1}
h3{margin:10px 0 6px}
.certificate{margin:12px;padding:12px 16px;background:#fff;border:1px solid #ddd;border-left:8px solid #b40426;border-radius:6px}
.certificate.done{border-left-color:#1a7f37}.certificate.partial{border-left-color:#d97706}
.certificate h2{margin:0 0 4px;font-size:15px;font-weight:600;color:#555}
.verdict{font-size:28px;font-weight:700;margin:0}.done .verdict{color:#1a7f37}.not-done .verdict{color:#b40426}
.partial .verdict{color:#b45309}.why{margin:4px 0 10px;font-size:14px}
.figures{display:flex;flex-wrap:wrap;gap:8px;margin:0 0 10px}
.figure{background:#f6f7f9;border:1px solid #e5e7eb;border-radius:6px;padding:6px 10px;min-width:130px;max-width:220px}
.figure b{display:block;font-size:18px}.figure span{font-size:12px;color:#555}
.scroll{overflow-x:auto;max-width:100%}
main{display:grid;grid-template-columns:minmax(0,1fr) minmax(0,360px);gap:12px;padding:0 12px}
#viewport{height:62vh;min-height:380px;background:#f4f4f4;border:1px solid #ddd;border-radius:6px;overflow:hidden}
.controls{display:flex;flex-wrap:wrap;gap:6px 14px;align-items:center;margin:6px 0;font-size:14px}
#iteration{width:220px;max-width:50vw}
#slice{display:block;width:100%;max-width:360px;border:1px solid #ddd;border-radius:4px;image-rendering:pixelated}
.caption{font-size:12px;color:#555;margin:4px 0}
.plot{background:#fff;border:1px solid #ddd;border-radius:6px;margin:0 8px 8px 0;max-width:100%;height:auto}
.plot-title{font-size:13px;font-weight:600}.tick{font-size:10px;fill:#555}
#plots{display:flex;flex-wrap:wrap}table{border-collapse:collapse;font-size:13px}
td,th{padding:2px 8px;border-bottom:1px solid #eee;text-align:right;white-space:nowrap}
.legend{display:flex;flex-wrap:wrap;gap:4px 14px;align-items:center;font-size:13px;margin:6px 0}
.sw{display:inline-block;width:12px;height:12px;margin-right:4px;vertical-align:middle;border-radius:2px}
.ring{display:inline-block;width:12px;height:12px;margin-right:4px;vertical-align:middle;border-radius:50%;border:3px solid}
#colorbar{display:inline-block;position:relative;width:200px;height:12px;vertical-align:middle;border:1px solid #999}
#colorbar-threshold{position:absolute;top:-4px;width:2px;height:20px;background:#000}
.history{padding:0 12px 12px}
@media (max-width:960px){main{grid-template-columns:minmax(0,1fr)}table{font-size:12px}td,th{padding:2px 3px}
th{white-space:normal}}
)CSS";

// Display decimation of large meshes by vertex clustering: vertices are merged per cell of a grid
// whose cell size gives about `max_faces` faces (faces ≈ 2·area/h²); a cell's vertex is the mean of
// its members and carries the mean of their scalars; collapsed faces are dropped.
TriangleMesh cluster_vertices(const TriangleMesh& mesh, std::size_t max_faces) {
  const double h = std::sqrt(2.0 * std::max(mesh.area(), 1e-12) / static_cast<double>(max_faces));
  const AABB box = mesh.bounds();
  std::unordered_map<std::uint64_t, int> cell_of;
  std::vector<int> remap(mesh.vertices.size());
  TriangleMesh out;
  std::vector<int> members;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Vec3 q = (mesh.vertices[v] - box.min) / h;
    const auto key = (static_cast<std::uint64_t>(q.x()) << 42) ^ (static_cast<std::uint64_t>(q.y()) << 21) ^
                     static_cast<std::uint64_t>(q.z());
    auto [it, inserted] = cell_of.try_emplace(key, static_cast<int>(out.vertices.size()));
    if (inserted) {
      out.vertices.push_back(Vec3::Zero());
      members.push_back(0);
    }
    remap[v] = it->second;
    out.vertices[it->second] += mesh.vertices[v];
    ++members[it->second];
  }
  for (std::size_t i = 0; i < out.vertices.size(); ++i) out.vertices[i] /= members[i];
  for (const auto& [name, col] : mesh.vertex_scalars.columns()) {
    std::vector<double> acc(out.vertices.size(), 0.0);
    for (std::size_t v = 0; v < col.size(); ++v) acc[remap[v]] += col[v];
    for (std::size_t i = 0; i < acc.size(); ++i) acc[i] /= members[i];
    out.vertex_scalars.set(name, std::move(acc));
  }
  for (const auto& f : mesh.faces) {
    const Tri t{remap[f[0]], remap[f[1]], remap[f[2]]};
    if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) out.faces.push_back(t);
  }
  return out;
}

// The iteration's point cloud for the viewer: positions (and the "new" flags), decimated to the
// display budget by a seeded Bernoulli pick.
json cloud_entry(const fs::path& file, const ReportOptions& opt, Rng& rng, Buffers& bufs, ReportResult& result) {
  const PointCloud cloud = io::read_point_cloud(file);
  const std::size_t n = cloud.size();
  std::vector<std::size_t> keep;
  if (n > opt.max_points) {
    // Deterministic display decimation: a seeded Bernoulli pick with the budget's rate.
    const double rate = static_cast<double>(opt.max_points) / static_cast<double>(n);
    for (std::size_t i = 0; i < n; ++i)
      if (rng.uniform() < rate) keep.push_back(i);
  } else {
    keep.resize(n);
    for (std::size_t i = 0; i < n; ++i) keep[i] = i;
  }
  std::vector<float> pos;
  pos.reserve(keep.size() * 3);
  std::vector<std::uint8_t> isnew;
  const auto* newcol = cloud.scalars.find("new");
  for (auto i : keep) {
    for (int c = 0; c < 3; ++c) pos.push_back(static_cast<float>(cloud.positions[i][c]));
    if (newcol) isnew.push_back((*newcol)[i] > 0.5 ? 1 : 0);
  }
  json c{{"count", keep.size()}, {"total", n}, {"positions", bufs.add(pos)}};
  if (newcol) c["new"] = bufs.add(isnew);
  result.points_shown += keep.size();
  return c;
}

// The coloured model (docs/colour.md): its colours ride along as scalars color_r/g/b, so that display
// decimation averages them like f. False when the coloured mesh does not match `mesh`.
bool attach_colors(const fs::path& file, TriangleMesh& mesh) {
  const TriangleMesh cm = io::read_mesh(file);
  if (cm.vertices.size() != mesh.vertices.size() || cm.vertex_colors.size() != cm.vertices.size()) return false;
  const char* names[] = {"color_r", "color_g", "color_b"};
  for (int c = 0; c < 3; ++c) {
    std::vector<double> ch(cm.vertices.size());
    for (std::size_t v = 0; v < ch.size(); ++v) ch[v] = cm.vertex_colors[v][static_cast<std::size_t>(c)] / 255.0;
    mesh.vertex_scalars.set(names[c], std::move(ch));
  }
  return true;
}

// Columns of values in [0, 1] as bytes (round(255 · value), clamped), interleaved per vertex.
std::vector<std::uint8_t> unit_bytes(std::initializer_list<const std::vector<double>*> columns) {
  const std::size_t n = (*columns.begin())->size();
  std::vector<std::uint8_t> out;
  out.reserve(n * columns.size());
  for (std::size_t v = 0; v < n; ++v)
    for (const auto* col : columns) {
      const double x = std::isfinite((*col)[v]) ? std::clamp((*col)[v], 0.0, 1.0) : 0.0;
      out.push_back(static_cast<std::uint8_t>(std::lround(255.0 * x)));
    }
  return out;
}

// The iteration's Poisson mesh for the viewer: positions, indices, f/f_g/f_s and the colours,
// decimated by vertex clustering beyond the display budget. Sets `any_color` for a coloured mesh.
json mesh_entry(const SessionLayout& layout, int index, const ReportOptions& opt, Buffers& bufs, bool& any_color) {
  TriangleMesh mesh = io::read_mesh(layout.mesh(index));
  std::error_code ec;
  const bool colored = fs::exists(layout.mesh_color(index), ec) && attach_colors(layout.mesh_color(index), mesh);
  if (mesh.faces.size() > opt.max_mesh_faces) mesh = cluster_vertices(mesh, opt.max_mesh_faces);
  std::vector<float> pos;
  pos.reserve(mesh.vertices.size() * 3);
  for (const auto& v : mesh.vertices)
    for (int c = 0; c < 3; ++c) pos.push_back(static_cast<float>(v[c]));
  std::vector<std::uint32_t> idx;
  for (const auto& f : mesh.faces)
    for (int c = 0; c < 3; ++c) idx.push_back(static_cast<std::uint32_t>(f[c]));
  json m{{"vertices", mesh.vertices.size()}, {"positions", bufs.add(pos)}, {"indices", bufs.add(idx)}};
  json scalars = json::object();
  // f, f_g, f_s (in [0, 1]) and the colours as bytes (value · 255): a quarter of the floats' size, and
  // finer than the display's colour steps.
  for (const char* s : {"f", "f_g", "f_s"}) {
    if (const auto* col = mesh.vertex_scalars.find(s)) scalars[s] = bufs.add(unit_bytes({col}));
  }
  m["scalars"] = scalars;
  if (colored) {
    m["color"] = bufs.add(unit_bytes({&mesh.vertex_scalars.get("color_r"), &mesh.vertex_scalars.get("color_g"),
                                      &mesh.vertex_scalars.get("color_b")}));
    any_color = true;
  }
  return m;
}

// What the page shows of the session: the manifest (iterations with their buffers, plots, title)
// and the binary buffers.
struct Page {
  json manifest;
  Buffers bufs;
  ReportResult result;
  std::unordered_map<long long, json> scan_pose;  ///< scan id → its (registered) pose, from session.json
};

// Scan id → the pose it was taken from (the registered one when the session has it), for the frusta
// of the views already scanned.
std::unordered_map<long long, json> scan_pose_map(const json& session) {
  std::unordered_map<long long, json> out;
  for (const auto& sc : session.value("scans", json::array())) {
    if (!sc.is_object() || !sc.contains("id") || !sc["id"].is_number_integer()) continue;
    for (const char* key : {"registered_pose", "pose"}) {
      const json pose = sc.value(key, json(nullptr));
      if (pose.is_object() && pose.contains("position") && pose.contains("direction")) {
        out[sc["id"].get<long long>()] = pose;
        break;
      }
    }
  }
  return out;
}

// The poses of the scans iteration record `rec` added (its "scans": ids), in order.
json scan_poses(const std::unordered_map<long long, json>& poses, const json& rec) {
  json out = json::array();
  for (const auto& id : rec.value("scans", json::array())) {
    if (!id.is_number_integer()) continue;
    const auto it = poses.find(id.get<long long>());
    if (it != poses.end()) out.push_back(it->second);
  }
  return out;
}

// The per-iteration series of the history plots (manifest.plots).
constexpr const char* kPlotSeries[] = {"mean_f",
                                       "mean_f_g",
                                       "mean_f_s",
                                       "accuracy_mean",
                                       "completeness_mean",
                                       "coverage",
                                       "coverage_scannable",
                                       "fscore",
                                       "share_confident",
                                       "share_improvable",
                                       "share_unreachable",
                                       "share_too_noisy"};

// Appends the plot series and the seconds per stage of iteration record `rec` (the k-th).
void add_plot_points(const json& rec, std::size_t k, json& plots, json& seconds) {
  plots["mean_f"].push_back(number_or_null(rec, "mean_f"));
  plots["mean_f_g"].push_back(number_or_null(rec, "mean_f_g"));
  plots["mean_f_s"].push_back(number_or_null(rec, "mean_f_s"));
  const json truth = rec.value("truth", json::object());
  plots["accuracy_mean"].push_back(number_or_null(truth, "accuracy_mean"));
  plots["completeness_mean"].push_back(number_or_null(truth, "completeness_mean"));
  plots["coverage"].push_back(number_or_null(truth, "coverage"));
  plots["coverage_scannable"].push_back(number_or_null(truth, "coverage_scannable"));
  plots["fscore"].push_back(number_or_null(truth, "fscore"));
  const json cert = rec.value("certificate", json::object());
  plots["share_confident"].push_back(number_or_null(cert, "share_confident"));
  plots["share_improvable"].push_back(number_or_null(cert, "share_improvable"));
  plots["share_unreachable"].push_back(number_or_null(cert, "share_unreachable"));
  plots["share_too_noisy"].push_back(number_or_null(cert, "share_too_noisy"));
  if (rec.contains("seconds") && rec["seconds"].is_object()) {
    for (const auto& [stage, v] : rec["seconds"].items()) {
      if (!seconds.contains(stage)) seconds[stage] = json::array();
      while (seconds[stage].size() < k) seconds[stage].push_back(nullptr);
      seconds[stage].push_back(v.is_number() ? v : json(nullptr));
    }
  }
}

// One iteration of the manifest: its figures and the files of iterations/iter_KKK/ it finds.
json iteration_entry(const SessionLayout& layout, const json& rec, int index, const ReportOptions& opt, Rng& rng,
                     Page& page, bool& any_color) {
  json it;
  it["index"] = index;
  it["scans"] = scan_poses(page.scan_pose, rec);
  if (rec.contains("truth") && rec["truth"].is_object()) {
    json t = json::object();
    for (const char* k : {"coverage", "coverage_scannable", "fscore", "accuracy_mean"})
      if (rec["truth"].contains(k)) t[k] = number_or_null(rec["truth"], k);
    it["truth"] = t;
  }
  it["stop_reason"] =
      rec.contains("stop_reason") && rec["stop_reason"].is_string() ? rec["stop_reason"] : json(nullptr);
  it["points"] = number_or_null(rec, "points");
  it["mean_f"] = number_or_null(rec, "mean_f");
  std::error_code ec;
  if (fs::exists(layout.cloud(index), ec))
    it["cloud"] = cloud_entry(layout.cloud(index), opt, rng, page.bufs, page.result);
  if (fs::exists(layout.mesh(index), ec)) it["mesh"] = mesh_entry(layout, index, opt, page.bufs, any_color);
  if (auto views = read_json_file(layout.views(index))) {
    it["views"] = views->value("views", json::array());
    if (views->contains("start")) it["start"] = (*views)["start"];
    it["path_length"] = number_or_null(*views, "path_length");
  }
  if (fs::exists(layout.field_slice(index), ec)) {
    const std::string png = read_text_file(layout.field_slice(index));
    it["slice"] = "data:image/png;base64," + base64(png.data(), png.size());
  }
  if (rec.contains("certificate") && rec["certificate"].is_object()) it["certificate"] = rec["certificate"];
  return it;
}

// The manifest and the buffers of every iteration of `session` (session.json of `layout`).
Page build_page(const SessionLayout& layout, const json& session, const ReportOptions& opt) {
  Page page;
  json& manifest = page.manifest;
  manifest["title"] = opt.title.empty() ? fs::absolute(layout.dir()).filename().string() : opt.title;
  if (session.contains("scanner")) manifest["scanner"] = session["scanner"];
  json iterations = json::array();
  bool any_color = false;  // a coloured model: the viewer opens on it (docs/colour.md)
  json plots;
  for (const char* k : kPlotSeries) plots[k] = json::array();
  json seconds = json::object();
  Rng rng(opt.seed);
  page.scan_pose = scan_pose_map(session);
  const auto& its = session["iterations"];
  for (std::size_t k = 0; k < its.size(); ++k) {
    const json& rec = its[k];
    const int index = rec.value("index", static_cast<int>(k));
    add_plot_points(rec, k, plots, seconds);
    const json truth = rec.value("truth", json::object());
    // The logarithmic bins when the session has them (eval::make_log_histogram), else the linear ones.
    if (truth.contains("log_histogram")) {
      manifest["histogram"] = truth["log_histogram"];
      manifest["histogram"]["log"] = true;
    } else if (truth.contains("histogram")) {
      manifest["histogram"] = truth["histogram"];
    }
    iterations.push_back(iteration_entry(layout, rec, index, opt, rng, page, any_color));
  }
  for (auto& [stage, v] : seconds.items())
    while (v.size() < its.size()) v.push_back(nullptr);
  plots["seconds"] = seconds;
  manifest["iterations"] = iterations;
  manifest["has_color"] = any_color;
  manifest["plots"] = plots;
  page.result.iterations = static_cast<int>(iterations.size());
  return page;
}

// A number of `o`'s `key` with `prec` decimals, or "–".
std::string num(const json& o, const char* key, int prec) {
  return o.is_object() && o.contains(key) && o[key].is_number() ? fmt::format("{:.{}f}", o[key].get<double>(), prec)
                                                                : std::string("–");
}

// A share of `o`'s `key` in per cent with two decimals, or "–".
std::string pct(const json& o, const char* key) {
  return o.is_object() && o.contains(key) && o[key].is_number() ? fmt::format("{:.2f} %", 100.0 * o[key].get<double>())
                                                                : std::string("–");
}

// The table of the iterations: the certificate's shares, the truth's figures, the stop.
std::string summary_table(const json& its) {
  std::ostringstream table;
  table << "<table id=\"iterations-table\"><tr><th>iteration</th><th>points</th><th>views</th><th>mean f</th>"
           "<th>confident</th><th>improvable</th><th>unreachable</th><th>too noisy</th><th>regions</th>"
           "<th>coverage</th><th>F-score</th><th>accuracy</th><th>stop</th></tr>";
  for (const auto& rec : its) {
    const json truth = rec.value("truth", json::object());
    const json cert = rec.value("certificate", json::object());
    const json cov = truth.is_object() && truth.contains("coverage_scannable") ? truth : json::object();
    table << "<tr><td>" << rec.value("index", 0) << "</td><td>" << num(rec, "points", 0) << "</td><td>"
          << num(rec, "views", 0) << "</td><td>" << num(rec, "mean_f", 3) << "</td><td>" << pct(cert, "share_confident")
          << "</td><td>" << pct(cert, "share_improvable") << "</td><td>" << pct(cert, "share_unreachable")
          << "</td><td>" << pct(cert, "share_too_noisy") << "</td><td>"
          << (cert.is_object() && cert.contains("regions") ? std::to_string(cert["regions"].size()) : "–")
          << "</td><td>" << (cov.empty() ? pct(truth, "coverage") : pct(truth, "coverage_scannable")) << "</td><td>"
          << num(truth, "fscore", 4) << "</td><td>" << num(truth, "accuracy_mean", 6) << "</td><td>"
          << (rec.contains("stop_reason") && rec["stop_reason"].is_string()
                  ? escape_html(rec["stop_reason"].get<std::string>())
                  : std::string())
          << "</td></tr>";
  }
  table << "</table>";
  return table.str();
}

// What a stop reason (docs/session-format.md) means, in a sentence.
std::string stop_meaning(const std::string& reason) {
  static const std::pair<const char*, const char*> kMeaning[] = {
      {"complete", "what views can still improve is below the remaining share of the surface"},
      {"no_improvement", "views stopped improving the low-confidence regions they looked at"},
      {"quality_fell", "the mean confidence fell below the best iteration's; the result is the best iteration"},
      {"past_best",
       "more scans no longer made the model more accurate (its points thickened); the result is its most accurate "
       "iteration"},
      {"quality_fell_truth", "the F-score against the truth fell; the result is the best iteration"},
      {"converged", "the mean confidence stopped changing (the paper's rule)"},
      {"confidence_fell", "the mean confidence fell (the paper's rule)"},
      {"max_iterations", "the iteration budget ran out"},
      {"max_views", "the view budget ran out"},
      {"no_views", "the planner found no view worth scanning"}};
  for (const auto& [key, meaning] : kMeaning)
    if (reason == key) return meaning;
  return reason.empty() ? "the session is still running" : "";
}

// The colour of a region's reason (the same as the viewer's markers, report/src/viewer.js).
const char* reason_color(const std::string& reason) {
  if (reason == "not_scanned") return "#7c3aed";
  if (reason == "improving") return "#db2777";
  if (reason == "unreachable") return "#111827";
  if (reason == "too_noisy") return "#a16207";
  return "#888888";
}

// The rows of the certificate's regions.
void certificate_regions(const json& cert, std::ostringstream& out) {
  const json regions = cert.value("regions", json::array());
  out << "<h3>" << regions.size() << " region" << (regions.size() == 1 ? "" : "s")
      << " of low confidence left (ringed in the 3D view)</h3>";
  if (regions.empty()) return;
  out << "<div class=\"scroll\"><table id=\"regions-table\"><tr><th>region</th><th>reason</th><th>share</th>"
         "<th>mean f</th><th>has data</th><th>views aimed</th><th>expected accuracy</th><th>radius</th>"
         "<th>centroid</th></tr>";
  for (const auto& r : regions) {
    const auto c = r.value("centroid", json::array());
    const std::string reason = r.value("reason", std::string());
    out << "<tr><td>" << r.value("id", 0)
        << "</td><td style=\"text-align:left\"><span class=\"ring\" style=\"border-color:" << reason_color(reason)
        << "\"></span>" << escape_html(reason) << "</td><td>" << pct(r, "share") << "</td><td>" << num(r, "mean_f", 3)
        << "</td><td>" << (r.value("has_data", false) ? "yes" : "no") << "</td><td>" << num(r, "views_aimed", 0)
        << "</td><td>" << fmt::format("{:.3g}", r.value("expected_accuracy", 0.0)) << "</td><td>" << num(r, "radius", 3)
        << "</td><td>"
        << (c.size() == 3 && c[0].is_number() && c[1].is_number() && c[2].is_number()
                ? fmt::format("{:.3f}, {:.3f}, {:.3f}", c[0].get<double>(), c[1].get<double>(), c[2].get<double>())
                : std::string("–"))
        << "</td></tr>";
  }
  out << "</table></div>";
}

// One figure tile of the certificate: a value and what it is.
std::string figure(const std::string& value, const std::string& what) {
  return "<div class=\"figure\"><b>" + value + "</b><span>" + what + "</span></div>";
}

// The key figures of the certificate (and of the truth, in a simulation).
void certificate_figures(const json& session, const json& cert, const json& truth, std::ostringstream& out) {
  out << "<div class=\"figures\">"
      << figure(pct(cert, "share_confident"),
                fmt::format("of the surface confident (f &ge; {:.3f})", cert.value("threshold", 0.0)))
      << figure(pct(cert, "share_improvable"), "views can still improve (not scanned, improving)")
      << figure(pct(cert, "share_unreachable"), "unreachable: no view sees it")
      << figure(pct(cert, "share_too_noisy"), "too noisy: more data does not help")
      << figure(pct(cert, "share_scattered"), "scattered specks (not tracked)");
  if (truth.is_object() && truth.contains("coverage_scannable"))
    out << figure(pct(truth, "coverage_scannable"), "of the scannable surface covered (truth)");
  else if (truth.is_object() && truth.contains("coverage"))
    out << figure(pct(truth, "coverage"), "of the true surface covered (truth)");
  if (truth.is_object() && truth.contains("fscore")) out << figure(num(truth, "fscore", 4), "F-score (truth)");
  const double sigma = cert.value("expected_accuracy", 0.0);
  out << figure(sigma > 0 ? fmt::format("{:.3g}", sigma) : "0",
                sigma > 0 ? "expected accuracy: the scanner's depth σ" : "expected accuracy (noise-free scanner)");
  if (session.contains("best_iteration") && session["best_iteration"].is_number_integer())
    out << figure(fmt::format("iteration {}", session["best_iteration"].get<int>()), "the result (model.ply)");
  out << "</div>";
}

// The quality certificate of the last iteration (docs/stop-rule.md): is the scan done, and what is
// missing where, and why.
std::string certificate_section(const json& session, const json& its, const std::string& stop) {
  std::ostringstream out;
  const json& last = its.back();
  const json cert = last.contains("certificate") ? last["certificate"] : json(nullptr);
  if (!cert.is_object()) {
    return "<section class=\"certificate not-done\" id=\"certificate\"><h2>Quality certificate</h2>"
           "<p class=\"why\">No certificate (a session written before it). Stop: " +
           escape_html(stop) + ".</p></section>\n";
  }
  const bool done = cert.value("done", false);
  const double missing = cert.value("share_unreachable", 0.0) + cert.value("share_too_noisy", 0.0);
  const std::string verdict = !done           ? "NOT DONE"
                              : missing > 0.0 ? fmt::format("DONE with {:.2f} % missing", 100.0 * missing)
                                              : "DONE";
  const char* cls = !done ? "not-done" : missing > 0.0 ? "partial" : "done";
  const std::string meaning = stop_meaning(stop == "still running" ? std::string() : stop);
  out << "<section class=\"certificate " << cls << "\" id=\"certificate\"><h2>Quality certificate · iteration "
      << last.value("index", 0) << "</h2><p class=\"verdict\" id=\"verdict\">" << verdict
      << "</p><p class=\"why\">Stop: <b>" << escape_html(stop) << "</b>" << (meaning.empty() ? "" : " — ")
      << escape_html(meaning) << ". " << pct(cert, "share_confident") << " of the surface has confidence &ge; "
      << fmt::format("{:.3f}", cert.value("threshold", 0.0)) << "; views can still improve "
      << pct(cert, "share_improvable") << ", unreachable " << pct(cert, "share_unreachable") << ", too noisy "
      << pct(cert, "share_too_noisy") << ".</p>";
  certificate_figures(session, cert, last.value("truth", json::object()), out);
  certificate_regions(cert, out);
  out << "</section>\n";
  return out.str();
}

// The viewer's controls and legends (filled by report/src/viewer.js).
const char* kViewerControls =
    R"HTML(<div class="controls"><label>iteration <input type="range" id="iteration" min="0" step="1"></label>
<span id="iteration-label"></span></div>
<div class="controls"><label>colour by <select id="color-by"><option value="f">f (confidence)</option>
<option value="f_g">f_g (completeness)</option><option value="f_s">f_s (smoothness)</option>
<option value="color">colour (scanned)</option></select></label>
<label><input type="checkbox" id="show-regions" checked> regions</label>
<label><input type="checkbox" id="show-views" checked> views</label>
<label><input type="checkbox" id="show-mesh" checked> Poisson mesh</label>
<label><input type="checkbox" id="show-cloud"> points</label>
<label>opacity <input type="range" id="mesh-opacity" min="0.1" max="1" step="0.05" value="1"></label></div>
<div id="viewport"></div>
<div class="legend" id="legend"><span><span id="colorbar-name">f</span> 0 <span id="colorbar"><span id="colorbar-threshold"></span></span> 1
<span id="colorbar-note"></span></span></div>
<div class="legend" id="legend-marks"><span><span class="ring" style="border-color:#7c3aed"></span>not scanned</span>
<span><span class="ring" style="border-color:#db2777"></span>improving</span>
<span><span class="ring" style="border-color:#111827"></span>unreachable</span>
<span><span class="ring" style="border-color:#a16207"></span>too noisy</span>
<span><span class="sw" style="background:#1a7f37"></span>next views</span>
<span><span class="sw" style="background:#64748b"></span>scanned views</span>
<span><span class="sw" style="background:#d97706"></span>path</span>
<span><span class="sw" style="background:#d91a1a"></span>new points</span></div>
)HTML";

// The whole page: header, certificate, viewer, slice, history (table, plots), the manifest, the
// buffers, the bundle.
std::string page_html(const json& session, const Page& page, std::string_view bundle) {
  const auto& its = session["iterations"];
  const std::string stop = session.contains("stop_reason") && session["stop_reason"].is_string()
                               ? session["stop_reason"].get<std::string>()
                               : "still running";
  const std::string title = page.manifest["title"].get<std::string>();
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
       << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>autoscan report — "
       << escape_html(title) << "</title><style>" << kStyle << "</style></head><body>\n"
       << "<header><h1>autoscan report — " << escape_html(title) << "</h1><p>" << its.size() << " iterations · planner "
       << escape_html(session.value("planner", std::string("poisson"))) << " · stop: " << escape_html(stop)
       << "</p></header>\n"
       << certificate_section(session, its, stop) << "<main><section>\n"
       << kViewerControls << "</section><aside><h3>Viewing vector field (slice)</h3>"
       << "<img id=\"slice\" alt=\"|g| on a horizontal slice\"><p class=\"caption\" id=\"slice-caption\"></p>\n"
       << "</aside></main>\n<section class=\"history\"><h3>History per iteration</h3><div class=\"scroll\">"
       << summary_table(its) << "</div><div id=\"plots\"></div></section>\n"
       << "<script id=\"autoscan-data\" type=\"application/json\">" << script_safe(page.manifest.dump())
       << "</script>\n";
  for (const auto& [id, b64] : page.bufs.items)
    html << "<script id=\"" << id << "\" type=\"application/octet-stream\">" << b64 << "</script>\n";
  html << "<script>" << script_safe(std::string(bundle)) << "</script>\n</body></html>\n";
  return html.str();
}

}  // namespace

ReportResult write_report(const fs::path& dir, const ReportOptions& opt) {
  const SessionLayout layout(dir);
  const fs::path session_path = layout.session_json();
  auto session_opt = read_json_file(session_path);
  AUTOSCAN_REQUIRE(session_opt.has_value(), "{}: no session.json (is this a session directory?)", dir.string());
  const json& session = *session_opt;
  AUTOSCAN_REQUIRE(session.is_object() && session.contains("iterations") && session["iterations"].is_array(),
                   "{}: missing 'iterations' array", session_path.string());
  const auto bundle = viewer_bundle();
  if (bundle.empty())
    throw RuntimeError("autoscan report: the viewer bundle was not built into this binary (run scripts/setup.sh)");

  Page page = build_page(layout, session, opt);
  AUTOSCAN_REQUIRE(page.result.iterations > 0, "{}: the session has no iterations yet", session_path.string());
  ReportResult result = page.result;
  result.html = layout.report();
  const std::string text = page_html(session, page, bundle);
  write_text_atomic(result.html, text);
  result.bytes = text.size();
  log::info("report: wrote {} ({} iterations, {:.1f} MB)", result.html.string(), result.iterations,
            static_cast<double>(text.size()) / 1e6);
  return result;
}

}  // namespace autoscan::report
