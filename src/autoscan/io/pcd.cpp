// PCD, the Point Cloud Library's format (v0.5-0.7), DATA ascii and binary (binary_compressed is
// refused by name). Header: VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS,
// DATA; binary data is little endian, one point after another.
// Fields: x y z (required), normal_x normal_y normal_z, rgb / rgba (packed 0x00RRGGBB, TYPE F or U),
// '_' (padding, skipped); any other field is a named scalar (a COUNT > 1 field gives name_0,
// name_1, ...). PCL marks a missing measurement by x = y = z = NaN (organised clouds); such points
// are dropped. Any other non-finite value is an InputError.
#include <array>
#include <limits>
#include <optional>
#include <ostream>
#include <vector>

#include "autoscan/io/detail_parse.hpp"

namespace autoscan::io::detail {
namespace {

constexpr std::size_t kMaxPcdFields = 4096;
constexpr std::size_t kMaxHeaderLines = 1024;  ///< comment lines included

struct PcdField {
  std::string name;
  int size = 4;
  char type = 'F';
  int count = 1;
  std::size_t offset = 0;  ///< byte offset in a binary point
};

enum class Role { skip, x, y, z, nx, ny, nz, rgb, scalar };

struct PcdHeader {
  std::vector<PcdField> fields;
  std::size_t points = 0;
  std::string data;  ///< ascii or binary
  std::size_t body = 0;
  std::size_t body_line = 1;
  std::size_t point_size = 0;
};

bool valid_size_type(int size, char type) {
  if (type == 'F') return size == 4 || size == 8;
  if (type == 'I' || type == 'U') return size == 1 || size == 2 || size == 4 || size == 8;
  return false;
}

// The header's keywords as they are read, then checked against each other (finish).
class HeaderReader {
 public:
  explicit HeaderReader(const std::string& path) : path_(path) {}

  // One keyword line (`line_no`) with its arguments; DATA ends the header.
  void keyword(std::string_view kw, const std::vector<std::string_view>& args, TextReader& t, std::size_t line_no);
  bool done() const { return !h_.data.empty(); }
  PcdHeader finish(std::size_t body, std::size_t body_line);

 private:
  std::size_t count_arg(const std::vector<std::string_view>& args, TextReader& t, std::size_t line_no,
                        std::string_view what) const {
    if (args.size() != 1) fail(path_, "line {}: {} expects one number", line_no, what);
    const long long v = t.integer(args[0], what);
    if (v < 0) fail(path_, "line {}: {} is negative ({})", line_no, what, v);
    return static_cast<std::size_t>(v);
  }

  const std::string& path_;
  PcdHeader h_;
  std::optional<std::size_t> width_, height_, points_;
  std::vector<int> sizes_, counts_;
  std::vector<char> types_;
  bool have_fields_ = false;
};

void HeaderReader::keyword(std::string_view kw, const std::vector<std::string_view>& args, TextReader& t,
                           std::size_t line_no) {
  const std::string& path = path_;
  if (kw == "VERSION") {
    // 0.5 .. 0.7 and ".7"-style spellings all share this layout.
  } else if (kw == "FIELDS" || kw == "COLUMNS") {
    if (args.empty()) fail(path, "line {}: FIELDS lists no field", line_no);
    have_fields_ = true;
    for (auto a : args) {
      for (const auto& f : h_.fields)
        if (f.name == a && a != "_") fail(path, "line {}: field '{}' is listed twice", line_no, TextReader::shorten(a));
      h_.fields.push_back({std::string(a)});
    }
  } else if (kw == "SIZE") {
    for (auto a : args) sizes_.push_back(static_cast<int>(t.integer(a, "SIZE")));
  } else if (kw == "TYPE") {
    for (auto a : args) {
      if (a.size() != 1) fail(path, "line {}: unknown TYPE '{}' (expected F, I or U)", line_no, TextReader::shorten(a));
      types_.push_back(a[0]);
    }
  } else if (kw == "COUNT") {
    for (auto a : args) {
      const long long c = t.integer(a, "COUNT");
      if (c < 1 || c > 4096) fail(path, "line {}: COUNT {} out of range [1, 4096]", line_no, c);
      counts_.push_back(static_cast<int>(c));
    }
  } else if (kw == "WIDTH") {
    width_ = count_arg(args, t, line_no, "WIDTH");
  } else if (kw == "HEIGHT") {
    height_ = count_arg(args, t, line_no, "HEIGHT");
  } else if (kw == "POINTS") {
    points_ = count_arg(args, t, line_no, "POINTS");
  } else if (kw == "VIEWPOINT") {
    if (args.size() != 7) fail(path, "line {}: VIEWPOINT expects 7 numbers", line_no);
    for (auto a : args) t.number(a, "VIEWPOINT");
  } else if (kw == "DATA") {
    if (args.size() != 1) fail(path, "line {}: DATA expects ascii or binary", line_no);
    if (args[0] == "binary_compressed")
      fail(path, "line {}: DATA binary_compressed is not supported (save it as binary or ascii in PCL)", line_no);
    if (args[0] != "ascii" && args[0] != "binary")
      fail(path, "line {}: unknown DATA '{}' (expected ascii or binary)", line_no, TextReader::shorten(args[0]));
    h_.data = std::string(args[0]);
  } else {
    if (line_no == 1) fail(path, "not a PCD file (unknown first keyword '{}')", TextReader::shorten(kw));
    fail(path, "line {}: unknown PCD header keyword '{}'", line_no, TextReader::shorten(kw));
  }
}

PcdHeader HeaderReader::finish(std::size_t body, std::size_t body_line) {
  const std::string& path = path_;
  PcdHeader h = std::move(h_);
  h.body = body;
  h.body_line = body_line;
  if (!have_fields_) fail(path, "the PCD header has no FIELDS line");
  const std::size_t nf = h.fields.size();
  if (sizes_.size() != nf) fail(path, "SIZE has {} entries but FIELDS has {}", sizes_.size(), nf);
  if (types_.size() != nf) fail(path, "TYPE has {} entries but FIELDS has {}", types_.size(), nf);
  if (!counts_.empty() && counts_.size() != nf)
    fail(path, "COUNT has {} entries but FIELDS has {}", counts_.size(), nf);
  for (std::size_t i = 0; i < nf; ++i) {
    auto& f = h.fields[i];
    f.size = sizes_[i];
    f.type = types_[i];
    f.count = counts_.empty() ? 1 : counts_[i];
    if (!valid_size_type(f.size, f.type))
      fail(path, "field '{}': SIZE {} is not valid for TYPE {}", TextReader::shorten(f.name), f.size, f.type);
    f.offset = h.point_size;
    h.point_size += static_cast<std::size_t>(f.size) * static_cast<std::size_t>(f.count);
  }
  if (!width_) fail(path, "the PCD header has no WIDTH line");
  const std::size_t hgt = height_.value_or(1);
  if (hgt != 0 && *width_ > std::numeric_limits<std::size_t>::max() / hgt)
    fail(path, "WIDTH {} x HEIGHT {} overflows", *width_, hgt);
  h.points = points_.value_or(*width_ * hgt);
  if (h.points != *width_ * hgt) fail(path, "POINTS {} differs from WIDTH {} x HEIGHT {}", h.points, *width_, hgt);
  return h;
}

PcdHeader read_header(const std::string& path, const std::string& bytes) {
  HeaderReader reader(path);
  std::size_t pos = 0, line_no = 0;
  while (!reader.done()) {
    if (pos >= bytes.size()) fail(path, "the PCD header has no DATA line (truncated or not a PCD file)");
    if (++line_no > kMaxHeaderLines) fail(path, "the PCD header is too long (corrupt or not a PCD file)");
    std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) end = bytes.size();
    const std::string_view line(bytes.data() + pos, end - pos);
    pos = std::min(end + 1, bytes.size());
    if (line.find('\0') != std::string_view::npos)
      fail(path, "line {}: the PCD header contains binary data (not a PCD file?)", line_no);
    TextReader t(line, path, '#', line_no);
    const std::string_view kw = t.token_in_line();
    if (kw.empty()) continue;  // blank or comment line
    std::vector<std::string_view> args;
    for (auto tok = t.token_in_line(); !tok.empty(); tok = t.token_in_line()) {
      if (args.size() >= kMaxPcdFields)
        fail(path, "line {}: more than {} entries (corrupt header?)", line_no, kMaxPcdFields);
      args.push_back(tok);
    }
    reader.keyword(kw, args, t, line_no);
  }
  return reader.finish(pos, line_no + 1);
}

/// The value of one element of a field, as a double.
double decode(const char* p, const PcdField& f) {
  switch (f.type) {
    case 'F':
      if (f.size == 4) {
        float v;
        std::memcpy(&v, p, 4);
        return v;
      } else {
        double v;
        std::memcpy(&v, p, 8);
        return v;
      }
    case 'I':
      switch (f.size) {
        case 1:
          return static_cast<std::int8_t>(*p);
        case 2: {
          std::int16_t v;
          std::memcpy(&v, p, 2);
          return v;
        }
        case 4: {
          std::int32_t v;
          std::memcpy(&v, p, 4);
          return v;
        }
        default: {
          std::int64_t v;
          std::memcpy(&v, p, 8);
          return static_cast<double>(v);
        }
      }
    default:
      switch (f.size) {
        case 1:
          return static_cast<std::uint8_t>(*p);
        case 2: {
          std::uint16_t v;
          std::memcpy(&v, p, 2);
          return v;
        }
        case 4: {
          std::uint32_t v;
          std::memcpy(&v, p, 4);
          return v;
        }
        default: {
          std::uint64_t v;
          std::memcpy(&v, p, 8);
          return static_cast<double>(v);
        }
      }
  }
}

/// The packed 0x00RRGGBB colour of an rgb/rgba field element (bits of a float or an integer).
Rgb unpack_rgb(std::uint32_t bits) {
  return {static_cast<std::uint8_t>((bits >> 16) & 0xff), static_cast<std::uint8_t>((bits >> 8) & 0xff),
          static_cast<std::uint8_t>(bits & 0xff)};
}

// What each field element is (each element of a COUNT > 1 field is a scalar of its own).
struct FieldRoles {
  std::vector<std::vector<Role>> roles;        ///< per field, per element
  std::vector<std::vector<int>> scalar_index;  ///< per field, per element: into scalar_names, or -1
  std::vector<std::string> scalar_names;
  bool has_normals = false;
  bool has_colors = false;
  std::size_t elements = 0;
};

Role role_of(const std::string& name) {
  if (name == "_") return Role::skip;
  if (name == "x") return Role::x;
  if (name == "y") return Role::y;
  if (name == "z") return Role::z;
  if (name == "normal_x") return Role::nx;
  if (name == "normal_y") return Role::ny;
  if (name == "normal_z") return Role::nz;
  if (name == "rgb" || name == "rgba") return Role::rgb;
  return Role::scalar;
}

FieldRoles field_roles(const PcdHeader& h, const std::string& path) {
  FieldRoles fr;
  fr.roles.resize(h.fields.size());
  fr.scalar_index.resize(h.fields.size());
  bool seen[7] = {};
  for (std::size_t i = 0; i < h.fields.size(); ++i) {
    const auto& f = h.fields[i];
    const Role r = role_of(f.name);
    if (r != Role::scalar && r != Role::skip) {
      if (f.count != 1) fail(path, "field '{}' has COUNT {} (expected 1)", f.name, f.count);
      if (r == Role::rgb && f.size != 4)
        fail(path, "field '{}' has SIZE {} (a packed colour has 4 bytes)", f.name, f.size);
      seen[static_cast<int>(r) - 1] = true;
    }
    for (int k = 0; k < f.count; ++k) {
      fr.roles[i].push_back(r);
      if (r == Role::scalar) {
        fr.scalar_index[i].push_back(static_cast<int>(fr.scalar_names.size()));
        fr.scalar_names.push_back(f.count == 1 ? f.name : fmt::format("{}_{}", f.name, k));
      } else {
        fr.scalar_index[i].push_back(-1);
      }
    }
    fr.elements += static_cast<std::size_t>(f.count);
  }
  if (!seen[0] || !seen[1] || !seen[2]) fail(path, "the PCD file has no x, y and z fields");
  fr.has_normals = seen[3] || seen[4] || seen[5];
  if (fr.has_normals && !(seen[3] && seen[4] && seen[5]))
    fail(path, "the PCD file has only some of normal_x, normal_y, normal_z");
  fr.has_colors = seen[6];
  return fr;
}

// Collects the points one by one: `values` (per field element) and `rgb_bits` (per field) are filled
// by the reader of the data section, then `add` checks and keeps the point.
class PointSink {
 public:
  PointSink(const PcdHeader& h, const FieldRoles& fr, PointCloud& pc)
      : h_(h), fr_(fr), pc_(pc), values(fr.elements), rgb_bits(h.fields.size()), scalars_(fr.scalar_names.size()) {
    pc.positions.reserve(h.points);
    if (fr.has_normals) pc.normals.reserve(h.points);
    if (fr.has_colors) pc.colors.reserve(h.points);
    for (auto& s : scalars_) s.reserve(h.points);
  }

  // Point i from values/rgb_bits; `where(message)` throws the error with the position in the file.
  template <class Where>
  void add(std::size_t i, const Where& where) {
    Vec3 p = Vec3::Zero(), n = Vec3::Zero();
    Rgb c{0, 0, 0};
    std::size_t v = 0;
    for (std::size_t fi = 0; fi < h_.fields.size(); ++fi)
      for (std::size_t k = 0; k < fr_.roles[fi].size(); ++k, ++v) switch (fr_.roles[fi][k]) {
          case Role::x:
            p.x() = values[v];
            break;
          case Role::y:
            p.y() = values[v];
            break;
          case Role::z:
            p.z() = values[v];
            break;
          case Role::nx:
            n.x() = values[v];
            break;
          case Role::ny:
            n.y() = values[v];
            break;
          case Role::nz:
            n.z() = values[v];
            break;
          case Role::rgb:
            c = unpack_rgb(rgb_bits[fi]);
            break;
          default:
            break;
        }
    if (std::isnan(p.x()) && std::isnan(p.y()) && std::isnan(p.z())) {  // PCL's "no measurement"
      ++dropped;
      return;
    }
    static_assert(kMaxCoordinate == 1e12, "the messages below name the bound");
    if (!p.allFinite()) where(fmt::format("point {} has a non-finite coordinate", i));
    if (!within_coordinate_range(p)) where(fmt::format("point {} has a coordinate beyond ±1e12", i));
    if (fr_.has_normals && !(n.allFinite() && within_coordinate_range(n)))
      where(fmt::format("point {} has a non-finite normal or one beyond ±1e12", i));
    v = 0;
    for (std::size_t fi = 0; fi < h_.fields.size(); ++fi)
      for (std::size_t k = 0; k < fr_.roles[fi].size(); ++k, ++v)
        if (fr_.roles[fi][k] == Role::scalar) {
          if (!std::isfinite(values[v]))
            where(fmt::format("point {} has a non-finite value in field '{}'", i, h_.fields[fi].name));
          scalars_[static_cast<std::size_t>(fr_.scalar_index[fi][k])].push_back(values[v]);
        }
    pc_.positions.push_back(p);
    if (fr_.has_normals) pc_.normals.push_back(n);
    if (fr_.has_colors) pc_.colors.push_back(c);
  }

  void finish() {
    for (std::size_t s = 0; s < scalars_.size(); ++s) pc_.scalars.set(fr_.scalar_names[s], std::move(scalars_[s]));
  }

 private:
  const PcdHeader& h_;
  const FieldRoles& fr_;
  PointCloud& pc_;

 public:
  std::vector<double> values;
  std::vector<std::uint32_t> rgb_bits;
  std::size_t dropped = 0;

 private:
  std::vector<std::vector<double>> scalars_;
};

void read_ascii_points(const std::string& path, const std::string& bytes, const PcdHeader& h, const FieldRoles& fr,
                       PointSink& sink) {
  TextReader t(std::string_view(bytes).substr(h.body), path, '#', h.body_line);
  for (std::size_t i = 0; i < h.points; ++i) {
    if (!t.next_line()) t.fail("truncated: {} points declared, the data ends after {}", h.points, i);
    std::size_t v = 0;
    for (std::size_t fi = 0; fi < h.fields.size(); ++fi) {
      const auto& f = h.fields[fi];
      for (int k = 0; k < f.count; ++k, ++v) {
        const std::string_view tok = t.token_in_line();
        if (tok.empty()) t.fail("point {} ends before field '{}'", i, f.name);
        if (fr.roles[fi][static_cast<std::size_t>(k)] == Role::rgb) {
          // PCL writes a packed colour as the float with those bits (TYPE F) or as an integer (U).
          double d = t.number(tok, "a colour");
          std::uint32_t bits = 0;
          if (f.type == 'F') {
            const float fl = static_cast<float>(d);
            std::memcpy(&bits, &fl, 4);
          } else {
            if (!(d >= 0 && d <= 4294967295.0)) t.fail("colour '{}' out of range", TextReader::shorten(tok));
            bits = static_cast<std::uint32_t>(d);
          }
          sink.rgb_bits[fi] = bits;
          sink.values[v] = 0;
        } else {
          sink.values[v] = t.number(tok, "a value");
          // A 4-byte float field holds a float: the text is rounded as PCL (and the binary form) would.
          if (f.type == 'F' && f.size == 4) sink.values[v] = static_cast<float>(sink.values[v]);
        }
      }
    }
    if (!t.token_in_line().empty()) t.fail("point {} has more values than the {} fields", i, h.fields.size());
    sink.add(i, [&](const std::string& msg) { t.fail("{}", msg); });
  }
  if (t.next_line()) t.fail("unexpected data after the {} declared points", h.points);
}

void read_binary_points(const std::string& path, const std::string& bytes, const PcdHeader& h, const FieldRoles& fr,
                        PointSink& sink) {
  const char* base = bytes.data() + h.body;
  for (std::size_t i = 0; i < h.points; ++i) {
    const char* pt = base + i * h.point_size;
    std::size_t v = 0;
    for (std::size_t fi = 0; fi < h.fields.size(); ++fi) {
      const auto& f = h.fields[fi];
      for (int k = 0; k < f.count; ++k, ++v) {
        const char* e = pt + f.offset + static_cast<std::size_t>(k) * static_cast<std::size_t>(f.size);
        if (fr.roles[fi][static_cast<std::size_t>(k)] == Role::rgb) {
          std::memcpy(&sink.rgb_bits[fi], e, 4);
          sink.values[v] = 0;
        } else {
          sink.values[v] = decode(e, f);
        }
      }
    }
    sink.add(i, [&](const std::string& msg) { fail(path, "{}", msg); });
  }
  const std::size_t extra = bytes.size() - h.body - h.points * h.point_size;
  if (extra > 0)
    fail(path, "{} bytes of unexpected data after the {} declared points (wrong POINTS?)", extra, h.points);
}

}  // namespace

GeometryFile read_pcd(const std::string& path, const std::string& bytes) {
  static_assert(std::endian::native == std::endian::little, "PCD binary data is read as little endian");
  const PcdHeader h = read_header(path, bytes);
  GeometryFile g;
  g.format = "pcd " + h.data;
  const FieldRoles fr = field_roles(h, path);
  // Counts are checked against the bytes left before anything is allocated.
  const std::size_t left = bytes.size() - h.body;
  if (h.data == "binary") {
    if (h.point_size == 0 || h.points > left / h.point_size)
      fail(path, "truncated: POINTS {} of {} bytes need {} bytes of data, the file has {}", h.points, h.point_size,
           static_cast<double>(h.points) * static_cast<double>(h.point_size), left);
  } else if (h.points > left / 2 + 1) {
    fail(path, "POINTS {} is more than the {} bytes of data can hold", h.points, left);
  }
  if (h.points > 2147483647ULL) fail(path, "{} points: more than 2^31-1 points are not supported", h.points);
  PointSink sink(h, fr, g.vertices);
  if (h.data == "ascii")
    read_ascii_points(path, bytes, h, fr, sink);
  else
    read_binary_points(path, bytes, h, fr, sink);
  sink.finish();
  if (sink.dropped) g.format += fmt::format(" ({} points without a measurement dropped)", sink.dropped);
  return g;
}

void write_pcd(std::ostream& os, const PointCloud& cloud, const WriteOptions& o) {
  static_assert(std::endian::native == std::endian::little, "PCD binary data is written as little endian");
  const bool ascii = o.ascii;
  const int cs = o.double_coordinates ? 8 : 4;
  const int ss = o.double_scalars ? 8 : 4;
  std::string fields = "x y z", size = fmt::format("{0} {0} {0}", cs), type = "F F F", count = "1 1 1";
  if (cloud.has_normals()) {
    fields += " normal_x normal_y normal_z";
    size += fmt::format(" {0} {0} {0}", cs);
    type += " F F F";
    count += " 1 1 1";
  }
  if (cloud.has_colors()) {
    fields += " rgb";
    size += " 4";
    type += " U";
    count += " 1";
  }
  for (const auto& [name, col] : cloud.scalars.columns()) {
    fields += " " + name;
    size += fmt::format(" {}", ss);
    type += " F";
    count += " 1";
  }
  OutBuffer out(os);
  out.str() += fmt::format(
      "# .PCD v0.7 - Point Cloud Data file format (written by autoscan)\nVERSION 0.7\nFIELDS {}\nSIZE {}\nTYPE "
      "{}\nCOUNT {}\nWIDTH {}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {}\n",
      fields, size, type, count, cloud.size(), cloud.size(), ascii ? "ascii" : "binary");
  const auto put = [&](double v, int bytes) {
    if (ascii) {
      out.str() += bytes == 8 ? fmt::format("{} ", v) : fmt::format("{} ", static_cast<float>(v));
    } else if (bytes == 8) {
      out.put<double>(v, false);
    } else {
      out.put<float>(static_cast<float>(v), false);
    }
  };
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int k = 0; k < 3; ++k) put(cloud.positions[i][k], cs);
    if (cloud.has_normals())
      for (int k = 0; k < 3; ++k) put(cloud.normals[i][k], cs);
    if (cloud.has_colors()) {
      const auto& c = cloud.colors[i];
      const std::uint32_t bits = (std::uint32_t(c[0]) << 16) | (std::uint32_t(c[1]) << 8) | std::uint32_t(c[2]);
      if (ascii)
        out.str() += fmt::format("{} ", bits);
      else
        out.put<std::uint32_t>(bits, false);
    }
    for (const auto& [name, col] : cloud.scalars.columns()) put(col[i], ss);
    if (ascii) out.str().back() = '\n';
    out.maybe_flush();
  }
  out.flush();
}

}  // namespace autoscan::io::detail
