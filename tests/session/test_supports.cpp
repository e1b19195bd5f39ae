// Supports and fixtures in the session (issue 17, session/supports.hpp, docs/supports.md): removal of
// declared fixtures' points and of an undeclared support plane against known clouds, the flagged
// points kept in the scan file and out of the model (also after open()), and the contact region of
// a cube standing on a plane certified unreachable while its other faces are not.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "autoscan/io/mesh_io.hpp"
#include "autoscan/session/certificate.hpp"
#include "autoscan/session/session.hpp"
#include "autoscan/session/supports.hpp"
#include "session_fixtures.hpp"

using namespace autoscan;
using namespace autoscan::session;
using autoscan::test::fresh_dir;
using autoscan::test::scripted_reconstructor;
using autoscan::test::test_options;
namespace fs = std::filesystem;

namespace {

constexpr double kTable = -0.25;  // the table top; the sphere (radius 0.25, centred at 0) touches it

// A scan of the table seen from `from` (a grid of `n`² points on |x|, |y| <= 0.6, outside the
// sphere's footprint, jittered by `noise`) followed by the sphere's points facing `from`.
PointCloud table_and_sphere(const Vec3& from, int n, double noise, std::size_t* table_points) {
  Rng rng(3);
  PointCloud c;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec3 p(-0.6 + 1.2 * i / (n - 1), -0.6 + 1.2 * j / (n - 1), kTable + noise * rng.normal());
      if (p.head<2>().norm() < 0.05) continue;  // under the sphere's bottom
      c.positions.push_back(p);
      c.normals.emplace_back(0, 0, 1);
    }
  *table_points = c.size();
  c.append(test::sphere_scan(from, 3000, 5));
  return c;
}

Rig table_rig(double tolerance = 0.004) {
  Rig r;
  Fixture t;
  t.kind = Fixture::Kind::plane;
  t.height = kTable;
  t.half_extent = 1.0;
  t.tolerance = tolerance;
  r.fixtures.push_back(t);
  return r;
}

}  // namespace

TEST(Supports, DeclaredFixturePointsAreRemovedAndNothingElse) {
  std::size_t table = 0;
  const PointCloud scan = table_and_sphere(Vec3(1, 0, 1), 60, 0.0005, &table);
  const FixtureGeometry g(table_rig());
  SupportOptions o;
  Rng rng(1);
  RemovalReport rep;
  const auto codes = classify_scan(scan, g, o, std::nullopt, rng, rep);
  // Oracle: the table points (|z − kTable| <= 4 σ < tolerance) and the sphere's points within the
  // tolerance of the table (its bottom cap: z < kTable + 0.004).
  std::size_t expected = table;
  for (std::size_t i = table; i < scan.size(); ++i) expected += scan.positions[i].z() <= kTable + 0.004;
  EXPECT_EQ(rep.fixture, expected);
  EXPECT_EQ(rep.support_plane, 0u);
  for (std::size_t i = 0; i < table; ++i) EXPECT_EQ(codes[i], 1) << i;
  const PointCloud kept = kept_points(scan, codes);
  EXPECT_EQ(kept.size(), scan.size() - expected);
  for (const auto& p : kept.positions) EXPECT_GT(p.z(), kTable + 0.004);
}

TEST(Supports, UndeclaredTablePlaneIsDetectedAndRemoved) {
  std::size_t table = 0;
  const PointCloud scan = table_and_sphere(Vec3(1, 0.3, 1), 60, 0.0005, &table);
  SupportOptions o;
  o.detect_plane = true;
  Rng rng(11);
  const auto plane = detect_support_plane(scan, o, rng);
  ASSERT_TRUE(plane.has_value());
  EXPECT_GT(plane->normal.z(), std::cos(0.5 * M_PI / 180));  // within half a degree of +Z
  EXPECT_NEAR(plane->offset / plane->normal.z(), kTable, 2e-4);
  const FixtureGeometry none(Rig{});
  Rng rng2(11);
  RemovalReport rep;
  const auto codes = classify_scan(scan, none, o, std::nullopt, rng2, rep);
  EXPECT_TRUE(rep.plane_detected);
  EXPECT_EQ(rep.fixture, 0u);
  std::size_t table_removed = 0, sphere_removed = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (codes[i] == 0) continue;
    EXPECT_EQ(codes[i], 2);
    (i < table ? table_removed : sphere_removed) += 1;
  }
  EXPECT_EQ(table_removed, table);                   // every table point
  for (std::size_t i = table; i < scan.size(); ++i)  // and only the sphere's bottom cap
    if (codes[i]) {
      EXPECT_LT(scan.positions[i].z(), kTable + 0.005);
    }
  EXPECT_LT(sphere_removed, 20u);
}

TEST(Supports, NoPlaneIsFoundInAnObjectAloneOrUnderATopFace) {
  SupportOptions o;
  o.detect_plane = true;
  Rng rng(2);
  // A sphere seen from above: its lowest visible rim is a horizontal band with nothing below it,
  // but its normals are not the plane's.
  EXPECT_FALSE(detect_support_plane(test::sphere_scan(Vec3(0, 0, 1), 5000, 4), o, rng).has_value());
  // The top face of a box with its sides below: a horizontal plane with most points below it.
  PointCloud box;
  auto add = [&](const Vec3& p, const Vec3& n) {
    box.positions.push_back(p);
    box.normals.push_back(n);
  };
  for (int j = 0; j <= 40; ++j)
    for (int i = 0; i <= 40; ++i) {
      const double u = -0.2 + 0.4 * i / 40, v = -0.2 + 0.4 * j / 40;
      add(Vec3(u, v, 0.2), Vec3::UnitZ());    // top
      add(Vec3(0.2, u, v), Vec3::UnitX());    // side x = 0.2
      add(Vec3(u, -0.2, v), -Vec3::UnitY());  // side y = −0.2
    }
  EXPECT_FALSE(detect_support_plane(box, o, rng).has_value());
}

TEST(Supports, SessionKeepsRemovedPointsInTheFileAndOutOfTheModelAlsoAfterOpen) {
  const auto dir = fresh_dir("supports");
  std::size_t table = 0;
  const PointCloud scan = table_and_sphere(Vec3(1, 0, 1), 40, 0.0, &table);
  std::size_t model = 0, removed = 0;
  {
    auto s = Session::create(dir, ScannerSpec{}, table_rig(), test_options());
    s.set_reconstructor(scripted_reconstructor({0.3}));
    const auto rec = s.add_scan(scan, Pose::look_at(Vec3(1, 0, 1), Vec3::Zero()));
    removed = rec.removed_fixture;
    EXPECT_GE(removed, table);
    EXPECT_EQ(rec.removed_support_plane, 0u);
    EXPECT_EQ(rec.points, scan.size());
    EXPECT_EQ(rec.inserted, scan.size() - removed);
    model = s.model_points().size();
    EXPECT_EQ(model, scan.size() - removed);
    for (const auto& p : s.model_points().positions) EXPECT_GT(p.z(), kTable + 0.004);
    // The scan file holds every point received, each removed one flagged with its reason.
    const PointCloud stored = io::read_point_cloud(dir / "scans" / "scan_0000.ply");
    ASSERT_EQ(stored.size(), scan.size());
    const auto& why = stored.scalars.get(kRemovedColumn);
    const auto& ins = stored.scalars.get("inserted");
    std::size_t flagged = 0;
    for (std::size_t i = 0; i < stored.size(); ++i) {
      flagged += why[i] == 1.0;
      if (why[i] != 0.0) {
        EXPECT_EQ(ins[i], 0.0);
      }
    }
    EXPECT_EQ(flagged, removed);
    const auto j = nlohmann::json::parse(std::ifstream(dir / "session.json"));
    EXPECT_EQ(j["scans"][0]["removed"]["fixture"].get<std::size_t>(), removed);
  }
  auto s = Session::open(dir);
  EXPECT_EQ(s.model_points().size(), model);
  EXPECT_EQ(s.scans()[0].removed_fixture, removed);
  fs::remove_all(dir);
}

TEST(Supports, SessionDetectsTheUndeclaredPlaneOnceAndAppliesItLater) {
  const auto dir = fresh_dir("supports_detect");
  auto o = test_options();
  o.supports.detect_plane = true;
  auto s = Session::create(dir, ScannerSpec{}, Rig{}, o);
  s.set_reconstructor(scripted_reconstructor({0.3}));
  std::size_t table = 0;
  const auto a =
      s.add_scan(table_and_sphere(Vec3(1, 0, 1), 40, 0.0, &table), Pose::look_at(Vec3(1, 0, 1), Vec3::Zero()));
  ASSERT_TRUE(a.support_plane.has_value());
  EXPECT_TRUE(a.support_plane_detected);
  EXPECT_GE(a.removed_support_plane, table);
  // A later scan with only a sliver of table (too few points to detect a plane on its own).
  PointCloud sliver = test::sphere_scan(Vec3(-1, 0, 1), 3000, 8);
  for (int i = 0; i < 30; ++i) sliver.positions.emplace_back(-0.5 + 0.01 * i, 0.4, kTable);
  sliver.normals.resize(sliver.size(), Vec3::UnitZ());
  const auto b = s.add_scan(sliver, Pose::look_at(Vec3(-1, 0, 1), Vec3::Zero()));
  ASSERT_TRUE(b.support_plane.has_value());
  EXPECT_FALSE(b.support_plane_detected);  // the first scan's plane
  EXPECT_GE(b.removed_support_plane, 30u);
  for (const auto& p : s.model_points().positions) EXPECT_GT(p.z(), kTable + 0.003);
  fs::remove_all(dir);
}

namespace {

// The unit cube [0, 1]³, each face its own grid of 9 × 9 vertices (faces share no vertex), vertex f
// 0.1 on the top and bottom faces, 0.9 on the sides.
TriangleMesh cube_mesh() {
  TriangleMesh m;
  std::vector<double> f;
  constexpr int n = 9;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int base = static_cast<int>(m.vertices.size());
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          Vec3 p;
          p[axis] = side;
          p[(axis + 1) % 3] = i / double(n - 1);
          p[(axis + 2) % 3] = j / double(n - 1);
          m.vertices.push_back(p);
          f.push_back(axis == 2 ? 0.1 : 0.9);
        }
      for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
          const int a = base + j * n + i, b = a + 1, c = a + n, d = c + 1;
          if (side == 1) {
            m.faces.push_back({a, b, d});
            m.faces.push_back({a, d, c});
          } else {
            m.faces.push_back({a, d, b});
            m.faces.push_back({a, c, d});
          }
        }
    }
  m.vertex_scalars.set("f", f);
  return m;
}

}  // namespace

TEST(Supports, CubeOnAPlaneHasAnUnreachableBottomAndReachableOtherFaces) {
  const TriangleMesh cube = cube_mesh();
  PointCloud iso;
  iso.positions = cube.vertices;
  iso.scalars.set("f", cube.vertex_scalars.get("f"));
  const SupportContact contact{SupportPlane{Vec3::UnitZ(), 0.0}, 0.01};
  const auto c = compute_certificate(0, cube, iso, PointCloud{}, ScannerSpec{}, StopOptions{}, nullptr, &contact);
  ASSERT_EQ(c.regions.size(), 2u);  // the top and the bottom face (the sides are confident)
  int bottom = 0, top = 0;
  for (const auto& r : c.regions) {
    EXPECT_NEAR(r.share, 1.0 / 6.0, 1e-9);
    if (r.centroid.z() < 0.5) {
      ++bottom;
      EXPECT_EQ(r.reason, "unreachable");
      EXPECT_EQ(r.detail, "on the support");
    } else {
      ++top;
      EXPECT_EQ(r.reason, "not_scanned");  // no data yet: views can still improve it
      EXPECT_EQ(r.detail, "");
    }
  }
  EXPECT_EQ(bottom, 1);
  EXPECT_EQ(top, 1);
  EXPECT_NEAR(c.share_unreachable, 1.0 / 6.0, 1e-9);
  EXPECT_NEAR(c.share_improvable, 1.0 / 6.0, 1e-9);
  // The planner does not chase it: its iso-points get f = 1 in the copy the planner sees.
  PointCloud planner_iso = iso;
  EXPECT_GE(mask_settled_regions(c, planner_iso), 81u);
  const auto& masked_f = planner_iso.scalars.get("f");
  std::size_t bottom_masked = 0, top_kept = 0;
  for (std::size_t i = 0; i < iso.size(); ++i) {
    if (iso.positions[i].z() < 1e-9 && masked_f[i] == 1.0) ++bottom_masked;
    if (iso.positions[i].z() > 1 - 1e-9 && masked_f[i] == 0.1) ++top_kept;
  }
  EXPECT_EQ(bottom_masked, 9u * 9u + 4u * 9u);  // the bottom face, and the sides' bottom rows on it
  EXPECT_EQ(top_kept, 9u * 9u);
  // The detail survives session.json.
  const auto back = certificate_from_json(to_json(c), "certificate");
  for (std::size_t i = 0; i < c.regions.size(); ++i) EXPECT_EQ(back.regions[i].detail, c.regions[i].detail);
  // Without the contact, the bottom is just another region views could improve.
  const auto plain = compute_certificate(0, cube, iso, PointCloud{}, ScannerSpec{}, StopOptions{}, nullptr);
  EXPECT_NEAR(plain.share_unreachable, 0.0, 1e-12);
  EXPECT_NEAR(plain.share_improvable, 2.0 / 6.0, 1e-9);
}

TEST(Supports, TheSideJustAboveTheSupportIsNotSwallowedByTheFaceOnIt) {
  // One connected mesh: the bottom face [0, 1]² at z = 0 (on the support, facing it) and a wall at
  // x = 1 rising to z = 0.5 (facing +X), sharing the bottom's edge. Low f on the bottom and on the
  // wall's lower half: one low component by connectivity, of which most vertices lie on the
  // support. The wall's part above the contact is a region of its own that views can still reach.
  TriangleMesh m;
  std::vector<double> f;
  constexpr int n = 11, rows = 6;  // bottom n × n; the wall n columns × rows (row 0 = the shared edge)
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.vertices.emplace_back(i / double(n - 1), j / double(n - 1), 0.0);
      f.push_back(0.1);
    }
  const auto bottom = [&](int i, int j) { return j * n + i; };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {  // normal −Z
      m.faces.push_back({bottom(i, j), bottom(i + 1, j + 1), bottom(i + 1, j)});
      m.faces.push_back({bottom(i, j), bottom(i, j + 1), bottom(i + 1, j + 1)});
    }
  std::vector<int> wall(static_cast<std::size_t>(n * rows));
  for (int r = 0; r < rows; ++r)
    for (int j = 0; j < n; ++j) {
      if (r == 0) {
        wall[static_cast<std::size_t>(r * n + j)] = bottom(n - 1, j);
        continue;
      }
      const double z = 0.5 * r / double(rows - 1);
      wall[static_cast<std::size_t>(r * n + j)] = static_cast<int>(m.vertices.size());
      m.vertices.emplace_back(1.0, j / double(n - 1), z);
      f.push_back(z <= 0.3 ? 0.1 : 0.9);
    }
  const auto w = [&](int r, int j) { return wall[static_cast<std::size_t>(r * n + j)]; };
  for (int r = 0; r + 1 < rows; ++r)
    for (int j = 0; j + 1 < n; ++j) {  // normal +X
      m.faces.push_back({w(r, j), w(r, j + 1), w(r + 1, j + 1)});
      m.faces.push_back({w(r, j), w(r + 1, j + 1), w(r + 1, j)});
    }
  m.vertex_scalars.set("f", f);
  PointCloud iso;
  iso.positions = m.vertices;
  iso.scalars.set("f", f);
  const SupportContact contact{SupportPlane{Vec3::UnitZ(), 0.0}, 0.01};
  StopOptions options;
  options.confidence_ratio = 0.0;  // the threshold 0.5 as such
  const auto c = compute_certificate(0, m, iso, PointCloud{}, ScannerSpec{}, options, nullptr, &contact);
  ASSERT_EQ(c.regions.size(), 2u);
  int on_support = 0, on_wall = 0;
  for (const auto& r : c.regions) {
    if (r.centroid.z() < 0.01) {
      ++on_support;
      EXPECT_EQ(r.reason, "unreachable");
      EXPECT_EQ(r.detail, "on the support");
      EXPECT_NEAR(r.area, 1.05, 1e-9);  // and the wall's lowest triangles with two corners on it
    } else {
      ++on_wall;
      EXPECT_EQ(r.reason, "not_scanned");
      EXPECT_EQ(r.detail, "");
      // From the first triangles with a single corner on the support up to the triangles between
      // z = 0.3 and 0.4 that have two corners at f 0.1 (mean f 0.37): 0.35 of wall less 0.05.
      EXPECT_NEAR(r.area, 0.3, 1e-9);
    }
  }
  EXPECT_EQ(on_support, 1);
  EXPECT_EQ(on_wall, 1);
}

TEST(Supports, MeshSaysWhichPartDataSupports) {
  // Data on every face of the cube but the bottom one (the face on the support).
  const TriangleMesh cube = cube_mesh();
  PointCloud data;
  for (const auto& v : cube.vertices)
    if (v.z() > 1e-9) data.positions.push_back(v);
  const auto supported = vertex_data_support(cube, data);
  ASSERT_EQ(supported.size(), cube.vertices.size());
  std::size_t bottom_supported = 0, others_unsupported = 0;
  for (std::size_t i = 0; i < cube.vertices.size(); ++i) {
    const bool bottom_interior = cube.vertices[i].z() < 1e-9 && cube.vertices[i].x() > 0.3 &&
                                 cube.vertices[i].x() < 0.7 && cube.vertices[i].y() > 0.3 && cube.vertices[i].y() < 0.7;
    if (bottom_interior) bottom_supported += supported[i] != 0.0;
    if (cube.vertices[i].z() > 1e-9) others_unsupported += supported[i] == 0.0;
  }
  EXPECT_EQ(bottom_supported, 0u);  // the middle of the bottom face has no data near it
  EXPECT_EQ(others_unsupported, 0u);
}

TEST(Supports, AFaceTurnedToTheSupportIsUnreachableOnlyWhenNoViewAboveItSeesIt) {
  // The cube floating `lift` above the support: its bottom face faces it. At the incidence limit
  // (75°) and the optimal distance (1.2) the highest view rises −1.2·cos 75° = −0.31 below the face.
  for (const double lift : {0.2, 0.5}) {
    TriangleMesh cube = cube_mesh();
    for (auto& v : cube.vertices) v.z() += lift;
    PointCloud iso;
    iso.positions = cube.vertices;
    iso.scalars.set("f", cube.vertex_scalars.get("f"));
    const SupportContact contact{SupportPlane{Vec3::UnitZ(), 0.0}, 0.01};
    const auto c = compute_certificate(0, cube, iso, PointCloud{}, ScannerSpec{}, StopOptions{}, nullptr, &contact);
    ASSERT_EQ(c.regions.size(), 2u);
    for (const auto& r : c.regions) {
      const bool bottom = r.centroid.z() < lift + 0.5;
      const bool hidden = bottom && lift < 0.31;
      EXPECT_EQ(r.reason, hidden ? "unreachable" : "not_scanned") << "lift " << lift << ", bottom " << bottom;
    }
  }
}
