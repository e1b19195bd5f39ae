// Geomview OFF reader and writer (text only). Header keyword [ST][C][N][4][n]OFF: vertex lines are
// "x y z [w] [nx ny nz] [r g b [a]] [s t]" (w for 4OFF, which divides; nOFF must be 3-dimensional);
// face lines "n i0 ... i(n-1) [colour]", polygons fan-triangulated. '#' starts a comment. Vertex
// colours given as integers are 0..255, with a decimal point 0..1. Binary OFF is refused.
#include <algorithm>
#include <cmath>

#include "autoscan/io/detail_parse.hpp"

namespace autoscan::io::detail {

namespace {

// The header keyword's flags: [ST][C][N][4][n]OFF.
struct OffFlags {
  bool st = false, col = false, nrm = false, four = false, ndim = false;
  std::size_t ncoord() const { return four ? 4 : 3; }
  std::size_t nfixed() const { return ncoord() + (nrm ? 3 : 0); }
};

OffFlags parse_keyword(TextReader& t, std::string_view kw) {
  std::string_view k = kw;
  auto eat = [&](std::string_view prefix) {
    if (k.substr(0, prefix.size()) != prefix || k.size() == prefix.size()) return false;
    k.remove_prefix(prefix.size());
    return true;
  };
  OffFlags f;
  f.st = eat("ST");
  f.col = eat("C");
  f.nrm = eat("N");
  f.four = eat("4");
  f.ndim = eat("n");
  if (k != "OFF")
    t.fail("not an OFF file: the first word is '{}' (expected OFF, COFF, NOFF, CNOFF, 4OFF...)",
           TextReader::shorten(kw));
  return f;
}

// Vertex i from its tokens v: position (divided by w for 4OFF), normal, colour.
void read_off_vertex(TextReader& t, const OffFlags& fl, std::string_view kw, long long i,
                     const std::vector<std::string_view>& v, PointCloud& pc, std::vector<Rgb>& colors) {
  const std::size_t nfixed = fl.nfixed();
  if (v.size() < nfixed) t.fail("vertex {} has {} values, expected at least {}", i, v.size(), nfixed);
  Vec3 p;
  for (int c = 0; c < 3; ++c) p[c] = t.number(v[c], "vertex coordinate");
  if (fl.four) {
    const double w = t.number(v[3], "homogeneous coordinate w");
    if (w == 0) t.fail("vertex {} has homogeneous coordinate w = 0", i);
    p /= w;
  }
  if (!p.allFinite()) t.fail("vertex {} has a non-finite coordinate (NaN or Inf)", i);
  if (!within_coordinate_range(p))
    t.fail("vertex {} has a coordinate beyond ±{:g}, the largest supported magnitude", i, kMaxCoordinate);
  pc.positions.push_back(p);
  if (fl.nrm) {
    Vec3 n;
    for (int c = 0; c < 3; ++c) n[c] = t.number(v[fl.ncoord() + c], "normal component");
    if (!n.allFinite()) t.fail("vertex {} has a non-finite normal (NaN or Inf)", i);
    if (!within_coordinate_range(n))
      t.fail("vertex {} has a normal component beyond ±{:g}, the largest supported magnitude", i, kMaxCoordinate);
    pc.normals.push_back(n);
  }
  if (fl.col) {
    // A C[N]OFF vertex carries r g b [a] after its coordinates (and normal), then s t for ST.
    const std::size_t before = nfixed + (fl.st ? 2 : 0);
    const std::size_t extra = v.size() > before ? v.size() - before : 0;
    if (extra < 3 || extra > 4)
      t.fail("vertex {} has {} colour values; a {} vertex needs r g b or r g b a", i, extra, kw);
    Rgb c;
    for (int ch = 0; ch < 3; ++ch) {
      const auto s = v[nfixed + ch];
      double x = t.number(s, "colour component");
      if (!std::isfinite(x)) t.fail("vertex {} has a non-finite colour component", i);
      if (s.find('.') != std::string_view::npos || s.find('e') != std::string_view::npos) x *= 255.0;
      c[ch] = to_byte(x);
    }
    colors.push_back(c);
  }
}

void read_off_faces(TextReader& t, long long nf, long long nv, GeometryFile& g) {
  g.faces.reserve(static_cast<std::size_t>(nf));
  std::vector<int> poly;
  for (long long f = 0; f < nf; ++f) {
    if (!t.next_line()) t.fail("truncated: the header says {} faces but the file ends after {}", nf, f);
    const long long n = t.integer(t.token_in_line(), "the vertex count of a face");
    if (n < 3) t.fail("face {} has {} vertices (a face needs at least 3)", f, n);
    if (static_cast<unsigned long long>(n) > t.remaining_bytes()) t.fail("face {} claims {} vertices", f, n);
    poly.clear();
    for (long long c = 0; c < n; ++c) {
      const long long idx = t.integer(t.token_in_line(), "a face vertex index");
      if (idx < 0 || idx >= nv)
        t.fail("face {} references vertex {} but there are {} vertices (index out of range)", f, idx, nv);
      poly.push_back(static_cast<int>(idx));
    }
    fan_triangulate(poly, g.faces);
    ++g.polygons;
  }
}

}  // namespace

GeometryFile read_off(const std::string& path, const std::string& bytes) {
  require_text(path, bytes, "OFF");
  GeometryFile g;
  TextReader t(bytes, path, '#');
  if (!t.next_line()) fail(path, "holds only comments and blank lines; not an OFF file");
  const auto kw = t.token_in_line();
  const OffFlags fl = parse_keyword(t, kw);
  g.format = std::string(kw);
  auto tok = t.token_in_line();
  if (tok == "BINARY") t.fail("binary OFF is not supported (convert it to text OFF or PLY)");
  if (fl.ndim) {
    if (tok.empty()) tok = t.token();
    const long long dim = t.integer(tok, "the dimension of an nOFF file");
    if (dim != 3) t.fail("only 3-dimensional OFF files are supported (this one has dimension {})", dim);
    tok = t.token_in_line();
  }
  if (tok.empty()) tok = t.token();
  const long long nv = t.integer(tok, "the vertex count");
  const long long nf = t.integer(t.token_in_line(), "the face count");
  long long ne = 0;
  if (const auto e = t.token_in_line(); !e.empty()) ne = t.integer(e, "the edge count");
  if (nv < 0 || nf < 0 || ne < 0) t.fail("negative element count ({} vertices, {} faces, {} edges)", nv, nf, ne);
  if (nv > 2147483647LL) t.fail("{} vertices: more than 2^31-1 vertices are not supported", nv);
  // Refuse counts the file cannot hold before allocating: every number takes at least two bytes.
  const long double need = static_cast<long double>(nv) * (2.0L * static_cast<long double>(fl.nfixed())) +
                           static_cast<long double>(nf) * 8.0L;
  if (need > static_cast<long double>(t.remaining_bytes()) + 2)
    t.fail("the header claims {} vertices and {} faces but only {} bytes follow (truncated file or corrupt counts)", nv,
           nf, t.remaining_bytes());
  PointCloud& pc = g.vertices;
  pc.positions.reserve(static_cast<std::size_t>(nv));
  if (fl.nrm) pc.normals.reserve(static_cast<std::size_t>(nv));
  std::vector<Rgb> colors;
  std::vector<std::string_view> v;
  for (long long i = 0; i < nv; ++i) {
    if (!t.next_line()) t.fail("truncated: the header says {} vertices but the file ends after {}", nv, i);
    v.clear();
    for (auto s = t.token_in_line(); !s.empty(); s = t.token_in_line()) v.push_back(s);
    read_off_vertex(t, fl, kw, i, v, pc, colors);
  }
  if (fl.col) pc.colors = std::move(colors);
  read_off_faces(t, nf, nv, g);
  if (ne == 0 && t.next_line()) t.fail("unexpected data after the last face (the counts in the header are wrong?)");
  return g;
}

void write_off(std::ostream& os, const TriangleMesh& m) {
  OutBuffer out(os);
  std::string& s = out.str();
  auto it = std::back_inserter(s);
  const bool colors = !m.vertex_colors.empty(), normals = !m.vertex_normals.empty();
  s += colors ? "C" : "";
  s += normals ? "N" : "";
  s += "OFF\n# written by autoscan\n";
  fmt::format_to(it, "{} {} 0\n", m.vertices.size(), m.faces.size());
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const auto& p = m.vertices[i];
    fmt::format_to(it, "{} {} {}", p.x(), p.y(), p.z());
    if (normals)
      fmt::format_to(it, " {} {} {}", m.vertex_normals[i].x(), m.vertex_normals[i].y(), m.vertex_normals[i].z());
    if (colors)
      fmt::format_to(it, " {} {} {} 255", m.vertex_colors[i][0], m.vertex_colors[i][1], m.vertex_colors[i][2]);
    s += '\n';
    out.maybe_flush();
  }
  for (const auto& f : m.faces) {
    fmt::format_to(it, "3 {} {} {}\n", f[0], f[1], f[2]);
    out.maybe_flush();
  }
  out.flush();
}

}  // namespace autoscan::io::detail
