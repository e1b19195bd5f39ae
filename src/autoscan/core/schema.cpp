// The JSON side of the options schema (schema.hpp, docs/options.md).
#include "autoscan/core/schema.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "autoscan/core/error.hpp"

namespace autoscan::schema::detail {

using nlohmann::json;

void make_object(json& j) { j = json::object(); }
json& put_object(json& obj, const char* key) {
  json& j = obj[key];
  j = json::object();
  return j;
}
void put(json& obj, const char* key, bool x) { obj[key] = x; }
void put(json& obj, const char* key, long long x) { obj[key] = x; }
void put(json& obj, const char* key, unsigned long long x) { obj[key] = x; }
void put(json& obj, const char* key, double x) { obj[key] = x; }
void put(json& obj, const char* key, const std::string& x) { obj[key] = x; }
void put(json& obj, const char* key, const std::vector<int>& x) { obj[key] = x; }
void put(json& obj, const char* key, const std::vector<double>& x) { obj[key] = x; }
void put(json& obj, const char* key, const json& x) { obj[key] = x; }
void put(json& obj, const char* key, const Eigen::Isometry3d& x) {
  json m = json::array();
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 4; ++k) m.push_back(x.matrix()(i, k));
  obj[key] = std::move(m);
}

namespace {
// A short rendering of a JSON value for messages (a whole object would flood them).
std::string brief(const json& v) {
  std::string s = v.dump();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return s;
}

std::string range_text(const Range& r) {
  const bool lo = std::isfinite(r.lo), hi = std::isfinite(r.hi);
  std::string s;
  if (lo && hi)
    s = fmt::format("in {}{:g}, {:g}{}", r.lo_open ? '(' : '[', r.lo, r.hi, r.hi_open ? ')' : ']');
  else if (lo)
    s = fmt::format("{} {:g}", r.lo_open ? ">" : ">=", r.lo);
  else if (hi)
    s = fmt::format("{} {:g}", r.hi_open ? "<" : "<=", r.hi);
  else
    s = "finite";
  return r.zero_too ? "0 or " + s : s;
}
}  // namespace

void require_object(const json& j, const std::string& where) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: expected a JSON object (got {})", where, brief(j));
}

const json* get(const json& obj, const char* key) {
  const auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

void refuse_unknown(const json& obj, const std::vector<const char*>& known, const std::string& what,
                    const std::string& path) {
  for (const auto& [k, v] : obj.items()) {
    bool ok = false;
    for (const char* n : known) ok = ok || k == n;
    if (ok) continue;
    std::string list;
    for (const char* n : known) list += (list.empty() ? "" : ", ") + std::string(n);
    if (path.empty()) throw InputError(fmt::format("{}: unknown option '{}' (known: {})", what, k, list));
    throw InputError(
        fmt::format("{}: {}: unknown option '{}' (known: {})", what, path.substr(0, path.size() - 1), k, list));
  }
}

bool read_bool(const json& v, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_boolean(), "{}: expected true or false (got {})", where, brief(v));
  return v.get<bool>();
}

long long read_signed(const json& v, long long lo, long long hi, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_number_integer(), "{}: expected an integer (got {})", where, brief(v));
  if (v.is_number_unsigned())
    AUTOSCAN_REQUIRE(v.get<unsigned long long>() <= static_cast<unsigned long long>(hi),
                     "{}: {} does not fit (at most {})", where, brief(v), hi);
  const long long x = v.get<long long>();
  AUTOSCAN_REQUIRE(x >= lo && x <= hi, "{}: {} does not fit (range [{}, {}])", where, x, lo, hi);
  return x;
}

unsigned long long read_unsigned(const json& v, unsigned long long hi, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_number_integer(), "{}: expected an integer (got {})", where, brief(v));
  AUTOSCAN_REQUIRE(v.is_number_unsigned() || v.get<long long>() >= 0, "{}: expected a non-negative integer (got {})",
                   where, brief(v));
  const auto x = v.get<unsigned long long>();
  AUTOSCAN_REQUIRE(x <= hi, "{}: {} does not fit (at most {})", where, x, hi);
  return x;
}

double read_double(const json& v, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_number(), "{}: expected a number (got {})", where, brief(v));
  return v.get<double>();
}

std::string read_string(const json& v, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_string(), "{}: expected a string (got {})", where, brief(v));
  return v.get<std::string>();
}

std::vector<int> read_int_list(const json& v, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_array(), "{}: expected an array of integers (got {})", where, brief(v));
  std::vector<int> out;
  for (std::size_t i = 0; i < v.size(); ++i)
    out.push_back(static_cast<int>(read_signed(v[i], std::numeric_limits<int>::min(), std::numeric_limits<int>::max(),
                                               fmt::format("{}[{}]", where, i))));
  return out;
}

std::vector<double> read_double_list(const json& v, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_array(), "{}: expected an array of numbers (got {})", where, brief(v));
  std::vector<double> out;
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(read_double(v[i], fmt::format("{}[{}]", where, i)));
  return out;
}

void read_object(const json& v, json& out, const std::string& where) {
  require_object(v, where);
  out = v;
}

Eigen::Isometry3d read_matrix(const json& v, const std::string& where) {
  AUTOSCAN_REQUIRE(v.is_array() && v.size() == 16, "{}: expected 16 numbers (a 4x4 row-major matrix)", where);
  Eigen::Matrix4d M;
  for (int i = 0; i < 16; ++i) {
    AUTOSCAN_REQUIRE(v[i].is_number(), "{}: entry {} is not a number", where, i);
    M(i / 4, i % 4) = v[i].get<double>();
  }
  AUTOSCAN_REQUIRE(M.allFinite(), "{}: non-finite entry", where);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix() = M;
  return T;
}

void unknown_enum(const std::string& name, const std::vector<const char*>& known, const std::string& where) {
  std::string list;
  for (const char* n : known) list += (list.empty() ? "" : ", ") + std::string(n);
  throw InputError(fmt::format("{}: unknown value '{}' (expected one of: {})", where, name, list));
}

void check_range(double x, const Range& r, const std::string& what, const std::string& path) {
  AUTOSCAN_REQUIRE(std::isfinite(x) && r.contains(x), "{}: {} must be {} (got {})", what, path, range_text(r), x);
}

void check_finite(const std::vector<double>& x, const Range& r, const std::string& what, const std::string& path) {
  for (std::size_t i = 0; i < x.size(); ++i) check_range(x[i], r, what, fmt::format("{}[{}]", path, i));
}

void check_list(const std::vector<int>& x, const Range& r, const std::string& what, const std::string& path) {
  for (std::size_t i = 0; i < x.size(); ++i) check_range(x[i], r, what, fmt::format("{}[{}]", path, i));
}

void check_matrix(const Eigen::Isometry3d& x, const std::string& what, const std::string& path) {
  AUTOSCAN_REQUIRE(x.matrix().allFinite(), "{}: {} has a non-finite entry", what, path);
}

}  // namespace autoscan::schema::detail
