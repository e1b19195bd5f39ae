// Topology counts against hand-computed oracles, and the six real benchmark meshes.
#include <gtest/gtest.h>

#include "autoscan/io/mesh_io.hpp"
#include "autoscan/io/topology.hpp"
#include "io_test_util.hpp"

using namespace autoscan;
using namespace autoscan::io;

TEST(Topology, TetrahedronIsClosedGenusZero) {
  const auto t = analyze_topology(autoscan::testing::tetrahedron());
  EXPECT_EQ(t.vertices, 4u);
  EXPECT_EQ(t.faces, 4u);
  EXPECT_EQ(t.edges, 6u);
  EXPECT_EQ(t.boundary_edges, 0u);
  EXPECT_EQ(t.non_manifold_edges, 0u);
  EXPECT_EQ(t.connected_components, 1u);
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_TRUE(t.closed);
  EXPECT_TRUE(t.consistently_oriented);
  ASSERT_TRUE(t.genus.has_value());
  EXPECT_EQ(*t.genus, 0);
}

TEST(Topology, TorusHasGenusOneAndTwoToriGenusTwo) {
  const auto t = analyze_topology(autoscan::testing::torus(12, 8));
  EXPECT_EQ(t.euler_characteristic, 0);
  EXPECT_EQ(t.edges, 3u * 12 * 8);
  EXPECT_TRUE(t.closed);
  ASSERT_TRUE(t.genus.has_value());
  EXPECT_EQ(*t.genus, 1);
  // Two disjoint tori: two components, genus summed.
  TriangleMesh two = autoscan::testing::torus(10, 6);
  const TriangleMesh other = autoscan::testing::torus(9, 7, 1.0, 0.3, Vec3(5, 0, 0));
  const int off = static_cast<int>(two.vertices.size());
  two.vertices.insert(two.vertices.end(), other.vertices.begin(), other.vertices.end());
  for (auto f : other.faces) two.faces.push_back({f[0] + off, f[1] + off, f[2] + off});
  const auto t2 = analyze_topology(two);
  EXPECT_EQ(t2.connected_components, 2u);
  EXPECT_EQ(*t2.genus, 2);
}

TEST(Topology, OpenSquareHasFourBoundaryEdges) {
  TriangleMesh sq;
  sq.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  sq.faces = {{0, 1, 2}, {0, 2, 3}};
  const auto t = analyze_topology(sq);
  EXPECT_EQ(t.edges, 5u);
  EXPECT_EQ(t.boundary_edges, 4u);
  EXPECT_EQ(t.euler_characteristic, 1);
  EXPECT_FALSE(t.closed);
  EXPECT_TRUE(t.manifold);
  EXPECT_FALSE(t.genus.has_value());
}

TEST(Topology, NonManifoldFanAndBowtie) {
  // Three triangles around the edge (0,1).
  TriangleMesh fan;
  fan.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1)};
  fan.faces = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  const auto t = analyze_topology(fan);
  EXPECT_EQ(t.non_manifold_edges, 1u);
  EXPECT_EQ(t.boundary_edges, 6u);
  EXPECT_FALSE(t.manifold);
  EXPECT_FALSE(t.closed);
  EXPECT_FALSE(t.genus.has_value());
  // Two triangles touching at one vertex: manifold edges, a non-manifold vertex.
  TriangleMesh bow;
  bow.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(-1, 0, 0), Vec3(-1, -1, 0)};
  bow.faces = {{0, 1, 2}, {0, 3, 4}};
  const auto b = analyze_topology(bow);
  EXPECT_EQ(b.non_manifold_edges, 0u);
  EXPECT_EQ(b.non_manifold_vertices, 1u);
  EXPECT_EQ(b.connected_components, 1u);
  EXPECT_FALSE(b.manifold);
  // Two tetrahedra sharing one vertex: no boundary, but pinched, so not closed and no genus.
  TriangleMesh two = autoscan::testing::tetrahedron();
  two.vertices.push_back(Vec3(-1, 0, 0));
  two.vertices.push_back(Vec3(0, -1, 0));
  two.vertices.push_back(Vec3(0, 0, -1));
  two.faces.push_back({0, 4, 5});
  two.faces.push_back({0, 5, 6});
  two.faces.push_back({0, 6, 4});
  two.faces.push_back({4, 6, 5});
  const auto tt = analyze_topology(two);
  EXPECT_EQ(tt.boundary_edges, 0u);
  EXPECT_EQ(tt.non_manifold_vertices, 1u);
  EXPECT_FALSE(tt.closed);
}

TEST(Topology, DuplicateVerticesAreWeldedAndCounted) {
  // A tetrahedron with separate corners per face ("triangle soup").
  const TriangleMesh t = autoscan::testing::tetrahedron();
  TriangleMesh soup;
  for (const auto& f : t.faces) {
    const int b = static_cast<int>(soup.vertices.size());
    for (int k = 0; k < 3; ++k) soup.vertices.push_back(t.vertices[f[k]]);
    soup.faces.push_back({b, b + 1, b + 2});
  }
  const auto w = analyze_topology(soup);
  EXPECT_EQ(w.duplicate_vertices, 8u);
  EXPECT_TRUE(w.closed);
  EXPECT_EQ(*w.genus, 0);
  const auto raw = analyze_topology(soup, {.weld_coincident = false});
  EXPECT_EQ(raw.duplicate_vertices, 0u);
  EXPECT_EQ(raw.connected_components, 4u);
  EXPECT_EQ(raw.boundary_edges, 12u);
  EXPECT_FALSE(raw.closed);
}

TEST(Topology, DegenerateFlippedAndIsolated) {
  TriangleMesh m = autoscan::testing::tetrahedron();
  std::swap(m.faces[3][0], m.faces[3][1]);  // one face flipped: orientable, not consistent
  m.faces.push_back({0, 0, 1});             // degenerate: ignored by the counts
  m.vertices.push_back(Vec3(9, 9, 9));      // isolated
  const auto t = analyze_topology(m);
  EXPECT_EQ(t.degenerate_faces, 1u);
  EXPECT_EQ(t.isolated_vertices, 1u);
  EXPECT_FALSE(t.consistently_oriented);
  EXPECT_TRUE(t.orientable);
  EXPECT_TRUE(t.closed);
  EXPECT_EQ(*t.genus, 0);
  EXPECT_EQ(t.connected_components, 1u);
}

TEST(Topology, MoebiusStripIsNotOrientable) {
  // A strip of n quads whose ends are glued with a half twist.
  const int n = 8;
  TriangleMesh m;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * 3.14159265358979 * i / n;
    m.vertices.push_back(Vec3(std::cos(a), std::sin(a), -0.2));
    m.vertices.push_back(Vec3(std::cos(a), std::sin(a), 0.2));
  }
  for (int i = 0; i < n; ++i) {
    const int a0 = 2 * i, a1 = 2 * i + 1;
    int b0 = 2 * (i + 1), b1 = 2 * (i + 1) + 1;
    if (i == n - 1) {
      b0 = 1;  // the twist
      b1 = 0;
    }
    m.faces.push_back({a0, b0, b1});
    m.faces.push_back({a0, b1, a1});
  }
  const auto t = analyze_topology(m);
  EXPECT_TRUE(t.manifold);
  EXPECT_FALSE(t.orientable);
  EXPECT_EQ(t.boundary_edges, 2u * n);
  EXPECT_FALSE(t.genus.has_value());
}

TEST(Topology, RealBenchmarkMeshesAreClosedWithTheirGenus) {
  // Meshes from Debian's libcgal-demo (scripts/fetch-models; part of the set-up).
  const std::pair<const char*, long long> models[] = {{"bunny00", 0},      {"armadillo", 0}, {"refined_elephant", 3},
                                                      {"anchor_dense", 4}, {"man", 0},       {"eight", 2}};
  for (const auto& [name, genus] : models) {
    SCOPED_TRACE(name);
    const auto path = std::filesystem::path(AUTOSCAN_MODELS_DIR) / (std::string(name) + ".off");
    ASSERT_TRUE(std::filesystem::exists(path)) << path << " is missing: run scripts/fetch-models";
    const TriangleMesh m = read_mesh(path);
    const auto t = analyze_topology(m);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.non_manifold_edges, 0u);
    EXPECT_EQ(t.non_manifold_vertices, 0u);
    EXPECT_EQ(t.duplicate_vertices, 0u);
    EXPECT_EQ(t.connected_components, 1u);
    EXPECT_TRUE(t.closed);
    EXPECT_TRUE(t.orientable);
    ASSERT_TRUE(t.genus.has_value());
    EXPECT_EQ(*t.genus, genus);
  }
}
