#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/io/image.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/report/report.hpp"
#include "support/temp_dir.hpp"

using namespace autoscan;
namespace fs = std::filesystem;

namespace {

TriangleMesh uv_sphere(double r, int nu, int nv) {
  TriangleMesh m;
  m.vertices.emplace_back(0, 0, r);
  for (int i = 1; i < nv; ++i) {
    const double th = std::numbers::pi * i / nv;
    for (int j = 0; j < nu; ++j) {
      const double ph = 2 * std::numbers::pi * j / nu;
      m.vertices.emplace_back(r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph), r * std::cos(th));
    }
  }
  m.vertices.emplace_back(0, 0, -r);
  const int south = static_cast<int>(m.vertices.size()) - 1;
  auto ring = [&](int i, int j) { return 1 + (i - 1) * nu + (j % nu); };
  for (int j = 0; j < nu; ++j) m.faces.push_back({0, ring(1, j), ring(1, j + 1)});
  for (int i = 1; i < nv - 1; ++i)
    for (int j = 0; j < nu; ++j) {
      m.faces.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
      m.faces.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
  for (int j = 0; j < nu; ++j) m.faces.push_back({south, ring(nv - 1, j + 1), ring(nv - 1, j)});
  return m;
}

// A region of the certificate (docs/stop-rule.md) at `centroid` with `reason`.
nlohmann::json region(int id, const Vec3& centroid, double radius, double share, const char* reason) {
  const std::string r = reason;
  return {{"id", id},
          {"area", share},
          {"share", share},
          {"centroid", {centroid.x(), centroid.y(), centroid.z()}},
          {"radius", radius},
          {"mean_f", 0.1 + 0.05 * id},
          {"has_data", r == "improving" || r == "too_noisy"},
          {"reason", reason},
          {"views_aimed", r == "not_scanned" ? 2 : 0},
          {"stalls", r == "unreachable" || r == "too_noisy" ? 2 : 0},
          {"ignored", 0},
          {"previous", -1},
          {"expected_accuracy", 0.00225}};
}

// The certificate of the synthetic session's last iteration: one region of each reason, on the
// sphere's side that the report's camera looks at (towards (1.1, -1.4, 0.9)), apart from each other.
nlohmann::json synthetic_certificate() {
  auto on_sphere = [](double x, double y, double z) -> Vec3 { return Vec3(x, y, z).normalized() * 0.48; };
  nlohmann::json regions = nlohmann::json::array();
  regions.push_back(region(0, on_sphere(1.0, -0.3, 0.5), 0.07, 0.03, "not_scanned"));
  regions.push_back(region(1, on_sphere(0.3, -1.0, 0.5), 0.07, 0.02, "improving"));
  regions.push_back(region(2, on_sphere(0.9, -0.6, -0.25), 0.07, 0.02, "unreachable"));
  regions.push_back(region(3, on_sphere(0.2, -1.0, -0.3), 0.07, 0.01, "too_noisy"));
  return {{"iteration", 1},
          {"threshold", 0.45},
          {"surface_area", 1.0},
          {"share_confident", 0.91},
          {"share_scattered", 0.01},
          {"share_improvable", 0.05},
          {"share_unreachable", 0.02},
          {"share_too_noisy", 0.01},
          {"regions_improved", 0},
          {"regions_aimed_before", 1},
          {"stalled_rounds", 1},
          {"views_planned", 2},
          {"done", false},
          {"expected_accuracy", 0.00225},
          {"regions", regions}};
}

// The truth's figures of iteration k, with the error histograms of seeded log-uniform distances
// (1e-6 to 1e-1 of the diagonal 1) as eval::evaluate_mesh writes them.
nlohmann::json synthetic_truth(int k) {
  Rng rng(7 + k);
  std::vector<double> d(5000);
  for (auto& x : d) x = std::pow(10.0, rng.uniform(-6.0, -1.0));
  return {{"accuracy_mean", 0.004 - 0.001 * k},
          {"completeness_mean", 0.005 - 0.001 * k},
          {"coverage", 0.8 + 0.1 * k},
          {"coverage_scannable", 0.85 + 0.1 * k},
          {"fscore", 0.9 + 0.05 * k},
          {"histogram", eval::make_histogram(d, 20, 0.02, 1.0).to_json()},
          {"log_histogram", eval::make_log_histogram(d, 20, 0.02, 1.0).to_json()}};
}

// The poses of the synthetic session's scans: four around the sphere, two per iteration.
nlohmann::json synthetic_scans() {
  nlohmann::json scans = nlohmann::json::array();
  for (int id = 0; id < 4; ++id) {
    const double a = 2.0 * std::numbers::pi * id / 4.0;
    const Vec3 p(1.3 * std::cos(a), 1.3 * std::sin(a), 0.2);
    const Vec3 d = (-p).normalized();
    scans.push_back(
        {{"id", id},
         {"file", fmt::format("scans/scan_{:04d}.ply", id)},
         {"pose", {{"position", {p.x(), p.y(), p.z()}}, {"direction", {d.x(), d.y(), d.z()}}, {"up", {0, 0, 1}}}}});
  }
  return scans;
}

// A synthetic two-iteration session in the layout of docs/session-format.md; with
// `with_certificate`, the last iteration has a certificate with one region of each reason.
void write_synthetic_session(const fs::path& dir, bool with_certificate = false) {
  fs::create_directories(dir);
  nlohmann::json iters = nlohmann::json::array();
  for (int k = 0; k < 2; ++k) {
    const fs::path idir = dir / "iterations" / fmt::format("iter_{:03d}", k);
    fs::create_directories(idir);
    PointCloud cloud;
    const int n = 1500 * (k + 1);
    std::vector<double> is_new;
    for (int i = 0; i < n; ++i) {
      const double z = -1 + 2.0 * (i + 0.5) / n, a = i * 2.399963;
      const double s = std::sqrt(1 - z * z) * 0.5;
      cloud.positions.emplace_back(s * std::cos(a), s * std::sin(a), 0.5 * z);
      is_new.push_back(i >= 1500 * k ? 1.0 : 0.0);
    }
    cloud.scalars.set("new", is_new);
    io::write_point_cloud(idir / "cloud.ply", cloud);
    TriangleMesh mesh = uv_sphere(0.48, 48, 24);
    std::vector<double> f, fg, fs;
    for (const auto& v : mesh.vertices) {
      f.push_back(0.5 + v.z());
      fg.push_back(0.5 + v.x());
      fs.push_back(0.5 + v.y());
    }
    mesh.vertex_scalars.set("f", f);
    mesh.vertex_scalars.set("f_g", fg);
    mesh.vertex_scalars.set("f_s", fs);
    io::write_mesh(idir / "mesh.ply", mesh);
    if (k == 1) {
      // The last iteration has a coloured model (docs/colour.md): red above z = 0, blue below.
      TriangleMesh colored = mesh;
      colored.vertex_scalars = {};
      for (const auto& v : mesh.vertices)
        colored.vertex_colors.push_back(v.z() > 0 ? Rgb{210, 20, 20} : Rgb{20, 40, 210});
      io::write_mesh(idir / "mesh_color.ply", colored);
    }
    nlohmann::json views = {{"views",
                             {{{"position", {1.2, 0, 0.3}},
                               {"direction", {-1, 0, -0.25}},
                               {"up", {0, 0, 1}},
                               {"score", 0.8},
                               {"target", {0.5, 0, 0.1}}},
                              {{"position", {0, 1.2, 0.6}},
                               {"direction", {0, -1, -0.5}},
                               {"up", {0, 0, 1}},
                               {"score", 0.6},
                               {"target", {0, 0.5, 0.2}}}}},
                            {"path_length", 1.8}};
    write_text_atomic(idir / "views.json", views.dump(2));
    if (k == 0) {  // the last iteration has no field slice (as a session that stopped without planning)
      io::Image img;
      img.width = 32;
      img.height = 24;
      for (int i = 0; i < img.width * img.height; ++i)
        img.pixels.push_back({static_cast<std::uint8_t>(i % 256), 64, static_cast<std::uint8_t>(255 - i % 256)});
      io::write_png(idir / "field_slice.png", img);
    }
    iters.push_back({{"index", k},
                     {"points", n},
                     {"views", 2},
                     {"mean_f", 0.3 + 0.3 * k},
                     {"mean_f_g", 0.5 + 0.2 * k},
                     {"mean_f_s", 0.6 + 0.1 * k},
                     {"scans", {2 * k, 2 * k + 1}},
                     {"seconds", {{"poisson", 1.0 + k}, {"nbv", 0.5}}},
                     {"truth", synthetic_truth(k)}});
  }
  if (with_certificate) iters[1]["certificate"] = synthetic_certificate();
  nlohmann::json session = {{"format", "autoscan-session"}, {"version", 1},
                            {"planner", "poisson"},         {"iterations", iters},
                            {"scans", synthetic_scans()},   {"stop_reason", "confidence converged"}};
  write_text_atomic(dir / "session.json", session.dump(2));
}

}  // namespace

TEST(Report, Base64MatchesRfc4648) {
  EXPECT_EQ(report::base64("", 0), "");
  EXPECT_EQ(report::base64("f", 1), "Zg==");
  EXPECT_EQ(report::base64("fo", 2), "Zm8=");
  EXPECT_EQ(report::base64("foo", 3), "Zm9v");
  EXPECT_EQ(report::base64("foobar", 6), "Zm9vYmFy");
}

TEST(Report, WritesSelfContainedPage) {
  const autoscan::testing::TempDir tmp("report");
  const fs::path& dir = tmp.path();
  fs::remove_all(dir);
  write_synthetic_session(dir);
  const auto r = report::write_report(dir);
  EXPECT_EQ(r.iterations, 2);
  EXPECT_EQ(r.points_shown, 1500u + 3000u);
  const std::string html = read_text_file(r.html);
  EXPECT_NE(html.find("autoscan-data"), std::string::npos);
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
  // Offline: the only URLs in the page are XML namespace names (w3.org), never resources to load.
  for (const std::string scheme : {"http://", "https://"}) {
    for (auto pos = html.find(scheme); pos != std::string::npos; pos = html.find(scheme, pos + 1))
      EXPECT_EQ(html.compare(pos + scheme.size(), 11, "www.w3.org/"), 0) << html.substr(pos, 60);
  }
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find(" src=\"http"), std::string::npos);
  fs::remove_all(dir);
}

TEST(Report, DecimatesLargeCloudsDeterministically) {
  const autoscan::testing::TempDir tmp("report_dec");
  const fs::path& dir = tmp.path();
  fs::remove_all(dir);
  write_synthetic_session(dir);
  report::ReportOptions o;
  o.max_points = 1000;
  const auto a = report::write_report(dir, o);
  const std::string ha = read_text_file(a.html);
  const auto b = report::write_report(dir, o);
  EXPECT_EQ(ha, read_text_file(b.html));
  EXPECT_LT(a.points_shown, 2u * 1000u * 13 / 10);
  EXPECT_GT(a.points_shown, 2u * 1000u * 7 / 10);
  fs::remove_all(dir);
}

TEST(Report, MissingSessionIsInputError) {
  const autoscan::testing::TempDir tmp("report_empty");
  const fs::path& dir = tmp.path();
  fs::remove_all(dir);
  fs::create_directories(dir);
  EXPECT_THROW(report::write_report(dir), InputError);
  write_text_atomic(dir / "session.json", "{not json");
  EXPECT_THROW(report::write_report(dir), InputError);
  EXPECT_FALSE(fs::exists(dir / "report.html"));
  fs::remove_all(dir);
}

// The quality certificate (docs/stop-rule.md) heads the page: the verdict, the stop and what it means,
// the figures, each region with its reason; a session without one says so.
TEST(Report, ShowsTheQualityCertificate) {
  const autoscan::testing::TempDir tmp("report_cert");
  const fs::path& dir = tmp.path();
  fs::remove_all(dir);
  write_synthetic_session(dir);
  {
    const std::string html = read_text_file(report::write_report(dir).html);
    EXPECT_NE(html.find("No certificate (a session written before it). Stop: confidence converged."),
              std::string::npos);
  }
  write_synthetic_session(dir, true);
  auto session = nlohmann::json::parse(read_text_file(dir / "session.json"));
  session["best_iteration"] = 1;
  session["stop_reason"] = "max_views";
  write_text_atomic(dir / "session.json", session.dump(2));
  const std::string html = read_text_file(report::write_report(dir).html);
  // The certificate comes before the viewer.
  EXPECT_LT(html.find("id=\"certificate\""), html.find("id=\"viewport\""));
  EXPECT_NE(html.find("<p class=\"verdict\" id=\"verdict\">NOT DONE</p>"), std::string::npos);
  EXPECT_NE(html.find("Stop: <b>max_views</b> — the view budget ran out. 91.00 % of the surface has confidence "
                      "&ge; 0.450; views can still improve 5.00 %, unreachable 2.00 %, too noisy 1.00 %."),
            std::string::npos);
  EXPECT_NE(html.find("<b>95.00 %</b><span>of the scannable surface covered (truth)</span>"), std::string::npos);
  EXPECT_NE(html.find("<b>iteration 1</b><span>the result (model.ply)</span>"), std::string::npos);
  EXPECT_NE(html.find("<h3>4 regions of low confidence left (ringed in the 3D view)</h3>"), std::string::npos);
  for (const char* reason : {"not_scanned", "improving", "unreachable", "too_noisy"})
    EXPECT_NE(html.find(std::string("</span>") + reason + "</td>"), std::string::npos) << reason;
  EXPECT_NE(html.find("border-color:#111827\"></span>unreachable</td><td>2.00 %</td><td>0.200</td><td>no</td>"),
            std::string::npos);
  // The iterations table: the certificate's shares and the truth's figures.
  EXPECT_NE(html.find("<td>91.00 %</td><td>5.00 %</td><td>2.00 %</td><td>1.00 %</td><td>4</td><td>95.00 %</td>"
                      "<td>0.9500</td>"),
            std::string::npos);
  // A finished certificate with something missing.
  session["iterations"][1]["certificate"]["done"] = true;
  write_text_atomic(dir / "session.json", session.dump(2));
  EXPECT_NE(read_text_file(report::write_report(dir).html).find("id=\"verdict\">DONE with 3.00 % missing</p>"),
            std::string::npos);
  fs::remove_all(dir);
}

// The report's manifest carries what the viewer draws: the scanned views' poses, the certificate, the
// logarithmic error histogram.
TEST(Report, ManifestHasScansCertificateAndLogHistogram) {
  const autoscan::testing::TempDir tmp("report_manifest");
  const fs::path& dir = tmp.path();
  fs::remove_all(dir);
  write_synthetic_session(dir, true);
  const std::string html = read_text_file(report::write_report(dir).html);
  const std::string open = "<script id=\"autoscan-data\" type=\"application/json\">";
  const auto a = html.find(open) + open.size();
  const auto m = nlohmann::json::parse(html.substr(a, html.find("</script>", a) - a));
  ASSERT_EQ(m["iterations"].size(), 2u);
  EXPECT_EQ(m["iterations"][1]["scans"].size(), 2u);
  EXPECT_EQ(m["iterations"][1]["scans"][0]["position"][0].get<double>(), -1.3);  // scan 2, at angle π
  EXPECT_EQ(m["iterations"][1]["certificate"]["regions"].size(), 4u);
  EXPECT_TRUE(m["histogram"].value("log", false));
  EXPECT_EQ(m["histogram"]["values"].size(), 20u);
  EXPECT_EQ(m["plots"]["share_confident"][1].get<double>(), 0.91);
  EXPECT_TRUE(m["plots"]["share_confident"][0].is_null());
  fs::remove_all(dir);
}

// Writes the fixture used by the browser tests (report/tests, CTest: report_browser).
TEST(ReportFixture, WritesSyntheticSession) {
  const char* env = std::getenv("AUTOSCAN_REPORT_FIXTURE_DIR");
  const fs::path dir = env ? fs::path(env) : fs::temp_directory_path() / "autoscan_report_fixture";
  fs::remove_all(dir);
  write_synthetic_session(dir, true);
  const auto r = report::write_report(dir);
  EXPECT_TRUE(fs::exists(r.html));
}
