// PCD (ASCII and binary), XYZ and PTS point clouds: round trips and the malformed-input discipline
// of the PLY reader (every error an InputError starting with the path; counts checked against the
// file size; truncation at any byte never crashes).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "autoscan/core/error.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "support/temp_dir.hpp"

using namespace autoscan;
namespace fs = std::filesystem;

namespace {

// Below the test process's scratch root, removed when the process exits (support/temp_dir.hpp).
fs::path temp_dir() { return autoscan::testing::shared_scratch_dir("point_formats"); }

fs::path write_bytes(const std::string& name, const std::string& bytes) {
  const auto p = temp_dir() / name;
  std::ofstream(p, std::ios::binary) << bytes;
  return p;
}

PointCloud sample_cloud(bool normals, bool colors, bool scalars, std::size_t n = 200) {
  Rng rng(7);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    c.positions.emplace_back(rng.normal(), rng.normal(), rng.normal());
    if (normals) c.normals.push_back(c.positions.back().normalized());
    if (colors)
      c.colors.push_back({static_cast<std::uint8_t>(i % 256), static_cast<std::uint8_t>((3 * i) % 256),
                          static_cast<std::uint8_t>(255 - i % 256)});
  }
  if (scalars) {
    std::vector<double> f(n), id(n);
    for (std::size_t i = 0; i < n; ++i) {
      f[i] = rng.uniform();
      id[i] = static_cast<double>(i % 7);
    }
    c.scalars.set("f", f);
    c.scalars.set("scan_id", id);
  }
  return c;
}

std::string error_of(const fs::path& p) {
  try {
    io::read_point_cloud(p);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

void expect_error(const std::string& name, const std::string& bytes, const std::string& fragment) {
  const auto p = write_bytes(name, bytes);
  const std::string msg = error_of(p);
  EXPECT_EQ(msg.rfind(p.string(), 0), 0u) << name << ": " << msg;
  EXPECT_NE(msg.find(fragment), std::string::npos) << name << ": '" << msg << "' lacks '" << fragment << "'";
}

const char* kHeader3 =
    "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";

}  // namespace

TEST(PointFormats, PcdRoundTripsBinaryAndAscii) {
  const PointCloud c = sample_cloud(true, true, true);
  for (bool ascii : {false, true})
    for (bool dbl : {false, true}) {
      io::WriteOptions o;
      o.ascii = ascii;
      o.double_coordinates = dbl;
      o.double_scalars = dbl;
      const auto p = temp_dir() / "round.pcd";
      io::write_point_cloud(p, c, o);
      const PointCloud r = io::read_point_cloud(p);
      ASSERT_EQ(r.size(), c.size());
      ASSERT_TRUE(r.has_normals());
      for (std::size_t i = 0; i < c.size(); ++i) {
        if (dbl) {
          EXPECT_EQ(r.positions[i], c.positions[i]);
          EXPECT_EQ(r.normals[i], c.normals[i]);
        } else {
          EXPECT_EQ(r.positions[i], c.positions[i].cast<float>().cast<double>());
        }
        EXPECT_EQ(r.colors[i], c.colors[i]);
      }
      EXPECT_EQ(r.scalars.get("scan_id"), c.scalars.get("scan_id"));
      if (dbl) {
        EXPECT_EQ(r.scalars.get("f"), c.scalars.get("f"));
      }
    }
}

TEST(PointFormats, XyzAndPtsRoundTripExactly) {
  const PointCloud c = sample_cloud(true, false, false);
  io::write_point_cloud(temp_dir() / "a.xyz", c);
  const PointCloud x = io::read_point_cloud(temp_dir() / "a.xyz");
  EXPECT_EQ(x.positions, c.positions);
  EXPECT_EQ(x.normals, c.normals);

  PointCloud d = sample_cloud(false, true, false);
  std::vector<double> intensity(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) intensity[i] = 0.25 * static_cast<double>(i);
  d.scalars.set("intensity", intensity);
  io::write_point_cloud(temp_dir() / "a.PTS", d);
  const PointCloud p = io::read_point_cloud(temp_dir() / "a.PTS");
  EXPECT_EQ(p.positions, d.positions);
  EXPECT_EQ(p.colors, d.colors);
  EXPECT_EQ(p.scalars.get("intensity"), intensity);
}

TEST(PointFormats, PcdReadsPclLayouts) {
  // PCL's own ASCII layout: rgb as the float carrying the packed bits, padding, a COUNT 3 field,
  // an organised cloud with a "no measurement" point.
  float rgb;
  const std::uint32_t bits = (10u << 16) | (20u << 8) | 30u;
  std::memcpy(&rgb, &bits, 4);
  const std::string text = fmt::format(
      "# .PCD v.7 - Point Cloud Data file format\nVERSION .7\nFIELDS x y z rgb _ hist\nSIZE 4 4 4 4 1 4\n"
      "TYPE F F F F U F\nCOUNT 1 1 1 1 1 3\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n"
      "1 2 3 {} 0 0.5 1.5 2.5\nnan nan nan {} 0 0 0 0\n-1 -2 -3 {} 0 1 2 3\n",
      rgb, rgb, rgb);
  const auto p = write_bytes("pcl.pcd", text);
  const io::GeometryFile g = io::read_geometry(p);
  EXPECT_NE(g.format.find("1 points without a measurement dropped"), std::string::npos) << g.format;
  const PointCloud& c = g.vertices;
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.positions[1], Vec3(-1, -2, -3));
  EXPECT_EQ(c.colors[0], (Rgb{10, 20, 30}));
  EXPECT_EQ(c.scalars.get("hist_1"), (std::vector<double>{1.5, 2}));
  EXPECT_FALSE(c.has_normals());
  // The same cloud in binary with integer fields.
  std::string bin =
      "VERSION 0.7\nFIELDS x y z label\nSIZE 8 8 8 2\nTYPE F F F I\nCOUNT 1 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\n"
      "DATA binary\n";
  const double xyz[3] = {0.1, 0.2, 0.3};
  const std::int16_t label = -7;
  bin.append(reinterpret_cast<const char*>(xyz), sizeof xyz).append(reinterpret_cast<const char*>(&label), 2);
  const PointCloud b = io::read_point_cloud(write_bytes("bin.pcd", bin));
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(b.positions[0], Vec3(0.1, 0.2, 0.3));
  EXPECT_EQ(b.scalars.get("label")[0], -7.0);
}

TEST(PointFormats, MalformedPcdGivesInputErrorNamingTheFile) {
  const std::string h = kHeader3;
  expect_error("garbage.pcd", std::string("\x01\x02garbage\0\0", 11), "binary data");
  expect_error("nodata.pcd", h, "no DATA line");
  expect_error("compressed.pcd", h + "DATA binary_compressed\n", "binary_compressed is not supported");
  expect_error("unknown.pcd", h + "DATA text\n", "unknown DATA");
  expect_error("keyword.pcd", "VERSION 0.7\nFOO 1\n", "unknown PCD header keyword 'FOO'");
  expect_error("first.pcd", "hello world\n", "not a PCD file");
  expect_error("noxyz.pcd", "FIELDS a b\nSIZE 4 4\nTYPE F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2\n",
               "no x, y and z fields");
  expect_error("sizes.pcd", "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n", "SIZE has 2 entries");
  expect_error("badsize.pcd", "FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
               "SIZE 3 is not valid for TYPE F");
  expect_error("points.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nPOINTS 3\nDATA ascii\n",
               "POINTS 3 differs from WIDTH 2 x HEIGHT 1");
  expect_error("absurd.pcd",
               "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4000000000000\nPOINTS 4000000000000\nDATA binary\n1234",
               "truncated");
  expect_error("absurd_ascii.pcd",
               "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4000000000\nPOINTS 4000000000\nDATA ascii\n1 2 3\n",
               "more than the");
  expect_error("short.pcd", h + "DATA ascii\n1 2 3\n", "truncated: 2 points declared");
  expect_error("field.pcd", h + "DATA ascii\n1 2 3\n4 5\n", "ends before field 'z'");
  expect_error("extra.pcd", h + "DATA ascii\n1 2 3\n4 5 6 7\n", "more values");
  expect_error("after.pcd", h + "DATA ascii\n1 2 3\n4 5 6\n7 8 9\n", "unexpected data after the 2 declared points");
  expect_error("nan.pcd", h + "DATA ascii\n1 nan 3\n4 5 6\n", "non-finite coordinate");
  expect_error("inf.pcd", h + "DATA ascii\n1 2 3\n4 inf 6\n", "line 13: point 1 has a non-finite coordinate");
  expect_error("big.pcd", h + "DATA ascii\n1 2 3\n4 5e13 6\n", "beyond ±1e12");
  expect_error("word.pcd", h + "DATA ascii\n1 2 3\n4 five 6\n", "'five' is not a number");
  expect_error("normals.pcd", "FIELDS x y z normal_x\nSIZE 4 4 4 4\nTYPE F F F F\nWIDTH 1\nDATA ascii\n1 2 3 0\n",
               "only some of normal_x");
  expect_error("twice.pcd", "FIELDS x y x\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n", "listed twice");
  std::string trailing = h + "DATA binary\n";
  trailing.append(2 * 12 + 5, '\0');
  expect_error("trailing.pcd", trailing, "5 bytes of unexpected data");
}

TEST(PointFormats, TruncatedBinaryPcdAtEveryByteNeverCrashes) {
  const PointCloud c = sample_cloud(true, true, true, 5);
  const auto full = temp_dir() / "full.pcd";
  io::write_point_cloud(full, c);
  std::ifstream in(full, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (std::size_t n = 1; n < bytes.size(); ++n) {
    const auto p = write_bytes("cut.pcd", bytes.substr(0, n));
    EXPECT_THROW(io::read_point_cloud(p), InputError) << n;
  }
}

TEST(PointFormats, MalformedXyzAndPtsGiveInputErrorNamingTheFile) {
  expect_error("cols.xyz", "1 2 3\n4 5 6 7\n", "4 values on this line but 3");
  expect_error("four.xyz", "1 2 3 4\n", "4 values on a line; expected x y z or x y z nx ny nz");
  expect_error("nan.xyz", "1 2 3\n4 nan 6\n", "line 2: point 1 has a non-finite value");
  expect_error("word.xyz", "1 2 x\n", "'x' is not a number");
  expect_error("big.xyz", "1 2 3e15\n", "beyond ±1e12");
  expect_error("empty.xyz", "# nothing\n\n", "has no points");
  expect_error("binary.xyz", std::string("1 2 3\n\0\0", 8), "binary data");
  expect_error("long.xyz", "1 2 3 4 5 6 7 8 9\n", "more than 7 values");
  expect_error("count.pts", "3\n1 2 3\n4 5 6\n", "declares 3 points but the file has 2");
  expect_error("absurd.pts", "99999999999\n1 2 3\n", "more than the file's");
  expect_error("negative.pts", "-4\n1 2 3\n", "not a non-negative integer");
  expect_error("colour.pts", "1\n1 2 3 0.5 256 0 0\n", "colour value 256 outside 0..255");
  expect_error("five.pts", "1 2 3 4 5\n", "5 values on a line");
}

TEST(PointFormats, WritersRefuseWhatTheFormatCannotHold) {
  PointCloud c = sample_cloud(false, false, false, 3);
  c.scalars.set("normal_x", {1, 2, 3});
  EXPECT_THROW(io::write_point_cloud(temp_dir() / "bad.pcd", c), InputError);
  EXPECT_FALSE(fs::exists(temp_dir() / "bad.pcd"));
  TriangleMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  m.faces = {{0, 1, 2}};
  try {
    io::write_mesh(temp_dir() / "m.pcd", m);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is a point cloud format"), std::string::npos) << e.what();
  }
  // A mesh file's vertices can be written as any cloud format.
  EXPECT_EQ(io::format_from_extension("a/B.Pcd"), io::FileFormat::pcd);
  EXPECT_EQ(io::format_from_extension("b.xyz"), io::FileFormat::xyz);
  EXPECT_EQ(io::format_from_extension("c.pts"), io::FileFormat::pts);
  fs::remove_all(temp_dir());
}
