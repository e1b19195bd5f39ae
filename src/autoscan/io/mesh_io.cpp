#include "autoscan/io/mesh_io.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <new>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/io/detail_parse.hpp"
#include "autoscan/io/image.hpp"

namespace autoscan::io {
namespace fs = std::filesystem;

namespace detail {

std::string load_file(const fs::path& path) {
  const std::string p = path.string();
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (!fs::exists(st)) fail(p, "no such file");
  if (fs::is_directory(st)) fail(p, "is a directory, not a file");
  if (!fs::is_regular_file(st)) fail(p, "is not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(p, "cannot be opened for reading (permission denied?)");
  in.seekg(0, std::ios::end);
  const auto size = in.tellg();
  if (size < 0) fail(p, "cannot be read");
  if (size == 0) fail(p, "is empty");
  in.seekg(0, std::ios::beg);
  std::string bytes(static_cast<std::size_t>(size), '\0');
  in.read(bytes.data(), size);
  if (in.gcount() != size) fail(p, "could not be read completely");
  return bytes;
}

void require_text(const std::string& path, std::string_view bytes, std::string_view format) {
  const auto nul = bytes.find('\0');
  if (nul != std::string_view::npos)
    fail(path, "contains binary data (a NUL byte at offset {}); not a text {} file", nul, format);
}

}  // namespace detail

FileFormat format_from_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".ply") return FileFormat::ply;
  if (ext == ".obj") return FileFormat::obj;
  if (ext == ".off") return FileFormat::off;
  if (ext == ".stl") return FileFormat::stl;
  if (ext == ".pcd") return FileFormat::pcd;
  if (ext == ".xyz") return FileFormat::xyz;
  if (ext == ".pts") return FileFormat::pts;
  detail::fail(path.string(), "unknown file format '{}' (expected .ply, .obj, .off, .stl, .pcd, .xyz or .pts)",
               ext.empty() ? std::string("no extension") : ext);
}

namespace {

GeometryFile read_geometry_unchecked(const std::string& p, FileFormat kind, const std::string& bytes) {
  GeometryFile g;
  switch (kind) {
    case FileFormat::ply:
      g = detail::read_ply(p, bytes);
      break;
    case FileFormat::obj:
      g = detail::read_obj(p, bytes);
      break;
    case FileFormat::off:
      g = detail::read_off(p, bytes);
      break;
    case FileFormat::stl:
      g = detail::read_stl(p, bytes);
      break;
    case FileFormat::pcd:
      g = detail::read_pcd(p, bytes);
      break;
    case FileFormat::xyz:
    case FileFormat::pts:
      g = detail::read_xyz(p, bytes, kind == FileFormat::pts);
      break;
  }
  return g;
}

}  // namespace

GeometryFile parse_geometry(const std::string& bytes, FileFormat format, const std::string& name) {
  if (bytes.empty()) detail::fail(name, "is empty");
  GeometryFile g;
  try {
    // Counts are checked against the file's size before anything is allocated, but a large valid
    // file still takes about twice its size or more in memory (double coordinates).
    g = read_geometry_unchecked(name, format, bytes);
  } catch (const std::bad_alloc&) {
    throw InputError(fmt::format("{}: too large to read: out of memory ({:.1f} MB file)", name,
                                 static_cast<double>(bytes.size()) / 1e6));
  }
  // Readers check as they go; this is the final guarantee of the contract.
  g.vertices.validate(name);
  const auto n = static_cast<long long>(g.vertices.size());
  for (std::size_t f = 0; f < g.faces.size(); ++f)
    for (int k = 0; k < 3; ++k)
      AUTOSCAN_REQUIRE(g.faces[f][k] >= 0 && g.faces[f][k] < n, "{}: face {} references vertex {} ({} vertices)", name,
                       f, g.faces[f][k], n);
  return g;
}

GeometryFile read_geometry(const fs::path& path) {
  const std::string p = path.string();
  const FileFormat kind = format_from_extension(path);
  std::string bytes;
  try {
    bytes = detail::load_file(path);
  } catch (const std::bad_alloc&) {
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    throw InputError(fmt::format("{}: too large to read: out of memory ({:.1f} MB file)", p,
                                 ec ? 0.0 : static_cast<double>(size) / 1e6));
  }
  return parse_geometry(bytes, kind, p);
}

namespace {

/// The map_Kd of `material` (or of the first material when it is empty or not defined) in the MTL
/// file at `mtl`; empty when that material has none.
std::string mtl_diffuse_map(const fs::path& mtl, const std::string& material) {
  const std::string p = mtl.string();
  const std::string bytes = detail::load_file(mtl);
  detail::require_text(p, bytes, "MTL");
  std::string current, first_map, wanted_map;
  bool wanted_defined = false;
  std::size_t pos = 0;
  while (pos < bytes.size()) {
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    std::string line = bytes.substr(pos, end - pos);
    pos = end + 1;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    std::size_t b = 0;
    while (b < line.size() && std::isspace(static_cast<unsigned char>(line[b]))) ++b;
    line.erase(0, b);
    const std::size_t sp = line.find_first_of(" \t");
    const std::string key = line.substr(0, sp);
    std::string value = sp == std::string::npos ? std::string() : line.substr(sp + 1);
    value.erase(0, value.find_first_not_of(" \t") == std::string::npos ? value.size() : value.find_first_not_of(" \t"));
    if (key == "newmtl") {
      current = value;
      if (current == material) wanted_defined = true;
    } else if (key == "map_Kd" && !value.empty()) {
      // Options (-s, -o, ...) precede the file name: the name is the last token.
      const std::size_t last = value.find_last_of(" \t");
      const std::string file = last == std::string::npos ? value : value.substr(last + 1);
      if (first_map.empty()) first_map = file;
      if (!material.empty() && current == material && wanted_map.empty()) wanted_map = file;
    }
  }
  return wanted_defined ? wanted_map : first_map;
}

}  // namespace

TriangleMesh mesh_from_geometry(GeometryFile&& g) {
  TriangleMesh m;
  m.vertices = std::move(g.vertices.positions);
  m.vertex_normals = std::move(g.vertices.normals);
  m.vertex_colors = std::move(g.vertices.colors);
  m.vertex_scalars = std::move(g.vertices.scalars);
  m.faces = std::move(g.faces);
  return m;
}

TriangleMesh read_mesh(const fs::path& path) {
  GeometryFile g = read_geometry(path);
  AUTOSCAN_REQUIRE(!g.faces.empty(), "{}: has no faces ({} vertices): not a mesh (read it as a point cloud)",
                   path.string(), g.vertices.size());
  TriangleMesh m = mesh_from_geometry(std::move(g));  // takes the vertices and faces; the UVs stay
  if (!g.face_uvs.empty() && !g.material_library.empty()) {
    const fs::path mtl = path.parent_path() / g.material_library;
    const std::string map = mtl_diffuse_map(mtl, g.material);
    if (!map.empty()) {
      const fs::path png = mtl.parent_path() / map;
      std::string ext = png.extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      AUTOSCAN_REQUIRE(ext == ".png", "{}: map_Kd '{}' is not a PNG (only PNG textures are read)", mtl.string(), map);
      m.texture = read_png(png);
      m.face_uvs = std::move(g.face_uvs);
    }
  }
  return m;
}

PointCloud read_point_cloud(const fs::path& path) { return std::move(read_geometry(path).vertices); }

namespace {

void check_scalar_names(const std::string& p, const ScalarAttributes& s, bool pcd = false) {
  static const char* reserved[] = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue"};
  static const char* reserved_pcd[] = {"x", "y", "z", "normal_x", "normal_y", "normal_z", "rgb", "rgba", "_"};
  const char* format = pcd ? "PCD" : "PLY";
  for (const auto& [name, col] : s.columns()) {
    AUTOSCAN_REQUIRE(!name.empty(), "{}: a scalar attribute has an empty name", p);
    for (char c : name)
      AUTOSCAN_REQUIRE(std::isgraph(static_cast<unsigned char>(c)),
                       "{}: scalar attribute '{}' has a name {} cannot hold (whitespace or control characters)", p,
                       name, format);
    for (const char* r : pcd ? reserved_pcd : reserved)
      AUTOSCAN_REQUIRE(name != r, "{}: scalar attribute '{}' clashes with a standard {} field", p, name, format);
  }
}

}  // namespace

void write_mesh(const fs::path& path, const TriangleMesh& mesh, const WriteOptions& options) {
  const std::string p = path.string();
  const FileFormat fmt = format_from_extension(path);
  mesh.validate(p);
  for (std::size_t i = 0; i < mesh.vertex_normals.size(); ++i)
    AUTOSCAN_REQUIRE(mesh.vertex_normals[i].allFinite(), "{}: vertex normal {} is not finite", p, i);
  switch (fmt) {
    case FileFormat::ply: {
      check_scalar_names(p, mesh.vertex_scalars);
      write_file_atomic(path, [&](std::ostream& os) {
        detail::write_ply(os, {mesh.vertices, mesh.vertex_normals, mesh.vertex_colors, mesh.vertex_scalars}, mesh.faces,
                          options);
      });
      break;
    }
    case FileFormat::obj:
      if (mesh.has_texture()) {
        // The texture and the MTL first, the OBJ that names them last.
        const std::string stem = path.stem().string();
        write_png(path.parent_path() / (stem + ".png"), mesh.texture);
        write_text_atomic(path.parent_path() / (stem + ".mtl"),
                          fmt::format("# written by autoscan\nnewmtl {}\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nmap_Kd {}.png\n",
                                      detail::kObjMaterialName, stem));
        write_file_atomic(path, [&](std::ostream& os) { detail::write_obj(os, mesh, stem + ".mtl"); });
      } else {
        write_file_atomic(path, [&](std::ostream& os) { detail::write_obj(os, mesh); });
      }
      break;
    case FileFormat::off:
      write_file_atomic(path, [&](std::ostream& os) { detail::write_off(os, mesh); });
      break;
    case FileFormat::stl:
      write_file_atomic(path, [&](std::ostream& os) { detail::write_stl(os, mesh, options.ascii); });
      break;
    case FileFormat::pcd:
    case FileFormat::xyz:
    case FileFormat::pts:
      throw InputError(fmt::format("{}: {} is a point cloud format; write a mesh as .ply, .obj, .off or .stl", p,
                                   path.extension().string()));
  }
}

void write_point_cloud(const fs::path& path, const PointCloud& cloud, const WriteOptions& options) {
  const std::string p = path.string();
  const FileFormat f = format_from_extension(path);
  AUTOSCAN_REQUIRE(f == FileFormat::ply || f == FileFormat::pcd || f == FileFormat::xyz || f == FileFormat::pts,
                   "{}: point clouds are written as .ply, .pcd, .xyz or .pts", p);
  cloud.validate(p);
  if (f == FileFormat::ply || f == FileFormat::pcd) check_scalar_names(p, cloud.scalars, f == FileFormat::pcd);
  write_file_atomic(path, [&](std::ostream& os) {
    if (f == FileFormat::pcd)
      detail::write_pcd(os, cloud, options);
    else if (f == FileFormat::ply)
      detail::write_ply(os, {cloud.positions, cloud.normals, cloud.colors, cloud.scalars}, {}, options);
    else
      detail::write_xyz(os, cloud, f == FileFormat::pts);
  });
}

}  // namespace autoscan::io
