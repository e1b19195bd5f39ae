// Round trips for every format and encoding, hand-written files exercising the readers' corners
// (extra elements and list properties, polygons, OBJ index forms, OFF variants, STL welding).
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <fstream>
#include <iterator>

#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "io_test_util.hpp"

using namespace autoscan;
using namespace autoscan::io;
using autoscan::testing::decorated_sphere;
using autoscan::testing::temp_dir;
using autoscan::testing::write_bytes;

namespace {

double max_position_error(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double e = 0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, (a[i] - b[i]).cwiseAbs().maxCoeff());
  return e;
}

/// Checks that `got` equals `want` with the same vertex order; `tol` for positions and normals.
void expect_same_mesh(const TriangleMesh& want, const TriangleMesh& got, double tol, bool normals, bool colors,
                      bool scalars) {
  ASSERT_EQ(got.vertices.size(), want.vertices.size());
  ASSERT_EQ(got.faces, want.faces);
  EXPECT_LE(max_position_error(want.vertices, got.vertices), tol);
  if (normals) {
    ASSERT_EQ(got.vertex_normals.size(), want.vertex_normals.size());
    EXPECT_LE(max_position_error(want.vertex_normals, got.vertex_normals), tol);
  } else {
    EXPECT_TRUE(got.vertex_normals.empty());
  }
  if (colors)
    EXPECT_EQ(got.vertex_colors, want.vertex_colors);
  else
    EXPECT_TRUE(got.vertex_colors.empty());
  if (scalars) {
    ASSERT_EQ(got.vertex_scalars.size(), want.vertex_scalars.size());
    for (std::size_t c = 0; c < want.vertex_scalars.size(); ++c) {
      const auto& [name, col] = want.vertex_scalars.columns()[c];
      EXPECT_EQ(got.vertex_scalars.columns()[c].first, name);  // order kept
      const auto& g = got.vertex_scalars.get(name);
      ASSERT_EQ(g.size(), col.size());
      for (std::size_t i = 0; i < col.size(); ++i) EXPECT_NEAR(g[i], col[i], tol * std::max(1.0, std::abs(col[i])));
    }
  } else {
    EXPECT_TRUE(got.vertex_scalars.empty());
  }
}

struct PlyCase {
  const char* name;
  WriteOptions options;
  double tol;
};

}  // namespace

TEST(MeshIo, PlyRoundTripEveryEncoding) {
  const auto dir = temp_dir("ply_rt");
  const TriangleMesh m = decorated_sphere();
  const PlyCase cases[] = {
      {"binary_le_float", {}, 1e-7},
      {"binary_be_float", {.big_endian = true}, 1e-7},
      {"ascii_float", {.ascii = true}, 1e-7},
      {"binary_le_double", {.double_coordinates = true, .double_scalars = true}, 0.0},
      {"binary_be_double", {.big_endian = true, .double_coordinates = true, .double_scalars = true}, 0.0},
      {"ascii_double", {.ascii = true, .double_coordinates = true, .double_scalars = true}, 0.0},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const auto path = dir / (std::string(c.name) + ".ply");
    write_mesh(path, m, c.options);
    const GeometryFile g = read_geometry(path);
    EXPECT_EQ(g.format, c.options.ascii        ? "ply ascii"
                        : c.options.big_endian ? "ply binary_big_endian"
                                               : "ply binary_little_endian");
    expect_same_mesh(m, read_mesh(path), c.tol, true, true, true);
  }
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, ObjOffStlRoundTrips) {
  const auto dir = temp_dir("text_rt");
  const TriangleMesh m = decorated_sphere();
  // OBJ and OFF keep normals and colours (not scalars) and print shortest round-trip decimals.
  write_mesh(dir / "m.obj", m);
  expect_same_mesh(m, read_mesh(dir / "m.obj"), 0.0, true, true, false);
  write_mesh(dir / "m.off", m);
  expect_same_mesh(m, read_mesh(dir / "m.off"), 0.0, true, true, false);
  EXPECT_EQ(read_geometry(dir / "m.off").format, "CNOFF");
  TriangleMesh bare;
  bare.vertices = m.vertices;
  bare.faces = m.faces;
  write_mesh(dir / "bare.off", bare);
  expect_same_mesh(bare, read_mesh(dir / "bare.off"), 0.0, false, false, false);
  write_mesh(dir / "bare.obj", bare);
  expect_same_mesh(bare, read_mesh(dir / "bare.obj"), 0.0, false, false, false);

  // STL duplicates each corner; exact welding restores the shared vertices. Vertex order follows
  // first use, so compare face by face through positions.
  for (bool ascii : {false, true}) {
    SCOPED_TRACE(ascii ? "stl ascii" : "stl binary");
    const auto path = dir / (ascii ? "a.stl" : "b.stl");
    write_mesh(path, m, {.ascii = ascii});
    const GeometryFile g = read_geometry(path);
    EXPECT_EQ(g.format, ascii ? "stl ascii" : "stl binary");
    const TriangleMesh r = read_mesh(path);
    ASSERT_EQ(r.faces.size(), m.faces.size());
    EXPECT_EQ(r.vertices.size(), m.vertices.size());
    EXPECT_EQ(g.stl_corners, 3 * m.faces.size());
    const double tol = ascii ? 0.0 : 1e-7;
    for (std::size_t f = 0; f < m.faces.size(); ++f)
      for (int k = 0; k < 3; ++k)
        ASSERT_LE((r.vertices[r.faces[f][k]] - m.vertices[m.faces[f][k]]).cwiseAbs().maxCoeff(), tol);
  }
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, PointCloudRoundTripWithNormalsColoursScalars) {
  const auto dir = temp_dir("pc_rt");
  Rng rng(11);
  PointCloud pc;
  std::vector<double> f, fg, id;
  for (int i = 0; i < 500; ++i) {
    pc.positions.push_back(Vec3(rng.normal(), rng.normal(), rng.normal()));
    pc.normals.push_back(rng.unit_vector());
    pc.colors.push_back({static_cast<std::uint8_t>(i % 256), 7, static_cast<std::uint8_t>(255 - i % 256)});
    f.push_back(rng.uniform());
    fg.push_back(-rng.uniform());
    id.push_back(i % 9);
  }
  pc.scalars.set("f", f);
  pc.scalars.set("f_g", fg);
  pc.scalars.set("scan_id", id);
  for (bool ascii : {false, true})
    for (bool big : {false, true})
      for (bool dbl : {false, true}) {
        SCOPED_TRACE(fmt::format("ascii {} big {} double {}", ascii, big, dbl));
        const auto path = dir / "pc.ply";
        write_point_cloud(path, pc,
                          {.ascii = ascii, .big_endian = big, .double_coordinates = dbl, .double_scalars = dbl});
        const PointCloud r = read_point_cloud(path);
        ASSERT_EQ(r.size(), pc.size());
        const double tol = dbl ? 0.0 : 1e-6;
        EXPECT_LE(max_position_error(pc.positions, r.positions), tol * 5);
        EXPECT_LE(max_position_error(pc.normals, r.normals), tol);
        EXPECT_EQ(r.colors, pc.colors);
        ASSERT_EQ(r.scalars.size(), 3u);
        EXPECT_EQ(r.scalars.columns()[0].first, "f");
        EXPECT_EQ(r.scalars.columns()[1].first, "f_g");
        EXPECT_EQ(r.scalars.columns()[2].first, "scan_id");
        for (const char* name : {"f", "f_g", "scan_id"})
          for (std::size_t i = 0; i < pc.size(); ++i)
            ASSERT_NEAR(r.scalars.get(name)[i], pc.scalars.get(name)[i], tol * 10);
      }
  // Positions only, and an empty cloud (a scan that saw nothing) are valid files too.
  PointCloud bare;
  bare.positions = pc.positions;
  write_point_cloud(dir / "bare.ply", bare);
  const PointCloud rb = read_point_cloud(dir / "bare.ply");
  EXPECT_EQ(rb.size(), bare.size());
  EXPECT_FALSE(rb.has_normals());
  EXPECT_FALSE(rb.has_colors());
  EXPECT_TRUE(rb.scalars.empty());
  write_point_cloud(dir / "empty.ply", PointCloud{});
  EXPECT_TRUE(read_point_cloud(dir / "empty.ply").empty());
  // A point cloud is not a mesh.
  EXPECT_THROW(read_mesh(dir / "bare.ply"), InputError);
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, PointCloudFromMeshFormatsTakesVertices) {
  const auto dir = temp_dir("pc_from_mesh");
  const TriangleMesh m = autoscan::testing::tetrahedron();
  for (const char* ext : {".off", ".obj", ".ply", ".stl"}) {
    SCOPED_TRACE(ext);
    write_mesh(dir / (std::string("t") + ext), m);
    const PointCloud pc = read_point_cloud(dir / (std::string("t") + ext));
    ASSERT_EQ(pc.size(), 4u);
    // The STL order follows first use; compare as sets.
    for (const auto& v : m.vertices) {
      bool found = false;
      for (const auto& p : pc.positions) found = found || (p - v).norm() == 0.0;
      EXPECT_TRUE(found);
    }
  }
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, PlySkipsExtraElementsAndListPropertiesInEveryEncoding) {
  const auto dir = temp_dir("ply_extra");
  // vertex: x, a list (skipped), y, uchar scalar "quality", z, double "f"; a "material" element
  // before the faces; faces: a flag, the index list (a quad and a triangle), a texcoord list.
  auto header = [](const char* fmt) {
    return fmt::format(
        "ply\nformat {} 1.0\ncomment extra stuff\nobj_info made by hand\nelement vertex 5\nproperty float x\n"
        "property list uchar float junk\nproperty float y\nproperty uchar quality\nproperty float z\n"
        "property double f\nelement material 2\nproperty list int char name\nproperty float shininess\n"
        "element face 2\nproperty uchar flags\nproperty list uchar uint vertex_indices\n"
        "property list uchar float texcoord\nend_header\n",
        fmt);
  };
  const float xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 1}};
  std::string ascii = header("ascii");
  for (int i = 0; i < 5; ++i)
    ascii += fmt::format("{} {} {} {} {} {} {}\n", xyz[i][0], i % 3,
                         std::string(i % 3 ? " 1.5" : "").append(i % 3 == 2 ? " 2" : ""), xyz[i][1], 10 + i, xyz[i][2],
                         0.25 * i);
  ascii += "3 65 66 67 0.5\n0 1.5\n";
  ascii += "7 4 0 1 2 3 2 0.1 0.2\n0 3 4 2 1 0\n";
  write_bytes(dir / "ascii.ply", ascii);

  for (bool big : {false, true}) {
    std::string b = header(big ? "binary_big_endian" : "binary_little_endian");
    auto put = [&](auto v) {
      char raw[sizeof(v)];
      std::memcpy(raw, &v, sizeof(v));
      if (big != (std::endian::native == std::endian::big)) std::reverse(raw, raw + sizeof(v));
      b.append(raw, sizeof(v));
    };
    for (int i = 0; i < 5; ++i) {
      put(xyz[i][0]);
      put(static_cast<std::uint8_t>(i % 3));
      for (int k = 0; k < i % 3; ++k) put(1.5f);
      put(xyz[i][1]);
      put(static_cast<std::uint8_t>(10 + i));
      put(xyz[i][2]);
      put(0.25 * i);
    }
    put(std::int32_t{3});
    for (char ch : {'A', 'B', 'C'}) put(ch);
    put(0.5f);
    put(std::int32_t{0});
    put(1.5f);
    put(std::uint8_t{7});
    put(std::uint8_t{4});
    for (std::uint32_t v : {0u, 1u, 2u, 3u}) put(v);
    put(std::uint8_t{2});
    put(0.1f);
    put(0.2f);
    put(std::uint8_t{0});
    put(std::uint8_t{3});
    for (std::uint32_t v : {4u, 2u, 1u}) put(v);
    put(std::uint8_t{0});
    write_bytes(dir / (big ? "be.ply" : "le.ply"), b);
  }
  for (const char* name : {"ascii.ply", "le.ply", "be.ply"}) {
    SCOPED_TRACE(name);
    const TriangleMesh m = read_mesh(dir / name);
    ASSERT_EQ(m.vertices.size(), 5u);
    for (int i = 0; i < 5; ++i) EXPECT_EQ(m.vertices[i], Vec3(xyz[i][0], xyz[i][1], xyz[i][2]));
    const std::vector<Tri> want = {{0, 1, 2}, {0, 2, 3}, {4, 2, 1}};
    EXPECT_EQ(m.faces, want);
    ASSERT_EQ(m.vertex_scalars.size(), 2u);
    EXPECT_EQ(m.vertex_scalars.get("quality"), (std::vector<double>{10, 11, 12, 13, 14}));
    EXPECT_EQ(m.vertex_scalars.get("f"), (std::vector<double>{0, 0.25, 0.5, 0.75, 1.0}));
    EXPECT_TRUE(m.vertex_normals.empty());
    EXPECT_TRUE(m.vertex_colors.empty());
  }
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, ObjIndexFormsNegativeIndicesAndPolygons) {
  const auto dir = temp_dir("obj_forms");
  write_bytes(dir / "q.obj",
              "# a unit square pyramid\r\nmtllib none.mtl\no pyramid\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
              "v 0.5 0.5 1 1.0\nvt 0 0\nvt 1 0\nvn 0 0 -1\ng base\nusemtl stone\ns off\n"
              "f 1/1/1 4/2/1 3//1 2\n"  // a quad mixing corner forms
              "f -5/1 -4/2 -1\n"        // negative indices: 1 2 5
              "f 2 3 5\nf 3 4 5\nf 4 1 5\nl 1 2\n");
  const TriangleMesh m = read_mesh(dir / "q.obj");
  ASSERT_EQ(m.vertices.size(), 5u);
  const std::vector<Tri> want = {{0, 3, 2}, {0, 2, 1}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  EXPECT_EQ(m.faces, want);
  EXPECT_TRUE(m.vertex_normals.empty());  // only some vertices had normals
  EXPECT_TRUE(m.vertex_colors.empty());
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, OffVariantsCommentsAndPolygons) {
  const auto dir = temp_dir("off_forms");
  // Counts on the header line, comments everywhere, a quad with a face colour, COFF float colours.
  write_bytes(dir / "a.off",
              "OFF 5 2 0 # counts on the header line\n# a comment line\n\n0 0 0\n1 0 0 # trailing comment\n"
              "1 1 0\n0 1 0\n0.5 0.5 1\n4 0 1 2 3 255 0 0\n3 0 1 4\n");
  TriangleMesh a = read_mesh(dir / "a.off");
  EXPECT_EQ(a.vertices.size(), 5u);
  EXPECT_EQ(a.faces, (std::vector<Tri>{{0, 1, 2}, {0, 2, 3}, {0, 1, 4}}));
  write_bytes(dir / "c.off", "COFF\n3 1 0\n0 0 0 1.0 0.0 0.0 1.0\n1 0 0 0 0 255 255\n0 1 0 0 128 0 255\n3 0 1 2\n");
  const TriangleMesh c = read_mesh(dir / "c.off");
  EXPECT_EQ(c.vertex_colors, (std::vector<Rgb>{{255, 0, 0}, {0, 0, 255}, {0, 128, 0}}));
  write_bytes(dir / "n.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n");
  const TriangleMesh n = read_mesh(dir / "n.off");
  ASSERT_EQ(n.vertex_normals.size(), 3u);
  EXPECT_EQ(n.vertex_normals[2], Vec3(0, 0, 1));
  write_bytes(dir / "h.off", "4OFF\n3 1 0\n0 0 0 2\n2 0 0 2\n0 4 0 2\n3 0 1 2\n");
  EXPECT_EQ(read_mesh(dir / "h.off").vertices[2], Vec3(0, 2, 0));
  write_bytes(dir / "d.off", "nOFF\n3\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(read_mesh(dir / "d.off").faces.size(), 1u);
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, StlAsciiPolygonsAndExactWelding) {
  const auto dir = temp_dir("stl_weld");
  // Two facets sharing an edge, one written with -0: exact welding merges -0 and +0 but not 1e-9.
  write_bytes(dir / "w.stl",
              "solid two\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
              "endfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\nvertex -0 1 0\nendloop\n"
              "endfacet\nfacet normal 0 0 1\nouter loop\nvertex 5 5 5\nvertex 6 5 5\nvertex 5 6 5.000000001\n"
              "endloop\nendfacet\nendsolid two\n");
  const TriangleMesh m = read_mesh(dir / "w.stl");
  EXPECT_EQ(m.faces.size(), 3u);
  EXPECT_EQ(m.vertices.size(), 7u);
  EXPECT_EQ(m.faces[1], (Tri{1, 3, 2}));
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, UppercaseExtensionsAndCrLf) {
  const auto dir = temp_dir("case");
  write_bytes(dir / "T.PLY",
              "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty double x\r\nproperty double y\r\n"
              "property double z\r\nelement face 1\r\nproperty list uchar int vertex_index\r\nend_header\r\n"
              "0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n");
  EXPECT_EQ(read_mesh(dir / "T.PLY").faces.size(), 1u);
  EXPECT_EQ(format_from_extension("a/b/C.Obj"), FileFormat::obj);
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, WritersRefuseBadInputAndLeaveNothing) {
  const auto dir = temp_dir("bad_write");
  TriangleMesh m = autoscan::testing::tetrahedron();
  m.faces.push_back({0, 1, 7});
  EXPECT_THROW(write_mesh(dir / "bad.ply", m), InputError);
  m = autoscan::testing::tetrahedron();
  m.vertices[2].x() = std::nan("");
  EXPECT_THROW(write_mesh(dir / "bad.off", m), InputError);
  m = autoscan::testing::tetrahedron();
  EXPECT_THROW(write_mesh(dir / "bad.xyz", m), InputError);
  m.vertex_scalars.set("has space", {1, 2, 3, 4});
  EXPECT_THROW(write_mesh(dir / "bad2.ply", m), InputError);
  m.vertex_scalars.clear();
  m.vertex_scalars.set("x", {1, 2, 3, 4});
  EXPECT_THROW(write_mesh(dir / "bad3.ply", m), InputError);
  m.vertex_scalars.clear();
  m.vertex_scalars.set("short", {1, 2});
  EXPECT_THROW(write_mesh(dir / "bad4.ply", m), InputError);
  PointCloud pc;
  pc.positions = {Vec3(0, 0, 0)};
  EXPECT_THROW(write_point_cloud(dir / "cloud.obj", pc), InputError);
  pc.normals = {Vec3(0, 0, 1), Vec3(1, 0, 0)};
  EXPECT_THROW(write_point_cloud(dir / "cloud.ply", pc), InputError);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  // A write into a missing directory is a runtime failure that leaves nothing behind either.
  EXPECT_THROW(write_mesh(dir / "missing" / "t.ply", autoscan::testing::tetrahedron()), Error);
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  std::filesystem::remove_all(dir);
}

TEST(MeshIo, WritesReplaceExistingFilesAtomically) {
  const auto dir = temp_dir("replace");
  write_bytes(dir / "t.ply", "old content");
  write_mesh(dir / "t.ply", autoscan::testing::tetrahedron());
  EXPECT_EQ(read_mesh(dir / "t.ply").faces.size(), 4u);
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);  // no temporary left over
  std::filesystem::remove_all(dir);
}

// Found by fuzzing (fuzz_ply's round trip, docs/reliability.md): a PLY double scalar beyond float's
// range was read, then written as float (the default) — as inf — so the written file could not be
// read back (`convert` made a file no reader accepts). Such a column is now written as double.
TEST(MeshIo, PlyScalarBeyondFloatRangeSurvivesARoundTripWithDefaultOptions) {
  const auto dir = temp_dir("ply_scalar_range");
  write_bytes(dir / "in.ply",
              "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
              "property double quality\nproperty float intensity\nend_header\n0 0 0 1e300 1\n1 0 0 -4e38 2\n");
  const PointCloud in = read_point_cloud(dir / "in.ply");
  for (const WriteOptions& o : {WriteOptions{}, WriteOptions{.ascii = true}, WriteOptions{.big_endian = true}}) {
    write_point_cloud(dir / "out.ply", in, o);
    const PointCloud out = read_point_cloud(dir / "out.ply");
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(out.scalars.get("quality"), (std::vector<double>{1e300, -4e38}));
    EXPECT_EQ(out.scalars.get("intensity"), (std::vector<double>{1.0, 2.0}));
  }
  // The other columns keep the float the options ask for.
  std::ifstream f(dir / "out.ply", std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("property double quality\n"), std::string::npos);
  EXPECT_NE(text.find("property float intensity\n"), std::string::npos);
  std::filesystem::remove_all(dir);
}
