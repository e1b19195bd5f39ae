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

// The reader's state over the statements of one OBJ file.
class ObjParser {
 public:
  ObjParser(const std::string& path, const std::string& bytes) : t_(bytes, path, '#') { g_.format = "obj"; }

  GeometryFile run(const std::string& path) {
    while (t_.next_line()) {
      const auto kw = t_.token_in_line();
      if (kw == "v") {
        vertex();
      } else if (kw == "vn") {
        normal();
      } else if (kw == "f" || kw == "fo") {
        face();
      } else if (kw == "vt") {
        texcoord();
      } else if (kw == "mtllib" || kw == "usemtl") {
        const auto name = t_.token_in_line();
        std::string& slot = kw == "mtllib" ? g_.material_library : g_.material;
        if (slot.empty() && !name.empty()) slot = std::string(name);
      } else if (!known_ignored_statement(kw)) {
        t_.fail("unknown OBJ statement '{}'", TextReader::shorten(kw));
      }
    }
    return finish(path);
  }

 private:
  // "v x y z [w] [r g b]"
  void vertex() {
    PointCloud& pc = g_.vertices;
    tok_.clear();
    for (auto s = t_.token_in_line(); !s.empty(); s = t_.token_in_line()) tok_.push_back(s);
    if (tok_.size() != 3 && tok_.size() != 4 && tok_.size() != 6 && tok_.size() != 7)
      t_.fail("a vertex needs 3 coordinates (optionally w and/or r g b), got {} values", tok_.size());
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = t_.number(tok_[k], "vertex coordinate");
    if (tok_.size() == 4 || tok_.size() == 7)
      if (!std::isfinite(t_.number(tok_[3], "vertex weight w")))
        t_.fail("vertex {} has a non-finite weight w", pc.positions.size() + 1);
    if (!p.allFinite()) t_.fail("vertex {} has a non-finite coordinate (NaN or Inf)", pc.positions.size() + 1);
    if (!within_coordinate_range(p))
      t_.fail("vertex {} has a coordinate beyond ±{:g}, the largest supported magnitude", pc.positions.size() + 1,
              kMaxCoordinate);
    pc.positions.push_back(p);
    if (tok_.size() >= 6) {
      const std::size_t o = tok_.size() - 3;
      Rgb c;
      for (int k = 0; k < 3; ++k) {
        const double x = t_.number(tok_[o + k], "vertex colour");
        if (!std::isfinite(x)) t_.fail("vertex {} has a non-finite colour", pc.positions.size());
        c[k] = to_byte(x * 255.0);
      }
      colors_.push_back(c);
    } else {
      all_colored_ = false;
    }
  }

  // "vn x y z"
  void normal() {
    Vec3 n;
    for (int k = 0; k < 3; ++k) n[k] = t_.number(t_.token_in_line(), "normal component");
    if (!n.allFinite()) t_.fail("normal {} has a non-finite component (NaN or Inf)", vn_.size() + 1);
    if (!within_coordinate_range(n))
      t_.fail("normal {} has a component beyond ±{:g}, the largest supported magnitude", vn_.size() + 1,
              kMaxCoordinate);
    vn_.push_back(n);
  }

  // "vt u [v [w]]"
  void texcoord() {
    ++texcoords_;
    Eigen::Vector2d uv(0.0, 0.0);
    auto first = t_.token_in_line();
    if (first.empty()) t_.fail("a texture coordinate needs at least u");
    uv.x() = t_.number(first, "texture coordinate");
    if (auto second = t_.token_in_line(); !second.empty()) uv.y() = t_.number(second, "texture coordinate");
    if (!uv.allFinite() || std::abs(uv.x()) > kMaxCoordinate || std::abs(uv.y()) > kMaxCoordinate)
      t_.fail("texture coordinate {} is not finite or beyond ±{:g}", texcoords_, kMaxCoordinate);
    vt_values_.push_back(uv);
  }

  // The texture and normal indices after the first '/' of corner `s` (v/vt, v/vt/vn or v//vn): every
  // part that is present is an index in range; -1 for an absent one.
  void corner_indices(std::string_view s, std::size_t slash, int& t_idx, int& n_idx) {
    const auto rest = s.substr(slash + 1);
    const auto slash2 = rest.find('/');
    const auto vt = rest.substr(0, slash2);
    if (vt.empty() && slash2 == std::string_view::npos)
      t_.fail("face corner '{}' has a '/' but no texture index", TextReader::shorten(s));
    if (!vt.empty()) {
      const long long j = t_.integer(vt, "face texture index");
      const long long jdx = j < 0 ? texcoords_ + j : j - 1;
      if (j == 0 || jdx < 0 || jdx >= texcoords_)
        t_.fail("face texture index {} is out of range ({} texture coordinates defined so far)", j, texcoords_);
      t_idx = static_cast<int>(jdx);
    }
    if (slash2 != std::string_view::npos && slash2 + 1 == rest.size())
      t_.fail("face corner '{}' has a '/' but no normal index", TextReader::shorten(s));
    if (slash2 != std::string_view::npos && slash2 + 1 < rest.size()) {
      long long j = t_.integer(rest.substr(slash2 + 1), "face normal index");
      const auto nn = static_cast<long long>(vn_.size());
      const long long jdx = j < 0 ? nn + j : j - 1;
      if (j == 0 || jdx < 0 || jdx >= nn)
        t_.fail("face normal index {} is out of range ({} normals defined so far)", j, nn);
      n_idx = static_cast<int>(jdx);
    }
  }

  // "f c1 c2 c3 ..." (and "fo"): a polygon, fan-triangulated.
  void face() {
    const PointCloud& pc = g_.vertices;
    poly_.clear();
    poly_n_.clear();
    poly_t_.clear();
    const auto nv = static_cast<long long>(pc.positions.size());
    for (auto s = t_.token_in_line(); !s.empty(); s = t_.token_in_line()) {
      const auto slash = s.find('/');
      long long i = t_.integer(s.substr(0, slash), "face vertex index");
      if (i == 0) t_.fail("face vertex index 0 (OBJ indices start at 1)");
      const long long idx = i < 0 ? nv + i : i - 1;
      if (idx < 0 || idx >= nv) t_.fail("face vertex index {} is out of range ({} vertices defined so far)", i, nv);
      poly_.push_back(static_cast<int>(idx));
      int n_idx = -1, t_idx = -1;
      if (slash != std::string_view::npos) corner_indices(s, slash, t_idx, n_idx);
      poly_n_.push_back(n_idx);
      poly_t_.push_back(t_idx);
      if (t_idx < 0) all_corners_textured_ = false;
    }
    if (poly_.size() < 3) t_.fail("a face needs at least 3 vertices, got {}", poly_.size());
    fan_triangulate(poly_, g_.faces);
    if (all_corners_textured_)
      for (std::size_t k = 1; k + 1 < poly_t_.size(); ++k)
        uv_index_.insert(uv_index_.end(), {poly_t_[0], poly_t_[k], poly_t_[k + 1]});
    ++g_.polygons;
    if (normal_of_.size() < pc.positions.size()) normal_of_.resize(pc.positions.size(), -1);
    for (std::size_t k = 0; k < poly_.size(); ++k)
      if (poly_n_[k] >= 0) {
        normal_of_[poly_[k]] = poly_n_[k];
        ++corners_with_normals_;
      }
  }

  // Colours, UVs and normals kept when complete.
  GeometryFile finish(const std::string& path) {
    PointCloud& pc = g_.vertices;
    if (pc.positions.empty()) fail(path, "the OBJ file defines no vertices");
    if (all_colored_ && colors_.size() == pc.positions.size()) pc.colors = std::move(colors_);
    if (all_corners_textured_ && !g_.faces.empty() && uv_index_.size() == 3 * g_.faces.size()) {
      g_.face_uvs.reserve(uv_index_.size());
      for (int i : uv_index_) g_.face_uvs.push_back(vt_values_[static_cast<std::size_t>(i)]);
    }
    if (corners_with_normals_ > 0) {
      normal_of_.resize(pc.positions.size(), -1);
      if (std::all_of(normal_of_.begin(), normal_of_.end(), [](int i) { return i >= 0; })) {
        pc.normals.resize(pc.positions.size());
        for (std::size_t i = 0; i < normal_of_.size(); ++i) pc.normals[i] = vn_[normal_of_[i]];
      }
    }
    return std::move(g_);
  }

  TextReader t_;
  GeometryFile g_;
  std::vector<Rgb> colors_;
  std::vector<Vec3> vn_;
  std::vector<int> normal_of_;  // per vertex, index into vn_ or -1
  bool all_colored_ = true;
  std::size_t corners_with_normals_ = 0;
  long long texcoords_ = 0;  // "vt" statements so far: a corner's texture index must name one
  std::vector<Eigen::Vector2d> vt_values_;
  std::vector<int> poly_t_, uv_index_;  // per corner of the polygon / of every triangle: index into vt_values_ or -1
  bool all_corners_textured_ = true;
  std::vector<int> poly_, poly_n_;
  std::vector<std::string_view> tok_;
};

}  // namespace

GeometryFile read_obj(const std::string& path, const std::string& bytes) {
  require_text(path, bytes, "OBJ");
  return ObjParser(path, bytes).run(path);
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
