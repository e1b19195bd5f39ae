// Fuzz target for one geometry reader (PLY, OBJ, OFF or STL, chosen at build time by
// AUTOSCAN_FUZZ_FORMAT): the bytes are parsed as a file of that format by io::parse_geometry, the
// in-memory entry point of io::read_geometry, with all its checks. An accepted file must then
// (1) meet the contract of mesh_io.hpp: finite attributes within kMaxCoordinate, one value per
//     vertex, face indices in range, at least one triangle per polygon;
// (2) survive a round trip: what the reader accepted, the writer of the same format writes (in
//     memory, default options and, for PLY, also ASCII with doubles) and the reader reads back
//     with the same counts (and, where the written numbers are exact, the same positions).
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "autoscan/io/detail_parse.hpp"
#include "autoscan/io/mesh_io.hpp"
#include "fuzz_common.hpp"

#ifndef AUTOSCAN_FUZZ_FORMAT
#error "define AUTOSCAN_FUZZ_FORMAT (ply, obj, off or stl)"
#endif

namespace {

namespace io = autoscan::io;
using io::FileFormat;
constexpr FileFormat kFormat = FileFormat::AUTOSCAN_FUZZ_FORMAT;
constexpr const char* kName = (kFormat == FileFormat::ply   ? "fuzz.ply"
                               : kFormat == FileFormat::obj ? "fuzz.obj"
                               : kFormat == FileFormat::off ? "fuzz.off"
                                                            : "fuzz.stl");

void check(bool ok) {
  if (!ok) std::abort();  // an accepted file broke the reader's contract
}

void check_contract(const io::GeometryFile& g) {
  const auto& v = g.vertices;
  const auto n = static_cast<long long>(v.size());
  for (const auto& p : v.positions) check(p.allFinite() && p.cwiseAbs().maxCoeff() <= autoscan::kMaxCoordinate);
  for (const auto& q : v.normals) check(q.allFinite() && q.cwiseAbs().maxCoeff() <= autoscan::kMaxCoordinate);
  check(v.normals.empty() || v.normals.size() == v.positions.size());
  check(v.colors.empty() || v.colors.size() == v.positions.size());
  for (const auto& [name, column] : v.scalars.columns()) {
    check(column.size() == v.positions.size());
    for (double x : column) check(std::isfinite(x));
  }
  for (const auto& f : g.faces)
    for (int k = 0; k < 3; ++k) check(f[k] >= 0 && f[k] < n);
  check(g.polygons <= g.faces.size() || kFormat == FileFormat::stl);
}

// write_mesh's own refusal: scalar names PLY cannot hold (mesh_io.cpp, check_scalar_names).
bool writable_names(const autoscan::ScalarAttributes& s) {
  static const char* reserved[] = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue"};
  for (const auto& [name, col] : s.columns()) {
    if (name.empty()) return false;
    for (char c : name)
      if (!std::isgraph(static_cast<unsigned char>(c))) return false;
    for (const char* r : reserved)
      if (name == r) return false;
  }
  return true;
}

autoscan::TriangleMesh mesh_of(const io::GeometryFile& g) {
  autoscan::TriangleMesh m;
  m.vertices = g.vertices.positions;
  m.vertex_normals = g.vertices.normals;
  m.vertex_colors = g.vertices.colors;
  m.vertex_scalars = g.vertices.scalars;
  m.faces = g.faces;
  return m;
}

void round_trip(const io::GeometryFile& g, const io::WriteOptions& o, bool exact) {
  std::ostringstream os;
  const auto m = mesh_of(g);
  switch (kFormat) {
    case FileFormat::ply:
      io::detail::write_ply(os, {m.vertices, m.vertex_normals, m.vertex_colors, m.vertex_scalars}, m.faces, o);
      break;
    case FileFormat::obj:
      io::detail::write_obj(os, m);
      break;
    case FileFormat::off:
      io::detail::write_off(os, m);
      break;
    case FileFormat::stl:
      io::detail::write_stl(os, m, o.ascii);
      break;
  }
  // Anything thrown here, InputError included, is a finding: the file was accepted.
  const io::GeometryFile back = io::parse_geometry(os.str(), kFormat, kName);
  check_contract(back);
  check(back.faces.size() == g.faces.size());
  if (kFormat == FileFormat::stl) return;  // STL keeps no vertex list: corners are welded
  check(back.vertices.size() == g.vertices.size());
  if (kFormat == FileFormat::ply) check(back.vertices.scalars.size() == g.vertices.scalars.size());
  if (exact) check(back.vertices.positions == g.vertices.positions && back.faces == g.faces);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  autoscan::fuzz::quiet();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes = autoscan::fuzz::bytes_of(data, size);
  io::GeometryFile g;
  try {
    g = io::parse_geometry(bytes, kFormat, kName);
  } catch (const autoscan::InputError&) {
    return 0;  // refused: the expected answer to bad input
  }
  check_contract(g);
  if (kFormat == FileFormat::ply && !writable_names(g.vertices.scalars)) return 0;
  round_trip(g, {}, kFormat == FileFormat::obj || kFormat == FileFormat::off);
  if (kFormat == FileFormat::ply)
    round_trip(g, {.ascii = true, .double_coordinates = true, .double_scalars = true}, true);
  if (kFormat == FileFormat::stl) round_trip(g, {.ascii = true}, false);
  return 0;
}
