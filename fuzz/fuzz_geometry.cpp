// Fuzz target for one geometry reader (PLY, OBJ, OFF or STL, chosen at build time by
// AUTOSCAN_FUZZ_FORMAT): the bytes are parsed as a file of that format by io::parse_geometry,
// the in-memory entry point of io::read_geometry, with all its checks. On success the contract
// of mesh_io.hpp is checked too: finite attributes within kMaxCoordinate, one value per vertex,
// face indices in range, at least one triangle per polygon.
#include <cmath>
#include <cstdlib>

#include "autoscan/io/mesh_io.hpp"
#include "fuzz_common.hpp"

#ifndef AUTOSCAN_FUZZ_FORMAT
#error "define AUTOSCAN_FUZZ_FORMAT (ply, obj, off or stl)"
#endif

namespace {

using autoscan::io::FileFormat;
constexpr FileFormat kFormat = FileFormat::AUTOSCAN_FUZZ_FORMAT;
constexpr const char* kName = (kFormat == FileFormat::ply   ? "fuzz.ply"
                               : kFormat == FileFormat::obj ? "fuzz.obj"
                               : kFormat == FileFormat::off ? "fuzz.off"
                                                            : "fuzz.stl");

void check(bool ok) {
  if (!ok) std::abort();  // an accepted file broke the reader's contract
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  autoscan::fuzz::quiet();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes = autoscan::fuzz::bytes_of(data, size);
  autoscan::fuzz::expect_input_error([&] {
    const autoscan::io::GeometryFile g = autoscan::io::parse_geometry(bytes, kFormat, kName);
    const auto& v = g.vertices;
    const auto n = static_cast<long long>(v.size());
    for (const auto& p : v.positions) check(p.allFinite() && p.cwiseAbs().maxCoeff() <= autoscan::kMaxCoordinate);
    for (const auto& q : v.normals) check(q.allFinite() && q.cwiseAbs().maxCoeff() <= autoscan::kMaxCoordinate);
    for (const auto& [name, column] : v.scalars.columns()) {
      check(column.size() == v.positions.size());
      for (double x : column) check(std::isfinite(x));
    }
    check(v.normals.empty() || v.normals.size() == v.positions.size());
    check(v.colors.empty() || v.colors.size() == v.positions.size());
    for (const auto& f : g.faces)
      for (int k = 0; k < 3; ++k) check(f[k] >= 0 && f[k] < n);
    check(g.polygons <= g.faces.size() || kFormat == FileFormat::stl);
  });
  return 0;
}
