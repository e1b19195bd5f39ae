#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
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

// A synthetic two-iteration session in the layout of docs/session-format.md.
void write_synthetic_session(const fs::path& dir) {
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
    io::Image img;
    img.width = 32;
    img.height = 24;
    for (int i = 0; i < img.width * img.height; ++i)
      img.pixels.push_back({static_cast<std::uint8_t>(i % 256), 64, static_cast<std::uint8_t>(255 - i % 256)});
    io::write_png(idir / "field_slice.png", img);
    iters.push_back({{"index", k},
                     {"points", n},
                     {"views", 2},
                     {"mean_f", 0.3 + 0.3 * k},
                     {"mean_f_g", 0.5 + 0.2 * k},
                     {"mean_f_s", 0.6 + 0.1 * k},
                     {"seconds", {{"poisson", 1.0 + k}, {"nbv", 0.5}}},
                     {"truth", {{"accuracy_mean", 0.004 - 0.001 * k}, {"coverage", 0.8 + 0.1 * k}}}});
  }
  nlohmann::json session = {{"format", "autoscan-session"},
                            {"version", 1},
                            {"planner", "poisson"},
                            {"iterations", iters},
                            {"stop_reason", "confidence converged"}};
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

// The quality certificate (docs/stop-rule.md) heads the page: the verdict, each region and its reason,
// the result iteration; a session without one says so.
TEST(Report, ShowsTheQualityCertificate) {
  const autoscan::testing::TempDir tmp("report_cert");
  const fs::path& dir = tmp.path();
  fs::remove_all(dir);
  write_synthetic_session(dir);
  {
    const std::string html = read_text_file(report::write_report(dir).html);
    EXPECT_NE(html.find("Quality certificate"), std::string::npos);
    EXPECT_NE(html.find("No certificate"), std::string::npos);
  }
  auto session = nlohmann::json::parse(read_text_file(dir / "session.json"));
  session["best_iteration"] = 1;
  session["iterations"][1]["certificate"] = {{"iteration", 1},
                                             {"threshold", 0.45},
                                             {"surface_area", 1.0},
                                             {"share_confident", 0.95},
                                             {"share_scattered", 0.0},
                                             {"share_improvable", 0.03},
                                             {"share_unreachable", 0.02},
                                             {"share_too_noisy", 0.0},
                                             {"regions_improved", 0},
                                             {"regions_aimed_before", 1},
                                             {"stalled_rounds", 1},
                                             {"views_planned", 3},
                                             {"done", false},
                                             {"expected_accuracy", 0.00225},
                                             {"regions",
                                              {{{"id", 0},
                                                {"area", 0.03},
                                                {"share", 0.03},
                                                {"centroid", {0.1, 0.2, 0.3}},
                                                {"radius", 0.1},
                                                {"mean_f", 0.1},
                                                {"has_data", false},
                                                {"reason", "not_scanned"},
                                                {"views_aimed", 2},
                                                {"stalls", 0},
                                                {"ignored", 0},
                                                {"previous", -1},
                                                {"expected_accuracy", 0.00225}},
                                               {{"id", 1},
                                                {"area", 0.02},
                                                {"share", 0.02},
                                                {"centroid", {-0.1, 0.0, 0.3}},
                                                {"radius", 0.05},
                                                {"mean_f", 0.2},
                                                {"has_data", false},
                                                {"reason", "unreachable"},
                                                {"views_aimed", 0},
                                                {"stalls", 1},
                                                {"ignored", 0},
                                                {"previous", 0},
                                                {"expected_accuracy", 0.00225}}}}};
  write_text_atomic(dir / "session.json", session.dump(2));
  const std::string html = read_text_file(report::write_report(dir).html);
  EXPECT_NE(html.find("NOT DONE: 95.00 %"), std::string::npos);
  EXPECT_NE(html.find("views can still improve 3.00 %, unreachable 2.00 %"), std::string::npos);
  EXPECT_NE(html.find("<td>not_scanned</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>unreachable</td>"), std::string::npos);
  EXPECT_NE(html.find("0.100, 0.200, 0.300"), std::string::npos);
  EXPECT_NE(html.find("Result: iteration 1"), std::string::npos);
  fs::remove_all(dir);
}

// Writes the fixture used by the browser tests (report/tests, CTest: report_browser).
TEST(ReportFixture, WritesSyntheticSession) {
  const char* env = std::getenv("AUTOSCAN_REPORT_FIXTURE_DIR");
  const fs::path dir = env ? fs::path(env) : fs::temp_directory_path() / "autoscan_report_fixture";
  fs::remove_all(dir);
  write_synthetic_session(dir);
  const auto r = report::write_report(dir);
  EXPECT_TRUE(fs::exists(r.html));
}
