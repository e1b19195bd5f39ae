#pragma once
// Internal to the io module: file loading, a line-aware tokenizer for the text formats and an
// endian-aware byte reader for the binary ones. Every error is an InputError that starts with the
// file's path.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>

#include "autoscan/core/error.hpp"
#include "autoscan/io/mesh_io.hpp"

namespace autoscan::io::detail {

/// Throws InputError "<path>: <message>".
template <typename... Args>
[[noreturn]] void fail(const std::string& path, fmt::format_string<Args...> f, Args&&... args) {
  throw InputError(path + ": " + fmt::format(f, std::forward<Args>(args)...));
}

/// Reads a whole file. Throws InputError naming the path when it is missing, a directory, not a
/// regular file, unreadable or empty.
std::string load_file(const std::filesystem::path& path);

/// Throws InputError when `bytes` contains a NUL byte (a text format holding binary data).
void require_text(const std::string& path, std::string_view bytes, std::string_view format);

/// Parses the whole token as a double ("nan"/"inf" parse; callers check finiteness). A leading '+'
/// is accepted.
inline bool parse_double(std::string_view tok, double& v) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}

/// Parses the whole token as a signed integer.
inline bool parse_int(std::string_view tok, long long& v) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const auto r = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  return r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}

/// Whitespace-separated tokens of an in-memory text with line numbers (1-based). `comment`, when
/// not '\0', starts a comment that runs to the end of the line.
class TextReader {
 public:
  /// `first_line` is the file line number of the text's first line (for a body after a header).
  TextReader(std::string_view text, const std::string& path, char comment = '\0', std::size_t first_line = 1)
      : s_(text), path_(path), comment_(comment), line_(first_line) {}

  /// The next token on the current line; empty at the end of the line (or of the file).
  std::string_view token_in_line() {
    skip_blanks();
    if (pos_ >= s_.size() || s_[pos_] == '\n' || (comment_ && s_[pos_] == comment_)) return {};
    const std::size_t b = pos_;
    while (pos_ < s_.size() && !is_space(s_[pos_]) && !(comment_ && s_[pos_] == comment_)) ++pos_;
    return s_.substr(b, pos_ - b);
  }

  /// Moves to the start of the next line holding a token (skipping the rest of the current line,
  /// blank and comment-only lines). Returns false at the end of the file.
  bool next_line() {
    if (started_) skip_rest_of_line();
    started_ = true;
    for (;;) {
      skip_blanks();
      if (pos_ >= s_.size()) return false;
      if (s_[pos_] == '\n' || (comment_ && s_[pos_] == comment_)) {
        skip_rest_of_line();
        continue;
      }
      return true;
    }
  }

  /// The next token anywhere after the current position (crossing lines and comments); empty at
  /// the end of the file.
  std::string_view token() {
    started_ = true;
    for (;;) {
      skip_blanks();
      if (pos_ >= s_.size()) return {};
      if (s_[pos_] == '\n' || (comment_ && s_[pos_] == comment_)) {
        skip_rest_of_line();
        continue;
      }
      return token_in_line();
    }
  }

  /// Skips to just after the next '\n' (or to the end).
  void skip_rest_of_line() {
    while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
    if (pos_ < s_.size()) {
      ++pos_;
      ++line_;
    }
  }

  /// The line of the last token returned.
  std::size_t line() const { return line_; }
  std::size_t remaining_bytes() const { return s_.size() - pos_; }
  const std::string& path() const { return path_; }

  /// Throws InputError "<path>: line <n>: <message>".
  template <typename... Args>
  [[noreturn]] void fail(fmt::format_string<Args...> f, Args&&... args) const {
    throw InputError(fmt::format("{}: line {}: {}", path_, line_, fmt::format(f, std::forward<Args>(args)...)));
  }

  double number(std::string_view tok, std::string_view what) const {
    double v;
    if (tok.empty()) fail("expected {} but the line ends", what);
    if (!parse_double(tok, v)) fail("'{}' is not a number ({})", shorten(tok), what);
    return v;
  }
  long long integer(std::string_view tok, std::string_view what) const {
    long long v;
    if (tok.empty()) fail("expected {} but the line ends", what);
    if (!parse_int(tok, v)) fail("'{}' is not an integer ({})", shorten(tok), what);
    return v;
  }
  static std::string shorten(std::string_view tok) {
    std::string out;
    for (char c : tok.substr(0, 32))
      out += (static_cast<unsigned char>(c) >= 32 && static_cast<unsigned char>(c) < 127) ? c : '?';
    if (tok.size() > 32) out += "...";
    return out;
  }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
  void skip_blanks() {
    while (pos_ < s_.size() &&
           (s_[pos_] == ' ' || s_[pos_] == '\t' || s_[pos_] == '\r' || s_[pos_] == '\f' || s_[pos_] == '\v'))
      ++pos_;
  }

  std::string_view s_;
  const std::string& path_;
  char comment_;
  std::size_t line_ = 1;
  std::size_t pos_ = 0;
  bool started_ = false;
};

/// Reads fixed-size little- or big-endian values from memory; running past the end throws
/// InputError naming the file and `what_` (set by the caller to the element being read).
class ByteReader {
 public:
  ByteReader(std::string_view data, const std::string& path, bool big_endian)
      : p_(data.data()),
        end_(data.data() + data.size()),
        path_(path),
        swap_(big_endian != (std::endian::native == std::endian::big)) {}

  template <typename T>
  T read() {
    if (static_cast<std::size_t>(end_ - p_) < sizeof(T)) truncated();
    unsigned char b[sizeof(T)];
    std::memcpy(b, p_, sizeof(T));
    p_ += sizeof(T);
    if (swap_)
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
  }
  void skip(std::size_t n) {
    if (static_cast<std::size_t>(end_ - p_) < n) truncated();
    p_ += n;
  }
  std::size_t remaining() const { return static_cast<std::size_t>(end_ - p_); }
  /// Describes what is being read, for the "file ends inside ..." message.
  void set_context(std::string what) { what_ = std::move(what); }

 private:
  [[noreturn]] void truncated() const { fail(path_, "truncated: the file ends inside {}", what_); }
  const char* p_;
  const char* end_;
  const std::string& path_;
  bool swap_;
  std::string what_ = "the data";
};

// Format readers (one per file), each given the whole file.
GeometryFile read_ply(const std::string& path, const std::string& bytes);
GeometryFile read_obj(const std::string& path, const std::string& bytes);
GeometryFile read_off(const std::string& path, const std::string& bytes);
GeometryFile read_stl(const std::string& path, const std::string& bytes);
GeometryFile read_pcd(const std::string& path, const std::string& bytes);
/// .xyz (pts = false) or .pts (pts = true).
GeometryFile read_xyz(const std::string& path, const std::string& bytes, bool pts);

// Format writers (to a stream inside write_file_atomic).
/// The per-vertex data a PLY file holds (views into a mesh or a point cloud).
struct PlyVertexData {
  const std::vector<Vec3>& positions;
  const std::vector<Vec3>& normals;
  const std::vector<Rgb>& colors;
  const ScalarAttributes& scalars;
};
void write_ply(std::ostream& os, const PlyVertexData& v, const std::vector<Tri>& faces, const WriteOptions& o);
/// The material name a textured OBJ export uses (its MTL defines it with map_Kd).
inline constexpr const char* kObjMaterialName = "autoscan_texture";
/// Writes `mesh` as OBJ; a textured mesh with a non-empty `material_library` also gets `mtllib`,
/// `usemtl` and its corner UVs.
void write_obj(std::ostream& os, const TriangleMesh& mesh, const std::string& material_library = {});
void write_off(std::ostream& os, const TriangleMesh& mesh);
void write_stl(std::ostream& os, const TriangleMesh& mesh, bool ascii);
void write_pcd(std::ostream& os, const PointCloud& cloud, const WriteOptions& o);
void write_xyz(std::ostream& os, const PointCloud& cloud, bool pts);

/// Buffers output and hands it to the stream in large blocks.
class OutBuffer {
 public:
  explicit OutBuffer(std::ostream& os) : os_(os) { buf_.reserve(kBlock + 1024); }
  ~OutBuffer() = default;
  OutBuffer(const OutBuffer&) = delete;
  OutBuffer& operator=(const OutBuffer&) = delete;
  std::string& str() { return buf_; }
  template <typename T>
  void put(T v, bool big_endian) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_endian != (std::endian::native == std::endian::big))
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    buf_.append(reinterpret_cast<const char*>(b), sizeof(T));
  }
  void maybe_flush() {
    if (buf_.size() >= kBlock) flush();
  }
  void flush() {
    os_.write(buf_.data(), static_cast<std::streamsize>(buf_.size()));
    buf_.clear();
  }

 private:
  static constexpr std::size_t kBlock = 1 << 20;
  std::ostream& os_;
  std::string buf_;
};

/// Rounds a colour channel to 0..255 (NaN → 0; values are clamped before rounding).
inline std::uint8_t to_byte(double v) {
  if (!(v == v)) return 0;
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0)));
}

/// Appends a fan triangulation of `poly` (≥ 3 indices) to `faces`.
inline void fan_triangulate(const std::vector<int>& poly, std::vector<Tri>& faces) {
  for (std::size_t k = 1; k + 1 < poly.size(); ++k) faces.push_back({poly[0], poly[k], poly[k + 1]});
}

}  // namespace autoscan::io::detail
