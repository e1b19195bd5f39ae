// PLY reader and writer (ASCII, binary little endian, binary big endian).
// Reader: the "vertex" element gives positions (x y z, required), normals (nx ny nz), colours
// (red green blue) and every other scalar property as a named scalar; the "face" element's
// "vertex_indices" (or "vertex_index") list gives polygons, fan-triangulated. Every other element,
// list property or face property is skipped, in every encoding.
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_set>

#include "autoscan/io/detail_parse.hpp"

namespace autoscan::io::detail {
namespace {

enum class PlyType { i8, u8, i16, u16, i32, u32, f32, f64 };

std::optional<PlyType> parse_type(std::string_view t) {
  if (t == "char" || t == "int8") return PlyType::i8;
  if (t == "uchar" || t == "uint8") return PlyType::u8;
  if (t == "short" || t == "int16") return PlyType::i16;
  if (t == "ushort" || t == "uint16") return PlyType::u16;
  if (t == "int" || t == "int32") return PlyType::i32;
  if (t == "uint" || t == "uint32") return PlyType::u32;
  if (t == "float" || t == "float32") return PlyType::f32;
  if (t == "double" || t == "float64") return PlyType::f64;
  return std::nullopt;
}

std::size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::i8:
    case PlyType::u8:
      return 1;
    case PlyType::i16:
    case PlyType::u16:
      return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32:
      return 4;
    case PlyType::f64:
      return 8;
  }
  return 1;
}

bool is_float(PlyType t) { return t == PlyType::f32 || t == PlyType::f64; }

/// The range of values type `t` holds (a float's finite range for f32 and f64).
std::pair<double, double> type_range(PlyType t) {
  switch (t) {
    case PlyType::i8:
      return {-128.0, 127.0};
    case PlyType::u8:
      return {0.0, 255.0};
    case PlyType::i16:
      return {-32768.0, 32767.0};
    case PlyType::u16:
      return {0.0, 65535.0};
    case PlyType::i32:
      return {-2147483648.0, 2147483647.0};
    case PlyType::u32:
      return {0.0, 4294967295.0};
    case PlyType::f32:
      return {-std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
    case PlyType::f64:
      return {std::numeric_limits<double>::lowest(), std::numeric_limits<double>::max()};
  }
  return {0.0, 0.0};
}

/// At most this many properties in one file (over all elements) and this many elements: a header
/// beyond them is refused before any data is read (no real PLY comes near them).
constexpr std::size_t kMaxPlyProperties = 16384;
constexpr std::size_t kMaxPlyElements = 16384;

const char* type_name(PlyType t) {
  static const char* names[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"};
  return names[static_cast<int>(t)];
}

/// Where a vertex property's value goes.
enum class Sink { skip, x, y, z, nx, ny, nz, red, green, blue, scalar };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::f32;
  bool is_list = false;
  PlyType count_type = PlyType::u8;
  Sink sink = Sink::skip;
  std::size_t scalar = 0;     ///< column index when sink == scalar
  bool face_indices = false;  ///< the face element's vertex_indices list
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> props;
  std::size_t header_line = 0;
};

enum class Encoding { ascii, little, big };

struct PlyHeader {
  Encoding enc = Encoding::ascii;
  std::vector<PlyElement> elements;
  std::size_t body = 0;   ///< byte offset of the first data byte
  std::size_t lines = 0;  ///< header line count (the ASCII body starts on line lines + 1)
};

// A 'format' line's encoding (version 1.x only).
Encoding parse_format(const std::vector<std::string_view>& tok, const std::string& path, std::size_t line_no) {
  if (tok.size() != 3) fail(path, "line {}: malformed format line", line_no);
  Encoding enc = Encoding::ascii;
  if (tok[1] == "ascii")
    enc = Encoding::ascii;
  else if (tok[1] == "binary_little_endian")
    enc = Encoding::little;
  else if (tok[1] == "binary_big_endian")
    enc = Encoding::big;
  else
    fail(path, "line {}: unknown PLY format '{}' (expected ascii, binary_little_endian or binary_big_endian)", line_no,
         TextReader::shorten(tok[1]));
  if (tok[2].substr(0, 1) != "1")
    fail(path, "line {}: unsupported PLY version '{}'", line_no, TextReader::shorten(tok[2]));
  return enc;
}

// A 'property' line: 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'.
PlyProperty parse_property(const std::vector<std::string_view>& tok, std::string_view line, const std::string& path,
                           std::size_t line_no) {
  PlyProperty prop;
  if (tok.size() >= 2 && tok[1] == "list") {
    if (tok.size() != 5)
      fail(path, "line {}: malformed list property (expected 'property list COUNT_TYPE TYPE NAME')", line_no);
    const auto ct = parse_type(tok[2]);
    const auto it = parse_type(tok[3]);
    if (!ct || !it) fail(path, "line {}: unknown property type in list '{}'", line_no, TextReader::shorten(line));
    if (is_float(*ct)) fail(path, "line {}: a list count type must be an integer type", line_no);
    prop.is_list = true;
    prop.count_type = *ct;
    prop.type = *it;
    prop.name = std::string(tok[4]);
  } else {
    if (tok.size() != 3) fail(path, "line {}: malformed property line (expected 'property TYPE NAME')", line_no);
    const auto t = parse_type(tok[1]);
    if (!t) fail(path, "line {}: unknown property type '{}'", line_no, TextReader::shorten(tok[1]));
    prop.type = *t;
    prop.name = std::string(tok[2]);
  }
  return prop;
}

PlyHeader parse_header(const std::string& path, const std::string& bytes) {
  PlyHeader h;
  std::size_t pos = 0, line_no = 0;
  bool have_format = false, have_end = false;
  auto next_line = [&](std::string_view& line) {
    if (pos >= bytes.size()) return false;
    std::size_t e = bytes.find('\n', pos);
    if (e == std::string::npos) e = bytes.size();
    line = std::string_view(bytes).substr(pos, e - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = std::min(e + 1, bytes.size());
    ++line_no;
    return true;
  };
  std::string_view line;
  if (!next_line(line) || line != "ply") fail(path, "not a PLY file (the first line is not 'ply')");
  // Names seen so far (views into `bytes`), so that duplicate checks stay linear in the header.
  std::unordered_set<std::string_view> element_names, property_names;
  std::size_t properties = 0;
  while (next_line(line)) {
    for (char c : line) {
      const auto u = static_cast<unsigned char>(c);
      if ((u < 32 && c != '\t') || u == 127)
        fail(path, "line {}: the PLY header contains binary data (corrupt header or missing 'end_header')", line_no);
    }
    std::vector<std::string_view> tok;
    for (std::size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      std::size_t b = i;
      while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
      if (i > b) tok.push_back(line.substr(b, i - b));
    }
    if (tok.empty()) continue;
    const auto kw = tok[0];
    if (kw == "comment" || kw == "obj_info") continue;
    if (kw == "end_header") {
      have_end = true;
      break;
    }
    if (kw == "format") {
      h.enc = parse_format(tok, path, line_no);
      have_format = true;
    } else if (kw == "element") {
      if (tok.size() != 3) fail(path, "line {}: malformed element line (expected 'element NAME COUNT')", line_no);
      long long c;
      if (!parse_int(tok[2], c) || c < 0)
        fail(path, "line {}: element '{}' has an invalid count '{}'", line_no, TextReader::shorten(tok[1]),
             TextReader::shorten(tok[2]));
      if (!element_names.insert(tok[1]).second)
        fail(path, "line {}: element '{}' is declared twice", line_no, TextReader::shorten(tok[1]));
      if (h.elements.size() >= kMaxPlyElements)
        fail(path, "line {}: more than {} elements in the PLY header (corrupt header?)", line_no, kMaxPlyElements);
      h.elements.push_back({std::string(tok[1]), static_cast<std::uint64_t>(c), {}, line_no});
      property_names.clear();
    } else if (kw == "property") {
      if (h.elements.empty()) fail(path, "line {}: property declared before any element", line_no);
      PlyProperty prop = parse_property(tok, line, path, line_no);
      if (!property_names.insert(tok.back()).second)
        fail(path, "line {}: property '{}' is declared twice in element '{}'", line_no, TextReader::shorten(tok.back()),
             h.elements.back().name);
      if (++properties > kMaxPlyProperties)
        fail(path, "line {}: more than {} properties in the PLY header (corrupt header?)", line_no, kMaxPlyProperties);
      h.elements.back().props.push_back(std::move(prop));
    } else {
      fail(path, "line {}: unknown PLY header keyword '{}'", line_no, TextReader::shorten(kw));
    }
  }
  if (!have_end) fail(path, "the PLY header has no 'end_header' line (truncated or not a PLY file)");
  if (!have_format) fail(path, "the PLY header has no 'format' line");
  h.body = pos;
  h.lines = line_no;
  return h;
}

/// Converts a colour channel to 0..255: integer types as they are, float types from [0, 1].
std::uint8_t to_channel(double v, PlyType t) { return to_byte(is_float(t) ? v * 255.0 : v); }

/// Holds the parsed vertex attributes while reading.
struct VertexSinks {
  std::vector<Vec3>& pos;
  std::vector<Vec3>& nrm;
  std::vector<Rgb>& col;
  std::vector<std::vector<double>*> scalars;
  bool has_normals = false;
  bool has_colors = false;
  Vec3 p = Vec3::Zero(), n = Vec3::Zero();
  Rgb c{0, 0, 0};

  void put(const PlyProperty& prop, double v) {
    switch (prop.sink) {
      case Sink::x:
        p.x() = v;
        break;
      case Sink::y:
        p.y() = v;
        break;
      case Sink::z:
        p.z() = v;
        break;
      case Sink::nx:
        n.x() = v;
        break;
      case Sink::ny:
        n.y() = v;
        break;
      case Sink::nz:
        n.z() = v;
        break;
      case Sink::red:
        c[0] = to_channel(v, prop.type);
        break;
      case Sink::green:
        c[1] = to_channel(v, prop.type);
        break;
      case Sink::blue:
        c[2] = to_channel(v, prop.type);
        break;
      case Sink::scalar:
        scalars[prop.scalar]->push_back(v);
        break;
      case Sink::skip:
        break;
    }
  }
  /// Ends vertex `i`; returns a message when it is invalid.
  const char* finish() {
    static_assert(kMaxCoordinate == 1e12, "the messages below name the bound");
    pos.push_back(p);
    if (has_normals) nrm.push_back(n);
    if (has_colors) col.push_back(c);
    if (!p.allFinite()) return "has a non-finite coordinate (NaN or Inf)";
    if (has_normals && !n.allFinite()) return "has a non-finite normal (NaN or Inf)";
    if (!within_coordinate_range(p)) return "has a coordinate beyond ±1e12, the largest supported magnitude";
    if (has_normals && !within_coordinate_range(n)) return "has a normal component beyond ±1e12";
    return nullptr;
  }
};

double read_binary(ByteReader& r, PlyType t) {
  switch (t) {
    case PlyType::i8:
      return r.read<std::int8_t>();
    case PlyType::u8:
      return r.read<std::uint8_t>();
    case PlyType::i16:
      return r.read<std::int16_t>();
    case PlyType::u16:
      return r.read<std::uint16_t>();
    case PlyType::i32:
      return r.read<std::int32_t>();
    case PlyType::u32:
      return r.read<std::uint32_t>();
    case PlyType::f32:
      return r.read<float>();
    case PlyType::f64:
      return r.read<double>();
  }
  return 0;
}

/// The next ASCII value: a number of `type` (finite, within the type's range), or InputError naming
/// the line, the element, the item and the property.
double read_ascii(TextReader& t, PlyType type, const PlyElement& e, std::uint64_t item, const std::string& prop) {
  const auto tok = t.token();
  if (tok.empty())
    t.fail("truncated: the file ends inside element '{}' item {} of {} (property '{}')", e.name, item, e.count, prop);
  double v;
  if (is_float(type)) {
    if (!parse_double(tok, v)) {
      // from_chars reports a value beyond double's range (1e999) as an error, not as inf.
      const auto r = std::from_chars(tok.data() + (tok.front() == '+'), tok.data() + tok.size(), v);
      if (r.ec == std::errc::result_out_of_range && r.ptr == tok.data() + tok.size())
        t.fail("'{}' overflows the property's type {} (element '{}' item {}, property '{}')", TextReader::shorten(tok),
               type_name(type), e.name, item, prop);
      t.fail("'{}' is not a number (element '{}' item {}, property '{}')", TextReader::shorten(tok), e.name, item,
             prop);
    }
    if (!std::isfinite(v))
      t.fail("non-finite value '{}' (element '{}' item {}, property '{}')", TextReader::shorten(tok), e.name, item,
             prop);
  } else {
    long long i;
    if (parse_int(tok, i)) {
      v = static_cast<double>(i);
    } else if (!(parse_double(tok, v) && std::isfinite(v) && v == std::floor(v))) {
      // Integral values written with a decimal point ("3.0") are tolerated; nothing else.
      t.fail("'{}' is not an integer (element '{}' item {}, property '{}' of type {})", TextReader::shorten(tok),
             e.name, item, prop, type_name(type));
    }
  }
  const auto [lo, hi] = type_range(type);
  if (v < lo || v > hi)
    t.fail("'{}' overflows the property's type {} (element '{}' item {}, property '{}')", TextReader::shorten(tok),
           type_name(type), e.name, item, prop);
  return v;
}

}  // namespace

namespace {

// Decides where each vertex property goes: x y z (required), nx ny nz and red green blue (when all
// three are there), every other non-list property a named scalar column of pc.
void assign_vertex_sinks(PlyElement& vertex, PointCloud& pc, const std::string& path) {
  auto find = [&](const char* n) -> PlyProperty* {
    for (auto& p : vertex.props)
      if (p.name == n && !p.is_list) return &p;
    return nullptr;
  };
  const char* xyz[] = {"x", "y", "z"};
  for (const char* n : xyz)
    if (!find(n)) fail(path, "line {}: the vertex element has no '{}' property", vertex.header_line, n);
  find("x")->sink = Sink::x;
  find("y")->sink = Sink::y;
  find("z")->sink = Sink::z;
  if (find("nx") && find("ny") && find("nz")) {
    find("nx")->sink = Sink::nx;
    find("ny")->sink = Sink::ny;
    find("nz")->sink = Sink::nz;
  }
  if (find("red") && find("green") && find("blue")) {
    find("red")->sink = Sink::red;
    find("green")->sink = Sink::green;
    find("blue")->sink = Sink::blue;
  }
  // The header has no duplicate names, so columns are appended without a (linear) lookup each.
  for (auto& p : vertex.props) {
    if (p.is_list || p.sink != Sink::skip) continue;
    p.sink = Sink::scalar;
    p.scalar = pc.scalars.size();
    pc.scalars.columns().emplace_back(p.name, std::vector<double>{});
  }
}

// The face element's integer 'vertex_indices' (or 'vertex_index') list.
void mark_face_indices(PlyElement& face, const std::string& path) {
  for (auto& p : face.props)
    if (p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index") && !is_float(p.type)) {
      p.face_indices = true;
      break;
    }
  bool found = false;
  for (const auto& p : face.props) found = found || p.face_indices;
  if (!found && face.count > 0)
    fail(path, "line {}: the face element has no integer 'vertex_indices' list property", face.header_line);
}

// Refuses counts the file cannot hold before anything is allocated: each item takes at least its
// fixed-size properties plus one count per list (binary) or two bytes per property (ASCII).
void check_counts_fit(const PlyHeader& h, std::size_t data_bytes, const std::string& path) {
  long double need = 0;
  for (const auto& e : h.elements) {
    std::size_t min_item = 0;
    for (const auto& p : e.props)
      min_item += h.enc == Encoding::ascii ? 2 : (p.is_list ? type_size(p.count_type) : type_size(p.type));
    need += static_cast<long double>(e.count) * static_cast<long double>(min_item);
    if (need > static_cast<long double>(data_bytes) + 1)
      fail(path,
           "line {}: element '{}' claims {} items but only {} bytes of data follow the header (truncated file or "
           "corrupt count)",
           e.header_line, e.name, e.count, data_bytes);
  }
}

// Reads the data section (ASCII or binary) into g: the vertex element's properties through the sinks,
// the face element's index lists fan-triangulated; every other element skipped.
class PlyBodyReader {
 public:
  PlyBodyReader(const std::string& path, const std::string& bytes, const PlyHeader& h, const PlyElement* vertex,
                GeometryFile& g)
      : path_(path),
        bytes_(bytes),
        h_(h),
        vertex_(vertex),
        g_(g),
        nv_(vertex->count),
        sinks_{g.vertices.positions, g.vertices.normals, g.vertices.colors, {}} {
    PointCloud& pc = g.vertices;
    pc.positions.reserve(nv_);
    for (const auto& p : vertex->props) {
      if (p.sink == Sink::nx) sinks_.has_normals = true;
      if (p.sink == Sink::red) sinks_.has_colors = true;
    }
    if (sinks_.has_normals) pc.normals.reserve(nv_);
    if (sinks_.has_colors) pc.colors.reserve(nv_);
    for (auto& [name, col] : pc.scalars.columns()) {
      col.reserve(nv_);
      sinks_.scalars.push_back(&col);
    }
  }

  void read() {
    if (h_.enc == Encoding::ascii)
      read_ascii_body();
    else
      read_binary_body();
  }

 private:
  template <class Where>
  void add_polygon(std::uint64_t item, const Where& where) {
    if (poly_.size() < 3) where(fmt::format("face {} has {} vertices (a face needs at least 3)", item, poly_.size()));
    for (int v : poly_)
      if (v < 0 || static_cast<std::uint64_t>(v) >= nv_)
        where(fmt::format("face {} references vertex {} but there are {} vertices (index out of range)", item, v, nv_));
    fan_triangulate(poly_, g_.faces);
    ++g_.polygons;
  }
  void read_ascii_body();
  void read_binary_body();

  const std::string& path_;
  const std::string& bytes_;
  const PlyHeader& h_;
  const PlyElement* vertex_;
  GeometryFile& g_;
  std::uint64_t nv_;
  VertexSinks sinks_;
  std::vector<int> poly_;
};

void PlyBodyReader::read_ascii_body() {
  // Line numbers continue from the header.
  TextReader t(std::string_view(bytes_).substr(h_.body), path_, '\0', h_.lines + 1);
  auto where_line = [&](const std::string& msg) { t.fail("{}", msg); };
  for (const auto& e : h_.elements) {
    for (std::uint64_t i = 0; i < e.count; ++i) {
      for (const auto& p : e.props) {
        if (p.is_list) {
          const double c = read_ascii(t, p.count_type, e, i, p.name);
          if (c < 0 || c > static_cast<double>(t.remaining_bytes()))
            where_line(fmt::format("element '{}' item {}: invalid list length {}", e.name, i, c));
          const auto len = static_cast<std::size_t>(c);
          if (p.face_indices) poly_.clear();
          for (std::size_t k = 0; k < len; ++k) {
            const double v = read_ascii(t, p.type, e, i, p.name);
            if (p.face_indices) poly_.push_back(v < -2147483648.0 || v > 2147483647.0 ? -1 : static_cast<int>(v));
          }
          if (p.face_indices) add_polygon(i, where_line);
        } else {
          const double v = read_ascii(t, p.type, e, i, p.name);
          if (&e == vertex_) sinks_.put(p, v);
        }
      }
      if (&e == vertex_)
        if (const char* msg = sinks_.finish()) where_line(fmt::format("vertex {} {}", i, msg));
    }
  }
  if (!t.token().empty())
    where_line("unexpected data after the last element (the element counts in the header are wrong?)");
}

void PlyBodyReader::read_binary_body() {
  const std::string& path = path_;
  ByteReader r(std::string_view(bytes_).substr(h_.body), path, h_.enc == Encoding::big);
  auto where_bin = [&](const std::string& msg) { fail(path, "{}", msg); };
  for (const auto& e : h_.elements) {
    r.set_context(fmt::format("element '{}' (header says {} items)", e.name, e.count));
    const bool is_vertex = &e == vertex_;
    for (std::uint64_t i = 0; i < e.count; ++i) {
      for (const auto& p : e.props) {
        if (p.is_list) {
          const double c = read_binary(r, p.count_type);
          if (c < 0 || c * static_cast<double>(type_size(p.type)) > static_cast<double>(r.remaining()))
            fail(path, "truncated or corrupt: element '{}' item {} has a list of {} values", e.name, i, c);
          const auto len = static_cast<std::size_t>(c);
          if (p.face_indices) {
            poly_.clear();
            for (std::size_t k = 0; k < len; ++k) {
              const double v = read_binary(r, p.type);
              poly_.push_back(v < -2147483648.0 || v > 2147483647.0 ? -1 : static_cast<int>(v));
            }
            add_polygon(i, where_bin);
          } else {
            r.skip(len * type_size(p.type));
          }
        } else if (is_vertex) {
          const double v = read_binary(r, p.type);
          if (!std::isfinite(v))
            fail(path, "vertex {} has a non-finite value (NaN or Inf) in property '{}'", i, p.name);
          sinks_.put(p, v);
        } else {
          r.skip(type_size(p.type));
        }
      }
      if (is_vertex)
        if (const char* msg = sinks_.finish()) fail(path, "vertex {} {}", i, msg);
    }
  }
  if (r.remaining() > 0)
    fail(path, "{} bytes of unexpected data after the last element (the element counts in the header are wrong?)",
         r.remaining());
}

}  // namespace

GeometryFile read_ply(const std::string& path, const std::string& bytes) {
  PlyHeader h = parse_header(path, bytes);
  GeometryFile g;
  g.format = h.enc == Encoding::ascii    ? "ply ascii"
             : h.enc == Encoding::little ? "ply binary_little_endian"
                                         : "ply binary_big_endian";
  // Locate the vertex and face elements and decide where each property goes.
  PlyElement* vertex = nullptr;
  PlyElement* face = nullptr;
  for (auto& e : h.elements) {
    if (e.props.empty() && e.count > 0)
      fail(path, "line {}: element '{}' has {} items but no properties", e.header_line, e.name, e.count);
    if (e.name == "vertex") vertex = &e;
    if (e.name == "face") face = &e;
  }
  if (!vertex) fail(path, "the PLY header declares no 'vertex' element");
  assign_vertex_sinks(*vertex, g.vertices, path);
  if (face) mark_face_indices(*face, path);
  check_counts_fit(h, bytes.size() - h.body, path);
  if (vertex->count > 2147483647ULL)
    fail(path, "{} vertices: more than 2^31-1 vertices are not supported", vertex->count);
  if (face) g.faces.reserve(face->count);
  PlyBodyReader(path, bytes, h, vertex, g).read();
  return g;
}

void write_ply(std::ostream& os, const PlyVertexData& v, const std::vector<Tri>& faces, const WriteOptions& o) {
  const bool binary = !o.ascii;
  const bool big = o.big_endian;
  const char* coord_type = o.double_coordinates ? "double" : "float";
  OutBuffer out(os);
  std::string& s = out.str();
  s += "ply\n";
  s += binary ? (big ? "format binary_big_endian 1.0\n" : "format binary_little_endian 1.0\n") : "format ascii 1.0\n";
  s += "comment written by autoscan\n";
  s += fmt::format("element vertex {}\n", v.positions.size());
  for (const char* c : {"x", "y", "z"}) s += fmt::format("property {} {}\n", coord_type, c);
  const bool normals = !v.normals.empty(), colors = !v.colors.empty();
  if (normals)
    for (const char* c : {"nx", "ny", "nz"}) s += fmt::format("property {} {}\n", coord_type, c);
  if (colors)
    for (const char* c : {"red", "green", "blue"}) s += fmt::format("property uchar {}\n", c);
  // A column holding a value beyond float's range is written as double whatever the options say:
  // as float it would hold inf, which no reader accepts (found by fuzzing, docs/reliability.md).
  std::vector<const std::vector<double>*> cols;
  std::vector<char> col_double;
  for (const auto& [name, col] : v.scalars.columns()) {
    const bool dbl = o.double_scalars || std::any_of(col.begin(), col.end(), [](double x) {
                       return std::abs(x) > static_cast<double>(std::numeric_limits<float>::max());
                     });
    s += fmt::format("property {} {}\n", dbl ? "double" : "float", name);
    cols.push_back(&col);
    col_double.push_back(dbl ? 1 : 0);
  }
  if (!faces.empty()) {
    s += fmt::format("element face {}\n", faces.size());
    s += "property list uchar int vertex_indices\n";
  }
  s += "end_header\n";

  if (binary) {
    auto real = [&](double x, bool dbl) {
      if (dbl)
        out.put<double>(x, big);
      else
        out.put<float>(static_cast<float>(x), big);
    };
    for (std::size_t i = 0; i < v.positions.size(); ++i) {
      for (int k = 0; k < 3; ++k) real(v.positions[i][k], o.double_coordinates);
      if (normals)
        for (int k = 0; k < 3; ++k) real(v.normals[i][k], o.double_coordinates);
      if (colors)
        for (int k = 0; k < 3; ++k) out.put<std::uint8_t>(v.colors[i][k], big);
      for (std::size_t c = 0; c < cols.size(); ++c) real((*cols[c])[i], col_double[c] != 0);
      out.maybe_flush();
    }
    for (const auto& f : faces) {
      out.put<std::uint8_t>(3, big);
      for (int k = 0; k < 3; ++k) out.put<std::int32_t>(f[k], big);
      out.maybe_flush();
    }
  } else {
    auto it = std::back_inserter(s);
    auto real = [&](double x, bool dbl) {
      if (dbl)
        fmt::format_to(it, " {}", x);
      else
        fmt::format_to(it, " {}", static_cast<float>(x));
    };
    for (std::size_t i = 0; i < v.positions.size(); ++i) {
      if (o.double_coordinates)
        fmt::format_to(it, "{}", v.positions[i][0]);
      else
        fmt::format_to(it, "{}", static_cast<float>(v.positions[i][0]));
      for (int k = 1; k < 3; ++k) real(v.positions[i][k], o.double_coordinates);
      if (normals)
        for (int k = 0; k < 3; ++k) real(v.normals[i][k], o.double_coordinates);
      if (colors) fmt::format_to(it, " {} {} {}", v.colors[i][0], v.colors[i][1], v.colors[i][2]);
      for (std::size_t c = 0; c < cols.size(); ++c) real((*cols[c])[i], col_double[c] != 0);
      s += '\n';
      out.maybe_flush();
    }
    for (const auto& f : faces) {
      fmt::format_to(it, "3 {} {} {}\n", f[0], f[1], f[2]);
      out.maybe_flush();
    }
  }
  out.flush();
}

}  // namespace autoscan::io::detail
