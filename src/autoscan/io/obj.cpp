// Wavefront OBJ reader and writer. Reader: "v x y z [w] [r g b]", "vn", "f" with v, v/vt, v//vn and
// v/vt/vn corners (negative indices count back from the last vertex), polygons fan-triangulated.
// Per-corner normals become per-vertex normals when every vertex gets one; vertex colours are kept
// when every vertex has them; "vt u v [w]" texture coordinates become per-corner UVs when every face
// corner names one; the first "mtllib" and "usemtl" names are kept (mesh_io.cpp reads the MTL and
// its map_Kd). Other known statements (g, o, s, l, p, curves...) are ignored; an unknown statement is an error (it
// catches binary garbage and non-OBJ files).
#include <algorithm>
#include <array>
#include <cmath>

#include "autoscan/io/detail_parse.hpp"

namespace autoscan::io::detail {
namespace {

bool known_ignored_statement(std::string_view k) {
  static constexpr std::array<std::string_view, 38> known = {
      "vt",     "vp",    "l",          "p",         "g",     "o",     "s",      "usemtl", "mtllib", "maplib",
      "usemap", "lod",   "shadow_obj", "trace_obj", "ctech", "stech", "cstype", "deg",    "bmat",   "step",
      "curv",   "curv2", "surf",       "parm",      "trim",  "hole",  "scrv",   "sp",     "end",    "con",
      "mg",     "bevel", "c_interp",   "d_interp",  "call",  "csh",   "bsp",    "bzp"};
  return std::find(known.begin(), known.end(), k) != known.end();
}

}  // namespace

GeometryFile read_obj(const std::string& path, const std::string& bytes) {
  require_text(path, bytes, "OBJ");
  GeometryFile g;
  g.format = "obj";
  PointCloud& pc = g.vertices;
  std::vector<Rgb> colors;
  std::vector<Vec3> vn;
  std::vector<int> normal_of;  // per vertex, index into vn or -1
  bool all_colored = true;
  std::size_t corners_with_normals = 0;
  long long texcoords = 0;  // "vt" statements so far: a corner's texture index must name one
  std::vector<Eigen::Vector2d> vt_values;
  std::vector<int> poly_t, uv_index;  // per corner of the polygon / of every triangle: index into vt_values or -1
  bool all_corners_textured = true;
  TextReader t(bytes, path, '#');
  std::vector<int> poly, poly_n;
  std::vector<std::string_view> tok;
  while (t.next_line()) {
    const auto kw = t.token_in_line();
    if (kw == "v") {
      tok.clear();
      for (auto s = t.token_in_line(); !s.empty(); s = t.token_in_line()) tok.push_back(s);
      if (tok.size() != 3 && tok.size() != 4 && tok.size() != 6 && tok.size() != 7)
        t.fail("a vertex needs 3 coordinates (optionally w and/or r g b), got {} values", tok.size());
      Vec3 p;
      for (int k = 0; k < 3; ++k) p[k] = t.number(tok[k], "vertex coordinate");
      if (tok.size() == 4 || tok.size() == 7)
        if (!std::isfinite(t.number(tok[3], "vertex weight w")))
          t.fail("vertex {} has a non-finite weight w", pc.positions.size() + 1);
      if (!p.allFinite()) t.fail("vertex {} has a non-finite coordinate (NaN or Inf)", pc.positions.size() + 1);
      if (!within_coordinate_range(p))
        t.fail("vertex {} has a coordinate beyond ±{:g}, the largest supported magnitude", pc.positions.size() + 1,
               kMaxCoordinate);
      pc.positions.push_back(p);
      if (tok.size() >= 6) {
        const std::size_t o = tok.size() - 3;
        Rgb c;
        for (int k = 0; k < 3; ++k) {
          const double x = t.number(tok[o + k], "vertex colour");
          if (!std::isfinite(x)) t.fail("vertex {} has a non-finite colour", pc.positions.size());
          c[k] = to_byte(x * 255.0);
        }
        colors.push_back(c);
      } else {
        all_colored = false;
      }
    } else if (kw == "vn") {
      Vec3 n;
      for (int k = 0; k < 3; ++k) n[k] = t.number(t.token_in_line(), "normal component");
      if (!n.allFinite()) t.fail("normal {} has a non-finite component (NaN or Inf)", vn.size() + 1);
      if (!within_coordinate_range(n))
        t.fail("normal {} has a component beyond ±{:g}, the largest supported magnitude", vn.size() + 1,
               kMaxCoordinate);
      vn.push_back(n);
    } else if (kw == "f" || kw == "fo") {
      poly.clear();
      poly_n.clear();
      poly_t.clear();
      const auto nv = static_cast<long long>(pc.positions.size());
      for (auto s = t.token_in_line(); !s.empty(); s = t.token_in_line()) {
        const auto slash = s.find('/');
        long long i = t.integer(s.substr(0, slash), "face vertex index");
        if (i == 0) t.fail("face vertex index 0 (OBJ indices start at 1)");
        const long long idx = i < 0 ? nv + i : i - 1;
        if (idx < 0 || idx >= nv) t.fail("face vertex index {} is out of range ({} vertices defined so far)", i, nv);
        poly.push_back(static_cast<int>(idx));
        int n_idx = -1, t_idx = -1;
        if (slash != std::string_view::npos) {
          // v/vt, v/vt/vn or v//vn: every part that is present is an index in range.
          const auto rest = s.substr(slash + 1);
          const auto slash2 = rest.find('/');
          const auto vt = rest.substr(0, slash2);
          if (vt.empty() && slash2 == std::string_view::npos)
            t.fail("face corner '{}' has a '/' but no texture index", TextReader::shorten(s));
          if (!vt.empty()) {
            const long long j = t.integer(vt, "face texture index");
            const long long jdx = j < 0 ? texcoords + j : j - 1;
            if (j == 0 || jdx < 0 || jdx >= texcoords)
              t.fail("face texture index {} is out of range ({} texture coordinates defined so far)", j, texcoords);
            t_idx = static_cast<int>(jdx);
          }
          if (slash2 != std::string_view::npos && slash2 + 1 == rest.size())
            t.fail("face corner '{}' has a '/' but no normal index", TextReader::shorten(s));
          if (slash2 != std::string_view::npos && slash2 + 1 < rest.size()) {
            long long j = t.integer(rest.substr(slash2 + 1), "face normal index");
            const auto nn = static_cast<long long>(vn.size());
            const long long jdx = j < 0 ? nn + j : j - 1;
            if (j == 0 || jdx < 0 || jdx >= nn)
              t.fail("face normal index {} is out of range ({} normals defined so far)", j, nn);
            n_idx = static_cast<int>(jdx);
          }
        }
        poly_n.push_back(n_idx);
        poly_t.push_back(t_idx);
        if (t_idx < 0) all_corners_textured = false;
      }
      if (poly.size() < 3) t.fail("a face needs at least 3 vertices, got {}", poly.size());
      fan_triangulate(poly, g.faces);
      if (all_corners_textured)
        for (std::size_t k = 1; k + 1 < poly_t.size(); ++k)
          uv_index.insert(uv_index.end(), {poly_t[0], poly_t[k], poly_t[k + 1]});
      ++g.polygons;
      if (normal_of.size() < pc.positions.size()) normal_of.resize(pc.positions.size(), -1);
      for (std::size_t k = 0; k < poly.size(); ++k)
        if (poly_n[k] >= 0) {
          normal_of[poly[k]] = poly_n[k];
          ++corners_with_normals;
        }
    } else if (kw == "vt") {
      ++texcoords;
      Eigen::Vector2d uv(0.0, 0.0);
      auto first = t.token_in_line();
      if (first.empty()) t.fail("a texture coordinate needs at least u");
      uv.x() = t.number(first, "texture coordinate");
      if (auto second = t.token_in_line(); !second.empty()) uv.y() = t.number(second, "texture coordinate");
      if (!uv.allFinite() || std::abs(uv.x()) > kMaxCoordinate || std::abs(uv.y()) > kMaxCoordinate)
        t.fail("texture coordinate {} is not finite or beyond ±{:g}", texcoords, kMaxCoordinate);
      vt_values.push_back(uv);
    } else if (kw == "mtllib" || kw == "usemtl") {
      const auto name = t.token_in_line();
      std::string& slot = kw == "mtllib" ? g.material_library : g.material;
      if (slot.empty() && !name.empty()) slot = std::string(name);
    } else if (!known_ignored_statement(kw)) {
      t.fail("unknown OBJ statement '{}'", TextReader::shorten(kw));
    }
  }
  if (pc.positions.empty()) fail(path, "the OBJ file defines no vertices");
  if (all_colored && colors.size() == pc.positions.size()) pc.colors = std::move(colors);
  if (all_corners_textured && !g.faces.empty() && uv_index.size() == 3 * g.faces.size()) {
    g.face_uvs.reserve(uv_index.size());
    for (int i : uv_index) g.face_uvs.push_back(vt_values[static_cast<std::size_t>(i)]);
  }
  if (corners_with_normals > 0) {
    normal_of.resize(pc.positions.size(), -1);
    if (std::all_of(normal_of.begin(), normal_of.end(), [](int i) { return i >= 0; })) {
      pc.normals.resize(pc.positions.size());
      for (std::size_t i = 0; i < normal_of.size(); ++i) pc.normals[i] = vn[normal_of[i]];
    }
  }
  return g;
}

void write_obj(std::ostream& os, const TriangleMesh& m, const std::string& material_library) {
  OutBuffer out(os);
  std::string& s = out.str();
  auto it = std::back_inserter(s);
  s += "# written by autoscan\n";
  const bool textured = m.has_texture() && !material_library.empty();
  if (textured) fmt::format_to(it, "mtllib {}\nusemtl {}\n", material_library, kObjMaterialName);
  const bool colors = !m.vertex_colors.empty(), normals = !m.vertex_normals.empty();
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const auto& p = m.vertices[i];
    fmt::format_to(it, "v {} {} {}", p.x(), p.y(), p.z());
    if (colors) {
      const auto& c = m.vertex_colors[i];
      fmt::format_to(it, " {} {} {}", c[0] / 255.0, c[1] / 255.0, c[2] / 255.0);
    }
    s += '\n';
    out.maybe_flush();
  }
  if (normals)
    for (const auto& n : m.vertex_normals) {
      fmt::format_to(it, "vn {} {} {}\n", n.x(), n.y(), n.z());
      out.maybe_flush();
    }
  if (textured)
    for (const auto& uv : m.face_uvs) {
      fmt::format_to(it, "vt {} {}\n", uv.x(), uv.y());
      out.maybe_flush();
    }
  for (std::size_t fi = 0; fi < m.faces.size(); ++fi) {
    const auto& f = m.faces[fi];
    if (textured) {
      const std::size_t t0 = 3 * fi + 1;
      if (normals)
        fmt::format_to(it, "f {}/{}/{} {}/{}/{} {}/{}/{}\n", f[0] + 1, t0, f[0] + 1, f[1] + 1, t0 + 1, f[1] + 1,
                       f[2] + 1, t0 + 2, f[2] + 1);
      else
        fmt::format_to(it, "f {}/{} {}/{} {}/{}\n", f[0] + 1, t0, f[1] + 1, t0 + 1, f[2] + 1, t0 + 2);
    } else if (normals) {
      fmt::format_to(it, "f {0}//{0} {1}//{1} {2}//{2}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    } else {
      fmt::format_to(it, "f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    out.maybe_flush();
  }
  out.flush();
}

}  // namespace autoscan::io::detail
