// Procedural paints (docs/colour.md): the pattern's colours and edges, and painting a mesh.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/paint.hpp"
#include "autoscan/shapes/primitives.hpp"

using namespace autoscan;

TEST(Paint, StripesAndCheckerHaveSharpEdgesAtKnownPlaces) {
  // Cell (0, 0, 0) of the stripes paint is cream/blue (even), its neighbour along x is red.
  EXPECT_EQ(paint_color(Paint::stripes, Vec3(0.1, 0.01, 0.001)), (Rgb{240, 225, 180}));
  EXPECT_EQ(paint_color(Paint::stripes, Vec3(0.1, 0.01, 0.0126)), (Rgb{30, 60, 190}));  // the stripe above
  EXPECT_EQ(paint_color(Paint::stripes, Vec3(0.126, 0.01, 0.001)), (Rgb{200, 30, 40}));
  EXPECT_EQ(paint_color(Paint::stripes, Vec3(-0.001, 0.01, 0.001)), (Rgb{200, 30, 40}));  // cell -1
  EXPECT_EQ(paint_color(Paint::checker, Vec3(0.01, 0.01, 0.01)), (Rgb{245, 200, 40}));
  EXPECT_EQ(paint_color(Paint::checker, Vec3(0.07, 0.01, 0.01)), (Rgb{20, 110, 50}));
  EXPECT_EQ(paint_from_name("checker"), Paint::checker);
  EXPECT_STREQ(paint_name(Paint::stripes), "stripes");
  try {
    paint_from_name("plaid", "--paint");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--paint: unknown paint 'plaid'"), std::string::npos);
  }
}

TEST(Paint, PaintingSplitsTrianglesKeepingTheSurface) {
  TriangleMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0, 0.1, 0.05)};
  m.faces = {{0, 1, 2}};
  const double area = m.area();
  TriangleMesh p = m;
  paint_mesh(p, Paint::stripes, 0.004);
  // Edges 0.1, 0.112 and 0.15 long: a third of the edges follow the longest, so 95 % of them are
  // short enough only after 6 halvings (0.15/64 = 0.0023 ≤ 0.004; 0.15/32 = 0.0047 is not):
  // 4^6 triangles, the same area and plane.
  EXPECT_EQ(p.faces.size(), 4096u);
  EXPECT_NEAR(p.area(), area, 1e-12);
  ASSERT_EQ(p.vertex_colors.size(), p.vertices.size());
  const Vec3 n = (m.vertices[1] - m.vertices[0]).cross(m.vertices[2] - m.vertices[0]).normalized();
  for (std::size_t i = 0; i < p.vertices.size(); ++i) {
    EXPECT_NEAR(n.dot(p.vertices[i]), 0.0, 1e-15);
    EXPECT_EQ(p.vertex_colors[i], paint_color(Paint::stripes, p.vertices[i]));
  }
  // The face budget stops the splitting; none leaves the mesh alone.
  TriangleMesh capped = m;
  paint_mesh(capped, Paint::checker, 0.004, 100);
  EXPECT_EQ(capped.faces.size(), 64u);
  TriangleMesh none = m;
  paint_mesh(none, Paint::none);
  EXPECT_EQ(none.faces.size(), 1u);
  EXPECT_TRUE(none.vertex_colors.empty());
}
