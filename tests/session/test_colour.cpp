// Colour through the session (docs/colour.md): coloured scans keep their colours through insertion,
// the model, consolidation and reopening; the Poisson mesh gets vertex colours weighted by the
// measurement quality, against the plain average as the baseline.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "autoscan/consolidate/consolidate.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "autoscan/session/quality.hpp"
#include "autoscan/session/reconstruct.hpp"
#include "autoscan/session/session.hpp"
#include "session_fixtures.hpp"

using namespace autoscan;
using namespace autoscan::session;
using autoscan::test::fresh_dir;
using autoscan::test::sphere_scan;

namespace {

constexpr Rgb kRed{200, 30, 40};
constexpr Rgb kBlue{30, 60, 190};

Rgb truth_colour(const Vec3& p) { return p.z() > 0 ? kRed : kBlue; }

PointCloud coloured_sphere_scan(const Vec3& from, std::size_t n, std::uint64_t seed) {
  PointCloud c = sphere_scan(from, n, seed);
  c.colors.reserve(c.size());
  for (const auto& p : c.positions) c.colors.push_back(truth_colour(p));
  return c;
}

double rgb_distance(const Rgb& a, const Rgb& b) {
  return Vec3(double(a[0]) - b[0], double(a[1]) - b[1], double(a[2]) - b[2]).norm();
}

}  // namespace

TEST(Colour, VertexColoursAreTheWeightedMeanOfTheNearestPoints) {
  PointCloud pts;
  pts.positions = {Vec3(0, 0, 0), Vec3(0.01, 0, 0), Vec3(1, 0, 0), Vec3(1.01, 0, 0)};
  pts.colors = {Rgb{0, 0, 0}, Rgb{200, 100, 40}, Rgb{10, 10, 10}, Rgb{30, 30, 30}};
  const std::vector<Vec3> verts = {Vec3(0.005, 0, 0), Vec3(1.005, 0, 0)};
  const std::vector<double> w = {1.0, 3.0, 0.0, 0.0};
  // Quality: 1/4 · black + 3/4 · (200, 100, 40) = (150, 75, 30); both weights 0: the plain mean.
  const auto q = color_vertices(verts, pts, w, 2);
  ASSERT_EQ(q.size(), 2u);
  EXPECT_EQ(q[0], (Rgb{150, 75, 30}));
  EXPECT_EQ(q[1], (Rgb{20, 20, 20}));
  // Average: equal weights.
  const auto a = color_vertices(verts, pts, {}, 2);
  EXPECT_EQ(a[0], (Rgb{100, 50, 20}));
  EXPECT_EQ(a[1], (Rgb{20, 20, 20}));
  // No colours: nothing.
  PointCloud bare;
  bare.positions = pts.positions;
  EXPECT_TRUE(color_vertices(verts, bare, {}, 2).empty());
  EXPECT_THROW(color_vertices(verts, pts, std::vector<double>{1.0}, 2), InputError);
}

TEST(Colour, QualityWeightingBeatsTheAverageWhenGrazingViewsSeeWrongColours) {
  // Every surface point of a plane is seen twice: from straight above and near (the true colour)
  // and at a grazing angle from far away (a washed-out colour, as an over-exposed or shaded view).
  ScannerSpec scanner;
  PointCloud pts;
  std::vector<double> w;
  const Vec3 good_sensor(0, 0, 0.8), bad_sensor(3.0, 0, 0.4);
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      const Vec3 p(0.01 * i - 0.2, 0.01 * j - 0.2, 0.0);
      for (const Vec3& s : {good_sensor, bad_sensor}) {
        pts.positions.push_back(p + Vec3(0, 0, s == good_sensor ? 0.0 : 1e-4));
        pts.colors.push_back(s == good_sensor ? kRed : Rgb{250, 240, 240});
        const Vec3 ray = s - p;
        const double sigma = scanner.relative_depth_sigma(ray.norm(), ray.normalized().z());
        w.push_back(1.0 / (sigma * sigma));
      }
    }
  std::vector<Vec3> verts;
  for (int i = 5; i < 35; ++i) verts.emplace_back(0.01 * i - 0.2 + 0.003, 0.0, 0.0);
  const auto q = color_vertices(verts, pts, w, 8);
  const auto a = color_vertices(verts, pts, {}, 8);
  double eq = 0, ea = 0;
  for (std::size_t v = 0; v < verts.size(); ++v) {
    eq += rgb_distance(q[v], kRed);
    ea += rgb_distance(a[v], kRed);
  }
  eq /= verts.size();
  ea /= verts.size();
  EXPECT_LT(eq, 15.0);
  EXPECT_GT(ea, 100.0);
}

TEST(Colour, ConsolidationCarriesColours) {
  PointCloud raw;
  const Vec3 from[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int i = 0; i < 6; ++i) raw.append(coloured_sphere_scan(from[i], 3000, 10 + i));
  consolidate::ConsolidateOptions o;
  o.thinning.max_points = 6000;
  const auto r = consolidate::consolidate(raw, o);
  ASSERT_EQ(r.cloud.colors.size(), r.cloud.size());
  std::size_t right = 0, counted = 0;
  for (std::size_t i = 0; i < r.cloud.size(); ++i) {
    if (std::abs(r.cloud.positions[i].z()) < 0.01) continue;
    ++counted;
    right += r.cloud.colors[i] == truth_colour(r.cloud.positions[i]);
  }
  ASSERT_GT(counted, 1000u);
  EXPECT_GT(static_cast<double>(right) / counted, 0.99);
}

TEST(Colour, SessionKeepsColoursAndWritesTheColouredMesh) {
  const auto dir = fresh_dir("colour");
  SessionOptions o = test::test_options();
  o.poisson.depth = 6;
  o.confidence.iso.count = 1500;
  o.confidence.k = 30;
  o.consolidate.thinning.max_points = 8000;
  o.max_iterations = 2;
  {
    Session s = Session::create(dir, ScannerSpec{}, Rig{}, o);
    const Vec3 from[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int i = 0; i < 6; ++i)
      s.add_scan(coloured_sphere_scan(from[i], 2500, 50 + i), Pose::look_at(1.0 * from[i], Vec3::Zero()));
    const PointCloud& model = s.model_points();
    ASSERT_EQ(model.colors.size(), model.size());
    ASSERT_TRUE(model.scalars.has(kColorWeightColumn));
    for (std::size_t i = 0; i < model.size(); ++i) ASSERT_EQ(model.colors[i], truth_colour(model.positions[i]));
    const auto w = model.scalars.get(kColorWeightColumn);
    for (double x : w) ASSERT_GT(x, 0.0);

    const auto nv = s.next_views();
    const auto mesh_path = nv.directory / "mesh_color.ply";
    ASSERT_TRUE(std::filesystem::exists(mesh_path));
    const TriangleMesh mesh = io::read_mesh(mesh_path);
    ASSERT_EQ(mesh.vertex_colors.size(), mesh.vertices.size());
    std::size_t right = 0, counted = 0;
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      if (std::abs(mesh.vertices[v].z()) < 0.03) continue;  // the colour border
      ++counted;
      right += rgb_distance(mesh.vertex_colors[v], truth_colour(mesh.vertices[v])) < 1.0;
    }
    ASSERT_GT(counted, 500u);
    EXPECT_GT(static_cast<double>(right) / counted, 0.98);
    // The confidence mesh is still written as before.
    EXPECT_TRUE(std::filesystem::exists(nv.directory / "mesh.ply"));
    const auto consolidated = io::read_point_cloud(nv.directory / "consolidated.ply");
    EXPECT_EQ(consolidated.colors.size(), consolidated.size());
  }
  // Reopened: the model is rebuilt from the scan files with the same colours and weights.
  Session back = Session::open(dir);
  const PointCloud& model = back.model_points();
  ASSERT_EQ(model.colors.size(), model.size());
  for (std::size_t i = 0; i < model.size(); ++i) ASSERT_EQ(model.colors[i], truth_colour(model.positions[i]));
  std::filesystem::remove_all(dir);
}

TEST(Colour, WeightingIsAnOption) {
  SessionOptions o;
  EXPECT_EQ(o.color_weighting, ColorWeighting::quality);
  const auto j = to_json(o);
  EXPECT_EQ(j["color_weighting"], "quality");
  nlohmann::json bad = j;
  bad["color_weighting"] = "median";
  EXPECT_THROW(session_options_from_json(bad), InputError);
  bad = j;
  bad["color_neighbours"] = 0;
  EXPECT_THROW(session_options_from_json(bad), InputError);
}
