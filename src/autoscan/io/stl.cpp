// STL reader and writer. Binary when the size is exactly 84 + 50·n bytes (n from the header; such a
// file is binary even if its header starts with "solid"), ASCII when it starts with "solid".
// STL stores each triangle's corners separately: the reader welds corners whose coordinates are
// bit-identical (after turning -0 into +0), which restores the shared vertices of any mesh that was
// written as STL, and nothing more (no tolerance).
#include <cmath>
#include <unordered_map>

#include "autoscan/io/detail_parse.hpp"

namespace autoscan::io::detail {
namespace {

struct KeyHash {
  std::size_t operator()(const std::array<std::uint64_t, 3>& k) const {
    std::uint64_t h = 1469598103934665603ULL;
    for (auto v : k) {
      h ^= v + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
      h *= 1099511628211ULL;
    }
    return static_cast<std::size_t>(h);
  }
};

/// Exact welding of corners into shared vertices.
class Welder {
 public:
  Welder(PointCloud& pc, std::size_t expected) : pc_(pc) { map_.reserve(expected); }
  int add(const Vec3& p) {
    std::array<std::uint64_t, 3> key;
    for (int k = 0; k < 3; ++k) {
      const double v = p[k] + 0.0;  // -0 → +0
      std::memcpy(&key[k], &v, sizeof(double));
    }
    const auto [it, inserted] = map_.try_emplace(key, static_cast<int>(pc_.positions.size()));
    if (inserted) pc_.positions.push_back(p);
    return it->second;
  }

 private:
  PointCloud& pc_;
  std::unordered_map<std::array<std::uint64_t, 3>, int, KeyHash> map_;
};

GeometryFile read_binary_stl(const std::string& path, const std::string& bytes, std::uint32_t n) {
  GeometryFile g;
  g.format = "stl binary";
  ByteReader r(std::string_view(bytes).substr(84), path, false);
  r.set_context("a triangle");
  Welder weld(g.vertices, n);
  g.faces.reserve(n);
  for (std::uint32_t f = 0; f < n; ++f) {
    r.skip(12);  // facet normal: recomputed from the vertices when needed
    Tri t;
    for (int c = 0; c < 3; ++c) {
      Vec3 p;
      for (int k = 0; k < 3; ++k) p[k] = r.read<float>();
      if (!p.allFinite()) fail(path, "triangle {} has a non-finite coordinate (NaN or Inf)", f);
      if (!within_coordinate_range(p))
        fail(path, "triangle {} has a coordinate beyond ±{:g}, the largest supported magnitude", f, kMaxCoordinate);
      t[c] = weld.add(p);
    }
    r.skip(2);  // attribute byte count
    g.faces.push_back(t);
  }
  g.polygons = n;
  g.stl_corners = 3 * static_cast<std::size_t>(n);
  return g;
}

GeometryFile read_ascii_stl(const std::string& path, const std::string& bytes) {
  require_text(path, bytes, "ASCII STL");
  GeometryFile g;
  g.format = "stl ascii";
  TextReader t(bytes, path);
  Welder weld(g.vertices, bytes.size() / 100);
  auto expect = [&](std::string_view word) {
    const auto tok = t.token();
    if (tok.empty()) t.fail("truncated: the file ends where '{}' was expected", word);
    if (tok != word) t.fail("expected '{}', found '{}'", word, TextReader::shorten(tok));
  };
  std::size_t solids = 0;
  std::vector<int> poly;
  for (auto tok = t.token(); !tok.empty(); tok = t.token()) {
    if (tok != "solid") t.fail("expected 'solid', found '{}'", TextReader::shorten(tok));
    ++solids;
    t.skip_rest_of_line();  // the solid's name
    for (;;) {
      tok = t.token();
      if (tok.empty()) t.fail("truncated: the file ends inside a solid (no 'endsolid')");
      if (tok == "endsolid") {
        t.skip_rest_of_line();
        break;
      }
      if (tok != "facet") t.fail("expected 'facet' or 'endsolid', found '{}'", TextReader::shorten(tok));
      expect("normal");
      // The facet normal is recomputed from the vertices, never used: exporters write NaN for a
      // degenerate facet, which is no reason to refuse the file.
      for (int k = 0; k < 3; ++k) (void)t.number(t.token(), "facet normal component");
      expect("outer");
      expect("loop");
      poly.clear();
      for (;;) {
        tok = t.token();
        if (tok.empty()) t.fail("truncated: the file ends inside a facet");
        if (tok == "endloop") break;
        if (tok != "vertex") t.fail("expected 'vertex' or 'endloop', found '{}'", TextReader::shorten(tok));
        Vec3 p;
        for (int k = 0; k < 3; ++k) p[k] = t.number(t.token(), "vertex coordinate");
        if (!p.allFinite()) t.fail("vertex has a non-finite coordinate (NaN or Inf)");
        if (!within_coordinate_range(p))
          t.fail("vertex has a coordinate beyond ±{:g}, the largest supported magnitude", kMaxCoordinate);
        poly.push_back(weld.add(p));
        g.stl_corners++;
      }
      if (poly.size() < 3) t.fail("a facet needs at least 3 vertices, got {}", poly.size());
      expect("endfacet");
      fan_triangulate(poly, g.faces);
      ++g.polygons;
    }
  }
  if (solids == 0) fail(path, "the ASCII STL file holds no solid");
  return g;
}

}  // namespace

GeometryFile read_stl(const std::string& path, const std::string& bytes) {
  if (bytes.size() >= 84) {
    std::uint32_t n;
    std::memcpy(&n, bytes.data() + 80, 4);
    if constexpr (std::endian::native == std::endian::big) n = __builtin_bswap32(n);
    if (84 + 50 * static_cast<std::uint64_t>(n) == bytes.size()) return read_binary_stl(path, bytes, n);
  }
  std::size_t i = 0;
  while (i < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[i]))) ++i;
  if (bytes.compare(i, 5, "solid") == 0) return read_ascii_stl(path, bytes);
  if (bytes.size() < 84)
    fail(path, "not an STL file: too small for binary STL ({} bytes) and does not start with 'solid'", bytes.size());
  std::uint32_t n;
  std::memcpy(&n, bytes.data() + 80, 4);
  if constexpr (std::endian::native == std::endian::big) n = __builtin_bswap32(n);
  fail(path,
       "not a valid STL file: the binary header says {} triangles ({} bytes) but the file has {} bytes, and it does "
       "not start with 'solid'",
       n, 84 + 50 * static_cast<std::uint64_t>(n), bytes.size());
}

void write_stl(std::ostream& os, const TriangleMesh& m, bool ascii) {
  OutBuffer out(os);
  std::string& s = out.str();
  const auto normals = m.face_normals();
  if (ascii) {
    auto it = std::back_inserter(s);
    s += "solid autoscan\n";
    for (std::size_t f = 0; f < m.faces.size(); ++f) {
      const auto& n = normals[f];
      fmt::format_to(it, "  facet normal {} {} {}\n    outer loop\n", n.x(), n.y(), n.z());
      for (int k = 0; k < 3; ++k) {
        const auto& p = m.vertices[m.faces[f][k]];
        fmt::format_to(it, "      vertex {} {} {}\n", p.x(), p.y(), p.z());
      }
      s += "    endloop\n  endfacet\n";
      out.maybe_flush();
    }
    s += "endsolid autoscan\n";
  } else {
    AUTOSCAN_REQUIRE(m.faces.size() <= 0xffffffffULL, "binary STL holds at most 2^32-1 triangles ({} given)",
                     m.faces.size());
    std::string header = "binary STL written by autoscan";
    header.resize(80, ' ');
    s += header;
    out.put<std::uint32_t>(static_cast<std::uint32_t>(m.faces.size()), false);
    for (std::size_t f = 0; f < m.faces.size(); ++f) {
      for (int k = 0; k < 3; ++k) out.put<float>(static_cast<float>(normals[f][k]), false);
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k) out.put<float>(static_cast<float>(m.vertices[m.faces[f][c]][k]), false);
      out.put<std::uint16_t>(0, false);
      out.maybe_flush();
    }
  }
  out.flush();
}

}  // namespace autoscan::io::detail
