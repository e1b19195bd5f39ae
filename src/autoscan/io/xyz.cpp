// Plain-text point lists.
//  * .xyz: one point per line, "x y z" or "x y z nx ny nz" (MeshLab's and CloudCompare's layout);
//    every line has the same number of columns. '#' starts a comment.
//  * .pts (Leica): an optional first line with the point count, then "x y z", "x y z intensity",
//    "x y z r g b" or "x y z intensity r g b" per line (colours 0..255); intensity becomes the
//    scalar "intensity".
#include <optional>
#include <ostream>
#include <vector>

#include "autoscan/io/detail_parse.hpp"

namespace autoscan::io::detail {

GeometryFile read_xyz(const std::string& path, const std::string& bytes, bool pts) {
  require_text(path, bytes, pts ? "PTS" : "XYZ");
  GeometryFile g;
  g.format = pts ? "pts" : "xyz";
  PointCloud& pc = g.vertices;
  TextReader t(bytes, path, '#');
  std::vector<double> row;
  std::size_t columns = 0;
  std::optional<std::size_t> declared;
  std::vector<double> intensity;
  // Reads one line's numbers (at most 8: more is an error, so a line never allocates).
  const auto read_row = [&]() {
    row.clear();
    for (auto tok = t.token_in_line(); !tok.empty(); tok = t.token_in_line()) {
      if (row.size() == 7) t.fail("more than 7 values on a line (not an {} file?)", pts ? "PTS" : "XYZ");
      row.push_back(t.number(tok, "a coordinate"));
    }
  };
  bool first = true;
  while (t.next_line()) {
    read_row();
    if (first && pts && row.size() == 1) {  // the point count
      first = false;
      const double c = row[0];
      if (!(c >= 0 && c == std::floor(c))) t.fail("the point count '{}' is not a non-negative integer", c);
      if (c > static_cast<double>(bytes.size() / 6 + 1))
        t.fail("the point count {} is more than the file's {} bytes can hold", c, bytes.size());
      declared = static_cast<std::size_t>(c);
      pc.positions.reserve(*declared);
      continue;
    }
    first = false;
    if (columns == 0) {
      columns = row.size();
      const bool ok =
          pts ? (columns == 3 || columns == 4 || columns == 6 || columns == 7) : (columns == 3 || columns == 6);
      if (!ok)
        t.fail("{} values on a line; expected {}", columns,
               pts ? "x y z, x y z intensity, x y z r g b or x y z intensity r g b" : "x y z or x y z nx ny nz");
    } else if (row.size() != columns) {
      t.fail("{} values on this line but {} on the first point's line", row.size(), columns);
    }
    const std::size_t i = pc.positions.size();
    if (pc.positions.size() >= 2147483647ULL) t.fail("more than 2^31-1 points are not supported");
    for (double v : row)
      if (!std::isfinite(v)) t.fail("point {} has a non-finite value", i);
    const Vec3 p(row[0], row[1], row[2]);
    static_assert(kMaxCoordinate == 1e12, "the message below names the bound");
    if (!within_coordinate_range(p)) t.fail("point {} has a coordinate beyond ±1e12", i);
    pc.positions.push_back(p);
    if (!pts && columns == 6) {
      const Vec3 n(row[3], row[4], row[5]);
      if (!within_coordinate_range(n)) t.fail("point {} has a normal component beyond ±1e12", i);
      pc.normals.push_back(n);
    }
    if (pts) {
      const std::size_t c0 = columns == 6 ? 3 : 4;  // first colour column
      if (columns == 4 || columns == 7) intensity.push_back(row[3]);
      if (columns >= 6) {
        Rgb c{};
        for (int k = 0; k < 3; ++k) {
          const double v = row[c0 + static_cast<std::size_t>(k)];
          if (!(v >= 0 && v <= 255)) t.fail("point {} has a colour value {} outside 0..255", i, v);
          c[static_cast<std::size_t>(k)] = to_byte(v);
        }
        pc.colors.push_back(c);
      }
    }
  }
  if (declared && *declared != pc.positions.size())
    fail(path, "the first line declares {} points but the file has {}", *declared, pc.positions.size());
  if (pc.positions.empty()) fail(path, "has no points");
  if (!intensity.empty()) pc.scalars.set("intensity", std::move(intensity));
  return g;
}

void write_xyz(std::ostream& os, const PointCloud& cloud, bool pts) {
  OutBuffer out(os);
  const std::vector<double>* intensity = pts ? cloud.scalars.find("intensity") : nullptr;
  if (pts) out.str() += fmt::format("{}\n", cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Vec3& p = cloud.positions[i];
    out.str() += fmt::format("{} {} {}", p.x(), p.y(), p.z());
    if (!pts && cloud.has_normals()) {
      const Vec3& n = cloud.normals[i];
      out.str() += fmt::format(" {} {} {}", n.x(), n.y(), n.z());
    }
    if (intensity) out.str() += fmt::format(" {}", (*intensity)[i]);
    if (pts && cloud.has_colors()) {
      const Rgb& c = cloud.colors[i];
      out.str() += fmt::format(" {} {} {}", c[0], c[1], c[2]);
    }
    out.str() += '\n';
    out.maybe_flush();
  }
  out.flush();
}

}  // namespace autoscan::io::detail
