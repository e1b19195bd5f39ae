// Colours through every file round trip (docs/colour.md): vertex colours in PLY (binary and ASCII)
// and OBJ, a texture with UVs in OBJ + MTL + PNG, and the MTL reader's corners and errors.
#include <gtest/gtest.h>

#include "autoscan/core/error.hpp"
#include "autoscan/io/image.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "io_test_util.hpp"

using namespace autoscan;
using namespace autoscan::io;
using autoscan::testing::temp_dir;
using autoscan::testing::torus;
using autoscan::testing::write_bytes;

namespace {

/// A torus whose vertices take every byte value in every channel (0..255, in three different orders).
TriangleMesh every_colour_torus() {
  TriangleMesh m = torus(16, 16);  // 256 vertices
  m.vertex_colors.resize(m.vertices.size());
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    m.vertex_colors[i] = {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(255 - i),
                          static_cast<std::uint8_t>((i * 7) % 256)};
  return m;
}

TriangleMesh textured_torus() {
  TriangleMesh m = torus(12, 8);
  Rng rng(5);
  m.texture = Image(7, 5);
  for (auto& p : m.texture.pixels)
    for (auto& c : p) c = static_cast<std::uint8_t>(rng.uniform_int(256));
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) m.face_uvs.emplace_back(rng.uniform(), rng.uniform());
  return m;
}

}  // namespace

TEST(ColourIo, PlyKeepsEveryVertexColourBinaryAndAscii) {
  const auto dir = temp_dir("colour_ply");
  const TriangleMesh m = every_colour_torus();
  for (bool ascii : {false, true})
    for (bool big : {false, true}) {
      SCOPED_TRACE(fmt::format("ascii {} big endian {}", ascii, big));
      const auto path = dir / "m.ply";
      write_mesh(path, m, {.ascii = ascii, .big_endian = big});
      EXPECT_EQ(read_mesh(path).vertex_colors, m.vertex_colors);
      PointCloud cloud;
      cloud.positions = m.vertices;
      cloud.colors = m.vertex_colors;
      write_point_cloud(dir / "c.ply", cloud, {.ascii = ascii, .big_endian = big});
      EXPECT_EQ(read_point_cloud(dir / "c.ply").colors, cloud.colors);
    }
  std::filesystem::remove_all(dir);
}

TEST(ColourIo, ObjKeepsEveryVertexColour) {
  const auto dir = temp_dir("colour_obj");
  const TriangleMesh m = every_colour_torus();
  write_mesh(dir / "m.obj", m);
  EXPECT_EQ(read_mesh(dir / "m.obj").vertex_colors, m.vertex_colors);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.mtl"));  // no texture: no MTL
  std::filesystem::remove_all(dir);
}

TEST(ColourIo, ObjMtlPngRoundTripKeepsTextureAndUvs) {
  const auto dir = temp_dir("colour_tex");
  TriangleMesh m = textured_torus();
  m.vertex_colors.assign(m.vertices.size(), Rgb{1, 2, 3});
  m.compute_vertex_normals();
  write_mesh(dir / "model.obj", m);
  ASSERT_TRUE(std::filesystem::exists(dir / "model.mtl"));
  ASSERT_TRUE(std::filesystem::exists(dir / "model.png"));
  const TriangleMesh r = read_mesh(dir / "model.obj");
  EXPECT_EQ(r.vertices, m.vertices);
  EXPECT_EQ(r.faces, m.faces);
  EXPECT_EQ(r.face_uvs, m.face_uvs);  // shortest round-trip decimals: exact
  EXPECT_EQ(r.texture.width, 7);
  EXPECT_EQ(r.texture.height, 5);
  EXPECT_EQ(r.texture.pixels, m.texture.pixels);
  EXPECT_EQ(r.vertex_colors, m.vertex_colors);
  ASSERT_EQ(r.vertex_normals.size(), m.vertex_normals.size());
  // The surface colour is the texture's, the same before and after.
  for (std::size_t f = 0; f < m.faces.size(); f += 7) EXPECT_EQ(r.color_at(f, 0.2, 0.3), m.color_at(f, 0.2, 0.3));
  // And through the PNG alone.
  EXPECT_EQ(read_png(dir / "model.png").pixels, m.texture.pixels);
  std::filesystem::remove_all(dir);
}

TEST(ColourIo, HandWrittenObjWithQuadsMaterialsAndMapOptions) {
  const auto dir = temp_dir("colour_hand");
  Image tex(2, 2);
  tex.at(0, 0) = {255, 0, 0};
  tex.at(1, 0) = {0, 255, 0};
  tex.at(0, 1) = {0, 0, 255};
  tex.at(1, 1) = {255, 255, 255};
  std::filesystem::create_directories(dir / "tex");
  write_png(dir / "tex" / "paint.png", tex);
  write_bytes(dir / "scene.mtl",
              "# two materials\nnewmtl other\nKd 1 0 0\nnewmtl painted  \n  Kd 1 1 1\n  map_Kd -s 1 1 1 "
              "tex/paint.png\n");
  // A quad (fan-triangulated: its UVs follow), negative and positive texture indices.
  write_bytes(dir / "quad.obj",
              "mtllib scene.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1 0\nvt 0 1\n"
              "usemtl painted\nf 1/1 2/2 3/-2 4/-1\n");
  const TriangleMesh m = read_mesh(dir / "quad.obj");
  ASSERT_EQ(m.faces.size(), 2u);
  ASSERT_EQ(m.face_uvs.size(), 6u);
  EXPECT_EQ(m.face_uvs[3], Eigen::Vector2d(0, 0));
  EXPECT_EQ(m.face_uvs[4], Eigen::Vector2d(1, 1));
  EXPECT_EQ(m.face_uvs[5], Eigen::Vector2d(0, 1));
  EXPECT_EQ(m.texture.pixels, tex.pixels);
  // Vertex 0 at UV (0, 0): the bottom-left texel (row 1, v up).
  const Vec3 c = m.color_at(0, 0.0, 0.0);
  EXPECT_EQ(c, Vec3(0, 0, 255));

  // Faces without UVs or no mtllib: no texture, no error.
  write_bytes(dir / "plain.obj", "mtllib scene.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
  EXPECT_FALSE(read_mesh(dir / "plain.obj").has_texture());

  // A missing MTL, a missing texture, a texture that is not a PNG: errors naming the file.
  auto expect_error = [&](const std::string& obj, const std::string& needle) {
    write_bytes(dir / "bad.obj", obj);
    try {
      (void)read_mesh(dir / "bad.obj");
      ADD_FAILURE() << "no error for " << needle;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  const std::string body = "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n";
  expect_error("mtllib nowhere.mtl\n" + body, "nowhere.mtl");
  write_bytes(dir / "gone.mtl", "newmtl a\nmap_Kd gone.png\n");
  expect_error("mtllib gone.mtl\n" + body, "gone.png");
  write_bytes(dir / "jpeg.mtl", "newmtl a\nmap_Kd photo.jpg\n");
  expect_error("mtllib jpeg.mtl\n" + body, "photo.jpg");
  std::filesystem::remove_all(dir);
}

TEST(ColourIo, TextureSamplingIsBilinearWithVUp) {
  Image img(2, 1);
  img.at(0, 0) = {0, 0, 0};
  img.at(1, 0) = {200, 100, 50};
  EXPECT_EQ(img.sample(0.25, 0.5), Vec3(0, 0, 0));       // the left texel's centre
  EXPECT_EQ(img.sample(0.75, 0.5), Vec3(200, 100, 50));  // the right one's
  EXPECT_TRUE(img.sample(0.5, 0.5).isApprox(Vec3(100, 50, 25)));
  EXPECT_EQ(img.sample(0.1, 0.5), Vec3(0, 0, 0));                    // clamped at the edge
  EXPECT_TRUE(img.sample(1.5, 0.5).isApprox(img.sample(0.5, 0.5)));  // repeat
  EXPECT_EQ(Image().sample(0.5, 0.5), Vec3::Zero());
}
